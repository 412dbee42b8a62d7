//! sin/cos as a polynomial: faster than libm's call, and one polynomial for a run and
//! for a sweep's lanes (`Lane::sincos`: plain multiply-adds in a run, so that it needs no
//! FMA unit or libm call; fused in lanes).
//!
//! Reduction by π/2 (rounding to nearest even): Cody–Waite's three parts in a run, two
//! parts and one fused multiply-add in lanes, whose quadrant logic is bit masks (no
//! branch stops the vectorisation). Then Taylor polynomials on |r| ≤ π/4. Accurate to
//! a few ulp in f64 for |x| < 1e5; a run takes libm's beyond (`REDUCTION_LIMIT`).
use crate::model::lane::Lane;
use crate::{c, Real};

// π/2 split in three parts (Cody–Waite), written to more digits than f64 holds.
#[allow(clippy::excessive_precision)]
pub(crate) const PIO2_1: f64 = 1.570_796_326_734_125_614_17;
#[allow(clippy::excessive_precision)]
pub(crate) const PIO2_2: f64 = 6.077_100_506_303_965_976_6e-11;
#[allow(clippy::excessive_precision)]
pub(crate) const PIO2_3: f64 = 2.022_266_248_795_950_732_4e-21;

/// sin coefficients r^3 … r^15, cos coefficients r^2 … r^16 (Taylor).
pub(crate) const SIN: [f64; 7] = [
    -1.0 / 6.0,
    1.0 / 120.0,
    -1.0 / 5040.0,
    1.0 / 362_880.0,
    -1.0 / 39_916_800.0,
    1.0 / 6_227_020_800.0,
    -1.0 / 1_307_674_368_000.0,
];
pub(crate) const COS: [f64; 8] = [
    -0.5,
    1.0 / 24.0,
    -1.0 / 720.0,
    1.0 / 40_320.0,
    -1.0 / 3_628_800.0,
    1.0 / 479_001_600.0,
    -1.0 / 87_178_291_200.0,
    1.0 / 20_922_789_888_000.0,
];

/// Beyond this angle [rad] a run's sin/cos is the library's: the three-part reduction
/// holds a few ulp below it, and loses the angle far above (at 1e20 the 2-DOF mass
/// matrix's M12 read −9.5e27). A sweep's lanes keep the polynomial: their robots fall
/// long before.
const REDUCTION_LIMIT: f64 = 1e5;

/// (sin x, cos x).
#[inline(always)]
pub fn sin_cos<T: Real>(x: T) -> (T, T) {
    if x.abs() > c(REDUCTION_LIMIT) {
        return x.sin_cos();
    }
    // Adding and removing 1.5/ε rounds to the nearest integer (ties to even).
    let magic = c::<T>(1.5) / T::default_epsilon();
    let k = (x * T::frac_2_pi() + magic) - magic;
    let quadrant = (crate::to_f64(k) as i64) & 3;
    let r = ((x - k * c::<T>(PIO2_1)) - k * c::<T>(PIO2_2)) - k * c::<T>(PIO2_3);
    let (s, co) = kernel(r);
    rotate(s, co, quadrant)
}

/// The lanes' sin/cos (`Wide::sincos`): the reduction by π/2 in two parts and one fused
/// multiply-add, the polynomial fused, the quadrant's swap and signs applied with bit
/// masks: no branch, so every step is a vector instruction. Sweeps only (std: `mul_add`).
#[cfg(feature = "std")]
mod wide {
    use super::kernel;
    use crate::model::lane::{Fused, Lane, Wide};

    // The reduction, the polynomial and the rotation, per lane: one source for both.

    /// 1.5 · 2^52: adding and subtracting it rounds to the nearest integer (|y| < 2^51),
    /// and leaves that integer in the low bits of the sum.
    const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;

    /// π/2 = PIO2_HI + PIO2_LO + O(1e-33): the nearest f64, and the nearest to the rest.
    const PIO2_HI: f64 = core::f64::consts::FRAC_PI_2;
    const PIO2_LO: f64 = 6.123_233_995_736_766e-17;

    /// Up to this |x|, [`reduce`] takes k = 0 (|x| · 2/π < 0.5), so r = x exactly and the
    /// quadrant is 0: [`kernel`] alone gives the same bits (π/4 = 0.785…). A pitch stays
    /// there but near a fall.
    pub(crate) const UNREDUCED: f64 = 0.78;

    #[inline(always)]
    pub(crate) fn sin_cos_wide<const N: usize>(x: Wide<N>) -> (Wide<N>, Wide<N>) {
        // One branch for all N lanes (explicit vectors): the reduction's chain of three
        // multiply-adds and the quadrant's masks skipped where no lane needs them.
        let mut near = true;
        for v in x.0 {
            near &= v.abs() <= UNREDUCED;
        }
        if near {
            return kernel(x);
        }
        let (mut r, mut quadrant) = ([0.0; N], [0u64; N]);
        for i in 0..N {
            (r[i], quadrant[i]) = reduce(x.0[i]);
        }
        let (s, c) = kernel(Wide(r));
        let (mut sin, mut cos) = ([0.0; N], [0.0; N]);
        for i in 0..N {
            (sin[i], cos[i]) = rotate(s.0[i], c.0[i], quadrant[i]);
        }
        (Wide(sin), Wide(cos))
    }

    /// The same for one lane's value inside a loop over lanes (`Fused::sincos`).
    #[inline(always)]
    pub(crate) fn sin_cos_fused(x: f64) -> (f64, f64) {
        let (r, quadrant) = reduce(x);
        let (s, c) = kernel(Fused(r));
        rotate(s.0, c.0, quadrant)
    }

    /// [`sin_cos_fused`] by [`super::kernel_from`], its polynomials' terms read as `coef(i)`.
    #[inline(always)]
    pub(crate) fn sin_cos_fused_from(x: f64, coef: impl Fn(usize) -> f64) -> (f64, f64) {
        let (r, quadrant) = reduce(x);
        let (s, c) = super::kernel_from(Fused(r), |i| Fused(coef(i)));
        rotate(s.0, c.0, quadrant)
    }

