//! An n × n fuzzy basis over the adaptive controllers' two inputs, n from 2 to
//! [`MAX_SETS`] (the thesis's future work: more sets and rules than its Arduino could
//! afford). The sets live in a fixed-capacity array and the rule count is read at run
//! time, so the control law stays no_std and allocation-free: a controller carries
//! room for [`MAX_RULES`] weights whatever its n.
//!
//! ξ is computed as [`super::fuzzy_basis`]'s grid (each input's memberships normalised on
//! their own, then their product, the last input fastest, the same operations in the same
//! order), so the thesis's 3 × 3 trapezoids give the same bits through either.
use crate::control::fuzzy_basis::{fires_none, grid, nearer, weight, Member, Membership, Prepared, ThesisBasis, Trapezoid};
use crate::model::lane::Lane;
use crate::{Real, TwipError};

/// The most sets per input a controller has room for.
pub const MAX_SETS: usize = 7;
/// The most rules: [`MAX_SETS`]².
pub const MAX_RULES: usize = MAX_SETS * MAX_SETS;
/// The capacity as the error says it, in step with [`MAX_SETS`].
const CAPACITY: &str = "must be at most 7 sets per input (49 rules), the controllers' fixed capacity";
const _: () = assert!(MAX_SETS == 7 && MAX_RULES == 49, "CAPACITY's numbers");

/// The shape of every set of a regular grid ([`FuzzyGrid::regular`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetKind {
    /// Core [c_j − w_j, c_j + w_j], feet at the neighbours' core edges, the outer two
    /// shoulders: the sets sum to 1 everywhere (the thesis's N, Z, P are such).
    Trapezoid,
    /// Peak at c_j, feet at the neighbouring centres, the outer two shoulders (no widths).
    Triangle,
    /// Mean c_j, σ = w_j.
    Gaussian,
}

/// An n × n grid basis over (φ, φ̇): rule k takes set k / n of φ and set k % n of φ̇.
#[derive(Clone, Copy, Debug)]
pub struct FuzzyGrid<T> {
    n: usize,
    /// The sets, the slots past n holding copies of the last (never evaluated).
    sets: [[Membership<T>; MAX_SETS]; 2],
    prepared: [[Prepared<T>; MAX_SETS]; 2],
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> TwipError {
    TwipError::InvalidParameter { name, value, reason }
}

/// Refuses an n no grid can have.
fn check_n(n: usize) -> Result<(), TwipError> {
    if n < 2 {
        return Err(invalid("n", n as f64, "a grid needs at least 2 sets per input"));
    }
    if n > MAX_SETS {
        return Err(invalid("n", n as f64, CAPACITY));
    }
    Ok(())
}

impl<T: Real> FuzzyGrid<T> {
    /// The grid of `sets[0]` (φ's) × `sets[1]` (φ̇'s), n of each, every set checked.
    pub fn new(sets: [&[Membership<T>]; 2]) -> Result<Self, TwipError> {
        let n = sets[0].len();
        check_n(n)?;
        if sets[1].len() != n {
            return Err(TwipError::Shape { name: "sets", expected: (2, n), got: (2, sets[1].len()) });
        }
        let mut out = [[sets[0][0]; MAX_SETS]; 2];
        for (row, given) in out.iter_mut().zip(sets) {
            for (j, slot) in row.iter_mut().enumerate() {
                *slot = given[j.min(n - 1)].validate()?;
            }
        }
        Ok(Self { n, sets: out, prepared: out.map(|row| row.map(Prepared::new)) })
    }

    /// A regular grid: `kind` sets at `centres[i]` (n per input, finite, strictly
    /// increasing) with `widths[i]` (n per input, finite, > 0; empty for triangles).
    pub fn regular(kind: SetKind, centres: [&[T]; 2], widths: [&[T]; 2]) -> Result<Self, TwipError> {
        let n = centres[0].len();
        check_n(n)?;
        let mut rows = [[Membership::Gaussian { mean: T::zero(), sigma: T::one() }; MAX_SETS]; 2];
        for (row, (c, w)) in rows.iter_mut().zip(centres.into_iter().zip(widths)) {
            if c.len() != n {
                return Err(TwipError::Shape { name: "centres", expected: (2, n), got: (2, c.len()) });
            }
            for (j, v) in c.iter().enumerate() {
                if !v.is_finite() || (j > 0 && *v <= c[j - 1]) {
                    return Err(invalid("centres", crate::to_f64(*v), "must be finite and strictly increasing"));
                }
            }
            let expected = if kind == SetKind::Triangle { 0 } else { n };
            if w.len() != expected {
                let reason = "must give one width per set (none for triangles, whose feet are the neighbouring centres)";
                return Err(invalid("widths", w.len() as f64, reason));
            }
            for v in w {
                if !(v.is_finite() && *v > T::zero()) {
                    return Err(invalid("widths", crate::to_f64(*v), "must be finite and > 0"));
                }
            }
            regular_row(kind, c, w, &mut row[..n])?;
        }
        Self::new([&rows[0][..n], &rows[1][..n]])
    }

