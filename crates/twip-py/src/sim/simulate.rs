//! The closed-loop runner for the 2-DOF model: any 2-DOF controller, one code path.
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

use crate::convert::{int, vector, Real};
use crate::sim::run_result::{run_dict, LogLayout};
use crate::errors::{CoreResult, PyTwipError};
use crate::control::fuzzy::PyFuzzyController;
use crate::control::lqr::PyLqrController;
use crate::model::models::PySlopeModel;
use crate::hardware::realism::PyRealism;
use crate::control::schedule::PySpeedSchedule;
use crate::control::user_controller::is_user_controller;
use crate::sim::drive::{run_native, run_user, Run};

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

crate::sim::dispatch::controller_enum!(SlopeController, 4, 1, SpeedRef<f64>, "2-DOF"; Lqr(PyLqrController), Fuzzy(PyFuzzyController));

/// One 2-DOF run's settings, for any controller.
#[derive(Clone, Copy)]
struct SlopeRun {
    plant: twip_core::SlopeModel<f64>,
    schedule: SpeedSchedule<f64>,
    x0: nalgebra::Vector4<f64>,
    config: SimConfig<f64>,
    realism: Option<twip_core::hardware::realism::Realism<f64>>,
    record_every: usize,
    extra: usize,
}

type SlopeOutput = (Outcome<f64>, usize, SlopeMetrics<f64>, TrajectoryLog<f64>);

impl SlopeRun {
    /// The log's widths: state, input, reference, internals (+ the rig's signals).
    fn widths(&self, internals: usize) -> [usize; 4] {
        [4, 1, <SpeedRef<f64> as LogRow<f64>>::NAMES.len(), internals + self.extra]
    }
}

impl Run<4, 1> for SlopeRun {
    type Reference = SpeedRef<f64>;
    type Output = SlopeOutput;

    /// The ideal loop is the plain runner; realism builds its own plant, sensor and
    /// actuator kinds (core enums) and runs them through simulate_rig.
    fn run<C>(&self, ctrl: &mut C, should_stop: impl FnMut() -> bool) -> Result<SlopeOutput, twip_core::TwipError>
    where
        C: Controller<f64, 4, 1, Reference = SpeedRef<f64>>,
    {
        let (n, _) = self.config.steps(ctrl.period())?;
        let widths = self.widths(ctrl.internal_names().len());
        let mut observers =
            (SlopeMetrics::new(self.plant), TrajectoryLog::with_capacity(n + 1, self.record_every, widths)?);
        let (outcome, steps) = match self.realism {
            None => simulate_until(&self.plant, ctrl, &self.schedule, &self.x0, &self.config, &mut observers, should_stop)?,
            Some(r) => r
                .build(&self.plant, self.config.dt)?
                .simulate(ctrl, &self.schedule, &self.x0, &self.config, &mut observers, should_stop)?,
        };
        let (metrics, log) = observers;
        Ok((outcome, steps, metrics, log))
    }
}

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
    t_final: Real,
    dt: Real,
    reference: &PySpeedSchedule,
    control_period: Option<Real>,
    fall_limit: Option<Real>,
    #[pyo3(from_py_with = int::<usize>)] record_every: usize,
    realism: Option<&PyRealism>,
) -> PyResult<Bound<'py, PyDict>> {
    let (t_final, dt) = (t_final.0, dt.0);
    let (control_period, fall_limit) = (control_period.map(|p| p.0), fall_limit.map(|f| f.0));
    let plant = model.cast::<PySlopeModel>().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err("this controller drives a twip.SlopeModel")
    })?;
    let plant = plant.get().inner;
    let realism = realism.map(|r| r.to_core(plant.params())).transpose().map_err(PyTwipError)?;
    // An explicit control_period wins over the realism's loop period.
    let period = control_period.or(realism.and_then(|r| r.control_period));
    let x0 = vector::<4>("x0", x0)?;
    let config = SimConfig::new(dt, t_final, fall_limit);
    if record_every == 0 {
        return Err(crate::errors::invalid("record_every", 0.0, "must be >= 1").into());
    }
    let schedule = reference.inner;
    let extra = if realism.is_some() { RIG_SIGNALS.len() } else { 0 };
    let run = SlopeRun { plant, schedule, x0, config, realism, record_every, extra };
    let (names, (outcome, steps, metrics, log)) = if is_user_controller(controller) && SlopeController::extract(controller).is_err() {
        run_user(&run, controller, period, dt, "SlopeModel")?
    } else {
        let mut ctrl = SlopeController::extract(controller)?;
        if let Some(p) = period {
            ctrl = ctrl.with_period(p)?;
        }
        ctrl.check_reference(&schedule)?;
        run_native(py, &run, ctrl)?
    };
    let layout = LogLayout {
        states: 4,
        inputs: 1,
        reference_names: <SpeedRef<f64> as LogRow<f64>>::NAMES,
        internal_names: names,
        signal_names: (extra > 0).then_some(&RIG_SIGNALS[..]),
    };
    // A run that fell or diverged never settled (as its sweep sample says).
    let summary = metrics.summary();
    let summary = outcome.ended_early().map_or(summary, |t| summary.ended_early(t));
    run_dict(py, log, &layout, outcome, steps, summary.named())
}
