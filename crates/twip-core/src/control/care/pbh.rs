//! The PBH rank test behind the stabilizability and detectability checks.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use alloc::vec::Vec;

use nalgebra::DMatrix;

use super::*;

/// Is `[M − λI, N]` (n×(n+k)) rank deficient: σ_min ≤ tol · σ_max? In real arithmetic
/// when λ is real, complex otherwise.
pub(crate) fn rank_deficient<T: Real>(m: &DMatrix<T>, other: &DMatrix<T>, lambda: Complex<T>, tol: T) -> bool {
    if lambda.im.is_zero() {
        rank_deficient_in(m, other, lambda.re, tol)
    } else {
        rank_deficient_in(m, other, lambda, tol)
    }
}

/// [`rank_deficient`] in the field `F` (`T` or `Complex<T>`).
///
/// Householder QR of the (n+k)×n conjugate transpose gives a triangular `R` with the same
/// singular values; `1/‖R⁻¹‖_F ≤ σ_min ≤ √n/‖R⁻¹‖_F` and `‖R‖_F/√n ≤ σ_max ≤ ‖R‖_F`, so the
/// ratio is known within a factor n, which is nothing next to `tol`. No iteration.
pub(crate) fn rank_deficient_in<T: Real, F: ComplexField<RealField = T> + Copy>(
    m: &DMatrix<T>,
    other: &DMatrix<T>,
    lambda: F,
    tol: T,
) -> bool {
    let n = m.nrows();
    let rows = n + other.ncols();
    // H = [M − λI, N]ᴴ, column-major rows×n.
    let mut h = alloc::vec![F::zero(); rows * n];
    for j in 0..n {
        for i in 0..n {
            let mut v = F::from_real(m[(j, i)]);
            if i == j {
                v -= lambda;
            }
            h[j * rows + i] = v.conjugate();
        }
        for i in 0..other.ncols() {
            h[j * rows + n + i] = F::from_real(other[(j, i)]);
        }
    }
    let mut diag = alloc::vec![F::zero(); n];
    for k in 0..n {
        let col = &mut h[k * rows..(k + 1) * rows];
        let norm = col[k..]
            .iter()
            .fold(T::zero(), |acc, &z| acc + z.modulus_squared())
            .sqrt();
        if norm.is_zero() {
            return true;
        }
        // Reflector v = x + e^{iθ}‖x‖ e₁ (θ = arg x₁), R_kk = −e^{iθ}‖x‖.
        let x0 = col[k];
        let a0 = x0.modulus();
        let phase = if a0.is_zero() { F::one() } else { x0.unscale(a0) };
        diag[k] = -phase.scale(norm);
        col[k] = x0 + phase.scale(norm);
        let vnorm2 = col[k..].iter().fold(T::zero(), |acc, &z| acc + z.modulus_squared());
        let (head, tail) = h.split_at_mut((k + 1) * rows);
        let v = &head[k * rows + k..k * rows + rows];
        for target in tail.chunks_exact_mut(rows) {
            let target = &mut target[k..];
            let dot = v
                .iter()
                .zip(target.iter())
                .fold(F::zero(), |acc, (&vi, &ti)| acc + vi.conjugate() * ti);
            let f = dot.scale(c::<T>(2.0) / vnorm2);
            for (ti, &vi) in target.iter_mut().zip(v.iter()) {
                *ti -= vi * f;
            }
        }
    }
    // R: strictly upper part in h (row i < j of column j), diagonal in `diag`.
    let r = |i: usize, j: usize| if i == j { diag[j] } else { h[j * rows + i] };
    let mut r_norm2 = T::zero();
    for j in 0..n {
        for i in 0..=j {
            r_norm2 += r(i, j).modulus_squared();
        }
    }
    // ‖R⁻¹‖_F by back substitution, column by column of the inverse.
    let mut inv_norm2 = T::zero();
    let mut y = alloc::vec![F::zero(); n];
    for col in 0..n {
        for i in (0..=col).rev() {
            let mut s = if i == col { F::one() } else { F::zero() };
            for (j, &yj) in y.iter().enumerate().take(col + 1).skip(i + 1) {
                s -= r(i, j) * yj;
            }
            let d = r(i, i);
            if d.modulus_squared().is_zero() {
                return true;
            }
            y[i] = s / d;
            inv_norm2 += y[i].modulus_squared();
        }
    }
    if !inv_norm2.is_finite() {
        return true;
    }
    // σ_min / σ_max ≥ (1/‖R⁻¹‖) / ‖R‖.
    T::one() / (inv_norm2 * r_norm2).sqrt() <= tol
}


