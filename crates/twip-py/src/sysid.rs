//! `_core.sysid_shoot`: the multiple-shooting predictions of a logged run for many robots
//! at once (the finite-difference columns of the estimator's Jacobian), on all cores.
use nalgebra::Vector4;
use numpy::{IntoPyArray, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use twip_core::hardware::driver::Driven;
use twip_core::sysid::parallel::{run_all, Prediction};
use twip_core::hardware::backlash::{Backlash, GearEvent};
use twip_core::sysid::geared::geared;
use twip_core::sysid::Shooting;
use twip_core::{SlopeModel, TwipError};

use crate::errors::PyTwipError;
use crate::model::models::PySlopeModel;
use crate::hardware::realism::PyMotorDriver;

type Out<'py> = (Bound<'py, PyArray3<f64>>, Bound<'py, PyArray3<f64>>, Bound<'py, PyArray3<f64>>, Bound<'py, PyArray3<f64>>);

/// Predicts the log for each of `models` (K SlopeModels) from its own start states
/// `starts` [K, segments, 4]: returns (states, rates), each [K, n, 4], and each segment's
/// state carried on to the next segment's first sample, [K, segments, 4] (NaN for the
/// last). `u[i]` is held over
/// [t_i, t_i+1): the lumped current [A], or with `drivers` (one MotorDriver per model) the
/// PWM duty [counts]. A driver with inductance carries its winding's current along each
/// segment, and each RK4 stage feels it within the step, as `simulate` does (from the
/// steady current of the duty held before the segment's first sample); without, the
/// current is algebraic. The fourth array, [K, n, 2], is what the sensors see besides the
/// state: the motor shafts' offset from the wheels (the encoder counts the shaft) and the
/// pitch rate the IMU samples. With `backlash` (each gear train's play at the wheel [rad])
/// the models' gear trains have play, as the rig's (`Realism(backlash=)`): the first run
/// carries each segment's play on from the previous segment's end and records its impacts
/// and openings, step by step; the others start each segment from the first run's play and
/// replay its events (a finite difference holds the impacts' schedule; `run_all`).
#[pyfunction]
#[pyo3(signature = (models, starts, t, u, segments, max_step = 1e-3, drivers = None, backlash = None))]
#[allow(clippy::too_many_arguments)]
pub fn sysid_shoot<'py>(
    py: Python<'py>,
    models: Vec<PyRef<'py, PySlopeModel>>,
    starts: PyReadonlyArray3<'py, f64>,
    t: PyReadonlyArray1<'py, f64>,
    u: PyReadonlyArray1<'py, f64>,
    segments: PyReadonlyArray1<'py, i64>,
    max_step: f64,
    drivers: Option<Vec<PyRef<'py, PyMotorDriver>>>,
    backlash: Option<f64>,
) -> PyResult<Out<'py>> {
    let (t, u) = (t.as_slice()?, u.as_slice()?);
    let segments: Vec<usize> = segments
        .as_array()
        .iter()
        .map(|&s| usize::try_from(s).map_err(|_| PyTwipError(invalid("segments", s as f64, "must be >= 0"))))
        .collect::<Result<_, _>>()?;
    let shooting = Shooting::new(t, u, &segments, max_step).map_err(PyTwipError)?;
    let k = models.len();
    let shape = starts.shape();
    if shape != [k, segments.len(), 4] {
        let got = (shape[0], shape[1]);
        return Err(PyTwipError(TwipError::Shape { name: "starts", expected: (k, segments.len()), got }).into());
    }
    let starts: Vec<Vec<Vector4<f64>>> = starts
        .as_array()
        .outer_iter()
        .map(|run| run.outer_iter().map(|s| Vector4::new(s[0], s[1], s[2], s[3])).collect())
        .collect();
    let n = shooting.samples();
    // One gear event per plant step, with play (`Shooting::plant_steps`).
    let events = if backlash.is_some() { shooting.plant_steps() } else { 0 };
    let mut out = buffer(k, n, segments.len(), events)?;
    let plants: Vec<SlopeModel<f64>> = models.iter().map(|m| m.inner).collect();
    if let Some(d) = &drivers {
        if d.len() != k {
            let got = (d.len(), 1);
            return Err(PyTwipError(TwipError::Shape { name: "drivers", expected: (k, 1), got }).into());
        }
    }
    let drivers: Option<Vec<_>> = drivers.map(|d| d.iter().map(|d| d.inner).collect());
    match (backlash, drivers) {
        (Some(gap), drivers) => {
            let play = Backlash { gap }.validate().map_err(PyTwipError)?;
            let geared = plants
                .iter()
                .enumerate()
                .map(|(i, p)| geared(p, drivers.as_ref().map(|d| &d[i]), play))
                .collect::<Result<Vec<_>, _>>()
                .map_err(PyTwipError)?;
            py.detach(|| run_all(&shooting, &geared, &starts, &mut out))
        }
        (None, None) => py.detach(|| run_all(&shooting, &plants, &starts, &mut out)),
        (None, Some(drivers)) => {
            let driven = plants
                .iter()
                .zip(&drivers)
                .map(|(p, d)| Driven::new(*p, d, p.params()))
                .collect::<Result<Vec<_>, _>>()
                .map_err(PyTwipError)?;
            py.detach(|| run_all(&shooting, &driven, &starts, &mut out))
        }
    }
    .map_err(PyTwipError)?;
    let segments = segments.len();
    let states = to_array(py, out.iter().map(|p| &p.states), n)?;
    let rates = to_array(py, out.iter().map(|p| &p.rates), n)?;
    let ends = to_array(py, out.iter().map(|p| &p.ends), segments)?;
    let flat: Vec<f64> = out.iter().flat_map(|p| p.sensed.iter().flatten().copied()).collect();
    let sensed = flat.into_pyarray(py).reshape([k, n, 2])?;
    Ok((states, rates, ends, sensed))
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> TwipError {
    TwipError::InvalidParameter { name, value, reason }
}

