//! The fast path of a sweep: [`LANES`] samples at once on the 2-DOF model, for every
//! controller family with a law on lanes ([`LaneLaw`] of the [`Slope`] shape: LQR, fuzzy
//! backstepping + PD).
//!
//! Each lane is its own robot (plant coefficients per lane); the controller is the one
//! prototype designed on the nominal robot, each lane with its own controller state.
//! The physics is the run's own source: `model::slope::deriv`, `model::integrate::rk4`,
//! the controllers' laws and `sim::metrics::Tally`, instantiated on [`Fused`] lanes, whose
//! multiply-adds are fused (one rounding instead of two). A lane therefore agrees with
//! `runner::simulate` for that robot to rounding (~1e-14 relative over 10 s), not bit
//! for bit; it is bit for bit the same on every CPU, thread count and block neighbour,
//! because a fused multiply-add is exactly rounded wherever it runs. What is here is the
//! data layout (one array per quantity, loops over lanes that the compiler vectorises)
//! and the 2-DOF hooks ([`SlopePlants`], and [`SlopeLanes`], the rig's lanes' observer too) of
//! the one closed loop (`sim::closed_loop`), which is written once for the runner and the
//! 2-DOF and 3-DOF lanes, ideal and through a rig, on a block
//! ([`closed_loop`](closed_loop::closed_loop)).
use closed_loop::{closed_loop, Aligned, Observer};
use crate::control::reference::{SpeedRef, SpeedSchedule};
use crate::model::dynamics::Halt;
use crate::control::Reference;
use crate::model::integrate::{rk4, stage_state, Field, Stage};
use crate::model::lane::{Fused, Lane, Wide, WIDTH};
use crate::model::math::{sin_cos_fused_from, sin_cos_plus, sin_cos_unreduced_from, SHIFT_LIMIT, SIN_COS, UNREDUCED};
use crate::model::slope::{deriv_at, SlopeCoefficients, SlopeModel};
use core::cell::Cell;
use crate::sim::drive_metrics::{DriveTally, DRIVE_TALLIES};
use crate::sim::metrics::{pitch_band, steady_pitch, Aim, DrivePeaks, SlopeSummary, Tally};
use crate::sim::runner::SimConfig;
use crate::sweep::lanes::{fast_where_every_live, mask, where_live, Lanes, LANES};
use crate::sweep::{Sample, SampleMetrics, SweepMetrics};
use crate::TwipError;
use core::sync::atomic::{AtomicU8, Ordering};

mod closed_loop;
mod fuzzy;
mod kinds;
mod law;
mod lqr;
mod planar;
mod planar_rig;
mod planar_rig_lanes;
mod planar_terrain;
mod rig;
mod rig_context;
mod rig_lanes;
mod smc;
mod winding;
pub use fuzzy::FuzzyLanes;
pub use law::{LaneLaw, Planar, Shape, Slope};
pub use lqr::LqrLanes;
pub use planar::{run_planar_block, BlockGround, Flat, LanePath, PidLanes};
pub use planar_terrain::{FeedForwardLanes, TerrainLanes};
#[cfg(feature = "parallel")] // the envs' only use, and they build with `parallel`
pub(crate) use {planar::Plants as PlanarPlants, planar_rig_lanes::PlanarRigLanes, rig_lanes::RigLanes};
pub use planar_rig::run_planar_rig_block;
pub use rig::run_rig_block;
pub use smc::SmcLanes;

/// [`Wide`] vectors in a block.
pub(crate) const CHUNKS: usize = LANES / WIDTH;

/// Lanes `c·N ..` of a quantity, as one vector.
#[inline(always)]
pub(crate) fn chunk<const N: usize>(v: &Lanes, c: usize) -> Wide<N> {
    let mut out = [0.0; N];
    out.copy_from_slice(&v[c * N..(c + 1) * N]);
    Wide(out)
}

/// Writes a vector back to lanes `c·N ..`.
#[inline(always)]
pub(crate) fn put<const N: usize>(v: &mut Lanes, c: usize, w: Wide<N>) {
    v[c * N..(c + 1) * N].copy_from_slice(&w.0);
}

/// The state's chunk `c`.
#[inline(always)]
pub(crate) fn state_chunk<const N: usize>(x: &[Lanes; 4], c: usize) -> [Wide<N>; 4] {
    [chunk(&x[0], c), chunk(&x[1], c), chunk(&x[2], c), chunk(&x[3], c)]
}

/// Plant coefficients, one array per coefficient, one entry per lane. Aligned to a cache
/// line, which makes the kernel's stack frame 64-byte aligned, so that its lanes' vector
/// loads and stores do not straddle two lines: without it the wheel's LQR kernel ran its
/// frame at 40 bytes past a line and swept ~1.13x slower. `tests/test_kernel_frames.py`
/// reads the wheel's machine code to check every kernel's frame.
#[repr(C, align(64))]
pub(crate) struct Plants([Lanes; 14], [Lanes; SIN_COS.len()]);

impl Plants {
    pub(crate) fn new(c: &[SlopeCoefficients<f64>; LANES]) -> Self {
        let per_lane = c.map(|k| Self::fields(&k));
        Self(core::array::from_fn(|f| core::array::from_fn(|l| per_lane[l][f])), SIN_COS.map(|c| [c; LANES]))
    }

