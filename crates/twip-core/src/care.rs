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
//! 1. Checks: shapes, finiteness, `Q = Qᵀ ⪰ 0`, `R = Rᵀ ≻ 0`, then the PBH rank test on
//!    every eigenvalue λ of `A` with `Re λ ≥ −√ε ‖A‖`: `rank [A − λI, B] = n` (stabilizable)
//!    and `rank [A − λI; Q] = n` (detectable). The rank is judged from the triangular factor
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
//!    loop, for as long as the residual decreases (down to 4 n ε relative to its terms; from a
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

/// Cap on the Newton iterations of the matrix sign function (it takes ~5–15).
const SIGN_MAX_ITER: usize = 100;
/// Cap on the Newton–Kleinman refinement steps (it takes 0–3).
const NEWTON_MAX_ITER: usize = 30;

/// The result of [`lqr`].
#[derive(Clone, Debug, PartialEq)]
pub struct Lqr<T: Real> {
    /// The gain `K = R⁻¹ Bᵀ X` (m×n) of the control law `u = −K x`.
    pub k: DMatrix<T>,
    /// The stabilising solution `X` of the CARE (n×n, symmetric, positive semi-definite).
    pub x: DMatrix<T>,
    /// The eigenvalues of `A − B K`, sorted by real part then imaginary part.
    pub poles: Vec<Complex<T>>,
}

/// Solves `X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q = 0` for the stabilising `X` (see the module docs).
///
/// `A` is n×n, `B` n×m, `Q` n×n symmetric positive semi-definite, `R` m×m symmetric
/// positive definite. Errors: [`TwipError::Shape`], [`TwipError::NonFinite`],
/// [`TwipError::InvalidParameter`] (Q or R not symmetric, Q not PSD, R not PD),
/// [`TwipError::NotStabilizable`], [`TwipError::NotDetectable`], [`TwipError::NoConvergence`].
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
    let closed = a - b * &k;
    let (_, t) = schur(closed).ok_or(TwipError::NoConvergence {
        what: "Schur decomposition of the closed loop A - B K",
        iterations: schur_cap(a.nrows()),
    })?;
    let mut poles = quasi_eigenvalues(&t);
    poles.sort_by(|u, v| {
        u.re.partial_cmp(&v.re)
            .unwrap_or(Ordering::Equal)
            .then(u.im.partial_cmp(&v.im).unwrap_or(Ordering::Equal))
    });
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
    bh: DMatrix<T>,
    chol_r: Cholesky<T, Dyn>,
}

