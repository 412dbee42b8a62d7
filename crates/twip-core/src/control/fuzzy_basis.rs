//! Fuzzy logic systems (thesis 4.27–4.31, 4.39): membership functions and the normalised
//! fuzzy basis ξ of a grid rule base with singleton fuzzifier, product inference and
//! centre-average defuzzification, so that the system's output is `Ŝᵀ ξ(x)` (4.30).
//!
//! A grid rule base has one rule per combination of one set per input. Its denominator
//! D of (4.29) factorises, D = Π_i Σ_j μ_ij(x_i), so ξ is the product of each input's
//! memberships normalised on their own: that is how it is computed here (fewer
//! operations, and no underflow of D when many small memberships multiply).
//!
//! **When no rule fires** (D = 0: some input lies where none of its sets is non-zero, or
//! where their memberships sum to less than 1/f64::MAX, a subnormal whose inverse
//! overflows), that input's nearest set fires alone with weight 1: nearest by distance to the support
//! [a, d] for trapezoids and triangles, by |x − mean|/σ for Gaussians (a Gaussian far
//! out underflows to 0). Ties go to the last set listed when x > 0 and to the first one
//! otherwise, so with sets listed left to right an input at ±∞ belongs to the outermost
//! set. ξ is then defined, non-negative and sums to 1 for every finite or infinite input;
//! a NaN input gives NaN. Sets that cover the line with shoulders (the thesis's N, Z, P)
//! never need the fallback.
//!
//! Everything is fixed-size: no allocation, no_std.
use crate::error::invalid;
use crate::model::lane::{fill, Lane};
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
                // A ramp is evaluated by its slope 1/width: a width too narrow (subnormal) or
                // too wide (overflowing) for it to be finite and nonzero would read NaN or 0.
                const RAMP: &str = "makes a ramp whose slope 1/width is not finite: a width must be 0 or from 5.6e-309 to 1.8e308";
                let slope_ok = |lo: T, hi: T| lo == hi || ((hi - lo).is_finite() && (T::one() / (hi - lo)).is_finite());
                if !slope_ok(a, b) {
                    return Err(invalid("trapezoid.b", b, RAMP));
                }
                if !slope_ok(c, d) {
                    return Err(invalid("trapezoid.d", d, RAMP));
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

    /// μ(x) (the ramps multiplied by their reciprocal widths, within an ulp of dividing).
    #[inline(always)]
    pub fn eval(&self, x: T) -> T {
        Prepared::new(*self).value(x)
    }

    /// How far `x` is from where the set is non-zero (for the no-rule-fires fallback).
    #[inline]
    pub fn distance(&self, x: T) -> T {
        Prepared::new(*self).distance(x)
    }
}

/// Writes the memberships of `x` in `sets`, normalised to sum to 1, into `out`
/// (`out.len() == sets.len()`); if none is non-zero, the nearest set gets 1 (module docs).
#[inline(always)]
pub fn normalised_memberships<T: Real>(sets: &[Membership<T>], x: T, out: &mut [T]) {
    // `normalise` for a number of sets known only at run time, from the same pieces.
    let mut sum = T::zero();
    for (o, s) in out.iter_mut().zip(sets) {
        *o = s.value(x);
        sum += *o;
    }
    let (mut nearest, mut best) = (T::zero(), T::one() / T::zero());
    for (j, set) in sets.iter().enumerate() {
        (nearest, best) = nearer(x, (nearest, best), (j, Member::distance(set, x)));
    }
    let inv = T::one() / sum;
    let none = fires_none(sum, inv);
    for (j, o) in out.iter_mut().enumerate() {
        *o = weight(*o, inv, none, nearest == c::<T>(j as f64));
    }
}

/// A membership function as the basis evaluates it, for a run (`T`) or a sweep's lanes.
pub(crate) trait Member<S> {
    /// μ(x).
    fn value(&self, x: S) -> S;
    /// How far x is from where μ is non-zero.
    fn distance(&self, x: S) -> S;
}

impl<T: Real> Member<T> for Membership<T> {
    #[inline(always)]
    fn value(&self, x: T) -> T {
        self.eval(x)
    }

    #[inline(always)]
    fn distance(&self, x: T) -> T {
        Membership::distance(self, x)
    }
}

