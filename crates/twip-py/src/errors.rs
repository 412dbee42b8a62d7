//! Maps the core's `TwipError` onto a Python exception hierarchy rooted at
//! `twip.TwipError(ValueError)`. One exhaustive match: a new case cannot be forgotten.
use pyo3::create_exception;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyType;
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
    m.add("ArgumentTypeError", argument_type_error_class(py)?)?;
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

/// `twip.ArgumentTypeError`, a TypeError: what the bindings raise for an argument of the
/// wrong type. pyo3 names the argument by calling `add_note("while processing 'x'")` on the
/// error: a note that `str(error)` leaves out, and that Python 3.9 and 3.10 (no `add_note`)
/// drop. This class's `add_note` also puts the name in front of the message, on every Python.
/// Written in Python: a native exception class cannot carry a method.
const ARGUMENT_TYPE_ERROR: &std::ffi::CStr = cr#"
class ArgumentTypeError(TypeError):
    """An argument of the wrong type; the message names the argument ("x: expected a real number...")."""

    __module__ = "twip"

    def add_note(self, note):
        prefix = "while processing '"
        if isinstance(note, str) and note.startswith(prefix) and note.endswith("'") and self.args:
            name = note[len(prefix):-1]
            if not str(self.args[0]).startswith(name + ": "):
                self.args = (f"{name}: {self.args[0]}",) + self.args[1:]
        if hasattr(TypeError, "add_note"):  # Python 3.11+: the note as well
            super().add_note(note)
"#;

static ARGUMENT_TYPE_ERROR_CLASS: PyOnceLock<Py<PyType>> = PyOnceLock::new();

fn argument_type_error_class(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    ARGUMENT_TYPE_ERROR_CLASS
        .get_or_try_init(py, || {
            let module = PyModule::from_code(py, ARGUMENT_TYPE_ERROR, c"twip/_core/errors.rs", c"twip._argument_type_error")?;
            Ok::<_, PyErr>(module.getattr("ArgumentTypeError")?.cast_into::<PyType>()?.unbind())
        })
        .map(|cls| cls.bind(py))
}

/// A `twip.ArgumentTypeError` with `message` (pyo3 then puts the argument's name in front).
pub(crate) fn argument_type_error(py: Python<'_>, message: String) -> PyErr {
    match argument_type_error_class(py) {
        Ok(cls) => PyErr::from_type(cls.clone(), message),
        Err(e) => e,
    }
}

/// `err` as a `twip.ArgumentTypeError` with the same message and cause when it is a plain
/// TypeError (pyo3's own conversions raise those), so that it gets the argument's name.
pub(crate) fn as_argument_error(py: Python<'_>, err: PyErr) -> PyErr {
    if !err.is_instance_of::<PyTypeError>(py) {
        return err;
    }
    if let Ok(cls) = argument_type_error_class(py) {
        if err.value(py).is_instance(cls).unwrap_or(false) {
            return err;
        }
    }
    let named = argument_type_error(py, err.value(py).to_string());
    named.set_cause(py, err.cause(py));
    named
}

/// A TypeError reading `context`'s settings comes back as "`context`: x: message": the
/// argument's name is in the message of a `twip.ArgumentTypeError` (see there) and, for
/// pyo3's own plain TypeErrors, only in a note ("while processing 'x'"), which `str(error)`
/// leaves out. Just "`context`: message" when neither names it. Other errors pass unchanged.
pub(crate) fn naming_argument(py: Python<'_>, context: &str, err: PyErr) -> PyErr {
    if !err.is_instance_of::<PyTypeError>(py) {
        return err;
    }
    let text = err.value(py).to_string();
    let notes: Vec<String> =
        err.value(py).getattr("__notes__").and_then(|n| n.extract()).unwrap_or_default();
    let argument = notes.iter().find_map(|n| n.strip_prefix("while processing '")?.strip_suffix('\''));
    let message = match argument {
        Some(name) if !text.starts_with(&format!("{name}: ")) => format!("{context}: {name}: {text}"),
        _ => format!("{context}: {text}"),
    };
    let named = PyTypeError::new_err(message);
    named.set_cause(py, Some(err));
    named
}
