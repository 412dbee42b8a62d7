//! What `twip export` needs from twip-ffi: a tuned controller's C configuration (the raw
//! bytes of its `repr(C)` struct, decoded in Python against the header), the header itself,
//! and a recorded closed-loop run of the `f32` controller that C replays.
use numpy::{IntoPyArray, PyArray2};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use twip_core::control::Controller;
use twip_core::hardware::driver::PwmActuator;
use twip_core::hardware::tilt::TiltEstimator;
use twip_core::RobotParams;
use twip_ffi::replay::{planar_f32, record, slope_f32, Record};
use twip_ffi::{TwipFuzzyConfig, TwipLqrConfig, TwipPidConfig, TwipPwmConfig, TwipSmcConfig, TwipTiltConfig};

use crate::convert::{reals, Real};
use crate::errors::PyTwipError;
use crate::control::fuzzy::PyFuzzyController;
use crate::control::lqr::PyLqrController;
use crate::model::models::{PyPlanarModel, PySlopeModel};
use crate::model::params::PyRobotParams;
use crate::hardware::realism::PyRealism;
use crate::control::schedule::PySpeedSchedule;
use crate::control::tracking::{PyPidTracker, PySmcTracker};
use crate::control::trajectory::trajectory;

/// The C header of twip-ffi, as built into this module.
pub const HEADER: &str = include_str!("../../twip-ffi/include/twip.h");
/// Where twip-ffi's sources were when this module was built (the exported Makefile's default).
pub const SOURCE_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../twip-ffi");

/// The bytes of a `repr(C)` struct of 4-byte fields (no padding: every field is an `f32`
/// or an `i32`, which the header test and the decoder check).
fn bytes_of<'py, C: Copy>(py: Python<'py>, value: &C) -> Bound<'py, PyBytes> {
    // SAFETY: `value` is a plain `repr(C)` struct of f32/i32 fields, read as bytes.
    let raw = unsafe { core::slice::from_raw_parts((value as *const C).cast::<u8>(), core::mem::size_of::<C>()) };
    PyBytes::new(py, raw)
}

fn record_dict<'py, const NX: usize, const NU: usize, R: Copy>(
    py: Python<'py>,
    family: &str,
    config: Bound<'py, PyBytes>,
    (rec, outcome): (Record<NX, NU, R>, twip_core::sim::runner::Outcome<f32>),
    reference_fields: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let n = rec.t.len();
    // SAFETY: a C reference is `reference_fields` f32s (TwipSpeedRef, TwipPlanarRef).
    let refs: Vec<f32> = rec
        .reference
        .iter()
        .flat_map(|r| unsafe { core::slice::from_raw_parts((r as *const R).cast::<f32>(), reference_fields) }.to_vec())
        .collect();
    let to_2d = |data: Vec<f32>, cols: usize| -> PyResult<Bound<'py, PyArray2<f32>>> {
        Ok(numpy::ndarray::Array2::from_shape_vec((n, cols), data)
            .map_err(|e| PyTypeError::new_err(e.to_string()))?
            .into_pyarray(py))
    };
    let out = PyDict::new(py);
    out.set_item("family", family)?;
    out.set_item("config", config)?;
    out.set_item("t", rec.t.clone().into_pyarray(py))?;
    out.set_item("y", to_2d(rec.y.concat(), NX)?)?;
    out.set_item("reference", to_2d(refs, reference_fields)?)?;
    out.set_item("u", to_2d(rec.u.concat(), NU)?)?;
    out.set_item("outcome", format!("{outcome:?}"))?;
    Ok(out)
}

