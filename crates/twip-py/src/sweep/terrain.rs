//! 3-DOF tracking sweeps on terrain (`sweep_planar_raw` and `sweep_planar_draw` with a
//! PlanarModel on a terrain, or a GradeFeedForward): the slope and heading axes redraw the
//! terrain's plane per sample. Sweeps of the PID and sliding-mode trackers (with the grade's
//! feed-forward or without) run on the planar lanes on terrain (kernel "planar-lanes"; through
//! the 3-DOF rig on its terrain, the rig lanes "planar-realism-lanes"), the others on the
//! general runner (core `sweep::terrain`: "planar", "planar-realism").
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::grade::GradeFeedForward;
use twip_core::sim::runner::SimConfig;
use twip_core::sweep::block::{FeedForwardLanes, PidLanes, SmcLanes};
use twip_core::sweep::lanes::LANES;
use twip_core::sweep::planar::{run_planar_lane_samples, run_planar_rig_lane_samples, PlanarNominal, PlanarSample, PlanarSampleMetrics, BLOCK};
use twip_core::sweep::rig::for_sweep;
use twip_core::sweep::terrain::{self as core_terrain, run_terrain_sample, SweepTerrain};
use twip_core::sweep::{Perturbation, SweepMetrics};
use twip_core::control::trajectory::Trajectory;
use twip_core::hardware::realism::Realism;

use crate::control::grade::PyGradeFeedForward;
use crate::convert::vector;
use crate::errors::PyTwipError;
use crate::hardware::realism::PyRealism;
use crate::model::models::PyPlanarModel;
use crate::model::terrain::PyTerrain;
use crate::sim::simulate_planar::PlanarController;
use crate::sweep::{parse_perturbations, run_sweep, PerturbTuple};

/// The tracker of a sweep on terrain: as it is, or with the grade's feed-forward, which each
/// sample gets for its own terrain.
#[allow(clippy::large_enum_variant)]
pub(crate) enum TerrainController {
    Plain(PlanarController),
    Graded(GradeFeedForward<f64, PlanarController>),
}

impl TerrainController {
    pub(crate) fn extract(controller: &Bound<'_, PyAny>, control_period: Option<f64>) -> PyResult<Self> {
        if let Ok(g) = controller.cast::<PyGradeFeedForward>() {
            return Ok(Self::Graded(g.get().core(controller.py(), control_period)?));
        }
        let mut c = PlanarController::extract(controller)?;
        if let Some(p) = control_period {
            c = c.with_period(p)?;
        }
        Ok(Self::Plain(c))
    }

    fn period(&self) -> f64 {
        use twip_core::control::Controller;
        match self {
            Self::Plain(c) => c.period(),
            Self::Graded(g) => g.period(),
        }
    }
}

/// A sweep's terrain: the model's (flat ground, fixed, when only the controller is on
/// terrain: a GradeFeedForward on a flat model).
fn sweep_terrain(model: &PyPlanarModel) -> SweepTerrain {
    model.terrain.as_ref().map_or(SweepTerrain::Fixed(twip_core::model::terrain::Terrain::flat()), PyTerrain::sweep_terrain)
}

/// The perturbations of a sweep on `terrain`, each checked against it.
fn perturbations(tuples: &[PerturbTuple], terrain: &SweepTerrain) -> PyResult<Vec<Perturbation>> {
    let perts = parse_perturbations(tuples, |_| Ok(()))?;
    for p in &perts {
        terrain.validate(p).map_err(PyTwipError)?;
    }
    Ok(perts)
}

fn nominal(model: &PyPlanarModel, x0: &Bound<'_, PyAny>) -> PyResult<PlanarNominal> {
    crate::sweep::no_friction_in_sweeps(model.inner.friction().is_some())?;
    Ok(PlanarNominal { params: *model.inner.params(), x0: vector::<7>("x0", x0)? })
}

/// Sample `index`'s robot, initial state and ground: (slope, heading, terrain), the slope and
/// heading None on a terrain without a plane.
#[allow(clippy::type_complexity)]
pub(crate) fn draw(
    model: &PyPlanarModel,
    x0: &Bound<'_, PyAny>,
    tuples: &[PerturbTuple],
    seed: u64,
    index: u64,
) -> PyResult<(PlanarSample, (Option<f64>, Option<f64>, PyTerrain))> {
    let terrain = sweep_terrain(model);
    let perts = perturbations(tuples, &terrain)?;
    let (sample, ground) = core_terrain::draw(&nominal(model, x0)?, &terrain, &perts, seed, index);
    let drawn = PyTerrain::of_sweep(&terrain, ground, model.terrain.as_ref()).map_err(PyTwipError)?;
    let finite = |v: f64| v.is_finite().then_some(v);
    Ok((sample, (finite(ground[0]), finite(ground[1]), drawn)))
}

