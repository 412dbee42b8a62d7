//! `twip/Balance-v0`'s native batch.
use numpy::PyArray2;
use pyo3::prelude::*;
use twip_core::envs::{BalanceEnvs, BalanceSpec};
use twip_core::sweep::{Nominal, Perturbation};

use super::{batch_class, realism_for, rows};

use crate::convert::vector;
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
        Ok(Self::wrap(inner))
    }

    /// Every robot's observation (num_envs x 4).
    fn observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let inner = &self.inner;
        rows::<4>(py, inner.len(), |out| inner.rows_into(out, |envs, l| envs.observation(l).into()))
    }
}
