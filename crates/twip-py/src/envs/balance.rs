//! `twip/Balance-v0`'s native batch.
use numpy::{PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;
use twip_core::envs::{BalanceEnvs, BalanceReward, BalanceSpec};
use twip_core::sweep::{Nominal, Perturbation};

use super::{batch_class, realism_for, rows, rows_array, NextStep, KEPT_REFRESH};

use crate::convert::{int, ints, vector, Int, Real};
use crate::errors::PyTwipError;
use crate::hardware::realism::PyRealism;
use crate::model::models::PySlopeModel;
use crate::sweep::{no_friction_in_sweeps, parse_perturbations, PerturbTuple};

batch_class! {
    /// N balancing robots, each keyed (seed, episode); `twip.envs` wraps it.
    PyBalanceBatch, "BalanceBatch", BalanceEnvs, 4, 4, |envs: &BalanceEnvs, l| envs.observation(l).into()
}

#[pymethods]
impl PyBalanceBatch {
    #[new]
    #[pyo3(signature = (model, x0, perturbations, num_envs, dt, substeps, fall_limit, realism = None, threads = 0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        model: &PySlopeModel,
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
        no_friction_in_sweeps(model.inner.friction().is_some())?;
        let nominal = Nominal { params: *model.inner.params(), slope: model.inner.slope(), x0: vector::<4>("x0", x0)? };
        let perturbations = parse_perturbations(&perturbations, Perturbation::validate)?;
        let spec = BalanceSpec { nominal, perturbations, realism: realism_for(realism), dt, substeps, fall_limit };
        let inner = py.detach(|| BalanceEnvs::new(spec, num_envs, threads)).map_err(PyTwipError)?;
        Ok(Self::wrap(inner))
    }

    /// One step under Gymnasium's NEXT_STEP autoreset, in one trip to the threads: every
    /// robot steps under `actions`, the rewards are the default terms with these weights on
    /// the true states after it (`twip.envs.balance.BalanceSettings.rewards`' bits), then the
    /// lanes `reset` (done at the last step) start their next episode. Returns which fell,
    /// the rewards, and the true states and observations after the restarts.
    /// `weights`: (alive, upright, tracking, effort).
    fn step_next<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray1<'py, f64>,
        reset: Vec<Int<usize>>,
        weights: (Real, Real, Real, Real),
        speed_ref: Real,
        bound: Real,
    ) -> PyResult<NextStep<'py>> {
        let (Real(alive), Real(upright), Real(tracking), Real(effort)) = weights;
        let (speed_ref, bound, reset) = (speed_ref.0, bound.0, ints(reset));
        let weights = BalanceReward { alive, upright, tracking, effort, speed_ref };
        let n = self.hold_actions(actions)?;
        let (mut rewards, mut states) = (vec![0.0; n], vec![0.0; 4 * n]);
        let (inner, actions, fell) = (&mut self.inner, &self.actions, &mut self.fell);
        let observations = py
            .detach(|| {
                inner.in_one_trip(|envs| {
                    envs.step(actions, fell)?;
                    envs.rows_into(&mut states, |envs, l| envs.state(l).into())?;
                    weights.rewards_into(&states, actions, bound, &mut rewards)?;
                    envs.reset_many(&reset, None)?;
                    if reset.len() > KEPT_REFRESH {
                        envs.rows_into(&mut states, |envs, l| envs.state(l).into())?;
                    } else {
                        for &l in &reset {
                            states[4 * l..4 * (l + 1)].copy_from_slice(&<[f64; 4]>::from(envs.state(l)));
                        }
                    }
                    if !envs.has_rig() {
                        // The ideal plant's observation is the state.
                        return Ok(states.clone());
                    }
                    let mut observations = vec![0.0; 4 * n];
                    envs.rows_into(&mut observations, |envs, l| envs.observation(l).into())?;
                    Ok(observations)
                })
            })
            .map_err(PyTwipError)?;
        Ok((PyArray1::from_slice(py, &self.fell), PyArray1::from_vec(py, rewards), rows_array::<4>(py, n, states), rows_array::<4>(py, n, observations)))
    }

    /// Every robot's observation (num_envs x 4).
    fn observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let inner = &self.inner;
        rows::<4>(py, inner.len(), |out| inner.rows_into(out, |envs, l| envs.observation(l).into()))
    }
}
