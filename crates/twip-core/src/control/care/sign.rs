//! The matrix sign function of the Hamiltonian (step 3 of the CARE method).
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use nalgebra::DMatrix;

use super::*;

/// Gauss–Jordan inversion with partial pivoting, in place on a column-major n×n slice;
/// returns log|det|, or `None` if a pivot is zero or not finite.
pub(crate) fn invert_in_place<T: Real>(a: &mut [T], n: usize, perm: &mut [usize], factors: &mut [T]) -> Option<T> {
    let mut logdet = T::zero();
    // |det| accumulates as a product, folded into the log when it leaves [2⁻³², 2³²]
    // (a product of two such numbers is finite even in f32).
    let (big, small) = (c::<T>(4294967296.0), c::<T>(2.3283064365386963e-10));
    let mut product = T::one();
    for k in 0..n {
        let (mut p, mut best) = (k, T::zero());
        for (i, v) in a[k * n..(k + 1) * n].iter().enumerate().skip(k) {
            if v.abs() > best {
                best = v.abs();
                p = i;
            }
        }
        if !(best > T::zero()) || !best.is_finite() {
            return None;
        }
        perm[k] = p;
        if p != k {
            for col in a.chunks_exact_mut(n) {
                col.swap(k, p);
            }
        }
        let inv_pivot = T::one() / a[k * n + k];
        if best > big || best < small {
            logdet += best.ln();
        } else {
            product *= best;
        }
        if product > big || product < small {
            logdet += product.ln();
            product = T::one();
        }
        factors.copy_from_slice(&a[k * n..(k + 1) * n]);
        factors[k] = T::zero();
        {
            let col = &mut a[k * n..(k + 1) * n];
            col.iter_mut().for_each(|x| *x = T::zero());
            col[k] = T::one();
        }
        for col in a.chunks_exact_mut(n) {
            let akj = col[k] * inv_pivot;
            col[k] = akj;
            for (x, &f) in col.iter_mut().zip(factors.iter()) {
                *x -= f * akj;
            }
        }
    }
    // Undo the row interchanges on the columns of the inverse, last first.
    for k in (0..n).rev() {
        let p = perm[k];
        if p != k {
            let (lo, hi) = a.split_at_mut(k.max(p) * n);
            lo[k.min(p) * n..(k.min(p) + 1) * n].swap_with_slice(&mut hi[..n]);
        }
    }
    Some(logdet + product.ln())
}

