//! `twip/Track-v0`'s native batch.
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;
use twip_core::control::trajectory::Trajectory;
use twip_core::envs::{TrackEnvs, TrackSpec, TRACK_OBS};
use twip_core::sweep::planar::validate;

use super::{realism_for, reset_lanes, rows};
use crate::control::trajectory::trajectory;
use crate::errors::PyTwipError;
use crate::hardware::realism::PyRealism;
use crate::model::models::PyPlanarModel;
use crate::sweep::planar::nominal;
use crate::sweep::{parse_perturbations, PerturbTuple};

/// N tracking robots on one path, each keyed (seed, episode); `twip.envs` wraps it.
#[pyclass(name = "TrackBatch", module = "twip._core")]
pub struct PyTrackBatch {
    inner: TrackEnvs,
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
        num_envs: usize,
        dt: f64,
        substeps: usize,
        fall_limit: f64,
        realism: Option<&PyRealism>,
        threads: usize,
    ) -> PyResult<Self> {
        let path: Trajectory<f64> = trajectory(path)?;
        let nominal = nominal(model, x0)?;
        let perturbations = parse_perturbations(&perturbations, validate)?;
        let spec = TrackSpec { nominal, perturbations, realism: realism_for(realism), path, dt, substeps, fall_limit };
        let inner = py.detach(|| TrackEnvs::new(spec, num_envs, threads)).map_err(PyTwipError)?;
        Ok(Self { inner })
    }

    #[getter]
    fn num_envs(&self) -> usize {
        self.inner.len()
    }

    #[getter]
    fn has_rig(&self) -> bool {
        self.inner.has_rig()
    }

    /// Starts the next episode of each lane in `lanes`: with `seeds` (one per lane),
    /// episode 0 of that seed; else the lane's next episode.
    #[pyo3(signature = (lanes, seeds = None))]
    fn reset(&mut self, py: Python<'_>, lanes: Vec<usize>, seeds: Option<Vec<u64>>) -> PyResult<()> {
        let inner = &mut self.inner;
        reset_lanes(py, &lanes, seeds, |l, seed| inner.reset(l, seed))
    }

    /// One control period of every robot under `actions` (2 per robot, robot after robot);
    /// returns which fell.
    fn step<'py>(&mut self, py: Python<'py>, actions: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let actions = actions.as_slice()?.to_vec();
        let mut fell = vec![false; self.inner.len()];
        let inner = &mut self.inner;
        py.detach(|| inner.step(&actions, &mut fell)).map_err(PyTwipError)?;
        Ok(fell.into_pyarray(py))
    }

    /// Every robot's observation (num_envs x 9): path error in its frame, pitch, speeds,
    /// the reference's speeds.
    fn observations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows::<TRACK_OBS>(py, self.inner.len(), |l| self.inner.observation(l))
    }

    /// The observations the true states give (num_envs x 9).
    fn true_observations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows::<TRACK_OBS>(py, self.inner.len(), |l| self.inner.true_observation(l))
    }

    /// Every robot's true state (num_envs x 7).
    fn states<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows::<7>(py, self.inner.len(), |l| self.inner.state(l).into())
    }

    /// Every robot's (seed, episode) key, as two uint64 arrays.
    fn keys<'py>(&self, py: Python<'py>) -> (Bound<'py, PyArray1<u64>>, Bound<'py, PyArray1<u64>>) {
        let (seeds, episodes): (Vec<u64>, Vec<u64>) = (0..self.inner.len()).map(|l| self.inner.key(l)).unzip();
        (seeds.into_pyarray(py), episodes.into_pyarray(py))
    }
}
