//! Lyapunov equations by Bartels–Stewart on a real Schur form.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use nalgebra::DMatrix;

use super::*;

/// Solves `Mᵀ D + D M = F` (F symmetric) with `M = U T Uᵀ` in real Schur form
/// (Bartels–Stewart): `Tᵀ Y + Y T = Uᵀ F U`, block by block, then `D = U Y Uᵀ`.
pub(crate) fn lyapunov_schur<T: Real>(u: &DMatrix<T>, t: &DMatrix<T>, f: &DMatrix<T>) -> DMatrix<T> {
    let n = t.nrows();
    let ft = u.tr_mul(f) * u;
    let blocks = quasi_blocks(t);
    let eps = T::default_epsilon();
    let smin = (eps * t.amax()).max(eps * eps * eps);
    let mut y = DMatrix::<T>::zeros(n, n);
    for (bi, &(i0, si)) in blocks.iter().enumerate() {
        for &(j0, sj) in &blocks[bi..] {
            // Right-hand side: F_ij − Σ_{k<i0} T_ki Y_kj − Σ_{l<j0} Y_il T_lj.
            let mut rhs = [T::zero(); 4];
            for r in 0..si {
                for cc in 0..sj {
                    let (i, j) = (i0 + r, j0 + cc);
                    let mut s = ft[(i, j)];
                    for k in 0..i0 {
                        s -= t[(k, i)] * y[(k, j)];
                    }
                    for l in 0..j0 {
                        s -= y[(i, l)] * t[(l, j)];
                    }
                    rhs[r + si * cc] = s;
                }
            }
            // T_iiᵀ Z + Z T_jj = rhs as a (si·sj)-square system on vec(Z) (column-major).
            let mut mat = [[T::zero(); 4]; 4];
            for r in 0..si {
                for cc in 0..sj {
                    let row = r + si * cc;
                    for p in 0..si {
                        mat[row][p + si * cc] += t[(i0 + p, i0 + r)];
                    }
                    for qq in 0..sj {
                        mat[row][r + si * qq] += t[(j0 + qq, j0 + cc)];
                    }
                }
            }
            let z = solve_small(si * sj, mat, rhs, smin);
            for r in 0..si {
                for cc in 0..sj {
                    let v = z[r + si * cc];
                    y[(i0 + r, j0 + cc)] = v;
                    y[(j0 + cc, i0 + r)] = v;
                }
            }
        }
    }
    symmetrise(u * y * u.transpose())
}

/// Gaussian elimination with complete pivoting on a k×k system (k ≤ 4); pivots smaller
/// than `smin` are raised to it (as LAPACK's `dlasy2` does), so it always returns.
pub(crate) fn solve_small<T: Real>(k: usize, mut mat: [[T; 4]; 4], mut rhs: [T; 4], smin: T) -> [T; 4] {
    let mut cols = [0usize, 1, 2, 3];
    for p in 0..k {
        let (mut ip, mut jp, mut best) = (p, p, T::zero());
        for (i, row) in mat.iter().enumerate().take(k).skip(p) {
            for (j, v) in row.iter().enumerate().take(k).skip(p) {
                if v.abs() > best {
                    best = v.abs();
                    ip = i;
                    jp = j;
                }
            }
        }
        mat.swap(p, ip);
        rhs.swap(p, ip);
        if jp != p {
            for row in mat.iter_mut() {
                row.swap(p, jp);
            }
            cols.swap(p, jp);
        }
        if mat[p][p].abs() < smin {
            mat[p][p] = smin;
        }
        let pivot_row = mat[p];
        for i in (p + 1)..k {
            let f = mat[i][p] / pivot_row[p];
            if !f.is_zero() {
                for (x, &v) in mat[i].iter_mut().zip(pivot_row.iter()).take(k).skip(p) {
                    *x -= f * v;
                }
                let v = rhs[p];
                rhs[i] -= f * v;
            }
        }
    }
    let mut y = [T::zero(); 4];
    for p in (0..k).rev() {
        let mut s = rhs[p];
        for (&mpj, &yj) in mat[p].iter().zip(y.iter()).take(k).skip(p + 1) {
            s -= mpj * yj;
        }
        y[p] = s / mat[p][p];
    }
    let mut out = [T::zero(); 4];
    for p in 0..k {
        out[cols[p]] = y[p];
    }
    out
}