/// The state weight of a Riccati equation as the PBH tests need it.
pub(crate) struct Weight<'a, T: Real> {
    pub(crate) q: &'a DMatrix<T>,
    /// The smallest eigenvalue of Q.
    pub(crate) q_min: T,
    /// Q is positive semi-definite (up to rounding).
    pub(crate) q_psd: bool,
}

/// The PBH tests with relative rank tolerance `tol`, on the eigenvalues λ of A that
/// `unstable(λ, ‖Ã‖)` keeps: (A, B) stabilizable; and, for a positive semi-definite Q, no mode with
/// `undamped(λ, ‖Ã‖)` (on the stability boundary) invisible to Q (else the Riccati pencil has that
/// eigenvalue too and no stabilising solution exists). An unstable mode invisible to Q is
/// no obstacle: the stabilising solution exists and mirrors it. A Schur form that does not
/// converge skips the tests: the solver's own checks (residual, closed-loop stability) still stand.
///
/// The verdicts must not depend on the units of the states or the inputs, while a rank
/// tolerance relative to the norm does: the tests run on `Ã = D⁻¹ A D` (Parlett–Reinsch
/// balancing, powers of two), `D⁻¹ B` with each column brought to Ã's size, and `D Q D`
/// likewise. `‖Ã‖` is Ã's largest entry, for the closures' margins.
pub(crate) fn check_pbh<T: Real>(
    a: &DMatrix<T>,
    b: &DMatrix<T>,
    weight: Weight<'_, T>,
    tol: T,
    unstable: impl Fn(&Complex<T>, T) -> bool,
    undamped: impl Fn(&Complex<T>, T) -> bool,
) -> Result<(), TwipError> {
    let n = a.nrows();
    let d = balance(a, &DMatrix::zeros(n, n), &DMatrix::zeros(n, n));
    let a = DMatrix::from_fn(n, n, |i, j| a[(i, j)] * (d[j] / d[i]));
    let a_max = a.amax();
    let size = if a_max > T::zero() { a_max } else { T::one() };
    // Each column of D⁻¹ B (any input scaling keeps the rank), and D Q D as a whole, to Ã's size.
    let mut b = DMatrix::from_fn(n, b.ncols(), |i, j| b[(i, j)] / d[i]);
    for mut col in b.column_iter_mut() {
        let top = col.amax();
        if top > T::zero() {
            col *= c::<T>(2.0).powi(pow2_exponent(size / top));
        }
    }
    let q = DMatrix::from_fn(n, n, |i, j| weight.q[(i, j)] * d[i] * d[j]);
    let q = if q.amax() > T::zero() { scaled_pow2(&q, pow2_exponent(size / q.amax())) } else { q };
    let Some((_, t)) = schur(a.clone()) else {
        return Ok(());
    };
    let suspects: Vec<Complex<T>> =
        quasi_eigenvalues(&t).into_iter().filter(|l| unstable(l, a_max) && l.im >= T::zero()).collect();
    if suspects.is_empty() {
        return Ok(());
    }
    // Each PBH matrix is scaled as a whole by a power of two (its singular value ratio
    // does not change) so that no norm overflows or underflows.
    // (A, B) stabilizable: rank [A − λI, B] = n; no undamped mode invisible to Q:
    // rank [Aᵀ − λI, Q] = n on the boundary.
    // Each test's error names the mode λ it finds (an eigenvalue of A: Ã is similar to it).
    let error = |transpose: bool, eigenvalue: (f64, f64)| {
        if transpose {
            TwipError::NotDetectable { eigenvalue }
        } else {
            TwipError::NotStabilizable { eigenvalue }
        }
    };
    for (other, transpose) in [(&b, false), (&q, true)] {
        if transpose && !weight.q_psd {
            continue;
        }
        let k = -pow2_exponent::<T>(a_max.max(other.amax()));
        let a = scaled_pow2(&a, k);
        let a = if transpose { a.transpose() } else { a };
        let other = scaled_pow2(other, k);
        let f = c::<T>(2.0).powi(k);
        for lambda in &suspects {
            if transpose && !undamped(lambda, a_max) {
                continue;
            }
            // A positive definite Q (σ_min ≥ its smallest eigenvalue) needs no test.
            let bound = c::<T>(n as f64) * (a_max + weight.q.amax())
                + c::<T>(n as f64).sqrt() * (lambda.re.abs() + lambda.im.abs());
            if transpose && weight.q_min > tol * bound {
                continue;
            }
            if rank_deficient(&a, &other, lambda.scale(f), tol) {
                return Err(error(transpose, (to_f64(lambda.re), to_f64(lambda.im))));
            }
        }
    }
    Ok(())
}
