//! `twip._core.sweep_raw`: samples [start, start + count) of a Monte Carlo sweep on all
//! cores with the GIL released. The calling thread watches: every 25 ms it takes the
//! GIL back for a moment to report progress and to notice Ctrl-C, which stops the
//! workers before their next block (or within 4096 steps of a sample). With a realism
//! every sample runs through the rig (`sweep::rig`), noise stream = sample index. The
//! watcher, the perturbation tuples and the result's layout are shared with `sweep_planar`.
pub mod planar;
pub mod terrain;

use std::ops::Range;
use std::sync::atomic::Ordering;
use std::thread;
use std::time::Duration;

use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::Controller;
use twip_core::sim::runner::SimConfig;
use twip_core::sweep::lanes::LANES;
use twip_core::sweep::parallel::{self, Progress};
use twip_core::sweep::block::{FuzzyLanes, KernelCopy};
use twip_core::sweep::block::LqrLanes;
use twip_core::sweep::rig::{for_sweep, noise_seed, run_rig_lane_samples};
use twip_core::sweep::{
    draw, run_lane_samples, run_lqr_samples, Nominal, Perturbation, Sample, Spread, SweepMetrics,
    Target,
};
use twip_core::{RobotParams, TwipError};

use crate::convert::{int, vector, Int, Real};
use crate::errors::{key, InvalidParameterError, PyTwipError};
use crate::model::params::params_dict;
use crate::model::models::PySlopeModel;
use crate::hardware::realism::PyRealism;
use crate::control::schedule::PySpeedSchedule;
use crate::sim::simulate::SlopeController;

/// (target, index, kind, a, b, low, high): target "param" | "slope" | "heading" | "x0";
/// kind "uniform" (a = low, b = high) | "normal" (a = mean, b = std, clamped to [low, high]).
pub(crate) type PerturbTuple = (String, Int<usize>, String, Real, Real, Real, Real);

/// The perturbations, each checked by `validate` (the sweep family's own rules).
pub(crate) fn parse_perturbations(
    tuples: &[PerturbTuple],
    validate: fn(&Perturbation) -> Result<(), TwipError>,
) -> PyResult<Vec<Perturbation>> {
    tuples
        .iter()
        .map(|t| {
            let p = perturbation(t)?;
            validate(&p).map_err(PyTwipError)?;
            Ok(p)
        })
        .collect()
}

fn perturbation(t: &PerturbTuple) -> Result<Perturbation, PyErr> {
    let (target, Int(index), kind, Real(a), Real(b), Real(low), Real(high)) = t;
    let target = match target.as_str() {
        "param" => Target::Param(*index),
        "slope" => Target::Slope,
        "heading" => Target::Heading,
        "x0" => Target::Initial(*index),
        other => {
            return Err(crate::errors::InvalidParameterError::new_err(format!(
                "perturbation target '{other}': must be 'param', 'slope', 'heading' or 'x0'"
            )))
        }
    };
    let spread = match kind.as_str() {
        "uniform" => Spread::Uniform { low: *a, high: *b },
        "normal" => Spread::Normal { mean: *a, std: *b, low: *low, high: *high },
        other => {
            return Err(crate::errors::InvalidParameterError::new_err(format!(
                "distribution '{other}': must be 'uniform' or 'normal'"
            )))
        }
    };
    Ok(Perturbation { target, spread })
}

