//! sin/cos as a polynomial: faster than libm's call, and the same polynomial as the
//! lane version that sweeps vectorise (`sweep::lanes::sin_cos`, which fuses its
//! multiply-adds; this one does not, so that it needs no FMA unit or libm call).
//!
//! Cody–Waite reduction by π/2 (rounding to nearest even, as the lane version does),
//! then Taylor polynomials on |r| ≤ π/4. Accurate to a few ulp in f64 for |x| < 1e5.
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

/// (sin x, cos x).
#[inline(always)]
pub fn sin_cos<T: Real>(x: T) -> (T, T) {
    // Adding and removing 1.5/ε rounds to the nearest integer (ties to even).
    let magic = c::<T>(1.5) / T::default_epsilon();
    let k = (x * T::frac_2_pi() + magic) - magic;
    let quadrant = (crate::to_f64(k) as i64) & 3;
    let r = ((x - k * c::<T>(PIO2_1)) - k * c::<T>(PIO2_2)) - k * c::<T>(PIO2_3);
    let (s, co) = kernel(r);
    rotate(s, co, quadrant)
}

/// sin and cos of |r| ≤ π/4. The polynomials in r² are evaluated by Estrin's scheme
/// (pairs, then pairs of pairs): a shorter chain of dependent operations than Horner's,
/// which is what bounds the speed of a single evaluation.
#[inline(always)]
pub(crate) fn kernel<T: Real>(r: T) -> (T, T) {
    let k = |i: usize, table: &[f64]| c::<T>(table[i]);
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let s01 = k(0, &SIN) + r2 * k(1, &SIN);
    let s23 = k(2, &SIN) + r2 * k(3, &SIN);
    let s45 = k(4, &SIN) + r2 * k(5, &SIN);
    let ps = (s01 + r4 * s23) + r8 * (s45 + r4 * k(6, &SIN));
    let c01 = k(0, &COS) + r2 * k(1, &COS);
    let c23 = k(2, &COS) + r2 * k(3, &COS);
    let c45 = k(4, &COS) + r2 * k(5, &COS);
    let c67 = k(6, &COS) + r2 * k(7, &COS);
    let pc = (c01 + r4 * c23) + r8 * (c45 + r4 * c67);
    (r + r * r2 * ps, T::one() + r2 * pc)
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
    }
}
