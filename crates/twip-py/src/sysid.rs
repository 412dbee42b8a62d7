//! `_core.sysid_shoot`: the multiple-shooting predictions of a logged run for many robots
//! at once (the finite-difference columns of the estimator's Jacobian), on all cores.
use nalgebra::Vector4;
use numpy::{IntoPyArray, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use twip_core::sysid::parallel::run_all;
use twip_core::hardware::backlash::{Backlash, GearEvent, PlayState};
use twip_core::sysid::geared::rig_plant;
use twip_core::sysid::{Outputs, Shooting};
use twip_core::{SlopeModel, TwipError};

use crate::convert::{real, Real};
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
    #[pyo3(from_py_with = real)] max_step: f64,
    drivers: Option<Vec<PyRef<'py, PyMotorDriver>>>,
    backlash: Option<Real>,
) -> PyResult<Out<'py>> {
    let backlash = backlash.map(|b| b.0);
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
    let mut buffers = Buffers::new(k, n, segments.len(), events)?;
    let mut out = buffers.outputs(n, segments.len(), events);
    let plants: Vec<SlopeModel<f64>> = models.iter().map(|m| m.inner).collect();
    if let Some(d) = &drivers {
        if d.len() != k {
            let got = (d.len(), 1);
            return Err(PyTwipError(TwipError::Shape { name: "drivers", expected: (k, 1), got }).into());
        }
    }
    let drivers: Option<Vec<_>> = drivers.map(|d| d.iter().map(|d| d.inner).collect());
    match (backlash, drivers) {
        (None, None) => py.detach(|| run_all(&shooting, &plants, &starts, &mut out)),
        // The rig's plant: the driver, the play, or both.
        (backlash, drivers) => {
            let play = backlash.map(|gap| Backlash { gap }.validate()).transpose().map_err(PyTwipError)?;
            let rigs = plants
                .iter()
                .enumerate()
                .map(|(i, p)| rig_plant(p, drivers.as_ref().map(|d| &d[i]), play))
                .collect::<Result<Vec<_>, _>>()
                .map_err(PyTwipError)?;
            py.detach(|| run_all(&shooting, &rigs, &starts, &mut out))
        }
    }
    .map_err(PyTwipError)?;
    drop(out);
    let segments = segments.len();
    let Buffers { states, rates, ends, sensed, .. } = buffers;
    Ok((
        states.into_pyarray(py).reshape([k, n, 4])?,
        rates.into_pyarray(py).reshape([k, n, 4])?,
        ends.into_pyarray(py).reshape([k, segments, 4])?,
        sensed.into_pyarray(py).reshape([k, n, 2])?,
    ))
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> TwipError {
    TwipError::InvalidParameter { name, value, reason }
}

/// The k runs' outputs, each array flat in the layout NumPy is handed ([k, rows, columns]):
/// the runs write there and the arrays move to NumPy without a copy.
struct Buffers {
    states: Vec<f64>,
    rates: Vec<f64>,
    ends: Vec<f64>,
    sensed: Vec<f64>,
    plays: Vec<Option<PlayState<f64, 1>>>,
    events: Vec<GearEvent>,
}

impl Buffers {
    /// Reserved fallibly: a MemoryError naming the size, not an abort.
    fn new(k: usize, n: usize, segments: usize, events: usize) -> PyResult<Self> {
        // A gear event is 2 bytes, a row 32.
        let rows = (n as u64).saturating_mul(3).saturating_add(segments as u64 * 2).saturating_add(events as u64 / 16);
        let bytes = (k as u64).saturating_mul(rows).saturating_mul(32);
        let oom = || PyTwipError(TwipError::OutOfMemory { name: "models x samples", bytes });
        fn filled<T: Clone>(len: Option<usize>, value: T, oom: &dyn Fn() -> PyTwipError) -> PyResult<Vec<T>> {
            let len = len.ok_or_else(oom)?;
            let mut v = Vec::new();
            v.try_reserve_exact(len).map_err(|_| oom())?;
            v.resize(len, value);
            Ok(v)
        }
        let per_runs = |columns: usize, rows: usize| k.checked_mul(rows).and_then(|r| r.checked_mul(columns));
        Ok(Self {
            states: filled(per_runs(4, n), 0.0, &oom)?,
            rates: filled(per_runs(4, n), 0.0, &oom)?,
            ends: filled(per_runs(4, segments), 0.0, &oom)?,
            sensed: filled(per_runs(2, n), 0.0, &oom)?,
            plays: filled(per_runs(1, segments), None, &oom)?,
            events: filled(per_runs(1, events), GearEvent::default(), &oom)?,
        })
    }

    /// Each run's share of the arrays: n samples, `segments` ends and plays, and `events`
    /// gear events (none without play).
    fn outputs(&mut self, n: usize, segments: usize, events: usize) -> Vec<Outputs<'_, f64>> {
        let mut gear_events = self.events.chunks_mut(events.max(1));
        runs_of_rows(&mut self.states, n)
            .zip(runs_of_rows(&mut self.rates, n))
            .zip(runs_of_rows(&mut self.ends, segments))
            .zip(bytemuck::cast_slice_mut::<f64, [f64; 2]>(&mut self.sensed).chunks_mut(n))
            .zip(self.plays.chunks_mut(segments))
            .map(|((((states, rates), ends), sensed), plays)| {
                let events = gear_events.next().unwrap_or(&mut []);
                Outputs { states, rates, sensed, ends, plays, events }
            })
            .collect()
    }
}

/// A flat array of runs × `rows` rows of 4 numbers, as each run's rows of states.
fn runs_of_rows(flat: &mut [f64], rows: usize) -> core::slice::ChunksMut<'_, Vector4<f64>> {
    bytemuck::cast_slice_mut::<f64, Vector4<f64>>(flat).chunks_mut(rows)
}
