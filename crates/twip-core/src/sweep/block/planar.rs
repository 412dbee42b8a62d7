//! The fast path of a 3-DOF tracking sweep: [`LANES`] samples at once on the planar model,
//! for the trackers with a law on lanes ([`LaneLaw`] of the [`Planar`] shape: PID, sliding mode).
//!
//! As the 2-DOF block: each lane its own robot, the tracker the one prototype designed on
//! the nominal robot with each lane's own state; the physics is the run's own source
//! (`model::planar::deriv`, `model::integrate::rk4`, `PidLaw::step`, `SmcLaw::step`,
//! `TrackingTally`)
//! on [`Fused`] lanes, so a lane agrees with `runner::simulate` to rounding and is bit for
//! bit the same on every CPU, thread count and block neighbour. The reference is the
//! same for every lane: sampled once per step. What is here is the data layout and the
//! 3-DOF hooks ([`PlanarPlants`], and [`Tracking`], the rig's lanes' observer too) of the
//! one closed loop (`sim::closed_loop`, the runner's, the 2-DOF lanes' and the rigs' too) on a
//! block ([`closed_loop`](super::closed_loop::closed_loop)).
use super::closed_loop::{self, closed_loop, Aligned, Observer};
use super::law::{LaneLaw, Planar};
use super::{multiversioned, only, stage_sin_cos};
use crate::control::pid::{PidLaw, PidTracker};
use crate::control::trajectory::{Path, PlanarRef};
use crate::control::{Controller, Reference};
use core::cell::Cell;
use crate::model::integrate::{rk4, stage_state, Field, Stage};
use crate::model::lane::{fill, Fused, Lane};
use crate::model::math::{kernel, SIN_COS, UNREDUCED};
use crate::model::dynamics::Halt;
use crate::model::planar::{deriv_at, PlanarCoefficients, PlanarModel, PLANAR_COEFFICIENTS};
use crate::sim::drive_metrics::{DriveTally, DRIVE_TALLIES};
use crate::sim::metrics::DrivePeaks;
use crate::sim::runner::SimConfig;
use crate::sim::tracking_metrics::{TrackingTally, TRACKING_TALLIES};
use crate::sweep::lanes::{fast_where_every_live, mask, where_live, Lanes, LANES};
use crate::sweep::planar::{PlanarSample, PlanarSampleMetrics};
use crate::sweep::SweepMetrics;
use crate::TwipError;

/// The PID tracker on lanes: `PidLaw::step` on each lane, each lane's two integrals.
#[derive(Clone, Debug)]
pub struct PidLanes {
    law: PidLaw<Fused>,
    period: f64,
}

impl PidLanes {
    pub fn new(prototype: &PidTracker<f64>) -> Self {
        Self { law: prototype.law().map(Fused), period: prototype.period() }
    }
}

impl LaneLaw for PidLanes {
    type Shape = Planar;
    /// Σ e_v and Σ e_ψ of each lane.
    type State = [Lanes; 2];

    fn period(&self) -> f64 {
        self.period
    }

    fn start(&self) -> [Lanes; 2] {
        [[0.0; LANES]; 2]
    }

    #[inline(always)]
    fn update<const COPY: u8>(&mut self, integrals: &mut [Lanes; 2], x: &[Lanes; 7], r: &PlanarRef<f64>, u: &mut [Lanes; 2]) {
        let r: PlanarRef<Fused> = lane_ref(r);
        // A loop over lanes that the compiler vectorises.
        for l in 0..LANES {
            let y = fill(|i| Fused(x[i][l]));
            let step = self.law.step(&y, &r, [Fused(integrals[0][l]), Fused(integrals[1][l])]);
            for w in 0..2 {
                u[w][l] = step.torque[w].0;
                integrals[w][l] = step.integrals[w].0;
            }
        }
    }
}

/// The reference as every lane sees it.
#[inline(always)]
pub(crate) fn lane_ref<S: Lane>(r: &PlanarRef<f64>) -> PlanarRef<S> {
    PlanarRef {
        x: S::splat(r.x),
        y: S::splat(r.y),
        psi: S::splat(r.psi),
        v: S::splat(r.v),
        omega: S::splat(r.omega),
        v_dot: S::splat(r.v_dot),
        omega_dot: S::splat(r.omega_dot),
    }
}

/// Plant coefficients, one array per coefficient, one entry per lane, aligned to a cache
/// line for the kernel's frame (as the 2-DOF `Plants`).
#[repr(C, align(64))]
pub struct Plants([Lanes; PLANAR_COEFFICIENTS]);

