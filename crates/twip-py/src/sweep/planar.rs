//! `twip._core.sweep_planar_raw`: samples [start, start + count) of a 3-DOF tracking
//! sweep on all cores, the GIL released and watched as `sweep_raw` does (progress,
//! Ctrl-C); `sweep_planar_draw` gives one sample's robot and initial state to replay it.
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::Controller;
use twip_core::sim::runner::SimConfig;
use twip_core::sweep::block::{PidLanes, SmcLanes};
use twip_core::sweep::lanes::LANES;
use twip_core::sweep::planar::{
    self as core_planar, run_planar_lane_samples, run_planar_rig_lane_samples, run_planar_sample, PlanarNominal, PlanarSampleMetrics, BLOCK,
};
use twip_core::RobotParams;
use twip_core::sweep::SweepMetrics;
use twip_core::sweep::rig::for_sweep;

use crate::hardware::realism::PyRealism;

use crate::convert::{int, vector, Real};
use crate::errors::{key, PyTwipError};
use crate::model::params::params_dict;
use crate::model::models::PyPlanarModel;
use crate::sweep::{parse_perturbations, run_sweep, PerturbTuple};
use crate::sim::simulate_planar::{settle_time, PlanarController};
use crate::control::trajectory::trajectory;

pub(crate) fn nominal(model: &PyPlanarModel, x0: &Bound<'_, PyAny>) -> PyResult<PlanarNominal> {
    crate::sweep::no_friction_in_sweeps(model.flat_only("a sweep")?.friction().is_some())?;
    Ok(PlanarNominal { params: *model.inner.params(), x0: vector::<7>("x0", x0)? })
}

/// The robot, initial state and ground of sample `index` (to replay it alone): the ground
/// None on flat ground, else (slope, heading, terrain) drawn (slope and heading None on a
/// terrain without a plane).
#[pyfunction]
#[pyo3(signature = (model, x0, perturbations, seed, index))]
pub fn sweep_planar_draw<'py>(
    py: Python<'py>,
    model: &PyPlanarModel,
    x0: &Bound<'py, PyAny>,
    perturbations: Vec<PerturbTuple>,
    seed: &Bound<'py, PyAny>,
    index: &Bound<'py, PyAny>,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyArray1<f64>>, Option<Ground>)> {
    let (seed, index) = (key("seed", seed)?, key("index", index)?);
    let (s, ground) = if model.terrain.is_some() {
        let (s, ground) = crate::sweep::terrain::draw(model, x0, &perturbations, seed, index)?;
        (s, Some(ground))
    } else {
        let perts = parse_perturbations(&perturbations, core_planar::validate)?;
        (core_planar::draw(&nominal(model, x0)?, &perts, seed, index), None)
    };
    let params = params_dict(py, &s.params)?;
    Ok((params, crate::convert::to_py_vector(py, &s.x0), ground))
}

/// A sample's drawn slope, uphill heading and terrain.
type Ground = (Option<f64>, Option<f64>, crate::model::terrain::PyTerrain);

/// Runs samples `start..start + count` of a tracker on perturbed planar robots along
/// `reference`; returns their metrics as arrays ("_settled" ones after one lap of a
/// closed path, else from the start: `simulate_planar_raw`'s default).
#[pyfunction]
#[pyo3(signature = (model, controller, x0, t_final, dt, reference, perturbations, seed, start, count,
                    control_period = None, threads = 0, progress = None, realism = None))]
