//! Input checks of the CARE: finiteness, symmetry, definiteness.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use alloc::vec::Vec;

use nalgebra::DMatrix;

use super::*;

pub(crate) fn finite<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<(), TwipError> {
    // Row-major index, as numpy users count.
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            let v = m[(i, j)];
            if !v.is_finite() {
                return Err(TwipError::NonFinite {
                    name,
                    index: i * m.ncols() + j,
                    value: to_f64(v),
                });
            }
        }
    }
    Ok(())
}

/// Checks symmetry up to rounding (100 n ε of the largest entry) and returns (M + Mᵀ)/2.
pub(crate) fn symmetric<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<DMatrix<T>, TwipError> {
    let n = m.nrows();
    let mut worst = T::zero();
    for j in 0..n {
        for i in (j + 1)..n {
            worst = worst.max((m[(i, j)] - m[(j, i)]).abs());
        }
    }
    if worst > c::<T>(100.0) * c::<T>(n as f64) * T::default_epsilon() * m.amax() {
        return Err(TwipError::InvalidParameter {
            name,
            value: to_f64(worst),
            reason: "must be symmetric (the value is the largest |M[i,j] - M[j,i]|)",
        });
    }
    Ok(symmetrised(m))
}

pub(crate) fn symmetrised<T: Real>(m: &DMatrix<T>) -> DMatrix<T> {
    symmetrise(m.clone())
}

/// (M + Mᵀ)/2 in place.
pub(crate) fn symmetrise<T: Real>(mut m: DMatrix<T>) -> DMatrix<T> {
    let n = m.nrows();
    let half = c::<T>(0.5);
    for j in 0..n {
        for i in 0..j {
            let v = (m[(i, j)] + m[(j, i)]) * half;
            m[(i, j)] = v;
            m[(j, i)] = v;
        }
    }
    m
}

pub(crate) fn symmetric_eigenvalues<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<Vec<T>, TwipError> {
    let n = m.nrows();
    let cap = 100 + 40 * n;
    SymmetricEigen::try_new(m.clone(), T::default_epsilon(), cap)
        .map(|e| e.eigenvalues.iter().copied().collect())
        .ok_or(TwipError::NoConvergence {
            what: if name == "Q" {
                "eigenvalues of Q"
            } else {
                "eigenvalues of R"
            },
            iterations: cap,
        })
}


/// Checks the shapes (A n×n, B n×m, Q n×n, R m×m, n, m ≥ 1), finiteness and symmetry of a
/// Riccati equation's data: `(n, m, (Q + Qᵀ)/2, (R + Rᵀ)/2)`.
pub(crate) fn checked_problem<T: Real>(
    a: &DMatrix<T>,
    b: &DMatrix<T>,
    q: &DMatrix<T>,
    r: &DMatrix<T>,
) -> Result<(usize, usize, DMatrix<T>, DMatrix<T>), TwipError> {
    let n = a.nrows();
    if n == 0 || a.ncols() != n {
        return Err(TwipError::Shape { name: "A", expected: (n.max(1), n.max(1)), got: a.shape() });
    }
    let m = b.ncols();
    if b.nrows() != n || m == 0 {
        return Err(TwipError::Shape { name: "B", expected: (n, m.max(1)), got: b.shape() });
    }
    if q.shape() != (n, n) {
        return Err(TwipError::Shape { name: "Q", expected: (n, n), got: q.shape() });
    }
    if r.shape() != (m, m) {
        return Err(TwipError::Shape { name: "R", expected: (m, m), got: r.shape() });
    }
    finite("A", a)?;
    finite("B", b)?;
    finite("Q", q)?;
    finite("R", r)?;
    Ok((n, m, symmetric("Q", q)?, symmetric("R", r)?))
}

/// The smallest eigenvalue of the symmetric `m` and whether `m` is positive semi-definite
/// up to rounding (no eigenvalue below −100 n ε of the largest in size).
pub(crate) fn smallest_eigenvalue<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<(T, bool), TwipError> {
    let eig = symmetric_eigenvalues(name, m)?;
    let top = eig.iter().fold(T::zero(), |acc, v| acc.max(v.abs()));
    let min = eig.iter().fold(top, |acc, &v| acc.min(v));
    let psd = !(min < -(c::<T>(100.0) * c::<T>(m.nrows() as f64) * T::default_epsilon() * top));
    Ok((min, psd))
}
