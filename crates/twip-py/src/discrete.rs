//! `twip.dare`, `twip.dlqr` and `twip.c2d`: the core's discrete-time design tools with
//! SciPy's and python-control's conventions.
use numpy::{Complex64, PyArray1};
use pyo3::prelude::*;

use crate::convert::{to_py_complex_vector, to_py_dmatrix, Real};
use crate::errors::PyTwipError;
use crate::linalg::{matrix, problem, Arr2};

/// Stabilising solution X of Aᵀ X A − X − Aᵀ X B (R + Bᵀ X B)⁻¹ Bᵀ X A + Q = 0 (like scipy's
/// `solve_discrete_are`: Q, R symmetric, R may be singular where the pencil allows it).
/// B may be 1-D for one input, R a scalar.
#[pyfunction]
#[pyo3(name = "dare", signature = (A, B, Q, R))]
#[allow(non_snake_case)]
pub fn dare_py<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    B: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
) -> PyResult<Arr2<'py>> {
    let (a, b, q, r) = problem(A, B, Q, R)?;
    let x = twip_core::dare(&a, &b, &q, &r).map_err(PyTwipError)?;
    Ok(to_py_dmatrix(py, &x))
}

/// Discrete-time LQR, python-control's `dlqr(A, B, Q, R) -> (K, S, E)`: K = (R + Bᵀ S B)⁻¹ Bᵀ S A
/// for u[k] = −K x[k], S the DARE solution, E the eigenvalues of A − B K (complex).
#[pyfunction]
#[pyo3(name = "dlqr", signature = (A, B, Q, R))]
#[allow(non_snake_case, clippy::type_complexity)]
pub fn dlqr_py<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    B: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
) -> PyResult<(Arr2<'py>, Arr2<'py>, Bound<'py, PyArray1<Complex64>>)> {
    let (a, b, q, r) = problem(A, B, Q, R)?;
    let sol = twip_core::dlqr(&a, &b, &q, &r).map_err(PyTwipError)?;
    Ok((to_py_dmatrix(py, &sol.k), to_py_dmatrix(py, &sol.x), to_py_complex_vector(py, &sol.poles)))
}

/// Exact zero-order-hold discretisation over `period` [s]: (Ad, Bd) with x[k+1] = Ad x[k] + Bd u[k]
/// (scipy's `cont2discrete(..., method="zoh")`). B may be 1-D for one input.
#[pyfunction]
#[pyo3(name = "c2d", signature = (A, B, period))]
#[allow(non_snake_case)]
pub fn c2d_py<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    B: &Bound<'py, PyAny>,
    period: Real,
) -> PyResult<(Arr2<'py>, Arr2<'py>)> {
    let (a, b) = (matrix("A", A)?, matrix("B", B)?);
    let (ad, bd) = twip_core::c2d(&a, &b, period.0).map_err(PyTwipError)?;
    Ok((to_py_dmatrix(py, &ad), to_py_dmatrix(py, &bd)))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(dare_py, m)?)?;
    m.add_function(wrap_pyfunction!(dlqr_py, m)?)?;
    m.add_function(wrap_pyfunction!(c2d_py, m)?)?;
    Ok(())
}