    /// [`sin_cos_fused_from`] for |x| ≤ [`UNREDUCED`] (which the caller checks): the same bits,
    /// without the reduction or the rotation, for a loop over lanes that cannot branch.
    #[inline(always)]
    pub(crate) fn sin_cos_unreduced_from(x: f64, coef: impl Fn(usize) -> f64) -> (f64, f64) {
        let (s, c) = super::kernel_from(Fused(x), |i| Fused(coef(i)));
        (s.0, c.0)
    }

    /// x − k π/2 for the nearest integer k, and k's low bits. In two parts: a fused
    /// multiply-add rounds x − k·PIO2_HI once, so the third part that plain arithmetic
    /// needs (math::PIO2_3) is not.
    #[inline(always)]
    fn reduce(x: f64) -> (f64, u64) {
        let shifted = x.mul_add(core::f64::consts::FRAC_2_PI, ROUND_MAGIC);
        let k = shifted - ROUND_MAGIC;
        ((-k).mul_add(PIO2_LO, (-k).mul_add(PIO2_HI, x)), shifted.to_bits())
    }

    /// ln 2 = LN2_HI + LN2_LO + O(1e-33), as PIO2_HI/PIO2_LO for π/2.
    const LN2_HI: f64 = core::f64::consts::LN_2;
    const LN2_LO: f64 = 2.319_046_813_846_299_6e-17;

    /// e^x for one lane, without a branch or a call, so that a loop over lanes
    /// vectorises: x = k ln 2 + r with |r| ≤ ln 2 / 2 (reduced as `reduce`), the Taylor
    /// polynomial of degree 13 in r (its remainder < 5e-18 relative; [`exp_poly_short`]),
    /// times 2^k set in the exponent bits. Within 2 ulp of libm's `exp` (tested); 0 below
    /// −708 (no subnormal results), +inf above ln f64::MAX, NaN for NaN.
    #[inline(always)]
    pub(crate) fn exp_fused(x: f64) -> f64 {
        let (r, shifted) = exp_reduce(x);
        exp_edges(Fused(x), Fused(exp_scale(exp_poly_short(Fused(r)).0, shifted))).0
    }

    /// `exp_fused` for x ≤ 0 or NaN (a decay): the same bits for x ≥ −707, within 2 ulp of
    /// libm's below (tested). e^x cannot overflow there, so the reduction clamps only below,
    /// 2^k is one product and the edge below −708 the only select (a NaN stays NaN through the
    /// arithmetic): fewer operations where e^x sits on a chain (the Stribeck hump of the
    /// stick law's RK4 stages: the thesis-like rig 1.07x on the `avx2` copy, an AVX2-only
    /// EPYC, `benches/pair_builds.py`; docs/performance.md).
    #[inline(always)]
    pub(crate) fn decay_fused(x: f64) -> f64 {
        let (r, shifted) = decay_reduce(x);
        decay_edge(Fused(x), Fused(exp_poly_short(Fused(r)).0 * power_of_two(shifted, 0))).0
    }

    /// e^x on `N` lanes: `exp_fused`'s stages, each a loop over the lanes or `Wide`'s
    /// own operations, so that each is vector instructions (one loop over the whole of
    /// `exp_fused` was not vectorised: a scalar copy per lane). The polynomial is summed
    /// in Horner's order ([`exp_poly`]), so a lane may differ from `exp_fused` by an ulp;
    /// both are within 2 ulp of libm's (tested).
    #[inline(always)]
    pub(crate) fn exp_wide<const N: usize>(x: Wide<N>) -> Wide<N> {
        exp_edges(x, scaled_poly::<false, N>(x))
    }

    /// `exp_wide` for x ≤ 0 or NaN, as `decay_fused` is `exp_fused` (the same bits for
    /// x ≥ −707): fewer operations for the fuzzy law's Gaussian sets.
    #[inline(always)]
    pub(crate) fn decay_wide<const N: usize>(x: Wide<N>) -> Wide<N> {
        decay_edge(x, scaled_poly::<true, N>(x))
    }

    /// e^x on `N` lanes before its edges, of any x or (`DECAY`) of x ≤ 0 (a constant, not
    /// functions passed in, so that nothing here waits on the compiler inlining a call).
    #[inline(always)]
    fn scaled_poly<const DECAY: bool, const N: usize>(x: Wide<N>) -> Wide<N> {
        let (mut r, mut shifted) = ([0.0; N], [0.0; N]);
        for i in 0..N {
            (r[i], shifted[i]) = if DECAY { decay_reduce(x.0[i]) } else { exp_reduce(x.0[i]) };
        }
        let p = exp_poly(Wide(r));
        let mut scaled = [0.0; N];
        for i in 0..N {
            scaled[i] = if DECAY { p.0[i] * power_of_two(shifted[i], 0) } else { exp_scale(p.0[i], shifted[i]) };
        }
        Wide(scaled)
    }

    /// e^x's reduction: r = x − k ln 2 for the nearest integer k, and x log2 e + 1.5 · 2^52,
    /// whose low bits hold k (x clamped to where e^x is a normal number or just overflows).
    #[inline(always)]
    fn exp_reduce(x: f64) -> (f64, f64) {
        reduce_clamped(x.clamp(-708.0, 709.79))
    }

    /// [`exp_reduce`] of x ≤ 0 or NaN: clamped below only (a NaN stays NaN).
    #[inline(always)]
    fn decay_reduce(x: f64) -> (f64, f64) {
        reduce_clamped(if x < -708.0 { -708.0 } else { x })
    }

    /// [`exp_reduce`] once x is clamped.
    #[inline(always)]
    fn reduce_clamped(clamped: f64) -> (f64, f64) {
        let shifted = clamped.mul_add(core::f64::consts::LOG2_E, ROUND_MAGIC);
        let k = shifted - ROUND_MAGIC;
        ((-k).mul_add(LN2_LO, (-k).mul_add(LN2_HI, clamped)), shifted)
    }

