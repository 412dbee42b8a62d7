//! Exact rescalings by powers of two and the diagonal balancing of the Hamiltonian
//! (step 2 of the CARE method).
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use alloc::vec::Vec;

use nalgebra::DMatrix;

use super::*;

/// The exponent k with 2^k nearest to `v` (> 0) in the log, clamped so that 2^±k and
/// 2^±2k stay finite and normal in `T`.
pub(crate) fn pow2_exponent<T: Real>(v: T) -> i32 {
    if !(v > T::zero()) || !v.is_finite() {
        return 0;
    }
    let limit = (to_f64(T::max_value().unwrap_or(c::<T>(1e300)).ln() / T::ln_2()) as i32) / 2 - 2;
    let k = to_f64((v.ln() / T::ln_2()).round()) as i32;
    k.clamp(-limit, limit)
}

/// `m · 2^k`, exact barring overflow and underflow.
pub(crate) fn scaled_pow2<T: Real>(m: &DMatrix<T>, k: i32) -> DMatrix<T> {
    if k == 0 {
        return m.clone();
    }
    m * c::<T>(2.0).powi(k)
}

/// The problem after rescaling and balancing: `X = s D⁻¹ X̃ D⁻¹`.
pub(crate) struct Scaled<T: Real> {
    pub(crate) a: DMatrix<T>,
    pub(crate) bh: DMatrix<T>,
    pub(crate) q: DMatrix<T>,
    pub(crate) g: DMatrix<T>,
    pub(crate) d: Vec<T>,
    pub(crate) s: T,
}

/// Diagonal scaling `d` (powers of two) that balances the Hamiltonian under the symplectic
/// similarity `diag(D, D⁻¹)`: `A_ij d_j / d_i`, `G_ij / (d_i d_j)`, `Q_ij d_i d_j`
/// (Parlett–Reinsch-like sweeps on 1-norms, at most 50, with 2⁻⁵⁰ ≤ d_i ≤ 2⁵⁰).
pub(crate) fn balance<T: Real>(a: &DMatrix<T>, g: &DMatrix<T>, q: &DMatrix<T>) -> Vec<T> {
    let n = a.nrows();
    let mut d = alloc::vec![T::one(); n];
    let mut exps = alloc::vec![0i32; n];
    // The scaled absolute values (column-major), updated in place with each accepted factor.
    let mut aa: Vec<T> = a.iter().map(|v| v.abs()).collect();
    let mut qa: Vec<T> = q.iter().map(|v| v.abs()).collect();
    let mut ga: Vec<T> = g.iter().map(|v| v.abs()).collect();
    let two = c::<T>(2.0);
    for _ in 0..50 {
        let mut changed = false;
        for i in 0..n {
            // The i-th row and column sums as a function of the factor f on d_i: the
            // off-diagonal A and Q terms scale with f, A's row and G with 1/f, Q_ii with f²,
            // G_ii with 1/f²; the sum is convex in log f, so walk in powers of two.
            let col = i * n..(i + 1) * n;
            let (qd, gd, ad) = (qa[i * n + i], ga[i * n + i], aa[i * n + i]);
            let mut a_row = T::zero();
            for j in 0..n {
                a_row += aa[j * n + i];
            }
            let a_col = aa[col.clone()].iter().fold(T::zero(), |acc, &v| acc + v);
            let q_col = qa[col.clone()].iter().fold(T::zero(), |acc, &v| acc + v);
            let g_col = ga[col.clone()].iter().fold(T::zero(), |acc, &v| acc + v);
            let grow = a_col - ad + q_col - qd;
            let shrink = a_row - ad + g_col - gd;
            let total = |f: T| grow * f + qd * f * f + shrink / f + gd / (f * f);
            let before = total(T::one());
            // Only terms on both sides give the sum a finite minimum.
            if (grow + qd).is_zero() || (shrink + gd).is_zero() || !before.is_finite() {
                continue;
            }
            // Walk up, else down, while the sum decreases; |log2 d_i| stays ≤ 50.
            let mut k = 0i32;
            let mut f = T::one();
            for (dir, step) in [(1i32, two), (-1, T::one() / two)] {
                let mut best = before;
                while (exps[i] + k + dir).abs() <= 50 {
                    let next = total(f * step);
                    if !(next < best) {
                        break;
                    }
                    best = next;
                    k += dir;
                    f *= step;
                }
                if k != 0 {
                    break;
                }
            }
            if k != 0 && total(f) < c::<T>(0.95) * before {
                exps[i] += k;
                d[i] *= f;
                changed = true;
                let inv_f = T::one() / f;
                // Column i by f (A, Q) or 1/f (G), then row i by 1/f (A, G) or f (Q).
                aa[col.clone()].iter_mut().for_each(|v| *v *= f);
                qa[col.clone()].iter_mut().for_each(|v| *v *= f);
                ga[col].iter_mut().for_each(|v| *v *= inv_f);
                for j in 0..n {
                    aa[j * n + i] *= inv_f;
                    qa[j * n + i] *= f;
                    ga[j * n + i] *= inv_f;
                }
            }
        }
        if !changed {
            break;
        }
    }
    d
}

