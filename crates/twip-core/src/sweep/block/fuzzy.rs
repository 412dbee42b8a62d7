//! Fuzzy adaptive backstepping + PD on lanes: `control::fuzzy::Law` on each lane, whose
//! weights Ŝ adapt on their own.
use super::{out_of_line_in, LaneLaw, Slope};
use crate::control::fuzzy::{FuzzyController, FuzzyGains, Law};
use crate::control::fuzzy_basis::{Member, Prepared, Trapezoid};
use crate::control::fuzzy_grid::{RuleBase, Sized, MAX_RULES, MAX_SETS};
use crate::control::reference::SpeedRef;
use crate::control::Controller;
use super::{chunk, put, state_chunk};
use crate::model::lane::{Lane, Wide};
use crate::model::math::UNREDUCED;
use crate::model::slope::SlopeCoefficients;
use crate::sweep::lanes::{Lanes, LANES};

/// The prototype's constants in lanes' numbers, shared by the lanes.
#[derive(Clone, Debug)]
pub struct FuzzyLanes {
    controller: FuzzyController<f64>,
    law: Constants<LAW_WIDTH>,
    /// (θ̇_ref, φ_s) of the last reference speed.
    steady: Option<(f64, f64)>,
}

/// How many lanes the law takes at a time, on every copy and for every set (which changes no
/// lane's numbers). On AVX-512, 16 at a time measured 0.93x the speed of 8 and 4 0.87x
/// (`sweep_throughput fuzzy-lanes`, 8 alternated runs); Gaussians at 4 took 1.12x the time of
/// 8. The thesis's trapezoids took 4 on AVX2 and the baseline copy until a real AVX2
/// CPU (a Zen 3 EPYC) measured 8 at 1.074x (10 rounds; the baseline copy 1.056x, 4 rounds).
const LAW_WIDTH: usize = 8;

/// The law's gains, sets and model in `Wide<N>` numbers.
#[derive(Clone, Debug)]
struct Constants<const N: usize> {
    gains: FuzzyGains<Wide<N>>,
    sets: Sets<N>,
    model: SlopeCoefficients<Wide<N>>,
}

/// The basis's sets in lanes' numbers: all trapezoids (the thesis's), evaluated without a
/// match per set (measured: the match costs the trapezoid law 21 % more instructions), or
/// any sets; a 3 × 3 grid fixed when compiling (the thesis's, as fast as before grids of
/// other sizes came), any other n × n sized at run time. The 3 × 3 trapezoids also in a
/// run's numbers, which the AVX-512 copy reads ([`Broadcast`]), and where each holds x alone
/// ([`Alone`]).
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)] // ~2.5 to 5.4 KB, one per worker's law: no box needed
enum Sets<const N: usize> {
    Trapezoids([[Trapezoid<Wide<N>>; 3]; 2], [[Broadcast; 3]; 2], [[Alone; 3]; 2]),
    Any([[Prepared<Wide<N>>; 3]; 2]),
    SizedTrapezoids([[Trapezoid<Wide<N>>; MAX_SETS]; 2], usize),
    SizedAny([[Prepared<Wide<N>>; MAX_SETS]; 2], usize),
}

/// A trapezoid whose breakpoints the lanes read as numbers, each broadcast where it is used:
/// on AVX-512, an operand broadcast from 8 bytes of memory (`{1to8}`), not a vector's 64. In a
/// trace of one 16-lane fuzzy step (`gdb`, `stepi`): 359 -> 337 vector loads, 54 operands
/// broadcast; `sweep_throughput fuzzy-lanes`, paired builds: 1.015x (8 rounds), 1.056x (12),
/// 1.012x (10), the same bits; the wheel against 0.1.12's, 1.042x (8 rounds, an AVX-512 EPYC).
/// AVX2 has no broadcast operand, so there each becomes an instruction of its own: 0.982x on
/// the forced `avx2` copy (8 rounds), which keeps the sets as vectors.
#[derive(Clone, Copy, Debug)]
struct Broadcast(Trapezoid<f64>);

