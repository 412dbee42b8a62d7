//! Speed schedules, the LQR controller and the closed-loop runner for the 2-DOF model.
use nalgebra::Matrix4;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::Reference;
use twip_core::log::{LogRow, TrajectoryLog};
use twip_core::lqr_control::{design, DesignPoint, LqrController, LQR_INTERNALS};
use twip_core::metrics::SlopeMetrics;
use twip_core::reference::{Leg, SpeedRef, SpeedSchedule};
use twip_core::runner::{simulate as run, Outcome, SimConfig};
use twip_core::TwipError;

use crate::convert::{dmatrix, scalar, to_py_dmatrix, vector};
use crate::errors::{CoreResult, PyTwipError};
use crate::models::PySlopeModel;

/// A wheel schedule from theta = 0: legs of (goal [rad], speed [rad/s] > 0, hold [s]).
#[pyclass(name = "SpeedSchedule", module = "twip", frozen)]
#[derive(Clone)]
pub struct PySpeedSchedule {
    pub inner: SpeedSchedule<f64>,
}

#[pymethods]
impl PySpeedSchedule {
    #[new]
    fn new(legs: Vec<(f64, f64, f64)>) -> CoreResult<Self> {
        let legs: Vec<Leg<f64>> = legs.into_iter().map(|(goal, speed, hold)| Leg { goal, speed, hold }).collect();
        Ok(Self { inner: SpeedSchedule::new(&legs)? })
    }

    /// Constant wheel speed [rad/s] from rest, forever.
    #[staticmethod]
    fn constant(speed: f64) -> CoreResult<Self> {
        Ok(Self { inner: SpeedSchedule::constant(speed)? })
    }

    /// The thesis's experiment: drive `distance` [m] at wheel speed `speed` [rad/s],
    /// hold `hold` [s], drive back to the start and hold `hold_end` [s].
    #[staticmethod]
    #[pyo3(signature = (distance, speed, wheel_radius, hold = 0.0))]
    fn go_and_return(distance: f64, speed: f64, wheel_radius: f64, hold: f64) -> CoreResult<Self> {
        if !(wheel_radius.is_finite() && wheel_radius > 0.0) {
            return Err(TwipError::InvalidParameter {
                name: "wheel_radius",
                value: wheel_radius,
                reason: "must be finite and > 0",
            }
            .into());
        }
        let goal = scalar("distance", distance)? / wheel_radius;
        Self::new(vec![(goal, speed, hold), (0.0, speed, 0.0)])
    }

    /// Legs as (goal, speed, hold) tuples.
    #[getter]
    fn legs(&self) -> Vec<(f64, f64, f64)> {
        self.inner.legs().iter().map(|l| (l.goal, l.speed, l.hold)).collect()
    }

    /// (theta_ref, theta_dot_ref) at time t.
    fn sample(&self, t: f64) -> (f64, f64) {
        let s = self.inner.sample(t);
        (s.theta, s.theta_dot)
    }

    fn __repr__(&self) -> String {
        format!("SpeedSchedule({:?})", self.legs())
    }
}

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

/// LQR with integral action on the wheel speed (thesis 4.24).
#[pyclass(name = "LqrController", module = "twip", frozen)]
pub struct PyLqrController {
    pub inner: LqrController<f64>,
    /// Design details when built by `design` (Â, B̂, P̂, poles).
    info: Option<Py<PyDict>>,
}

#[pymethods]
impl PyLqrController {
    /// A controller with given gains K̂ = [k_phi, k_phi_dot, k_theta_dot, k_z];
    /// `model` is the controller's own model (for the steady state).
    #[new]
    #[pyo3(signature = (model, gains, point = "operating", period = 0.005))]
    fn new(model: &PySlopeModel, gains: &Bound<'_, PyAny>, point: &str, period: f64) -> PyResult<Self> {
        let g = vector::<4>("gains", gains)?;
        let inner = LqrController::new([g[0], g[1], g[2], g[3]], model.inner, design_point(point)?, period)
            .map_err(PyTwipError)?;
        Ok(Self { inner, info: None })
    }

    /// Designs K̂ by LQR on the augmented system (4.17)-(4.23) at `theta_dot_ref`.
    /// `Q` is 4x4 (or the 4 diagonal entries), `R` a positive scalar.
    #[staticmethod]
    #[pyo3(name = "design", signature = (model, theta_dot_ref, Q, R, point = "operating", period = 0.005))]
    #[allow(non_snake_case)]
    fn design_py(
        py: Python<'_>,
        model: &PySlopeModel,
        theta_dot_ref: f64,
        Q: &Bound<'_, PyAny>,
        R: f64,
        point: &str,
        period: f64,
    ) -> PyResult<Self> {
        let q = match vector::<4>("Q", Q) {
            Ok(diag) => Matrix4::from_diagonal(&diag),
            Err(_) => {
                let m = dmatrix("Q", Q)?;
                if m.shape() != (4, 4) {
                    return Err(PyTwipError(TwipError::Shape { name: "Q", expected: (4, 4), got: m.shape() }).into());
                }
                Matrix4::from_fn(|i, j| m[(i, j)])
            }
        };
        let p = design_point(point)?;
        let d = design(&model.inner, scalar("theta_dot_ref", theta_dot_ref)?, &q, scalar("R", R)?, p)
            .map_err(PyTwipError)?;
        let info = PyDict::new(py);
        info.set_item("A", to_py_dmatrix(py, &nalgebra::DMatrix::from_fn(4, 4, |i, j| d.a[(i, j)])))?;
        info.set_item("B", to_py_dmatrix(py, &nalgebra::DMatrix::from_fn(4, 1, |i, _| d.b[i])))?;
        info.set_item("X", to_py_dmatrix(py, &d.x))?;
        info.set_item("poles", crate::convert::to_py_complex_vector(py, &d.poles))?;
        info.set_item("phi_s", d.phi_s)?;
        info.set_item("u_s", d.u_s)?;
        info.set_item("theta_dot_ref", theta_dot_ref)?;
        let inner = LqrController::new(d.gains, model.inner, p, period).map_err(PyTwipError)?;
        Ok(Self { inner, info: Some(info.unbind()) })
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
        self.info.as_ref().map(|d| d.clone_ref(py))
    }