    /// Lane `l`'s coefficients set to `k` (a robot started anew), the others' as they are.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn set_lane(&mut self, l: usize, k: &SlopeCoefficients<f64>) {
        for (field, v) in self.0.iter_mut().zip(Self::fields(k)) {
            field[l] = v;
        }
    }

    /// A robot's coefficients in the order of the arrays.
    fn fields(k: &SlopeCoefficients<f64>) -> [f64; 14] {
        [
            k.m11, k.m22, k.m11_m22, k.mrl, k.mrl_cos, k.mrl_sin, k.rotor, k.mgl, k.grade, k.torque_per_amp,
            k.mu_bearing, k.mu_ground, k.sin_slope, k.cos_slope,
        ]
    }

    /// sin/cos's terms (`math::SIN_COS`) as lanes, for `math::kernel_from` (`lane_terms`):
    /// each a vector load that a multiply-add takes as its operand. Behind `black_box`, so that
    /// the compiler reads them as lanes and not as the constants they are; taken once, out of a
    /// loop over lanes (inside it, the barrier kept the loop scalar: 3x the instructions).
    #[inline(always)]
    pub(crate) fn sin_cos_terms(&self) -> &[Lanes; SIN_COS.len()] {
        core::hint::black_box(&self.1)
    }

    /// Lane `l`'s coefficients.
    #[inline(always)]
    fn lane(&self, l: usize) -> SlopeCoefficients<Fused> {
        let f = |i: usize| Fused(self.0[i][l]);
        SlopeCoefficients {
            m11: f(0),
            m22: f(1),
            m11_m22: f(2),
            mrl: f(3),
            mrl_cos: f(4),
            mrl_sin: f(5),
            rotor: f(6),
            mgl: f(7),
            grade: f(8),
            torque_per_amp: f(9),
            mu_bearing: f(10),
            mu_ground: f(11),
            sin_slope: f(12),
            cos_slope: f(13),
        }
    }

    /// One RK4 step, the input held, on every lane. The whole step of a lane is one loop
    /// body in [`Fused`] numbers (bit for bit [`Wide`]'s), which the compiler vectorises
    /// across lanes with every intermediate kept in registers; each body advances two
    /// lanes (l and l + LANES/2) stage by stage, two independent chains of dependent
    /// operations that the CPU overlaps. (Measured faster than RK4 on `Wide` chunks.)
    #[inline(always)]
    pub(crate) fn rk4(&self, x: &[Lanes; 4], u: &Lanes, dt: f64) -> [Lanes; 4] {
        let mut next = [[0.0; LANES]; 4];
        self.rk4_in::<false>(x, &[[0.0; LANES]; 2], u, dt, &mut next, &mut [u64::MAX; LANES]);
        next
    }

    /// [`Self::rk4`]'s step, into `next`, where every `live` lane's pitch starts within
    /// ±[`UNREDUCED`] and moves by at most [`SHIFT_LIMIT`] to each later stage, else
    /// `reduced`'s (the caller's `rk4`; the other lanes' steps do not count), from the first
    /// stage's sin/cos `pitch` ([`Self::pitch_sin_cos`] of `x`, taken before for the law too).
    /// There sin/cos skip the reduction by π/2 and the quadrant's rotation, which change
    /// nothing there, and every later stage's sin/cos is shifted from the first's
    /// (`Plant::at_offset`), as `rk4`'s is there: the same bits, and each stage's chain
    /// shorter. A loop over lanes cannot branch per lane, so the range is checked after the
    /// step. Measured (new/old CPU time, 6 pairs): unreduced,
    /// LQR lanes 1.055x, fuzzy 1.095x on `avx512`, 1.083x and 1.067x on its forced `avx2`
    /// copy (an AVX-512 EPYC); on an AVX2-only EPYC (`avx2`) 1.052x and 1.187x; then shifted,
    /// 1.086x and 1.066x on `avx512`, 1.040x and 1.018x on `avx2`, on an AVX-512 EPYC
    /// (docs/performance.md).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn rk4_unreduced_into(&self, x: &[Lanes; 4], pitch: &[Lanes; 2], u: &Lanes, dt: f64, live: &[bool; LANES], next: &mut [Lanes; 4], reduced: impl FnOnce(&mut [Lanes; 4])) {
        fast_where_every_live(live, next, #[inline(always)] |next, inside| self.rk4_in::<true>(x, pitch, u, dt, next, inside), reduced)
    }

    /// [`Self::rk4_unreduced_into`]'s step, None where it would take the reduced one.
    #[cfg(test)]
    fn rk4_unreduced(&self, x: &[Lanes; 4], u: &Lanes, dt: f64, live: &[bool; LANES]) -> Option<[Lanes; 4]> {
        let (mut next, mut reduced) = ([[f64::NAN; LANES]; 4], false);
        self.rk4_unreduced_into(x, &self.pitch_sin_cos(x), u, dt, live, &mut next, |_| reduced = true);
        (!reduced).then_some(next)
    }

    /// sin and cos of every lane's pitch x[0] without the reduction by π/2: right where
    /// |x[0]| ≤ [`UNREDUCED`], which [`Self::rk4_unreduced_into`] checks.
    #[inline(always)]
    pub(crate) fn pitch_sin_cos(&self, x: &[Lanes; 4]) -> [Lanes; 2] {
        let terms = self.sin_cos_terms();
        let mut out = [[0.0; LANES]; 2];
        for l in 0..LANES {
            (out[0][l], out[1][l]) = sin_cos_unreduced_from(x[0][l], |i| terms[i][l]);
        }
        out
    }

    /// The step into `out`, with sin/cos unreduced or not, and whether each lane's pitch started
    /// within ±[`UNREDUCED`] and moved by at most [`SHIFT_LIMIT`] a stage, as a [`mask`] in
    /// `inside` (unreduced; else left as it is). `pitch`: the first stage's sin/cos, read when
    /// unreduced (the reduced step takes its own).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn rk4_in<const UNREDUCED_SIN: bool>(&self, x: &[Lanes; 4], pitch: &[Lanes; 2], u: &Lanes, dt: f64, out: &mut [Lanes; 4], inside: &mut [u64; LANES]) {
        const HALF: usize = LANES / 2;
        let mut lanes_inside = [u64::MAX; LANES];
        let state = |l: usize| [Fused(x[0][l]), Fused(x[1][l]), Fused(x[2][l]), Fused(x[3][l])];
        let terms = self.sin_cos_terms();
        let plant = |l: usize| Plant::<UNREDUCED_SIN> {
            k: self.lane(l),
            terms: lane_terms(terms, l),
            u: Fused(u[l]),
            inside: Cell::new(u64::MAX),
            start: Cell::new((0.0, 1.0)),
            first: (pitch[0][l], pitch[1][l]),
        };
        for l in 0..HALF {
            let m = l + HALF;
            let (pa, pb) = (plant(l), plant(m));
            let (xa, xb) = (state(l), state(m));
            let next_a = rk4(&pa, &xa, &pa.at(&xa), Fused(dt));
            let next_b = rk4(&pb, &xb, &pb.at(&xb), Fused(dt));
            for i in 0..4 {
                out[i][l] = next_a[i].0;
                out[i][m] = next_b[i].0;
            }
            (lanes_inside[l], lanes_inside[m]) = (pa.inside.get(), pb.inside.get());
        }
        if UNREDUCED_SIN {
            *inside = lanes_inside;
        }
    }
}

/// Lane `l` of sin/cos's `terms` ([`Plants::sin_cos_terms`]).
#[inline(always)]
pub(crate) fn lane_terms(terms: &[Lanes; SIN_COS.len()], l: usize) -> [f64; SIN_COS.len()] {
    core::array::from_fn(|i| terms[i][l])
}

/// One lane's plant with its input held; `UNREDUCED_SIN`: sin/cos without the reduction,
/// noting in `inside` (a [`mask`]) whether each pitch it saw allowed that.
struct Plant<const UNREDUCED_SIN: bool> {
    k: SlopeCoefficients<Fused>,
    terms: [f64; SIN_COS.len()],
    u: Fused,
    inside: Cell<u64>,
    /// sin/cos of the step's first pitch (`at`), which the later stages shift.
    start: Cell<(f64, f64)>,
    /// The first pitch's unreduced sin/cos, taken before the step (`UNREDUCED_SIN` only).
    first: (f64, f64),
}

