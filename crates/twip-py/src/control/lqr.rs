//! `twip.LqrController`: LQR with integral action (thesis 4.24) and its design.
use std::sync::OnceLock;

use nalgebra::Matrix4;
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::lqr::{design, DesignPoint, LqrController};
use twip_core::control::lqr_discrete::design_discrete;

use crate::convert::{dmatrix, gain_row, real, scalar, to_py_dmatrix, vector, Real};
use crate::errors::{CoreResult, PyTwipError};
use crate::model::models::PySlopeModel;

fn design_point(name: &str) -> PyResult<DesignPoint> {
    match name {
        "thesis" => Ok(DesignPoint::Thesis),
        "operating" => Ok(DesignPoint::OperatingPoint),
        other => Err(crate::errors::InvalidParameterError::new_err(format!(
            "point = '{other}': must be 'thesis' (linearised at phi = 0, (4.6)-(4.13)) or 'operating' (at the true steady state)"
        ))),
    }
}

fn point_name(p: DesignPoint) -> &'static str {
    match p {
        DesignPoint::Thesis => "thesis",
        DesignPoint::OperatingPoint => "operating",
    }
}

/// The constructor's arguments (model, gains, point, period), as pickled.
type LqrArgs<'py> = (PySlopeModel, Bound<'py, PyArray1<f64>>, &'static str, f64);

/// LQR with integral action on the wheel speed (thesis 4.24). A controller holds no run
/// state (each run starts its integral z at zero): a pickled copy has the same gains, model,
/// point and period, and `design_info` too.
#[pyclass(name = "LqrController", module = "twip", frozen)]
pub struct PyLqrController {
    pub inner: LqrController<f64>,
    /// Design details when built by `design` (Â, B̂, P̂, poles), or set once by unpickling.
    info: OnceLock<Py<PyDict>>,
}

#[pymethods]
impl PyLqrController {
    /// A controller with given gains K̂ = [k_phi, k_phi_dot, k_theta_dot, k_z] (this order,
    /// not the plant's state order: pitch, pitch rate, wheel-speed error, the integral z of
    /// the wheel-speed error), shape (4,) or python-control's (1, 4);
    /// u = u_s − (k_phi (φ − φ_s) + k_phi_dot φ̇ + k_theta_dot (θ̇ − θ̇_ref)) − k_z z.
    /// `model` is the controller's own model (for the steady state).
    #[new]
    #[pyo3(signature = (model, gains, point = "operating", period = 0.005))]
    fn new(model: &PySlopeModel, gains: &Bound<'_, PyAny>, point: &str, #[pyo3(from_py_with = real)] period: f64) -> PyResult<Self> {
        let g = gain_row::<4>("gains", gains)?;
        let inner = LqrController::new([g[0], g[1], g[2], g[3]], model.inner, design_point(point)?, period)
            .map_err(PyTwipError)?;
        Ok(Self { inner, info: OnceLock::new() })
    }

