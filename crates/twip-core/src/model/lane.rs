//! The scalar the physics is written over, once, for a run and for a sweep's lanes.
//!
//! A run computes in `f32` or `f64` with plain rounding: a multiply-add is `a * b + c`,
//! two roundings, which needs neither an FMA unit nor a libm call (a microcontroller's
//! firmware gets the same bits). A sweep advances many robots at once, their multiply-adds
//! fused: one rounding, faster, and exactly rounded on every CPU, so a lane agrees with
//! the run of its robot to rounding, and with itself bit for bit on any CPU. Two lane
//! types carry it, with the same bits lane by lane:
//! - [`Fused`], one lane's `f64` in a loop over lanes that the compiler vectorises itself
//!   (the plant's RK4, the LQR law, the metrics: measured the fastest there);
//! - [`Wide`], [`WIDTH`] lanes in one value, every operation a vector instruction, for the
//!   laws whose loop the compiler will not vectorise (the fuzzy basis's selects).
//!
//! Code over [`Lane`] has no branches on values: a comparison gives a mask
//! ([`Lane::Mask`]: a `bool` for one number, one per lane for [`Wide`]) and
//! [`Lane::select`] picks lane by lane.
use core::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

use crate::Real;

/// A number as the physics kernels see it (see the module docs).
pub trait Lane:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// The outcome of a comparison: `bool`, or one per lane.
    type Mask: Copy + BitAnd<Output = Self::Mask> + BitOr<Output = Self::Mask> + Not<Output = Self::Mask>;
    /// The constant `v`.
    fn splat(v: f64) -> Self;
    /// A mask that is `m` in every lane.
    fn mask(m: bool) -> Self::Mask;
    /// a · b + c, rounded as this type rounds (twice plain, once fused).
    fn madd(a: Self, b: Self, c: Self) -> Self;
    /// (sin x, cos x) by the shared polynomial (`math`).
    fn sincos(x: Self) -> (Self, Self);
    /// |x|.
    fn magnitude(self) -> Self;
    /// The larger of two (NaN-ignoring, as `f64::max`: for peaks; a saturation is [`saturate`],
    /// which keeps a NaN).
    fn larger(self, other: Self) -> Self;
    /// The smaller of two (NaN-ignoring, as `f64::min`).
    fn smaller(self, other: Self) -> Self;
    /// The largest whole number ≤ x.
    fn floor(self) -> Self;
    /// e^x: libm's in a run; on lanes a polynomial that vectorises, within 2 ulp of libm's
    /// (`math::exp_fused` on `Fused`, `math::exp_wide` on `Wide`: summed in other orders,
    /// the two may differ by an ulp). Named apart from `ComplexField::exp`, which a `Real`
    /// has too.
    fn exponential(self) -> Self;
    /// e^x for x ≤ 0 or NaN (a decay): [`Self::exponential`] in a run; on lanes without its
    /// guards against overflow, which x ≤ 0 cannot reach (its bits from −707 up).
    #[inline(always)]
    fn decay(self) -> Self {
        self.exponential()
    }
    /// tanh x: libm's in a run, `math::tanh_fused` on lanes (libm's is a call per lane,
    /// which kept the lanes' loops from vectorising; `Wide` still runs it lane by lane, as no
    /// `Wide` law takes tanh).
    fn hyperbolic_tangent(self) -> Self;
    /// √x, correctly rounded on every type (IEEE's square root: a run's and a lane's agree
    /// bit for bit).
    fn square_root(self) -> Self;
    /// atan(self / x) for x > 0 (the terrain frame's δ = atan2(sin γ, cos β)): libm's
    /// `atan2` in a run; on lanes `math::atan_fused` of the quotient, a polynomial without a
    /// branch or a call (within 2 ulp of libm's, tested), so that a loop over lanes vectorises.
    fn arctangent_over(self, x: Self) -> Self;
    /// asin x for |x| ≤ 1 (the grade's rest pitch, `control::grade`): libm's in a run; on
    /// lanes `math::asin_fused`, a rational function without a branch or a call (within 1 ulp
    /// of libm's, tested), so that a loop over lanes vectorises.
    fn arcsine(self) -> Self;
    /// The type's machine epsilon (f64's for the lanes).
    fn epsilon() -> Self;
    /// Comparisons, false where either side is NaN (as `<`, `<=`, `>`, `==`).
    fn lt(self, other: Self) -> Self::Mask;
    fn le(self, other: Self) -> Self::Mask;
    fn gt(self, other: Self) -> Self::Mask;
    fn eq(self, other: Self) -> Self::Mask;
    /// Neither NaN nor infinite.
    fn finite(self) -> Self::Mask;
    /// `a` where `m` holds, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// Whether `m` holds in some lane: a branch taken by all lanes together, for work that
    /// only rare lanes need.
    fn any(m: Self::Mask) -> bool;
}

