//! `twip.RobotParams`: a frozen, validated view of `twip_core::RobotParams<f64>`.
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::model::params::FIELD_NAMES;
use twip_core::RobotParams;

use crate::convert::Real;
use crate::errors::{CoreResult, InvalidParameterError};
use crate::settings::Reduced;

/// `params` as a dict, field name to value (`RobotParams.to_dict`, a sweep sample's robot).
pub(crate) fn params_dict<'py>(py: Python<'py>, params: &RobotParams<f64>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, value) in FIELD_NAMES.iter().zip(params.to_array()) {
        d.set_item(name, value)?;
    }
    Ok(d)
}

/// Physical parameters of one robot, SI units (see docs/parameters.md).
#[pyclass(name = "RobotParams", module = "twip", frozen, eq)]
#[derive(Clone, PartialEq)]
pub struct PyRobotParams {
    pub inner: RobotParams<f64>,
}

fn field_index(name: &str) -> PyResult<usize> {
    FIELD_NAMES.iter().position(|f| *f == name).ok_or_else(|| {
        InvalidParameterError::new_err(format!(
            "unknown RobotParams field '{name}'; the fields are: {}",
            FIELD_NAMES.join(", ")
        ))
    })
}

/// Overrides `values` with the entries of `kw` (field name -> number).
fn apply(values: &mut [f64; 16], kw: &Bound<'_, PyDict>) -> PyResult<()> {
    for (k, v) in kw.iter() {
        let name: String = k.extract()?;
        let i = field_index(&name)?;
        values[i] = v.extract::<Real>().map_err(|_| {
            InvalidParameterError::new_err(format!("RobotParams field '{name}' must be a real number, got {v}"))
        })?.0;
    }
    Ok(())
}

fn build(values: [f64; 16]) -> CoreResult<PyRobotParams> {
    Ok(PyRobotParams { inner: RobotParams::from_array(&values).validate()? })
}

#[pymethods]
impl PyRobotParams {
    /// All 16 fields by keyword; `RobotParams.balanbot().replace(...)` for a variant.
    #[new]
    #[pyo3(signature = (**fields))]
    fn new(fields: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut values = [f64::NAN; 16];
        if let Some(kw) = fields {
            apply(&mut values, kw)?;
        }
        // Missing is what was not given (a NaN given is named by the validation, as NaN).
        let given = |name: &str| fields.is_some_and(|kw| kw.contains(name).unwrap_or(false));
        let missing: Vec<&str> = FIELD_NAMES.iter().copied().filter(|n| !given(n)).collect();
        if !missing.is_empty() {
            return Err(InvalidParameterError::new_err(format!(
                "RobotParams needs every field; missing: {} (start from RobotParams.balanbot().replace(...))",
                missing.join(", ")
            )));
        }
        Ok(build(values)?)
    }

    /// The thesis's robot (Balanbot with GB37Y3530-12V-251R motors).
    #[staticmethod]
    fn balanbot() -> Self {
        Self { inner: RobotParams::balanbot() }
    }

    /// A copy with some fields changed, validated.
    #[pyo3(signature = (**changes))]
    fn replace(&self, changes: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut values = self.inner.to_array();
        if let Some(kw) = changes {
            apply(&mut values, kw)?;
        }
        Ok(build(values)?)
    }

    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        params_dict(py, &self.inner)
    }

    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyDict>) -> PyResult<Self> {
        Self::new(Some(d))
    }

    /// Field names in a fixed order.
    #[classattr]
    fn fields() -> Vec<&'static str> {
        FIELD_NAMES.to_vec()
    }

    fn __getattr__(&self, name: &str) -> PyResult<f64> {
        let i = FIELD_NAMES.iter().position(|f| *f == name).ok_or_else(|| {
            pyo3::exceptions::PyAttributeError::new_err(format!("RobotParams has no field '{name}'"))
        })?;
        Ok(self.inner.to_array()[i])
    }

    fn __repr__(&self) -> String {
        let body: Vec<String> =
            FIELD_NAMES.iter().zip(self.inner.to_array()).map(|(n, v)| format!("{n}={v:?}")).collect();
        format!("RobotParams({})", body.join(", "))
    }

    /// The [robot] table of a robot file (TOML; see `twip.robot_file`).
    #[classmethod]
    fn from_file<'py>(cls: &Bound<'py, pyo3::types::PyType>, path: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        cls.py().import("twip.robot_file")?.call_method1("load", (path,))?.getattr("params")
    }

    /// Writes a robot file: every field with its unit and thesis symbol in a comment.
    fn to_file(slf: &Bound<'_, Self>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        slf.py().import("twip.robot_file")?.call_method1("save", (slf, path))?;
        Ok(())
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Reduced<'py, (Bound<'py, PyDict>,)>> {
        crate::settings::reduced(slf, slf.get().to_dict(slf.py())?)
    }
}

