//! The matrix exponential by scaling and squaring with Padé approximants (Higham 2005), with
//! three defences against scales far apart:
//!
//! 1. an exact power-of-two diagonal similarity: columns whose row is zero (the inputs of
//!    the ZOH block `[[A T, B T], [0, 0]]`) shrunk to the others' size, then
//!    Parlett–Reinsch balancing, so that one large entry does not set the squarings for all;
//! 2. the squarings from Al-Mohy & Higham 2009 (`d_k = ‖Mᵏ‖^(1/k)`, exact 1-norms, and
//!    their correction ℓ for non-normal M), never more than the 1-norm rule asks for: each
//!    squaring doubles the relative rounding of every mode, so over-scaling loses the slow ones;
//! 3. for a matrix that a permutation makes upper triangular, the exact diagonal and first
//!    superdiagonal of `exp(2⁻ⁱ M)` put back after each squaring.
//!
//! A full matrix that would still need so many squarings that the rounding, doubled at each,
//! exceeds √ε is refused ([`ExpmFailure::TooStiff`]) rather than answered wrongly.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use alloc::vec::Vec;

use nalgebra::DMatrix;

use super::triangular::{fix_diagonals, times_pow2, triangular_order};
use crate::control::care::scaling::{balance, pow2_exponent, scaled_pow2};
use crate::{c, to_f64, Real};

/// Padé degrees with the largest 1-norm θ_m each is accurate to double precision for
/// (Higham 2005, table 2.3), and the numerator coefficients b_0..b_m.
const PADE: [(f64, &[f64]); 5] = [
    (1.495585217958292e-2, &[120.0, 60.0, 12.0, 1.0]),
    (2.53939833006323e-1, &[30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0]),
    (9.504178996162932e-1, &[17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0]),
    (
        2.097847961257068,
        &[17643225600.0, 8821612800.0, 2075673600.0, 302702400.0, 30270240.0, 2162160.0, 110880.0, 3960.0, 90.0, 1.0],
    ),
    (
        5.371920351148152,
        &[
            64764752532480000.0,
            32382376266240000.0,
            7771770303897600.0,
            1187353796428800.0,
            129060195264000.0,
            10559470521600.0,
            670442572800.0,
            33522128640.0,
            1323241920.0,
            40840800.0,
            960960.0,
            16380.0,
            182.0,
            1.0,
        ],
    ),
];

/// Al-Mohy & Higham 2009's θ_13, for their bound in terms of `d_k`.
const THETA_13_AMH: f64 = 4.25;
/// `1 / |c_27|`, the leading coefficient of the degree-13 Padé error series
/// (Al-Mohy & Higham 2009, eq. 5.1; SciPy's `_ell`).
const ELL_13: f64 = 113250775606021113483283660800000000.0;

/// Why [`expm_checked`] gave no exponential.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum ExpmFailure {
    /// An entry overflows, or the input is not finite.
    Overflow,
    /// A full (not triangular) matrix whose scales are so far apart that the squarings
    /// would lose its slow modes in rounding.
    TooStiff,
}

/// The exponential of a square matrix, or `None` if it overflows, `m` is not finite, or it
/// cannot be computed accurately (see the module docs).
pub fn expm<T: Real>(m: &DMatrix<T>) -> Option<DMatrix<T>> {
    expm_checked(m).ok()
}

/// [`expm`], saying why it failed.
pub(crate) fn expm_checked<T: Real>(m: &DMatrix<T>) -> Result<DMatrix<T>, ExpmFailure> {
    let n = m.nrows();
    if m.iter().any(|v| !v.is_finite()) {
        return Err(ExpmFailure::Overflow);
    }
    // exp(M) = D exp(D⁻¹ M D) D⁻¹, and with a permutation P, exp(Pᵀ M P) = Pᵀ exp(M) P.
    // The similarity only where the 1-norm would ask for squarings and it needs no more of
    // them (balancing is no sure gain, Higham 2005), so that an M that needs none (a
    // controller's A T) keeps its digits bit for bit.
    let d = similarity(m);
    let balanced = DMatrix::from_fn(n, n, |i, j| m[(i, j)] * (d[j] / d[i]));
    let ((t, plan), d) = match (plan(m), plan(&balanced)) {
        (Some(plain), Some(better)) if plain.2 == 0 || better.1 > plain.1 => ((m.clone(), plain), alloc::vec![T::one(); n]),
        (_, Some(better)) => ((balanced, better), d),
        (Some(plain), None) => ((m.clone(), plain), alloc::vec![T::one(); n]),
        (None, None) => return Err(ExpmFailure::Overflow),
    };
    let order = triangular_order(&t);
    let at = |i: usize| order.as_ref().map_or(i, |p| p[i]);
    let t = DMatrix::from_fn(n, n, |i, j| t[(at(i), at(j))]);
    let e = exp_planned(&t, order.is_some(), plan)?;
    let mut out = DMatrix::<T>::zeros(n, n);
    for j in 0..n {
        for i in 0..n {
            let (r, col) = (at(i), at(j));
            out[(r, col)] = e[(i, j)] * (d[r] / d[col]);
        }
    }
    out.iter().all(|v| v.is_finite()).then_some(out).ok_or(ExpmFailure::Overflow)
}