impl<const UNREDUCED_SIN: bool> Field<Fused, 4> for Plant<UNREDUCED_SIN> {
    #[inline(always)]
    fn at(&self, x: &[Fused; 4]) -> [Fused; 4] {
        let phi = x[0].0;
        let (s, c) = if UNREDUCED_SIN {
            // NaN is outside.
            self.inside.set(self.inside.get() & mask(phi.abs() <= UNREDUCED));
            self.first
        } else {
            sin_cos_fused_from(phi, |i| self.terms[i])
        };
        self.start.set((s, c));
        deriv_at(&self.k, x, self.u, (Fused(s), Fused(c)))
    }

    /// A later stage's sin/cos: the first's shifted by d = k₀ h (`stage_sin_cos`; 14
    /// operations, not `kernel_from`'s 19, for all of the pitch's sin/cos but the first).
    #[inline(always)]
    fn at_offset(&self, x: &[Fused; 4], k: &[Fused; 4], h: Fused, _: Stage) -> [Fused; 4] {
        let stage = stage_state(x, k, h);
        let own = || sin_cos_fused_from(stage[0].0, |i| self.terms[i]);
        let (s, c) = stage_sin_cos::<UNREDUCED_SIN>(self.start.get(), k[0] * h, |i| Fused(self.terms[i]), &self.inside, own);
        deriv_at(&self.k, &stage, self.u, (s, c))
    }
}

/// A later RK4 stage's sin/cos in a lanes' plant (`Field::at_offset`): the step's first,
/// `start`, shifted by `d` (`math::sin_cos_plus`) where |d| ≤ [`SHIFT_LIMIT`], else the stage's
/// `own`. `SHIFT_ONLY` (a fast step): the shift alone, noting in `near` (a [`mask`]) whether it holds;
/// else both, and the one that holds selected, so that a lane's bits are the same either way.
#[inline(always)]
pub(crate) fn stage_sin_cos<const SHIFT_ONLY: bool>(
    start: (f64, f64),
    d: Fused,
    coef: impl Fn(usize) -> Fused,
    near: &Cell<u64>,
    own: impl FnOnce() -> (f64, f64),
) -> (Fused, Fused) {
    let shifted = sin_cos_plus((Fused(start.0), Fused(start.1)), d, coef);
    // NaN is not near.
    let holds = d.0.abs() <= SHIFT_LIMIT;
    if SHIFT_ONLY {
        near.set(near.get() & mask(holds));
        return shifted;
    }
    let (s, c) = own();
    if holds { shifted } else { (Fused(s), Fused(c)) }
}

/// [`Tally`] on every lane, one array per field, and what each lane's observations are
/// measured against. Laid out as written (`repr(C)`) from a cache line's boundary, so that every
/// array of lanes starts on one, as the loop's input (`sim::closed_loop::Aligned`): the optional drive
/// tallies, whose tag would shift what follows, last.
#[repr(C, align(64))]
struct Metrics {
    tally: [Lanes; 6],
    samples: [u64; LANES],
    band: Lanes,
    radius: Lanes,
    /// Each lane's driver's gearbox efficiency (`Observer::drive_efficiency`; 1 without one).
    efficiency: Lanes,
    /// [`DriveTally`] on every lane, once a rig's lanes observe what the plants got ([`Self::drive`]);
    /// ideal lanes' plants get the commands.
    drive: Option<[Lanes; DRIVE_TALLIES]>,
}

/// What the lanes share of an observation's aim: the time and the reference.
struct Shared {
    t: f64,
    r: SpeedRef<f64>,
    speed_scale: f64,
    direction: f64,
}

impl Shared {
    /// The aim at time `t`: the reference then, and the speed scale and direction as they
    /// stand with it.
    fn at(t: f64, reference: &SpeedSchedule<f64>, speed_scale: f64, direction: f64) -> Self {
        let r = reference.sample(t);
        let towards = if r.theta_dot != 0.0 { r.theta_dot.signum() } else { direction };
        Shared { t, r, speed_scale: speed_scale.max(r.theta_dot.abs()), direction: towards }
    }
}

impl Metrics {
    fn new(radius: Lanes, x: &[Lanes; 4], phi_s: &Lanes) -> Self {
        Self {
            tally: [[0.0; LANES]; 6],
            drive: None,
            efficiency: [1.0; LANES],
            samples: [0; LANES],
            band: core::array::from_fn(|l| pitch_band(phi_s[l], x[0][l])),
            radius,
        }
    }

    /// Lane `l`'s tally.
    #[inline(always)]
    fn get(&self, l: usize) -> Tally<Fused> {
        let f = |i: usize| Fused(self.tally[i][l]);
        Tally {
            sum_pitch: f(0),
            sum_speed: f(1),
            pitch_settle: f(2),
            speed_settle: f(3),
            final_position_error: f(4),
            peak_abs_input: f(5),
        }
    }

    #[inline(always)]
    fn set(&mut self, l: usize, t: &Tally<Fused>) {
        let values = [t.sum_pitch, t.sum_speed, t.pitch_settle, t.speed_settle, t.final_position_error, t.peak_abs_input];
        for (i, v) in values.iter().enumerate() {
            self.tally[i][l] = v.0;
        }
    }

    /// Lane `l` has fallen into `x` at `at.t`: the runner observes that state, then stops.
    /// Only this lane is observed: only its steady pitch (robot `model`) is needed.
    fn observe_fall(&mut self, l: usize, x: &[Lanes; 4], u: &Lanes, model: &SlopeModel<f64>, phi_s: &Lanes, at: &Shared) {
        let mut phi_s_next = *phi_s;
        phi_s_next[l] = steady_pitch(model, at.r.theta_dot);
        self.observe(&only(l), x, u, &phi_s_next, at);
    }

    /// The runner's last observation at the end (`at`, after `n` steps) of the lanes still
    /// `alive`, then the metrics of every `active` lane into `out`, with how each `ended`.
    #[allow(clippy::type_complexity, clippy::too_many_arguments)]
    fn finish(
        &mut self,
        out: &mut [SampleMetrics; LANES],
        (alive, active, ended): (&[bool; LANES], &[bool; LANES], &mut [(bool, f64, u64); LANES]),
        x: &[Lanes; 4],
        u: &Lanes,
        models: &[SlopeModel<f64>; LANES],
        at: &Shared,
        n: usize,
    ) {
        self.observe(alive, x, u, &steady_pitches(models, at.r.theta_dot), at);
        for l in 0..LANES {
            if alive[l] {
                ended[l] = (false, at.t, n as u64);
            }
            if active[l] {
                out[l] = self.summary(l, &models[l], ended[l]);
            }
        }
    }

