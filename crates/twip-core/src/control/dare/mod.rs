//! The discrete-time algebraic Riccati equation (DARE) and the discrete LQR gain, on dense
//! heap matrices of any size (feature `alloc`). No LAPACK: nalgebra's decompositions and the
//! CARE solver's pieces ([`crate::control::care`]).
//!
//! [`dare`] returns the stabilising solution `X` of
//!
//! ```text
//! Aᵀ X A − X − Aᵀ X B (R + Bᵀ X B)⁻¹ Bᵀ X A + Q = 0,   A − B K stable (|λ| < 1),
//! K = (R + Bᵀ X B)⁻¹ Bᵀ X A,
//! ```
//!
//! with SciPy's `solve_discrete_are` semantics: Q and R symmetric, either may be indefinite
//! or singular so long as the pencil of the equation has no eigenvalue on the unit circle
//! and `R + Bᵀ X B` is invertible. [`dlqr`] returns `K`, `X` and the eigenvalues of
//! `A − B K` (python-control's `dlqr(A, B, Q, R) -> K, S, E`).
//!
//! Method:
//!
//! 1. Checks: shapes, finiteness, symmetry of Q and R (the CARE's), then the PBH rank test on
//!    every eigenvalue λ of A with `|λ| ≥ 1 − n √ε max(1, ‖A‖)`: `rank [A − λI, B] = n`, and,
//!    for `Q ⪰ 0` and `|λ| ≈ 1`, `rank [A − λI; Q] = n` (no mode on the unit circle invisible
//!    to the cost: it would be an eigenvalue of the pencil).
//! 2. Exact rescalings by powers of two: a diagonal state scaling `x = D x̃` that balances
//!    A against Q and G (`G = B R⁻¹ Bᵀ`, or `B Bᵀ / ‖R‖` for an ill-conditioned R), and
//!    `X = s X̃` (Q and R divided by `s = 4^k`) so that `‖Q̃‖ ≈ ‖G̃‖`.
//! 3. SciPy's extended pencil `(2n+m)`, compressed to `2n` by the orthogonal complement of
//!    `[B; 0; R]` (a QR decomposition), so that R is never inverted; its Cayley transform
//!    `Z = (M + N)⁻¹ (M − N)` is a Hamiltonian matrix whose stable invariant subspace is
//!    `[I; X]` (the unit circle maps to the imaginary axis). `X` comes from the CARE's matrix
//!    sign function of `Z` ([`pencil`]). Should the sign iteration fail (eigenvalues within
//!    rounding of the unit circle), it starts from the stabilising solution for
//!    `Q + (‖Q‖ + 1) I` instead, as the CARE solver does.
//! 4. Newton refinement (Hewer's iteration in correction form): `D − A_clᵀ D A_cl = Res(X)`,
//!    each Stein equation solved by Bartels–Stewart on the real Schur form of the closed loop
//!    ([`stein`]), the same loop as the CARE's Newton–Kleinman refinement. The Schur forms say
//!    whether the closed loop is stable (`|λ| < 1 − 100 n ε`); an `X` that is not stabilising,
//!    or whose relative residual stayed above √ε, is an error, never a silent answer.
//!
//! Every loop has a cap.

// `!(a <= b)` rather than `a > b` on purpose: a NaN must fail every acceptance test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use nalgebra::{Complex, DMatrix, SymmetricEigen};

use crate::control::care::checks::{checked_problem, smallest_eigenvalue, symmetrise};
use crate::control::care::newton::refine_with;
use crate::control::care::pbh::{check_pbh, Weight};
use crate::control::care::scaling::{balance, pow2_exponent};
use crate::control::care::schur::sorted_eigenvalues;
use crate::control::care::sign::sign_solution;
use crate::control::care::{Lqr, SIGN_MAX_ITER};
use crate::{c, Real, TwipError};

mod hewer;
mod pencil;
pub(crate) mod stein;
#[cfg(test)]
mod tests;

use hewer::Discrete;
use pencil::cayley_hamiltonian;

/// Cap on Hewer's refinement steps (it takes 0–3 after the sign function; from the
/// fallback start it converges linearly at worst).
const HEWER_MAX_ITER: usize = 80;