/// The power-of-two diagonal `d` of the similarity `D⁻¹ M D` (module docs, item 1).
fn similarity<T: Real>(m: &DMatrix<T>) -> Vec<T> {
    let n = m.nrows();
    let mut d = alloc::vec![T::one(); n];
    shrink_free_columns(m, &mut d);
    let zero = DMatrix::<T>::zeros(n, n);
    let scaled = DMatrix::from_fn(n, n, |i, j| m[(i, j)] * (d[j] / d[i]));
    // The CARE's balancing with no G and Q is Parlett–Reinsch on M (it skips the indices
    // whose row or column is zero off the diagonal).
    for (di, bi) in d.iter_mut().zip(balance(&scaled, &zero, &zero)) {
        *di *= bi;
    }
    shrink_free_columns(m, &mut d);
    d
}

/// For each index whose row is zero off the diagonal, column i of `D⁻¹ M D` scales with d_i
/// and nothing else does: shrink it to the largest other column (1-norm), or to 1 if all
/// others are zero. exp([[A, cB], [0, 0]]) = [[Ad, c Bd], [0, I]]: B's size is free.
fn shrink_free_columns<T: Real>(m: &DMatrix<T>, d: &mut [T]) {
    let n = m.nrows();
    let free: Vec<bool> = (0..n).map(|i| (0..n).all(|j| j == i || m[(i, j)].is_zero())).collect();
    let column = |j: usize, d: &[T]| (0..n).filter(|&i| i != j || !free[j]).fold(T::zero(), |acc, i| acc + (m[(i, j)] * (d[j] / d[i])).abs());
    let mut target = (0..n).filter(|&j| !free[j]).fold(T::zero(), |acc, j| acc.max(column(j, d)));
    if target.is_zero() {
        target = T::one();
    }
    for j in (0..n).filter(|&j| free[j]) {
        let size = column(j, d);
        if size > target {
            d[j] *= c::<T>(2.0).powi(pow2_exponent(target / size).min(0));
        }
    }
}

fn norm1<T: Real>(m: &DMatrix<T>) -> T {
    (0..m.ncols()).map(|j| m.column(j).iter().fold(T::zero(), |acc, v| acc + v.abs())).fold(T::zero(), |a, v| a.max(v))
}

/// `m · 2^k` in two steps (see [`times_pow2`]).
fn scaled2<T: Real>(m: &DMatrix<T>, k: i32) -> DMatrix<T> {
    scaled_pow2(&scaled_pow2(m, k / 2), k - k / 2)
}

fn log2<T: Real>(v: T) -> f64 {
    to_f64(v.ln() / T::ln_2())
}

/// The Padé degree (an index into [`PADE`]), the squarings, and the squarings the 1-norm
/// rule alone would take; `None` if the 1-norm overflows.
type Plan = (usize, i32, i32);

fn plan<T: Real>(t: &DMatrix<T>) -> Option<Plan> {
    let norm = norm1(t);
    if !norm.is_finite() {
        return None;
    }
    // The lowest degree accurate at this norm, with no squaring; else degree 13 on M / 2^s.
    if let Some(i) = PADE.iter().position(|(theta, _)| norm <= c::<T>(*theta)) {
        return Some((i, 0, 0));
    }
    let ratio = norm / c::<T>(PADE[4].0);
    let by_norm = to_f64((ratio.ln() / T::ln_2()).ceil().max(T::zero())) as i32;
    Some((4, squarings_amh(t, norm).min(by_norm), by_norm))
}

