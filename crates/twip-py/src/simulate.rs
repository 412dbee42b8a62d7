//! The closed-loop runner for the 2-DOF model: any 2-DOF controller, one code path.
use numpy::{IntoPyArray, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::Controller;
use twip_core::sim::log::{LogRow, TrajectoryLog};
use twip_core::control::fuzzy::FuzzyController;
use twip_core::control::lqr::LqrController;
use twip_core::sim::metrics::SlopeMetrics;
use twip_core::hardware::realism::RIG_SIGNALS;
use twip_core::control::reference::{SpeedRef, SpeedSchedule};
use twip_core::sim::runner::{simulate_until, Outcome, SimConfig};

use crate::convert::vector;
use crate::errors::{CoreResult, PyTwipError};
use crate::fuzzy::PyFuzzyController;
use crate::lqr::PyLqrController;
use crate::models::PySlopeModel;
use crate::realism::PyRealism;
use crate::schedule::PySpeedSchedule;

/// Every controller of the 2-DOF model. A new controller family adds a variant here
/// and in the `controller_enum!` line below; the runner stays one monomorphised loop.
/// Unboxed on purpose, as `PlanarController`: copied once per run, then updated in place.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum SlopeController {
    Lqr(LqrController<f64>),
    Fuzzy(FuzzyController<f64>),
}

impl SlopeController {
    pub(crate) fn check_reference(&self, schedule: &SpeedSchedule<f64>) -> CoreResult<()> {
        match self {
            Self::Lqr(c) => c.check_reference(schedule)?,
            Self::Fuzzy(c) => c.check_reference(schedule)?,
        }
        Ok(())
    }
}

crate::dispatch::controller_enum!(SlopeController, 4, 1, SpeedRef<f64>, "2-DOF"; Lqr(PyLqrController), Fuzzy(PyFuzzyController));

/// Runs the closed loop; returns a dict that `twip.simulate` wraps into a SimResult.
/// With `realism` (a `twip.Realism`) the loop runs through `simulate_rig` and the log
/// gains the `signals` (what the controller read, the plant's input, the motor current).
#[pyfunction]
#[pyo3(signature = (model, controller, x0, t_final, dt, reference, control_period = None, fall_limit = None, record_every = 1, realism = None))]
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
    realism: Option<&PyRealism>,
) -> PyResult<Bound<'py, PyDict>> {
    let plant = model.cast::<PySlopeModel>().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err("this controller drives a twip.SlopeModel")
    })?;
    let plant = plant.get().inner;
    let mut ctrl = SlopeController::extract(controller)?;
    let realism = realism.map(|r| r.to_core(plant.params())).transpose().map_err(PyTwipError)?;
    // An explicit control_period wins over the realism's loop period.
    if let Some(p) = control_period.or(realism.and_then(|r| r.control_period)) {
        ctrl = ctrl.with_period(p)?;
    }
    ctrl.check_reference(&reference.inner)?;
    let x0 = vector::<4>("x0", x0)?;
    let config = SimConfig::new(dt, t_final, fall_limit);
    let (n, _) = config.steps(ctrl.period()).map_err(PyTwipError)?;
    if record_every == 0 {
        return Err(crate::errors::invalid("record_every", 0.0, "must be >= 1").into());
    }
    let schedule = reference.inner;
    let names = ctrl.internal_names();
    let extra = if realism.is_some() { RIG_SIGNALS.len() } else { 0 };
    let widths = [4, 1, <SpeedRef<f64> as LogRow<f64>>::NAMES.len(), names.len() + extra];
    let (outcome, steps, metrics, log, interrupt) = py.detach(move || {
        let mut observers = (SlopeMetrics::new(plant), TrajectoryLog::with_capacity(n + 1, record_every, widths));
        let mut interrupt = None;
        let should_stop = || crate::interrupt::requested(&mut interrupt);
        // The ideal loop stays the plain runner; realism builds its own plant, sensor
        // and actuator kinds (core enums) and runs them through simulate_rig.
        let result = match realism {
            None => simulate_until(&plant, &mut ctrl, &schedule, &x0, &config, &mut observers, should_stop),
            Some(r) => r
                .build(&plant, config.dt)
                .and_then(|mut rig| rig.simulate(&mut ctrl, &schedule, &x0, &config, &mut observers, should_stop)),
        };
        result.map(|(outcome, steps)| {
            let (metrics, log) = observers;
            (outcome, steps, metrics, log, interrupt)
        })
    })
    .map_err(PyTwipError)?;
    if let Some(err) = interrupt {
        return Err(err);
    }
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
    set_internals_and_signals(&out, log.internals, rows, &names, extra > 0, &RIG_SIGNALS)?;
    let (name, t_end) = match outcome {
        Outcome::Completed => ("completed", None),
        Outcome::Fell { t } => ("fell", Some(t)),
        Outcome::Diverged { t } => ("diverged", Some(t)),
        Outcome::Interrupted { t } => ("interrupted", Some(t)),
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

/// Sets `internals`, `internal_names`, `signals` and `signal_names` of a run's dict from
/// its log's internals columns: the controller's internals, then (with realism) the
/// rig's signals.
pub(crate) fn set_internals_and_signals(
    out: &Bound<'_, PyDict>,
    columns: Vec<f64>,
    rows: usize,
    names: &[&str],
    with_signals: bool,
    signal_names: &[&str],
) -> PyResult<()> {
    let py = out.py();
    let cut = names.len();
    let width = cut + if with_signals { signal_names.len() } else { 0 };
    let table = numpy::ndarray::Array2::from_shape_vec((rows, width), columns)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    let signals = with_signals.then(|| table.slice(numpy::ndarray::s![.., cut..]).to_owned().into_pyarray(py));
    let internals = if with_signals { table.slice(numpy::ndarray::s![.., ..cut]).to_owned() } else { table };
    out.set_item("internals", internals.into_pyarray(py))?;
    out.set_item("internal_names", names.to_vec())?;
    out.set_item("signals", signals)?;
    out.set_item("signal_names", signal_names.to_vec())?;
    Ok(())
}