/// Runs `work` on a thread of its own with the GIL released while the calling thread
/// watches: every 25 ms it takes the GIL back for a moment to pass `watch.done` to
/// `progress` and to notice Ctrl-C; either one failing sets `watch.stop`. Returns what
/// `work` returned (`None` if it panicked) and the error to raise, if any.
fn watched<R: Send>(
    py: Python<'_>,
    watch: &Progress,
    progress: Option<&Py<PyAny>>,
    work: impl FnOnce() -> R + Send,
) -> (Option<R>, Option<PyErr>) {
    let mut interrupt: Option<PyErr> = None;
    let out = py.detach(|| {
        thread::scope(|scope| {
            let worker = scope.spawn(work);
            // Short work (a small shard) is not held up by the poll: the first waits are short.
            let mut wait = Duration::from_micros(250);
            while !worker.is_finished() {
                thread::sleep(wait);
                wait = (wait * 2).min(Duration::from_millis(25));
                Python::attach(|py| {
                    if interrupt.is_none() {
                        if let Err(e) = py.check_signals() {
                            interrupt = Some(e);
                            watch.stop.store(true, Ordering::Relaxed);
                        }
                    }
                    if let Some(callback) = progress {
                        let done = watch.done.load(Ordering::Relaxed);
                        if let Err(e) = callback.call1(py, (done,)) {
                            interrupt.get_or_insert(e);
                            watch.stop.store(true, Ordering::Relaxed);
                        }
                    }
                });
            }
            worker.join().ok()
        })
    });
    (out, interrupt)
}

/// Runs samples `samples` of a sweep in blocks of `block` on `threads` threads (0 = all
/// cores) with the GIL released, watched as [`watched`] says, and returns the result as
/// [`result_dict`] lays it out. `run_block` is [`parallel::run`]'s.
/// Samples `start..start + count`, or an error naming `count` when the end would pass
/// the last index a sample can have (it wrapped to an empty range).
pub(crate) fn sample_range(start: u64, count: u64) -> PyResult<Range<u64>> {
    let end = start.checked_add(count).ok_or(PyTwipError(TwipError::InvalidParameter {
        name: "count",
        value: count as f64,
        reason: "start + count passes the last sample index, 2^64 - 1",
    }))?;
    Ok(start..end)
}

pub(crate) fn run_sweep<'py, M, F>(
    py: Python<'py>,
    samples: Range<u64>,
    block: usize,
    threads: usize,
    progress: Option<&Py<PyAny>>,
    kernel: &str,
    run_block: F,
) -> PyResult<Bound<'py, PyDict>>
where
    M: SweepMetrics,
    F: Fn(Range<u64>, &dyn Fn() -> bool) -> Result<Option<Vec<M>>, TwipError> + Send + Sync,
{
    let start = samples.start;
    let watch = Progress::default();
    let (results, interrupt) = watched(py, &watch, progress, || parallel::run(samples, block, threads, &watch, run_block));
    let results = results.transpose().map_err(PyTwipError)?;
    result_dict(py, start, results, kernel, interrupt)
}

/// The result of samples `start..` as a dict of arrays: index, done, valid, fell, steps and
/// the float metrics `M::NAMES` (NaN where not done); "metric_names" lists "fell" and
/// those; "kernel", "interrupted". A KeyboardInterrupt is left for the Python layer to
/// raise once what finished is kept; any other error (the progress callback's) is raised.
fn result_dict<'py, M: SweepMetrics>(
    py: Python<'py>,
    start: u64,
    results: Option<Vec<Option<M>>>,
    kernel: &str,
    interrupt: Option<PyErr>,
) -> PyResult<Bound<'py, PyDict>> {
    let interrupted = match interrupt {
        Some(e) if !e.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) => return Err(e),
        other => other.is_some(),
    };
    let results = results.ok_or_else(|| pyo3::exceptions::PyRuntimeError::new_err("a sweep worker thread panicked"))?;
    let out = PyDict::new(py);
    let n = results.len() as u64;
    out.set_item("index", column(n, start..start + n)?.into_pyarray(py))?;
    out.set_item("done", column(n, results.iter().map(|r| r.is_some()))?.into_pyarray(py))?;
    out.set_item("valid", column(n, results.iter().map(|r| r.is_some_and(|m| m.valid())))?.into_pyarray(py))?;
    out.set_item("fell", column(n, results.iter().map(|r| r.is_some_and(|m| m.fell())))?.into_pyarray(py))?;
    out.set_item("steps", column(n, results.iter().map(|r| r.map_or(0, |m| m.steps())))?.into_pyarray(py))?;
    for (i, name) in M::NAMES.iter().enumerate() {
        out.set_item(name, column(n, results.iter().map(|r| r.map_or(f64::NAN, |m| m.value(i))))?.into_pyarray(py))?;
    }
    let names: Vec<&str> = core::iter::once("fell").chain(M::NAMES.iter().copied()).collect();
    out.set_item("metric_names", names)?;
    out.set_item("kernel", kernel)?;
    out.set_item("interrupted", interrupted)?;
    Ok(out)
}

