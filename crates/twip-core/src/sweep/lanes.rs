//! Arithmetic on lanes of samples (structure of arrays, `[f64; LANES]`) written as plain
//! loops without branches, so that the compiler turns them into SIMD instructions.
//! The one transcendental the 2-DOF model needs, sin/cos, is a polynomial here: libm's
//! is a call per value and would stop the vectorisation.

/// Samples advanced together. 8 f64 = two AVX2 registers, four SSE2 ones.
pub const LANES: usize = 16;

/// One value per lane.
pub type Lanes = [f64; LANES];

/// 1.5 · 2^52: adding and subtracting it rounds to the nearest integer (|y| < 2^51),
/// and leaves that integer in the low bits of the sum.
const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;

/// sin and cos of every lane. Branch-free: the quadrant's swap and signs are applied
/// with bit masks, so the loops vectorise. Bit for bit the same as
/// `crate::math::sin_cos::<f64>` (its test checks it).
#[inline(always)]
pub fn sin_cos(x: &Lanes) -> (Lanes, Lanes) {
    use crate::math::{PIO2_1, PIO2_2, PIO2_3};
    let mut sin = [0.0; LANES];
    let mut cos = [0.0; LANES];
    for l in 0..LANES {
        let shifted = x[l] * core::f64::consts::FRAC_2_PI + ROUND_MAGIC;
        let quadrant = shifted.to_bits();
        let k = shifted - ROUND_MAGIC;
        let r = ((x[l] - k * PIO2_1) - k * PIO2_2) - k * PIO2_3;
        let (s, c) = kernel(r);
        let (s, c) = (s.to_bits(), c.to_bits());
        // Odd quadrants swap sin and cos; quadrants 2, 3 negate sin; 1, 2 negate cos.
        let swap = (quadrant & 1).wrapping_neg();
        let sin_r = (s & !swap) | (c & swap);
        let cos_r = (c & !swap) | (s & swap);
        sin[l] = f64::from_bits(sin_r ^ ((quadrant & 2) << 62));
        cos[l] = f64::from_bits(cos_r ^ ((quadrant.wrapping_add(1) & 2) << 62));
    }
    (sin, cos)
}

/// `crate::math::kernel` for f64 with plain constants (the generic one's conversions
/// keep the compiler from vectorising); same operations in the same order.
#[inline(always)]
fn kernel(r: f64) -> (f64, f64) {
    use crate::math::{COS, SIN};
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let s01 = SIN[0] + r2 * SIN[1];
    let s23 = SIN[2] + r2 * SIN[3];
    let s45 = SIN[4] + r2 * SIN[5];
    let ps = (s01 + r4 * s23) + r8 * (s45 + r4 * SIN[6]);
    let c01 = COS[0] + r2 * COS[1];
    let c23 = COS[2] + r2 * COS[3];
    let c45 = COS[4] + r2 * COS[5];
    let c67 = COS[6] + r2 * COS[7];
    let pc = (c01 + r4 * c23) + r8 * (c45 + r4 * c67);
    (r + r * r2 * ps, 1.0 + r2 * pc)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(x: f64) -> (f64, f64) {
        let (s, c) = sin_cos(&[x; LANES]);
        (s[0], c[0])
    }

    #[test]
    fn sin_cos_matches_libm() {
        let mut worst: f64 = 0.0;
        let n = 200_000;
        for i in 0..=n {
            let x = -100.0 + 200.0 * i as f64 / n as f64;
            let (s, c) = one(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(worst < 5e-16, "worst absolute error {worst:e}");
        for i in 0..=n {
            let x = -1e4 + 2e4 * i as f64 / n as f64;
            let (a, b) = (one(x), crate::math::sin_cos(x));
            assert_eq!((a.0.to_bits(), a.1.to_bits()), (b.0.to_bits(), b.1.to_bits()), "x = {x}");
        }
        for x in [0.0, -0.0, 1e-300, core::f64::consts::FRAC_PI_2, core::f64::consts::PI, 3.0e4] {
            let (s, c) = one(x);
            assert!((s - x.sin()).abs() < 1e-15 && (c - x.cos()).abs() < 1e-15, "x = {x}");
        }
    }
}

