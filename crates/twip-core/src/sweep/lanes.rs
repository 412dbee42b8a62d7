//! Arithmetic on lanes of samples (structure of arrays, `[f64; LANES]`) written as plain
//! loops without branches, so that the compiler turns them into SIMD instructions.
//! The one transcendental the 2-DOF model needs, sin/cos, is a polynomial here: libm's
//! is a call per value and would stop the vectorisation. Multiply-adds are fused
//! (`mul_add`): exactly rounded, so the same bits on every CPU.

/// Samples advanced together: 16 f64 = two AVX-512 registers, four AVX2 ones.
pub const LANES: usize = 16;

/// One value per lane.
pub type Lanes = [f64; LANES];

/// 1.5 · 2^52: adding and subtracting it rounds to the nearest integer (|y| < 2^51),
/// and leaves that integer in the low bits of the sum.
const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;

/// π/2 = PIO2_HI + PIO2_LO + O(1e-33): the nearest f64, and the nearest to the rest.
const PIO2_HI: f64 = core::f64::consts::FRAC_PI_2;
const PIO2_LO: f64 = 6.123_233_995_736_766e-17;

/// sin and cos of one lane's value, written to vectorise inside a loop over lanes:
/// branch-free, the quadrant's swap and signs applied with bit masks.
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    let shifted = x.mul_add(core::f64::consts::FRAC_2_PI, ROUND_MAGIC);
    let quadrant = shifted.to_bits();
    let k = shifted - ROUND_MAGIC;
    // x − k π/2 in two parts: a fused multiply-add rounds x − k·PIO2_HI once, so the
    // third part that plain arithmetic needs (math::PIO2_3) is not.
    let r = (-k).mul_add(PIO2_LO, (-k).mul_add(PIO2_HI, x));
    let (s, c) = kernel(r);
    let (s, c) = (s.to_bits(), c.to_bits());
    // Odd quadrants swap sin and cos; quadrants 2, 3 negate sin; 1, 2 negate cos.
    let swap = (quadrant & 1).wrapping_neg();
    let sin_r = (s & !swap) | (c & swap);
    let cos_r = (c & !swap) | (s & swap);
    (f64::from_bits(sin_r ^ ((quadrant & 2) << 62)), f64::from_bits(cos_r ^ ((quadrant.wrapping_add(1) & 2) << 62)))
}

/// `crate::model::math::kernel` for f64 with plain constants and fused multiply-adds (the generic one's conversions
/// keep the compiler from vectorising): the same polynomial, multiply-adds fused.
#[inline(always)]
fn kernel(r: f64) -> (f64, f64) {
    use crate::model::math::{COS, SIN};
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let s01 = r2.mul_add(SIN[1], SIN[0]);
    let s23 = r2.mul_add(SIN[3], SIN[2]);
    let s45 = r2.mul_add(SIN[5], SIN[4]);
    let ps = r8.mul_add(r4.mul_add(SIN[6], s45), r4.mul_add(s23, s01));
    let c01 = r2.mul_add(COS[1], COS[0]);
    let c23 = r2.mul_add(COS[3], COS[2]);
    let c45 = r2.mul_add(COS[5], COS[4]);
    let c67 = r2.mul_add(COS[7], COS[6]);
    let pc = r8.mul_add(r4.mul_add(c67, c45), r4.mul_add(c23, c01));
    ((r * r2).mul_add(ps, r), r2.mul_add(pc, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_matches_libm() {
        let mut worst: f64 = 0.0;
        let n = 200_000;
        for i in 0..=n {
            let x = -100.0 + 200.0 * i as f64 / n as f64;
            let (s, c) = sin_cos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(worst < 5e-16, "worst absolute error {worst:e}");
        // Far out, the two-part reduction by π/2 (one fused multiply-add) still holds a few ulp.
        let mut far: f64 = 0.0;
        for i in 0..=n {
            let x = -1e4 + 2e4 * i as f64 / n as f64;
            let (s, c) = sin_cos(x);
            far = far.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(far < 2e-15, "worst absolute error on |x| <= 1e4: {far:e}");
        for x in [0.0, -0.0, 1e-300, core::f64::consts::FRAC_PI_2, core::f64::consts::PI, 3.0e4] {
            let (s, c) = sin_cos(x);
            assert!((s - x.sin()).abs() < 1e-15 && (c - x.cos()).abs() < 1e-15, "x = {x}");
        }
    }
}

