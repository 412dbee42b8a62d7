//! Stein (discrete Lyapunov) equations by Bartels–Stewart on a real Schur form.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use nalgebra::DMatrix;

use crate::control::care::checks::symmetrise;
use crate::control::care::lyapunov::solve_small;
use crate::control::care::schur::quasi_blocks;
use crate::Real;

/// Solves `Mᵀ D M − D = F` (F symmetric) with `M = U T Uᵀ` in real Schur form:
/// `Tᵀ Y T − Y = Uᵀ F U`, block by block, then `D = U Y Uᵀ`. Unique when no two eigenvalues
/// of M multiply to 1 (always, for a stable M).
///
/// Column block j after column block j, top to bottom: with `W = Y T` known on the blocks
/// above, block (i, j) reads `T_iiᵀ Y_ij T_jj − Y_ij = F_ij − T_iiᵀ Σ_{l<j} Y_il T_lj −
/// Σ_{k<i} T_kiᵀ W_kj`, a system of at most 4 unknowns.
pub(crate) fn stein_schur<T: Real>(u: &DMatrix<T>, t: &DMatrix<T>, f: &DMatrix<T>) -> DMatrix<T> {
    let n = t.nrows();
    let ft = u.tr_mul(f) * u;
    let blocks = quasi_blocks(t);
    let eps = T::default_epsilon();
    let smin = (eps * t.amax()).max(eps * eps * eps);
    let mut y = DMatrix::<T>::zeros(n, n);
    // W = Y T on the blocks solved so far.
    let mut w = DMatrix::<T>::zeros(n, n);
    for &(j0, sj) in &blocks {
        for &(i0, si) in &blocks {
            // S1 = Σ_{l<j} Y_il T_lj (si×sj), then the right-hand side.
            let mut s1 = [[T::zero(); 2]; 2];
            for (r, row) in s1.iter_mut().enumerate().take(si) {
                for (cc, v) in row.iter_mut().enumerate().take(sj) {
                    let mut s = T::zero();
                    for l in 0..j0 {
                        s += y[(i0 + r, l)] * t[(l, j0 + cc)];
                    }
                    *v = s;
                }
            }
            let mut rhs = [T::zero(); 4];
            for r in 0..si {
                for cc in 0..sj {
                    let mut s = ft[(i0 + r, j0 + cc)];
                    for p in 0..si {
                        s -= t[(i0 + p, i0 + r)] * s1[p][cc];
                    }
                    for k in 0..i0 {
                        s -= t[(k, i0 + r)] * w[(k, j0 + cc)];
                    }
                    rhs[r + si * cc] = s;
                }
            }
            // (T_jjᵀ ⊗ T_iiᵀ − I) vec(Y_ij) = rhs, column-major vec.
            let mut mat = [[T::zero(); 4]; 4];
            for r in 0..si {
                for cc in 0..sj {
                    let row = r + si * cc;
                    for p in 0..si {
                        for q in 0..sj {
                            mat[row][p + si * q] += t[(i0 + p, i0 + r)] * t[(j0 + q, j0 + cc)];
                        }
                    }
                    mat[row][row] -= T::one();
                }
            }
            let z = solve_small(si * sj, mat, rhs, smin);
            for r in 0..si {
                for cc in 0..sj {
                    y[(i0 + r, j0 + cc)] = z[r + si * cc];
                }
            }
            // W_ij = Y_ij T_jj + S1.
            for r in 0..si {
                for cc in 0..sj {
                    let mut s = s1[r][cc];
                    for q in 0..sj {
                        s += y[(i0 + r, j0 + q)] * t[(j0 + q, j0 + cc)];
                    }
                    w[(i0 + r, j0 + cc)] = s;
                }
            }
        }
    }
    symmetrise(u * y * u.transpose())
}