/// Sweeps draw robots from parameters alone: refuse a model with gearhead friction
/// rather than drop it in silence (the rig carries friction: `Realism(friction=...)`).
pub(crate) fn no_friction_in_sweeps(has_friction: bool) -> PyResult<()> {
    if has_friction {
        return Err(crate::errors::InvalidParameterError::new_err(
            "model.friction: sweeps draw robots from parameters alone and do not carry a model's gearhead \
             friction; give it as realism=twip.Realism(friction=...) or use a model without friction",
        ));
    }
    Ok(())
}

/// Refuses a model a sweep cannot carry (one with gearhead friction), before the sweep
/// touches anything (`montecarlo` asks before its checkpoint folder).
#[pyfunction]
pub fn check_sweep_model(model: &Bound<'_, PyAny>) -> PyResult<()> {
    let has_friction = match model.extract::<PyRef<'_, PySlopeModel>>() {
        Ok(m) => m.inner.friction().is_some(),
        Err(_) => model.extract::<PyRef<'_, crate::model::models::PyPlanarModel>>()?.inner.friction().is_some(),
    };
    no_friction_in_sweeps(has_friction)
}

/// One metric column of `n` samples, reserved fallibly: a MemoryError naming `n`, not an abort.
fn column<T>(n: u64, values: impl Iterator<Item = T>) -> PyResult<Vec<T>> {
    let mut out = Vec::new();
    out.try_reserve_exact(n as usize).map_err(|_| {
        PyTwipError(TwipError::OutOfMemory { name: "n", bytes: n.saturating_mul(core::mem::size_of::<T>() as u64) })
    })?;
    out.extend(values);
    Ok(out)
}

/// The robot, slope and initial state of sample `index` (to replay it alone).
#[pyfunction]
#[pyo3(signature = (model, x0, perturbations, seed, index))]
pub fn sweep_draw<'py>(
    py: Python<'py>,
    model: &PySlopeModel,
    x0: &Bound<'py, PyAny>,
    perturbations: Vec<PerturbTuple>,
    seed: &Bound<'py, PyAny>,
    index: &Bound<'py, PyAny>,
) -> PyResult<(Bound<'py, PyDict>, f64, Bound<'py, numpy::PyArray1<f64>>)> {
    let (seed, index) = (key("seed", seed)?, key("index", index)?);
    no_friction_in_sweeps(model.inner.friction().is_some())?;
    let nominal = Nominal { params: *model.inner.params(), slope: model.inner.slope(), x0: vector::<4>("x0", x0)? };
    let perts = parse_perturbations(&perturbations, Perturbation::validate)?;
    let s: Sample = draw(&nominal, &perts, seed, index);
    let params = params_dict(py, &s.params)?;
    Ok((params, s.slope, crate::convert::to_py_vector(py, &s.x0)))
}

/// Everything a controller is (gains, model, period, fuzzy sets, initial weights, ...),
/// as text: what a sweep's checkpoint fingerprints, so that any change is noticed.
#[pyfunction]
pub fn controller_fingerprint(controller: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(g) = controller.cast::<crate::control::grade::PyGradeFeedForward>() {
        return Ok(format!("{:?}", g.get().core(controller.py(), None)?));
    }
    match SlopeController::extract(controller) {
        Ok(c) => Ok(format!("{c:?}")),
        Err(_) => Ok(format!("{:?}", crate::sim::simulate_planar::PlanarController::extract(controller)?)),
    }
}