impl Plants {
    pub(crate) fn new(models: &[PlanarModel<f64>; LANES]) -> Self {
        let per_lane = models.map(|m| m.coefficients().to_array());
        Self(core::array::from_fn(|f| core::array::from_fn(|l| per_lane[l][f])))
    }

    /// Lane `l`'s coefficients set to `model`'s (a robot started anew), the others' as they are.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn set_lane(&mut self, l: usize, model: &PlanarModel<f64>) {
        for (field, v) in self.0.iter_mut().zip(model.coefficients().to_array()) {
            field[l] = v;
        }
    }

    /// Lane `l`'s coefficients.
    #[inline(always)]
    pub(crate) fn lane(&self, l: usize) -> PlanarCoefficients<Fused> {
        PlanarCoefficients::from_array(fill(|f| Fused(self.0[f][l])))
    }

    /// Each lane's wheels' speeds relative to the body (right, left) from its ν = (φ̇, v, ω),
    /// or their accelerations from ν̇ (`WheelRows::of`).
    #[inline(always)]
    pub(crate) fn wheels_of(&self, nu: [&Lanes; 3]) -> [Lanes; 2] {
        let mut out = [[0.0; LANES]; 2];
        for l in 0..LANES {
            let [right, left] = self.lane(l).wheels().of(&[Fused(nu[0][l]), Fused(nu[1][l]), Fused(nu[2][l])]);
            (out[0][l], out[1][l]) = (right.0, left.0);
        }
        out
    }

    /// One RK4 step, the inputs held, on every lane: a lane's whole step is one loop body
    /// in [`Fused`] numbers, which the compiler vectorises across lanes. (Two lanes per
    /// body, as the 2-DOF block does, measured no faster here: the 7-state step already
    /// spills registers.)
    #[inline(always)]
    pub(crate) fn rk4(&self, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64) -> [Lanes; 7] {
        let mut next = [[0.0; LANES]; 7];
        self.rk4_in::<false>(x, u, dt, &mut next, &mut [u64::MAX; LANES]);
        next
    }

    /// [`Self::rk4`]'s step, into `next`, where every `live` lane's pitch starts within
    /// ±[`UNREDUCED`] and its pitch and heading move by at most `math::SHIFT_LIMIT` to each
    /// later stage, else `full`'s (the caller's `rk4`; the other lanes' steps do not count).
    /// There the first pitch's sin/cos skips the reduction by π/2 and the quadrant's rotation, which change nothing
    /// there, and every later stage's sin/cos is only shifted from the first's
    /// (`Plant::at_offset`), as `rk4`'s is there: the same bits, with two reduced sin/cos a
    /// stage fewer. A loop over lanes cannot branch per lane, so this is checked after the
    /// step.
    #[inline(always)]
    pub(crate) fn rk4_shifted_into(&self, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64, live: &[bool; LANES], next: &mut [Lanes; 7], full: impl FnOnce(&mut [Lanes; 7])) {
        fast_where_every_live(live, next, #[inline(always)] |next, near| self.rk4_in::<true>(x, u, dt, next, near), full)
    }

    /// [`Self::rk4_shifted_into`]'s step, None where it would take the full one.
    #[cfg(test)]
    fn rk4_shifted(&self, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64, live: &[bool; LANES]) -> Option<[Lanes; 7]> {
        let (mut next, mut full) = ([[f64::NAN; LANES]; 7], false);
        self.rk4_shifted_into(x, u, dt, live, &mut next, |_| full = true);
        (!full).then_some(next)
    }

    /// The step, with the later stages' sin/cos shifted only (and the first pitch's unreduced)
    /// or not, and whether each lane's pitch started within ±[`UNREDUCED`] and its shifts were
    /// within `math::SHIFT_LIMIT`, as a `mask` in `near` (shifted only; else left as it is),
    /// the step into `out`.
    #[inline(always)]
    fn rk4_in<const SHIFTED: bool>(&self, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64, out: &mut [Lanes; 7], near: &mut [u64; LANES]) {
        let mut lanes_near = [u64::MAX; LANES];
        for l in 0..LANES {
            let (next, lane_near) = self.rk4_lane_in::<SHIFTED>(x, u, l, dt);
            for i in 0..7 {
                out[i][l] = next[i].0;
            }
            lanes_near[l] = lane_near;
        }
        if SHIFTED {
            *near = lanes_near;
        }
    }

    /// Lane `l`'s RK4 step, the inputs held. Always inlined: out of line it would be built
    /// without the kernel copy's instructions (a call per multiply-add).
    #[inline(always)]
    pub(crate) fn rk4_lane(&self, x: &[Lanes; 7], u: &[Lanes; 2], l: usize, dt: f64) -> [Fused; 7] {
        self.rk4_lane_in::<false>(x, u, l, dt).0
    }

    #[inline(always)]
    fn rk4_lane_in<const SHIFTED: bool>(&self, x: &[Lanes; 7], u: &[Lanes; 2], l: usize, dt: f64) -> ([Fused; 7], u64) {
        let plant = Plant::<SHIFTED> {
            k: self.lane(l),
            u: [Fused(u[0][l]), Fused(u[1][l])],
            near: Cell::new(u64::MAX),
            start: Cell::new([(0.0, 1.0); 2]),
        };
        let xl = fill(|i| Fused(x[i][l]));
        (rk4(&plant, &xl, &plant.at(&xl), Fused(dt)), plant.near.get())
    }
}

