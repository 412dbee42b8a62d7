//! Maps the core's `TwipError` onto a Python exception hierarchy rooted at
//! `twip.TwipError(ValueError)`. One exhaustive match: a new case cannot be forgotten.
use pyo3::create_exception;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use twip_core::TwipError as CoreError;

create_exception!(twip, TwipError, PyValueError, "Base of every twip error (a ValueError).");
create_exception!(twip, InvalidParameterError, TwipError, "A named parameter has an invalid value.");
create_exception!(twip, ShapeError, TwipError, "An array argument has the wrong shape.");
create_exception!(twip, NonFiniteError, TwipError, "A state, input or matrix holds NaN or inf.");
create_exception!(twip, NoEquilibriumError, TwipError, "The requested operating point does not exist.");
create_exception!(twip, SingularMatrixError, TwipError, "A matrix that must be invertible is singular.");
create_exception!(twip, NotStabilizableError, TwipError, "The pair (A, B) is not stabilizable.");
create_exception!(twip, NotDetectableError, TwipError, "The pair (A, Q) is not detectable.");
create_exception!(
    twip,
    NoStabilizingSolutionError,
    TwipError,
    "The Riccati equation has no stabilising solution (Hamiltonian eigenvalues on the imaginary axis)."
);
create_exception!(twip, ConvergenceError, TwipError, "An iterative method hit its iteration cap.");
create_exception!(twip, OffTerrainError, TwipError, "A point is off the terrain (outside its grid): there is no ground to extrapolate.");

/// Local wrapper (orphan rule) so that `?` converts core errors into Python ones.
pub struct PyTwipError(pub CoreError);

impl From<CoreError> for PyTwipError {
    fn from(e: CoreError) -> Self {
        Self(e)
    }
}

impl From<PyTwipError> for PyErr {
    fn from(e: PyTwipError) -> PyErr {
        let msg = e.0.to_string();
        match e.0 {
            CoreError::InvalidParameter { .. } => InvalidParameterError::new_err(msg),
            CoreError::Shape { .. } => ShapeError::new_err(msg),
            CoreError::NonFinite { .. } => NonFiniteError::new_err(msg),
            CoreError::NoEquilibrium { .. } => NoEquilibriumError::new_err(msg),
            CoreError::SingularMassMatrix { .. } => SingularMatrixError::new_err(msg),
            CoreError::NotStabilizable { .. } => NotStabilizableError::new_err(msg),
            CoreError::NotDetectable { .. } => NotDetectableError::new_err(msg),
            CoreError::NoStabilizingSolution => NoStabilizingSolutionError::new_err(msg),
            CoreError::NoConvergence { .. } => ConvergenceError::new_err(msg),
            CoreError::OutOfMemory { .. } => pyo3::exceptions::PyMemoryError::new_err(msg),
        }
    }
}

/// `Result` of a binding that may fail with a core error.
pub type CoreResult<T> = Result<T, PyTwipError>;

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("TwipError", py.get_type::<TwipError>())?;
    m.add("InvalidParameterError", py.get_type::<InvalidParameterError>())?;
    m.add("ShapeError", py.get_type::<ShapeError>())?;
    m.add("NonFiniteError", py.get_type::<NonFiniteError>())?;
    m.add("NoEquilibriumError", py.get_type::<NoEquilibriumError>())?;
    m.add("SingularMatrixError", py.get_type::<SingularMatrixError>())?;
    m.add("NotStabilizableError", py.get_type::<NotStabilizableError>())?;
    m.add("NotDetectableError", py.get_type::<NotDetectableError>())?;
    m.add("NoStabilizingSolutionError", py.get_type::<NoStabilizingSolutionError>())?;
    m.add("ConvergenceError", py.get_type::<ConvergenceError>())?;
    m.add("OffTerrainError", py.get_type::<OffTerrainError>())?;
    Ok(())
}

/// The error for a bad argument, naming it and its value.
pub(crate) fn invalid(name: &'static str, value: f64, reason: &'static str) -> PyTwipError {
    PyTwipError(twip_core::TwipError::InvalidParameter { name, value, reason })
}

/// `value` if it is finite (a time or a parameter), else the error naming it.
pub(crate) fn finite_param(name: &'static str, value: f64) -> CoreResult<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(invalid(name, value, "must be finite"))
    }
}

/// `value` if it is finite and > 0, else the error naming it.
pub(crate) fn positive_param(name: &'static str, value: f64) -> CoreResult<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(invalid(name, value, "must be finite and > 0"))
    }
}

/// An integer key (a seed, a stream, a sample index) in [0, 2**64), naming the argument
/// and echoing what was given (pyo3's own error names neither).
pub(crate) fn key(name: &'static str, v: &Bound<'_, PyAny>) -> PyResult<u64> {
    v.extract::<crate::convert::Int<u64>>().map(|k| k.0).map_err(|_| {
        let given = v.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into());
        InvalidParameterError::new_err(format!("invalid {name} = {given}: must be an integer in [0, 2**64)"))
    })
}

/// pyo3 names an argument it could not convert only in a note ("while processing 'x'"),
/// which `str(error)` leaves out: a TypeError comes back as "`context`: x: message"
/// (just "`context`: message" when it carries no such note). Other errors pass unchanged.
pub(crate) fn naming_argument(py: Python<'_>, context: &str, err: PyErr) -> PyErr {
    if !err.is_instance_of::<PyTypeError>(py) {
        return err;
    }
    let notes: Vec<String> =
        err.value(py).getattr("__notes__").and_then(|n| n.extract()).unwrap_or_default();
    let argument = notes.iter().find_map(|n| n.strip_prefix("while processing '")?.strip_suffix('\''));
    let message = match argument {
        Some(name) => format!("{context}: {name}: {}", err.value(py)),
        None => format!("{context}: {}", err.value(py)),
    };
    let named = PyTypeError::new_err(message);
    named.set_cause(py, Some(err));
    named
}
