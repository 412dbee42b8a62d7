//! Fuzzy logic systems (thesis 4.27–4.31, 4.39): membership functions and the normalised
//! fuzzy basis ξ of a grid rule base with singleton fuzzifier, product inference and
//! centre-average defuzzification, so that the system's output is `Ŝᵀ ξ(x)` (4.30).
//!
//! A grid rule base has one rule per combination of one set per input. Its denominator
//! D of (4.29) factorises, D = Π_i Σ_j μ_ij(x_i), so ξ is the product of each input's
//! memberships normalised on their own: that is how it is computed here (fewer
//! operations, and no underflow of D when many small memberships multiply).
//!
//! **When no rule fires** (D = 0: some input lies where none of its sets is non-zero),
//! that input's nearest set fires alone with weight 1: nearest by distance to the support
//! [a, d] for trapezoids and triangles, by |x − mean|/σ for Gaussians (a Gaussian far
//! out underflows to 0). Ties go to the last set listed when x > 0 and to the first one
//! otherwise, so with sets listed left to right an input at ±∞ belongs to the outermost
//! set. ξ is then defined, non-negative and sums to 1 for every finite or infinite input;
//! a NaN input gives NaN. Sets that cover the line with shoulders (the thesis's N, Z, P)
//! never need the fallback.
//!
//! Everything is fixed-size: no allocation, no_std.
use crate::{c, Real, TwipError};

/// A membership function μ(x) ∈ [0, 1]. Build through the checked constructors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Membership<T> {
    /// (4.31), `a ≤ b ≤ c ≤ d`. `a = b = −∞` is a left shoulder, `c = d = +∞` a right
    /// one; `b = c` is a triangle; `a = b` or `c = d` a crisp edge.
    Trapezoid { a: T, b: T, c: T, d: T },
    /// exp(−(x − mean)² / (2 σ²)), σ > 0.
    Gaussian { mean: T, sigma: T },
}

fn invalid<T: Real>(name: &'static str, v: T, reason: &'static str) -> TwipError {
    TwipError::InvalidParameter { name, value: crate::to_f64(v), reason }
}

impl<T: Real> Membership<T> {
    /// A trapezoid (4.31); see [`Membership::Trapezoid`] for the allowed breakpoints.
    pub fn trapezoid(a: T, b: T, c: T, d: T) -> Result<Self, TwipError> {
        Self::Trapezoid { a, b, c, d }.validate()
    }

    /// The triangle with feet `a`, `c` and peak `b`: the trapezoid (a, b, b, c).
    pub fn triangle(a: T, b: T, c: T) -> Result<Self, TwipError> {
        Self::trapezoid(a, b, b, c).map_err(|e| match e {
            // Name the triangle's own breakpoints, not the trapezoid's.
            TwipError::InvalidParameter { name, value, reason } => {
                let name = match name {
                    "trapezoid.a" => "triangle.a",
                    "trapezoid.b" | "trapezoid.c" => "triangle.b",
                    _ => "triangle.c",
                };
                TwipError::InvalidParameter { name, value, reason }
            }
            other => other,
        })
    }

    pub fn gaussian(mean: T, sigma: T) -> Result<Self, TwipError> {
        Self::Gaussian { mean, sigma }.validate()
    }