/// Solves the DARE for the stabilising `X` (see the module docs).
///
/// `A` is n×n, `B` n×m, `Q` n×n and `R` m×m symmetric (indefinite or singular allowed where
/// the pencil allows it). Errors: [`TwipError::Shape`], [`TwipError::NonFinite`],
/// [`TwipError::InvalidParameter`] (Q or R not symmetric), [`TwipError::NotStabilizable`],
/// [`TwipError::NotDetectable`] (a mode on the unit circle invisible to a semi-definite Q),
/// [`TwipError::NoStabilizingSolution`] (the pencil has eigenvalues on the unit circle, or
/// `R + Bᵀ X B` is singular), [`TwipError::NoConvergence`].
pub fn dare<T: Real>(a: &DMatrix<T>, b: &DMatrix<T>, q: &DMatrix<T>, r: &DMatrix<T>) -> Result<DMatrix<T>, TwipError> {
    Problem::new(a, b, q, r)?.solve()
}

/// Discrete-time linear-quadratic regulator: `K = (R + Bᵀ X B)⁻¹ Bᵀ X A` with
/// `X = dare(A, B, Q, R)`, and the eigenvalues of `A − B K` (python-control's `dlqr`), as
/// an [`Lqr`] (its `k`: `u[k] = −K x[k]`).
pub fn dlqr<T: Real>(a: &DMatrix<T>, b: &DMatrix<T>, q: &DMatrix<T>, r: &DMatrix<T>) -> Result<Lqr<T>, TwipError> {
    let problem = Problem::new(a, b, q, r)?;
    let x = problem.solve()?;
    let equation = Discrete { a, b, q: &problem.q, r: &problem.r };
    let (k, _) = equation.gain(&x).ok_or(TwipError::NoStabilizingSolution)?;
    let poles = sorted_eigenvalues(a - b * &k)?;
    Ok(Lqr { k, x, poles })
}

/// A checked problem: symmetrised Q and R.
struct Problem<'a, T: Real> {
    a: &'a DMatrix<T>,
    b: &'a DMatrix<T>,
    q: DMatrix<T>,
    r: DMatrix<T>,
    /// The smallest eigenvalue of Q.
    q_min: T,
    /// Q is positive semi-definite (up to rounding).
    q_psd: bool,
}

impl<'a, T: Real> Problem<'a, T> {
    fn new(a: &'a DMatrix<T>, b: &'a DMatrix<T>, q: &DMatrix<T>, r: &DMatrix<T>) -> Result<Self, TwipError> {
        let (n, m, q, r) = checked_problem(a, b, q, r)?;
        let (q_min, q_psd) = smallest_eigenvalue("Q", &q)?;
        let problem = Problem { a, b, q, r, q_min, q_psd };
        problem.check_pbh(c::<T>(1e3) * c::<T>((n + m) as f64) * T::default_epsilon())?;
        Ok(problem)
    }

    /// The PBH tests with relative rank tolerance `tol` on the eigenvalues of A on or outside
    /// the unit circle (within `n √ε max(1, ‖A‖)`).
    fn check_pbh(&self, tol: T) -> Result<(), TwipError> {
        let n = self.a.nrows();
        // The margins are relative to the balanced A's size (see `check_pbh`).
        let margin = |a_size: T| T::default_epsilon().sqrt() * a_size.max(T::one()) * c::<T>(n as f64);
        let weight = Weight { q: &self.q, q_min: self.q_min, q_psd: self.q_psd };
        let size = |l: &Complex<T>| l.re.hypot(l.im);
        check_pbh(self.a, self.b, weight, tol, |l, a_size| size(l) >= T::one() - margin(a_size), |l, a_size| {
            (size(l) - T::one()).abs() <= margin(a_size)
        })
    }

    fn solve(&self) -> Result<DMatrix<T>, TwipError> {
        // As the CARE: should X at the size Q and G give it fail, X at the size A and G give
        // it (a tiny Q on an unstable A).
        let first = self.solve_scaled(false);
        let retry = matches!(first, Err(TwipError::NoStabilizingSolution | TwipError::NoConvergence { .. }));
        match if retry { self.solve_scaled(true).or(first) } else { first } {
            Ok(x) => Ok(x),
            // A failure close to the rank tolerance is reported as what it most likely is.
            Err(e) => {
                self.check_pbh(T::default_epsilon().sqrt() * c::<T>(10.0))?;
                Err(e)
            }
        }
    }