/// One lane's plant with its inputs held; `SHIFTED`: the first pitch's sin/cos unreduced and
/// the later stages' shifted from the first's only, noting in `near` (a `mask`) whether each allowed that.
struct Plant<const SHIFTED: bool> {
    k: PlanarCoefficients<Fused>,
    u: [Fused; 2],
    near: Cell<u64>,
    /// (sin, cos) of the step's first pitch and heading (`at`), which the later stages shift.
    start: Cell<[(f64, f64); 2]>,
}

impl<const SHIFTED: bool> Field<Fused, 7> for Plant<SHIFTED> {
    #[inline(always)]
    fn at(&self, x: &[Fused; 7]) -> [Fused; 7] {
        // Shifted only, the pitch unreduced where it may be (the same bits:
        // `Plants::rk4_shifted_into`).
        let pitch = if SHIFTED {
            // NaN is not near.
            self.near.set(self.near.get() & mask(x[3].0.abs() <= UNREDUCED));
            kernel(x[3])
        } else {
            Fused::sincos(x[3])
        };
        let heading = Fused::sincos(x[2]);
        self.start.set([(pitch.0 .0, pitch.1 .0), (heading.0 .0, heading.1 .0)]);
        deriv_at(&self.k, x, self.u, pitch, heading)
    }

    /// A later stage's sin/cos of the pitch and of the heading: the first's shifted by
    /// d = k h (`stage_sin_cos`), noting in `near` whether both shifts hold.
    #[inline(always)]
    fn at_offset(&self, x: &[Fused; 7], k: &[Fused; 7], h: Fused, _: Stage) -> [Fused; 7] {
        let stage = stage_state(x, k, h);
        let start = self.start.get();
        let angle = |i: usize, start: (f64, f64)| {
            let own = || {
                let (s, c) = Fused::sincos(stage[i]);
                (s.0, c.0)
            };
            stage_sin_cos::<SHIFTED>(start, k[i] * h, |j| Fused(SIN_COS[j]), &self.near, own)
        };
        let (pitch, heading) = (angle(3, start[0]), angle(2, start[1]));
        deriv_at(&self.k, &stage, self.u, pitch, heading)
    }
}

/// [`TrackingTally`] on every lane, one array per field, with each lane's sample counts.
/// Laid out as written from a cache line's boundary, as the 2-DOF `Metrics` (which says why).
#[repr(C, align(64))]
pub(super) struct Metrics {
    tally: [Lanes; TRACKING_TALLIES],
    samples: [u64; LANES],
    settled: [u64; LANES],
    /// Each lane's driver's gearbox efficiency (`Observer::drive_efficiency`; 1 without one).
    pub(super) efficiency: Lanes,
    /// [`DriveTally`] on every lane, once a rig's lanes observe what the plants got
    /// ([`Self::drive`]); ideal lanes' plants get the commands.
    drive: Option<[Lanes; DRIVE_TALLIES]>,
    /// Why each lane that the terrain ended was ended (a run's "lifted", "off_terrain").
    halts: [Option<Halt>; LANES],
}

impl Metrics {
    pub(super) fn new() -> Self {
        Self { tally: [[0.0; LANES]; TRACKING_TALLIES], drive: None, efficiency: [1.0; LANES], samples: [0; LANES], settled: [0; LANES], halts: [None; LANES] }
    }

