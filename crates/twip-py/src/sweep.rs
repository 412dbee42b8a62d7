//! `twip._core.sweep_raw`: samples [start, start + count) of a Monte Carlo sweep on all
//! cores with the GIL released. The calling thread watches: every 25 ms it takes the
//! GIL back for a moment to report progress and to notice Ctrl-C, which stops the
//! workers before their next block (or within 4096 steps of a sample). With a realism
//! every sample runs through the rig (`sweep::rig`), noise stream = sample index.
use std::thread;
use std::time::Duration;

use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::Controller;
use twip_core::params::FIELD_NAMES;
use twip_core::runner::SimConfig;
use twip_core::sweep::lanes::LANES;
use twip_core::sweep::parallel::{self, Progress};
use twip_core::sweep::rig::{for_sweep, noise_seed, run_rig_sample};
use twip_core::sweep::{
    draw, run_lqr_samples, run_slope_sample, Nominal, Perturbation, SampleMetrics, Sample, Spread, Target,
};
use twip_core::TwipError;

use crate::convert::vector;
use crate::errors::PyTwipError;
use crate::models::PySlopeModel;
use crate::realism::PyRealism;
use crate::schedule::PySpeedSchedule;
use crate::simulate::SlopeController;

/// (target, index, kind, a, b, low, high): target "param" | "slope" | "x0";
/// kind "uniform" (a = low, b = high) | "normal" (a = mean, b = std, clamped to [low, high]).
type PerturbTuple = (String, usize, String, f64, f64, f64, f64);

