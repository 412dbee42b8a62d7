//! numpy <-> nalgebra conversions with shape and finiteness checks that name the argument.
use nalgebra::{DMatrix, SMatrix, SVector};
use numpy::{
    AllowTypeChange, Complex64, IntoPyArray, PyArray1, PyArray2, PyArrayDescrMethods, PyArrayLike1, PyArrayLike2, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyComplex, PyFloat, PyInt};
use twip_core::TwipError;

use crate::errors::{argument_type_error, as_argument_error, CoreResult, InvalidParameterError, ShapeError};

fn finite(name: &'static str, values: impl IntoIterator<Item = f64>) -> CoreResult<()> {
    for (index, value) in values.into_iter().enumerate() {
        if !value.is_finite() {
            return Err(TwipError::NonFinite { name, index, value }.into());
        }
    }
    Ok(())
}

/// A real number from Python: the type of every float parameter of the bindings
/// (`Option<Real>`, `Vec<Real>`, `(Real, Real)`... for the others). pyo3's own `f64`
/// goes through `__float__`, which reads a bool as 0 or 1 and a numpy complex as its real
/// part (with only a ComplexWarning); those are refused here, with a TypeError naming the
/// value. Every TypeError of it is a `twip.ArgumentTypeError`, whose message pyo3 then
/// starts with the argument's name (errors.rs). Anything else reads as `f64` does: an int,
/// a float, a numpy real, a Fraction or a Decimal.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Real(pub f64);

impl<'py> FromPyObject<'_, 'py> for Real {
    type Error = PyErr;

    fn extract(obj: Borrowed<'_, 'py, PyAny>) -> PyResult<Self> {
        // A float (np.float64 too) is the common case: nothing more to check.
        if let Ok(f) = obj.cast::<PyFloat>() {
            return Ok(Real(f.value()));
        }
        if let Some(what) = not_real(&obj) {
            return Err(argument_type_error(obj.py(), format!("expected a real number, got the {what} {}", obj.repr()?)));
        }
        obj.extract::<f64>().map(Real).map_err(|e| as_argument_error(obj.py(), e))
    }
}

/// What `obj` is when `float(obj)` would take it but it is no real number (nor, for `Int`,
/// an integer): a bool or a complex number, Python's or numpy's (a scalar or a 0-d array:
/// np.bool_ and np.complex64 are no subclasses of Python's bool and complex, so their dtype
/// tells).
fn not_real(obj: &Bound<'_, PyAny>) -> Option<&'static str> {
    if obj.is_instance_of::<PyBool>() {
        Some("bool")
    } else if obj.is_instance_of::<PyComplex>() {
        Some("complex value")
    } else if obj.is_instance_of::<PyInt>() {
        None
    } else {
        // Only for what is neither a float nor an int, so numpy is never imported here.
        let kind = obj.getattr(intern!(obj.py(), "dtype")).and_then(|d| d.getattr(intern!(obj.py(), "kind")));
        match kind.and_then(|k| k.extract::<String>()).as_deref() {
            Ok("b") => Some("bool"),
            Ok("c") => Some("complex value"),
            _ => None,
        }
    }
}

/// `obj` as a float parameter, for `#[pyo3(from_py_with = real)] x: f64`: the same
/// as `Real`, for a parameter whose default is a float literal (pyo3 shows a default in
/// the signature only when it is a literal, and `Real(1.0)` is none).
pub(crate) fn real(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    obj.extract::<Real>().map(|r| r.0)
}

/// The floats of a `Vec<Real>` parameter.
pub(crate) fn reals(values: Vec<Real>) -> Vec<f64> {
    values.into_iter().map(|r| r.0).collect()
}

/// An integer from Python: the type of every integer parameter of the bindings (`Int<usize>`,
/// `Int<u64>`, `Option<Vec<Int<i64>>>`...). pyo3's own integers go through `__index__`, which
/// reads a bool as 0 or 1; a bool (Python's or numpy's) is refused here with a TypeError
/// naming the value, as `Real` refuses it (a `twip.ArgumentTypeError`, as `Real`'s). Anything
/// else reads as `T` does: an int or a numpy integer (a float stays refused, by pyo3).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Int<T>(pub T);

impl<'a, 'py, T: FromPyObject<'a, 'py>> FromPyObject<'a, 'py> for Int<T> {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        // An int (not a bool, a subclass) is the common case: nothing more to check.
        if !obj.is_exact_instance_of::<PyInt>() {
            if let Some(what) = not_real(&obj) {
                return Err(argument_type_error(obj.py(), format!("expected an integer, got the {what} {}", obj.repr()?)));
            }
        }
        obj.extract::<T>().map(Int).map_err(|e| as_argument_error(obj.py(), e.into()))
    }
}