    /// Checks the breakpoints: no NaN, ordered, infinities only as shoulders.
    pub fn validate(self) -> Result<Self, TwipError> {
        match self {
            Self::Trapezoid { a, b, c, d } => {
                const ORDER: &str = "breakpoints must be ordered (a <= b <= c <= d; a <= b <= c for a triangle)";
                for (name, v) in [("trapezoid.a", a), ("trapezoid.b", b), ("trapezoid.c", c), ("trapezoid.d", d)] {
                    if v.partial_cmp(&v).is_none() {
                        return Err(invalid(name, v, "must not be NaN"));
                    }
                }
                if b < a {
                    return Err(invalid("trapezoid.b", b, ORDER));
                }
                if c < b {
                    return Err(invalid("trapezoid.c", c, ORDER));
                }
                if d < c {
                    return Err(invalid("trapezoid.d", d, ORDER));
                }
                // A ramp to or from infinity is zero everywhere: only shoulders may be infinite.
                if !a.is_finite() && a != b {
                    return Err(invalid("trapezoid.a", a, "may be infinite only as a left shoulder (a = b = -inf)"));
                }
                if !d.is_finite() && d != c {
                    return Err(invalid("trapezoid.d", d, "may be infinite only as a right shoulder (c = d = +inf)"));
                }
                // A core only at infinity: the set would be zero on the whole line.
                if b == T::one() / T::zero() {
                    return Err(invalid("trapezoid.b", b, "must be finite unless a = b = -inf"));
                }
                if c == -T::one() / T::zero() {
                    return Err(invalid("trapezoid.c", c, "must be finite unless c = d = +inf"));
                }
                Ok(self)
            }
            Self::Gaussian { mean, sigma } => {
                if !mean.is_finite() {
                    return Err(invalid("gaussian.mean", mean, "must be finite"));
                }
                if !(sigma.is_finite() && sigma > T::zero()) {
                    return Err(invalid("gaussian.sigma", sigma, "must be finite and > 0"));
                }
                Ok(self)
            }
        }
    }

    /// μ(x). No division by zero: each ramp is only evaluated where it has width.
    #[inline(always)]
    pub fn eval(&self, x: T) -> T {
        match *self {
            Self::Trapezoid { a, b, c, d } => {
                if x < a || x > d {
                    T::zero()
                } else if x < b {
                    (x - a) / (b - a)
                } else if x <= c {
                    T::one()
                } else {
                    // c < x <= d, or x is NaN (which stays NaN).
                    (d - x) / (d - c)
                }
            }
            Self::Gaussian { mean, sigma } => {
                let z = (x - mean) / sigma;
                (-c::<T>(0.5) * z * z).exp()
            }
        }
    }

    /// How far `x` is from where the set is non-zero (for the no-rule-fires fallback).
    #[inline]
    pub fn distance(&self, x: T) -> T {
        match *self {
            Self::Trapezoid { a, d, .. } => (a - x).max(x - d).max(T::zero()),
            Self::Gaussian { mean, sigma } => (x - mean).abs() / sigma,
        }
    }
}

/// Writes the memberships of `x` in `sets`, normalised to sum to 1, into `out`
/// (`out.len() == sets.len()`); if none is non-zero, the nearest set gets 1 (module docs).
#[inline(always)]
pub fn normalised_memberships<T: Real>(sets: &[Membership<T>], x: T, out: &mut [T]) {
    let mut sum = T::zero();
    for (o, s) in out.iter_mut().zip(sets) {
        *o = s.eval(x);
        sum += *o;
    }
    if sum == T::zero() {
        let nearest = nearest_set(sets, x);
        for (j, o) in out.iter_mut().enumerate() {
            *o = if j == nearest { T::one() } else { T::zero() };
        }
    } else {
        // A NaN sum (NaN input) propagates.
        let inv = T::one() / sum;
        for o in out.iter_mut() {
            *o *= inv;
        }
    }
}

/// Index of the set nearest to `x`; ties to the last set when x > 0, else the first.
fn nearest_set<T: Real>(sets: &[Membership<T>], x: T) -> usize {
    let later_wins = x > T::zero();
    let mut best = 0;
    let mut best_d = T::one() / T::zero();
    for (j, s) in sets.iter().enumerate() {
        let d = s.distance(x);
        if d < best_d || (later_wins && d == best_d) || j == 0 {
            best = j;
            best_d = d;
        }
    }
    best
}

/// A set ready for repeated evaluation: the ramps' reciprocal widths computed once.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Prepared<T> {
    /// 1/(b − a) and 1/(d − c) are only used where the ramp has width (else ∞ or NaN, unused).
    Trapezoid { a: T, b: T, c: T, d: T, inv_rise: T, inv_fall: T },
    /// Gaussians keep their division: exp(−z²/2) magnifies an ulp of z by z².
    Gaussian(Membership<T>),
}