    /// What the `live` lanes' plants get at a step's start, as a run's observer sees it
    /// (`Observer::drive`): the wheel torques after the drivers, and at a controller update
    /// (`update`) whether each lane's commands applied from then on are `beyond` the driver.
    #[inline(always)]
    pub(super) fn drive(&mut self, live: &[bool; LANES], delivered: &[Lanes; 2], update: bool, beyond: &[bool; LANES]) {
        let drive = self.drive.get_or_insert([[0.0; LANES]; DRIVE_TALLIES]);
        for l in 0..LANES {
            let mut tally = DriveTally::from_array(fill(|i| Fused(drive[i][l])));
            let largest = Fused(delivered[0][l]).magnitude().larger(Fused(delivered[1][l]).magnitude());
            tally.observe(live[l], largest, update, beyond[l]);
            for (i, v) in tally.to_array().into_iter().enumerate() {
                drive[i][l] = v.0;
            }
        }
    }

    /// Every active lane's metrics after the last step (`n` steps to `t_end`): each lane
    /// still `alive` is observed there and completes; the others ended as `ended` says
    /// ((fell, t_end, steps)). `u`: what the lanes' metrics observe.
    #[allow(clippy::type_complexity, clippy::too_many_arguments)]
    pub(super) fn finish(
        mut self,
        (alive, active, ended): (&[bool; LANES], &[bool; LANES], &mut [(bool, f64, u64); LANES]),
        x: &[Lanes; 7],
        u: &[Lanes; 2],
        models: &[PlanarModel<f64>; LANES],
        path: &impl LanePath,
        settle: f64,
        (t_end, n): (f64, usize),
    ) -> [PlanarSampleMetrics; LANES] {
        let mut out = [PlanarSampleMetrics::INVALID; LANES];
        self.observe(alive, t_end >= settle, x, u, &path.sample(t_end), path);
        for l in 0..LANES {
            if alive[l] {
                ended[l] = (false, t_end, n as u64);
            }
            if !active[l] {
                continue;
            }
            let summary = self.get(l).summary(self.samples[l] as usize, self.settled[l] as usize);
            let commanded = summary.peak_abs_torque;
            let peaks = match &self.drive {
                Some(drive) => {
                    let tally = DriveTally::from_array(drive.map(|v| v[l]));
                    DrivePeaks::from_wheel_torque(models[l].params(), tally.peak_delivered, commanded, tally.saturation_share(), self.efficiency[l])
                }
                // The plants got the commands (ideal lanes; the last sample's input is the
                // last step's), and the loop clamps nothing.
                None => DrivePeaks::from_wheel_torque(models[l].params(), commanded, commanded, 0.0, 1.0),
            };
            let (fell, t_end, steps) = ended[l];
            out[l] = PlanarSampleMetrics::from_summary(&summary, peaks, fell, t_end, steps).halted(self.halts[l]);
        }
        out
    }

    /// Lane `l`'s tally.
    #[inline(always)]
    fn get(&self, l: usize) -> TrackingTally<f64> {
        TrackingTally::from_array(fill(|i| self.tally[i][l]))
    }

    #[inline(always)]
    fn set(&mut self, l: usize, t: TrackingTally<f64>) {
        for (i, v) in t.to_array().into_iter().enumerate() {
            self.tally[i][l] = v;
        }
    }

    /// Lane `l` has ended in `x` (fallen, or halted for `halt`): the runner's last
    /// observation, `r` its reference then (settled when `settled`).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn end_lane(&mut self, l: usize, halt: Option<Halt>, settled: bool, x: &[Lanes; 7], u: &[Lanes; 2], r: &PlanarRef<f64>, path: &impl Path<f64>) {
        self.halts[l] = halt;
        self.observe(&only(l), settled, x, u, r, path);
    }

    /// Observes the lanes that are `live` at time `t` (settled when `settled`).
    #[inline(always)]
    pub(super) fn observe(&mut self, live: &[bool; LANES], settled: bool, x: &[Lanes; 7], u: &[Lanes; 2], r: &PlanarRef<f64>, path: &impl Path<f64>) {
        let r: PlanarRef<Fused> = lane_ref(r);
        // The distances first, in f64 as a run's (the path's own code, with branches), so
        // that the loop below vectorises.
        let mut distances = [0.0; LANES];
        if settled {
            for l in 0..LANES {
                distances[l] = path.distance(x[0][l], x[1][l]);
            }
        }
        where_live(live, #[inline(always)] |live| {
            for l in 0..LANES {
                let state = fill(|i| Fused(x[i][l]));
                let mut tally = TrackingTally::from_array(self.get(l).to_array().map(Fused));
                let distance = || Fused(distances[l]);
                tally.observe(live[l], settled, &state, [Fused(u[0][l]), Fused(u[1][l])], &r, distance);
                self.set(l, TrackingTally::from_array(tally.to_array().map(|v| v.0)));
                self.samples[l] += live[l] as u64;
                self.settled[l] += (live[l] & settled) as u64;
            }
        });
    }
}