/// `sweep_planar_raw` on terrain: samples `start..start + count` on the lanes (PID and
/// sliding mode: kernel "planar-lanes", through the rig "planar-realism-lanes"), else on the
/// general runner (kernel "planar", through the rig "planar-realism").
#[allow(clippy::too_many_arguments)]
pub(crate) fn sweep_raw<'py>(
    py: Python<'py>,
    model: &PyPlanarModel,
    controller: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    (t_final, dt): (f64, f64),
    path: Trajectory<f64>,
    settle: f64,
    tuples: &[PerturbTuple],
    (seed, start, count): (u64, u64, u64),
    control_period: Option<f64>,
    threads: usize,
    progress: Option<Py<PyAny>>,
    realism: Option<&PyRealism>,
) -> PyResult<Bound<'py, PyDict>> {
    let terrain = sweep_terrain(model);
    let nominal = nominal(model, x0)?;
    let perts = perturbations(tuples, &terrain)?;
    let realism = realism.cloned();
    let nominal_realism = realism.as_ref().map(|r| r.to_core(&nominal.params)).transpose().map_err(PyTwipError)?;
    // As in simulate: an explicit control_period wins over the realism's loop period.
    let ctrl = TerrainController::extract(controller, control_period.or(nominal_realism.and_then(|r| r.control_period)))?;
    let config = SimConfig::new(dt, t_final, None);
    config.steps(ctrl.period()).map_err(PyTwipError)?;
    // A rig no robot could have on this terrain is an error now, not n invalid samples.
    let nominal_terrain = terrain.at(terrain.ground()).map_err(PyTwipError)?;
    if let Some(r) = &nominal_realism {
        r.build_planar_on(&model.inner, Some(&nominal_terrain), config.dt).map_err(PyTwipError)?;
    }
    // PID and sliding mode, with the feed-forward or without: on lanes, through the rig or not.
    let (tracker, feed) = match &ctrl {
        TerrainController::Plain(c) => (c, None),
        TerrainController::Graded(g) => (g.inner(), Some(FeedForwardLanes::new(g))),
    };
    let ground = Some((&terrain, feed));
    // Push and force heights default to each sample's own centre of mass.
    let realism_of = |p: &twip_core::RobotParams<f64>| realism.as_ref().expect("realism given").to_core(p).map(|r| for_sweep(&r, seed));
    let lanes_kernel = crate::sweep::planar::kernel_of(tracker, realism.is_some());
    macro_rules! on_lanes {
        ($law:expr) => {{
            let law = $law;
            return run_sweep(py, crate::sweep::sample_range(start, count)?, LANES, threads, progress.as_ref(), lanes_kernel, |range, stop| match &realism {
                None => run_planar_lane_samples(&law, &path, &config, &nominal, &perts, seed, range, settle, stop, ground),
                Some(_) => run_planar_rig_lane_samples(&law, &path, &config, &nominal, &perts, seed, range, settle, &realism_of, stop, ground),
            });
        }};
    }
    match tracker {
        PlanarController::Pid(pid) => on_lanes!(PidLanes::new(pid)),
        PlanarController::Smc(smc) => {
            if let Some(law) = SmcLanes::new(smc) {
                on_lanes!(law)
            }
        }
    }
    let kernel = if realism.is_some() { "planar-realism" } else { "planar" };
    run_sweep(py, crate::sweep::sample_range(start, count)?, BLOCK, threads, progress.as_ref(), kernel, |range, stop| {
        Ok(range
            .map(|i| {
                let (sample, ground) = core_terrain::draw(&nominal, &terrain, &perts, seed, i);
                // Push and force heights default to each sample's own centre of mass.
                let rig: Option<Realism<f64>> = match &realism {
                    None => None,
                    Some(r) => match r.to_core(&sample.params) {
                        Ok(core) => Some(for_sweep(&core, seed)),
                        Err(_) => return Some(PlanarSampleMetrics::INVALID),
                    },
                };
                let rig = rig.as_ref();
                match &ctrl {
                    TerrainController::Plain(c) => run_terrain_sample(|_| *c, &path, &config, &sample, &terrain, ground, settle, rig, stop),
                    TerrainController::Graded(g) => run_terrain_sample(|t| g.on(t.clone()), &path, &config, &sample, &terrain, ground, settle, rig, stop),
                }
            })
            .collect())
    })
}