impl<const N: usize> Member<Wide<N>> for Broadcast {
    #[inline(always)]
    fn value(&self, x: Wide<N>) -> Wide<N> {
        self.0.map(Wide::splat).value(x)
    }

    #[inline(always)]
    fn distance(&self, x: Wide<N>) -> Wide<N> {
        self.0.map(Wide::splat).distance(x)
    }
}

/// Where one trapezoid of an input holds x alone: inside its top (μ = 1) and strictly outside
/// every other set's support (μ = +0 exactly there, as `Trapezoid::value` computes it), so the
/// input's normalised weights are exactly the unit vector of that set. There x lies in
/// [`lo`, `hi`]: the top's [b, c] narrowed to the f64 strictly inside the others' supports' gaps
/// (a set whose support covers the whole top leaves none: `lo` = +∞ > `hi` = −∞). Two compares
/// a lane, not four; ±∞ beyond the bounds and NaN are never inside.
#[derive(Clone, Copy, Debug)]
struct Alone {
    lo: f64,
    hi: f64,
}

impl Alone {
    /// Set `j`'s of `sets` (part of its top when another set's support reaches into it).
    fn of(sets: &[Trapezoid<f64>; 3], j: usize) -> Self {
        // x > after and x < before: the f64 above `after` and below `before` (both open bounds).
        let (mut after, mut before) = (f64::NEG_INFINITY, f64::INFINITY);
        for (k, other) in sets.iter().enumerate() {
            if k == j {
                continue;
            }
            if other.a > sets[j].b {
                before = before.min(other.a);
            } else if other.d < sets[j].c {
                after = after.max(other.d);
            } else {
                return Self { lo: f64::INFINITY, hi: f64::NEG_INFINITY };
            }
        }
        Self { lo: sets[j].b.max(next_toward(after, true)), hi: sets[j].c.min(next_toward(before, false)) }
    }

    /// Whether this set holds `x` alone.
    #[inline(always)]
    fn holds(&self, x: f64) -> bool {
        (x >= self.lo) & (x <= self.hi)
    }
}

/// The f64 next to `x` towards +∞ (`up`) or −∞; ±∞ stay where they are when moving outwards,
/// and step to ±f64::MAX when moving in: `f64::next_up` / `next_down`, which came in Rust 1.86,
/// one past the workspace's `rust-version`. Call those once it moves.
fn next_toward(x: f64, up: bool) -> f64 {
    if x.is_nan() || (x == f64::INFINITY && up) || (x == f64::NEG_INFINITY && !up) {
        return x;
    }
    if x == 0.0 {
        return if up { f64::from_bits(1) } else { -f64::from_bits(1) };
    }
    let bits = x.to_bits();
    f64::from_bits(if (x > 0.0) == up { bits + 1 } else { bits - 1 })
}

/// The one set of `alone`'s that holds every lane of `x` alone, if there is one: lane 0's set,
/// found in scalar code, then every lane checked in vectors. (The check on `Wide`'s masks, set
/// by set, compiled to scalar compares lane by lane, and the fuzzy lanes ran 0.735×.)
#[inline(always)]
fn alone_in<const N: usize>(alone: &[Alone; 3], x: &Wide<N>) -> Option<usize> {
    let j = alone.iter().position(|a| a.holds(x.0[0]))?;
    let mut every = true;
    for v in x.0 {
        every &= alone[j].holds(v);
    }
    every.then_some(j)
}

/// The fixed 3 × 3 trapezoids (`sets`, as vectors or as broadcast numbers), whose weights are
/// a unit vector where one set of each input holds every lane alone ([`Alone`]): then the
/// memberships, their normalisation and products are skipped, the same bits as computed.
struct Alone3<'a, M> {
    sets: &'a [[M; 3]; 2],
    alone: &'a [[Alone; 3]; 2],
}