/// `v` limited to [lo, hi] (hi wins if lo > hi, as `v.larger(lo).smaller(hi)`), with a NaN
/// `v` staying NaN: `larger`/`smaller` would turn it into a limit and hide it. A NaN limit
/// limits nothing, as with them; every other input gets the same value (the sign of a zero
/// aside, which `larger`/`smaller` leave unspecified).
#[inline(always)]
pub fn clamp<S: Lane>(v: S, lo: S, hi: S) -> S {
    let v = S::select(v.lt(lo), lo, v);
    S::select(v.gt(hi), hi, v)
}

/// `v` limited to ±`limit` ([`clamp`]: a NaN stays NaN).
#[inline(always)]
pub fn saturate<S: Lane>(v: S, limit: S) -> S {
    clamp(v, -limit, limit)
}

/// `[f(0), f(1), …]`: `core::array::from_fn` for the hot loops, as a plain loop that the
/// compiler unrolls into registers (`from_fn`'s drop guard can keep it from inlining).
#[inline(always)]
pub fn fill<S: Lane, const N: usize>(f: impl Fn(usize) -> S) -> [S; N] {
    let mut out = [S::splat(0.0); N];
    for (i, o) in out.iter_mut().enumerate() {
        *o = f(i);
    }
    out
}

impl<T: Real> Lane for T {
    type Mask = bool;

    #[inline(always)]
    fn splat(v: f64) -> Self {
        crate::c(v)
    }

    #[inline(always)]
    fn mask(m: bool) -> bool {
        m
    }

    #[inline(always)]
    fn madd(a: Self, b: Self, c: Self) -> Self {
        a * b + c
    }

    #[inline(always)]
    fn sincos(x: Self) -> (Self, Self) {
        crate::model::math::sin_cos(x)
    }

    #[inline(always)]
    fn magnitude(self) -> Self {
        nalgebra::ComplexField::abs(self)
    }

    #[inline(always)]
    fn larger(self, other: Self) -> Self {
        nalgebra::RealField::max(self, other)
    }

    #[inline(always)]
    fn smaller(self, other: Self) -> Self {
        nalgebra::RealField::min(self, other)
    }

    #[inline(always)]
    fn floor(self) -> Self {
        nalgebra::ComplexField::floor(self)
    }

    #[inline(always)]
    fn exponential(self) -> Self {
        nalgebra::ComplexField::exp(self)
    }

    #[inline(always)]
    fn hyperbolic_tangent(self) -> Self {
        nalgebra::ComplexField::tanh(self)
    }

    #[inline(always)]
    fn square_root(self) -> Self {
        nalgebra::ComplexField::sqrt(self)
    }

    #[inline(always)]
    fn arctangent_over(self, x: Self) -> Self {
        nalgebra::RealField::atan2(self, x)
    }

    #[inline(always)]
    fn arcsine(self) -> Self {
        nalgebra::ComplexField::asin(self)
    }

    #[inline(always)]
    fn epsilon() -> Self {
        T::default_epsilon()
    }

    #[inline(always)]
    fn lt(self, other: Self) -> bool {
        self < other
    }

    #[inline(always)]
    fn le(self, other: Self) -> bool {
        self <= other
    }