/// `obj` as an integer parameter, for `#[pyo3(from_py_with = int::<usize>)] n: usize`: the
/// same as `Int`, for a parameter whose default is an integer literal (shown in the signature).
pub(crate) fn int<'py, T: for<'a> FromPyObject<'a, 'py>>(obj: &Bound<'py, PyAny>) -> PyResult<T> {
    obj.extract::<Int<T>>().map(|i| i.0)
}

/// The integers of a `Vec<Int<T>>` parameter.
pub(crate) fn ints<T>(values: Vec<Int<T>>) -> Vec<T> {
    values.into_iter().map(|i| i.0).collect()
}

/// `obj` as a numpy array of real numbers (int or float): anything else (a string, a
/// complex number, a bool, None...) is refused naming the first such entry and its index.
pub(crate) fn real_array<'py>(name: &'static str, obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        if b"iuf".contains(&a.dtype().kind()) {
            return Ok(obj.clone());
        }
    }
    let np = obj.py().import("numpy")?;
    let arr = np.call_method1("asarray", (obj,)).map_err(|e| {
        ShapeError::new_err(format!("{name}: cannot be read as an array of numbers ({e})"))
    })?;
    // Anything but such an array is checked entry by entry, as given: numpy would have read
    // [1, "a"] as strings throughout, and [True, 0.5] as floats.
    let as_given = np.call_method1("asarray", (obj, "object")).unwrap_or(arr.clone());
    let numbers_real = obj.py().import("numbers")?.getattr("Real")?;
    let flat = as_given.call_method0("ravel")?.call_method0("tolist")?;
    for (index, entry) in flat.try_iter()?.enumerate() {
        let entry = entry?;
        // A bool is an int, so a numbers.Real, to Python: not a number here.
        let real = entry.is_instance_of::<PyFloat>() || (entry.is_instance(&numbers_real)? && !entry.is_instance_of::<PyBool>());
        if !real {
            return Err(InvalidParameterError::new_err(format!(
                "{name}[{index}] = {}: not a real number (got {})",
                entry.repr()?,
                entry.get_type().name()?
            )));
        }
    }
    Ok(arr)
}

/// The shape of an array-like, as numpy reads it (for error messages).
fn shape_of(obj: &Bound<'_, PyAny>) -> String {
    obj.getattr("shape")
        .and_then(|s| s.extract::<Vec<usize>>())
        .map(|s| match s.as_slice() {
            [one] => format!("({one},)"),
            _ => format!("{s:?}").replace('[', "(").replace(']', ")"),
        })
        .unwrap_or_else(|_| "unknown".into())
}

/// Reads a length-`N` float vector (any array-like of real numbers), checking shape
/// and finiteness; a wrong shape is reported as received.
pub fn vector<const N: usize>(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<SVector<f64, N>> {
    let obj = real_array(name, obj)?;
    let arr: PyArrayLike1<'_, f64, AllowTypeChange> = obj.extract().map_err(|_| {
        ShapeError::new_err(format!("{name} has shape {}, expected ({N},)", shape_of(&obj)))
    })?;
    let view = arr.as_array();
    if view.len() != N {
        return Err(ShapeError::new_err(format!("{name} has shape ({},), expected ({N},)", view.len())));
    }
    let v = SVector::<f64, N>::from_iterator(view.iter().copied());
    finite(name, v.iter().copied())?;
    Ok(v)
}

