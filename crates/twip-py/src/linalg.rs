//! `twip.care` and `twip.lqr`: the core's dense CARE solver with python-control's conventions.
use nalgebra::DMatrix;
use numpy::{AllowTypeChange, Complex64, PyArray1, PyArray2, PyArrayLikeDyn};
use pyo3::prelude::*;
use twip_core::TwipError;

use crate::convert::{dmatrix, real_array, to_py_complex_vector, to_py_dmatrix};
use crate::errors::PyTwipError;

pub(crate) type Arr2<'py> = Bound<'py, PyArray2<f64>>;

/// Reads a matrix argument: a 2-D array, a 1-D array (a column: B for one input), or a
/// scalar (1×1: R for one input). The core checks the shapes against each other.
pub(crate) fn matrix(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<DMatrix<f64>> {
    // Refused by entry first: numpy's cast would drop a complex entry's imaginary part (with
    // only a warning) or read a string of digits as its number.
    let obj = &real_array(name, obj)?;
    let arr: PyArrayLikeDyn<'_, f64, AllowTypeChange> = obj.extract().map_err(|_| {
        PyTwipError(TwipError::InvalidParameter {
            name,
            value: f64::NAN,
            reason: "must be a real matrix (an array-like of floats)",
        })
    })?;
    let view = arr.as_array();
    let shape = view.shape();
    match shape.len() {
        0 => Ok(DMatrix::from_iterator(1, 1, view.iter().copied())),
        1 => Ok(DMatrix::from_iterator(shape[0], 1, view.iter().copied())),
        2 => dmatrix(name, obj),
        d => Err(PyTwipError(TwipError::InvalidParameter {
            name,
            value: d as f64,
            reason: "must be a 2-D array (the value is its number of dimensions)",
        })
        .into()),
    }
}

pub(crate) type Problem = (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>);

pub(crate) fn problem(
    a: &Bound<'_, PyAny>,
    b: &Bound<'_, PyAny>,
    q: &Bound<'_, PyAny>,
    r: &Bound<'_, PyAny>,
) -> PyResult<Problem> {
    Ok((matrix("A", a)?, matrix("B", b)?, matrix("Q", q)?, matrix("R", r)?))
}

/// Stabilising solution X of X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q = 0 (like scipy's
/// `solve_continuous_are` and python-control's `care`). B may be 1-D for one input, R a scalar.
#[pyfunction]
#[pyo3(name = "care", signature = (A, B, Q, R))]
#[allow(non_snake_case)]
pub fn care_py<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    B: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
) -> PyResult<Arr2<'py>> {
    let (a, b, q, r) = problem(A, B, Q, R)?;
    let x = twip_core::care(&a, &b, &q, &r).map_err(PyTwipError)?;
    Ok(to_py_dmatrix(py, &x))
}

/// Linear-quadratic regulator, python-control's `lqr(A, B, Q, R) -> (K, X, E)`:
/// K = R⁻¹ Bᵀ X for u = −K x, X the CARE solution, E the eigenvalues of A − B K (complex).
#[pyfunction]
#[pyo3(name = "lqr", signature = (A, B, Q, R))]
#[allow(non_snake_case, clippy::type_complexity)]
pub fn lqr_py<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    B: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
) -> PyResult<(Arr2<'py>, Arr2<'py>, Bound<'py, PyArray1<Complex64>>)> {
    let (a, b, q, r) = problem(A, B, Q, R)?;
    let sol = twip_core::lqr(&a, &b, &q, &r).map_err(PyTwipError)?;
    Ok((
        to_py_dmatrix(py, &sol.k),
        to_py_dmatrix(py, &sol.x),
        to_py_complex_vector(py, &sol.poles),
    ))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(care_py, m)?)?;
    m.add_function(wrap_pyfunction!(lqr_py, m)?)?;
    Ok(())
}