    /// Designs K̂ by LQR on the augmented system (4.17)-(4.23) at `theta_dot_ref`.
    /// `Q` is 4x4 (or the 4 diagonal entries), `R` a positive scalar. `discrete=True` designs
    /// at `period` instead (zero-order hold, the integrator as the controller runs it, dlqr);
    /// `delay=True` (with `discrete=True`) also models the rig's one-period command delay and
    /// picks the best 4 gains for it (see docs/dare.md).
    #[staticmethod]
    #[pyo3(name = "design", signature = (model, theta_dot_ref, Q, R, point = "operating", period = 0.005, discrete = false, delay = false))]
    #[allow(non_snake_case, clippy::too_many_arguments)]
    fn design_py(
        py: Python<'_>,
        model: &PySlopeModel,
        theta_dot_ref: Real,
        Q: &Bound<'_, PyAny>,
        R: Real,
        point: &str,
        #[pyo3(from_py_with = real)] period: f64,
        discrete: bool,
        delay: bool,
    ) -> PyResult<Self> {
        let (theta_dot_ref, R) = (theta_dot_ref.0, R.0);
        let q = match vector::<4>("Q", Q) {
            Ok(diag) => Matrix4::from_diagonal(&diag),
            // A diagonal with a bad entry is reported as such; only a shape sends us on to a matrix.
            Err(e) if !e.is_instance_of::<crate::errors::ShapeError>(py) => return Err(e),
            Err(as_vector) => {
                let m = dmatrix("Q", Q).map_err(|e| {
                    if e.is_instance_of::<crate::errors::ShapeError>(py) {
                        crate::errors::ShapeError::new_err(format!("{} (its diagonal) or (4, 4)", as_vector.value(py)))
                    } else {
                        e
                    }
                })?;
                if m.shape() != (4, 4) {
                    return Err(crate::errors::ShapeError::new_err(format!(
                        "Q has shape {:?}, expected (4,) (its diagonal) or (4, 4)",
                        m.shape()
                    )));
                }
                Matrix4::from_fn(|i, j| m[(i, j)])
            }
        };
        let p = design_point(point)?;
        if delay && !discrete {
            return Err(crate::errors::InvalidParameterError::new_err(
                "delay = True: needs discrete = True (the delay is one controller period)",
            ));
        }
        let (speed, r) = (scalar("theta_dot_ref", theta_dot_ref)?, scalar("R", R)?);
        let d = if discrete {
            design_discrete(&model.inner, speed, &q, r, p, scalar("period", period)?, delay)
        } else {
            design(&model.inner, speed, &q, r, p)
        }
        .map_err(PyTwipError)?;
        let info = PyDict::new(py);
        info.set_item("A", to_py_dmatrix(py, &nalgebra::DMatrix::from_fn(4, 4, |i, j| d.a[(i, j)])))?;
        info.set_item("B", to_py_dmatrix(py, &nalgebra::DMatrix::from_fn(4, 1, |i, _| d.b[i])))?;
        info.set_item("X", to_py_dmatrix(py, &d.x))?;
        info.set_item("poles", crate::convert::to_py_complex_vector(py, &d.poles))?;
        info.set_item("phi_s", d.phi_s)?;
        info.set_item("u_s", d.u_s)?;
        info.set_item("theta_dot_ref", theta_dot_ref)?;
        info.set_item("discrete", discrete)?;
        info.set_item("delay", delay)?;
        let inner = LqrController::new(d.gains, model.inner, p, period).map_err(PyTwipError)?;
        Ok(Self { inner, info: OnceLock::from(info.unbind()) })
    }

    /// K̂ = [k_phi, k_phi_dot, k_theta_dot, k_z].
    #[getter]
    fn gains<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.gains().to_vec().into_pyarray(py)
    }

    #[getter]
    fn period(&self) -> f64 {
        use twip_core::control::Controller;
        self.inner.period()
    }

    #[getter]
    fn point(&self) -> &'static str {
        point_name(self.inner.point())
    }

    #[getter]
    fn model(&self) -> PySlopeModel {
        PySlopeModel { inner: *self.inner.model() }
    }

    /// The design's Â, B̂, X (P̂), poles, phi_s, u_s (None if the gains were given).
    #[getter]
    fn design_info(&self, py: Python<'_>) -> Option<Py<PyDict>> {
        self.info.get().map(|d| d.clone_ref(py))
    }

    /// The steady state (phi_s, u_s) the controller aims for at a reference speed.
    fn steady_state(&self, theta_dot_ref: Real) -> CoreResult<(f64, f64)> {
        Ok(self.inner.steady_state(theta_dot_ref.0)?)
    }

    /// Pickled as LqrController(model, gains, point, period), then `design_info` as its state.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> (Bound<'py, PyAny>, LqrArgs<'py>, Option<Py<PyDict>>) {
        let (me, py) = (slf.get(), slf.py());
        let args = (me.model(), me.gains(py), me.point(), me.period());
        (slf.get_type().into_any(), args, me.design_info(py))
    }

    /// Restores `design_info` when unpickling; refused on a controller that has one.
    fn __setstate__(&self, info: Option<Py<PyDict>>) -> PyResult<()> {
        let Some(info) = info else { return Ok(()) };
        self.info.set(info).map_err(|_| {
            crate::errors::InvalidParameterError::new_err("__setstate__: this LqrController already has its design_info")
        })
    }

    fn __repr__(&self) -> String {
        format!("LqrController(gains={:?}, point='{}')", self.inner.gains(), point_name(self.inner.point()))
    }
}

