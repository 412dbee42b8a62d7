//! The continuous-time algebraic Riccati equation (CARE) and the LQR gain, on dense
//! heap matrices of any size (feature `alloc`). No LAPACK: nalgebra's decompositions only.
//!
//! [`care`] returns the stabilising solution `X` of
//!
//! ```text
//! X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q = 0,        A − B R⁻¹ Bᵀ X Hurwitz,
//! ```
//!
//! and [`lqr`] the gain `K = R⁻¹ Bᵀ X` of the control law `u = −K x` with the eigenvalues
//! of `A − B K` (python-control's `lqr(A, B, Q, R) -> K, S, E`).
//!
//! Method, with `G = B R⁻¹ Bᵀ = Bh Bhᵀ` (`Bh = B L⁻ᵀ`, `R = L Lᵀ`):
//!
//! 1. Checks: shapes, finiteness, `Q = Qᵀ` (indefinite allowed, as in SciPy), `R = Rᵀ ≻ 0`,
//!    then the PBH rank test on every eigenvalue λ of `A` with `Re λ ≥ −√ε ‖A‖`:
//!    `rank [A − λI, B] = n` (stabilizable) and, for `Q ⪰ 0` and `Re λ ≈ 0`,
//!    `rank [A − λI; Q] = n` (no undamped mode invisible to the cost). The rank is judged from the triangular factor
//!    of a QR decomposition, whose `‖R‖ ‖R⁻¹‖` brackets the condition number within a factor
//!    n; a tight tolerance (10³ (n+m) ε) up front, a loose one (10 √ε) to name the cause
//!    when the solver fails.
//! 2. Exact rescalings by powers of two: the equation divided by `α ≈ max(‖A‖, √(‖Q‖ ‖G‖))`
//!    (X unchanged), a diagonal state scaling that balances the Hamiltonian
//!    (`Ã = D⁻¹ A D`, `B̃ = D⁻¹ B`, `Q̃ = D Q D`) and `X = s X̃` with `s = 4^k` so that
//!    `‖Q̃‖ ≈ ‖G̃‖`. Schur forms and PBH matrices are likewise scaled to unit size first.
//! 3. The matrix sign function of the Hamiltonian `H = [[A, −G], [−Q, −Aᵀ]]` by Newton's
//!    iteration `Z ← (c Z + Z⁻¹ / c) / 2` with determinant scaling `c = |det Z|^(−1/2n)`
//!    (dropped near convergence), run on the symmetric `W = J Z` (`J = [[0, I], [−I, 0]]`),
//!    symmetrised at every step. It stops once the quadratic phase has made the change
//!    small (≤ 10 √ε) or stagnates. `[I; X]` spans the stable invariant subspace,
//!    `(sign H + I) [I; X] = 0`, which gives `X` from a 2n×n least-squares problem (QR).
//! 4. Newton–Kleinman refinement in correction form, `(A − G X)ᵀ D + D (A − G X) = −Ric(X)`,
//!    each Lyapunov equation solved by Bartels–Stewart on the real Schur form of the closed
//!    loop, for as long as the residual decreases (down to n ε relative to its terms; from a
//!    poor start it goes on through increases, keeping the best iterate). The residual's
//!    quadratic term is formed as `Fᵀ F`, `F = Bhᵀ X`, never as `(X G) X`. The Schur forms
//!    tell whether the closed loop is stable (`Re λ < −100 n ε ‖A − G X‖`); an `X` that is
//!    not stabilising, or whose relative residual stayed above √ε, is an error, never a
//!    silent answer.
//!
//! Every loop has a cap (`Schur` and `SymmetricEigen` are called through `try_new`).

// `!(a <= b)` rather than `a > b` on purpose: a NaN must fail every acceptance test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use alloc::vec::Vec;
use core::cmp::Ordering;

use nalgebra::{Cholesky, Complex, ComplexField, DMatrix, Dyn, Schur, SymmetricEigen, QR};

use crate::{c, to_f64, Real, TwipError};

pub(crate) mod checks;
pub(crate) mod lyapunov;
pub(crate) mod newton;
pub(crate) mod pbh;
pub(crate) mod scaling;
pub(crate) mod schur;
pub(crate) mod sign;
#[cfg(test)]
mod tests;

use checks::*;
use lyapunov::*;
use newton::*;
use pbh::*;
use scaling::*;
use schur::*;
use sign::*;


/// Cap on the Newton iterations of the matrix sign function (it takes ~5–15).
pub(crate) const SIGN_MAX_ITER: usize = 100;
/// Determinant scaling stops after this many sign iterations at the latest.
pub(crate) const SIGN_SCALED_MAX_ITER: usize = 20;
/// Cap on the Newton–Kleinman refinement steps (it takes 0–3 after the sign function; from
/// the fallback start near a double Hamiltonian eigenvalue at 0 it converges linearly).
const NEWTON_MAX_ITER: usize = 80;