impl<const N: usize, M: Member<Wide<N>>> RuleBase<Wide<N>, 9> for Alone3<'_, M> {
    #[inline(always)]
    fn rules(&self) -> usize {
        9
    }

    #[inline(always)]
    fn xi(&self, x: &[Wide<N>; 2]) -> [Wide<N>; 9] {
        match (alone_in(&self.alone[0], &x[0]), alone_in(&self.alone[1], &x[1])) {
            (Some(i), Some(j)) => core::array::from_fn(|k| Wide::splat(if k == 3 * i + j { 1.0 } else { 0.0 })),
            _ => self.sets.xi(x),
        }
    }
}

/// Whether kernel copy `COPY` has operands broadcast from memory (AVX-512's).
const fn broadcasts<const COPY: u8>() -> bool {
    COPY == super::KernelCopy::Avx512 as u8
}

/// The first three sets of each input, for the fixed 3 × 3 law.
fn first_three<M: Copy>(sets: [[M; MAX_SETS]; 2]) -> [[M; 3]; 2] {
    sets.map(|row| [row[0], row[1], row[2]])
}

/// Each lane's weights Ŝ (one per rule, room for the largest grid, the rest zero) and the
/// PD's integral, in the kernel's frame (vectors from a cache line's boundary), a chunk of the
/// law's lanes at a time, so that the law reads and writes each chunk's weights where they lie.
/// In a `Vec` (on the heap, 8-byte aligned), each chunk's weights were copied out to the frame
/// and back every update, vectors straddling two lines: the `avx2` fuzzy kernel ran 17 % more
/// instructions (46.5 M against 39.7 M for a block, `cachegrind` of `sweep_throughput
/// fuzzy-lanes 16`), with `memcpy` calls; the `avx512` one ran within noise of this (1.01x,
/// 10 paired runs). Held one array per rule across all the lanes, each chunk's weights were
/// copied into a local array and back: loaded at the update's start, they were spilled
/// and loaded again.
#[derive(Clone, Debug)]
pub struct FuzzyState {
    chunks: [LawChunk<LAW_WIDTH>; LANES / LAW_WIDTH],
}

/// One chunk's weights Ŝ and integral (see [`FuzzyState`]).
#[derive(Clone, Debug)]
struct LawChunk<const N: usize> {
    s_hat: [Wide<N>; MAX_RULES],
    e_int: Wide<N>,
}

impl<const N: usize> Constants<N> {
    fn new(prototype: &FuzzyController<f64>) -> Self {
        let g = prototype.gains();
        let k = prototype.model().coefficients();
        let f = Wide::<N>::splat;
        let basis = prototype.basis();
        Self {
            gains: FuzzyGains { k1: f(g.k1), k2: f(g.k2), kp: f(g.kp), kd: f(g.kd), ki: f(g.ki) },
            sets: match (basis.n(), basis.trapezoids(f)) {
                (3, Some(trapezoids)) => {
                    let sets = first_three(trapezoids);
                    // Every lane holds the same numbers: lane 0's.
                    let numbers = sets.map(|row| row.map(|t| t.map(|v| v.0[0])));
                    Sets::Trapezoids(sets, numbers.map(|row| row.map(Broadcast)), numbers.map(|row| core::array::from_fn(|j| Alone::of(&row, j))))
                }
                (3, None) => Sets::Any(first_three(basis.prepared_in(f))),
                (n, Some(trapezoids)) => Sets::SizedTrapezoids(trapezoids, n),
                (n, None) => Sets::SizedAny(basis.prepared_in(f), n),
            },
            model: k.map(f),
        }
    }