impl<'a, T: Real> Problem<'a, T> {
    fn new(a: &'a DMatrix<T>, b: &'a DMatrix<T>, q: &DMatrix<T>, r: &DMatrix<T>) -> Result<Self, TwipError> {
        let n = a.nrows();
        if n == 0 || a.ncols() != n {
            return Err(TwipError::Shape {
                name: "A",
                expected: (n.max(1), n.max(1)),
                got: a.shape(),
            });
        }
        let m = b.ncols();
        if b.nrows() != n || m == 0 {
            return Err(TwipError::Shape {
                name: "B",
                expected: (n, m.max(1)),
                got: b.shape(),
            });
        }
        if q.shape() != (n, n) {
            return Err(TwipError::Shape {
                name: "Q",
                expected: (n, n),
                got: q.shape(),
            });
        }
        if r.shape() != (m, m) {
            return Err(TwipError::Shape {
                name: "R",
                expected: (m, m),
                got: r.shape(),
            });
        }
        finite("A", a)?;
        finite("B", b)?;
        finite("Q", q)?;
        finite("R", r)?;
        let q = symmetric("Q", q)?;
        let r = symmetric("R", r)?;

        let eps = T::default_epsilon();
        let q_eig = symmetric_eigenvalues("Q", &q)?;
        let q_top = q_eig.iter().fold(T::zero(), |acc, v| acc.max(v.abs()));
        let q_min = q_eig.iter().fold(q_top, |acc, &v| acc.min(v));
        if q_min < -(c::<T>(100.0) * c::<T>(n as f64) * eps * q_top) {
            return Err(TwipError::InvalidParameter {
                name: "Q",
                value: to_f64(q_min),
                reason: "must be positive semi-definite (the value is its smallest eigenvalue)",
            });
        }
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
            bh: bht.transpose(),
            chol_r,
        };
        problem.check_pbh(c::<T>(1e3) * c::<T>((n + m) as f64) * eps)?;
        Ok(problem)
    }

    /// The PBH tests with relative rank tolerance `tol`: stabilizability of (A, B), then
    /// detectability of (A, Q), on the eigenvalues of A with real part ≥ −√ε ‖A‖.
    fn check_pbh(&self, tol: T) -> Result<(), TwipError> {
        let n = self.a.nrows();
        let (_, t) = schur(self.a.clone()).ok_or(TwipError::NoConvergence {
            what: "Schur decomposition of A (PBH test)",
            iterations: schur_cap(n),
        })?;
        let a_max = self.a.amax();
        let margin = T::default_epsilon().sqrt() * a_max * c::<T>(n as f64);
        let suspects: Vec<Complex<T>> = quasi_eigenvalues(&t)
            .into_iter()
            .filter(|l| l.re >= -margin && l.im >= T::zero())
            .collect();
        if suspects.is_empty() {
            return Ok(());
        }
        // Each PBH matrix is scaled as a whole by a power of two (its singular value ratio
        // does not change) so that no norm overflows or underflows.
        // (A, B) stabilizable: rank [A − λI, B] = n; (A, Q) detectable: rank [Aᵀ − λI, Q] = n.
        let tests = [
            (self.b, false, TwipError::NotStabilizable),
            (&self.q, true, TwipError::NotDetectable),
        ];
        for (other, transpose, error) in tests {
            let k = -pow2_exponent::<T>(a_max.max(other.amax()));
            let a = scaled_pow2(self.a, k);
            let a = if transpose { a.transpose() } else { a };
            let other = scaled_pow2(other, k);
            let f = c::<T>(2.0).powi(k);
            for lambda in &suspects {
                // A positive definite Q (σ_min ≥ its smallest eigenvalue) needs no test.
                let bound = c::<T>(n as f64) * (a_max + self.q.amax())
                    + c::<T>(n as f64).sqrt() * (lambda.re.abs() + lambda.im.abs());
                if transpose && self.q_min > tol * bound {
                    continue;
                }
                if rank_deficient(&a, &other, lambda.scale(f), tol) {
                    return Err(error);
                }
            }
        }
        Ok(())
    }

    fn solve(&self) -> Result<DMatrix<T>, TwipError> {
        match self.solve_scaled() {
            Ok(x) => Ok(x),
            // A failure close to the rank tolerance is reported as what it most likely is.
            Err(e) => {
                self.check_pbh(T::default_epsilon().sqrt() * c::<T>(10.0))?;
                Err(e)
            }
        }
    }

    /// The balanced and scaled problem (step 2 of the module docs), all scalings exact.
    fn scaled(&self) -> Scaled<T> {
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
        let d = balance(&a, &bh, &q);
        let a = DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] * d[j] / d[i]);
        let bh = DMatrix::from_fn(bh.nrows(), bh.ncols(), |i, j| bh[(i, j)] / d[i]);
        let q = DMatrix::from_fn(q.nrows(), q.ncols(), |i, j| q[(i, j)] * d[i] * d[j]);
        // X = s X̃ turns the equation into one with s G and Q / s: balance their norms, with
        // s = 4^k so that Bh scales by 2^k.
        let g = &bh * bh.transpose();
        let (qn, gn) = (q.norm(), g.norm());
        let k = if qn > T::zero() && gn > T::zero() {
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

    fn solve_scaled(&self) -> Result<DMatrix<T>, TwipError> {
        let sc = self.scaled();
        let x0 = sign_solution(&sc.a, &sc.g, &sc.q).ok_or(TwipError::NoConvergence {
            what: "CARE matrix sign function (Hamiltonian eigenvalues on the imaginary axis?)",
            iterations: SIGN_MAX_ITER,
        })?;
        let (x, rel_res, stable) = refine(&sc.a, &sc.bh, &sc.q, x0)?;
        if !stable || !(rel_res <= T::default_epsilon().sqrt()) {
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

/// The exponent k with 2^k nearest to `v` (> 0) in the log, clamped so that 2^±k and
/// 2^±2k stay finite and normal in `T`.
fn pow2_exponent<T: Real>(v: T) -> i32 {
    if !(v > T::zero()) || !v.is_finite() {
        return 0;
    }
    let limit = (to_f64(T::max_value().unwrap_or(c::<T>(1e300)).ln() / T::ln_2()) as i32) / 2 - 2;
    let k = to_f64((v.ln() / T::ln_2()).round()) as i32;
    k.clamp(-limit, limit)
}

/// `m · 2^k`, exact barring overflow and underflow.
fn scaled_pow2<T: Real>(m: &DMatrix<T>, k: i32) -> DMatrix<T> {
    if k == 0 {
        return m.clone();
    }
    m * c::<T>(2.0).powi(k)
}

/// The problem after rescaling and balancing: `X = s D⁻¹ X̃ D⁻¹`.
struct Scaled<T: Real> {
    a: DMatrix<T>,
    bh: DMatrix<T>,
    q: DMatrix<T>,
    g: DMatrix<T>,
    d: Vec<T>,
    s: T,
}

/// Diagonal scaling `d` (powers of two) that balances the Hamiltonian under the symplectic
/// similarity `diag(D, D⁻¹)`: `A_ij d_j / d_i`, `G_ij / (d_i d_j)`, `Q_ij d_i d_j`
/// (Parlett–Reinsch-like sweeps on 1-norms, at most 50, with 2⁻⁵⁰ ≤ d_i ≤ 2⁵⁰).
fn balance<T: Real>(a: &DMatrix<T>, bh: &DMatrix<T>, q: &DMatrix<T>) -> Vec<T> {
    let n = a.nrows();
    let mut d = alloc::vec![T::one(); n];
    let mut exps = alloc::vec![0i32; n];
    // The scaled absolute values (column-major), updated in place with each accepted factor.
    let mut aa: Vec<T> = a.iter().map(|v| v.abs()).collect();
    let mut qa: Vec<T> = q.iter().map(|v| v.abs()).collect();
    let mut ga: Vec<T> = (bh * bh.transpose()).iter().map(|v| v.abs()).collect();
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

fn finite<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<(), TwipError> {
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
fn symmetric<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<DMatrix<T>, TwipError> {
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

fn symmetrised<T: Real>(m: &DMatrix<T>) -> DMatrix<T> {
    symmetrise(m.clone())
}

/// (M + Mᵀ)/2 in place.
fn symmetrise<T: Real>(mut m: DMatrix<T>) -> DMatrix<T> {
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

fn symmetric_eigenvalues<T: Real>(name: &'static str, m: &DMatrix<T>) -> Result<Vec<T>, TwipError> {
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

fn schur_cap(n: usize) -> usize {
    100 + 40 * n
}

/// Real Schur form `M = U T Uᵀ` with an iteration cap. nalgebra's QR sweeps have no
/// exceptional shifts; if they stall, a second try runs on an orthogonally similar matrix.
fn schur<T: Real>(m: DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
    schur_direct(m.clone()).or_else(|| schur_reflected(m))
}

fn schur_direct<T: Real>(m: DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
    let cap = schur_cap(m.nrows());
    // nalgebra rescales only from 3×3 up; a power of two keeps 2×2 blocks from overflowing.
    let k = pow2_exponent::<T>(m.amax());
    let m = scaled_pow2(&m, -k);
    Schur::try_new(m, T::default_epsilon(), cap).map(|s| {
        let (u, t) = s.unpack();
        (u, scaled_pow2(&t, k))
    })
}

/// Schur form of `P M P` with the reflector `P = I − 2 v vᵀ / (vᵀ v)` (symmetric,
/// orthogonal), mapped back: `M = (P U) T (P U)ᵀ`.
fn schur_reflected<T: Real>(m: DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
    let n = m.nrows();
    let v = DMatrix::<T>::from_fn(n, 1, |i, _| T::one() / c::<T>((i + 2) as f64));
    let p = DMatrix::<T>::identity(n, n) - (&v * v.transpose()) * (c::<T>(2.0) / v.norm_squared());
    let (u, t) = schur_direct(&p * m * &p)?;
    Some((p * u, t))
}

/// The diagonal blocks (start, size) of a real quasi-triangular Schur factor.
fn quasi_blocks<T: Real>(t: &DMatrix<T>) -> Vec<(usize, usize)> {
    let n = t.nrows();
    let mut blocks = Vec::with_capacity(n);
    let mut i = 0;
    while i < n {
        if i + 1 < n && !t[(i + 1, i)].is_zero() {
            blocks.push((i, 2));
            i += 2;
        } else {
            blocks.push((i, 1));
            i += 1;
        }
    }
    blocks
}

/// Eigenvalues of a real quasi-triangular matrix, from its 1×1 and 2×2 diagonal blocks.
fn quasi_eigenvalues<T: Real>(t: &DMatrix<T>) -> Vec<Complex<T>> {
    let mut out = Vec::with_capacity(t.nrows());
    for (i, size) in quasi_blocks(t) {
        if size == 1 {
            out.push(Complex::new(t[(i, i)], T::zero()));
            continue;
        }
        let (a, b, cc, d) = (t[(i, i)], t[(i, i + 1)], t[(i + 1, i)], t[(i + 1, i + 1)]);
        // On the block scaled to unit size, so that the discriminant cannot overflow.
        let size = a.abs().max(b.abs()).max(cc.abs()).max(d.abs());
        let size = if size > T::zero() { size } else { T::one() };
        let (a, b, cc, d) = (a / size, b / size, cc / size, d / size);
        let half_tr = (a + d) * c::<T>(0.5);
        let half_diff = (a - d) * c::<T>(0.5);
        let disc = half_diff * half_diff + b * cc;
        if disc >= T::zero() {
            let s = disc.sqrt();
            out.push(Complex::new((half_tr - s) * size, T::zero()));
            out.push(Complex::new((half_tr + s) * size, T::zero()));
        } else {
            let s = (-disc).sqrt();
            out.push(Complex::new(half_tr * size, s * size));
            out.push(Complex::new(half_tr * size, -s * size));
        }
    }
    out
}

/// Is `[M − λI, N]` (n×(n+k)) rank deficient: σ_min ≤ tol · σ_max? In real arithmetic
/// when λ is real, complex otherwise.
fn rank_deficient<T: Real>(m: &DMatrix<T>, other: &DMatrix<T>, lambda: Complex<T>, tol: T) -> bool {
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
fn rank_deficient_in<T: Real, F: ComplexField<RealField = T> + Copy>(
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

/// Gauss–Jordan inversion with partial pivoting, in place on a column-major n×n slice;
/// returns log|det|, or `None` if a pivot is zero or not finite.
fn invert_in_place<T: Real>(a: &mut [T], n: usize, perm: &mut [usize], factors: &mut [T]) -> Option<T> {
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
fn sign_solution<T: Real>(a: &DMatrix<T>, g: &DMatrix<T>, q: &DMatrix<T>) -> Option<DMatrix<T>> {
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
    for _ in 0..SIGN_MAX_ITER {
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
        if delta < c::<T>(1e-2) {
            // Near convergence the scaling only slows the quadratic phase down.
            scaling = false;
        }
        previous = delta;
    }
    if !converged {
        return None;
    }
    graph_from_sign(&DMatrix::from_vec(nn, nn, w))
}

/// `X` from `W = J sign(H)`: sign H = −J W = [[−W21, −W22], [W11, W12]], and
/// (sign H + I) [I; X] = 0 reads [W22; W12 + I] X = [I − W21; −W11], solved in the
/// least-squares sense (Householder QR).
fn graph_from_sign<T: Real>(w: &DMatrix<T>) -> Option<DMatrix<T>> {
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

/// `Ric(X) = X A + Aᵀ X − Fᵀ F + Q` with `F = Bhᵀ X` (symmetrised) and its norm relative
/// to the terms'.
fn residual<T: Real>(a: &DMatrix<T>, bh: &DMatrix<T>, q: &DMatrix<T>, x: &DMatrix<T>) -> (DMatrix<T>, T, T) {
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
fn is_stable<T: Real>(t: &DMatrix<T>) -> bool {
    let margin = c::<T>(100.0) * c::<T>(t.nrows() as f64) * T::default_epsilon() * t.norm();
    quasi_eigenvalues(t).iter().all(|l| l.re < -margin)
}

/// Newton–Kleinman refinement (step 4): `(X, relative residual, closed loop stable)`.
///
/// Stability is read from the Schur form of `A − G X` that each Newton step computes. After a
/// small accepted step (‖D‖ ≤ √ε ‖X‖) from a stable closed loop no new Schur form is needed:
/// by Kleinman's theorem a Newton step from a stabilising `X` is stabilising again when
/// `Q ⪰ 0` and (A, Q) is detectable, both checked up front. The same theorem lets the
/// iteration go on from a poor start (relative residual above √ε) even when the residual
/// grows for a step; the best stabilising iterate is kept.
fn refine<T: Real>(
    a: &DMatrix<T>,
    bh: &DMatrix<T>,
    q: &DMatrix<T>,
    x0: DMatrix<T>,
) -> Result<(DMatrix<T>, T, bool), TwipError> {
    let n = a.nrows();
    let eps = T::default_epsilon();
    // Rounding alone leaves a relative residual of a few n ε: no step can do better.
    let floor = c::<T>(4.0 * n as f64) * eps;
    let far = eps.sqrt();
    let closed_loop_schur = |x: &DMatrix<T>| {
        schur(a - bh * bh.tr_mul(x)).ok_or(TwipError::NoConvergence {
            what: "Schur decomposition of the closed loop",
            iterations: schur_cap(n),
        })
    };
    let mut x = x0;
    let (mut res, mut norm, mut rel) = residual(a, bh, q, &x);
    // Whether A − G X is stable, once known for the current X.
    let mut stable: Option<bool> = None;
    // A stabilising iterate with a smaller residual than the current one, if any.
    let mut best: Option<(DMatrix<T>, T)> = None;
    for _ in 0..NEWTON_MAX_ITER {
        if !(rel > floor) && stable.is_some() {
            break;
        }
        let (u, t) = closed_loop_schur(&x)?;
        let stable_here = is_stable(&t);
        stable = Some(stable_here);
        if !stable_here || !(rel > floor) {
            break;
        }
        let d = lyapunov_schur(&u, &t, &(-&res));
        let small_step = d.norm() <= eps.sqrt() * x.norm();
        let candidate = symmetrise(&x + d);
        let (res_c, norm_c, rel_c) = residual(a, bh, q, &candidate);
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
        stable = if stable_here && small_step { Some(true) } else { None };
    }
    let stable = match stable {
        Some(s) => s,
        None => is_stable(&closed_loop_schur(&x)?.1),
    };
    match best {
        Some((xb, rb)) if !stable || !(rel <= rb) => Ok((xb, rb, true)),
        _ => Ok((x, rel, stable)),
    }
}

/// Solves `Mᵀ D + D M = F` (F symmetric) with `M = U T Uᵀ` in real Schur form
/// (Bartels–Stewart): `Tᵀ Y + Y T = Uᵀ F U`, block by block, then `D = U Y Uᵀ`.
fn lyapunov_schur<T: Real>(u: &DMatrix<T>, t: &DMatrix<T>, f: &DMatrix<T>) -> DMatrix<T> {
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
fn solve_small<T: Real>(k: usize, mut mat: [[T; 4]; 4], mut rhs: [T; 4], smin: T) -> [T; 4] {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn m(rows: usize, cols: usize, data: &[f64]) -> DMatrix<f64> {
        DMatrix::from_row_slice(rows, cols, data)
    }

    fn rel_residual(a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, r: &DMatrix<f64>, x: &DMatrix<f64>) -> f64 {
        let bh = b * r.clone().cholesky().unwrap().l().try_inverse().unwrap().transpose();
        residual(a, &bh, q, x).2
    }

    #[test]
    fn double_integrator() {
        let a = m(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = m(2, 1, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2);
        let r = m(1, 1, &[1.0]);
        let sol = lqr(&a, &b, &q, &r).unwrap();
        let s3 = 3f64.sqrt();
        assert!((sol.k[(0, 0)] - 1.0).abs() < 1e-12, "{}", sol.k);
        assert!((sol.k[(0, 1)] - s3).abs() < 1e-12, "{}", sol.k);
        let x_exact = m(2, 2, &[s3, 1.0, 1.0, s3]);
        assert!((&sol.x - x_exact).amax() < 1e-12, "{}", sol.x);
        // Closed loop s² + √3 s + 1: poles −√3/2 ± i/2.
        assert_eq!(sol.poles.len(), 2);
        for p in &sol.poles {
            assert!(
                (p.re + s3 / 2.0).abs() < 1e-12 && (p.im.abs() - 0.5).abs() < 1e-12,
                "{p}"
            );
        }
        assert!(sol.poles[0].im < sol.poles[1].im);
    }

    #[test]
    fn scalar_closed_forms() {
        // 2 a x − b² x² / r + q = 0  →  x = r (a + √(a² + b² q / r)) / b².
        for &(a, b, q, r) in &[
            (1.0, 1.0, 1.0, 1.0),
            (-2.0, 0.5, 3.0, 0.1),
            (0.0, 1.0, 1.0, 1.0),
            (5.0, 2.0, 1e-9, 1.0),
            (1e3, 1e-2, 1e-4, 1e6),
            (-1e-3, 1e2, 1e4, 1e-6),
        ] {
            let x = care(&m(1, 1, &[a]), &m(1, 1, &[b]), &m(1, 1, &[q]), &m(1, 1, &[r])).unwrap()[(0, 0)];
            let disc: f64 = a * a + b * b * q / r;
            // Cancellation-free form when a < 0: x = q / (√disc − a).
            let exact = if a > 0.0 {
                r * (a + disc.sqrt()) / (b * b)
            } else {
                q / (disc.sqrt() - a)
            };
            assert!(
                (x - exact).abs() <= 1e-13 * exact.abs().max(f64::MIN_POSITIVE),
                "{a} {b} {q} {r}: {x} vs {exact}"
            );
        }
        // q = 0 with a stable a: x = 0 and the pole stays; the minimum-energy limit
        // (q → 0 with an unstable a) mirrors the pole.
        let x = care(&m(1, 1, &[-3.0]), &m(1, 1, &[1.0]), &m(1, 1, &[0.0]), &m(1, 1, &[1.0])).unwrap();
        assert_eq!(x[(0, 0)], 0.0);
        let sol = lqr(&m(1, 1, &[3.0]), &m(1, 1, &[1.0]), &m(1, 1, &[1e-12]), &m(1, 1, &[1.0])).unwrap();
        assert!((sol.poles[0].re + 3.0).abs() < 1e-12);
    }

    #[test]
    fn f32_matches_f64() {
        let a = DMatrix::<f32>::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::<f32>::from_row_slice(2, 1, &[0.0, 1.0]);
        let sol = lqr(&a, &b, &DMatrix::identity(2, 2), &DMatrix::identity(1, 1)).unwrap();
        assert!((sol.k[(0, 1)] - 3f32.sqrt()).abs() < 1e-5);
    }

    #[test]
    fn larger_problem_with_oscillators() {
        // Two undamped oscillators and an integrator, cross-coupled inputs.
        let a = m(
            5,
            5,
            &[
                0.0, 1.0, 0.0, 0.0, 0.0, //
                -4.0, 0.0, 0.0, 0.0, 0.0, //
                0.0, 0.0, 0.0, 1.0, 0.0, //
                0.0, 0.0, -9.0, 0.0, 0.0, //
                1.0, 0.0, 0.0, 0.0, 0.0,
            ],
        );
        let b = m(5, 2, &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0]);
        let q = DMatrix::identity(5, 5);
        let r = m(2, 2, &[1.0, 0.2, 0.2, 2.0]);
        let sol = lqr(&a, &b, &q, &r).unwrap();
        assert!(rel_residual(&a, &b, &q, &r, &sol.x) < 1e-13);
        assert!(sol.poles.iter().all(|p| p.re < 0.0));
        assert!((&sol.x - sol.x.transpose()).amax() == 0.0);
    }

    #[test]
    fn cyclic_matrix_does_not_stall() {
        // A cyclic permutation: eigenvalues on the unit circle, a classic hard case for QR.
        let a = m(3, 3, &[0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        let b = DMatrix::identity(3, 3);
        let q = DMatrix::identity(3, 3);
        let sol = lqr(&a, &b, &q, &DMatrix::identity(3, 3)).unwrap();
        assert!(rel_residual(&a, &b, &q, &DMatrix::identity(3, 3), &sol.x) < 1e-13);
    }

    #[test]
    fn errors() {
        let a = m(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = m(2, 1, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2);
        let r = m(1, 1, &[1.0]);
        let name = |e: TwipError| match e {
            TwipError::Shape { name, .. }
            | TwipError::InvalidParameter { name, .. }
            | TwipError::NonFinite { name, .. } => name,
            other => panic!("unexpected {other:?}"),
        };
        assert_eq!(name(care(&m(2, 3, &[0.0; 6]), &b, &q, &r).unwrap_err()), "A");
        assert_eq!(name(care(&a, &m(3, 1, &[0.0; 3]), &q, &r).unwrap_err()), "B");
        assert_eq!(name(care(&a, &b, &DMatrix::identity(3, 3), &r).unwrap_err()), "Q");
        assert_eq!(name(care(&a, &b, &q, &DMatrix::identity(2, 2)).unwrap_err()), "R");
        assert_eq!(
            name(care(&a, &b, &m(2, 2, &[1.0, 0.5, 0.0, 1.0]), &r).unwrap_err()),
            "Q"
        );
        assert_eq!(
            name(care(&a, &m(2, 2, &[1.0, 0.0, 0.0, 1.0]), &q, &m(2, 2, &[1.0, 0.1, 0.0, 1.0])).unwrap_err()),
            "R"
        );
        assert_eq!(
            name(care(&a, &b, &m(2, 2, &[1.0, 0.0, 0.0, -1.0]), &r).unwrap_err()),
            "Q"
        );
        assert_eq!(name(care(&a, &b, &q, &m(1, 1, &[0.0])).unwrap_err()), "R");
        assert_eq!(name(care(&a, &b, &q, &m(1, 1, &[-1.0])).unwrap_err()), "R");
        let e = care(&a, &b, &q, &m(1, 1, &[f64::NAN])).unwrap_err();
        assert!(
            matches!(
                e,
                TwipError::NonFinite {
                    name: "R",
                    index: 0,
                    ..
                }
            ),
            "{e:?}"
        );
        let e = care(&m(2, 2, &[0.0, 1.0, f64::INFINITY, 0.0]), &b, &q, &r).unwrap_err();
        assert!(
            matches!(
                e,
                TwipError::NonFinite {
                    name: "A",
                    index: 2,
                    ..
                }
            ),
            "{e:?}"
        );
        // Unstabilizable: the unstable mode 1 is not driven.
        let a2 = m(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        assert_eq!(care(&a2, &b, &q, &r).unwrap_err(), TwipError::NotStabilizable);
        // Marginal and undriven: the integrator of the double integrator with B = e1.
        assert_eq!(
            care(&a, &m(2, 1, &[1.0, 0.0]), &q, &r).unwrap_err(),
            TwipError::NotStabilizable
        );
        // Undetectable: the unstable mode is invisible to Q.
        let a3 = m(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        let b3 = m(2, 1, &[1.0, 1.0]);
        let q3 = m(2, 2, &[0.0, 0.0, 0.0, 1.0]);
        assert_eq!(care(&a3, &b3, &q3, &r).unwrap_err(), TwipError::NotDetectable);
        // An undamped oscillator invisible to Q: a Hamiltonian eigenvalue on the axis.
        let a4 = m(2, 2, &[0.0, 1.0, -1.0, 0.0]);
        assert_eq!(
            care(&a4, &b, &DMatrix::zeros(2, 2), &r).unwrap_err(),
            TwipError::NotDetectable
        );
    }

    #[test]
    fn schur_fallback_is_a_schur_form() {
        let mm = m(
            4,
            4,
            &[
                1.0, 2.0, 0.0, -1.0, 0.5, -3.0, 1.0, 0.0, 0.0, 1.0, 0.0, 2.0, -2.0, 0.0, 1.0, 1.0,
            ],
        );
        let (u, t) = schur_reflected(mm.clone()).unwrap();
        assert!((&u * &t * u.transpose() - &mm).amax() < 1e-13);
        assert!((u.transpose() * &u - DMatrix::identity(4, 4)).amax() < 1e-14);
        for (i, size) in quasi_blocks(&t) {
            for r in (i + size)..4 {
                for cc in i..(i + size) {
                    assert_eq!(t[(r, cc)], 0.0);
                }
            }
        }
    }

    #[test]
    fn no_input_is_a_lyapunov_equation() {
        // B = 0 with a stable A: Aᵀ X + X A + Q = 0.
        let a = m(2, 2, &[-1.0, 2.0, 0.0, -3.0]);
        let q = m(2, 2, &[2.0, 1.0, 1.0, 4.0]);
        let x = care(&a, &DMatrix::zeros(2, 1), &q, &m(1, 1, &[1.0])).unwrap();
        assert!((a.transpose() * &x + &x * &a + &q).amax() < 1e-14);
    }

    #[test]
    fn badly_scaled_states_are_exactly_rescaled() {
        // x' = T⁻¹ x with T = diag(2⁻¹⁰, 1, 2¹²): X' = T X T, entry by entry.
        let a = m(3, 3, &[0.5, 1.0, -0.3, -2.0, 0.1, 1.0, 0.2, -1.0, -0.4]);
        let b = m(3, 2, &[1.0, 0.0, 0.3, 1.0, -0.5, 2.0]);
        let q = m(3, 3, &[2.0, 0.5, 0.0, 0.5, 1.0, 0.2, 0.0, 0.2, 3.0]);
        let r = m(2, 2, &[1.0, 0.1, 0.1, 0.5]);
        let t = [2f64.powi(-10), 1.0, 2f64.powi(12)];
        let a2 = DMatrix::from_fn(3, 3, |i, j| a[(i, j)] * t[j] / t[i]);
        let b2 = DMatrix::from_fn(3, 2, |i, j| b[(i, j)] / t[i]);
        let q2 = DMatrix::from_fn(3, 3, |i, j| q[(i, j)] * t[i] * t[j]);
        let x = care(&a, &b, &q, &r).unwrap();
        let x2 = care(&a2, &b2, &q2, &r).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let want = x[(i, j)] * t[i] * t[j];
                assert!(
                    (x2[(i, j)] - want).abs() <= 1e-12 * want.abs().max(1e-300),
                    "{i} {j}: {} vs {want}",
                    x2[(i, j)]
                );
            }
        }
    }

    #[test]
    fn solve_small_and_lyapunov() {
        // A 3×3 with a complex pair: check Mᵀ D + D M = F directly.
        let mm = m(3, 3, &[-1.0, 2.0, 0.5, -3.0, -1.0, 0.0, 0.2, 0.1, -0.5]);
        let f = m(3, 3, &[1.0, 0.2, 0.3, 0.2, 2.0, 0.1, 0.3, 0.1, 3.0]);
        let (u, t) = schur(mm.clone()).unwrap();
        let d = lyapunov_schur(&u, &t, &f);
        let err = (mm.transpose() * &d + &d * &mm - &f).amax();
        assert!(err < 1e-13, "{err}");
    }
}