    /// Sets per input.
    pub fn n(&self) -> usize {
        self.n
    }

    /// n².
    pub fn rules(&self) -> usize {
        self.n * self.n
    }

    /// φ's sets and φ̇'s, n each.
    pub fn sets(&self) -> [&[Membership<T>]; 2] {
        [&self.sets[0][..self.n], &self.sets[1][..self.n]]
    }

    /// ξ(φ, φ̇): the first n² entries are the rules', the rest 0.
    #[inline]
    pub fn eval(&self, x: &[T; 2]) -> [T; MAX_RULES] {
        self.sized().xi(x)
    }

    /// The prepared sets with their count, as the law reads them.
    #[inline(always)]
    pub(crate) fn sized(&self) -> Sized<'_, Prepared<T>> {
        Sized { sets: &self.prepared, n: self.n }
    }

    /// The prepared sets in another number type (a sweep's lanes).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps need std
    pub(crate) fn prepared_in<S>(&self, to: impl Fn(T) -> S + Copy) -> [[Prepared<S>; MAX_SETS]; 2] {
        self.prepared.map(|row| row.map(|p| p.map(to)))
    }

    /// The sets as trapezoids, if every one is, in another number type.
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps need std
    pub(crate) fn trapezoids<S: Copy>(&self, to: impl Fn(T) -> S + Copy) -> Option<[[Trapezoid<S>; MAX_SETS]; 2]> {
        let mut out = [[None; MAX_SETS]; 2];
        for (row, sets) in out.iter_mut().zip(self.prepared_in(to)) {
            for (o, p) in row.iter_mut().zip(sets) {
                let Prepared::Trapezoid(t) = p else { return None };
                *o = Some(t);
            }
        }
        Some(out.map(|row| row.map(|t| t.expect("every set was filled"))))
    }

    /// The thesis's grid as the fixed 2 × 3 basis, if this is 3 × 3.
    pub fn as_thesis(&self) -> Option<ThesisBasis<T>> {
        (self.n == 3).then(|| ThesisBasis::new([0, 1].map(|i| [0, 1, 2].map(|j| self.sets[i][j]))).expect("checked sets"))
    }
}

/// The n sets of one input of a regular grid into `row`.
fn regular_row<T: Real>(kind: SetKind, c: &[T], w: &[T], row: &mut [Membership<T>]) -> Result<(), TwipError> {
    let n = c.len();
    let inf = T::one() / T::zero();
    if kind == SetKind::Trapezoid {
        for j in 1..n {
            if c[j] - w[j] < c[j - 1] + w[j - 1] {
                let reason = "makes neighbouring cores overlap: need centres[j] - widths[j] >= centres[j-1] + widths[j-1]";
                return Err(invalid("widths", crate::to_f64(w[j]), reason));
            }
        }
    }
    for j in 0..n {
        row[j] = match kind {
            SetKind::Gaussian => Membership::gaussian(c[j], w[j])?,
            SetKind::Triangle => {
                let a = if j == 0 { -inf } else { c[j - 1] };
                let (cc, d) = if j + 1 == n { (inf, inf) } else { (c[j], c[j + 1]) };
                Membership::trapezoid(a, if j == 0 { -inf } else { c[j] }, cc, d)?
            }
            SetKind::Trapezoid => {
                let (a, b) = if j == 0 { (-inf, -inf) } else { (c[j - 1] + w[j - 1], c[j] - w[j]) };
                let (cc, d) = if j + 1 == n { (inf, inf) } else { (c[j] + w[j], c[j + 1] - w[j + 1]) };
                Membership::trapezoid(a, b, cc, d)?
            }
        };
    }
    Ok(())
}

/// Equal when the sets are (a shoulder's prepared ramp slope is NaN, so those are not compared).
impl<T: Real> PartialEq for FuzzyGrid<T> {
    fn eq(&self, other: &Self) -> bool {
        self.sets() == other.sets()
    }
}

