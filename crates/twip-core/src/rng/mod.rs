//! Counter-based random numbers: Philox4x64-10 (Salmon et al., SC'11).
//!
//! Sample `i` of a sweep draws from its own stream (key = [seed, i]), so its numbers do
//! not depend on which thread runs it or on the other samples: a sweep is bitwise the
//! same on 1 or 16 threads, and any sample can be replayed alone. The output sequence
//! is the one of numpy's `np.random.Philox(key=[seed, stream]).random_raw()`, which lets
//! the pure-Python reference draw the very same noise.
mod ziggurat_tables;

use crate::{c, Real};
use ziggurat_tables::{EDGES, HEIGHTS};

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

    /// The next four words, if the buffer holds four (refilled first when spent), left
    /// there: [`Self::skip`] takes them.
    #[inline(always)]
    fn peek4(&mut self) -> Option<[u64; 4]> {
        if self.used == self.buffer.len() {
            self.refill();
        }
        let w = self.buffer.get(self.used..self.used + 4)?;
        Some([w[0], w[1], w[2], w[3]])
    }

    /// Takes the `n` words peeked.
    #[inline(always)]
    fn skip(&mut self, n: usize) {
        self.used += n;
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
        c::<T>((self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64))
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

/// `f64` functions that work with and without std (via nalgebra's RealField).
trait F64Ext {
    fn sqrt_f64(self) -> f64;
    fn sin_f64(self) -> f64;
    fn cos_f64(self) -> f64;
}

impl F64Ext for f64 {
    fn sqrt_f64(self) -> f64 {
        nalgebra::ComplexField::sqrt(self)
    }
    fn sin_f64(self) -> f64 {
        nalgebra::ComplexField::sin(self)
    }
    fn cos_f64(self) -> f64 {
        nalgebra::ComplexField::cos(self)
    }
}

fn ln(x: f64) -> f64 {
    nalgebra::ComplexField::ln(x)
}

/// Standard normals by the ziggurat method (Marsaglia & Tsang 2000) with 256 layers.
/// 32 random bits give the layer (8), the sign (1) and a 23-bit uniform, so one 64-bit
/// word gives two normals; 98.8 % of draws are a multiply and a compare. The rare rest (a
/// layer's wedge, the tail beyond r) takes more words from the same stream. The IMU needs
/// four normals per 1 kHz sample: this costs two Philox words instead of Box–Muller's four
/// words, two logarithms, roots and sin/cos. The layers are one table all share
/// (`ziggurat_tables`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Ziggurat;

/// Where the tail starts, for 256 layers of e^(−x²/2).
const ZIGGURAT_R: f64 = 3.654_152_885_361_009;

fn gauss(x: f64) -> f64 {
    nalgebra::ComplexField::exp(-0.5 * x * x)
}

impl Ziggurat {
    pub fn new() -> Self {
        Self
    }

    /// The layers' edges and heights from r and v (what `ziggurat_tables` holds).
    #[cfg(test)]
    fn derive() -> ([f64; 257], [f64; 257]) {
        // Each layer's area.
        const ZIGGURAT_V: f64 = 4.928_673_233_974_658e-3;
        let mut x = [0.0; 257];
        x[0] = ZIGGURAT_V / gauss(ZIGGURAT_R);
        x[1] = ZIGGURAT_R;
        for i in 1..255 {
            x[i + 1] = (-2.0 * ln(ZIGGURAT_V / x[i] + gauss(x[i]))).sqrt_f64();
        }
        let mut f = [0.0; 257];
        for (fi, xi) in f.iter_mut().zip(x) {
            *fi = gauss(xi);
        }
        (x, f)
    }

    /// Fills `out` with standard normals from `rng`, two per word (low half first; the
    /// rare retries and tails draw their words as they come).
    #[inline(always)]
    pub fn fill(&self, rng: &mut Philox, out: &mut [f64]) {
        let mut rest = out;
        while rest.len() >= 8 {
            // Eight at once from four words when all are inside their rectangles (91 %):
            // the numbers one by one gives, without a branch between them.
            if let Some(normals) = rng.peek4().and_then(Self::all_inside) {
                rng.skip(4);
                rest[..8].copy_from_slice(&normals);
                rest = &mut rest[8..];
                continue;
            }
            self.one_word(rng, &mut rest[..2]);
            rest = &mut rest[2..];
        }
        for pair in rest.chunks_mut(2) {
            self.one_word(rng, pair);
        }
    }

    /// The normals of the next word into `pair` (its one or two places), low half first.
    #[inline(always)]
    fn one_word(&self, rng: &mut Philox, pair: &mut [f64]) {
        let word = rng.next_u64();
        pair[0] = self.normal((word & 0xFFFF_FFFF) as u32, rng);
        if let Some(second) = pair.get_mut(1) {
            *second = self.normal((word >> 32) as u32, rng);
        }
    }

    /// One normal from 32 bits: inside its layer's rectangle (98.8 %), at once.
    #[inline(always)]
    fn normal(&self, bits: u32, rng: &mut Philox) -> f64 {
        let (sign, z, i) = Self::candidate(bits);
        if z < EDGES[i + 1] {
            return sign * z;
        }
        self.outside(bits, rng)
    }

    /// The eight normals of four words (each low half first), if all are inside their
    /// layers' rectangles.
    #[inline(always)]
    fn all_inside(words: [u64; 4]) -> Option<[f64; 8]> {
        let mut out = [0.0; 8];
        let mut inside = true;
        for (j, word) in words.into_iter().enumerate() {
            for (h, bits) in [(word & 0xFFFF_FFFF) as u32, (word >> 32) as u32].into_iter().enumerate() {
                let (sign, z, i) = Self::candidate(bits);
                inside &= z < EDGES[i + 1];
                out[2 * j + h] = sign * z;
            }
        }
        inside.then_some(out)
    }

    /// The sign, the candidate |z| and its layer that 32 bits give.
    #[inline(always)]
    fn candidate(bits: u32) -> (f64, f64, usize) {
        let i = (bits & 0xFF) as usize;
        // Bit 8 is the sign, set without a branch (it is a coin toss).
        let sign = f64::from_bits(1f64.to_bits() | (u64::from(bits & 0x100) << 55));
        (sign, (bits >> 9) as f64 * (1.0 / 8_388_608.0) * EDGES[i], i)
    }

    /// [`Self::normal`] for bits whose candidate may lie outside its rectangle: a layer's
    /// wedge is accepted under the curve, the base layer goes to the tail, and a rejected
    /// draw takes a fresh word's low half. Out of line: rare, and large.
    #[cold]
    #[inline(never)]
    fn outside(&self, mut bits: u32, rng: &mut Philox) -> f64 {
        loop {
            let (sign, z, i) = Self::candidate(bits);
            if z < EDGES[i + 1] {
                return sign * z;
            }
            if i == 0 {
                return sign * self.tail(rng);
            }
            let y = HEIGHTS[i + 1] + rng.uniform::<f64>() * (HEIGHTS[i] - HEIGHTS[i + 1]);
            if y < gauss(z) {
                return sign * z;
            }
            bits = (rng.next_u64() & 0xFFFF_FFFF) as u32;
        }
    }

    /// Marsaglia's tail beyond r: r + a with a ~ Exp(r), accepted with e^(−a²/2).
    #[cold]
    fn tail(&self, rng: &mut Philox) -> f64 {
        loop {
            let a = -ln(1.0 - rng.uniform::<f64>()) / ZIGGURAT_R;
            let b = -ln(1.0 - rng.uniform::<f64>());
            if 2.0 * b > a * a {
                return ZIGGURAT_R + a;
            }
        }
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

    #[cfg(feature = "std")]
    #[test]
    fn ziggurat_normals_look_normal() {
        let z = Ziggurat::new();
        assert!(EDGES[255] > 0.2 && EDGES[255] < 0.22, "the top layer closes the table");
        let mut g = Philox::new(42, 17);
        let n = 400_000;
        let mut draws = std::vec![0.0; n];
        z.fill(&mut g, &mut draws);
        let (mut sum, mut sq, mut quad, mut beyond) = (0.0, 0.0, 0.0, 0);
        for v in draws {
            sum += v;
            sq += v * v;
            quad += v * v * v * v;
            beyond += (v.abs() > 3.0) as usize;
        }
        let (mean, var, kurt, tail) = (sum / n as f64, sq / n as f64, quad / n as f64, beyond as f64 / n as f64);
        // P(|z| > 3) = 0.0027.
        assert!(mean.abs() < 0.01 && (var - 1.0).abs() < 0.01 && (kurt - 3.0).abs() < 0.05 && (tail - 0.0027).abs() < 0.0005,
            "{mean} {var} {kurt} {tail}");
    }

    /// `fill`'s eight-at-once path gives the numbers one by one gives, whatever the length
    /// and wherever the retries and tails fall (which move later words off the groups of
    /// four): against a plain loop of `normal` per half word.
    #[test]
    fn fill_gives_the_numbers_one_by_one_gives() {
        let z = Ziggurat::new();
        let mut outside = 0;
        for stream in 0..40 {
            for len in [0, 1, 7, 8, 9, 32, 33, 1000] {
                let (mut a, mut b) = (Philox::new(3, stream), Philox::new(3, stream));
                let mut got = [0.0; 1000];
                z.fill(&mut a, &mut got[..len]);
                let mut want = [0.0; 1000];
                let mut one = |bits: u32, rng: &mut Philox| {
                    let (_, candidate, i) = Ziggurat::candidate(bits);
                    outside += (candidate >= EDGES[i + 1]) as usize;
                    z.normal(bits, rng)
                };
                for pair in want[..len].chunks_mut(2) {
                    let word = b.next_u64();
                    pair[0] = one((word & 0xFFFF_FFFF) as u32, &mut b);
                    if let Some(second) = pair.get_mut(1) {
                        *second = one((word >> 32) as u32, &mut b);
                    }
                }
                for (i, (g, w)) in got[..len].iter().zip(&want[..len]).enumerate() {
                    assert_eq!(g.to_bits(), w.to_bits(), "stream {stream}, length {len}, normal {i}");
                }
                assert_eq!(a.next_u64(), b.next_u64(), "stream {stream}, length {len}: the words after");
            }
        }
        assert!(outside > 100, "want draws outside the rectangles: {outside}");
    }

    /// The written-out layers are the derivation's, to an ulp (bit for bit with glibc's
    /// libm, which wrote them): any other libm draws the same normals from them.
    #[test]
    fn ziggurat_tables_are_the_derivation() {
        let (x, f) = Ziggurat::derive();
        for (name, table, derived) in [("edges", &EDGES, x), ("heights", &HEIGHTS, f)] {
            for i in 0..257 {
                let (a, b) = (table[i], derived[i]);
                assert!((a - b).abs() <= f64::EPSILON * a.abs(), "{name}[{i}]: {a:e} vs {b:e}");
            }
        }
        #[cfg(all(target_os = "linux", target_env = "gnu", feature = "std"))]
        assert_eq!((EDGES, HEIGHTS), (x, f), "glibc derives the very tables");
    }
}