impl<T: Real> Prepared<T> {
    fn new(m: Membership<T>) -> Self {
        match m {
            Membership::Trapezoid { a, b, c, d } => {
                Self::Trapezoid { a, b, c, d, inv_rise: T::one() / (b - a), inv_fall: T::one() / (d - c) }
            }
            Membership::Gaussian { .. } => Self::Gaussian(m),
        }
    }

    /// [`Membership::eval`], the ramps multiplied by their reciprocal widths (within an ulp).
    #[inline(always)]
    fn eval(&self, x: T) -> T {
        match *self {
            Self::Trapezoid { a, b, c, d, inv_rise, inv_fall } => {
                if x < a || x > d {
                    T::zero()
                } else if x < b {
                    (x - a) * inv_rise
                } else if x <= c {
                    T::one()
                } else {
                    (d - x) * inv_fall
                }
            }
            Self::Gaussian(m) => m.eval(x),
        }
    }
}

/// The row-major tensor product of per-input weights: `out[k] = Π_i w_i[j_i]` with the
/// last input varying fastest (the rule order of (4.39)). `out.len()` must be the
/// product of the lengths; for bases whose sizes are only known at run time.
pub fn grid_product<T: Real>(weights: &[&[T]], out: &mut [T]) -> Result<(), TwipError> {
    let rules = weights.iter().map(|w| w.len()).product::<usize>();
    if rules != out.len() || weights.is_empty() {
        return Err(TwipError::Shape { name: "xi", expected: (rules, 1), got: (out.len(), 1) });
    }
    out[0] = T::one();
    let mut filled = 1;
    // Expand one input at a time, in place, from the back so nothing is overwritten early.
    for w in weights {
        let n = w.len();
        for k in (0..filled).rev() {
            let base = out[k];
            for j in (0..n).rev() {
                out[k * n + j] = base * w[j];
            }
        }
        filled *= n;
    }
    Ok(())
}

/// A grid fuzzy basis: `N_IN` inputs, `N_SETS` sets per input, `N_RULES = N_SETS^N_IN`
/// rules in row-major order (the last input varies fastest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridBasis<T, const N_IN: usize, const N_SETS: usize, const N_RULES: usize> {
    sets: [[Membership<T>; N_SETS]; N_IN],
    prepared: [[Prepared<T>; N_SETS]; N_IN],
}

/// The thesis's basis (4.39): (φ, φ̇) × (N, Z, P), ξ1 = N(φ)N(φ̇), ξ2 = N(φ)Z(φ̇), …
pub type ThesisBasis<T> = GridBasis<T, 2, 3, 9>;

impl<T: Real, const N_IN: usize, const N_SETS: usize, const N_RULES: usize> GridBasis<T, N_IN, N_SETS, N_RULES> {
    /// Checks every set and that `N_RULES = N_SETS^N_IN`.
    pub fn new(sets: [[Membership<T>; N_SETS]; N_IN]) -> Result<Self, TwipError> {
        if N_IN == 0 || N_SETS == 0 || N_SETS.checked_pow(N_IN as u32) != Some(N_RULES) {
            return Err(TwipError::InvalidParameter {
                name: "N_RULES",
                value: N_RULES as f64,
                reason: "must equal N_SETS ^ N_IN, with N_IN and N_SETS >= 1",
            });
        }
        for row in &sets {
            for s in row {
                s.validate()?;
            }
        }
        Ok(Self { sets, prepared: sets.map(|row| row.map(Prepared::new)) })
    }

    pub fn sets(&self) -> &[[Membership<T>; N_SETS]; N_IN] {
        &self.sets
    }

