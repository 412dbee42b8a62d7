//! Newton refinement of the DARE (Hewer's iteration in correction form) and its residual.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use nalgebra::DMatrix;

use super::stein::stein_schur;
use crate::control::care::checks::symmetrise;
use crate::control::care::newton::Riccati;
use crate::control::care::schur::{quasi_eigenvalues, schur, schur_cap};
use crate::{c, Real, TwipError};

/// The DARE `Aᵀ X A − X − Aᵀ X B (R + Bᵀ X B)⁻¹ Bᵀ X A + Q = 0`.
pub(crate) struct Discrete<'a, T: Real> {
    pub(crate) a: &'a DMatrix<T>,
    pub(crate) b: &'a DMatrix<T>,
    pub(crate) q: &'a DMatrix<T>,
    pub(crate) r: &'a DMatrix<T>,
}

impl<T: Real> Discrete<'_, T> {
    /// `(K, Bᵀ X A)` with `K = (R + Bᵀ X B)⁻¹ Bᵀ X A`, or `None` if `R + Bᵀ X B` is singular.
    pub(crate) fn gain(&self, x: &DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
        let xb = x * self.b;
        let rx = symmetrise(self.r + self.b.tr_mul(&xb));
        let bxa = xb.tr_mul(self.a);
        let k = rx.lu().solve(&bxa)?;
        k.iter().all(|v| v.is_finite()).then_some((k, bxa))
    }
}

impl<T: Real> Riccati<T> for Discrete<'_, T> {
    /// `Aᵀ X A − X − (Bᵀ X A)ᵀ K + Q` (symmetrised), its norm and its norm relative to the
    /// terms'; norm and relative norm are the largest finite value when `R + Bᵀ X B` is singular.
    fn residual(&self, x: &DMatrix<T>) -> (DMatrix<T>, T, T) {
        let Some((k, bxa)) = self.gain(x) else {
            let big = T::max_value().unwrap_or(c::<T>(f64::MAX));
            return (x.clone(), big, big);
        };
        let axa = self.a.tr_mul(&(x * self.a));
        let coupling = bxa.tr_mul(&k);
        let scale = axa.norm() + x.norm() + coupling.norm() + self.q.norm();
        let res = symmetrise(axa - x - coupling + self.q);
        let norm = res.norm();
        let rel = if scale > T::zero() { norm / scale } else { norm };
        (res, norm, rel)
    }

    fn closed_loop(&self, x: &DMatrix<T>) -> Result<(DMatrix<T>, DMatrix<T>), TwipError> {
        let (k, _) = self.gain(x).ok_or(TwipError::NoStabilizingSolution)?;
        schur(self.a - self.b * k).ok_or(TwipError::NoConvergence {
            what: "Schur decomposition of the closed loop",
            iterations: schur_cap(self.a.nrows()),
        })
    }

    /// All eigenvalues inside the unit circle by more than 100 n ε.
    fn is_stable(&self, t: &DMatrix<T>) -> bool {
        let radius = T::one() - c::<T>(100.0) * c::<T>(t.nrows() as f64) * T::default_epsilon();
        quasi_eigenvalues(t).iter().all(|l| l.re.hypot(l.im) < radius)
    }

    /// Hewer's step: `D − A_clᵀ D A_cl = Res(X)`, a Stein equation on the closed loop.
    fn correction(&self, u: &DMatrix<T>, t: &DMatrix<T>, res: &DMatrix<T>) -> DMatrix<T> {
        stein_schur(u, t, &(-res))
    }
}