/// exp(t) by `plan`, `t` upper triangular if `triangular`.
fn exp_planned<T: Real>(t: &DMatrix<T>, triangular: bool, (degree, fewer, by_norm): Plan) -> Result<DMatrix<T>, ExpmFailure> {
    let u = T::default_epsilon() * c::<T>(0.5);
    if !triangular && times_pow2(u, fewer) > u.sqrt() {
        return Err(ExpmFailure::TooStiff);
    }
    // Fewer squarings leave a larger M / 2^s: should its Padé evaluation overflow, the
    // 1-norm rule's count still stands.
    let (squarings, mut e) = match pade(t, degree, fewer) {
        Some(e) => (fewer, e),
        None if by_norm > fewer => (by_norm, pade(t, degree, by_norm).ok_or(ExpmFailure::Overflow)?),
        None => return Err(ExpmFailure::Overflow),
    };
    if triangular {
        fix_diagonals(&mut e, t, squarings);
    }
    for i in (0..squarings).rev() {
        e = &e * &e;
        if triangular {
            fix_diagonals(&mut e, t, i);
        }
        if e.iter().any(|v| !v.is_finite()) {
            return Err(ExpmFailure::Overflow);
        }
    }
    Ok(e)
}

/// The Padé approximant of degree `PADE[chosen]` to exp(t / 2^s), `None` if not finite.
fn pade<T: Real>(t: &DMatrix<T>, chosen: usize, squarings: i32) -> Option<DMatrix<T>> {
    let n = t.nrows();
    let scaled = scaled2(t, -squarings);
    let coefficients = PADE[chosen].1;
    // U = A Σ b_{2j+1} A^{2j}, V = Σ b_{2j} A^{2j}.
    let square = &scaled * &scaled;
    let mut power = DMatrix::<T>::identity(n, n);
    let (mut odd, mut even) = (DMatrix::<T>::zeros(n, n), DMatrix::<T>::zeros(n, n));
    for (j, pair) in coefficients.chunks(2).enumerate() {
        if j > 0 {
            power = &power * &square;
        }
        even += &power * c::<T>(pair[0]);
        if let Some(&b_odd) = pair.get(1) {
            odd += &power * c::<T>(b_odd);
        }
    }
    let u = &scaled * odd;
    let e = (&even - &u).lu().solve(&(even + u))?;
    e.iter().all(|v| v.is_finite()).then_some(e)
}

/// Al-Mohy & Higham 2009's squarings for degree 13: the least s with
/// `min(max(d₆, d₈), max(d₈, d₁₀)) ≤ 2^s θ₁₃`, plus ℓ. The powers are of M / 2^p
/// (‖·‖₁ ≈ 1), so that none overflows.
fn squarings_amh<T: Real>(t: &DMatrix<T>, norm: T) -> i32 {
    let p = to_f64((norm.ln() / T::ln_2()).round()) as i32;
    let mn = scaled2(t, -p);
    let m2 = &mn * &mn;
    let m4 = &m2 * &m2;
    let m6 = &m4 * &m2;
    let m8 = &m4 * &m4;
    let m10 = &m8 * &m2;
    // log₂ d_k = p + log₂ ‖(M/2^p)^k‖ / k (−∞ for a zero power).
    let d = |power: &DMatrix<T>, k: f64| f64::from(p) + log2(norm1(power)) / k;
    let (d6, d8, d10) = (d(&m6, 6.0), d(&m8, 8.0), d(&m10, 10.0));
    let eta = d6.max(d8).min(d8.max(d10));
    if !(eta > f64::NEG_INFINITY) {
        // Nilpotent: M^8 = 0 and the Padé approximant is exact.
        return 0;
    }
    let s = ceil_i32(eta - log2(c::<T>(THETA_13_AMH))).max(0);
    s + ell(&mn, p, s)
}

fn ceil_i32(v: f64) -> i32 {
    let t = v as i32;
    if f64::from(t) < v {
        t + 1
    } else {
        t
    }
}

/// Al-Mohy & Higham 2009's ℓ(M/2^s, 13): extra squarings when the non-normality of M makes
/// the Padé error bound in `d_k` optimistic; `α = ‖|M/2^s|²⁷‖₁ / (‖M/2^s‖₁ / |c₂₇|)`,
/// `ℓ = max(⌈log₂(α/u) / 26⌉, 0)`. Exact 1-norms from 27 vector products with |M / 2^p|.
fn ell<T: Real>(mn: &DMatrix<T>, p: i32, s: i32) -> i32 {
    let n = mn.nrows();
    let abs = mn.map(|v| v.abs());
    let mut v = alloc::vec![T::one(); n];
    for _ in 0..27 {
        v = (0..n).map(|j| (0..n).fold(T::zero(), |acc, i| acc + v[i] * abs[(i, j)])).collect();
    }
    let top = v.iter().fold(T::zero(), |acc, &x| acc.max(x));
    if !(top > T::zero()) || !top.is_finite() {
        return 0;
    }
    let log2_alpha = log2(top) + 26.0 * f64::from(p - s) - log2(norm1(mn)) - log2(c::<T>(ELL_13));
    let log2_u = log2(T::default_epsilon() * c::<T>(0.5));
    ceil_i32((log2_alpha - log2_u) / 26.0).max(0)
}