/// k runs of n states (and as many rates, one end per segment, and `events` gear events),
/// reserved fallibly: a MemoryError naming the size, not an abort.
fn buffer(k: usize, n: usize, segments: usize, events: usize) -> PyResult<Vec<Prediction>> {
    // A gear event is 2 bytes, a row 32.
    let rows = (n as u64).saturating_mul(3).saturating_add(segments as u64 * 2).saturating_add(events as u64 / 16);
    let bytes = (k as u64).saturating_mul(rows).saturating_mul(32);
    let oom = || PyTwipError(TwipError::OutOfMemory { name: "models x samples", bytes });
    let column = |len: usize| -> PyResult<Vec<Vector4<f64>>> {
        let mut v = Vec::new();
        v.try_reserve_exact(len).map_err(|_| oom())?;
        v.resize(len, Vector4::zeros());
        Ok(v)
    };
    let mut out = Vec::new();
    out.try_reserve_exact(k).map_err(|_| oom())?;
    for _ in 0..k {
        let mut sensed = Vec::new();
        sensed.try_reserve_exact(n).map_err(|_| oom())?;
        sensed.resize(n, [0.0; 2]);
        let mut script = Vec::new();
        script.try_reserve_exact(events).map_err(|_| oom())?;
        script.resize(events, GearEvent::default());
        out.push(Prediction { states: column(n)?, rates: column(n)?, sensed, ends: column(segments)?, plays: vec![None; segments], events: script });
    }
    Ok(out)
}

fn to_array<'a, 'py>(
    py: Python<'py>,
    runs: impl ExactSizeIterator<Item = &'a Vec<Vector4<f64>>>,
    rows: usize,
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let k = runs.len();
    let flat: Vec<f64> = runs.flat_map(|r| r.iter().flat_map(|v| [v[0], v[1], v[2], v[3]])).collect();
    flat.into_pyarray(py).reshape([k, rows, 4])
}