    /// 1/n! for n = 0 … 17: the Taylor coefficients of e^x (the first 14) and of
    /// (e^x − 1)/x (from the second).
    const INV_FACT: [f64; 18] = [
        1.0, 1.0, 0.5, 1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0, 1.0 / 720.0, 1.0 / 5_040.0, 1.0 / 40_320.0,
        1.0 / 362_880.0, 1.0 / 3_628_800.0, 1.0 / 39_916_800.0, 1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0, 1.0 / 87_178_291_200.0, 1.0 / 1_307_674_368_000.0,
        1.0 / 20_922_789_888_000.0, 1.0 / 355_687_428_096_000.0,
    ];

    /// Σ c_i r^i for the coefficients `c` (lowest power first) by Horner's rule, fused.
    #[inline(always)]
    fn horner<S: Lane>(c: &[f64], r: S) -> S {
        let (last, rest) = c.split_last().expect("a coefficient");
        let mut p = S::splat(*last);
        for c in rest.iter().rev() {
            p = S::madd(p, r, S::splat(*c));
        }
        p
    }

    /// e^r for |r| ≤ ln 2 / 2: the Taylor polynomial of degree 13 by Horner's rule, for
    /// `Wide` numbers (the fuzzy law's Gaussian sets). There the law's many independent
    /// operations keep the vector units busy, and fewer operations are faster: by
    /// [`exp_poly_short`], the Gaussian law took 1.24x the time.
    #[inline(always)]
    fn exp_poly<S: Lane>(r: S) -> S {
        horner(&INV_FACT[..14], r)
    }

    /// The same polynomial as 1 + r (1 + r Q(r)), Q's twelve terms by [`super::estrin`] (the last
    /// two steps as Horner's keep the rounding of the terms that matter most), for a lane
    /// in a loop over lanes (`Fused`): there e^x sits on the chain each RK4 stage of the
    /// rig's stick law waits on, and the chain's length bounds the speed (`sweep_throughput
    /// realism-lanes`, paired against Horner's: 0.92x the time).
    #[inline(always)]
    fn exp_poly_short<S: Lane>(r: S) -> S {
        let q = super::estrin(&INV_FACT[2..14], r);
        S::madd(r, S::madd(r, q, S::splat(1.0)), S::splat(1.0))
    }

    /// p · 2^k for the polynomial `p` = e^r and k in `shifted`'s low bits.
    #[inline(always)]
    fn exp_scale(p: f64, shifted: f64) -> f64 {
        // k in [-1021, 1024]. 2^k as 2^(k−1) · 2, so that k = 1024 (x near ln of the largest
        // f64) overflows only if e^x does.
        (p * power_of_two(shifted, -1)) * 2.0
    }

    /// 2^(k + `offset`) for k in `shifted`'s low bits, a normal number for k + offset in
    /// [−1022, 1023].
    #[inline(always)]
    fn power_of_two(shifted: f64, offset: i64) -> f64 {
        let k_int = shifted.to_bits().wrapping_sub(ROUND_MAGIC.to_bits()) as i64;
        f64::from_bits(((k_int + offset + 1023) as u64) << 52)
    }

    /// e^x's edges as selects (branches per lane kept a loop over lanes scalar): 0 below
    /// −708, +inf above 709.79, NaN for NaN, else `y`.
    #[inline(always)]
    fn exp_edges<S: Lane>(x: S, y: S) -> S {
        let nan = !x.eq(x);
        decay_edge(x, S::select(x.gt(S::splat(709.79)), S::splat(f64::INFINITY), S::select(nan, x, y)))
    }

    /// The edge below: 0 below −708, else `y`.
    #[inline(always)]
    fn decay_edge<S: Lane>(x: S, y: S) -> S {
        S::select(x.lt(S::splat(-708.0)), S::splat(0.0), y)
    }

    /// Below this |x|, tanh takes e^(−2|x|) − 1 from its Taylor polynomial; above, from
    /// `decay_fused`, where 1 − e^(−2|x|) ≥ 0.5 loses no precision to cancellation.
    const TANH_SMALL: f64 = 0.35;

    /// tanh x for one lane, without a branch or a call, so that a loop over lanes
    /// vectorises (libm's `tanh` is a call per lane): tanh |x| = −m / (2 + m) with
    /// m = e^(−2|x|) − 1, from the Taylor polynomial of degree 17 for |x| ≤ 0.35 (its
    /// remainder < 2e-17 relative), else from `decay_fused`; the sign of x put back. Within
    /// 3 ulp of libm's `tanh` (tested); ±1 for |x| ≥ 354 and ±∞, NaN for NaN, ±0 for ±0.
    #[inline(always)]
    pub(crate) fn tanh_fused(x: f64) -> f64 {
        let a = x.abs();
        let y = -2.0 * a;
        // m = y · Σ y^n/(n + 1)! for n = 0 … 16, as y (1 + y (1/2 + y Q(y))) with Q's
        // fifteen terms by `estrin`.
        let q = super::estrin(&INV_FACT[3..], Fused(y)).0;
        let m = y.mul_add(y.mul_add(q, 0.5), 1.0) * y;
        let small = -m / (2.0 + m);
        let e = decay_fused(y);
        let large = (1.0 - e) / (1.0 + e);
        let magnitude = if a <= TANH_SMALL { small } else { large };
        magnitude.copysign(x)
    }

    /// atan's reduction points c = atan⁻¹ of 0.5, 1, 1.5 and ∞ (fdlibm's `s_atan.c`): the
    /// nearest f64 (HI) and the nearest to the rest (LO).
    #[allow(clippy::excessive_precision)]
    const ATAN_HI: [f64; 4] = [4.636_476_090_008_060_935_15e-01, core::f64::consts::FRAC_PI_4, 9.827_937_232_473_290_540_82e-01, core::f64::consts::FRAC_PI_2];
    #[allow(clippy::excessive_precision)]
    const ATAN_LO: [f64; 4] = [2.269_877_745_296_168_709_24e-17, 3.061_616_997_868_383_017_93e-17, 1.390_331_103_123_099_845_16e-17, 6.123_233_995_736_766_035_87e-17];
    /// fdlibm's odd polynomial for atan on |r| ≤ 7/16: atan r = r − r (s₁ + s₂).
    #[allow(clippy::excessive_precision)]
    const ATAN_T: [f64; 11] = [
        3.333_333_333_333_293_180_27e-01,
        -1.999_999_999_987_648_324_76e-01,
        1.428_571_427_250_346_637_11e-01,
        -1.111_111_040_546_235_578_80e-01,
        9.090_887_133_436_506_561_96e-02,
        -7.691_876_205_044_829_994_95e-02,
        6.661_073_137_387_531_206_69e-02,
        -5.833_570_133_790_573_486_45e-02,
        4.976_877_994_615_932_360_17e-02,
        -3.653_157_274_421_691_552_70e-02,
        1.628_582_011_536_578_236_23e-02,
    ];

