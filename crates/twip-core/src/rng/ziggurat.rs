//! Standard normals by the ziggurat method (Marsaglia & Tsang 2000) with 256 layers, on the
//! lanes of an [`Sfc64`].
use super::ziggurat_tables::{EDGES, HEIGHTS};
#[cfg(test)]
use super::F64Ext;
use super::{ln, Sfc64};

/// Standard normals by the ziggurat method with 256 layers. 32 random bits give the layer
/// (8), the sign (1) and a 23-bit uniform, so one 64-bit word gives two normals; 98.8 % of
/// draws are a multiply and a compare. The rare rest (a layer's wedge, the tail beyond r)
/// takes more words from the same stream. The layers are one table all share
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

    /// The normals of every lane's next `words` words: normal `n` (of word n / 2, its low
    /// half first) goes to `out(n, that normal on each lane)`. A lane's normals are the ones
    /// its stream alone gives, a word's two halves and any retry they take in turn; the
    /// lanes draw side by side, and only a lane whose candidate falls outside its rectangle
    /// goes on alone (after both halves' candidates: each half's bits are its word's, and a
    /// lane's retries still take its stream's words in the halves' order).
    #[inline(always)]
    pub fn fill<const N: usize>(&self, rng: &mut Sfc64<N>, words: usize, mut out: impl FnMut(usize, [f64; N])) {
        const { assert!(N <= 64, "a lane is a bit of a u64") };
        for j in 0..words {
            let word = rng.words();
            let mut normals = [[0.0; N]; 2];
            let mut outside = [0u64; 2];
            for h in 0..2 {
                // Each lane's layer edges x_i, x_(i+1) by one load of both: loaded as a
                // vector's lanes (gathers) they took most of the draws' time on AVX-512
                // (measured, a 16-lane fill alone: 0.83x the time by these loads; medians of
                // 10 alternated runs, scratch bench s15-rigspeed/zig).
                let mut edges = [[0.0; 2]; N];
                for (e, w) in edges.iter_mut().zip(&word) {
                    *e = Self::layer((w >> (32 * h)) as usize & 0xFF);
                }
                for l in 0..N {
                    let (sign, z) = Self::candidate_in((word[l] >> (32 * h)) as u32, edges[l][0]);
                    normals[h][l] = sign * z;
                    outside[h] |= u64::from(z >= edges[l][1]) << l;
                }
            }
            // The lanes outside, one at a time (a bit mask: a set of lanes that costs no
            // loop over the rest).
            for h in 0..2 {
                while outside[h] != 0 {
                    let l = outside[h].trailing_zeros() as usize;
                    normals[h][l] = self.outside((word[l] >> (32 * h)) as u32, rng, l);
                    outside[h] &= outside[h] - 1;
                }
                out(2 * j + h, normals[h]);
            }
        }
    }

    /// Layer `i`'s edges x_i and x_(i+1), read as one scalar load: not vectorised into gathers.
    #[inline(always)]
    fn layer(i: usize) -> [f64; 2] {
        let pair = &EDGES[i..i + 2];
        // SAFETY: `pair` is two f64 in a row, which is what [f64; 2] is (and its alignment).
        unsafe { core::ptr::read_volatile(pair.as_ptr().cast::<[f64; 2]>()) }
    }

    /// The sign, the candidate |z| and its layer that 32 bits give.
    #[inline(always)]
    fn candidate(bits: u32) -> (f64, f64, usize) {
        let i = (bits & 0xFF) as usize;
        let (sign, z) = Self::candidate_in(bits, EDGES[i]);
        (sign, z, i)
    }

    /// The sign and candidate |z| that 32 bits give, their layer's edge x_i being `edge`.
    #[inline(always)]
    fn candidate_in(bits: u32, edge: f64) -> (f64, f64) {
        // Bit 8 is the sign, set without a branch (it is a coin toss).
        let sign = f64::from_bits(1f64.to_bits() | (u64::from(bits & 0x100) << 55));
        (sign, (bits >> 9) as f64 * (1.0 / 8_388_608.0) * edge)
    }

    /// The normal of lane `lane`'s bits whose candidate may lie outside its rectangle: a
    /// layer's wedge is accepted under the curve, the base layer goes to the tail, and a
    /// rejected draw takes a fresh word's low half. Out of line: rare, and large.
    #[cold]
    #[inline(never)]
    fn outside<const N: usize>(&self, mut bits: u32, rng: &mut Sfc64<N>, lane: usize) -> f64 {
        loop {
            let (sign, z, i) = Self::candidate(bits);
            if z < EDGES[i + 1] {
                return sign * z;
            }
            if i == 0 {
                return sign * Self::tail(rng, lane);
            }
            let y = HEIGHTS[i + 1] + rng.uniform(lane) * (HEIGHTS[i] - HEIGHTS[i + 1]);
            if y < gauss(z) {
                return sign * z;
            }
            bits = (rng.word(lane) & 0xFFFF_FFFF) as u32;
        }
    }

    /// Marsaglia's tail beyond r: r + a with a ~ Exp(r), accepted with e^(−a²/2).
    #[cold]
    fn tail<const N: usize>(rng: &mut Sfc64<N>, lane: usize) -> f64 {
        loop {
            let a = -ln(1.0 - rng.uniform(lane)) / ZIGGURAT_R;
            let b = -ln(1.0 - rng.uniform(lane));
            if 2.0 * b > a * a {
                return ZIGGURAT_R + a;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` normals of one stream, one at a time as the method reads (the test's reference:
    /// each half word, then whatever its retries and tail draw).
    fn one_by_one<const M: usize>(rng: &mut Sfc64, outside: &mut usize) -> [f64; M] {
        let z = Ziggurat::new();
        let mut out = [0.0; M];
        for pair in out.chunks_mut(2) {
            let word = rng.next_u64();
            for (slot, bits) in pair.iter_mut().zip([(word & 0xFFFF_FFFF) as u32, (word >> 32) as u32]) {
                let (_, candidate, i) = Ziggurat::candidate(bits);
                *outside += usize::from(candidate >= EDGES[i + 1]);
                *slot = z.outside(bits, rng, 0);
            }
        }
        out
    }

    #[cfg(feature = "std")]
    #[test]
    fn ziggurat_normals_look_normal() {
        assert!(EDGES[255] > 0.2 && EDGES[255] < 0.22, "the top layer closes the table");
        let mut g = Sfc64::new(42, 17);
        let n = 400_000;
        let mut draws = std::vec![0.0; n];
        Ziggurat::new().fill(&mut g, n / 2, |i, [v]| draws[i] = v);
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

    /// On lanes side by side, each lane's normals and the words after them are the ones its
    /// stream alone gives, wherever the retries and tails fall on the lanes (which put a lane
    /// ahead of the others in its stream).
    #[test]
    fn lanes_draw_what_each_stream_alone_draws() {
        const N: usize = 16;
        const WORDS: usize = 160;
        let z = Ziggurat::new();
        let mut outside = 0;
        for seed in 0..6 {
            let streams: [Sfc64; N] = core::array::from_fn(|l| Sfc64::new(seed, l as u64));
            let mut lanes = Sfc64::lanes(streams);
            let mut got = [[0.0; N]; 2 * WORDS];
            z.fill(&mut lanes, WORDS, |n, row| got[n] = row);
            for (l, mut alone) in streams.into_iter().enumerate() {
                let want: [f64; 2 * WORDS] = one_by_one(&mut alone, &mut outside);
                for (n, w) in want.iter().enumerate() {
                    assert_eq!(got[n][l].to_bits(), w.to_bits(), "seed {seed}, lane {l}, normal {n}");
                }
                assert_eq!(lanes.word(l), alone.next_u64(), "seed {seed}, lane {l}: the words after");
            }
        }
        assert!(outside > 300, "want draws outside the rectangles: {outside}");
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