/// [`normalised_memberships`] of one input of a grid basis, over any [`Member`], written
/// once over [`Lane`] without branches: every membership and the nearest set are
/// computed, and the case that holds is selected. A NaN input gives NaN. Fixed-size and
/// by value, so that a sweep's loop over lanes keeps it in registers and vectorises it.
#[inline(always)]
pub(crate) fn normalise<S: Lane, M: Member<S>, const N: usize>(sets: &[M; N], x: S) -> [S; N] {
    // A loop, not `fill`'s closure: a Gaussian's e^x made that closure too large to inline
    // into a sweep's CPU-specific copy, which then ran baseline code calling libm's fma.
    let mut mu = [S::splat(0.0); N];
    for (m, set) in mu.iter_mut().zip(sets) {
        *m = set.value(x);
    }
    let sum = mu.iter().fold(S::splat(0.0), |sum, m| sum + *m);
    let inv = S::splat(1.0) / sum;
    let none = fires_none(sum, inv);
    if !S::any(none) {
        // Some rule fires for every lane (always with sets that cover the line).
        return fill(|j| mu[j] * inv);
    }
    let (mut nearest, mut best) = (S::splat(0.0), S::splat(f64::INFINITY));
    for (j, set) in sets.iter().enumerate() {
        (nearest, best) = nearer(x, (nearest, best), (j, set.distance(x)));
    }
    fill(|j| weight(mu[j], inv, none, nearest.eq(S::splat(j as f64))))
}

/// The nearer of the best set so far (its index, as a number, and distance) and set `j`
/// at distance `d` from `x`: ties go to the later set when x > 0, else to the first
/// (module docs).
#[inline(always)]
pub(crate) fn nearer<S: Lane>(x: S, (best, best_d): (S, S), (j, d): (usize, S)) -> (S, S) {
    let take = d.lt(best_d) | (x.gt(S::splat(0.0)) & d.eq(best_d)) | S::mask(j == 0);
    (S::select(take, S::splat(j as f64), best), S::select(take, d, best_d))
}

/// Whether no rule fires, given the memberships' sum and its inverse: no set holds x, or
/// they hold it so faintly (Gaussians far out: a subnormal Σμ) that 1/Σμ overflows, where
/// μ · ∞ would make ξ infinite or NaN. A NaN input keeps its NaN.
#[inline(always)]
pub(crate) fn fires_none<S: Lane>(sum: S, inv: S) -> S::Mask {
    sum.eq(S::splat(0.0)) | inv.eq(S::splat(f64::INFINITY))
}

/// A set's normalised weight: its share μ · (1/Σμ), or when no set holds x (`none`),
/// 1 for the nearest set and 0 for the others.
#[inline(always)]
pub(crate) fn weight<S: Lane>(mu: S, inv: S, none: S::Mask, nearest: S::Mask) -> S {
    S::select(none, S::select(nearest, S::splat(1.0), S::splat(0.0)), mu * inv)
}

/// A trapezoid ready for repeated evaluation: its breakpoints and the ramps' reciprocal
/// widths 1/(b − a) and 1/(d − c), which are only used where the ramp has width (else ∞
/// or NaN, computed and not selected).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Trapezoid<S> {
    pub a: S,
    pub b: S,
    pub c: S,
    pub d: S,
    pub inv_rise: S,
    pub inv_fall: S,
}

impl<S: Lane> Trapezoid<S> {
    #[inline(always)]
    pub(crate) fn new(a: S, b: S, c: S, d: S) -> Self {
        let one = S::splat(1.0);
        Self { a, b, c, d, inv_rise: one / (b - a), inv_fall: one / (d - c) }
    }
}

impl<T: Copy> Trapezoid<T> {
    /// The same trapezoid in another number type (a sweep's lanes).
    #[inline(always)]
    pub(crate) fn map<S>(&self, to: impl Fn(T) -> S) -> Trapezoid<S> {
        Trapezoid { a: to(self.a), b: to(self.b), c: to(self.c), d: to(self.d), inv_rise: to(self.inv_rise), inv_fall: to(self.inv_fall) }
    }
}

impl<S: Lane> Member<S> for Trapezoid<S> {
    /// Every piece computed, the one that holds selected; NaN stays NaN. Outside [a, d]
    /// the ramp that is selected there is negative (or −∞ at a vertical edge), so one
    /// compare with 0 gives the zero, not two with the ends: the same numbers.
    #[inline(always)]
    fn value(&self, x: S) -> S {
        let top = S::select(x.le(self.c), S::splat(1.0), (self.d - x) * self.inv_fall);
        let piece = S::select(x.lt(self.b), (x - self.a) * self.inv_rise, top);
        S::select(piece.lt(S::splat(0.0)), S::splat(0.0), piece)
    }