type BlockResult = Result<Option<[PlanarSampleMetrics; LANES]>, TwipError>;

/// The path a block follows: its reference and its distance to the curve.
pub trait LanePath: Reference<f64, Sample = PlanarRef<f64>> + Path<f64> {}
impl<P: Reference<f64, Sample = PlanarRef<f64>> + Path<f64>> LanePath for P {}

multiversioned! {
    /// Runs up to [`LANES`] samples with `controller`'s law along `path` ("_settled"
    /// metrics from `settle` [s]; fewer samples fill the block with idle lanes).
    /// `should_stop` is asked every `runner::STOP_CHECK_STEPS` steps; `Ok(None)` means it
    /// said yes before the block was done.
    /// On `ground`: [`Flat`], or the lanes' terrains ([`TerrainLanes`], chosen once per block:
    /// a flat block keeps its kernel and its bits).
    pub fn run_planar_block, planar_avx512, planar_avx2, planar_baseline = planar_block<C: LaneLaw<Shape = Planar>, P: LanePath, G: BlockGround; const COPY>(
        controller: C,
        path: &P,
        config: &SimConfig<f64>,
        samples: &[PlanarSample],
        settle: f64,
        should_stop: &dyn Fn() -> bool,
        ground: &G,
    ) -> BlockResult
}

/// The ground a block of lanes runs on: how a step is taken, what ends a lane besides a fall,
/// and what the tracker is fed forward.
pub trait BlockGround {
    /// Whether lane `l`'s sample can run on it (its terrain valid and its start on it).
    fn valid(&self, l: usize) -> bool;
    /// One RK4 step, the inputs held, on every lane.
    fn rk4(&self, plants: &Plants, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64) -> [Lanes; 7];
    /// [`Self::rk4`] into `next`, knowing which lanes are `live` (only their new states count).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn rk4_live(&self, plants: &Plants, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64, live: &[bool; LANES], next: &mut [Lanes; 7]) {
        let _ = live;
        *next = self.rk4(plants, x, u, dt);
    }
    /// What ends each lane at `next` under `u` besides a fall (None: nothing can).
    fn halts(&self, plants: &Plants, next: &[Lanes; 7], u: &[Lanes; 2]) -> Option<[Option<Halt>; LANES]>;
    /// The tracker's update on every lane, with what this ground feeds forward.
    fn update<C: LaneLaw<Shape = Planar>, const COPY: u8>(&self, controller: &mut C, state: &mut C::State, x: &[Lanes; 7], r: &PlanarRef<f64>, u: &mut [Lanes; 2]);
}

/// Flat ground: the planar model, nothing halts a lane, nothing fed forward.
pub struct Flat;

impl BlockGround for Flat {
    #[inline(always)]
    fn valid(&self, _: usize) -> bool {
        true
    }

    #[inline(always)]
    fn rk4(&self, plants: &Plants, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64) -> [Lanes; 7] {
        plants.rk4(x, u, dt)
    }

    /// The later stages' sin/cos shifted only where the live lanes allow
    /// (`Plants::rk4_shifted_into`), else the step again with each stage's own where needed
    /// (rare: a stage's pitch or heading moving by more than `SHIFT_LIMIT`).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn rk4_live(&self, plants: &Plants, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64, live: &[bool; LANES], next: &mut [Lanes; 7]) {
        plants.rk4_shifted_into(x, u, dt, live, next, #[inline(always)] |next| *next = plants.rk4(x, u, dt));
    }

    #[inline(always)]
    fn halts(&self, _: &Plants, _: &[Lanes; 7], _: &[Lanes; 2]) -> Option<[Option<Halt>; LANES]> {
        None
    }