    #[inline(always)]
    fn gt(self, other: Self) -> bool {
        self > other
    }

    #[inline(always)]
    fn eq(self, other: Self) -> bool {
        self == other
    }

    #[inline(always)]
    fn finite(self) -> bool {
        nalgebra::ComplexField::is_finite(&self)
    }

    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m {
            a
        } else {
            b
        }
    }

    #[inline(always)]
    fn any(m: bool) -> bool {
        m
    }
}

#[cfg(feature = "std")]
pub use wide::{Fused, Wide, WideMask, WIDTH};

/// The sweep's vector of lanes (std: `mul_add` needs it).
#[cfg(feature = "std")]
mod wide {
    use super::*;

    /// Lanes in one [`Wide`] unless said otherwise: 8 f64 = one AVX-512 register, two AVX2
    /// ones. The width changes no lane's numbers, only how many share an instruction.
    pub const WIDTH: usize = 8;

    /// `N` robots' values of one quantity. Every operation is a loop over the lanes
    /// that the compiler turns into vector instructions.
    #[derive(Clone, Copy, Debug, PartialEq)]
    #[repr(C, align(64))]
    pub struct Wide<const N: usize = WIDTH>(pub [f64; N]);

    /// One comparison's outcome per lane: all ones where it holds (as a vector compare's).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    #[repr(C, align(64))]
    pub struct WideMask<const N: usize = WIDTH>(pub [u64; N]);

    #[inline(always)]
    fn each<T: Copy + Default, R: Copy + Default, const N: usize>(a: [T; N], f: impl Fn(T) -> R) -> [R; N] {
        let mut out = [R::default(); N];
        for i in 0..N {
            out[i] = f(a[i]);
        }
        out
    }

    #[inline(always)]
    fn pair<T: Copy + Default, R: Copy + Default, const N: usize>(a: [T; N], b: [T; N], f: impl Fn(T, T) -> R) -> [R; N] {
        let mut out = [R::default(); N];
        for i in 0..N {
            out[i] = f(a[i], b[i]);
        }
        out
    }

    #[inline(always)]
    fn bits(m: bool) -> u64 {
        (m as u64).wrapping_neg()
    }

    macro_rules! wide_op {
        ($trait:ident, $method:ident, $op:tt) => {
            impl<const N: usize> $trait for Wide<N> {
                type Output = Wide<N>;
                #[inline(always)]
                fn $method(self, other: Wide<N>) -> Wide<N> {
                    Wide(pair(self.0, other.0, |a, b| a $op b))
                }
            }
        };
    }
    wide_op!(Add, add, +);
    wide_op!(Sub, sub, -);
    wide_op!(Mul, mul, *);
    wide_op!(Div, div, /);

    impl<const N: usize> Neg for Wide<N> {
        type Output = Wide<N>;
        #[inline(always)]
        fn neg(self) -> Wide<N> {
            Wide(each(self.0, |a| -a))
        }
    }

    macro_rules! mask_op {
        ($trait:ident, $method:ident, $op:tt) => {
            impl<const N: usize> $trait for WideMask<N> {
                type Output = WideMask<N>;
                #[inline(always)]
                fn $method(self, other: WideMask<N>) -> WideMask<N> {
                    WideMask(pair(self.0, other.0, |a, b| a $op b))
                }
            }
        };
    }
    mask_op!(BitAnd, bitand, &);
    mask_op!(BitOr, bitor, |);

    impl<const N: usize> Not for WideMask<N> {
        type Output = WideMask<N>;
        #[inline(always)]
        fn not(self) -> WideMask<N> {
            WideMask(each(self.0, |a| !a))
        }
    }

    /// One lane as a plain `f64` whose multiply-adds are fused: [`Wide`]'s arithmetic
    /// lane by lane, bit for bit, for loops over lanes that the compiler vectorises
    /// itself (the plant's RK4, whose every step is one loop body).
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    #[repr(transparent)]
    pub struct Fused(pub f64);