    #[inline(always)]
    fn distance(&self, x: S) -> S {
        (self.a - x).larger(x - self.d).larger(S::splat(0.0))
    }
}

/// A set ready for repeated evaluation, in a run's numbers or a sweep's lanes'.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Prepared<T> {
    Trapezoid(Trapezoid<T>),
    /// Gaussians keep their division: exp(−z²/2) magnifies an ulp of z by z².
    Gaussian { mean: T, sigma: T },
}

impl<T: Real> Prepared<T> {
    pub(crate) fn new(m: Membership<T>) -> Self {
        match m {
            Membership::Trapezoid { a, b, c, d } => Self::Trapezoid(Trapezoid::new(a, b, c, d)),
            Membership::Gaussian { mean, sigma } => Self::Gaussian { mean, sigma },
        }
    }
}

impl<T: Copy> Prepared<T> {
    /// The same set in another number type (a sweep's lanes).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps need std
    pub(crate) fn map<S>(&self, to: impl Fn(T) -> S) -> Prepared<S> {
        match *self {
            Self::Trapezoid(t) => Prepared::Trapezoid(t.map(to)),
            Self::Gaussian { mean, sigma } => Prepared::Gaussian { mean: to(mean), sigma: to(sigma) },
        }
    }
}

/// Written once over [`Lane`]: the set's kind is every lane's alike (the prototype's), so
/// the match is one branch for all lanes. A lane's e^x is the vectorising polynomial
/// (within 2 ulp of a run's libm), which gives 0 below e^−708 where libm still gives a tiny
/// number: an input that far from every Gaussian takes the nearest-set fallback on lanes,
/// and in a run too once Σμ is too small to invert (see [`normalise`]); in between, a run's
/// shares pick the same set up to shares of 1e-308.
impl<S: Lane> Member<S> for Prepared<S> {
    #[inline(always)]
    fn value(&self, x: S) -> S {
        match *self {
            Self::Trapezoid(t) => t.value(x),
            Self::Gaussian { mean, sigma } => {
                let z = (x - mean) / sigma;
                (S::splat(-0.5) * z * z).decay()
            }
        }
    }

    #[inline(always)]
    fn distance(&self, x: S) -> S {
        match *self {
            Self::Trapezoid(t) => t.distance(x),
            Self::Gaussian { mean, sigma } => (x - mean).magnitude() / sigma,
        }
    }
}

/// The row-major tensor product of per-input weights: `out[k] = Π_i w_i[j_i]` with the
/// last input varying fastest (the rule order of (4.39)). `out.len()` must be the
/// product of the lengths; for bases whose sizes are only known at run time.
pub fn grid_product<S: Lane>(weights: &[&[S]], out: &mut [S]) -> Result<(), TwipError> {
    let rules = weights.iter().map(|w| w.len()).product::<usize>();
    if rules != out.len() || weights.is_empty() {
        return Err(TwipError::Shape { name: "xi", expected: (rules, 1), got: (out.len(), 1) });
    }
    product_into(weights, out);
    Ok(())
}

/// [`grid_product`] once the sizes are known to agree.
#[inline(always)]
fn product_into<S: Lane>(weights: &[&[S]], out: &mut [S]) {
    out[0] = S::splat(1.0);
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
        grid(&self.prepared, x)
    }
}

