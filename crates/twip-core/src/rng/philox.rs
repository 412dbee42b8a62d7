//! Philox4x64-10 (Salmon et al., SC'11): a sweep's draws of its samples.
use super::{ln, unit_interval, F64Ext};
use crate::{c, Real};

const M0: u64 = 0xD2E7_470E_E14C_6C93;
const M1: u64 = 0xCA5A_8263_9512_1157;
const W0: u64 = 0x9E37_79B9_7F4A_7C15;
const W1: u64 = 0xBB67_AE85_84CA_A73B;

#[inline(always)]
fn mulhilo(a: u64, b: u64) -> (u64, u64) {
    let p = (a as u128) * (b as u128);
    ((p >> 64) as u64, p as u64)
}

/// The Philox4x64 bijection with 10 rounds, on [`BLOCKS`] counters at once: their rounds
/// are independent, so the multiplies of one overlap the latency of the other's.
#[inline(always)]
fn philox4x64_10(mut xs: [[u64; 4]; BLOCKS], mut k: [u64; 2]) -> [[u64; 4]; BLOCKS] {
    for round in 0..10 {
        if round > 0 {
            k[0] = k[0].wrapping_add(W0);
            k[1] = k[1].wrapping_add(W1);
        }
        for x in xs.iter_mut() {
            let (hi0, lo0) = mulhilo(M0, x[0]);
            let (hi1, lo1) = mulhilo(M1, x[2]);
            *x = [hi1 ^ x[1] ^ k[0], lo1, hi0 ^ x[3] ^ k[1], lo0];
        }
    }
    xs
}

/// Blocks of four words made at once (see [`philox4x64_10`]).
const BLOCKS: usize = 2;

/// A stream of 64-bit words: key = [seed, stream], counter from 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Philox {
    key: [u64; 2],
    counter: [u64; 4],
    buffer: [u64; 4 * BLOCKS],
    used: usize,
    /// A second normal deviate left over from Box–Muller.
    spare: Option<u64>,
}

impl Philox {
    pub fn new(seed: u64, stream: u64) -> Self {
        Self { key: [seed, stream], counter: [0; 4], buffer: [0; 4 * BLOCKS], used: 4 * BLOCKS, spare: None }
    }

    /// The next 64-bit word (numpy's `random_raw` order: the counter is incremented
    /// before each block).
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        if self.used == self.buffer.len() {
            self.refill();
        }
        self.used += 1;
        self.buffer[self.used - 1]
    }

    /// The next [`BLOCKS`] blocks into the buffer. Out of line: its registers would
    /// otherwise be saved and restored on every word.
    #[inline(never)]
    fn refill(&mut self) {
        let counters = core::array::from_fn(|_| {
            for word in self.counter.iter_mut() {
                *word = word.wrapping_add(1);
                if *word != 0 {
                    break;
                }
            }
            self.counter
        });
        for (words, block) in self.buffer.chunks_exact_mut(4).zip(philox4x64_10(counters, self.key)) {
            words.copy_from_slice(&block);
        }
        self.used = 0;
    }

    /// Uniform on [0, 1) with 53 random bits.
    pub fn uniform<T: Real>(&mut self) -> T {
        c::<T>(unit_interval(self.next_u64()))
    }

    /// Standard normal by Box–Muller (both deviates used, in order).
    pub fn normal<T: Real>(&mut self) -> T {
        if let Some(bits) = self.spare.take() {
            return c::<T>(f64::from_bits(bits));
        }
        // 1 - U is in (0, 1]: the logarithm is finite.
        let u1: f64 = 1.0 - self.uniform::<f64>();
        let u2: f64 = self.uniform::<f64>();
        let radius = (-2.0 * ln(u1)).sqrt_f64();
        let angle = core::f64::consts::TAU * u2;
        self.spare = Some((radius * angle.sin_f64()).to_bits());
        c::<T>(radius * angle.cos_f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Known answers from numpy: `np.random.Philox(key=[7, 3]).random_raw(6)`.
    #[test]
    fn matches_numpy_philox() {
        let mut g = Philox::new(7, 3);
        let expected = [
            0x7b6c_c7b1_862c_c5f2,
            0xb960_f2ea_4b3f_8d9f,
            0x0cdd_72e0_15de_b1a6,
            0x50ed_b0d2_2a6a_6fd5,
            0xae45_891b_f7ab_4df3,
            0x3200_5aae_5c70_0f2c,
        ];
        for e in expected {
            assert_eq!(g.next_u64(), e);
        }
        let mut g = Philox::new(0, 0);
        assert_eq!(g.next_u64(), 0x02f4_ba64_08e4_d89b);
    }

    #[test]
    fn streams_differ_and_normals_look_normal() {
        let mut a = Philox::new(1, 0);
        let mut b = Philox::new(1, 1);
        assert_ne!(a.next_u64(), b.next_u64());
        let mut g = Philox::new(42, 17);
        let n = 100_000;
        let (mut sum, mut sq) = (0.0, 0.0);
        for _ in 0..n {
            let z: f64 = g.normal();
            sum += z;
            sq += z * z;
        }
        let mean = sum / n as f64;
        let var = sq / n as f64 - mean * mean;
        assert!(mean.abs() < 0.02 && (var - 1.0).abs() < 0.02, "mean {mean} var {var}");
    }
}