    macro_rules! fused_op {
        ($trait:ident, $method:ident, $op:tt) => {
            impl $trait for Fused {
                type Output = Fused;
                #[inline(always)]
                fn $method(self, other: Fused) -> Fused {
                    Fused(self.0 $op other.0)
                }
            }
        };
    }
    fused_op!(Add, add, +);
    fused_op!(Sub, sub, -);
    fused_op!(Mul, mul, *);
    fused_op!(Div, div, /);

    impl Neg for Fused {
        type Output = Fused;
        #[inline(always)]
        fn neg(self) -> Fused {
            Fused(-self.0)
        }
    }

    impl Lane for Fused {
        type Mask = bool;

        #[inline(always)]
        fn splat(v: f64) -> Self {
            Fused(v)
        }

        #[inline(always)]
        fn mask(m: bool) -> bool {
            m
        }

        #[inline(always)]
        fn madd(a: Self, b: Self, c: Self) -> Self {
            Fused(a.0.mul_add(b.0, c.0))
        }

        #[inline(always)]
        fn sincos(x: Self) -> (Self, Self) {
            let (s, c) = crate::model::math::sin_cos_fused(x.0);
            (Fused(s), Fused(c))
        }

        #[inline(always)]
        fn magnitude(self) -> Self {
            Fused(self.0.abs())
        }

        #[inline(always)]
        fn larger(self, other: Self) -> Self {
            Fused(self.0.max(other.0))
        }

        #[inline(always)]
        fn smaller(self, other: Self) -> Self {
            Fused(self.0.min(other.0))
        }

        #[inline(always)]
        fn floor(self) -> Self {
            Fused(self.0.floor())
        }

        #[inline(always)]
        fn exponential(self) -> Self {
            Fused(crate::model::math::exp_fused(self.0))
        }

        #[inline(always)]
        fn decay(self) -> Self {
            Fused(crate::model::math::decay_fused(self.0))
        }

        #[inline(always)]
        fn hyperbolic_tangent(self) -> Self {
            Fused(crate::model::math::tanh_fused(self.0))
        }

        #[inline(always)]
        fn square_root(self) -> Self {
            Fused(self.0.sqrt())
        }

        #[inline(always)]
        fn arctangent_over(self, x: Self) -> Self {
            Fused(crate::model::math::atan_fused(self.0 / x.0))
        }

        #[inline(always)]
        fn arcsine(self) -> Self {
            Fused(crate::model::math::asin_fused(self.0))
        }

        #[inline(always)]
        fn epsilon() -> Self {
            Fused(f64::EPSILON)
        }

        #[inline(always)]
        fn lt(self, other: Self) -> bool {
            self.0 < other.0
        }

        #[inline(always)]
        fn le(self, other: Self) -> bool {
            self.0 <= other.0
        }

        #[inline(always)]
        fn gt(self, other: Self) -> bool {
            self.0 > other.0
        }

        #[inline(always)]
        fn eq(self, other: Self) -> bool {
            self.0 == other.0
        }

        #[inline(always)]
        fn finite(self) -> bool {
            self.0.is_finite()
        }

        #[inline(always)]
        fn select(m: bool, a: Self, b: Self) -> Self {
            if m {
                a
            } else {
                b
            }
        }

        #[inline(always)]
        fn any(m: bool) -> bool {
            m
        }
    }

    impl<const N: usize> Lane for Wide<N> {
        type Mask = WideMask<N>;

        #[inline(always)]
        fn splat(v: f64) -> Self {
            Wide([v; N])
        }

        #[inline(always)]
        fn mask(m: bool) -> WideMask<N> {
            WideMask([bits(m); N])
        }

        #[inline(always)]
        fn madd(a: Self, b: Self, c: Self) -> Self {
            let mut out = [0.0; N];
            for (i, o) in out.iter_mut().enumerate() {
                *o = a.0[i].mul_add(b.0[i], c.0[i]);
            }
            Wide(out)
        }

        #[inline(always)]
        fn sincos(x: Self) -> (Self, Self) {
            crate::model::math::sin_cos_wide(x)
        }

        #[inline(always)]
        fn magnitude(self) -> Self {
            Wide(each(self.0, f64::abs))
        }