    /// atan x for one lane, without a branch or a call, so that a loop over lanes vectorises
    /// (libm's `atan` is a call per lane): fdlibm's algorithm with its four reductions
    /// (|x| past 7/16, 11/16, 19/16 and 39/16: atan |x| = c + atan((|x| − tan c)/(1 + |x| tan c)),
    /// the last −1/|x| from π/2) picked by selects, its polynomial fused. Within 2 ulp of
    /// libm's (tested); ±π/2 at ±∞, NaN for NaN, ±0 for ±0.
    #[inline(always)]
    pub(crate) fn atan_fused(x: f64) -> f64 {
        let a = x.abs();
        let (reduced, past_39, past_19, past_11) = (a >= 0.4375, a >= 2.4375, a >= 1.1875, a >= 0.6875);
        let id = if past_39 { 3 } else if past_19 { 2 } else if past_11 { 1 } else { 0 };
        let t = if past_19 { 1.5 } else if past_11 { 1.0 } else { 0.5 };
        let quotient = if past_39 { -1.0 / a } else { (a - t) / t.mul_add(a, 1.0) };
        let r = if reduced { quotient } else { a };
        let (hi, lo) = if reduced { (ATAN_HI[id], ATAN_LO[id]) } else { (0.0, 0.0) };
        let z = r * r;
        let w = z * z;
        let even = |k: usize| ATAN_T[k];
        let s1 = z * w.mul_add(w.mul_add(w.mul_add(w.mul_add(w.mul_add(even(10), even(8)), even(6)), even(4)), even(2)), even(0));
        let s2 = w * w.mul_add(w.mul_add(w.mul_add(w.mul_add(even(9), even(7)), even(5)), even(3)), even(1));
        // Unreduced: hi = lo = 0 gives r − r (s₁ + s₂).
        (hi - (r.mul_add(s1 + s2, -lo) - r)).copysign(x)
    }

    /// asin's constants (fdlibm's `e_asin.c`): π/2 and π/4 as the nearest f64 (HI) and π/2's
    /// rest (LO); the rational function R(t) = t P(t) / Q(t) whose asin x = x + x R(x²) on
    /// |x| < 1/2, P's coefficients lowest power first, Q's after its leading 1.
    #[allow(clippy::excessive_precision)]
    const ASIN_PIO2: (f64, f64) = (core::f64::consts::FRAC_PI_2, 6.123_233_995_736_766_035_87e-17);
    const ASIN_PIO4_HI: f64 = core::f64::consts::FRAC_PI_4;
    #[allow(clippy::excessive_precision)]
    const ASIN_P: [f64; 6] = [
        1.666_666_666_666_666_574_15e-01,
        -3.255_658_186_224_009_154_05e-01,
        2.012_125_321_348_629_258_81e-01,
        -4.005_553_450_067_941_140_27e-02,
        7.915_349_942_898_145_321_76e-04,
        3.479_331_075_960_211_675_70e-05,
    ];
    #[allow(clippy::excessive_precision)]
    const ASIN_Q: [f64; 4] = [-2.403_394_911_734_414_218_78e+00, 2.020_945_760_233_505_694_71e+00, -6.882_839_716_054_532_930_30e-01, 7.703_815_055_590_193_527_91e-02];

    /// asin x for one lane, without a branch or a call, so that a loop over lanes vectorises
    /// (libm's `asin` is a call per lane): fdlibm's three ranges picked by selects, its
    /// rational function fused. |x| < 1/2: x + x R(x²); past it, with t = (1 − |x|)/2 and
    /// asin |x| = π/2 − 2 asin √t, from √t's value (|x| ≥ 0.975) or, nearer 1/2, from √t
    /// split in a high part and the rest (one rounding less in 2√t). Within 1 ulp of libm's
    /// (tested); NaN past ±1 and for NaN, ±0 for ±0.
    #[inline(always)]
    pub(crate) fn asin_fused(x: f64) -> f64 {
        let a = x.abs();
        let (small, steep) = (a < 0.5, a.to_bits() >= 0x3FEF_3333_0000_0000);
        let t = if small { a * a } else { (1.0 - a) * 0.5 };
        let p = t * t.mul_add(t.mul_add(t.mul_add(t.mul_add(t.mul_add(ASIN_P[5], ASIN_P[4]), ASIN_P[3]), ASIN_P[2]), ASIN_P[1]), ASIN_P[0]);
        let q = t.mul_add(t.mul_add(t.mul_add(t.mul_add(ASIN_Q[3], ASIN_Q[2]), ASIN_Q[1]), ASIN_Q[0]), 1.0);
        let r = p / q;
        let near = r.mul_add(a, a);
        let s = t.sqrt();
        let (pio2_hi, pio2_lo) = ASIN_PIO2;
        let far = pio2_hi - (2.0 * s.mul_add(r, s) - pio2_lo);
        // √t = hi + c, hi its upper 21 bits (hi² exact).
        let hi = f64::from_bits(s.to_bits() & 0xFFFF_FFFF_0000_0000);
        let c = (-hi).mul_add(hi, t) / (s + hi);
        let mid = ASIN_PIO4_HI - ((2.0 * s).mul_add(r, -(2.0f64.mul_add(-c, pio2_lo))) - (ASIN_PIO4_HI - 2.0 * hi));
        let magnitude = if small { near } else if steep { far } else { mid };
        magnitude.copysign(x)
    }