/// `X` from the matrix sign function of the Hamiltonian (step 3 of the module docs).
pub(crate) fn sign_solution<T: Real>(a: &DMatrix<T>, g: &DMatrix<T>, q: &DMatrix<T>) -> Option<DMatrix<T>> {
    let n = a.nrows();
    let nn = 2 * n;
    // W = J H = [[−Q, −Aᵀ], [−A, G]], column-major.
    let mut w = alloc::vec![T::zero(); nn * nn];
    for j in 0..n {
        for i in 0..n {
            w[j * nn + i] = -q[(i, j)];
            w[(j + n) * nn + i] = -a[(j, i)];
            w[j * nn + i + n] = -a[(i, j)];
            w[(j + n) * nn + i + n] = g[(i, j)];
        }
    }
    let mut inv = w.clone();
    let mut next = w.clone();
    let mut perm = alloc::vec![0usize; nn];
    let mut factors = alloc::vec![T::zero(); nn];

    let eps = T::default_epsilon();
    let tol = c::<T>(10.0) * c::<T>(nn as f64) * eps;
    let stagnation = eps.sqrt().sqrt();
    let quadratic = eps.sqrt() * c::<T>(10.0);
    let half = c::<T>(0.5);
    let mut scaling = true;
    let mut previous = T::max_value()?;
    let mut converged = false;
    for iteration in 0..SIGN_MAX_ITER {
        inv.copy_from_slice(&w);
        let logdet = invert_in_place(&mut inv, nn, &mut perm, &mut factors)?;
        let cf = if scaling {
            (-logdet / c::<T>(nn as f64)).exp()
        } else {
            T::one()
        };
        if !cf.is_finite() || cf.is_zero() {
            return None;
        }
        let inv_cf = T::one() / cf;
        // W ← (c W + J W⁻¹ J / c) / 2, symmetrised. Column j of J W⁻¹ J is column j ± n of
        // W⁻¹ with its halves swapped, negated in the diagonal blocks ([[−M22, M21], [M12, −M11]]).
        for j in 0..nn {
            let (sj, flip) = if j < n { (j + n, -inv_cf) } else { (j - n, inv_cf) };
            let src = &inv[sj * nn..(sj + 1) * nn];
            let (w_col, next_col) = (&w[j * nn..(j + 1) * nn], &mut next[j * nn..(j + 1) * nn]);
            for i in 0..n {
                next_col[i] = (cf * w_col[i] + flip * src[i + n]) * half;
                next_col[i + n] = (cf * w_col[i + n] - flip * src[i]) * half;
            }
        }
        let (mut diff2, mut norm2) = (T::zero(), T::zero());
        for j in 0..nn {
            for i in 0..=j {
                let v = if i == j {
                    next[j * nn + i]
                } else {
                    (next[j * nn + i] + next[i * nn + j]) * half
                };
                let d = v - w[j * nn + i];
                let weight = if i == j { T::one() } else { c::<T>(2.0) };
                diff2 += weight * d * d;
                norm2 += weight * v * v;
                next[j * nn + i] = v;
                next[i * nn + j] = v;
            }
        }
        core::mem::swap(&mut w, &mut next);
        let delta = (diff2 / norm2).sqrt();
        if !delta.is_finite() {
            return None;
        }
        // Unscaled, the iteration converges quadratically: the iterate just computed is
        // off by about delta², and Newton–Kleinman refinement follows anyway.
        if delta <= tol || (!scaling && (delta <= quadratic || (delta <= stagnation && delta >= previous * half))) {
            converged = true;
            break;
        }
        if delta < c::<T>(1e-2) || iteration + 1 == SIGN_SCALED_MAX_ITER {
            // Near convergence the scaling only slows the quadratic phase down. Nor does it
            // settle when two eigenvalues nearly meet at 0 (CAREX #4's Hamiltonian has ±6e-9):
            // unscaled, the iteration still converges, one bit per step, then quadratically.
            scaling = false;
        }
        previous = delta;
    }
    if !converged {
        return None;
    }
    graph_from_sign(&DMatrix::from_vec(nn, nn, w))
}

/// A stabilising `X` to start Newton–Kleinman from when the sign function of the problem
/// itself fails: the stabilising solution for the positive definite weight
/// `Q + (‖Q‖ + 1) I` (its Hamiltonian has no imaginary eigenvalue when (A, B) is stabilizable).
pub(crate) fn stabilising_start<T: Real>(sc: &Scaled<T>) -> Option<DMatrix<T>> {
    let n = sc.a.nrows();
    let shift = sc.q.norm() + T::one();
    let q = &sc.q + DMatrix::<T>::identity(n, n) * shift;
    sign_solution(&sc.a, &sc.g, &q)
}

/// `X` from `W = J sign(H)`: sign H = −J W = [[−W21, −W22], [W11, W12]], and
/// (sign H + I) [I; X] = 0 reads [W22; W12 + I] X = [I − W21; −W11], solved in the
/// least-squares sense (Householder QR).
pub(crate) fn graph_from_sign<T: Real>(w: &DMatrix<T>) -> Option<DMatrix<T>> {
    let n = w.nrows() / 2;
    let mut lhs = DMatrix::<T>::zeros(2 * n, n);
    let mut rhs = DMatrix::<T>::zeros(2 * n, n);
    for j in 0..n {
        for i in 0..n {
            lhs[(i, j)] = w[(n + i, n + j)];
            lhs[(n + i, j)] = w[(i, n + j)];
            rhs[(i, j)] = -w[(n + i, j)];
            rhs[(n + i, j)] = -w[(i, j)];
        }
        lhs[(n + j, j)] += T::one();
        rhs[(j, j)] += T::one();
    }
    let qr = QR::new(lhs);
    qr.q_tr_mul(&mut rhs);
    let x = qr.r().solve_upper_triangular(&rhs.rows(0, n))?;
    if x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    Some(symmetrise(x))
}