impl<T: Real> From<ThesisBasis<T>> for FuzzyGrid<T> {
    fn from(b: ThesisBasis<T>) -> Self {
        let [phi, rate] = b.sets();
        Self::new([&phi[..], &rate[..]]).expect("a checked 3 x 3 basis")
    }
}

impl<T: Real> Default for FuzzyGrid<T> {
    /// The thesis's 3 × 3 trapezoids ([`ThesisBasis::default`]).
    fn default() -> Self {
        ThesisBasis::default().into()
    }
}

/// A rule base as the adaptive laws read it: ξ into `R` slots, of which the first
/// [`RuleBase::rules`] are the rules'.
pub(crate) trait RuleBase<S, const R: usize> {
    fn rules(&self) -> usize;
    fn xi(&self, x: &[S; 2]) -> [S; R];
}

/// A fixed n × n grid, n known when compiling (the thesis's 3 × 3 on lanes).
impl<S: Lane, M: Member<S>, const NS: usize, const R: usize> RuleBase<S, R> for [[M; NS]; 2] {
    #[inline(always)]
    fn rules(&self) -> usize {
        R
    }

    #[inline(always)]
    fn xi(&self, x: &[S; 2]) -> [S; R] {
        grid(self, x)
    }
}

/// A grid of n sets per input in a capacity of [`MAX_SETS`], n read at run time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sized<'a, M> {
    pub sets: &'a [[M; MAX_SETS]; 2],
    pub n: usize,
}

impl<S: Lane, M: Member<S>> RuleBase<S, MAX_RULES> for Sized<'_, M> {
    #[inline(always)]
    fn rules(&self) -> usize {
        self.n * self.n
    }

    /// As [`grid`], over the first n sets of each input.
    #[inline(always)]
    fn xi(&self, x: &[S; 2]) -> [S; MAX_RULES] {
        let n = self.n;
        let w0 = normalise_first(&self.sets[0], n, x[0]);
        let w1 = normalise_first(&self.sets[1], n, x[1]);
        let mut xi = [S::splat(0.0); MAX_RULES];
        for (k, o) in xi.iter_mut().take(n * n).enumerate() {
            *o = S::splat(1.0) * w0[k / n] * w1[k % n];
        }
        xi
    }
}