    /// Lane `l`'s metrics, for its robot `model` and how it ended: (fell, t_end, steps).
    fn summary(&self, l: usize, model: &SlopeModel<f64>, (fell, t_end, steps): (bool, f64, u64)) -> SampleMetrics {
        let count = self.samples[l].max(1) as f64;
        let tally = self.get(l);
        let commanded = tally.peak_abs_input.0;
        let peaks = match &self.drive {
            Some(drive) => {
                let tally = DriveTally::from_array(drive.map(|v| v[l]));
                DrivePeaks::of_slope_run(model.params(), &tally, commanded, self.efficiency[l])
            }
            // The plant got the command: the ideal loop's peak over each step's start is
            // the commanded one (the last sample's input is the last step's), and the
            // loop clamps nothing.
            None => DrivePeaks::from_lumped_current(model.params(), commanded, commanded, 0.0, 1.0),
        };
        let summary = SlopeSummary {
            mean_abs_pitch_error: tally.sum_pitch.0 / count,
            mean_abs_speed_error: tally.sum_speed.0 / count,
            pitch_settling_time: tally.pitch_settle.0,
            speed_settling_time: tally.speed_settle.0,
            final_position_error: tally.final_position_error.0,
            peak_abs_input: tally.peak_abs_input.0,
            peak_current: peaks.current,
            peak_torque: peaks.torque,
            peak_command: peaks.command,
            saturation_share: peaks.saturation_share,
            samples: self.samples[l] as usize,
        };
        SampleMetrics::from_summary(&summary, fell, t_end, steps)
    }

    /// What the `live` lanes' plants get at a step's start, as a run's observer sees it
    /// (`Observer::drive`): the input after the driver, and at a controller update
    /// (`update`) whether each lane's command applied from then on is `beyond` the driver.
    #[inline(always)]
    fn drive(&mut self, live: &[bool; LANES], delivered: &Lanes, update: bool, beyond: &[bool; LANES]) {
        let drive = self.drive.get_or_insert([[0.0; LANES]; DRIVE_TALLIES]);
        for l in 0..LANES {
            let mut tally = DriveTally::from_array(core::array::from_fn(|i| Fused(drive[i][l])));
            tally.observe(live[l], Fused(delivered[l]).magnitude(), update, beyond[l]);
            for (i, v) in tally.to_array().into_iter().enumerate() {
                drive[i][l] = v.0;
            }
        }
    }

    /// Observes the lanes that are `live`: a loop over lanes without branches, which the
    /// compiler vectorises, without the alive masks while every lane is live (`where_live`).
    #[inline(always)]
    fn observe(&mut self, live: &[bool; LANES], x: &[Lanes; 4], u: &Lanes, phi_s: &Lanes, shared: &Shared) {
        where_live(live, #[inline(always)] |live| {
            for l in 0..LANES {
                let aim = Aim {
                    t: Fused(shared.t),
                    phi_s: Fused(phi_s[l]),
                    band: Fused(self.band[l]),
                    theta_dot: Fused(shared.r.theta_dot),
                    theta: Fused(shared.r.theta),
                    speed_band: Fused(0.02 * shared.speed_scale),
                    direction: Fused(shared.direction),
                    wheel_radius: Fused(self.radius[l]),
                };
                let state = [Fused(x[0][l]), Fused(x[1][l]), Fused(x[2][l]), Fused(x[3][l])];
                let mut tally = self.get(l);
                tally.observe(live[l], &state, Fused(u[l]), &aim);
                self.set(l, &tally);
                self.samples[l] += live[l] as u64;
            }
        });
    }
}

/// The plants' own steady pitch at a reference speed, per lane (as `SlopeMetrics`).
fn steady_pitches(models: &[SlopeModel<f64>; LANES], speed: f64) -> Lanes {
    core::array::from_fn(|l| steady_pitch(&models[l], speed))
}

/// Only lane `l`.
pub(crate) fn only(l: usize) -> [bool; LANES] {
    core::array::from_fn(|i| i == l)
}

/// Moves the lanes that go on (alive, the new state finite and its pitch, entry `pitch`,
/// within the fall limit) to their new state `next`; returns each lane's mask, all ones
/// where it went on, and whether some lane alive ends. Lane by lane, each lane's entries in
/// turn, on 64-bit lane masks (`mask`): one loop whose body the compiler makes vector
/// instructions across the lanes. Entry by entry with `bool` flags, circle-pid's `avx512`
/// kernel ran 1.10x the time (1.07-1.13, 10 paired runs of `sweep_throughput pid-lanes
/// 2048`; fuzzy and LQR within noise).
#[inline(always)]
pub(crate) fn go_on<const N: usize>(
    x: &mut [Lanes; N],
    next: &[Lanes; N],
    alive: &[bool; LANES],
    pitch: usize,
    fall_limit: f64,
) -> ([u64; LANES], bool) {
    let mut goes_on = [0u64; LANES];
    let mut ends = 0u64;
    for l in 0..LANES {
        let live = mask(alive[l]);
        let mut take = live & mask(next[pitch][l].abs() <= fall_limit);
        for entry in next {
            take &= mask(entry[l].is_finite());
        }
        for (xi, ni) in x.iter_mut().zip(next) {
            xi[l] = f64::from_bits((ni[l].to_bits() & take) | (xi[l].to_bits() & !take));
        }
        goes_on[l] = take;
        ends |= live & !take;
    }
    (goes_on, ends != 0)
}

/// Whether lane `l` of a state is finite in every entry.
#[inline(always)]
pub(crate) fn finite_at<const N: usize>(x: &[Lanes; N], l: usize) -> bool {
    let mut finite = true;
    for v in x {
        finite &= v[l].is_finite();
    }
    finite
}

/// Which copy of the lane kernels (`multiversioned!`) the sweeps run: the widest this CPU
/// has instructions for, unless a narrower one was chosen ([`KernelCopy::choose`]). Speeds
/// measured on one copy say little about another.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum KernelCopy {
    /// x86-64 with AVX-512 (avx512f) and FMA: 8 f64 per vector.
    Avx512 = 1,
    /// x86-64 with AVX2 and FMA: 4 f64 per vector.
    Avx2 = 2,
    /// Any other CPU: the compiler's baseline, `mul_add` through libm's `fma`. On x86-64
    /// only with the `baseline-copy` feature (see [`KernelCopy::compiled`]).
    Baseline = 3,
}

/// The copy chosen with [`KernelCopy::choose`] (its `u8`), 0 for none: the widest.
static CHOSEN: AtomicU8 = AtomicU8::new(0);