/// `ffi_record(model, controller, x0, t_final, dt, reference, control_period=None)`: the
/// controller's C configuration and a closed-loop run of its `f32` build (as `twip_X_init`
/// makes it) on the `f32` plant, every update recorded: {"family", "config" (bytes of the C
/// struct), "t", "y", "reference", "u", "outcome"}. With `control_period` [s] the controller
/// runs at that period, as `simulate(..., control_period=)` runs it, and its configuration
/// says so.
#[pyfunction]
#[pyo3(signature = (model, controller, x0, t_final, dt, reference, control_period = None))]
#[allow(clippy::too_many_arguments)]
pub fn ffi_record<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    controller: &Bound<'py, PyAny>,
    x0: Vec<Real>,
    t_final: Real,
    dt: Real,
    reference: &Bound<'py, PyAny>,
    control_period: Option<Real>,
) -> PyResult<Bound<'py, PyDict>> {
    let (x0, t_final, dt, control_period) = (reals(x0), t_final.0, dt.0, control_period.map(|p| p.0));
    let (dt32, t32) = (dt as f32, t_final as f32);
    // The period the loop runs at: the scenario's, else the controller's own.
    let at_period = |period: f64| control_period.unwrap_or(period);
    if let Ok(m) = model.cast::<PySlopeModel>() {
        let plant = slope_f32(&m.get().inner).map_err(PyTwipError)?;
        let schedule = reference.cast::<PySpeedSchedule>()?.get().inner;
        let x0: [f32; 4] = state_of(&x0)?;
        if let Ok(c) = controller.cast::<PyLqrController>() {
            let inner = c.get().inner;
            let config = TwipLqrConfig::from_core(&inner.with_period(at_period(inner.period())).map_err(PyTwipError)?)
                .map_err(PyTwipError)?;
            let run = record(&plant, config.build().map_err(PyTwipError)?, &schedule, x0, dt32, t32).map_err(PyTwipError)?;
            return record_dict(py, "lqr", bytes_of(py, &config), run, 2);
        }
        if let Ok(c) = controller.cast::<PyFuzzyController>() {
            let inner = c.get().inner;
            let config = TwipFuzzyConfig::from_core(&inner.with_period(at_period(inner.period())).map_err(PyTwipError)?)
                .map_err(PyTwipError)?;
            let run = record(&plant, config.build().map_err(PyTwipError)?, &schedule, x0, dt32, t32).map_err(PyTwipError)?;
            return record_dict(py, "fuzzy", bytes_of(py, &config), run, 2);
        }
    } else if let Ok(m) = model.cast::<PyPlanarModel>() {
        let plant = planar_f32(m.get().flat_only("twip export")?).map_err(PyTwipError)?;
        let path = trajectory(reference)?;
        let x0: [f32; 7] = state_of(&x0)?;
        if let Ok(c) = controller.cast::<PyPidTracker>() {
            let inner = c.get().inner;
            let config = TwipPidConfig::from_core(&inner.with_period(at_period(inner.period())).map_err(PyTwipError)?)
                .map_err(PyTwipError)?;
            let run = record(&plant, config.build().map_err(PyTwipError)?, &path, x0, dt32, t32).map_err(PyTwipError)?;
            return record_dict(py, "pid", bytes_of(py, &config), run, 7);
        }
        if let Ok(c) = controller.cast::<PySmcTracker>() {
            let inner = c.get().inner;
            let config = TwipSmcConfig::from_core(&inner.with_period(at_period(inner.period())).map_err(PyTwipError)?)
                .map_err(PyTwipError)?;
            let run = record(&plant, config.build().map_err(PyTwipError)?, &path, x0, dt32, t32).map_err(PyTwipError)?;
            return record_dict(py, "smc", bytes_of(py, &config), run, 7);
        }
    }
    Err(PyTypeError::new_err(format!(
        "twip export takes an LQR or fuzzy controller on a SlopeModel, or a PID or sliding-mode tracker on a \
         PlanarModel; got {} on {}",
        controller.get_type().name()?,
        model.get_type().name()?
    )))
}

fn state_of<const N: usize>(x0: &[f64]) -> PyResult<[f32; N]> {
    let v: Vec<f32> = x0.iter().map(|&v| v as f32).collect();
    v.try_into().map_err(|v: Vec<f32>| {
        PyTwipError(twip_core::TwipError::Shape { name: "x0", expected: (N, 1), got: (v.len(), 1) }).into()
    })
}

/// `ffi_firmware(realism, params)`: the C configurations of the firmware pieces the
/// realism describes: {"tilt": bytes of TwipTiltConfig, "pwm_lumped" and "pwm_wheel": bytes
/// of TwipPwmConfig (for a lumped current and for one wheel's torque), "encoder_cpr"}.
#[pyfunction]
pub fn ffi_firmware<'py>(
    py: Python<'py>,
    realism: &PyRealism,
    params: &PyRobotParams,
) -> PyResult<Bound<'py, PyDict>> {
    let p: RobotParams<f64> = params.inner;
    let core = realism.to_core(&p).map_err(PyTwipError)?;
    let tilt = match core.estimator {
        TiltEstimator::Complementary { time_constant } => {
            TwipTiltConfig { kind: 0, time_constant: time_constant as f32, ..Default::default() }
        }
        TiltEstimator::Kalman { q_angle, q_bias, r_angle } => TwipTiltConfig {
            kind: 1,
            q_angle: q_angle as f32,
            q_bias: q_bias as f32,
            r_angle: r_angle as f32,
            ..Default::default()
        },
    };
    let out = PyDict::new(py);
    out.set_item("tilt", bytes_of(py, &tilt))?;
    if let Some(driver) = core.motor {
        let lumped = PwmActuator::new(&driver, &p).map_err(PyTwipError)?;
        let wheel = PwmActuator::per_wheel_torque(&driver, &p).map_err(PyTwipError)?;
        out.set_item("pwm_lumped", bytes_of(py, &TwipPwmConfig::from_core(&lumped).map_err(PyTwipError)?))?;
        out.set_item("pwm_wheel", bytes_of(py, &TwipPwmConfig::from_core(&wheel).map_err(PyTwipError)?))?;
    }
    out.set_item("encoder_cpr", core.encoder_cpr)?;
    Ok(out)
}