    #[inline(always)]
    fn update<C: LaneLaw<Shape = Planar>, const COPY: u8>(&self, controller: &mut C, state: &mut C::State, x: &[Lanes; 7], r: &PlanarRef<f64>, u: &mut [Lanes; 2]) {
        controller.update::<COPY>(state, x, r, u);
    }
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn planar_block<C: LaneLaw<Shape = Planar>, P: LanePath, G: BlockGround, const COPY: u8>(
    mut controller: C,
    path: &P,
    config: &SimConfig<f64>,
    samples: &[PlanarSample],
    settle: f64,
    should_stop: &dyn Fn() -> bool,
    ground: &G,
) -> BlockResult {
    assert!(samples.len() <= LANES, "a block holds at most {LANES} samples");
    let steps = config.steps(controller.period())?;
    // Invalid or missing samples run an idle copy of a valid robot and are never kept.
    let mut active = [false; LANES];
    let mut models = [None; LANES];
    for (l, s) in samples.iter().enumerate() {
        if s.x0.iter().all(|v| v.is_finite()) && ground.valid(l) {
            models[l] = PlanarModel::new(s.params).ok();
            active[l] = models[l].is_some();
        }
    }
    let Some(fallback) = models.iter().flatten().next().copied() else {
        return Ok(Some([PlanarSampleMetrics::INVALID; LANES]));
    };
    let models: [PlanarModel<f64>; LANES] = core::array::from_fn(|l| models[l].unwrap_or(fallback));
    let x: [Lanes; 7] = core::array::from_fn(|i| core::array::from_fn(|l| if active[l] { samples[l].x0[i] } else { 0.0 }));
    let plants = Plants::new(&models);
    let mut x = Aligned(x);
    let plant = PlanarPlants { plants: &plants, x: &mut x.0, ground };
    Ok(closed_loop::<C, _, _, 7, COPY>(&mut controller, plant, Tracking::new(&models, path, settle), active, steps, config, should_stop))
}

/// The ideal 3-DOF lanes' plant in the closed loop: their plants on their ground, their state
/// in the loop's frame. The plants are borrowed from the kernel's frame, as the 2-DOF hooks'
/// arrays (`SlopeLanes` says why).
struct PlanarPlants<'a, G> {
    plants: &'a Plants,
    x: &'a mut [Lanes; 7],
    ground: &'a G,
}

impl<G: BlockGround> closed_loop::Plant for PlanarPlants<'_, G> {
    type Shape = Planar;

    #[inline(always)]
    fn state(&self) -> &[Lanes; 7] {
        self.x
    }

    #[inline(always)]
    fn state_mut(&mut self) -> &mut [Lanes; 7] {
        self.x
    }

    #[inline(always)]
    fn update<C: LaneLaw<Shape = Planar>, const COPY: u8>(&mut self, controller: &mut C, state: &mut C::State, _: f64, r: &PlanarRef<f64>, u: &mut [Lanes; 2]) {
        self.ground.update::<C, COPY>(controller, state, self.x, r, u);
    }

    #[inline(always)]
    fn apply(&mut self, _: f64, u: &[Lanes; 2]) -> [bool; LANES] {
        closed_loop::not_finite(u)
    }

    #[inline(always)]
    fn command<'s>(&'s self, u: &'s [Lanes; 2]) -> &'s [Lanes; 2] {
        u
    }

    #[inline(always)]
    fn step<const COPY: u8>(&mut self, _: usize, u: &[Lanes; 2], dt: f64, _: impl FnOnce(&[Lanes; 2], &[bool; LANES]), next: &mut [Lanes; 7]) {
        *next = self.ground.rk4(self.plants, self.x, u, dt);
    }

    #[inline(always)]
    fn step_live<const COPY: u8>(&mut self, _: usize, u: &[Lanes; 2], dt: f64, live: &[bool; LANES], _: impl FnOnce(&[Lanes; 2], &[bool; LANES]), next: &mut [Lanes; 7]) {
        self.ground.rk4_live(self.plants, self.x, u, dt, live, next);
    }

    #[inline(always)]
    fn halts<const COPY: u8>(&self, next: &[Lanes; 7], u: &[Lanes; 2]) -> Option<[Option<Halt>; LANES]> {
        self.ground.halts(self.plants, next, u)
    }
}

/// The 3-DOF lanes' observer in the closed loop, ideal or through a rig: their metrics along
/// the path ("_settled" from `settle` [s]). The models are borrowed from the kernel's frame.
pub(super) struct Tracking<'a, P> {
    models: &'a [PlanarModel<f64>; LANES],
    pub(super) metrics: Metrics,
    path: &'a P,
    settle: f64,
}

impl<'a, P: LanePath> Tracking<'a, P> {
    pub(super) fn new(models: &'a [PlanarModel<f64>; LANES], path: &'a P, settle: f64) -> Self {
        Self { models, metrics: Metrics::new(), path, settle }
    }
}