// The tests run every copy's kernels against each other.
#[cfg(all(test, target_arch = "x86_64", not(feature = "baseline-copy")))]
compile_error!("twip-core's sweep tests run the baseline kernel copy: test with the `baseline-copy` feature (on by default)");

/// Whether this build holds the baseline copy ([`KernelCopy::compiled`]).
const BASELINE_COMPILED: bool = cfg!(any(not(target_arch = "x86_64"), feature = "baseline-copy"));

/// Where a kernel would run the baseline copy that this build does not hold: only on an
/// x86-64 CPU without AVX2 or FMA, which a program using such a build refuses first
/// (`KernelCopy::detect().compiled()`; the Python module does at import).
#[cfg(all(target_arch = "x86_64", not(feature = "baseline-copy")))]
#[cold]
pub(crate) fn no_baseline_copy() -> ! {
    panic!("this build of twip-core holds no baseline kernel copy (built without its `baseline-copy` feature), which this CPU (no AVX2 or FMA) needs")
}

impl KernelCopy {
    /// Every copy, widest first.
    pub const ALL: [Self; 3] = [Self::Avx512, Self::Avx2, Self::Baseline];

    /// The widest copy this CPU has instructions for (the features are detected once and
    /// cached by std).
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            let fma = std::is_x86_feature_detected!("fma");
            if fma && std::is_x86_feature_detected!("avx512f") {
                return Self::Avx512;
            }
            if fma && std::is_x86_feature_detected!("avx2") {
                return Self::Avx2;
            }
        }
        Self::Baseline
    }

    /// Whether this CPU has the instructions this copy uses: the detected copy and every
    /// narrower one.
    pub fn runs_here(self) -> bool {
        self as u8 >= Self::detect() as u8
    }

    /// Whether this build holds the copy. Every build holds the vector copies (x86-64) and
    /// the baseline one on other CPUs; on x86-64 the baseline copy (for CPUs without AVX2
    /// and FMA) comes with the `baseline-copy` feature, on by default. `make` builds its wheel
    /// without it on a CPU with AVX2 and FMA: that copy is about a third of the kernels'
    /// optimiser time, and such a CPU never runs it.
    pub const fn compiled(self) -> bool {
        !matches!(self, Self::Baseline) || BASELINE_COMPILED
    }

    /// The copy the sweeps run now: the chosen one, else the widest.
    pub fn active() -> Self {
        match CHOSEN.load(Ordering::Relaxed) {
            1 => Self::Avx512,
            2 => Self::Avx2,
            3 => Self::Baseline,
            _ => Self::detect(),
        }
    }

    /// Makes every sweep of this process from now on run `copy` (None: the widest again),
    /// to measure what a CPU without the wider instructions gets. Every copy gives the
    /// same bits, so a sweep under way may change copy between blocks. A copy this CPU
    /// lacks, or this build does not hold ([`Self::compiled`]), is refused: `Err` holds the
    /// widest this CPU has.
    pub fn choose(copy: Option<Self>) -> Result<Self, Self> {
        match copy {
            Some(c) if !c.runs_here() || !c.compiled() => Err(Self::detect()),
            _ => {
                CHOSEN.store(copy.map_or(0, |c| c as u8), Ordering::Relaxed);
                Ok(Self::active())
            }
        }
    }

    /// "avx512", "avx2" or "baseline".
    pub fn name(self) -> &'static str {
        match self {
            Self::Avx512 => "avx512",
            Self::Avx2 => "avx2",
            Self::Baseline => "baseline",
        }
    }
}

