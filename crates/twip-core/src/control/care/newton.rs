//! Newton–Kleinman refinement and the Riccati residual (step 4 of the CARE method).
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use nalgebra::DMatrix;

use super::*;


/// `Ric(X) = X A + Aᵀ X − Fᵀ F + Q` with `F = Bhᵀ X` (symmetrised) and its norm relative
/// to the terms'.
pub(crate) fn residual<T: Real>(a: &DMatrix<T>, bh: &DMatrix<T>, q: &DMatrix<T>, x: &DMatrix<T>) -> (DMatrix<T>, T, T) {
    let xa = x * a;
    let f = bh.tr_mul(x);
    let mut res = f.tr_mul(&f);
    let scale = c::<T>(2.0) * xa.norm() + res.norm() + q.norm();
    let n = x.nrows();
    for j in 0..n {
        for i in 0..=j {
            let v = xa[(i, j)] + xa[(j, i)] - res[(i, j)] + q[(i, j)];
            res[(i, j)] = v;
            res[(j, i)] = v;
        }
    }
    let norm = res.norm();
    let rel = if scale > T::zero() { norm / scale } else { norm };
    (res, norm, rel)
}

/// All eigenvalues of the quasi-triangular `t` in `Re λ < −100 n ε ‖t‖`: a real part
/// within rounding of zero is not taken for stability.
pub(crate) fn is_stable<T: Real>(t: &DMatrix<T>) -> bool {
    let margin = c::<T>(100.0) * c::<T>(t.nrows() as f64) * T::default_epsilon() * t.norm();
    quasi_eigenvalues(t).iter().all(|l| l.re < -margin)
}

/// What Newton refinement needs of a Riccati equation: its residual, the Schur form of the
/// closed loop of an iterate, whether that loop is stable, and the Newton correction (the
/// solution of the equation linearised about the iterate). The CARE's and the DARE's
/// refinements are this one loop over the two.
pub(crate) trait Riccati<T: Real> {
    /// The residual, its norm and its norm relative to the equation's terms.
    fn residual(&self, x: &DMatrix<T>) -> (DMatrix<T>, T, T);
    /// The real Schur form `(U, T)` of the closed loop of `x`.
    fn closed_loop(&self, x: &DMatrix<T>) -> Result<(DMatrix<T>, DMatrix<T>), TwipError>;
    /// Whether the closed loop with Schur factor `t` is stable.
    fn is_stable(&self, t: &DMatrix<T>) -> bool;
    /// The correction `D` that makes the linearised residual at `x + D` vanish.
    fn correction(&self, u: &DMatrix<T>, t: &DMatrix<T>, res: &DMatrix<T>) -> DMatrix<T>;
}

/// The CARE `X A + Aᵀ X − X Bh Bhᵀ X + Q = 0`: Newton–Kleinman.
pub(crate) struct Continuous<'a, T: Real> {
    pub(crate) a: &'a DMatrix<T>,
    pub(crate) bh: &'a DMatrix<T>,
    pub(crate) q: &'a DMatrix<T>,
}

impl<T: Real> Riccati<T> for Continuous<'_, T> {
    fn residual(&self, x: &DMatrix<T>) -> (DMatrix<T>, T, T) {
        residual(self.a, self.bh, self.q, x)
    }

    fn closed_loop(&self, x: &DMatrix<T>) -> Result<(DMatrix<T>, DMatrix<T>), TwipError> {
        schur(self.a - self.bh * self.bh.tr_mul(x)).ok_or(TwipError::NoConvergence {
            what: "Schur decomposition of the closed loop",
            iterations: schur_cap(self.a.nrows()),
        })
    }

    fn is_stable(&self, t: &DMatrix<T>) -> bool {
        is_stable(t)
    }

    fn correction(&self, u: &DMatrix<T>, t: &DMatrix<T>, res: &DMatrix<T>) -> DMatrix<T> {
        lyapunov_schur(u, t, &(-res))
    }
}

/// Newton–Kleinman refinement of the CARE (step 4): `(X, relative residual, closed loop stable)`.
pub(crate) fn refine<T: Real>(
    a: &DMatrix<T>,
    bh: &DMatrix<T>,
    q: &DMatrix<T>,
    x0: DMatrix<T>,
) -> Result<(DMatrix<T>, T, bool), TwipError> {
    refine_with(&Continuous { a, bh, q }, x0, NEWTON_MAX_ITER)
}

/// Newton refinement of a Riccati equation: `(X, relative residual, closed loop stable)`,
/// at most `max_iter` steps.
///
/// Stability is read from the Schur form of the closed loop that each Newton step computes,
/// and once more for the `X` returned: with an indefinite `Q`, or an unstable mode invisible
/// to `Q`, Kleinman's theorem (a Newton step from a stabilising `X` stabilises) does not hold.
/// From a poor start (relative residual above √ε) the iteration goes on even when the
/// residual grows for a step; the best stabilising iterate is kept.
pub(crate) fn refine_with<T: Real, P: Riccati<T>>(
    p: &P,
    x0: DMatrix<T>,
    max_iter: usize,
) -> Result<(DMatrix<T>, T, bool), TwipError> {
    let n = x0.nrows();
    let eps = T::default_epsilon();
    // Rounding alone leaves a relative residual of a few n ε: no step can do better.
    let floor = c::<T>(n as f64) * eps;
    let far = eps.sqrt();
    let mut x = x0;
    let (mut res, mut norm, mut rel) = p.residual(&x);
    // Whether the closed loop is stable, once known for the current X.
    let mut stable: Option<bool> = None;
    // A stabilising iterate with a smaller residual than the current one, if any.
    let mut best: Option<(DMatrix<T>, T)> = None;
    for _ in 0..max_iter {
        if !(rel > floor) && stable.is_some() {
            break;
        }
        let (u, t) = p.closed_loop(&x)?;
        let stable_here = p.is_stable(&t);
        stable = Some(stable_here);
        if !stable_here || !(rel > floor) {
            break;
        }
        let d = p.correction(&u, &t, &res);
        let candidate = symmetrise(&x + d);
        let (res_c, norm_c, rel_c) = p.residual(&candidate);
        if !(norm_c < norm) {
            if !(rel > far) {
                break;
            }
            if best.as_ref().is_none_or(|(_, r)| rel < *r) {
                best = Some((x.clone(), rel));
            }
        }
        x = candidate;
        res = res_c;
        norm = norm_c;
        rel = rel_c;
        stable = None;
    }
    let stable = match stable {
        Some(s) => s,
        None => p.is_stable(&p.closed_loop(&x)?.1),
    };
    match best {
        Some((xb, rb)) if !stable || !(rel <= rb) => Ok((xb, rb, true)),
        _ => Ok((x, rel, stable)),
    }
}