    /// The law on every chunk of `N` lanes, in kernel copy `COPY`. The sized n × n forms
    /// are functions of their own per copy (`out_of_line_in`), shared by the kernels that
    /// run the law: inlined, their 49-rule loops were compiled again into each kernel, and
    /// made the wheel's build slow. The thesis's 3 × 3 stays inlined: out of line, its
    /// sweeps ran at 0.46-0.49x (the sized ones within noise).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn update<const COPY: u8>(&self, controller: &FuzzyController<f64>, phi_s: f64, state: &mut [LawChunk<N>], x: &[Lanes; 4], pitch: Option<&[Lanes; 2]>, r: &SpeedRef<f64>, u: &mut Lanes) {
        match &self.sets {
            Sets::Trapezoids(_, sets, alone) if broadcasts::<COPY>() => self.update_with::<9, _>(&Alone3 { sets, alone }, controller, phi_s, state, x, pitch, r, u),
            Sets::Trapezoids(sets, _, alone) => self.update_with::<9, _>(&Alone3 { sets, alone }, controller, phi_s, state, x, pitch, r, u),
            Sets::Any(sets) => self.update_with::<9, _>(sets, controller, phi_s, state, x, pitch, r, u),
            // `inline(always)`: the closure inlined into the copy's function, so compiled with
            // its instructions.
            Sets::SizedTrapezoids(sets, n) => out_of_line_in::<COPY, _>(#[inline(always)] || {
                self.update_with::<MAX_RULES, _>(&Sized { sets, n: *n }, controller, phi_s, state, x, pitch, r, u)
            }),
            Sets::SizedAny(sets, n) => out_of_line_in::<COPY, _>(#[inline(always)] || {
                self.update_with::<MAX_RULES, _>(&Sized { sets, n: *n }, controller, phi_s, state, x, pitch, r, u)
            }),
        }
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn update_with<const R: usize, B: RuleBase<Wide<N>, R>>(
        &self,
        basis: &B,
        controller: &FuzzyController<f64>,
        phi_s: f64,
        state: &mut [LawChunk<N>],
        x: &[Lanes; 4],
        pitch: Option<&[Lanes; 2]>,
        r: &SpeedRef<f64>,
        u: &mut Lanes,
    ) {
        let a = controller.adaptation();
        let (keep, per_z2) = a.euler(controller.period());
        let law = Law {
            gains: &self.gains,
            gamma: Wide::splat(a.gamma),
            keep: Wide::splat(keep),
            per_z2: Wide::splat(per_z2),
            adapt: a.enabled,
            period: Wide::splat(controller.period()),
            basis,
            model: &self.model,
        };
        let (phi_s, theta, theta_dot) = (Wide::splat(phi_s), Wide::splat(r.theta), Wide::splat(r.theta_dot));
        for (c, own) in state.iter_mut().enumerate() {
            // The law's constants read where they are, chunk by chunk (`black_box`: the compiler
            // cannot see the law is the same every chunk). Seen so, ~45 vectors of them (the sets,
            // the model) were loaded before the loop and, too many for the registers, copied
            // into the frame every update: the kernels' copies 66 -> 13 (`avx512`) and 142 -> 9
            // (`avx2`), the fuzzy lanes 1.01-1.035x on `avx512` (3 runs of 6-8 pairs), 1.01x on `avx2`.
            let law = core::hint::black_box(&law);
            // R (9, or MAX_RULES for the sized grids) fits the room for MAX_RULES: never fails.
            let s_hat = own.s_hat.first_chunk_mut::<R>().expect("no more rules than MAX_RULES");
            let y = state_chunk(x, c);
            // The plant's sin/cos of the pitch hold where it took them unreduced.
            let given = pitch.filter(|_| y[0].0.iter().all(|phi| phi.abs() <= UNREDUCED)).map(|p| (chunk(&p[0], c), chunk(&p[1], c)));
            let step = law.update(s_hat, &mut own.e_int, phi_s, &y, given, theta, theta_dot);
            put(u, c, step.u);
        }
    }
}

impl FuzzyLanes {
    /// Any sets: trapezoids, triangles and Gaussians (whose e^x is the lanes' polynomial).
    pub fn new(prototype: &FuzzyController<f64>) -> Self {
        Self { controller: *prototype, law: Constants::new(prototype), steady: None }
    }

    /// φ_s at `speed`, as `FuzzyController::update` finds it: cached, since speeds change
    /// rarely.
    #[inline(always)]
    fn steady_pitch(&mut self, speed: f64) -> f64 {
        match self.steady {
            Some((s, phi_s)) if s == speed => phi_s,
            _ => self.solve_steady_pitch(speed),
        }
    }