    /// (sin, cos) of r + quadrant · π/2: odd quadrants swap sin and cos; quadrants 2, 3
    /// negate sin; 1, 2 negate cos. Bit masks, no branch.
    #[inline(always)]
    fn rotate(s: f64, c: f64, quadrant: u64) -> (f64, f64) {
        let (s, c) = (s.to_bits(), c.to_bits());
        let swap = (quadrant & 1).wrapping_neg();
        let sin_r = (s & !swap) | (c & swap);
        let cos_r = (c & !swap) | (s & swap);
        (f64::from_bits(sin_r ^ ((quadrant & 2) << 62)), f64::from_bits(cos_r ^ ((quadrant.wrapping_add(1) & 2) << 62)))
    }
}
#[cfg(feature = "std")]
pub(crate) use wide::{asin_fused, atan_fused, decay_fused, decay_wide, exp_fused, exp_wide, sin_cos_fused, sin_cos_fused_from, sin_cos_unreduced_from, sin_cos_wide, tanh_fused, UNREDUCED};

/// sin and cos of |r| ≤ π/4: the polynomials in r² by [`estrin`].
#[inline(always)]
pub(crate) fn kernel<S: Lane>(r: S) -> (S, S) {
    let r2 = r * r;
    (S::madd(r * r2, estrin(&SIN, r2), r), S::madd(r2, estrin(&COS, r2), S::splat(1.0)))
}

/// [`SIN`]'s coefficients, then [`COS`]'s, in one array: the terms a sweep's 2-DOF plants read
/// as lanes (`sweep::block::Plants`), for [`kernel_from`].
#[cfg_attr(not(feature = "std"), allow(dead_code))] // the sweeps' lanes use it
pub(crate) const SIN_COS: [f64; SIN.len() + COS.len()] = {
    let mut all = [0.0; SIN.len() + COS.len()];
    let mut i = 0;
    while i < all.len() {
        all[i] = if i < SIN.len() { SIN[i] } else { COS[i - SIN.len()] };
        i += 1;
    }
    all
};

/// [`kernel`]'s polynomials with [`SIN_COS`]'s term `i` read as `coef(i)`, each by Horner's
/// rule of the second order ([`horner2`]), for a loop over lanes that reads the terms from an
/// array of lanes. There each term is one multiply-add's memory operand; by Estrin's pairs (two
/// terms to each multiply-add) one of two needs a register, and terms given as constants are a
/// broadcast each where AVX-512's embedded broadcast is missing. On the `avx2` copy (an AVX2-only
/// EPYC, callgrind) sin/cos was 28 % of the LQR lanes' instructions, 15 of its 134 a sample-step
/// broadcasts; by this kernel the lanes run 131, at 1.07-1.09x the speed, and the fuzzy lanes,
/// whose plants these are too, read 0.95-0.98x: not told apart from a layout effect
/// (docs/performance.md).
#[cfg_attr(not(feature = "std"), allow(dead_code))] // the sweeps' lanes use it
#[inline(always)]
pub(crate) fn kernel_from<S: Lane>(r: S, coef: impl Fn(usize) -> S) -> (S, S) {
    let r2 = r * r;
    let sin = horner2(SIN.len(), &coef, r2);
    let cos = horner2(COS.len(), |i| coef(SIN.len() + i), r2);
    (S::madd(r * r2, sin, r), S::madd(r2, cos, S::splat(1.0)))
}

/// Up to this |d|, [`sin_cos_plus`] holds: Taylor's next terms, d⁹/9! and d⁸/8!, are below
/// 3e-18 of sin d and 2.3e-17 (a tenth of an ulp of 1) of cos d.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // the sweeps' lanes use it
pub(crate) const SHIFT_LIMIT: f64 = 1.0 / 32.0;

/// sin and cos of φ + d from (sin φ, cos φ), for |d| ≤ [`SHIFT_LIMIT`]: sin d and cos d − 1
/// by Taylor's first four and three terms ([`SIN`]'s and [`COS`]'s; cos's fourth, d⁸/8!, below
/// a tenth of an ulp here, moved no sweep's bits in paired runs and cost one multiply-add in
/// the stage's chain: the `avx512` LQR lanes ran 1.035x without it on an AVX-512 EPYC, 10
/// pairs), then the sum formulas, the two small terms summed before sin φ or cos φ is added
/// (one rounding at the result's scale).
/// Where (sin φ, cos φ) are libm's, within 2 ulp of libm's sin/cos of φ + d, in ulp of the
/// largest of the result, the value shifted and d (tested): near a zero, as when φ + d is
/// rounded first. An RK4 stage's pitch is the step's first moved by d = k₀ h: 14 operations
/// instead of [`kernel_from`]'s 19, and of the exact φ + d, where the stage's own sin/cos is
/// of φ + d rounded (`scripts/sin_cos_shift_accuracy.py`, against 120-bit sin/cos, φ in ±3,
/// |d| ≤ 1/32: 0.38 ulp on average, against 1.89 for libm's of the rounded sum; 0.45 with the
/// terms added to sin φ one by one). The terms are read as [`kernel_from`]'s: [`SIN_COS`]'s
/// term `i` as `coef(i)`.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // the sweeps' lanes use it
#[inline(always)]
pub(crate) fn sin_cos_plus<S: Lane>((s, c): (S, S), d: S, coef: impl Fn(usize) -> S) -> (S, S) {
    let (sin, cos) = (|i: usize| coef(i), |i: usize| coef(SIN.len() + i));
    let d2 = d * d;
    let sin_d = S::madd(d * d2, S::madd(d2, S::madd(d2, sin(2), sin(1)), sin(0)), d);
    let cos_d_1 = d2 * S::madd(d2, S::madd(d2, cos(2), cos(1)), cos(0));
    (s + S::madd(c, sin_d, s * cos_d_1), c + S::madd(-s, sin_d, c * cos_d_1))
}

