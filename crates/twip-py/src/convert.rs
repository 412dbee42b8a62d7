//! numpy <-> nalgebra conversions with shape and finiteness checks that name the argument.
use nalgebra::{DMatrix, SMatrix, SVector};
use numpy::{AllowTypeChange, Complex64, IntoPyArray, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use twip_core::TwipError;

use crate::errors::{CoreResult, PyTwipError};

fn finite(name: &'static str, values: impl IntoIterator<Item = f64>) -> CoreResult<()> {
    for (index, value) in values.into_iter().enumerate() {
        if !value.is_finite() {
            return Err(TwipError::NonFinite { name, index, value }.into());
        }
    }
    Ok(())
}

/// Reads a length-`N` float vector (any array-like), checking shape and finiteness.
pub fn vector<const N: usize>(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<SVector<f64, N>> {
    let arr: PyArrayLike1<'_, f64, AllowTypeChange> = obj.extract().map_err(|_| {
        PyTwipError(TwipError::Shape { name, expected: (N, 1), got: dims_of(obj) })
    })?;
    let view = arr.as_array();
    if view.len() != N {
        return Err(PyTwipError(TwipError::Shape { name, expected: (N, 1), got: (view.len(), 1) }).into());
    }
    let v = SVector::<f64, N>::from_iterator(view.iter().copied());
    finite(name, v.iter().copied())?;
    Ok(v)
}

/// Reads an input that may be a scalar or a length-`N` vector.
pub fn input<const N: usize>(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<SVector<f64, N>> {
    if N == 1 {
        if let Ok(x) = obj.extract::<f64>() {
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
    let arr: PyArrayLike2<'_, f64, AllowTypeChange> = obj.extract().map_err(|_| {
        PyTwipError(TwipError::Shape { name, expected: (0, 0), got: dims_of(obj) })
    })?;
    let view = arr.as_array();
    let (r, c) = view.dim();
    let m = DMatrix::from_fn(r, c, |i, j| view[(i, j)]);
    finite(name, m.iter().copied())?;
    Ok(m)
}

fn dims_of(obj: &Bound<'_, PyAny>) -> (usize, usize) {
    match obj.extract::<PyArrayLike1<'_, f64, AllowTypeChange>>() {
        Ok(a) => (a.len(), 1),
        Err(_) => (0, 0),
    }
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