    /// ξ(x) of (4.29): non-negative, sums to 1 (module docs for when no rule fires).
    #[inline]
    pub fn eval(&self, x: &[T; N_IN]) -> [T; N_RULES] {
        let mut w = [[T::zero(); N_SETS]; N_IN];
        for i in 0..N_IN {
            let mut sum = T::zero();
            for (o, s) in w[i].iter_mut().zip(&self.prepared[i]) {
                *o = s.eval(x[i]);
                sum += *o;
            }
            if sum == T::zero() {
                w[i][nearest_set(&self.sets[i], x[i])] = T::one();
            } else {
                let inv = T::one() / sum;
                for o in w[i].iter_mut() {
                    *o *= inv;
                }
            }
        }
        let mut xi = [T::one(); N_RULES];
        // Rule k's set for input i is digit i of k in base N_SETS (most significant first).
        let mut stride = N_RULES;
        for wi in &w {
            stride /= N_SETS;
            for (k, v) in xi.iter_mut().enumerate() {
                *v *= wi[(k / stride) % N_SETS];
            }
        }
        xi
    }
}

impl<T: Real> ThesisBasis<T> {
    /// The thesis's 2 × 3 structure (4.39) with twip's breakpoints: [`Default::default`].
    pub fn thesis() -> Self {
        Self::default()
    }
}