        #[inline(always)]
        fn larger(self, other: Self) -> Self {
            Wide(pair(self.0, other.0, f64::max))
        }

        #[inline(always)]
        fn smaller(self, other: Self) -> Self {
            Wide(pair(self.0, other.0, f64::min))
        }

        #[inline(always)]
        fn floor(self) -> Self {
            Wide(each(self.0, f64::floor))
        }

        #[inline(always)]
        fn exponential(self) -> Self {
            crate::model::math::exp_wide(self)
        }

        #[inline(always)]
        fn decay(self) -> Self {
            crate::model::math::decay_wide(self)
        }

        #[inline(always)]
        fn hyperbolic_tangent(self) -> Self {
            Wide(each(self.0, crate::model::math::tanh_fused))
        }

        #[inline(always)]
        fn square_root(self) -> Self {
            Wide(each(self.0, f64::sqrt))
        }

        #[inline(always)]
        fn arctangent_over(self, x: Self) -> Self {
            Wide(pair(self.0, x.0, |y, x| crate::model::math::atan_fused(y / x)))
        }

        #[inline(always)]
        fn arcsine(self) -> Self {
            Wide(each(self.0, crate::model::math::asin_fused))
        }

        #[inline(always)]
        fn epsilon() -> Self {
            Self::splat(f64::EPSILON)
        }

        #[inline(always)]
        fn lt(self, other: Self) -> WideMask<N> {
            WideMask(pair(self.0, other.0, |a, b| bits(a < b)))
        }

        #[inline(always)]
        fn le(self, other: Self) -> WideMask<N> {
            WideMask(pair(self.0, other.0, |a, b| bits(a <= b)))
        }

        #[inline(always)]
        fn gt(self, other: Self) -> WideMask<N> {
            WideMask(pair(self.0, other.0, |a, b| bits(a > b)))
        }

        #[inline(always)]
        fn eq(self, other: Self) -> WideMask<N> {
            WideMask(pair(self.0, other.0, |a, b| bits(a == b)))
        }

        #[inline(always)]
        fn finite(self) -> WideMask<N> {
            WideMask(each(self.0, |a| bits(a.is_finite())))
        }

        #[inline(always)]
        fn select(m: WideMask<N>, a: Self, b: Self) -> Self {
            let mut out = [0.0; N];
            for (i, o) in out.iter_mut().enumerate() {
                *o = if m.0[i] != 0 { a.0[i] } else { b.0[i] };
            }
            Wide(out)
        }

        #[inline(always)]
        fn any(m: WideMask<N>) -> bool {
            m.0.iter().fold(0, |acc, b| acc | b) != 0
        }
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;

    /// `clamp` gives what `larger(lo).smaller(hi)` gives, except that a NaN stays NaN, in a
    /// run's numbers and in both lane types.
    #[test]
    fn clamp_is_larger_then_smaller_but_keeps_a_nan() {
        let values = [-3.0, -1.0, -0.5, 0.0, 0.5, 1.0, 3.0, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
        let limits = [(-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0), (f64::NAN, 1.0), (-1.0, f64::NAN), (0.5, 2.0)];
        for &(lo, hi) in &limits {
            for &v in &values {
                let want = v.max(lo).min(hi);
                let want = if v.is_nan() { f64::NAN } else { want };
                let same = |got: f64| got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan());
                assert!(same(clamp(v, lo, hi)), "{v} in [{lo}, {hi}]: {} vs {want}", clamp(v, lo, hi));
                assert!(same(clamp(v as f32, lo as f32, hi as f32) as f64), "f32 {v} in [{lo}, {hi}]");
                assert!(same(clamp(Fused(v), Fused(lo), Fused(hi)).0), "Fused {v} in [{lo}, {hi}]");
                let wide = clamp(Wide::<WIDTH>::splat(v), Wide::splat(lo), Wide::splat(hi));
                assert!(wide.0.iter().all(|&w| same(w)), "Wide {v} in [{lo}, {hi}]");
            }
        }
    }
}