/// The result of [`lqr`] (and of [`crate::control::dare::dlqr`], whose gain is
/// `(R + Bᵀ X B)⁻¹ Bᵀ X A` and whose `X` solves the DARE).
#[derive(Clone, Debug, PartialEq)]
pub struct Lqr<T: Real> {
    /// The gain `K = R⁻¹ Bᵀ X` (m×n) of the control law `u = −K x`.
    pub k: DMatrix<T>,
    /// The stabilising solution `X` of the CARE (n×n, symmetric; positive semi-definite when Q is).
    pub x: DMatrix<T>,
    /// The eigenvalues of `A − B K`, sorted by real part then imaginary part.
    pub poles: Vec<Complex<T>>,
}

/// Solves `X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q = 0` for the stabilising `X` (see the module docs).
///
/// `A` is n×n, `B` n×m, `Q` n×n symmetric (indefinite allowed), `R` m×m symmetric
/// positive definite. Errors: [`TwipError::Shape`], [`TwipError::NonFinite`],
/// [`TwipError::InvalidParameter`] (Q or R not symmetric, R not PD),
/// [`TwipError::NotStabilizable`], [`TwipError::NotDetectable`] (an undamped mode invisible
/// to a semi-definite Q), [`TwipError::NoStabilizingSolution`] (the Hamiltonian has
/// eigenvalues on the imaginary axis), [`TwipError::NoConvergence`].
pub fn care<T: Real>(a: &DMatrix<T>, b: &DMatrix<T>, q: &DMatrix<T>, r: &DMatrix<T>) -> Result<DMatrix<T>, TwipError> {
    let problem = Problem::new(a, b, q, r)?;
    problem.solve()
}

/// Linear-quadratic regulator: `K = R⁻¹ Bᵀ X` with `X = care(A, B, Q, R)`, and the
/// eigenvalues of the closed loop `A − B K` (python-control's convention, `u = −K x`).
pub fn lqr<T: Real>(a: &DMatrix<T>, b: &DMatrix<T>, q: &DMatrix<T>, r: &DMatrix<T>) -> Result<Lqr<T>, TwipError> {
    let problem = Problem::new(a, b, q, r)?;
    let x = problem.solve()?;
    let k = problem.chol_r.solve(&(b.transpose() * &x));
    let poles = sorted_eigenvalues(a - b * &k)?;
    Ok(Lqr { k, x, poles })
}

/// A checked problem: symmetrised `Q`, the Cholesky factor `L` of `R` and `Bh = B L⁻ᵀ`,
/// so that `G = B R⁻¹ Bᵀ = Bh Bhᵀ` and `X G X = Fᵀ F` with `F = Bhᵀ X`: never the product
/// `(X G) X`, whose rounding swamps the residual when `R` is small or `X` large.
struct Problem<'a, T: Real> {
    a: &'a DMatrix<T>,
    b: &'a DMatrix<T>,
    q: DMatrix<T>,
    /// The smallest eigenvalue of Q.
    q_min: T,
    /// Q is positive semi-definite (up to rounding).
    q_psd: bool,
    bh: DMatrix<T>,
    chol_r: Cholesky<T, Dyn>,
}

impl<'a, T: Real> Problem<'a, T> {
    fn new(a: &'a DMatrix<T>, b: &'a DMatrix<T>, q: &DMatrix<T>, r: &DMatrix<T>) -> Result<Self, TwipError> {
        let (n, m, q, r) = checked_problem(a, b, q, r)?;

        let eps = T::default_epsilon();
        // Q may be indefinite (as in SciPy and python-control): a stabilising solution exists
        // whenever the Hamiltonian has no eigenvalue on the imaginary axis, which the solver
        // finds out itself. Its smallest eigenvalue decides whether a detectability test applies.
        let (q_min, q_psd) = smallest_eigenvalue("Q", &q)?;
        let r_eig = symmetric_eigenvalues("R", &r)?;
        let r_top = r_eig.iter().fold(T::zero(), |acc, v| acc.max(v.abs()));
        let r_min = r_eig.iter().fold(r_top, |acc, &v| acc.min(v));
        let not_pd = TwipError::InvalidParameter {
            name: "R",
            value: to_f64(r_min),
            reason: "must be positive definite (the value is its smallest eigenvalue)",
        };
        if r_min <= c::<T>(10.0) * c::<T>(m as f64) * eps * r_top {
            return Err(not_pd);
        }
        let chol_r = Cholesky::new(r).ok_or(not_pd)?;
        // Bhᵀ = L⁻¹ Bᵀ.
        let bht = chol_r
            .l()
            .solve_lower_triangular(&b.transpose())
            .ok_or(TwipError::InvalidParameter {
                name: "R",
                value: to_f64(r_min),
                reason: "must be positive definite (the value is its smallest eigenvalue)",
            })?;
        let problem = Problem {
            a,
            b,
            q,
            q_min,
            q_psd,
            bh: bht.transpose(),
            chol_r,
        };
        problem.check_pbh(c::<T>(1e3) * c::<T>((n + m) as f64) * eps)?;
        Ok(problem)
    }