    /// The law on every lane, from the plant's sin/cos of the pitch where they are `pitch`.
    #[inline(always)]
    fn update_in<const COPY: u8>(&mut self, state: &mut FuzzyState, x: &[Lanes; 4], pitch: Option<&[Lanes; 2]>, r: &SpeedRef<f64>, u: &mut Lanes) {
        let phi_s = self.steady_pitch(r.theta_dot);
        self.law.update::<COPY>(&self.controller, phi_s, &mut state.chunks, x, pitch, r, u)
    }

    #[cold]
    #[inline(never)]
    fn solve_steady_pitch(&mut self, speed: f64) -> f64 {
        let phi_s = self.controller.steady_pitch(speed).unwrap_or(0.0);
        self.steady = Some((speed, phi_s));
        phi_s
    }
}

impl LaneLaw for FuzzyLanes {
    type Shape = Slope;
    type State = FuzzyState;

    fn period(&self) -> f64 {
        self.controller.period()
    }

    fn start(&self) -> FuzzyState {
        let s0 = self.controller.initial_weights();
        let first = LawChunk { s_hat: core::array::from_fn(|j| Wide::splat(s0.get(j).copied().unwrap_or(0.0))), e_int: Wide::splat(0.0) };
        FuzzyState { chunks: core::array::from_fn(|_| first.clone()) }
    }

    #[inline(always)]
    fn update<const COPY: u8>(&mut self, state: &mut FuzzyState, x: &[Lanes; 4], r: &SpeedRef<f64>, u: &mut Lanes) {
        self.update_in::<COPY>(state, x, None, r, u)
    }

    /// g1 from the plant's sin/cos of the pitch, taken once for both (where they hold; else
    /// the law's own). Measured against the law taking its own (`sweep_throughput`, paired
    /// builds, 8 rounds, twice): fuzzy lanes 1.038x and 1.056x on `avx512` (an AVX-512 EPYC),
    /// 1.063x on its forced `avx2` copy (6 rounds).
    #[inline(always)]
    fn update_at_pitch<const COPY: u8>(&mut self, state: &mut FuzzyState, x: &[Lanes; 4], pitch: &[Lanes; 2], r: &SpeedRef<f64>, u: &mut Lanes) {
        self.update_in::<COPY>(state, x, Some(pitch), r, u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Inputs that test a set's edges: ±0, ±∞, NaN, far and `outside` values, and each of
    /// `points` (breakpoints and midpoints) with the f64 either side of it.
    fn around(points: impl IntoIterator<Item = f64>, outside: f64) -> Vec<f64> {
        let inf = f64::INFINITY;
        let mut xs = vec![-inf, inf, f64::NAN, 0.0, -0.0, 1e300, -1e300, -outside, outside];
        for p in points {
            xs.extend([p, next_toward(p, true), next_toward(p, false)]);
        }
        xs
    }

    /// Where [`Alone`] says one set of each input holds every lane alone, the 3 × 3 weights
    /// skipped to a unit vector are the computed ones bit for bit, from the vectors' sets and
    /// the broadcast ones: the thesis's sets, overlapping ramps, triangles, crisp edges and
    /// gaps, at every breakpoint, an ulp either side, ±0, ±∞ and NaN, lanes alike (the skip
    /// taken where it holds) and lanes apart (computed).
    #[test]
    fn weights_skipped_where_one_set_holds_x_alone_are_the_computed_ones() {
        let inf = f64::INFINITY;
        let rows = [
            [(-inf, -inf, -0.3, -0.1), (-0.3, -0.1, 0.1, 0.3), (0.1, 0.3, inf, inf)],
            [(-inf, -inf, -2.0, -0.5), (-2.0, -0.5, 0.5, 2.0), (0.5, 2.0, inf, inf)],
            [(-inf, -inf, -0.2, 0.1), (-0.3, -0.1, 0.1, 0.3), (0.0, 0.3, inf, inf)],
            [(-2.0, -1.0, -1.0, 0.0), (-1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 1.0, 2.0)],
            [(-inf, -inf, -1.0, -1.0), (-1.0, -1.0, 1.0, 1.0), (1.0, 1.0, inf, inf)],
            [(-3.0, -2.0, -1.0, -0.5), (0.0, 0.5, 1.0, 2.0), (2.5, 3.0, 4.0, 5.0)],
        ];
        let same = |a: &[Wide<8>; 9], b: &[Wide<8>; 9]| a.iter().zip(b).all(|(a, b)| a.0.iter().zip(&b.0).all(|(a, b)| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())));
        let points = |row: &[(f64, f64, f64, f64); 3]| around(row.iter().flat_map(|&(a, b, c, d)| [a, b, c, d, 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + d)]), 7.0);
        let mut skipped = 0;
        for row0 in &rows {
            for row1 in &rows {
                let numbers = [row0, row1].map(|row| row.map(|(a, b, c, d)| Trapezoid::new(a, b, c, d)));
                let wide = numbers.map(|row| row.map(|t| t.map(Wide::<8>::splat)));
                let broadcast = numbers.map(|row| row.map(Broadcast));
                let alone = numbers.map(|row| core::array::from_fn(|j| Alone::of(&row, j)));
                let (xs0, xs1) = (points(row0), points(row1));
                for (i, &v0) in xs0.iter().enumerate() {
                    for (k, &v1) in xs1.iter().enumerate() {
                        let alike = [Wide::<8>::splat(v0), Wide::splat(v1)];
                        let apart = [Wide(core::array::from_fn(|l| xs0[(i + l) % xs0.len()])), Wide(core::array::from_fn(|l| xs1[(k + 3 * l) % xs1.len()]))];
                        for x in [alike, apart] {
                            let want = wide.xi(&x);
                            assert!(same(&Alone3 { sets: &wide, alone: &alone }.xi(&x), &want), "{row0:?} {row1:?} at {x:?}");
                            assert!(same(&Alone3 { sets: &broadcast, alone: &alone }.xi(&x), &want), "{row0:?} {row1:?} at {x:?}");
                            skipped += (alone_in(&alone[0], &x[0]).is_some() && alone_in(&alone[1], &x[1]).is_some()) as usize;
                        }
                    }
                }
            }
        }
        // The skip was taken, not only the computation checked against itself.
        assert!(skipped > 5_000, "{skipped}");
    }