    /// A stand-in for `G = B R⁻¹ Bᵀ` to scale by: itself when R is well conditioned
    /// (eigenvalues within 10⁸ of each other in size), else `B Bᵀ / ‖R‖`.
    fn g_for_scaling(&self) -> DMatrix<T> {
        let m = self.r.nrows();
        let cap = 100 + 40 * m;
        let bbt = self.b * self.b.transpose();
        let Some(eig) = SymmetricEigen::try_new(self.r.clone(), T::default_epsilon(), cap) else {
            return bbt;
        };
        let top = eig.eigenvalues.amax();
        let low = eig.eigenvalues.iter().fold(top, |acc, v| acc.min(v.abs()));
        if !(top > T::zero()) {
            return bbt;
        }
        if !(low > c::<T>(1e-8) * top) {
            return bbt / top;
        }
        let bv = self.b * &eig.eigenvectors;
        let scaled = DMatrix::from_fn(bv.nrows(), m, |i, j| bv[(i, j)] / eig.eigenvalues[j]);
        symmetrise(scaled * bv.transpose())
    }

    /// With `from_a`, `s` brings ‖G̃‖ to max(‖Ã‖², 1) instead of balancing ‖Q̃‖ against it.
    fn solve_scaled(&self, from_a: bool) -> Result<DMatrix<T>, TwipError> {
        // x = D x̃: Ã = D⁻¹ A D, B̃ = D⁻¹ B, Q̃ = D Q D, X = D⁻¹ X̃ D⁻¹ (powers of two).
        let g = self.g_for_scaling();
        let d = balance(self.a, &g, &self.q);
        let (n, m) = self.b.shape();
        let a = DMatrix::from_fn(n, n, |i, j| self.a[(i, j)] * d[j] / d[i]);
        let b = DMatrix::from_fn(n, m, |i, j| self.b[(i, j)] / d[i]);
        let q = DMatrix::from_fn(n, n, |i, j| self.q[(i, j)] * d[i] * d[j]);
        let g = DMatrix::from_fn(n, n, |i, j| g[(i, j)] / (d[i] * d[j]));
        // X = s X̃ with Q and R divided by s = 4^k (G times s): balance ‖Q̃‖ against ‖G̃‖.
        let (qn, gn) = (q.norm(), g.norm());
        let k = if from_a && gn > T::zero() {
            pow2_exponent::<T>(a.norm().powi(2).max(T::one()) / gn) / 2
        } else if qn > T::zero() && gn > T::zero() {
            pow2_exponent::<T>(qn / gn) / 2
        } else {
            0
        };
        let s = c::<T>(4.0).powi(k);
        let (q, r) = (q / s, &self.r / s);

        let start = |q: &DMatrix<T>| {
            let (ac, gc, qc) = cayley_hamiltonian(&a, &b, q, &r)?;
            sign_solution(&ac, &gc, &qc)
        };
        // The sign iteration fails when the pencil has eigenvalues on, or within rounding of,
        // the unit circle; Hewer's iteration from a stabilising start still finds the
        // stabilising solution of the latter, and fails on the former.
        let (x0, fallback) = match start(&q) {
            Some(x0) => (x0, false),
            None => {
                let shifted = &q + DMatrix::<T>::identity(n, n) * (q.norm() + T::one());
                (start(&shifted).ok_or(TwipError::NoStabilizingSolution)?, true)
            }
        };
        let equation = Discrete { a: &a, b: &b, q: &q, r: &r };
        let (x, rel_res, stable) = refine_with(&equation, x0, HEWER_MAX_ITER)?;
        let small = rel_res <= T::default_epsilon().sqrt();
        if !stable || (fallback && !small) {
            return Err(TwipError::NoStabilizingSolution);
        }
        if !small {
            return Err(TwipError::NoConvergence {
                what: "DARE solver (no stabilising solution with a small residual)",
                iterations: SIGN_MAX_ITER + HEWER_MAX_ITER,
            });
        }
        let x = DMatrix::from_fn(n, n, |i, j| x[(i, j)] * s / (d[i] * d[j]));
        Ok(symmetrise(x))
    }
}

/// `true` when `equation`'s closed loop at `x` is stable: for tests.
#[cfg(test)]
fn stabilising<T: Real>(a: &DMatrix<T>, b: &DMatrix<T>, q: &DMatrix<T>, r: &DMatrix<T>, x: &DMatrix<T>) -> bool {
    use crate::control::care::newton::Riccati;
    let equation = Discrete { a, b, q, r };
    equation.closed_loop(x).map(|(_, t)| equation.is_stable(&t)).unwrap_or(false)
}
