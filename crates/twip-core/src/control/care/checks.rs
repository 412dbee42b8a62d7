//! Input checks of the CARE: finiteness, symmetry, definiteness.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use alloc::vec::Vec;

use nalgebra::DMatrix;

use super::*;

pub(super) fn finite<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<(), TwipError> {
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
pub(super) fn symmetric<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<DMatrix<T>, TwipError> {
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

pub(super) fn symmetrised<T: Real>(m: &DMatrix<T>) -> DMatrix<T> {
    symmetrise(m.clone())
}

/// (M + Mᵀ)/2 in place.
pub(super) fn symmetrise<T: Real>(mut m: DMatrix<T>) -> DMatrix<T> {
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

pub(super) fn symmetric_eigenvalues<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<Vec<T>, TwipError> {
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