/// The sensor-noise key of a sweep with `seed` (sample i replays with
/// `realism.replace(seed=sweep_noise_seed(seed), stream=i)`).
#[pyfunction]
pub fn sweep_noise_seed(seed: &Bound<'_, PyAny>) -> PyResult<u64> {
    Ok(noise_seed(key("seed", seed)?))
}

/// Runs samples `start..start + count`; returns their metrics as arrays. With `realism`
/// (a `twip.Realism`) each runs through the rig; its seed and stream are replaced by the
/// sweep's (see `sweep_noise_seed`).
#[pyfunction]
#[pyo3(signature = (model, controller, x0, t_final, dt, reference, perturbations, seed, start, count,
                    control_period = None, threads = 0, progress = None, realism = None))]
#[allow(clippy::too_many_arguments)]
pub fn sweep_raw<'py>(
    py: Python<'py>,
    model: &PySlopeModel,
    controller: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    t_final: Real,
    dt: Real,
    reference: &PySpeedSchedule,
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
    no_friction_in_sweeps(model.inner.friction().is_some())?;
    let (seed, start, count) = (key("seed", seed)?, key("start", start)?, key("count", count)?);
    let nominal = Nominal { params: *model.inner.params(), slope: model.inner.slope(), x0: vector::<4>("x0", x0)? };
    let mut ctrl = SlopeController::extract(controller)?;
    let realism = realism.cloned();
    let nominal_realism = realism.as_ref().map(|r| r.to_core(&nominal.params)).transpose().map_err(PyTwipError)?;
    // As in simulate: an explicit control_period wins over the realism's loop period.
    if let Some(p) = control_period.or(nominal_realism.and_then(|r| r.control_period)) {
        ctrl = ctrl.with_period(p)?;
    }
    ctrl.check_reference(&reference.inner)?;
    let perts = parse_perturbations(&perturbations, Perturbation::validate)?;
    // The default fall limit, as `twip.simulate`'s: `SweepResult.replay` must agree.
    let config = SimConfig::new(dt, t_final, None);
    config.steps(ctrl.period()).map_err(PyTwipError)?;
    // A rig no robot could have (e.g. dt against the IMU's period) is an error now, not
    // n invalid samples.
    if let Some(r) = &nominal_realism {
        r.build(&model.inner, config.dt).map_err(PyTwipError)?;
    }
    let schedule = reference.inner;
    let kernel = kernel_of(realism.is_some());
    run_sweep(py, sample_range(start, count)?, LANES, threads, progress.as_ref(), kernel, |range, stop| {
        // Push and force heights default to each sample's own centre of mass.
        let realism_of = |p: &RobotParams<f64>| realism.as_ref().expect("realism given").to_core(p).map(|r| for_sweep(&r, seed));
        match (&realism, ctrl) {
            (Some(_), SlopeController::Lqr(c)) => run_rig_lane_samples(&LqrLanes::new(&c), &schedule, &config, &nominal, &perts, seed, range, &realism_of, stop),
            (Some(_), SlopeController::Fuzzy(c)) => run_rig_lane_samples(&FuzzyLanes::new(&c), &schedule, &config, &nominal, &perts, seed, range, &realism_of, stop),
            (None, SlopeController::Lqr(c)) => run_lqr_samples(&c, &schedule, &config, &nominal, &perts, seed, range, stop),
            (None, SlopeController::Fuzzy(c)) => run_lane_samples(&FuzzyLanes::new(&c), &schedule, &config, &nominal, &perts, seed, range, stop),
        }
    })
}

/// The kernel a 2-DOF sweep runs on: every built-in law (LQR, fuzzy with any sets) is on
/// lanes, "lanes" without a rig and "realism-lanes" through one.
fn kernel_of(through_rig: bool) -> &'static str {
    if through_rig {
        "realism-lanes"
    } else {
        "lanes"
    }
}

/// Which copy of the sweeps' lane kernels runs: "avx512" (x86-64 with AVX-512 and FMA),
/// "avx2" (AVX2 and FMA) or "baseline"; the widest this CPU has, unless `use_kernel_copy`
/// chose a narrower one. Every copy gives the same numbers, at its own speed: name it
/// beside any throughput you quote.
#[pyfunction]
pub fn kernel_copy() -> &'static str {
    KernelCopy::active().name()
}