/// ξ(x) of a grid basis of prepared sets, written once over [`Lane`] (a run's and a
/// sweep lane's): each input's memberships normalised on their own, then their product.
#[inline(always)]
pub(crate) fn grid<S: Lane, M: Member<S>, const N_IN: usize, const N_SETS: usize, const N_RULES: usize>(
    sets: &[[M; N_SETS]; N_IN],
    x: &[S; N_IN],
) -> [S; N_RULES] {
    let mut w = [[S::splat(0.0); N_SETS]; N_IN];
    for (i, wi) in w.iter_mut().enumerate() {
        *wi = normalise(&sets[i], x[i]);
    }
    // Rule k's set for input i is digit i of k in base N_SETS (most significant first).
    let xi = fill(|k| {
        let mut stride = N_RULES;
        w.iter().fold(S::splat(1.0), |product, wi| {
            stride /= N_SETS;
            product * wi[(k / stride) % N_SETS]
        })
    });
    xi
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
    #[cfg(feature = "std")] // the lanes' types
    fn a_trapezoid_is_its_four_pieces_bit_for_bit_on_runs_and_lanes() {
        use crate::model::lane::Wide;
        // The pieces as the definition reads: 0 outside [a, d], the rise on [a, b), 1 on
        // [b, c], the fall on (c, d].
        fn pieces(a: f64, b: f64, c: f64, d: f64, x: f64) -> f64 {
            let (rise, fall) = ((x - a) * (1.0 / (b - a)), (d - x) * (1.0 / (d - c)));
            match x {
                x if x.is_nan() => f64::NAN,
                x if x < a || x > d => 0.0,
                x if x < b => rise,
                x if x <= c => 1.0,
                _ => fall,
            }
        }
        let inf = f64::INFINITY;
        let sets = [
            (0.0, 1.0, 2.0, 4.0), (-inf, -inf, -0.3, -0.1), (-0.3, -0.1, 0.1, 0.3), (0.1, 0.3, inf, inf),
            (1.0, 1.0, 2.0, 2.0), (1.0, 1.0, 1.0, 1.0), (-2.0, 0.5, 0.5, 0.7), (-1e-3, 0.0, 1e300, 1e301),
        ];
        let ulp = |x: f64, up: bool| if x.is_finite() { f64::from_bits((x.to_bits() as i64 + if (x >= 0.0) == up { 1 } else { -1 }) as u64) } else { x };
        for (a, b, c, d) in sets {
            let t = trap(a, b, c, d);
            let mut xs = vec![-inf, inf, f64::NAN, 0.0, -0.0, 1e300, -1e300, -5.0, 5.0];
            for p in [a, b, c, d, 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + d), 0.3 * a + 0.7 * b, 0.9 * c + 0.1 * d] {
                xs.extend([p, ulp(p, true), ulp(p, false)]);
            }
            let lanes: Trapezoid<Wide<8>> = Trapezoid::new(Wide::splat(a), Wide::splat(b), Wide::splat(c), Wide::splat(d));
            for x in xs {
                let (want, run, lane) = (pieces(a, b, c, d, x), t.eval(x), lanes.value(Wide::splat(x)).0[3]);
                assert!(want.to_bits() == run.to_bits() || (want.is_nan() && run.is_nan()), "({a}, {b}, {c}, {d}) at {x}: {run} vs {want}");
                assert!(lane.to_bits() == run.to_bits() || (lane.is_nan() && run.is_nan()), "({a}, {b}, {c}, {d}) at {x}: lane {lane}");
            }
        }
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
        // A ramp whose slope 1/width overflows read NaN at its foot (0 · inf); one too wide to
        // measure read 0 all along it.
        let err = Membership::trapezoid(0.0, 0.0, 0.0, 2.225073858507e-311).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "trapezoid.d", .. }));
        let err = Membership::trapezoid(-1e308, 1e308, 1e308, 1e308).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "trapezoid.b", .. }));
        let narrowest = 1.0 / f64::MAX * 1.001;
        assert_eq!(trap(0.0, narrowest, 1.0, 1.0 + narrowest).eval(narrowest / 2.0), 0.5);
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
        // Far enough out that the memberships are subnormal (e^(−z²/2) ≈ 1e-310 at z ≈ 37.8):
        // 1/Σμ overflows, so the nearest set takes over (this gave ∞ · μ and NaN · 0: a run
        // with narrow Gaussians diverged where its sweep's lanes, whose e^x flushes those to
        // 0, did not).
        let x = 1.0 + 0.1 * 37.8;
        let mu = (-0.5f64 * 37.8 * 37.8).exp();
        assert!(mu > 0.0 && (1.0 / mu).is_infinite(), "{mu:e} should be subnormal");
        assert_eq!(basis.eval(&[x, -x]), [0.0, 0.0, 1.0, 0.0]);
        // The same for a number of sets known at run time (the bindings' `FuzzyBasis.eval`).
        let mut w = [0.0; 2];
        normalised_memberships(&g[0], x, &mut w);
        assert_eq!(w, [0.0, 1.0]);
        let xi = basis.eval(&[1.0 + 0.1 * 37.0, 0.0]); // normal but tiny: shares as usual
        assert!(xi.iter().all(|v| v.is_finite()) && (xi.iter().sum::<f64>() - 1.0).abs() < 1e-15, "{xi:?}");
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