/// Σ c(i) z^i for i < n ≥ 2: the even and the odd terms each by Horner's rule in z², joined.
/// Its chain of dependent multiply-adds is about n/2 long, not Horner's n − 1.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // the sweeps' lanes use it
#[inline(always)]
fn horner2<S: Lane>(n: usize, c: impl Fn(usize) -> S, z: S) -> S {
    debug_assert!(n >= 2);
    let z2 = z * z;
    let half = |first: usize| {
        let mut i = first + 2 * ((n - 1 - first) / 2);
        let mut p = c(i);
        while i > first {
            i -= 2;
            p = S::madd(p, z2, c(i));
        }
        p
    };
    S::madd(z, half(1), half(0))
}

/// Σ c_i r^i for the coefficients `c` (lowest power first; at most 16) by Estrin's scheme:
/// pairs c_i + c_(i+1) r, then pairs of those with r², r⁴, r⁸. Its chain of dependent
/// multiply-adds is 4 long, not Horner's n − 1, which is what bounds the speed of one
/// evaluation: of sin/cos, and of the lanes' e^x where an RK4 stage waits on it (the stick
/// law). Written out in functions always inlined (`n` is known where they are): a loop
/// over the terms, or closures, kept a loop over lanes scalar.
#[inline(always)]
pub(crate) fn estrin<S: Lane>(c: &[f64], r: S) -> S {
    debug_assert!((1..=16).contains(&c.len()));
    let r2 = r * r;
    let r4 = r2 * r2;
    if c.len() > 8 {
        S::madd(r4 * r4, estrin_8(c, 8, r, r2, r4), estrin_8(c, 0, r, r2, r4))
    } else {
        estrin_8(c, 0, r, r2, r4)
    }
}

/// The terms i … i + 7 of [`estrin`]'s sum, over r^i.
#[inline(always)]
fn estrin_8<S: Lane>(c: &[f64], i: usize, r: S, r2: S, r4: S) -> S {
    if i + 4 < c.len() {
        S::madd(r4, estrin_4(c, i + 4, r, r2), estrin_4(c, i, r, r2))
    } else {
        estrin_4(c, i, r, r2)
    }
}

/// The terms i … i + 3, over r^i.
#[inline(always)]
fn estrin_4<S: Lane>(c: &[f64], i: usize, r: S, r2: S) -> S {
    if i + 2 < c.len() {
        S::madd(r2, estrin_2(c, i + 2, r), estrin_2(c, i, r))
    } else {
        estrin_2(c, i, r)
    }
}

/// The terms i and i + 1, over r^i.
#[inline(always)]
fn estrin_2<S: Lane>(c: &[f64], i: usize, r: S) -> S {
    if i + 1 < c.len() {
        S::madd(r, S::splat(c[i + 1]), S::splat(c[i]))
    } else {
        S::splat(c[i])
    }
}

