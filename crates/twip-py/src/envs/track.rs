//! `twip/Track-v0`'s native batch.
use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use twip_core::control::trajectory::Trajectory;
use twip_core::envs::{TrackEnvs, TrackReward, TrackSpec, TRACK_OBS};
use twip_core::sweep::planar::validate;

use super::{batch_class, filled_rows, realism_for, rows, rows_array, NextStep, KEPT_REFRESH};
use crate::control::trajectory::trajectory;
use crate::convert::{int, ints, Int, Real};
use crate::errors::PyTwipError;
use crate::hardware::realism::PyRealism;
use crate::model::models::PyPlanarModel;
use crate::sweep::planar::nominal;
use crate::sweep::{parse_perturbations, PerturbTuple};

batch_class! {
    /// N tracking robots on one path, each keyed (seed, episode); `twip.envs` wraps it.
    PyTrackBatch, "TrackBatch", TrackEnvs, 7, TRACK_OBS, |envs: &TrackEnvs, l| envs.observation(l)
}

#[pymethods]
impl PyTrackBatch {
    #[new]
    #[pyo3(signature = (model, path, x0, perturbations, num_envs, dt, substeps, fall_limit, realism = None, threads = 0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        model: &PyPlanarModel,
        path: &Bound<'_, PyAny>,
        x0: &Bound<'_, PyAny>,
        perturbations: Vec<PerturbTuple>,
        num_envs: Int<usize>,
        dt: Real,
        substeps: Int<usize>,
        fall_limit: Real,
        realism: Option<&PyRealism>,
        #[pyo3(from_py_with = int::<usize>)] threads: usize,
    ) -> PyResult<Self> {
        let (dt, fall_limit) = (dt.0, fall_limit.0);
        let (num_envs, substeps) = (num_envs.0, substeps.0);
        let path: Trajectory<f64> = trajectory(path)?;
        let nominal = nominal(model, x0)?;
        let perturbations = parse_perturbations(&perturbations, validate)?;
        let spec = TrackSpec { nominal, perturbations, realism: realism_for(realism), path, dt, substeps, fall_limit };
        let inner = py.detach(|| TrackEnvs::new(spec, num_envs, threads)).map_err(PyTwipError)?;
        Ok(Self::wrap(inner))
    }

    /// One step under Gymnasium's NEXT_STEP autoreset, in one trip to the threads: every
    /// robot steps under `actions` (robot after robot), the rewards are `rewards`' with these
    /// weights, then the lanes `reset` (done at the last step) start their next episode.
    /// Returns which fell, the rewards, and the true states and observations after the
    /// restarts.
    /// `weights`: (alive, upright, tracking, heading, effort).
    fn step_next<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray1<'py, f64>,
        reset: Vec<Int<usize>>,
        weights: (Real, Real, Real, Real, Real),
        bound: Real,
    ) -> PyResult<NextStep<'py>> {
        let (Real(alive), Real(upright), Real(tracking), Real(heading), Real(effort)) = weights;
        let (bound, reset) = (bound.0, ints(reset));
        let weights = TrackReward { alive, upright, tracking, heading, effort };
        let n = self.hold_actions(actions)?;
        let (mut rewards, mut states, mut observations) = (vec![0.0; n], vec![0.0; 7 * n], vec![0.0; TRACK_OBS * n]);
        let (inner, actions, fell) = (&mut self.inner, &self.actions, &mut self.fell);
        py.detach(|| {
            inner.in_one_trip(|envs| {
                envs.step(actions, fell)?;
                envs.rows_into(&mut observations, |envs, l| envs.true_observation(l))?;
                weights.rewards_into(&observations, actions, bound, &mut rewards)?;
                envs.reset_many(&reset, None)?;
                envs.rows_into(&mut states, |envs, l| envs.state(l).data.0[0])?;
                if envs.has_rig() || reset.len() > KEPT_REFRESH {
                    envs.rows_into(&mut observations, |envs, l| envs.observation(l))
                } else {
                    // On the ideal plant the true observations are the observations: those
                    // of the lanes started anew made again.
                    for &l in &reset {
                        observations[TRACK_OBS * l..TRACK_OBS * (l + 1)].copy_from_slice(&envs.observation(l));
                    }
                    Ok(())
                }
            })
        })
        .map_err(PyTwipError)?;
        Ok((PyArray1::from_slice(py, &self.fell), PyArray1::from_vec(py, rewards), rows_array::<7>(py, n, states), rows_array::<TRACK_OBS>(py, n, observations)))
    }

    /// Every robot's observation (num_envs x 9): path error in its frame, pitch, speeds,
    /// the reference's speeds.
    fn observations<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.inner.len();
        if let Some(kept) = self.kept.take() {
            return Ok(rows_array::<TRACK_OBS>(py, n, kept));
        }
        let inner = &self.inner;
        rows::<TRACK_OBS>(py, n, |out| inner.rows_into(out, |envs, l| envs.observation(l)))
    }

    /// The observations the true states give (num_envs x 9): on the ideal plant, the
    /// observations.
    fn true_observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(rows_array::<TRACK_OBS>(py, self.inner.len(), self.true_rows(py)?))
    }

    /// Every robot's reward (num_envs) for the step just taken under `actions`
    /// (num_envs x 2): the default terms with these weights on the true observations
    /// (`true_observations`, made here), each action over `bound`, with the bits of the
    /// formula in NumPy (`twip.envs.track.TrackSettings.reward_terms`).
    #[allow(clippy::too_many_arguments)]
    fn rewards<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f64>,
        alive: Real,
        upright: Real,
        tracking: Real,
        heading: Real,
        effort: Real,
        bound: Real,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let weights = TrackReward { alive: alive.0, upright: upright.0, tracking: tracking.0, heading: heading.0, effort: effort.0 };
        let bound = bound.0;
        let o = self.true_rows(py)?;
        let mut out = vec![0.0; self.inner.len()];
        let shape = actions.shape().to_vec();
        let actions = actions.as_slice().map_err(|_| PyTwipError(twip_core::TwipError::Shape { name: "actions", expected: (out.len(), 2), got: (shape[0], shape[1]) }))?;
        weights.rewards_into(&o, actions, bound, &mut out).map_err(PyTwipError)?;
        if !self.inner.has_rig() {
            // On the ideal plant these are the observations: `observations` hands them out.
            self.kept = Some(o);
        }
        Ok(PyArray1::from_vec(py, out))
    }
}

impl PyTrackBatch {
    /// Every robot's observation as its true state gives it, made on the batch's threads.
    fn true_rows(&self, py: Python<'_>) -> PyResult<Vec<f64>> {
        let inner = &self.inner;
        filled_rows::<TRACK_OBS>(py, inner.len(), |out| inner.rows_into(out, |envs, l| envs.true_observation(l)))
    }
}