/// A block runner compiled three times on x86-64: for AVX-512, for AVX2 with FMA and for
/// the baseline CPU, the one [`KernelCopy::active`] names picked at run time (wheels are
/// built for the baseline CPU). All copies give the same bits: the baseline copy computes
/// each `mul_add` with libm's exactly rounded `fma`, a call per value (20× slower than the
/// AVX2 copy, measured; x86-64 CPUs older than 2013). `$run` dispatches to `$avx512`,
/// `$avx2` or `$base`, each `$inner`. An `$inner` whose generics end in `; const COPY` (a
/// `const COPY: u8`, a [`KernelCopy`] as `u8`) learns which copy it is in (see
/// [`out_of_line_in`]).
macro_rules! multiversioned {
    ($(#[$doc:meta])* pub fn $run:ident, $avx512:ident, $avx2:ident, $base:ident
        = $inner:ident<$($c:ident: $bound:path),+ $(; const $copy:ident)?>($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty) => {
        $(#[$doc])*
        pub fn $run<$($c: $bound),+>($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: each copy runs only on a CPU that has its instructions.
            match $crate::sweep::block::KernelCopy::active() {
                $crate::sweep::block::KernelCopy::Avx512 => return unsafe { $avx512($($arg),*) },
                $crate::sweep::block::KernelCopy::Avx2 => return unsafe { $avx2($($arg),*) },
                $crate::sweep::block::KernelCopy::Baseline => {}
            }
            #[cfg(any(not(target_arch = "x86_64"), feature = "baseline-copy"))]
            {
                $base($($arg),*)
            }
            #[cfg(all(target_arch = "x86_64", not(feature = "baseline-copy")))]
            {
                $crate::sweep::block::no_baseline_copy()
            }
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,fma")]
        unsafe fn $avx512<$($c: $bound),+>($($arg: $ty),*) -> $ret {
            multiversioned!(@call $inner [$($c),+] [$($copy)?] { $crate::sweep::block::KernelCopy::Avx512 as u8 } ($($arg),*))
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        unsafe fn $avx2<$($c: $bound),+>($($arg: $ty),*) -> $ret {
            multiversioned!(@call $inner [$($c),+] [$($copy)?] { $crate::sweep::block::KernelCopy::Avx2 as u8 } ($($arg),*))
        }

        #[cfg(any(not(target_arch = "x86_64"), feature = "baseline-copy"))]
        #[inline(never)]
        fn $base<$($c: $bound),+>($($arg: $ty),*) -> $ret {
            multiversioned!(@call $inner [$($c),+] [$($copy)?] { $crate::sweep::block::KernelCopy::Baseline as u8 } ($($arg),*))
        }
    };
    (@call $inner:ident [$($c:ident),+] [] $copy:block ($($arg:ident),*)) => {
        $inner($($arg),*)
    };
    (@call $inner:ident [$($c:ident),+] [$flag:ident] $copy:block ($($arg:ident),*)) => {
        $inner::<$($c,)+ $copy>($($arg),*)
    };
}
pub(crate) use multiversioned;

/// Runs `f` out of line, as a function of its own compiled for `COPY`'s instructions: the
/// rigs' kernels call each plant kind (`by_kind!`) through it, and every kernel the fuzzy
/// laws' sized n × n forms (`FuzzyLanes`, `SmcLanes`; once per copy, shared by the ideal and
/// the rig kernels). Inlined, those made the twelve kernels that run a fuzzy law take 87 %
/// of the wheel's optimiser time (loop rotation, SROA, full unrolling). Inlined into the kernels, the
/// 54 kinds of the 2-DOF rig and 18 of the 3-DOF one were compiled again for every
/// controller law and made functions so large that the optimiser's time grew faster than
/// their size: the wheel's build took 13 minutes of CPU, almost all in them. Out of line,
/// each kind is compiled once per copy, shared by the laws (the kinds are not generic over
/// them). Same bits. (The baseline copy's kinds were out of line already: inlined, they made
/// its frame ~2 MB, a thread's whole stack.)
#[inline(always)]
pub(super) fn out_of_line_in<const COPY: u8, R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: a kernel's copy `COPY` runs only on a CPU that has its instructions.
        if COPY == KernelCopy::Avx512 as u8 {
            return unsafe { avx512(f) };
        }
        if COPY == KernelCopy::Avx2 as u8 {
            return unsafe { avx2(f) };
        }
    }
    #[cfg(any(not(target_arch = "x86_64"), feature = "baseline-copy"))]
    {
        baseline(f)
    }
    #[cfg(all(target_arch = "x86_64", not(feature = "baseline-copy")))]
    {
        no_baseline_copy()
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,fma")]
#[inline(never)]
unsafe fn avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(any(not(target_arch = "x86_64"), feature = "baseline-copy"))]
#[inline(never)]
fn baseline<R>(f: impl FnOnce() -> R) -> R {
    f()
}

type BlockResult = Result<Option<[SampleMetrics; LANES]>, TwipError>;

multiversioned! {
    /// Runs up to [`LANES`] samples with `controller`'s law (fewer fill the rest of the
    /// block with idle lanes). `should_stop` is asked every `runner::STOP_CHECK_STEPS`
    /// steps; `Ok(None)` means it said yes before the block was done. Compiled once per
    /// x86-64 vector width, all giving the same bits (`multiversioned`).
    pub fn run_block, block_avx512, block_avx2, block_baseline = block<C: LaneLaw<Shape = Slope>; const COPY>(
        controller: C,
        reference: &SpeedSchedule<f64>,
        config: &SimConfig<f64>,
        samples: &[Sample],
        should_stop: &dyn Fn() -> bool,
    ) -> BlockResult
}

#[inline(always)]
fn block<C: LaneLaw<Shape = Slope>, const COPY: u8>(
    mut controller: C,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    samples: &[Sample],
    should_stop: &dyn Fn() -> bool,
) -> Result<Option<[SampleMetrics; LANES]>, TwipError> {
    assert!(samples.len() <= LANES, "a block holds at most {LANES} samples");
    let steps = config.steps(controller.period())?;
    // Invalid or missing samples run an idle copy of a valid robot and are never kept.
    let mut active = [false; LANES];
    let mut models = [None; LANES];
    for (l, s) in samples.iter().enumerate() {
        if s.x0.iter().all(|v| v.is_finite()) {
            models[l] = SlopeModel::new(s.params, s.slope).ok();
            active[l] = models[l].is_some();
        }
    }
    let Some(fallback) = models.iter().flatten().next().copied() else {
        return Ok(Some([SampleMetrics::INVALID; LANES]));
    };
    let models: [SlopeModel<f64>; LANES] = core::array::from_fn(|l| models[l].unwrap_or(fallback));
    let x: [Lanes; 4] = core::array::from_fn(|i| {
        core::array::from_fn(|l| if active[l] { samples[l].x0[i] } else { 0.0 })
    });
    let plants = Plants::new(&core::array::from_fn(|l| models[l].coefficients()));
    let (mut plant_phi_s, mut metrics) = SlopeLanes::metrics(&models, reference, &x);
    let mut x = Aligned(x);
    let mut pitch = None;
    let plant = SlopePlants { plants: &plants, x: &mut x.0, pitch: &mut pitch };
    let observer = SlopeLanes::new(&models, &mut metrics, &mut plant_phi_s, reference);
    Ok(closed_loop::<C, _, _, 4, COPY>(&mut controller, plant, observer, active, steps, config, should_stop))
}

/// The ideal 2-DOF lanes' plant in the closed loop: their plants, and their state in the
/// loop's frame. The law reads the state, the plants get its input.
struct SlopePlants<'a> {
    plants: &'a Plants,
    x: &'a mut [Lanes; 4],
    /// sin/cos of x's pitch from the law's update to the step that follows it.
    pitch: &'a mut Option<[Lanes; 2]>,
}

impl closed_loop::Plant for SlopePlants<'_> {
    type Shape = Slope;

    #[inline(always)]
    fn state(&self) -> &[Lanes; 4] {
        self.x
    }

    #[inline(always)]
    fn state_mut(&mut self) -> &mut [Lanes; 4] {
        self.x
    }

    /// The first stage's sin/cos of the pitch taken here, for the law and then the step (the
    /// LQR lanes, whose law ignores them, measured 1.033x and 1.072x with the sin/cos taken
    /// before the step's loop rather than in it: avx512 on an AVX-512 EPYC, paired builds, 8
    /// rounds).
    #[inline(always)]
    fn update<C: LaneLaw<Shape = Slope>, const COPY: u8>(&mut self, controller: &mut C, state: &mut C::State, _: f64, r: &SpeedRef<f64>, u: &mut Lanes) {
        let pitch = self.pitch.insert(self.plants.pitch_sin_cos(self.x));
        controller.update_at_pitch::<COPY>(state, self.x, pitch, r, u);
    }

    #[inline(always)]
    fn apply(&mut self, _: f64, u: &Lanes) -> [bool; LANES] {
        closed_loop::not_finite(u)
    }

    #[inline(always)]
    fn command<'s>(&'s self, u: &'s Lanes) -> &'s Lanes {
        u
    }

    #[inline(always)]
    fn step<const COPY: u8>(&mut self, _: usize, u: &Lanes, dt: f64, _: impl FnOnce(&Lanes, &[bool; LANES]), next: &mut [Lanes; 4]) {
        // The reduced step takes its own sin/cos; the pitch's, of this x, must not outlive it.
        *self.pitch = None;
        *next = self.plants.rk4(self.x, u, dt);
    }

    /// Unreduced sin/cos where the live lanes allow (`Plants::rk4_unreduced_into`), else the
    /// step again with the reduction (rare: a pitch past ±0.78 rad; asked out of line, but
    /// the 2-DOF kernels keep it inline, `objdump`).
    #[inline(always)]
    fn step_live<const COPY: u8>(&mut self, _: usize, u: &Lanes, dt: f64, live: &[bool; LANES], _: impl FnOnce(&Lanes, &[bool; LANES]), next: &mut [Lanes; 4]) {
        let pitch = self.pitch.take().unwrap_or_else(|| self.plants.pitch_sin_cos(self.x));
        let (plants, x) = (&self.plants, &*self.x);
        plants.rk4_unreduced_into(x, &pitch, u, dt, live, next, |next| *next = out_of_line_in::<COPY, _>(#[inline(always)] || plants.rk4(x, u, dt)));
    }

    #[inline(always)]
    fn halts<const COPY: u8>(&self, _: &[Lanes; 4], _: &Lanes) -> Option<[Option<Halt>; LANES]> {
        None
    }
}

/// The 2-DOF lanes' observer in the closed loop, ideal or through a rig: their metrics, and
/// what the metrics measure against as the reference runs. The arrays are borrowed from the
/// kernel's frame, each apart, as in the loop written out, and the hooks hold only them and
/// scalars: the out-of-line calls that take an array (`Metrics::observe_fall`,
/// `Metrics::finish`) then take no address of the hooks. Owned by the hooks, the arrays made
/// them one object in memory, copied whole (8.6 KB) to `finish`, and the fuzzy lanes swept at
/// 0.95x of the loop written out (avx512, 12 alternated pairs); borrowed, 1.04-1.06x.
struct SlopeLanes<'a> {
    models: &'a [SlopeModel<f64>; LANES],
    metrics: &'a mut Metrics,
    /// Each plant's steady pitch at `cached_speed`, recomputed only when the reference speed
    /// changes.
    plant_phi_s: &'a mut Lanes,
    reference: &'a SpeedSchedule<f64>,
    cached_speed: f64,
    /// The largest reference speed so far and the direction of travel (`Aim`'s).
    speed_scale: f64,
    direction: f64,
}

impl<'a> SlopeLanes<'a> {
    /// The plants' steady pitches at the reference's start and the metrics of `models` from `x`.
    fn metrics(models: &[SlopeModel<f64>; LANES], reference: &SpeedSchedule<f64>, x: &[Lanes; 4]) -> (Lanes, Metrics) {
        let plant_phi_s = steady_pitches(models, reference.sample(0.0).theta_dot);
        let metrics = Metrics::new(core::array::from_fn(|l| models[l].params().wheel_radius), x, &plant_phi_s);
        (plant_phi_s, metrics)
    }

    /// The observer of `models` along `reference`, into `metrics`, the plants' steady pitches
    /// at its start `plant_phi_s` (`Self::metrics`). Inlined, so that the loop knows which of
    /// the kernel's arrays the references are: out of line, they were pointers a call returned,
    /// read from the frame every step and the metrics' stores through them able to alias the
    /// state, and the fuzzy lanes swept at 0.96x of the loop before (`avx512`); inlined, 1.02x
    /// (6 alternated pairs, the rigs 1.03-1.04x).
    #[inline(always)]
    fn new(models: &'a [SlopeModel<f64>; LANES], metrics: &'a mut Metrics, plant_phi_s: &'a mut Lanes, reference: &'a SpeedSchedule<f64>) -> Self {
        let cached_speed = reference.sample(0.0).theta_dot;
        Self { models, metrics, plant_phi_s, reference, cached_speed, speed_scale: 0.0, direction: 1.0 }
    }
}

impl Observer for SlopeLanes<'_> {
    type Shape = Slope;
    type Out = [SampleMetrics; LANES];
    const PITCH: usize = 0;

    #[inline(always)]
    fn reference(&mut self, t: f64) -> SpeedRef<f64> {
        let r = self.reference.sample(t);
        if r.theta_dot != self.cached_speed {
            self.cached_speed = r.theta_dot;
            *self.plant_phi_s = steady_pitches(self.models, r.theta_dot);
        }
        self.speed_scale = self.speed_scale.max(r.theta_dot.abs());
        self.direction = if r.theta_dot != 0.0 { r.theta_dot.signum() } else { self.direction };
        r
    }

    #[inline(always)]
    fn observe(&mut self, live: &[bool; LANES], t: f64, x: &[Lanes; 4], u: &Lanes, r: &SpeedRef<f64>) {
        self.metrics.observe(live, x, u, self.plant_phi_s, &Shared { t, r: *r, speed_scale: self.speed_scale, direction: self.direction });
    }

    #[inline(always)]
    fn drive(&mut self, live: &[bool; LANES], delivered: &Lanes, update: bool, beyond: &[bool; LANES]) {
        self.metrics.drive(live, delivered, update, beyond);
    }

    #[inline(always)]
    fn observe_end(&mut self, l: usize, t: f64, x: &[Lanes; 4], u: &Lanes, _: Option<Halt>) {
        let at = Shared::at(t, self.reference, self.speed_scale, self.direction);
        self.metrics.observe_fall(l, x, u, &self.models[l], self.plant_phi_s, &at);
    }

    #[inline(always)]
    fn finish(self, lanes: (&[bool; LANES], &[bool; LANES], &mut [(bool, f64, u64); LANES]), x: &[Lanes; 4], u: &Lanes, (t_end, n): (f64, usize)) -> [SampleMetrics; LANES] {
        let mut out = [SampleMetrics::INVALID; LANES];
        let at = Shared::at(t_end, self.reference, self.speed_scale, self.direction);
        self.metrics.finish(&mut out, lanes, x, u, self.models, &at, n);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::fuzzy::FuzzyController;
    use crate::control::lqr::{design, DesignPoint, LqrController};
    use crate::model::params::RobotParams;
    use nalgebra::{Matrix4, Vector4};

    /// Every compiled copy of the kernel gives the same bits (the baseline one through
    /// libm's fma), so a sweep is the same on any x86-64 CPU.
    fn same_bits_on_every_copy<C: LaneLaw<Shape = Slope> + Clone>(law: C) -> String {
        let schedule = SpeedSchedule::new(&[crate::control::reference::Leg { goal: 10.0, speed: 4.0, hold: 0.5 }]).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 3.0, fall_limit: 0.45 };
        let samples: Vec<Sample> = (0..LANES as u64)
            .map(|i| {
                let mut params = RobotParams::balanbot();
                params.com_height *= 0.6 + 0.05 * i as f64;
                Sample { index: i, params, slope: 0.1, x0: Vector4::new(0.04 * i as f64, 0.0, 0.0, 0.0) }
            })
            .collect();
        let never = || false;
        let base = format!("{:?}", block_baseline(law.clone(), &schedule, &config, &samples, &never).unwrap());
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { block_avx2(law.clone(), &schedule, &config, &samples, &never) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX2 copy");
            }
            if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { block_avx512(law.clone(), &schedule, &config, &samples, &never) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX-512 copy");
            }
        }
        assert!(base.contains("fell: true") && base.contains("fell: false"), "want both outcomes: {base}");
        base
    }

    /// A chosen copy runs until it is unchosen; a copy the CPU lacks is refused and leaves
    /// the widest running. (Chosen only for a moment: other tests' sweeps run meanwhile. A
    /// copy the build does not hold is refused too: tests/test_kernel_copies.py, on the wheel
    /// `make` builds without the baseline copy.)
    #[test]
    fn a_chosen_copy_runs_until_unchosen() {
        let widest = KernelCopy::detect();
        assert!(widest.runs_here() && KernelCopy::Baseline.runs_here());
        for copy in KernelCopy::ALL {
            let got = KernelCopy::choose(Some(copy));
            let active = KernelCopy::active();
            assert_eq!(KernelCopy::choose(None), Ok(widest));
            if copy.runs_here() {
                assert_eq!((got, active), (Ok(copy), copy));
            } else {
                assert_eq!((got, active), (Err(widest), widest));
            }
        }
        assert_eq!(KernelCopy::active(), widest);
    }

    /// The plants' sin/cos of the pitch, which the fuzzy law's g1 reads, are within an ulp of
    /// the law's own (`Lane::sincos` on its vectors, Estrin's order where the plants take
    /// Horner's) wherever they hold (|φ| ≤ UNREDUCED), and mostly the same bits.
    #[test]
    fn the_plants_pitch_sin_cos_is_the_laws_own() {
        use crate::model::lane::Wide;
        let models: [SlopeModel<f64>; LANES] = core::array::from_fn(|_| SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap());
        let plants = Plants::new(&models.map(|m| m.coefficients()));
        let (steps, mut differ) = (20_000, 0);
        for k in 0..steps / LANES {
            let phi: Lanes = core::array::from_fn(|l| UNREDUCED * (2.0 * ((k * LANES + l) as f64) / steps as f64 - 1.0));
            let x = [phi, [0.0; LANES], [0.0; LANES], [0.0; LANES]];
            let [sin, cos] = plants.pitch_sin_cos(&x);
            for (c, chunk) in phi.chunks(8).enumerate() {
                let (s, co) = Wide::<8>::sincos(Wide(core::array::from_fn(|i| chunk[i])));
                for i in 0..8 {
                    let l = c * 8 + i;
                    for (own, shared) in [(s.0[i], sin[l]), (co.0[i], cos[l])] {
                        assert!(own.to_bits().abs_diff(shared.to_bits()) <= 1, "phi = {}: {own} vs {shared}", phi[l]);
                        differ += usize::from(own != shared);
                    }
                }
            }
        }
        assert!(differ < steps / 10, "{differ} of {} sin/cos values an ulp apart", 2 * steps);
    }

    /// The unreduced step is `rk4`'s bits where the live lanes' pitches allow it, and
    /// refused where a live lane's does not (a dead lane's does not count).
    #[test]
    fn unreduced_step_is_the_same_bits_or_refused() {
        let models: [SlopeModel<f64>; LANES] = core::array::from_fn(|l| {
            let mut params = RobotParams::balanbot();
            params.com_height *= 0.7 + 0.04 * l as f64;
            SlopeModel::new(params, 0.05).unwrap()
        });
        let plants = Plants::new(&models.map(|m| m.coefficients()));
        let u: Lanes = core::array::from_fn(|l| 0.3 * l as f64 - 2.0);
        let state = |pitch: f64| -> [Lanes; 4] {
            [core::array::from_fn(|l| if l == 0 { pitch } else { 0.05 * l as f64 - 0.4 }), [0.5; LANES], [0.0; LANES], [1.0; LANES]]
        };
        let bits = |x: &[Lanes; 4]| x.map(|v| v.map(f64::to_bits));
        let live = [true; LANES];
        let x = state(-0.77);
        assert_eq!(plants.rk4_unreduced(&x, &u, 1e-3, &live).map(|n| bits(&n)), Some(bits(&plants.rk4(&x, &u, 1e-3))));
        // Lane 0 at -0.9 rad: refused while it is live.
        let x = state(-0.9);
        assert!(plants.rk4_unreduced(&x, &u, 1e-3, &live).is_none());
        let mut others = live;
        others[0] = false;
        let next = plants.rk4_unreduced(&x, &u, 1e-3, &others).expect("lane 0 dead");
        assert_eq!(bits(&next)[..].iter().map(|v| &v[1..]).collect::<Vec<_>>(), bits(&plants.rk4(&x, &u, 1e-3))[..].iter().map(|v| &v[1..]).collect::<Vec<_>>());
        // Lane 0 pitching at 1,000 rad/s: its pitch moves 0.5 rad to the half step, far past
        // SHIFT_LIMIT, so refused while it is live; the others' bits are rk4's either way.
        let mut x = state(-0.5);
        x[1][0] = 1000.0;
        assert!(plants.rk4_unreduced(&x, &u, 1e-3, &live).is_none());
        let next = plants.rk4_unreduced(&x, &u, 1e-3, &others).expect("lane 0 dead");
        let full = plants.rk4(&x, &u, 1e-3);
        assert_eq!(bits(&next)[..].iter().map(|v| &v[1..]).collect::<Vec<_>>(), bits(&full)[..].iter().map(|v| &v[1..]).collect::<Vec<_>>());
        // There rk4 takes the stages' own sin/cos: a step as the runner's, to rounding (Taylor's
        // terms at 0.5 rad would be off by up to 9.7e-8, scripts/sin_cos_shift_accuracy.py's
        // `shifted` over φ in ±3).
        let model = models[0];
        let runner = crate::rk4_step(&model, &nalgebra::Vector4::new(x[0][0], x[1][0], x[2][0], x[3][0]), &nalgebra::Vector1::new(u[0]), 1e-3);
        for i in 0..4 {
            assert!((full[i][0] - runner[i]).abs() <= 1e-12 * runner[i].abs().max(1.0), "{i}: {} against {}", full[i][0], runner[i]);
        }
    }

    #[test]
    fn every_copy_gives_the_same_bits() {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap();
        let q = Matrix4::from_diagonal(&Vector4::new(10.0, 10.0, 1.0, 1.0));
        let d = design(&model, 4.0, &q, 1000.0, DesignPoint::OperatingPoint).unwrap();
        let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 0.005).unwrap();
        same_bits_on_every_copy(LqrLanes::new(&ctrl));
        let fuzzy = FuzzyController::thesis_slope(model, 0.005).unwrap();
        let gaussian = crate::sweep::tests::with_gaussians(&fuzzy);
        let [g5, t5, tri7] = crate::sweep::tests::grids(&fuzzy);
        // The thesis's 3 × 3 and n × n grids.
        for law in [fuzzy, gaussian, g5, t5, tri7] {
            same_bits_on_every_copy(FuzzyLanes::new(&law));
        }
    }
}