fn perturbation(t: &PerturbTuple) -> Result<Perturbation, PyErr> {
    let (target, index, kind, a, b, low, high) = t;
    let target = match target.as_str() {
        "param" => Target::Param(*index),
        "slope" => Target::Slope,
        "x0" => Target::Initial(*index),
        other => {
            return Err(crate::errors::InvalidParameterError::new_err(format!(
                "perturbation target '{other}': must be 'param', 'slope' or 'x0'"
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
    let p = Perturbation { target, spread };
    p.validate().map_err(PyTwipError)?;
    Ok(p)
}

/// The robot, slope and initial state of sample `index` (to replay it alone).
#[pyfunction]
#[pyo3(signature = (model, x0, perturbations, seed, index))]
pub fn sweep_draw<'py>(
    py: Python<'py>,
    model: &PySlopeModel,
    x0: &Bound<'py, PyAny>,
    perturbations: Vec<PerturbTuple>,
    seed: u64,
    index: u64,
) -> PyResult<(Bound<'py, PyDict>, f64, Bound<'py, numpy::PyArray1<f64>>)> {
    let nominal = Nominal { params: *model.inner.params(), slope: model.inner.slope(), x0: vector::<4>("x0", x0)? };
    let perts = perturbations.iter().map(perturbation).collect::<PyResult<Vec<_>>>()?;
    let s: Sample = draw(&nominal, &perts, seed, index);
    let params = PyDict::new(py);
    for (name, value) in FIELD_NAMES.iter().zip(s.params.to_array()) {
        params.set_item(name, value)?;
    }
    Ok((params, s.slope, crate::convert::to_py_vector(py, &s.x0)))
}

/// The sensor-noise key of a sweep with `seed` (sample i replays with
/// `realism.replace(seed=sweep_noise_seed(seed), stream=i)`).
#[pyfunction]
pub fn sweep_noise_seed(seed: u64) -> u64 {
    noise_seed(seed)
}

/// Runs samples `start..start + count`; returns their metrics as arrays. With `realism`
/// (a `twip.Realism`) each runs through the rig; its seed and stream are replaced by the
/// sweep's (see `sweep_noise_seed`).
#[pyfunction]
#[pyo3(signature = (model, controller, x0, t_final, dt, reference, perturbations, seed, start, count,
                    control_period = None, fall_limit = None, threads = 0, progress = None, realism = None))]
#[allow(clippy::too_many_arguments)]
pub fn sweep_raw<'py>(
    py: Python<'py>,
    model: &PySlopeModel,
    controller: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    t_final: f64,
    dt: f64,
    reference: &PySpeedSchedule,
    perturbations: Vec<PerturbTuple>,
    seed: u64,
    start: u64,
    count: u64,
    control_period: Option<f64>,
    fall_limit: Option<f64>,
    threads: usize,
    progress: Option<Py<PyAny>>,
    realism: Option<&PyRealism>,
) -> PyResult<Bound<'py, PyDict>> {
    let nominal = Nominal { params: *model.inner.params(), slope: model.inner.slope(), x0: vector::<4>("x0", x0)? };
    let mut ctrl = SlopeController::extract(controller)?;
    let realism = realism.cloned();
    let nominal_realism = realism.as_ref().map(|r| r.to_core(&nominal.params)).transpose().map_err(PyTwipError)?;
    // As in simulate: an explicit control_period wins over the realism's loop period.
    if let Some(p) = control_period.or(nominal_realism.and_then(|r| r.control_period)) {
        ctrl = ctrl.with_period(p)?;
    }
    ctrl.check_reference(&reference.inner)?;
    let perts = perturbations.iter().map(perturbation).collect::<PyResult<Vec<_>>>()?;
    let config = SimConfig { dt, t_final, fall_limit: fall_limit.unwrap_or(60f64.to_radians()) };
    config.steps(ctrl.period()).map_err(PyTwipError)?;
    // A rig no robot could have (e.g. dt against the IMU's period) is an error now, not
    // n invalid samples.
    if let Some(r) = &nominal_realism {
        r.build(&model.inner, config.dt).map_err(PyTwipError)?;
    }
    let schedule = reference.inner;
    let watch = Progress::default();
    let mut interrupt: Option<PyErr> = None;
    let kernel = match (&realism, ctrl) {
        (Some(_), _) => "realism",
        (None, SlopeController::Lqr(_)) => "lanes",
        (None, _) => "general",
    };

    let results: Result<Vec<Option<SampleMetrics>>, TwipError> = py.detach(|| {
        thread::scope(|scope| {
            let worker = scope.spawn(|| {
                parallel::run(start..start + count, LANES, threads, &watch, |range, stop| match (&realism, ctrl) {
                    // Push and force heights default to each sample's own centre of mass.
                    (Some(r), c) => range
                        .map(|i| {
                            let sample = draw(&nominal, &perts, seed, i);
                            match r.to_core(&sample.params) {
                                Ok(core) => run_rig_sample(&c, &schedule, &config, &sample, &for_sweep(&core, seed), stop),
                                Err(_) => Some(SampleMetrics::INVALID),
                            }
                        })
                        .collect(),
                    (None, SlopeController::Lqr(c)) => {
                        run_lqr_samples(&c, &schedule, &config, &nominal, &perts, seed, range, stop).ok().flatten()
                    }
                    (None, other) => range
                        .map(|i| run_slope_sample(&other, &schedule, &config, &draw(&nominal, &perts, seed, i), stop))
                        .collect(),
                })
            });
            while !worker.is_finished() {
                thread::sleep(Duration::from_millis(25));
                Python::attach(|py| {
                    if interrupt.is_none() {
                        if let Err(e) = py.check_signals() {
                            interrupt = Some(e);
                            watch.stop.store(true, std::sync::atomic::Ordering::Relaxed);
                        }
                    }
                    if let Some(callback) = &progress {
                        let done = watch.done.load(std::sync::atomic::Ordering::Relaxed);
                        if let Err(e) = callback.call1(py, (done,)) {
                            interrupt.get_or_insert(e);
                            watch.stop.store(true, std::sync::atomic::Ordering::Relaxed);
                        }
                    }
                });
            }
            worker.join().unwrap_or(Ok(Vec::new()))
        })
    });
    let results = results.map_err(PyTwipError)?;

    let n = results.len();
    let pick = |f: fn(&SampleMetrics) -> f64| -> Vec<f64> {
        results.iter().map(|r| r.as_ref().map_or(f64::NAN, f)).collect()
    };
    let out = PyDict::new(py);
    out.set_item("index", (start..start + n as u64).collect::<Vec<u64>>().into_pyarray(py))?;
    out.set_item("done", results.iter().map(|r| r.is_some()).collect::<Vec<bool>>().into_pyarray(py))?;
    out.set_item("valid", results.iter().map(|r| r.is_some_and(|m| m.valid)).collect::<Vec<bool>>().into_pyarray(py))?;
    out.set_item("fell", results.iter().map(|r| r.is_some_and(|m| m.fell)).collect::<Vec<bool>>().into_pyarray(py))?;
    out.set_item("steps", results.iter().map(|r| r.map_or(0, |m| m.steps)).collect::<Vec<u64>>().into_pyarray(py))?;
    out.set_item("t_end", pick(|m| m.t_end).into_pyarray(py))?;
    out.set_item("mean_abs_pitch_error", pick(|m| m.mean_abs_pitch_error).into_pyarray(py))?;
    out.set_item("mean_abs_speed_error", pick(|m| m.mean_abs_speed_error).into_pyarray(py))?;
    out.set_item("pitch_settling_time", pick(|m| m.pitch_settling_time).into_pyarray(py))?;
    out.set_item("speed_settling_time", pick(|m| m.speed_settling_time).into_pyarray(py))?;
    out.set_item("final_position_error", pick(|m| m.final_position_error).into_pyarray(py))?;
    out.set_item("peak_abs_input", pick(|m| m.peak_abs_input).into_pyarray(py))?;
    out.set_item("kernel", kernel)?;
    out.set_item("interrupted", interrupt.is_some())?;
    if let Some(e) = interrupt {
        // KeyboardInterrupt is re-raised by the Python layer once what finished is kept;
        // any other error (from the progress callback) is raised now.
        if !e.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) {
            return Err(e);
        }
    }
    Ok(out)
}