    /// A trapezoid read as numbers broadcast at use is the lanes' trapezoid bit for bit,
    /// membership and distance, at its breakpoints, an ulp either side, ±∞ and NaN, a
    /// different x on each lane: it guards the numbers' way into the lanes (each breakpoint to
    /// its field); that the AVX-512 kernel built on it gives the other copies' bits is
    /// `same_bits_on_every_copy`'s (the thesis's law, both widths).
    #[test]
    fn a_broadcast_trapezoid_is_the_lanes_trapezoid_bit_for_bit() {
        let inf = f64::INFINITY;
        let sets = [
            (0.0, 1.0, 2.0, 4.0), (-inf, -inf, -0.3, -0.1), (-0.3, -0.1, 0.1, 0.3), (0.1, 0.3, inf, inf),
            (1.0, 1.0, 2.0, 2.0), (1.0, 1.0, 1.0, 1.0), (-2.0, 0.5, 0.5, 0.7), (-1e-3, 0.0, 1e300, 1e301),
        ];
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        for (a, b, c, d) in sets {
            let t = Trapezoid::new(a, b, c, d);
            let (lanes, broadcast) = (t.map(Wide::<8>::splat), Broadcast(t));
            let xs = around([a, b, c, d, 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + d)], 5.0);
            for chunk in xs.chunks(8) {
                let x = Wide::<8>(core::array::from_fn(|j| chunk[j % chunk.len()]));
                for (want, got) in [(lanes.value(x), broadcast.value(x)), (lanes.distance(x), broadcast.distance(x))] {
                    assert!(want.0.iter().zip(&got.0).all(|(w, g)| same(*w, *g)), "({a}, {b}, {c}, {d}) at {x:?}: {got:?} vs {want:?}");
                }
            }
        }
    }
}