/// [`super::fuzzy_basis::normalise`] over the first `n` sets of `sets`.
#[inline(always)]
fn normalise_first<S: Lane, M: Member<S>>(sets: &[M; MAX_SETS], n: usize, x: S) -> [S; MAX_SETS] {
    let mut mu = [S::splat(0.0); MAX_SETS];
    for (m, set) in mu.iter_mut().zip(sets).take(n) {
        *m = set.value(x);
    }
    let sum = mu[..n].iter().fold(S::splat(0.0), |sum, m| sum + *m);
    let inv = S::splat(1.0) / sum;
    let none = fires_none(sum, inv);
    if !S::any(none) {
        for m in &mut mu[..n] {
            *m = *m * inv;
        }
        return mu;
    }
    let (mut nearest, mut best) = (S::splat(0.0), S::splat(f64::INFINITY));
    for (j, set) in sets.iter().enumerate().take(n) {
        (nearest, best) = nearer(x, (nearest, best), (j, set.distance(x)));
    }
    for (j, m) in mu.iter_mut().enumerate().take(n) {
        *m = weight(*m, inv, none, nearest.eq(S::splat(j as f64)));
    }
    mu
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thesis_grid_gives_the_fixed_basis_bits() {
        let fixed = ThesisBasis::<f64>::default();
        let grid = FuzzyGrid::from(fixed);
        for x in [[0.0, 0.0], [0.15, -1.0], [-0.25, 1.7], [1.0, -5.0], [f64::INFINITY, 0.3], [0.05, 0.6]] {
            let (a, b) = (fixed.eval(&x), grid.eval(&x));
            assert!(a.iter().zip(&b).all(|(a, b)| a.to_bits() == b.to_bits()), "{x:?}");
            assert!(b[9..].iter().all(|v| *v == 0.0));
        }
    }

    #[test]
    fn a_regular_gaussian_grid_sums_to_one_and_falls_back_far_out() {
        let c = [-0.4, -0.2, 0.0, 0.2, 0.4];
        let r = [-4.0, -2.0, 0.0, 2.0, 4.0];
        let grid = FuzzyGrid::regular(SetKind::Gaussian, [&c, &r], [&[0.1; 5], &[1.0; 5]]).unwrap();
        assert_eq!(grid.rules(), 25);
        for x in [[0.0, 0.0], [0.13, -1.1], [-0.5, 3.0]] {
            let xi = grid.eval(&x);
            assert!((xi.iter().sum::<f64>() - 1.0).abs() < 1e-14, "{x:?}");
            assert!(xi[..25].iter().all(|v| *v > 0.0) && xi[25..].iter().all(|v| *v == 0.0));
        }
        // At the corner's centres, that rule fires most.
        let xi = grid.eval(&[0.4, -4.0]);
        let best = (0..25).max_by(|a, b| xi[*a].total_cmp(&xi[*b])).unwrap();
        assert_eq!(best, 4 * 5);
        // Far beyond every set: the nearest set alone (module docs of fuzzy_basis).
        let xi = grid.eval(&[1e6, -1e6]);
        assert_eq!(xi[20], 1.0);
    }

    #[test]
    fn regular_trapezoids_and_triangles_cover_the_line() {
        let c = [-0.4, 0.0, 0.4];
        let r = [-2.5, 0.0, 2.5];
        let grid = FuzzyGrid::regular(SetKind::Trapezoid, [&c, &r], [&[0.1; 3], &[0.5; 3]]).unwrap();
        // The thesis's breakpoints, to the rounding of c ± w.
        let thesis = ThesisBasis::<f64>::default();
        for (got, want) in grid.sets().iter().flat_map(|r| r.iter()).zip(thesis.sets().iter().flatten()) {
            let (Membership::Trapezoid { a, b, c, d }, Membership::Trapezoid { a: a2, b: b2, c: c2, d: d2 }) = (got, want) else { panic!() };
            for (u, v) in [(a, a2), (b, b2), (c, c2), (d, d2)] {
                assert!(u == v || (u - v).abs() < 1e-15, "{got:?} vs {want:?}");
            }
        }
        let tri = FuzzyGrid::regular(SetKind::Triangle, [&[-1.0, -0.5, 0.0, 0.5, 1.0], &[-2.0, -1.0, 0.0, 1.0, 2.0]], [&[], &[]]).unwrap();
        for x in [[-3.0, 0.7], [0.25, -1.5], [0.9, 9.0]] {
            for (sets, v) in tri.sets().iter().zip(x) {
                assert!((sets.iter().map(|m| m.eval(v)).sum::<f64>() - 1.0).abs() < 1e-15, "{x:?}");
            }
            assert!((tri.eval(&x).iter().sum::<f64>() - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn bad_grids_are_named() {
        let name = |r: Result<FuzzyGrid<f64>, TwipError>| match r {
            Err(TwipError::InvalidParameter { name, value, .. }) => (name, value),
            Err(TwipError::Shape { name, .. }) => (name, f64::NAN),
            other => panic!("expected an error, got {other:?}"),
        };
        let g = |c: &[f64], w: &[f64]| FuzzyGrid::regular(SetKind::Gaussian, [c, c], [w, w]);
        assert_eq!(name(g(&[0.0], &[1.0])), ("n", 1.0));
        assert_eq!(name(g(&[0.0; 8], &[1.0; 8])), ("n", 8.0));
        assert_eq!(name(g(&[0.0, 1.0, 1.0], &[1.0; 3])), ("centres", 1.0));
        assert_eq!(name(g(&[0.0, f64::NAN], &[1.0; 2])).0, "centres");
        assert_eq!(name(g(&[0.0, 1.0], &[1.0, 0.0])), ("widths", 0.0));
        assert_eq!(name(g(&[0.0, 1.0], &[1.0, -2.0])), ("widths", -2.0));
        assert_eq!(name(g(&[0.0, 1.0], &[1.0])), ("widths", 1.0));
        let t = FuzzyGrid::regular(SetKind::Trapezoid, [&[0.0, 1.0], &[0.0, 1.0]], [&[0.6, 0.6], &[0.1, 0.1]]);
        assert_eq!(name(t), ("widths", 0.6));
        let tri = FuzzyGrid::regular(SetKind::Triangle, [&[0.0, 1.0], &[0.0, 1.0]], [&[1.0, 1.0], &[]]);
        assert_eq!(name(tri).0, "widths");
        let m = Membership::gaussian(0.0, 1.0).unwrap();
        assert_eq!(name(FuzzyGrid::new([&[m; 3], &[m; 2]])).0, "sets");
        assert_eq!(name(FuzzyGrid::new([&[m; 8], &[m; 8]])), ("n", 8.0));
    }
}
