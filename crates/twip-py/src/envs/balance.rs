//! `twip/Balance-v0`'s native batch.
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;
use twip_core::envs::{BalanceEnvs, BalanceSpec};
use twip_core::sweep::{Nominal, Perturbation};

use super::{realism_for, reset_lanes, rows};

use crate::convert::vector;
use crate::errors::PyTwipError;
use crate::hardware::realism::PyRealism;
use crate::model::models::PySlopeModel;
use crate::sweep::{no_friction_in_sweeps, parse_perturbations, PerturbTuple};

/// N balancing robots, each keyed (seed, episode); `twip.envs` wraps it.
#[pyclass(name = "BalanceBatch", module = "twip._core")]
pub struct PyBalanceBatch {
    inner: BalanceEnvs,
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
        num_envs: usize,
        dt: f64,
        substeps: usize,
        fall_limit: f64,
        realism: Option<&PyRealism>,
        threads: usize,
    ) -> PyResult<Self> {
        no_friction_in_sweeps(model.inner.friction().is_some())?;
        let nominal = Nominal { params: *model.inner.params(), slope: model.inner.slope(), x0: vector::<4>("x0", x0)? };
        let perturbations = parse_perturbations(&perturbations, Perturbation::validate)?;
        let spec = BalanceSpec { nominal, perturbations, realism: realism_for(realism), dt, substeps, fall_limit };
        let inner = py.detach(|| BalanceEnvs::new(spec, num_envs, threads)).map_err(PyTwipError)?;
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

    /// One control period of every robot; returns which fell.
    fn step<'py>(&mut self, py: Python<'py>, actions: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let actions = actions.as_slice()?.to_vec();
        let mut fell = vec![false; self.inner.len()];
        let inner = &mut self.inner;
        py.detach(|| inner.step(&actions, &mut fell)).map_err(PyTwipError)?;
        Ok(fell.into_pyarray(py))
    }

    /// Every robot's observation (num_envs x 4).
    fn observations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows::<4>(py, self.inner.len(), |l| self.inner.observation(l).into())
    }

    /// Every robot's true state (num_envs x 4).
    fn states<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows::<4>(py, self.inner.len(), |l| self.inner.state(l).into())
    }

    /// Every robot's (seed, episode) key, as two uint64 arrays.
    fn keys<'py>(&self, py: Python<'py>) -> (Bound<'py, PyArray1<u64>>, Bound<'py, PyArray1<u64>>) {
        let (seeds, episodes): (Vec<u64>, Vec<u64>) = (0..self.inner.len()).map(|l| self.inner.key(l)).unzip();
        (seeds.into_pyarray(py), episodes.into_pyarray(py))
    }
}