#[allow(clippy::too_many_arguments)]
pub fn sweep_planar_raw<'py>(
    py: Python<'py>,
    model: &PyPlanarModel,
    controller: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    t_final: Real,
    dt: Real,
    reference: &Bound<'py, PyAny>,
    perturbations: Vec<PerturbTuple>,
    seed: &Bound<'py, PyAny>,
    start: &Bound<'py, PyAny>,
    count: &Bound<'py, PyAny>,
    control_period: Option<Real>,
    #[pyo3(from_py_with = int::<usize>)] threads: usize,
    progress: Option<Py<PyAny>>,
    realism: Option<&PyRealism>,
) -> PyResult<Bound<'py, PyDict>> {
    let (t_final, dt, control_period) = (t_final.0, dt.0, control_period.map(|p| p.0));
    let (seed, start, count) = (key("seed", seed)?, key("start", start)?, key("count", count)?);
    if model.terrain.is_some() || controller.cast::<crate::control::grade::PyGradeFeedForward>().is_ok() {
        let path = trajectory(reference)?;
        let settle = settle_time(None, &path)?;
        return crate::sweep::terrain::sweep_raw(
            py, model, controller, x0, (t_final, dt), path, settle, &perturbations, (seed, start, count), control_period, threads, progress, realism,
        );
    }
    let nominal = nominal(model, x0)?;
    let mut ctrl = PlanarController::extract(controller)?;
    let realism = realism.cloned();
    let nominal_realism = realism.as_ref().map(|r| r.to_core(&nominal.params)).transpose().map_err(PyTwipError)?;
    // As in simulate: an explicit control_period wins over the realism's loop period.
    if let Some(p) = control_period.or(nominal_realism.and_then(|r| r.control_period)) {
        ctrl = ctrl.with_period(p)?;
    }
    let path = trajectory(reference)?;
    let settle = settle_time(None, &path)?;
    let perts = parse_perturbations(&perturbations, core_planar::validate)?;
    // The defaults of `twip.simulate`, so that `SweepResult.replay` agrees.
    let config = SimConfig::new(dt, t_final, None);
    config.steps(ctrl.period()).map_err(PyTwipError)?;
    // A rig no robot could have is an error now, not n invalid samples.
    if let Some(r) = &nominal_realism {
        r.build_planar(&model.inner, config.dt).map_err(PyTwipError)?;
    }
    let kernel = kernel_of(&ctrl, realism.is_some());
    // Push and force heights default to each sample's own centre of mass.
    let realism_of = |p: &RobotParams<f64>| realism.as_ref().expect("realism given").to_core(p).map(|r| for_sweep(&r, seed));
    // The trackers with a law on lanes: LANES samples at a time, through the rig or not.
    macro_rules! on_lanes {
        ($law:expr) => {{
            let law = $law;
            return run_sweep(py, super::sample_range(start, count)?, LANES, threads, progress.as_ref(), kernel, |range, stop| match &realism {
                None => run_planar_lane_samples(&law, &path, &config, &nominal, &perts, seed, range, settle, stop, None),
                Some(_) => run_planar_rig_lane_samples(&law, &path, &config, &nominal, &perts, seed, range, settle, &realism_of, stop, None),
            });
        }};
    }
    match &ctrl {
        PlanarController::Pid(pid) => on_lanes!(PidLanes::new(pid)),
        PlanarController::Smc(smc) => {
            if let Some(law) = SmcLanes::new(smc) {
                on_lanes!(law)
            }
        }
    }
    run_sweep(py, super::sample_range(start, count)?, BLOCK, threads, progress.as_ref(), kernel, |range, stop| {
        Ok(range
            .map(|i| {
                let sample = core_planar::draw(&nominal, &perts, seed, i);
                // Push and force heights default to each sample's own centre of mass.
                let Some(r) = &realism else {
                    return run_planar_sample(&ctrl, &path, &config, &sample, settle, None, stop);
                };
                match r.to_core(&sample.params) {
                    Ok(core) => run_planar_sample(&ctrl, &path, &config, &sample, settle, Some(&for_sweep(&core, seed)), stop),
                    Err(_) => Some(PlanarSampleMetrics::INVALID),
                }
            })
            .collect())
    })
}

/// The kernel a 3-DOF sweep of this tracker runs on: "planar-lanes" and through a rig
/// "planar-realism-lanes" (PID, and sliding mode unless its own model has friction without
/// adaptation: vectorised), else "planar" and "planar-realism" (the general runner).
pub(crate) fn kernel_of(ctrl: &PlanarController, realism: bool) -> &'static str {
    let on_lanes = match ctrl {
        PlanarController::Pid(_) => true,
        PlanarController::Smc(c) => SmcLanes::new(c).is_some(),
    };
    match (realism, on_lanes) {
        (false, true) => "planar-lanes",
        (true, true) => "planar-realism-lanes",
        (false, false) => "planar",
        (true, false) => "planar-realism",
    }
}