    /// The PBH tests with relative rank tolerance `tol`, on the eigenvalues of A with real
    /// part ≥ −√ε ‖A‖: (A, B) stabilizable; and, for a positive semi-definite Q, no mode on
    /// the imaginary axis invisible to Q (else the Hamiltonian has that eigenvalue too and no
    /// stabilising solution exists). An unstable mode invisible to Q is no obstacle: the
    /// stabilising solution exists and mirrors it. A Schur form that does not converge skips
    /// the tests: the solver's own checks (residual, closed-loop stability) still stand.
    fn check_pbh(&self, tol: T) -> Result<(), TwipError> {
        // The margins are relative to the balanced A's size (see `check_pbh`).
        let margin = |size: T| T::default_epsilon().sqrt() * size * c::<T>(self.a.nrows() as f64);
        let weight = Weight { q: &self.q, q_min: self.q_min, q_psd: self.q_psd };
        check_pbh(self.a, self.b, weight, tol, |l, size| l.re >= -margin(size), |l, size| l.re.abs() <= margin(size))
    }

    fn solve(&self) -> Result<DMatrix<T>, TwipError> {
        // X at the size Q and G give it, else at the size A and G give it: a tiny Q on an
        // unstable A (X ≈ its Q = 0 value, ~‖A‖/‖G‖) scaled the first way leaves G̃ at
        // ‖Q‖/‖G‖ of Ã and the sign iteration sees an imaginary axis that is not there.
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

    /// The balanced and scaled problem (step 2 of the module docs), all scalings exact;
    /// with `from_a`, `s` brings ‖G̃‖ to ‖Ã‖ instead of balancing ‖Q̃‖ against it.
    fn scaled(&self, from_a: bool) -> Scaled<T> {
        // Dividing the equation by α = 4^j (A, G, Q → A/α, G/α, Q/α) leaves X alone; α ≈ the
        // larger of ‖A‖ and √(‖Q‖ ‖G‖) brings the data near unit size.
        let size = self.a.amax().max(self.q.amax().sqrt() * self.bh.amax());
        let j = if size > T::zero() {
            pow2_exponent::<T>(size) / 2
        } else {
            0
        };
        let a = scaled_pow2(self.a, -2 * j);
        let bh = scaled_pow2(&self.bh, -j);
        let q = scaled_pow2(&self.q, -2 * j);
        // A symplectic diagonal similarity x = D x̃ (powers of two): Ã = D⁻¹ A D,
        // B̃h = D⁻¹ Bh, Q̃ = D Q D, X = D⁻¹ X̃ D⁻¹. It evens out badly scaled states.
        let d = balance(&a, &(&bh * bh.transpose()), &q);
        let a = DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] * d[j] / d[i]);
        let bh = DMatrix::from_fn(bh.nrows(), bh.ncols(), |i, j| bh[(i, j)] / d[i]);
        let q = DMatrix::from_fn(q.nrows(), q.ncols(), |i, j| q[(i, j)] * d[i] * d[j]);
        // X = s X̃ turns the equation into one with s G and Q / s: balance their norms, with
        // s = 4^k so that Bh scales by 2^k.
        let g = &bh * bh.transpose();
        let (qn, gn) = (q.norm(), g.norm());
        let k = if from_a && gn > T::zero() && a.norm() > T::zero() {
            pow2_exponent::<T>(a.norm() / gn) / 2
        } else if qn > T::zero() && gn > T::zero() {
            pow2_exponent::<T>(qn / gn) / 2
        } else {
            0
        };
        let half = c::<T>(2.0).powi(k);
        let s = half * half;
        let q = q / s;
        let bh = bh * half;
        let g = symmetrise(g * s);
        Scaled { a, bh, q, g, d, s }
    }

    fn solve_scaled(&self, from_a: bool) -> Result<DMatrix<T>, TwipError> {
        let sc = self.scaled(from_a);
        // The sign iteration fails when the Hamiltonian has eigenvalues on, or within rounding
        // of, the imaginary axis; Newton–Kleinman from a stabilising start still finds the
        // stabilising solution of the latter, and fails on the former.
        let (x0, fallback) = match sign_solution(&sc.a, &sc.g, &sc.q) {
            Some(x0) => (x0, false),
            None => (stabilising_start(&sc).ok_or(TwipError::NoStabilizingSolution)?, true),
        };
        let (x, rel_res, stable) = refine(&sc.a, &sc.bh, &sc.q, x0)?;
        let small = rel_res <= T::default_epsilon().sqrt();
        if !stable || (fallback && !small) {
            return Err(TwipError::NoStabilizingSolution);
        }
        if !small {
            return Err(TwipError::NoConvergence {
                what: "CARE solver (no stabilising solution with a small residual)",
                iterations: SIGN_MAX_ITER + NEWTON_MAX_ITER,
            });
        }
        let (d, s) = (&sc.d, sc.s);
        let x = DMatrix::from_fn(x.nrows(), x.ncols(), |i, j| x[(i, j)] * s / (d[i] * d[j]));
        Ok(symmetrise(x))
    }
}