/// (sin, cos) of r + quadrant · π/2.
#[inline(always)]
pub(crate) fn rotate<T: Real>(s: T, co: T, quadrant: i64) -> (T, T) {
    let (sin_r, cos_r) = if quadrant & 1 == 1 { (co, s) } else { (s, co) };
    let sin_sign = if quadrant & 2 == 2 { -T::one() } else { T::one() };
    let cos_sign = if (quadrant + 1) & 2 == 2 { -T::one() } else { T::one() };
    (sin_sign * sin_r, cos_sign * cos_r)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[cfg(feature = "std")]
    use crate::model::lane::Fused;

    /// The lanes' e^x is libm's to 2 ulp over the whole normal range, and its edges are
    /// libm's too (0 below the normal range, inf above, NaN for NaN).
    #[cfg(feature = "std")]
    #[test]
    fn lane_exp_is_libms_to_two_ulp() {
        use crate::model::lane::{Wide, WIDTH};
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        // Both sums of the polynomial: one lane (Estrin's) and `WIDTH` at once (Horner's).
        let wide = |x: f64| exp_wide(Wide([x; WIDTH])).0[0];
        let (mut worst, mut worst_wide) = (0, 0);
        let n = 400_000;
        let near_zero = [-1e-300, 0.0, 1e-300, 1e-9, -0.5 * core::f64::consts::LN_2, 0.5 * core::f64::consts::LN_2, 1.0];
        for x in (0..=n).map(|i| -708.0 + (709.78 + 708.0) * i as f64 / n as f64).chain(near_zero) {
            worst = worst.max(ulps(exp_fused(x), x.exp()));
            worst_wide = worst_wide.max(ulps(wide(x), x.exp()));
        }
        assert!(worst <= 2 && worst_wide <= 2, "{worst} ulp one lane, {worst_wide} ulp wide");
        // A `Wide` at once gives each lane's value alone, edges included.
        let xs = [-800.0, -708.0, -1e-300, 0.0, 0.3, 1.0, 709.7, 709.8, f64::NAN, f64::NEG_INFINITY, 42.0, -3.5, 1e-10, -700.0, 700.0, f64::INFINITY];
        for lanes in xs.chunks(WIDTH) {
            let lanes: [f64; WIDTH] = lanes.try_into().unwrap();
            let got = exp_wide(Wide(lanes)).0;
            for (g, x) in got.iter().zip(lanes) {
                assert_eq!(g.to_bits(), wide(x).to_bits(), "{x:e}");
            }
        }
        for exp in [exp_fused, wide] {
            assert_eq!(exp(-800.0), 0.0);
            assert_eq!(exp(f64::NEG_INFINITY), 0.0);
            assert_eq!(exp(710.0), f64::INFINITY);
            assert_eq!(exp(f64::INFINITY), f64::INFINITY);
            assert!(exp(f64::NAN).is_nan());
        }
    }

    /// The lanes' e^x of x ≤ 0 (`decay_fused`, `decay_wide`) is their e^x bit for bit down to
    /// −707, libm's to 2 ulp below, with the same edges.
    #[cfg(feature = "std")]
    #[test]
    fn decay_is_the_lanes_exp_where_its_scale_is_normal() {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        // From −707 up, exp_fused's halved scale 2^(k−1) leaves p · 2^(k−1) a normal number, so
        // its doubling is exact: the same bits as decay's one product.
        use crate::model::lane::{Wide, WIDTH};
        let n = 400_000;
        let (wide, decay) = (|x: f64| exp_wide(Wide([x; WIDTH])).0[0], |x: f64| decay_wide(Wide([x; WIDTH])).0[0]);
        for x in (0..=n).map(|i| -707.0 * i as f64 / n as f64).chain([-0.0, -1e-300, -1e-9, -0.5 * core::f64::consts::LN_2]) {
            assert_eq!(decay_fused(x).to_bits(), exp_fused(x).to_bits(), "x = {x:e}");
            assert_eq!(decay(x).to_bits(), wide(x).to_bits(), "x = {x:e}, wide");
        }
        // Below, where exp_fused's intermediate is subnormal, decay is as close to libm's.
        let (mut worst, mut worst_wide) = (0, 0);
        for x in (0..=1000).map(|i| -708.0 + i as f64 / 1000.0) {
            worst = worst.max(ulps(decay_fused(x), x.exp()));
            worst_wide = worst_wide.max(ulps(decay(x), x.exp()));
        }
        assert!(worst <= 2 && worst_wide <= 2, "{worst} ulp one lane, {worst_wide} ulp wide");
        for e in [decay_fused, decay] {
            assert_eq!(e(-708.5), 0.0);
            assert_eq!(e(f64::NEG_INFINITY), 0.0);
            assert!(e(f64::NAN).is_nan());
        }
    }

    /// The largest distance in ulp of `lane` from libm's `libm` and where, over ±`xs(u)` for
    /// 400,001 u in [0, 1].
    #[cfg(feature = "std")]
    fn worst_ulps(lane: fn(f64) -> f64, libm: fn(f64) -> f64, xs: impl Fn(f64) -> [f64; 3]) -> (u64, f64) {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        let mut worst = (0, 0.0);
        let n = 400_000;
        for i in 0..=n {
            for x in xs(i as f64 / n as f64) {
                for x in [x, -x] {
                    let e = ulps(lane(x), libm(x));
                    if e > worst.0 {
                        worst = (e, x);
                    }
                }
            }
        }
        worst
    }

    /// The lanes' tanh is libm's to 3 ulp, near 0 (where the polynomial holds), across the
    /// switch to e^x, and out to where tanh is ±1; and its edges are libm's.
    #[cfg(feature = "std")]
    #[test]
    fn lane_tanh_is_libms_to_three_ulp() {
        let worst = worst_ulps(tanh_fused, f64::tanh, |u| [-25.0 + 50.0 * u, 0.7 * u, 10f64.powf(-300.0 + 300.0 * u)]);
        assert!(worst.0 <= 3, "{} ulp at {:e}", worst.0, worst.1);
        for x in [0.0, -0.0, 354.0, -400.0, f64::INFINITY, f64::NEG_INFINITY, f64::MIN_POSITIVE, 5e-324] {
            assert_eq!(tanh_fused(x).to_bits(), x.tanh().to_bits(), "{x:e}");
        }
        assert!(tanh_fused(f64::NAN).is_nan());
    }

    /// The lanes' atan is libm's to 2 ulp: densely over ±50 (every reduction and its
    /// edges), out to ±1e300 and down to 1e-300; its edges are libm's.
    #[cfg(feature = "std")]
    #[test]
    fn lane_atan_is_libms_to_two_ulp() {
        let worst = worst_ulps(atan_fused, f64::atan, |u| [-50.0 + 100.0 * u, 3.0 * u, 10f64.powf(-300.0 + 600.0 * u)]);
        assert!(worst.0 <= 2, "{} ulp at {:e}", worst.0, worst.1);
        std::println!("lane atan against libm's: worst {} ulp at {:e}", worst.0, worst.1);
        for x in [0.0, -0.0, 0.4375, 0.6875, 1.1875, 2.4375, f64::INFINITY, f64::NEG_INFINITY, 5e-324] {
            assert_eq!(atan_fused(x).to_bits(), x.atan().to_bits(), "{x:e}");
        }
        assert!(atan_fused(f64::NAN).is_nan());
    }

    /// The lanes' asin is libm's to 1 ulp over [−1, 1]: densely, near ±1/2 and ±0.975 where
    /// its ranges meet, near ±1 and down to 1e-300; its edges are libm's.
    #[cfg(feature = "std")]
    #[test]
    fn lane_asin_is_libms_to_one_ulp() {
        let worst = worst_ulps(asin_fused, f64::asin, |u| [u, 0.45 + 0.1 * u, 0.97 + 0.03 * u]);
        let tiny = worst_ulps(asin_fused, f64::asin, |u| [10f64.powf(-300.0 + 299.0 * u), 1.0 - 10f64.powf(-16.0 + 15.0 * u), 0.975 + 1e-9 * (u - 0.5)]);
        std::println!("lane asin against libm's: worst {} ulp at {:e}; near the edges {} ulp at {:e}", worst.0, worst.1, tiny.0, tiny.1);
        assert!(worst.0 <= 1 && tiny.0 <= 1, "{worst:?} {tiny:?}");
        for x in [0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 5e-324, f64::from_bits(0x3FEF_3333_0000_0000)] {
            assert_eq!(asin_fused(x).to_bits(), x.asin().to_bits(), "{x:e}");
        }
        for x in [1.0 + f64::EPSILON, -2.0, f64::INFINITY, f64::NAN] {
            assert!(asin_fused(x).is_nan(), "{x:e}");
        }
    }

    #[test]
    fn matches_libm_in_f64_and_f32() {
        let n = 100_000;
        let (mut worst64, mut worst32) = (0.0f64, 0.0f32);
        for i in 0..=n {
            let x = -50.0 + 100.0 * i as f64 / n as f64;
            let (s, co) = sin_cos(x);
            worst64 = worst64.max((s - x.sin()).abs()).max((co - x.cos()).abs());
            // f32: the reduction constants are rounded; angles of a robot stay small.
            let xf = (x / 5.0) as f32;
            let (s, co) = sin_cos(xf);
            worst32 = worst32.max((s - xf.sin()).abs()).max((co - xf.cos()).abs());
        }
        assert!(worst64 < 5e-16, "f64 worst {worst64:e}");
        assert!(worst32 < 5e-7, "f32 worst {worst32:e} on |x| <= 10");
        // Far out the library's own, whose reduction is exact.
        for x in [-1e300f64, -3e20, 1e17, 1e5 + 1.0, 7e8] {
            assert_eq!(sin_cos(x), x.sin_cos(), "{x:e}");
        }
        assert_eq!(sin_cos(1e20f32), 1e20f32.sin_cos());
    }

    #[cfg(feature = "std")]
    #[test]
    fn wide_sin_cos_matches_libm() {
        use crate::model::lane::{Lane, Wide};
        let sin_cos_fused = |x: f64| {
            let (s, c) = <Wide>::sincos(<Wide>::splat(x));
            (s.0[3], c.0[3])
        };
        let mut worst: f64 = 0.0;
        let n = 200_000;
        for i in 0..=n {
            let x = -100.0 + 200.0 * i as f64 / n as f64;
            let (s, c) = sin_cos_fused(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(worst < 5e-16, "worst absolute error {worst:e}");
        // Far out, the two-part reduction by π/2 (one fused multiply-add) still holds a few ulp.
        let mut far: f64 = 0.0;
        for i in 0..=n {
            let x = -1e4 + 2e4 * i as f64 / n as f64;
            let (s, c) = sin_cos_fused(x);
            far = far.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(far < 2e-15, "worst absolute error on |x| <= 1e4: {far:e}");
        for x in [0.0, -0.0, 1e-300, core::f64::consts::FRAC_PI_2, core::f64::consts::PI, 3.0e4] {
            let (s, c) = sin_cos_fused(x);
            assert!((s - x.sin()).abs() < 1e-15 && (c - x.cos()).abs() < 1e-15, "x = {x}");
        }
    }

    /// Within ±UNREDUCED the unreduced sin/cos (one lane's, and `Wide`'s branch) give the
    /// reduced one's bits.
    #[cfg(feature = "std")]
    #[test]
    fn unreduced_sin_cos_is_the_same_bits() {
        use crate::model::lane::{Lane, Wide};
        let bits = |(s, c): (f64, f64)| (s.to_bits(), c.to_bits());
        let wide = |x: f64| {
            let (s, c) = <Wide>::sincos(<Wide>::splat(x));
            (s.0[0], c.0[0])
        };
        let n = 400_000;
        let edges = [0.0, -0.0, 1e-300, -1e-300, 5e-324, f64::MIN_POSITIVE, UNREDUCED, -UNREDUCED];
        let grid = (0..=n).map(|i| UNREDUCED * (2.0 * i as f64 / n as f64 - 1.0));
        let table = |i: usize| SIN_COS[i];
        for x in grid.chain(edges) {
            assert_eq!(bits(wide(x)), bits(sin_cos_fused(x)), "x = {x:e}");
            assert_eq!(bits(sin_cos_unreduced_from(x, table)), bits(sin_cos_fused_from(x, table)), "x = {x:e}");
        }
    }

    #[cfg(feature = "std")]
    #[test]
    fn sin_cos_from_a_table_is_libms_to_two_ulp() {
        // Its terms read from a table in the order of `SIN_COS` (a term out of place, or the
        // even and odd halves swapped, is off by far more), reduced where |x| > π/4.
        let table = |i: usize| SIN_COS[i];
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        let (mut worst, n) = (0, 400_000);
        for i in 0..=n {
            let x = -50.0 + 100.0 * i as f64 / n as f64;
            let (s, c) = sin_cos_fused_from(x, table);
            let (ls, lc) = x.sin_cos();
            // Near a zero of sin or cos an ulp of the reduced angle is many of the result's.
            if ls.abs() > 1e-3 {
                worst = worst.max(ulps(s, ls));
            }
            if lc.abs() > 1e-3 {
                worst = worst.max(ulps(c, lc));
            }
            assert!((s - ls).abs() < 5e-16 && (c - lc).abs() < 5e-16, "x = {x:e}");
        }
        assert!(worst <= 2, "{worst} ulp");
        assert_eq!(sin_cos_unreduced_from(0.0, table), (0.0, 1.0));
        assert!(sin_cos_fused_from(f64::NAN, table).0.is_nan());
    }

    #[cfg(feature = "std")]
    #[test]
    fn sin_cos_plus_is_libms_to_two_ulp() {
        // x on a grid of 2^-8 and d of 2^-16: x + d is exact, so libm's sin/cos of it is the
        // reference; d up to the limit, and past it, where the next term shows.
        let table = |i: usize| Fused(SIN_COS[i]);
        // Ulp of the largest of the result, the value shifted and the shift: where the shift
        // cancels most of sin φ or cos φ (near a zero), their roundings are what is left, as
        // the rounding of the stage's pitch x + d is when its sin/cos is computed from it.
        let ulps = |a: f64, b: f64, from: f64, d: f64| {
            let scale = b.abs().max(from.abs()).max(d.abs());
            (a - b).abs() / (f64::from_bits(scale.to_bits() + 1) - scale)
        };
        // The most ulp and the largest difference.
        let worst_at = |limit: f64| {
            let (mut worst, mut off) = (0.0f64, 0.0f64);
            for i in -1024..=1024 {
                let x = i as f64 / 256.0;
                let (s, c) = x.sin_cos();
                let mut j = -(limit * 65536.0) as i64;
                while j as f64 <= limit * 65536.0 {
                    let d = j as f64 / 65536.0;
                    let (ps, pc) = sin_cos_plus((Fused(s), Fused(c)), Fused(d), table);
                    let (ls, lc) = (x + d).sin_cos();
                    worst = worst.max(ulps(ps.0, ls, s, d)).max(ulps(pc.0, lc, c, d));
                    off = off.max((ps.0 - ls).abs()).max((pc.0 - lc).abs());
                    j += 7;
                }
            }
            (worst, off)
        };
        let (worst, off) = worst_at(SHIFT_LIMIT);
        assert!(worst <= 2.0 && off < 5e-16, "{worst} ulp, {off:e}");
        assert!(worst_at(4.0 * SHIFT_LIMIT).0 > 2.0, "the limit is not where Taylor's terms end");
        assert_eq!(sin_cos_plus((Fused(0.0), Fused(1.0)), Fused(0.0), table), (Fused(0.0), Fused(1.0)));
    }
}