impl<T: Real> Default for ThesisBasis<T> {
    /// twip's sets for (φ [rad], φ̇ [rad/s]) (the thesis's Figs 4.4/4.5 are not in the
    /// text; docs/scenarios.md says why these): trapezoids that sum to 1 everywhere
    /// (D = 1), φ: N = (−∞, −∞, −0.3, −0.1), Z = (−0.3, −0.1, 0.1, 0.3), P = (0.1, 0.3, ∞, ∞);
    /// φ̇: the same shapes with 0.5 and 2 rad/s.
    fn default() -> Self {
        let inf = T::one() / T::zero();
        let shoulders = |inner: f64, outer: f64| {
            let (inner, outer) = (c::<T>(inner), c::<T>(outer));
            [
                Membership::Trapezoid { a: -inf, b: -inf, c: -outer, d: -inner },
                Membership::Trapezoid { a: -outer, b: -inner, c: inner, d: outer },
                Membership::Trapezoid { a: inner, b: outer, c: inf, d: inf },
            ]
        };
        let sets = [shoulders(0.1, 0.3), shoulders(0.5, 2.0)];
        Self { sets, prepared: sets.map(|row| row.map(Prepared::new)) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trap(a: f64, b: f64, c: f64, d: f64) -> Membership<f64> {
        Membership::trapezoid(a, b, c, d).unwrap()
    }

    #[test]
    fn trapezoid_edges_shoulders_and_triangles() {
        let t = trap(0.0, 1.0, 2.0, 4.0);
        let expected = [(-1.0, 0.0), (0.0, 0.0), (0.5, 0.5), (1.0, 1.0), (2.0, 1.0), (3.0, 0.5), (4.0, 0.0), (5.0, 0.0)];
        for (x, mu) in expected {
            assert_eq!(t.eval(x), mu, "x = {x}");
        }
        let inf = f64::INFINITY;
        let left = trap(-inf, -inf, 0.0, 1.0);
        assert_eq!((left.eval(-inf), left.eval(-1e300), left.eval(0.5), left.eval(2.0)), (1.0, 1.0, 0.5, 0.0));
        let right = trap(0.0, 1.0, inf, inf);
        assert_eq!((right.eval(inf), right.eval(1e300), right.eval(0.5), right.eval(-2.0)), (1.0, 1.0, 0.5, 0.0));
        let crisp = trap(1.0, 1.0, 2.0, 2.0);
        assert_eq!((crisp.eval(0.999), crisp.eval(1.0), crisp.eval(2.0), crisp.eval(2.001)), (0.0, 1.0, 1.0, 0.0));
        let tri = Membership::triangle(0.0, 1.0, 3.0).unwrap();
        assert_eq!((tri.eval(0.5), tri.eval(1.0), tri.eval(2.0)), (0.5, 1.0, 0.5));
        let spike = trap(1.0, 1.0, 1.0, 1.0);
        assert_eq!((spike.eval(1.0), spike.eval(1.0 + 1e-15)), (1.0, 0.0));
        assert!(t.eval(f64::NAN).is_nan());
    }

    #[test]
    fn bad_breakpoints_are_named() {
        let err = Membership::trapezoid(0.0, 2.0, 1.0, 3.0).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "trapezoid.c", value, .. } if value == 1.0));
        let err = Membership::trapezoid(f64::NEG_INFINITY, 0.0, 1.0, 2.0).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "trapezoid.a", .. }));
        let err = Membership::triangle(0.0, 2.0, 1.0).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "triangle.c", .. }));
        assert!(Membership::gaussian(0.0, 0.0).is_err());
        assert!(Membership::trapezoid(0.0, f64::NAN, 1.0, 2.0).is_err());
    }

    #[test]
    fn thesis_basis_sums_to_one_and_orders_rules_as_4_39() {
        let basis = ThesisBasis::<f64>::default();
        for &x in &[[0.0, 0.0], [-1e9, 3.0], [0.2, -1.0], [f64::INFINITY, f64::NEG_INFINITY], [0.25, 1.1]] {
            let xi = basis.eval(&x);
            assert!((xi.iter().sum::<f64>() - 1.0).abs() < 1e-15 && xi.iter().all(|v| *v >= 0.0), "{x:?}");
        }
        // φ deep in N, φ̇ deep in Z: rule 2 (index 1) alone.
        assert_eq!(basis.eval(&[-1.0, 0.0])[1], 1.0);
        // φ in P, φ̇ in N: rule 7 (index 6).
        assert_eq!(basis.eval(&[1.0, -5.0])[6], 1.0);
    }

    #[test]
    fn no_rule_fires_falls_back_to_the_nearest_set() {
        // Gaps between the sets and no shoulders.
        let sets = [[trap(-3.0, -2.0, -2.0, -1.0), trap(-0.5, 0.0, 0.0, 0.5), trap(1.0, 2.0, 2.0, 3.0)]; 1];
        let basis = GridBasis::<f64, 1, 3, 3>::new(sets).unwrap();
        assert_eq!(basis.eval(&[0.7]), [0.0, 1.0, 0.0]);
        assert_eq!(basis.eval(&[0.9]), [0.0, 0.0, 1.0]);
        assert_eq!(basis.eval(&[-100.0]), [1.0, 0.0, 0.0]);
        assert_eq!(basis.eval(&[f64::INFINITY]), [0.0, 0.0, 1.0]);
        assert_eq!(basis.eval(&[f64::NEG_INFINITY]), [1.0, 0.0, 0.0]);
        let g = [[Membership::gaussian(-1.0, 0.1).unwrap(), Membership::gaussian(1.0, 0.1).unwrap()]; 2];
        let basis = GridBasis::<f64, 2, 2, 4>::new(g).unwrap();
        assert_eq!(basis.eval(&[1e6, -1e6]), [0.0, 0.0, 1.0, 0.0]);
        assert!(basis.eval(&[f64::NAN, 0.0]).iter().all(|v| v.is_nan()));
    }

    #[test]
    fn grid_product_matches_the_basis() {
        let basis = ThesisBasis::<f64>::default();
        let x = [0.15, -0.7];
        let mut w = [[0.0; 3]; 2];
        for i in 0..2 {
            normalised_memberships(&basis.sets()[i], x[i], &mut w[i]);
        }
        let mut out = [0.0; 9];
        grid_product(&[&w[0], &w[1]], &mut out).unwrap();
        for (a, b) in out.iter().zip(basis.eval(&x)) {
            assert!((a - b).abs() <= 4.0 * f64::EPSILON * a.abs(), "{a} vs {b}");
        }
        assert!(grid_product(&[&w[0], &w[1]], &mut [0.0; 8]).is_err());
        assert!(GridBasis::<f64, 2, 3, 8>::new(*basis.sets()).is_err());
    }
}
