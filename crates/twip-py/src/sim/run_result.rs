//! The dict every runner gives `twip.simulate`: the log as arrays, the outcome and the
//! metrics by name. One builder, so the 2-DOF and 3-DOF results cannot drift apart.
use numpy::{IntoPyArray, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::sim::log::TrajectoryLog;
use twip_core::sim::runner::Outcome;

/// What a run's log holds besides the state and input: the reference's columns, the
/// controller's internals and, with realism, the rig's signals.
pub(crate) struct LogLayout<'a> {
    pub states: usize,
    pub inputs: usize,
    pub reference_names: &'a [&'static str],
    pub internal_names: &'a [&'static str],
    /// The rig's signals when the run had realism.
    pub signal_names: Option<&'a [&'static str]>,
}

/// The run's dict: t, states, inputs, references, internals, signals, outcome, t_end,
/// steps and `metrics` (name -> value, names from the core).
pub(crate) fn run_dict<'py>(
    py: Python<'py>,
    log: TrajectoryLog<f64>,
    layout: &LogLayout<'_>,
    outcome: Outcome<f64>,
    steps: usize,
    metrics: impl IntoIterator<Item = (&'static str, f64)>,
) -> PyResult<Bound<'py, PyDict>> {
    let rows = log.len();
    let table = |v: Vec<f64>, cols: usize| -> PyResult<numpy::ndarray::Array2<f64>> {
        numpy::ndarray::Array2::from_shape_vec((rows, cols), v)
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
    };
    let array = |v: Vec<f64>, cols: usize| -> PyResult<Bound<'py, PyArray2<f64>>> { Ok(table(v, cols)?.into_pyarray(py)) };
    let out = PyDict::new(py);
    out.set_item("t", log.t.into_pyarray(py))?;
    out.set_item("states", array(log.x, layout.states)?)?;
    out.set_item("inputs", array(log.u, layout.inputs)?)?;
    out.set_item("references", array(log.reference, layout.reference_names.len())?)?;
    out.set_item("reference_names", layout.reference_names.to_vec())?;
    // The internals' columns are the controller's, then (with realism) the rig's signals.
    let cut = layout.internal_names.len();
    let signal_names = layout.signal_names.unwrap_or(&[]);
    let columns = table(log.internals, cut + signal_names.len())?;
    // Split only when there are signals: moved whole otherwise, a log of many internals
    // (a user's controller) is not held twice at its peak.
    let (internals, signals) = match layout.signal_names {
        None => (columns.into_pyarray(py), None),
        Some(_) => (
            columns.slice(numpy::ndarray::s![.., ..cut]).to_owned().into_pyarray(py),
            Some(columns.slice(numpy::ndarray::s![.., cut..]).to_owned().into_pyarray(py)),
        ),
    };
    out.set_item("internals", internals)?;
    out.set_item("internal_names", layout.internal_names.to_vec())?;
    out.set_item("signals", signals)?;
    out.set_item("signal_names", signal_names.to_vec())?;
    let (name, t_end) = match outcome {
        Outcome::Completed => ("completed", None),
        Outcome::Fell { t } => ("fell", Some(t)),
        Outcome::Diverged { t } => ("diverged", Some(t)),
        Outcome::Interrupted { t } => ("interrupted", Some(t)),
        Outcome::Lifted { t } => ("lifted", Some(t)),
        Outcome::OffTerrain { t } => ("off_terrain", Some(t)),
    };
    out.set_item("outcome", name)?;
    out.set_item("t_end", t_end)?;
    out.set_item("steps", steps)?;
    let m = PyDict::new(py);
    for (k, v) in metrics {
        m.set_item(k, v)?;
    }
    out.set_item("metrics", m)?;
    Ok(out)
}