    /// The steady state (phi_s, u_s) the controller aims for at a reference speed.
    fn steady_state(&self, theta_dot_ref: f64) -> CoreResult<(f64, f64)> {
        Ok(self.inner.steady_state(theta_dot_ref)?)
    }

    fn __repr__(&self) -> String {
        format!("LqrController(gains={:?}, point='{}')", self.inner.gains(), point_name(self.inner.point()))
    }
}

/// Runs the closed loop; returns a dict that `twip.simulate` wraps into a SimResult.
#[pyfunction]
#[pyo3(signature = (model, controller, x0, t_final, dt, reference, control_period = None, fall_limit = None, record_every = 1))]
#[allow(clippy::too_many_arguments)]
pub fn simulate_raw<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    controller: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    t_final: f64,
    dt: f64,
    reference: &PySpeedSchedule,
    control_period: Option<f64>,
    fall_limit: Option<f64>,
    record_every: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let plant = model.cast::<PySlopeModel>().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err("this controller drives a twip.SlopeModel")
    })?;
    let plant = plant.get().inner;
    let ctrl = controller.cast::<PyLqrController>().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "controller must be a twip controller, got {}",
            controller.get_type().name().map(|n| n.to_string()).unwrap_or_default()
        ))
    })?;
    let mut ctrl = ctrl.get().inner;
    if let Some(p) = control_period {
        ctrl = ctrl.with_period(p).map_err(PyTwipError)?;
    }
    ctrl.check_reference(&reference.inner).map_err(PyTwipError)?;
    let x0 = vector::<4>("x0", x0)?;
    let config = SimConfig { dt, t_final, fall_limit: fall_limit.unwrap_or(60f64.to_radians()) };
    use twip_core::control::Controller;
    let (n, _) = config.steps(ctrl.period()).map_err(PyTwipError)?;
    if record_every == 0 {
        return Err(PyTwipError(TwipError::InvalidParameter { name: "record_every", value: 0.0, reason: "must be >= 1" }).into());
    }
    let schedule = reference.inner;
    let widths = [4, 1, <SpeedRef<f64> as LogRow<f64>>::NAMES.len(), LQR_INTERNALS.len()];
    let (outcome, steps, metrics, log) = py.detach(move || {
        let mut observers = (SlopeMetrics::new(plant), TrajectoryLog::with_capacity(n + 1, record_every, widths));
        let result = run(&plant, &mut ctrl, &schedule, &x0, &config, &mut observers);
        result.map(|(outcome, steps)| {
            let (metrics, log) = observers;
            (outcome, steps, metrics, log)
        })
    })
    .map_err(PyTwipError)?;
    let summary = metrics.summary();
    let out = PyDict::new(py);
    let rows = log.len();
    let reshape = |v: Vec<f64>, cols: usize| -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(numpy::ndarray::Array2::from_shape_vec((rows, cols), v)
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?
            .into_pyarray(py))
    };
    out.set_item("t", log.t.into_pyarray(py))?;
    out.set_item("states", reshape(log.x, 4)?)?;
    out.set_item("inputs", reshape(log.u, 1)?)?;
    out.set_item("references", reshape(log.reference, widths[2])?)?;
    out.set_item("reference_names", <SpeedRef<f64> as LogRow<f64>>::NAMES.to_vec())?;
    out.set_item("internals", reshape(log.internals, widths[3])?)?;
    out.set_item("internal_names", LQR_INTERNALS.to_vec())?;
    let (name, t_end) = match outcome {
        Outcome::Completed => ("completed", None),
        Outcome::Fell { t } => ("fell", Some(t)),
        Outcome::Diverged { t } => ("diverged", Some(t)),
    };
    out.set_item("outcome", name)?;
    out.set_item("t_end", t_end)?;
    out.set_item("steps", steps)?;
    let m = PyDict::new(py);
    m.set_item("mean_abs_pitch_error", summary.mean_abs_pitch_error)?;
    m.set_item("mean_abs_speed_error", summary.mean_abs_speed_error)?;
    m.set_item("pitch_settling_time", summary.pitch_settling_time)?;
    m.set_item("speed_settling_time", summary.speed_settling_time)?;
    m.set_item("final_position_error", summary.final_position_error)?;
    m.set_item("peak_abs_input", summary.peak_abs_input)?;
    out.set_item("metrics", m)?;
    Ok(out)
}
