//! SFC64, Chris Doty-Humphrey's Small Fast Chaotic generator (numpy's `SFC64`): the words of
//! the sensors' noise.
//!
//! An IMU takes four normals per 1 kHz sample, and a rig on lanes spent ~45 % of its time
//! making them from Philox4x64-10, whose ten rounds of 64-bit multiplies run one stream at a
//! time. SFC64 is adds, shifts and a rotation, so a sweep's lanes run their streams side by
//! side ([`Sfc64<N>`]), each lane still drawing the words its own stream gives.
//!
//! Stream (seed, stream) starts from the first three words of Philox stream (seed, stream),
//! so streams are keyed as a sweep's samples are and start from unrelated states; then comes
//! numpy's own seeding (counter 1, twelve outputs discarded). numpy's `SFC64` given that state
//! draws the very same words, which lets the pure-Python reference draw the same noise.
use super::{unit_interval, Philox};

/// `N` SFC64 streams side by side (a sweep's lanes, lane `l` the stream `l`); one robot's
/// stream is `Sfc64` (`N` = 1). The state is a, b, c and a counter, as numpy's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sfc64<const N: usize = 1> {
    a: [u64; N],
    b: [u64; N],
    c: [u64; N],
    counter: [u64; N],
}

/// Outputs numpy's seeding discards.
const WARM_UP: usize = 12;

impl Sfc64 {
    /// Stream `stream` of seed `seed` (see the module's doc).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut key = Philox::new(seed, stream);
        let mut rng = Self { a: [key.next_u64()], b: [key.next_u64()], c: [key.next_u64()], counter: [1] };
        for _ in 0..WARM_UP {
            rng.next_u64();
        }
        rng
    }

    /// The next 64-bit word.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.word(0)
    }
}

impl<const N: usize> Sfc64<N> {
    /// The streams side by side: lane `l` goes on as `streams[l]` would.
    pub fn lanes(streams: [Sfc64; N]) -> Self {
        let of = |part: fn(&Sfc64) -> u64| streams.map(|s| part(&s));
        Self { a: of(|s| s.a[0]), b: of(|s| s.b[0]), c: of(|s| s.c[0]), counter: of(|s| s.counter[0]) }
    }

    /// Lane `lane`'s stream as it stands.
    pub fn lane(&self, lane: usize) -> Sfc64 {
        Sfc64 { a: [self.a[lane]], b: [self.b[lane]], c: [self.c[lane]], counter: [self.counter[lane]] }
    }

    /// Lane `lane` goes on as `stream` would.
    pub fn set_lane(&mut self, lane: usize, stream: Sfc64) {
        (self.a[lane], self.b[lane], self.c[lane], self.counter[lane]) = (stream.a[0], stream.b[0], stream.c[0], stream.counter[0]);
    }

    /// Lane `lane`'s next word.
    #[inline(always)]
    pub fn word(&mut self, lane: usize) -> u64 {
        let (a, b, c) = (self.a[lane], self.b[lane], self.c[lane]);
        let out = a.wrapping_add(b).wrapping_add(self.counter[lane]);
        self.counter[lane] = self.counter[lane].wrapping_add(1);
        self.a[lane] = b ^ (b >> 11);
        self.b[lane] = c.wrapping_add(c << 3);
        self.c[lane] = c.rotate_left(24).wrapping_add(out);
        out
    }

    /// Every lane's next word (a loop the compiler runs on SIMD lanes).
    #[inline(always)]
    pub fn words(&mut self) -> [u64; N] {
        core::array::from_fn(|lane| self.word(lane))
    }

    /// Lane `lane`'s next word as a uniform on [0, 1) with 53 random bits.
    #[inline]
    pub fn uniform(&mut self, lane: usize) -> f64 {
        unit_interval(self.word(lane))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Known answers from numpy: `np.random.SFC64()` given the state [w0, w1, w2, 1], where
    /// w are `np.random.Philox(key=[7, 3]).random_raw(3)`, then `random_raw(12)` discarded
    /// and `random_raw(6)` kept (python/twip/reference/rng.py does exactly this).
    #[test]
    fn matches_numpy_sfc64() {
        let mut g = Sfc64::new(7, 3);
        let expected = [
            0x127d_efca_977f_bd24,
            0x8559_346e_333a_185d,
            0x710c_6a0c_7d20_9ec0,
            0x7a0a_7d08_f128_3bca,
            0xc209_774f_6ff5_636e,
            0x0ffe_d34c_14a9_9a1b,
        ];
        for e in expected {
            assert_eq!(g.next_u64(), e);
        }
        assert_eq!(Sfc64::new(0, 0).next_u64(), 0x10b4_875a_05e7_69bc);
    }

    /// Lanes side by side give each lane the words its stream alone gives, in any order of
    /// drawing (all lanes at once, or one lane ahead of the rest).
    #[test]
    fn lanes_go_on_as_their_streams() {
        let streams: [Sfc64; 5] = core::array::from_fn(|l| Sfc64::new(9, 100 + l as u64));
        let mut alone = streams;
        let mut lanes = Sfc64::lanes(streams);
        for round in 0..50 {
            if round % 7 == 3 {
                assert_eq!(lanes.word(2), alone[2].next_u64(), "round {round}");
            }
            let words = lanes.words();
            for (l, w) in words.into_iter().enumerate() {
                assert_eq!(w, alone[l].next_u64(), "round {round}, lane {l}");
            }
        }
        // A lane taken out, drawn alone and put back goes on as its stream.
        let mut three = lanes.lane(3);
        assert_eq!(three.next_u64(), alone[3].next_u64());
        lanes.set_lane(3, three);
        let words = lanes.words();
        for (l, w) in words.into_iter().enumerate() {
            assert_eq!(w, alone[l].next_u64(), "after lane 3 alone, lane {l}");
        }
        assert_ne!(Sfc64::new(1, 0).next_u64(), Sfc64::new(1, 1).next_u64());
    }
}