/// The copies of the lane kernels this process can run, widest first: those this CPU has
/// instructions for and this build holds (a wheel `make` built on a CPU with AVX2 and FMA
/// holds no "baseline" copy; one for any x86-64 CPU does).
#[pyfunction]
pub fn available_kernel_copies() -> Vec<&'static str> {
    KernelCopy::ALL.into_iter().filter(|c| c.runs_here() && c.compiled()).map(KernelCopy::name).collect()
}

/// Refuses a build without the copy this CPU runs (an x86-64 CPU without AVX2 or FMA, and a
/// wheel built without the baseline copy): the module's import fails with this, before any
/// sweep could reach the missing copy.
pub fn check_kernel_copy() -> PyResult<()> {
    let widest = KernelCopy::detect();
    if widest.compiled() {
        return Ok(());
    }
    Err(pyo3::exceptions::PyImportError::new_err(format!(
        "this build of twip holds no {:?} kernel copy, which this CPU (no AVX2 or FMA) needs: it was built for \
         CPUs with AVX2 and FMA (`make` on such a CPU). Build it with every copy: `make build KERNEL_COPIES=all`, \
         or `pip install .`",
        widest.name()
    )))
}

/// Makes this process's sweeps run the lane kernels' copy `name` ("avx512", "avx2" or
/// "baseline"; None: the widest this CPU has), to measure what a CPU without the wider
/// instructions gets. The numbers are the same on every copy. Returns the copy that now
/// runs. A copy this CPU has no instructions for, or this build does not hold
/// (`available_kernel_copies`), is refused (`InvalidParameterError`). `import twip` applies the
/// environment variable `TWIP_KERNEL_COPY` this way.
#[pyfunction]
#[pyo3(signature = (name))]
pub fn use_kernel_copy(name: Option<&str>) -> PyResult<&'static str> {
    let names = KernelCopy::ALL.map(KernelCopy::name);
    let copy = match name {
        None => None,
        Some(n) => Some(KernelCopy::ALL.into_iter().find(|c| c.name() == n).ok_or_else(|| {
            InvalidParameterError::new_err(format!("invalid kernel copy {n:?}: must be one of {names:?} or None"))
        })?),
    };
    KernelCopy::choose(copy).map(KernelCopy::name).map_err(|widest| {
        let name = name.unwrap_or_default();
        let why = match copy {
            Some(c) if !c.compiled() => format!("this build of twip does not hold it (it holds {:?})", available_kernel_copies()),
            _ => format!("this CPU has no instructions for it (its widest copy is {:?})", widest.name()),
        };
        InvalidParameterError::new_err(format!("invalid kernel copy {name:?}: {why}"))
    })
}

/// The core's kernel for a sweep of `controller` (a built-in 2-DOF or 3-DOF controller),
/// with `realism` (a `twip.Realism`) or without (None): "lanes", "realism-lanes",
/// "planar-lanes", "planar-realism-lanes", "planar" or "planar-realism".
#[pyfunction]
#[pyo3(signature = (controller, realism = None))]
pub fn sweep_kernel(controller: &Bound<'_, PyAny>, realism: Option<&PyRealism>) -> PyResult<&'static str> {
    if SlopeController::extract(controller).is_ok() {
        return Ok(kernel_of(realism.is_some()));
    }
    // With the grade's feed-forward: a sweep on terrain, its tracker's lanes (through the
    // rig or not).
    if let Ok(g) = controller.cast::<crate::control::grade::PyGradeFeedForward>() {
        let ff = g.get().core(controller.py(), None)?;
        return Ok(crate::sweep::planar::kernel_of(ff.inner(), realism.is_some()));
    }
    let ctrl = crate::sim::simulate_planar::PlanarController::extract(controller)?;
    Ok(crate::sweep::planar::kernel_of(&ctrl, realism.is_some()))
}