impl<P: LanePath> Observer for Tracking<'_, P> {
    type Shape = Planar;
    type Out = [PlanarSampleMetrics; LANES];
    const PITCH: usize = 3;

    #[inline(always)]
    fn reference(&mut self, t: f64) -> PlanarRef<f64> {
        self.path.sample(t)
    }

    #[inline(always)]
    fn observe(&mut self, live: &[bool; LANES], t: f64, x: &[Lanes; 7], u: &[Lanes; 2], r: &PlanarRef<f64>) {
        self.metrics.observe(live, t >= self.settle, x, u, r, self.path);
    }

    #[inline(always)]
    fn drive(&mut self, live: &[bool; LANES], delivered: &[Lanes; 2], update: bool, beyond: &[bool; LANES]) {
        self.metrics.drive(live, delivered, update, beyond);
    }

    #[inline(always)]
    fn observe_end(&mut self, l: usize, t: f64, x: &[Lanes; 7], u: &[Lanes; 2], halt: Option<Halt>) {
        self.metrics.end_lane(l, halt, t >= self.settle, x, u, &self.path.sample(t), self.path);
    }

    #[inline(always)]
    fn finish(self, lanes: (&[bool; LANES], &[bool; LANES], &mut [(bool, f64, u64); LANES]), x: &[Lanes; 7], u: &[Lanes; 2], end: (f64, usize)) -> [PlanarSampleMetrics; LANES] {
        self.metrics.finish(lanes, x, u, self.models, self.path, self.settle, end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::trajectory::{Circle, Direction};
    use crate::hardware::motor::DcMotor;
    use crate::model::params::RobotParams;
    use crate::control::smc::{Adaptation, SmcGains, SmcOptions, SmcTracker};
    use crate::model::planar::PlanarState;
    use crate::sweep::block::SmcLanes;
    use alloc::vec::Vec;

    /// Every compiled copy of the kernel gives the same bits (the baseline one through
    /// libm's fma), so a tracking sweep is the same on any x86-64 CPU.
    fn same_bits_on_every_copy<C: LaneLaw<Shape = Planar> + Clone>(law: C) {
        same_bits_on_every_copy_on(law, |_| Flat, "fell: true");
    }

    /// [`same_bits_on_every_copy`] on the ground `ground_of` gives the block's samples (which
    /// it may change), some ending as `ending` says.
    fn same_bits_on_every_copy_on<C: LaneLaw<Shape = Planar> + Clone, G: BlockGround>(law: C, ground_of: impl Fn(&mut [PlanarSample]) -> G, ending: &str) {
        let nominal = RobotParams::balanbot();
        let circle = Circle::from_origin(0.6, 0.2, Direction::CounterClockwise).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 3.0, fall_limit: 0.5 };
        let mut samples: Vec<PlanarSample> = (0..LANES as u64)
            .map(|i| {
                let mut params = nominal;
                params.com_height *= 0.6 + 0.05 * i as f64;
                let mut x0 = PlanarState::zeros();
                x0[3] = 0.04 * i as f64;
                PlanarSample { index: i, params, x0 }
            })
            .collect();
        let ground = ground_of(&mut samples);
        let never = || false;
        let base = format!("{:?}", planar_baseline(law.clone(), &circle, &config, &samples, 1.0, &never, &ground).unwrap());
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { planar_avx2(law.clone(), &circle, &config, &samples, 1.0, &never, &ground) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX2 copy");
            }
            if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { planar_avx512(law.clone(), &circle, &config, &samples, 1.0, &never, &ground) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX-512 copy");
            }
        }
        assert!(base.contains(ending) && base.contains("fell: false"), "want both outcomes: {base}");
    }

    /// On terrain too (each lane its own plane, the grade fed forward; bumps): every copy the
    /// same bits, lanes lifting among them.
    #[test]
    fn every_copy_gives_the_same_bits_on_terrain() {
        use crate::control::grade::GradeFeedForward;
        use crate::model::terrain::Terrain;
        use crate::model::terrain_model::TerrainModel;
        use crate::sweep::block::{FeedForwardLanes, TerrainLanes};
        let nominal = RobotParams::balanbot();
        let motor = DcMotor::gb37y3530();
        let pid = PidTracker::table_4_1(&nominal, motor, 0.005).unwrap();
        let flat = TerrainModel::new(PlanarModel::new(nominal).unwrap(), Terrain::flat());
        let feed = FeedForwardLanes::new(&GradeFeedForward::new(pid, flat, Some(motor)));
        // Planes up to 0.6 rad at headings all round; half the lanes start across them at
        // speed, turning hard: some of those lift a wheel.
        let planes = |samples: &mut [PlanarSample]| {
            let terrains: Vec<_> = (0..samples.len()).map(|i| Terrain::plane(0.04 * i as f64, 0.7 * i as f64).ok()).collect();
            for (i, s) in samples.iter_mut().enumerate().filter(|(i, _)| i % 2 == 1) {
                (s.x0[2], s.x0[5], s.x0[6]) = (0.7 * i as f64 + core::f64::consts::FRAC_PI_2, 1.5, -8.0);
            }
            TerrainLanes::new(samples, &terrains, Some(feed))
        };
        same_bits_on_every_copy_on(PidLanes::new(&pid), planes, "lifted: 1.0");
        let bumps = |samples: &mut [PlanarSample]| TerrainLanes::new(samples, &alloc::vec![Terrain::bumps(0.03, 0.4).ok(); samples.len()], None);
        same_bits_on_every_copy_on(PidLanes::new(&pid), bumps, "fell: true");
    }

    /// The shifted step is `rk4`'s bits where the live lanes' pitches start within ±UNREDUCED
    /// and they and the headings move little enough, and refused where a live lane's does not
    /// (a dead lane's does not count); there `rk4` takes the stage's own sin/cos, as the runner.
    #[test]
    fn shifted_step_is_the_same_bits_or_refused() {
        let models: [PlanarModel<f64>; LANES] = core::array::from_fn(|l| {
            let mut params = RobotParams::balanbot();
            params.com_height *= 0.7 + 0.04 * l as f64;
            PlanarModel::new(params).unwrap()
        });
        let plants = Plants::new(&models);
        let u: [Lanes; 2] = [core::array::from_fn(|l| 0.03 * l as f64 - 0.2), core::array::from_fn(|l| 0.1 - 0.02 * l as f64)];
        // Headings all round, pitches either side, turning and pitching.
        let x: [Lanes; 7] = [
            [0.1; LANES],
            [-0.2; LANES],
            core::array::from_fn(|l| 0.9 * l as f64 - 7.0),
            core::array::from_fn(|l| 0.05 * l as f64 - 0.4),
            [0.8; LANES],
            [0.5; LANES],
            core::array::from_fn(|l| 0.3 * l as f64 - 2.0),
        ];
        let bits = |x: &[Lanes; 7]| x.map(|v| v.map(f64::to_bits));
        let others = |x: &[Lanes; 7]| bits(x).map(|v| v[1..].to_vec());
        let live = [true; LANES];
        assert_eq!(plants.rk4_shifted(&x, &u, 1e-3, &live).map(|n| bits(&n)), Some(bits(&plants.rk4(&x, &u, 1e-3))));
        // Lane 0 pitched 0.9 rad, where its first sin/cos needs the reduction: refused while it
        // is live, the others' bits the same.
        let mut far = x;
        far[3][0] = -0.9;
        assert!(plants.rk4_shifted(&far, &u, 1e-3, &live).is_none());
        let mut dead = live;
        dead[0] = false;
        assert_eq!(others(&plants.rk4_shifted(&far, &u, 1e-3, &dead).expect("lane 0 dead")), others(&plants.rk4(&far, &u, 1e-3)));
        // Lane 0 turning, then pitching, at 1,000 rad/s: its heading or pitch moves 0.5 rad to
        // the half step, far past SHIFT_LIMIT.
        for i in [6, 4] {
            let mut fast = x;
            fast[i][0] = 1000.0;
            assert!(plants.rk4_shifted(&fast, &u, 1e-3, &live).is_none(), "state {i}");
            let full = plants.rk4(&fast, &u, 1e-3);
            assert_eq!(others(&plants.rk4_shifted(&fast, &u, 1e-3, &dead).expect("lane 0 dead")), others(&full));
            // The shift's Taylor terms at 0.5 rad would be off by up to 9.7e-8.
            let runner = crate::rk4_step(&models[0], &PlanarState::from_fn(|j, _| fast[j][0]), &nalgebra::Vector2::new(u[0][0], u[1][0]), 1e-3);
            for j in 0..7 {
                assert!((full[j][0] - runner[j]).abs() <= 1e-12 * runner[j].abs().max(1.0), "state {i}, {j}: {} against {}", full[j][0], runner[j]);
            }
        }
    }

    #[test]
    fn every_copy_gives_the_same_bits() {
        let nominal = RobotParams::balanbot();
        same_bits_on_every_copy(PidLanes::new(&PidTracker::table_4_1(&nominal, DcMotor::gb37y3530(), 0.005).unwrap()));
        let model = PlanarModel::new(nominal).unwrap();
        let unit = DcMotor::<f64>::gb37y3530().torque_per_count();
        let fuzzy = SmcTracker::new(SmcGains::thesis(unit), SmcOptions::default(), model, Some(DcMotor::gb37y3530()), Some(Adaptation::default()), 0.005).unwrap();
        same_bits_on_every_copy(SmcLanes::new(&fuzzy).expect("the thesis's sets are trapezoids"));
        same_bits_on_every_copy(SmcLanes::new(&crate::sweep::planar::tests::smc_5x5()).expect("trapezoids"));
    }
}