/// Reads a 1-D series of samples of any length (any array-like of real numbers, as numpy
/// reads it: a list, an int array...), checking that every entry is finite.
pub fn series<'py>(name: &'static str, obj: &Bound<'py, PyAny>) -> PyResult<PyArrayLike1<'py, f64, AllowTypeChange>> {
    let obj = real_array(name, obj)?;
    let arr: PyArrayLike1<'py, f64, AllowTypeChange> = obj.extract().map_err(|_| {
        ShapeError::new_err(format!("{name} has shape {}, expected a 1-D array", shape_of(&obj)))
    })?;
    finite(name, arr.as_array().iter().copied())?;
    Ok(arr)
}

/// Reads a gain row as python-control's `lqr` returns it: shape (N,) or (1, N).
pub fn gain_row<const N: usize>(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<SVector<f64, N>> {
    let obj = real_array(name, obj)?;
    let shape = obj.getattr("shape").and_then(|s| s.extract::<Vec<usize>>()).unwrap_or_default();
    let flat = match shape.as_slice() {
        [n] if *n == N => obj.clone(),
        [1, n] if *n == N => obj.call_method0("ravel")?,
        _ => {
            return Err(ShapeError::new_err(format!(
                "{name} has shape {}, expected ({N},) or (1, {N}) (a row, as python-control's lqr returns K)",
                shape_of(&obj)
            )))
        }
    };
    vector::<N>(name, &flat)
}

/// Reads an input that may be a scalar or a length-`N` vector.
pub fn input<const N: usize>(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<SVector<f64, N>> {
    if N == 1 {
        // Anything but a real number (a bool too) is read as an array, which names it.
        if let Ok(Real(x)) = obj.extract::<Real>() {
            finite(name, [x])?;
            return Ok(SVector::<f64, N>::from_element(x));
        }
    }
    vector::<N>(name, obj)
}

/// Reads a finite float scalar.
pub fn scalar(name: &'static str, obj: f64) -> CoreResult<f64> {
    finite(name, [obj])?;
    Ok(obj)
}

/// Reads a 2-D float matrix of any shape, checking finiteness.
pub fn dmatrix(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<DMatrix<f64>> {
    let obj = real_array(name, obj)?;
    let arr: PyArrayLike2<'_, f64, AllowTypeChange> = obj.extract().map_err(|_| {
        ShapeError::new_err(format!("{name} has shape {}, expected a 2-D matrix", shape_of(&obj)))
    })?;
    let view = arr.as_array();
    let (r, c) = view.dim();
    let m = DMatrix::from_fn(r, c, |i, j| view[(i, j)]);
    finite(name, m.iter().copied())?;
    Ok(m)
}

pub fn to_py_vector<'py, const N: usize>(py: Python<'py>, v: &SVector<f64, N>) -> Bound<'py, PyArray1<f64>> {
    v.iter().copied().collect::<Vec<f64>>().into_pyarray(py)
}

pub fn to_py_matrix<'py, const R: usize, const C: usize>(
    py: Python<'py>,
    m: &SMatrix<f64, R, C>,
) -> Bound<'py, PyArray2<f64>> {
    to_py_dmatrix(py, &DMatrix::from_fn(R, C, |i, j| m[(i, j)]))
}

pub fn to_py_dmatrix<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    let rows = m.nrows();
    let cols = m.ncols();
    let data: Vec<f64> = (0..rows).flat_map(|i| (0..cols).map(move |j| m[(i, j)])).collect();
    numpy::ndarray::Array2::from_shape_vec((rows, cols), data)
        .expect("shape matches data length")
        .into_pyarray(py)
}

/// A 1-D complex128 array (e.g. eigenvalues).
pub fn to_py_complex_vector<'py>(py: Python<'py>, v: &[Complex64]) -> Bound<'py, PyArray1<Complex64>> {
    v.to_vec().into_pyarray(py)
}
