//! The closed-loop runner for the 3-DOF model: any 3-DOF controller, one code path.
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::Controller;
use twip_core::sim::log::{LogRow, TrajectoryLog};
use twip_core::control::pid::PidTracker;
use twip_core::hardware::planar_rig::PLANAR_RIG_SIGNALS;
use twip_core::sim::runner::{simulate_until, Outcome, SimConfig};
use twip_core::control::smc::SmcTracker;
use twip_core::sim::tracking_metrics::TrackingMetrics;
use twip_core::control::trajectory::{PlanarRef, Trajectory};

use crate::convert::{int, vector, Real};
use crate::sim::run_result::{run_dict, LogLayout};
use crate::errors::{invalid, PyTwipError};
use crate::model::models::PyPlanarModel;
use crate::control::user_controller::is_user_controller;
use crate::sim::drive::{run_native, run_user, Run};
use crate::control::grade::PyGradeFeedForward;
use crate::control::tracking::{PyPidTracker, PySmcTracker};
use crate::control::trajectory::trajectory;


// --- the planar runner -----------------------------------------------------------------------------

/// Every controller of the 3-DOF model, as `SlopeController` is for the 2-DOF one.
/// Unboxed on purpose: it is copied once per run and then updated in place.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum PlanarController {
    Pid(PidTracker<f64>),
    Smc(SmcTracker<f64>),
}

crate::sim::dispatch::controller_enum!(PlanarController, 7, 2, PlanarRef<f64>, "3-DOF"; Pid(PyPidTracker), Smc(PySmcTracker));

/// When the "_settled" metrics start: `settle` [s], by default one lap of a closed path, else 0.
pub(crate) fn settle_time(settle: Option<f64>, path: &Trajectory<f64>) -> PyResult<f64> {
    let settle = settle.or_else(|| path.period()).unwrap_or(0.0);
    if !settle.is_finite() {
        return Err(invalid("settle", settle, "must be finite").into());
    }
    Ok(settle)
}

/// One 3-DOF run's settings, for any controller.
#[derive(Clone)]
struct PlanarRun {
    plant: twip_core::PlanarModel<f64>,
    /// The plant on its terrain, or flat ground.
    terrain: Option<twip_core::model::terrain_model::TerrainModel<f64>>,
    path: Trajectory<f64>,
    settle: f64,
    x0: nalgebra::SVector<f64, 7>,
    config: SimConfig<f64>,
    record_every: usize,
    /// The robot's real parts (the 3-DOF rig), or the ideal loop.
    realism: Option<twip_core::hardware::realism::Realism<f64>>,
}

type PlanarOutput = (Outcome<f64>, usize, TrackingMetrics<f64, Trajectory<f64>>, TrajectoryLog<f64>);

impl Run<7, 2> for PlanarRun {
    type Reference = PlanarRef<f64>;
    type Output = PlanarOutput;

    fn run<C>(&self, ctrl: &mut C, should_stop: impl FnMut() -> bool) -> Result<PlanarOutput, twip_core::TwipError>
    where
        C: Controller<f64, 7, 2, Reference = PlanarRef<f64>>,
    {
        let (n, _) = self.config.steps(ctrl.period())?;
        let extra = if self.realism.is_some() { PLANAR_RIG_SIGNALS.len() } else { 0 };
        let widths = [7, 2, <PlanarRef<f64> as LogRow<f64>>::NAMES.len(), ctrl.internal_names().len() + extra];
        let mut observers =
            (TrackingMetrics::new(self.path, self.settle), TrajectoryLog::with_capacity(n + 1, self.record_every, widths)?);
        let (outcome, steps) = match (&self.realism, &self.terrain) {
            (None, Some(t)) => simulate_until(t, ctrl, &self.path, &self.x0, &self.config, &mut observers, should_stop)?,
            (None, None) => simulate_until(&self.plant, ctrl, &self.path, &self.x0, &self.config, &mut observers, should_stop)?,
            (Some(r), t) => r.build_planar_on(&self.plant, t.as_ref().map(|t| t.terrain()), self.config.dt)?.simulate(
                ctrl,
                &self.path,
                &self.x0,
                &self.config,
                &mut observers,
                should_stop,
            )?,
        };
        let (metrics, log) = observers;
        Ok((outcome, steps, metrics, log))
    }
}

/// Runs a tracker on the 3-DOF model; returns a dict that `twip.simulate` wraps into a
/// SimResult. `settle` [s] starts the "_settled" metrics (default: one lap of a circle or
/// figure-eight, else 0).
#[pyfunction]
#[pyo3(signature = (model, controller, x0, t_final, dt, reference, control_period = None, fall_limit = None, record_every = 1, settle = None, realism = None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate_planar_raw<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    controller: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    t_final: Real,
    dt: Real,
    reference: &Bound<'py, PyAny>,
    control_period: Option<Real>,
    fall_limit: Option<Real>,
    #[pyo3(from_py_with = int::<usize>)] record_every: usize,
    settle: Option<Real>,
    realism: Option<&crate::hardware::realism::PyRealism>,
) -> PyResult<Bound<'py, PyDict>> {
    let (t_final, dt) = (t_final.0, dt.0);
    let (control_period, fall_limit, settle) = (control_period.map(|p| p.0), fall_limit.map(|f| f.0), settle.map(|s| s.0));
    let model = model
        .cast::<PyPlanarModel>()
        .map_err(|_| pyo3::exceptions::PyTypeError::new_err("this controller drives a twip.PlanarModel"))?
        .get();
    let (plant, terrain) = (model.inner, model.on_terrain());
    if let Some(t) = &terrain {
        let x0 = vector::<7>("x0", x0)?;
        if !t.terrain().contains(x0[0], x0[1]) {
            return Err(crate::model::terrain::off_terrain(x0[0], x0[1]));
        }
    }
    let realism = realism.map(|r| r.to_core(plant.params())).transpose().map_err(PyTwipError)?;
    // As in simulate_raw: an explicit control_period wins over the realism's loop period.
    let control_period = control_period.or(realism.and_then(|r| r.control_period));
    let path = trajectory(reference)?;
    let settle = settle_time(settle, &path)?;
    let x0 = vector::<7>("x0", x0)?;
    let config = SimConfig::new(dt, t_final, fall_limit);
    if record_every == 0 {
        return Err(invalid("record_every", 0.0, "must be >= 1").into());
    }
    let run = PlanarRun { plant, terrain, path, settle, x0, config, record_every, realism };
    let (names, (outcome, steps, metrics, log)) =
        if is_user_controller(controller) && PlanarController::extract(controller).is_err() {
            run_user(&run, controller, control_period, dt, "PlanarModel")?
        } else if let Ok(g) = controller.cast::<PyGradeFeedForward>() {
            run_native(py, &run, g.get().core(py, control_period)?)?
        } else {
            let mut ctrl = PlanarController::extract(controller)?;
            if let Some(p) = control_period {
                ctrl = ctrl.with_period(p)?;
            }
            run_native(py, &run, ctrl)?
        };
    let layout = LogLayout {
        states: 7,
        inputs: 2,
        reference_names: <PlanarRef<f64> as LogRow<f64>>::NAMES,
        internal_names: names,
        signal_names: realism.is_some().then_some(&PLANAR_RIG_SIGNALS[..]),
    };
    let summary = metrics.summary();
    let peaks = metrics.drive_peaks(plant.params());
    let named = summary.named().into_iter().chain(peaks.named()).chain([("settle", settle)]);
    run_dict(py, log, &layout, outcome, steps, named)
}
