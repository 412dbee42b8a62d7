//! The 2-DOF rig on a block of [`LANES`] robots, as a state object stepped one plant step
//! at a time ([`RigLanes`]): what a closed loop around it needs (the sensors' read, the
//! actuator's drive, the held input and its delay, one plant step), with the loop's
//! controller and metrics outside it (`rig::run_rig_block`).
//!
//! The plant's RK4 is the run's own source (`model::slope::motion` with `Friction`'s law,
//! `open_motion` for a lane whose gear trains are open, and a driver's
//! `Winding::steady_current` or, with inductance, `Winding::stepped_current`) on [`Fused`]
//! lanes, which the compiler vectorises. Each lane's sensors, actuator, winding and gear
//! play are its own rig's parts, the very objects a run uses (`Realism::build`): they act
//! between steps or once per control period on a lane's numbers (the play's impacts and
//! openings, and pushes, too), and their noise draws are a lane's own.
use alloc::boxed::Box;
use alloc::vec::Vec;
use core::cell::Cell;

use nalgebra::{SVector, Vector4};

use super::rig_context::RigContext;
use super::winding::WindingLanes;
use super::{chunk, lane_terms, state_chunk, Plants, CHUNKS};
use crate::hardware::disturbance::{Force, SlopePlant, Slopes, MAX_SLOPE_CHANGES};
use crate::hardware::driver::{MotorDriver, Winding};
use crate::hardware::imu::{lane_from, specific_force_of, ImuClock, ImuReading, Mpu6050, NoiseLanes};
use crate::hardware::realism::{BalanceSensors, RealActuator, RigPlant as _, SlopeRig};
use crate::hardware::settle::settle_side_by_side;
use crate::model::friction::{Friction, Gearhead};
use crate::model::integrate::{rk4, Field, Stage};
use crate::model::lane::{Fused, Lane, Wide, WIDTH};
use crate::model::math::{sin_cos_fused_from, SIN_COS};
use crate::model::slope::{motion, open_motion, SlopeCoefficients, SlopeModel};
use crate::sweep::lanes::{Lanes, LANES};
use crate::{Dynamics, RobotParams, TwipError};

// The plant's kinds, decided once per block (`kinds`): its gearhead friction (`GEAR`; a stick
// band's law as the slip law, `OUTSIDE`, decided per step), what drives it (`DRIVE`: a lumped
// current held over the step, or a winding's) and whether the gear trains have play (`GEARED`).
use super::kinds::{clear_of_band, FREE, HELD, OUTSIDE, SLIP, STEADY, STEPPED, STICK};

/// A ground with at most this many slope changes has its own copies of the lanes' loops,
/// which pick a lane's piece among those only: picking among all that a ground may have
/// cost a rig with two changes 6 % more instructions and about 9 % more time.
const FEW_CHANGES: usize = 2;

/// One lane's plant over a step: the input held (a lumped current, or a duty that a
/// winding without inductance turns into current at each stage), or the lumped current at
/// the step's start of a winding with inductance, which has the step under way.
struct RigField<'a, const GEAR: u8, const DRIVE: u8, const GEARED: bool, const CHANGES: usize> {
    k: SlopeCoefficients<Fused>,
    /// sin/cos's terms as this lane reads them (`Plants`).
    terms: [f64; SIN_COS.len()],
    friction: &'a Friction<Fused>,
    u: Fused,
    winding: Winding<Fused>,
    per_amp: Fused,
    /// The gear trains are engaged over this step (backlash: set between steps).
    engaged: bool,
    /// A constant force on the body (zero: none), at this lane's robot's height.
    force: Force<Fused>,
    /// The ground's pieces (with `CHANGES` > 0, this lane's is picked at each stage among
    /// the first `CHANGES` + 1) and the force's part on θ on each.
    hills: &'a Hills,
    lane: usize,
    /// Whether some stage found the wheels in the stick band (`OUTSIDE` only).
    band: Cell<bool>,
}

impl<const GEAR: u8, const DRIVE: u8, const GEARED: bool, const CHANGES: usize> RigField<'_, GEAR, DRIVE, GEARED, CHANGES> {
    /// The derivative and the gearhead torque per wheel (`SlopeModel::deriv_geared`'s) at
    /// the step's start.
    #[inline(always)]
    fn motion(&self, x: &[Fused; 4]) -> ([Fused; 4], Fused) {
        // As `Driven::lumped_current_at` the first stage: 2 ε times the winding's current.
        let u = if DRIVE == STEADY { self.per_amp * self.winding.steady_current(self.u, x[3] - x[1]) } else { self.u };
        self.motion_under(x, u)
    }

    /// [`Self::motion`] under the lumped current `u`.
    #[inline(always)]
    fn motion_under(&self, x: &[Fused; 4], u: Fused) -> ([Fused; 4], Fused) {
        let gear = match GEAR {
            FREE => Gearhead::Free,
            SLIP => Gearhead::Slip(self.friction),
            OUTSIDE => Gearhead::Outside(self.friction, &self.band),
            _ => Gearhead::Stick(self.friction),
        };
        let (k, q_theta) = if CHANGES > 0 { self.hills.piece::<CHANGES>(self.lane, &self.k, x[2]) } else { (self.k, self.hills.flat_q_theta(self.lane)) };
        // As `Piece::force_at`, always added: a branch on it kept the compiler from
        // vectorising the lanes' loop (measured: 1.56x the kernel's instructions). Without a
        // force it adds zeros, which change nothing but the sign of a zero sum.
        let force = self.force;
        let extra = |sin_phi: Fused, cos_phi: Fused| Some([force.on_pitch(sin_phi, cos_phi), q_theta]);
        let sin_cos = sin_cos_fused_from(x[0].0, |i| self.terms[i]);
        let sin_cos = (Fused(sin_cos.0), Fused(sin_cos.1));
        let (engaged, tau) = motion(&k, gear, x, u, extra, sin_cos);
        if !GEARED {
            return (engaged, tau);
        }
        // As `SlopeModel::deriv_geared`, both computed and one kept: no branch per lane.
        let open = open_motion(&k, x, extra, sin_cos);
        let zero = Fused(0.0);
        (core::array::from_fn(|i| Fused::select(self.engaged, engaged[i], open[i])), Fused::select(self.engaged, tau, zero))
    }
}

impl<const GEAR: u8, const DRIVE: u8, const GEARED: bool, const CHANGES: usize> Field<Fused, 4> for RigField<'_, GEAR, DRIVE, GEARED, CHANGES> {
    #[inline(always)]
    fn at(&self, x: &[Fused; 4]) -> [Fused; 4] {
        self.motion(x).0
    }

    // As `Driven::deriv_at_stage`.
    #[inline(always)]
    fn at_stage(&self, x: &[Fused; 4], stage: Stage) -> [Fused; 4] {
        if DRIVE == STEPPED {
            self.motion_under(x, self.per_amp * self.winding.stepped_current(stage, x[3] - x[1])).0
        } else {
            self.motion(x).0
        }
    }
}

/// The ground's pieces: each piece's coefficients that depend on the slope, and the force's
/// part on θ on it, per lane, and the distances where the pieces after the first start
/// (every lane's alike; none on a ground of one slope).
struct Hills {
    /// +∞ past the last change, whose piece the ones past it copy: a lane picks as
    /// `SlopeProfile::segment` does, a NaN distance included (the last piece).
    starts: [f64; MAX_SLOPE_CHANGES],
    /// `mrl_cos`, `mrl_sin`, `grade`, `sin_slope`, `cos_slope`, q_θ.
    pieces: [[Lanes; 6]; MAX_SLOPE_CHANGES + 1],
    radius: Lanes,
    /// How many slope changes the lanes pick among: none on one slope, else [`FEW_CHANGES`]
    /// when there are that few (a step, or a ramp up and down), else all a ground may have.
    changes: usize,
}

impl Hills {
    fn new(grounds: [&Slopes<f64>; LANES], radius: Lanes) -> Self {
        let starts = core::array::from_fn(|j| grounds[0].slope_changes().nth(j).unwrap_or(f64::INFINITY));
        let last = grounds[0].slope_changes().count();
        let pieces = core::array::from_fn(|j| {
            let terms = grounds.map(|g| Self::piece_fields(g, j.min(last)));
            core::array::from_fn(|i| core::array::from_fn(|l| terms[l][i]))
        });
        let changes = match last {
            0 => 0,
            n if n <= FEW_CHANGES => FEW_CHANGES,
            _ => MAX_SLOPE_CHANGES,
        };
        Self { starts, pieces, radius, changes }
    }

    /// Lane `l` on `ground` with wheels of `radius` (a robot started anew), the other lanes
    /// as they are and where lane 0's ground has its changes: lane `l` of [`Self::new`].
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    fn set_lane(&mut self, l: usize, ground: &Slopes<f64>, lane0: &Slopes<f64>, radius: f64) {
        let last = lane0.slope_changes().count();
        for (j, piece) in self.pieces.iter_mut().enumerate() {
            for (field, v) in piece.iter_mut().zip(Self::piece_fields(ground, j.min(last))) {
                field[l] = v;
            }
        }
        self.radius[l] = radius;
    }

    /// Piece `i`'s `mrl_cos`, `mrl_sin`, `grade`, `sin_slope`, `cos_slope` and q_θ on `ground`.
    fn piece_fields(ground: &Slopes<f64>, i: usize) -> [f64; 6] {
        let (k, q_theta) = ground.piece_terms(i);
        [k.mrl_cos, k.mrl_sin, k.grade, k.sin_slope, k.cos_slope, q_theta]
    }

    /// Lane `l`'s force part on θ on a ground of one slope.
    #[inline(always)]
    fn flat_q_theta(&self, l: usize) -> Fused {
        Fused(self.pieces[0][5][l])
    }

    /// Lane `l`'s coefficients `k` with the slope of the piece under it at wheel angle
    /// `theta`, and the force's part on θ there (`Slopes::piece`'s, as masks), among the
    /// first `N` changes: the same piece as among all when the ground has no more (the
    /// starts past its last are +∞, never passed; a NaN distance passes every start, and
    /// piece `N` copies the last).
    #[inline(always)]
    fn piece<const N: usize>(&self, l: usize, k: &SlopeCoefficients<Fused>, theta: Fused) -> (SlopeCoefficients<Fused>, Fused) {
        let distance = theta * Fused(self.radius[l]);
        let mut v: [Fused; 6] = core::array::from_fn(|i| Fused(self.pieces[0][i][l]));
        for j in 0..N {
            let past = !distance.lt(Fused(self.starts[j]));
            v = core::array::from_fn(|i| Fused::select(past, Fused(self.pieces[j + 1][i][l]), v[i]));
        }
        (SlopeCoefficients { mrl_cos: v[0], mrl_sin: v[1], grade: v[2], sin_slope: v[3], cos_slope: v[4], ..*k }, v[5])
    }

    /// (sin, cos) of the slope under every lane at wheel angles `theta`, the piece
    /// [`Self::piece`] picks: what the accelerometers feel. The sensors' own table
    /// (`BalanceSensors::ground_trig_at`) holds the same `sin_cos` of the same slopes, and
    /// picks by the same distance (`SlopeProfile::segment`: the changes are in order).
    #[inline(always)]
    fn trig_at(&self, theta: &Lanes) -> [Lanes; 2] {
        let [mut sin, mut cos] = [self.pieces[0][3], self.pieces[0][4]];
        for (start, piece) in self.starts[..self.changes].iter().zip(&self.pieces[1..]) {
            for l in 0..LANES {
                let past = !(theta[l] * self.radius[l]).lt(*start);
                sin[l] = if past { piece[3][l] } else { sin[l] };
                cos[l] = if past { piece[4][l] } else { cos[l] };
            }
        }
        [sin, cos]
    }
}

/// The lanes' plants: coefficients per lane, the friction all share, and each lane's
/// winding (used when there is a driver) and force (its height may be the robot's own
/// centre of mass; its part on θ: `hills`).
struct RigPlants {
    plants: Plants,
    gear: u8,
    friction: Friction<Fused>,
    drive: u8,
    windings: WindingLanes,
    geared: bool,
    /// Side by side (`Force::side_by_side`).
    forces: Force<Lanes>,
    hills: Hills,
}

/// Any valid winding, for lanes that never evaluate one (no driver).
fn stand_in() -> Result<(Winding<f64>, f64), TwipError> {
    Ok((Winding::new(&MotorDriver::gb37y3530(), &RobotParams::balanbot())?, 2.0))
}

impl RigPlants {
    /// The plants of `rigs` (each lane's `models`' robot) for steps of `dt`.
    fn new(rigs: &[SlopeRig<f64>], models: &[SlopeModel<f64>; LANES], dt: f64, stand_in: (Winding<f64>, f64)) -> Self {
        let friction = ground_model(&rigs[0]).friction().copied();
        Self {
            plants: Plants::new(&core::array::from_fn(|l| ground_model(&rigs[l]).coefficients())),
            gear: super::kinds::gear(friction.as_ref()),
            // Unused without a friction: any friction's numbers.
            friction: friction.unwrap_or_else(Friction::gb37).map(Fused),
            drive: super::kinds::drive(rigs[0].plant.driven_winding().map(|(w, _)| w.inductive())),
            // Unused without a driver (the held current is the input).
            windings: WindingLanes::new(&core::array::from_fn(|l| winding_of(&rigs[l], dt, stand_in))),
            // Every lane's realism has the same parts (but for where pushes and forces act).
            geared: rigs[0].plant.has_play(),
            forces: Force::side_by_side(&core::array::from_fn(|l| rigs[l].plant.force())),
            hills: Hills::new(core::array::from_fn(|l| rigs[l].plant.ground()), core::array::from_fn(|l| models[l].params().wheel_radius)),
        }
    }

    /// Lane `l`'s numbers anew from its rig `rigs[l]` (a robot started anew: its winding's
    /// state too), the other lanes' as they are (their windings' states are theirs): what
    /// [`Self::new`] of `rigs` gives (a lane's numbers are its rig's and model's, which do
    /// not change), without making every lane's anew. Lane 0's rig sets the parts every lane
    /// shares (friction, drive, play, where the slope changes): its restart makes them all anew.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    fn restart_lane(&mut self, l: usize, rigs: &[SlopeRig<f64>], models: &[SlopeModel<f64>; LANES], dt: f64, stand_in: (Winding<f64>, f64)) {
        let fresh = winding_of(&rigs[l], dt, stand_in);
        if l == 0 {
            let windings = core::mem::replace(self, Self::new(rigs, models, dt, stand_in)).windings;
            self.windings = windings;
        } else {
            self.plants.set_lane(l, &ground_model(&rigs[l]).coefficients());
            self.forces.set_lane(l, rigs[l].plant.force());
            self.hills.set_lane(l, rigs[l].plant.ground(), rigs[0].plant.ground(), models[l].params().wheel_radius);
        }
        self.windings.set_lane(l, fresh);
    }
}

/// `rig`'s ground model at rest (its first piece: the coefficients but for the slope's).
fn ground_model(rig: &SlopeRig<f64>) -> SlopeModel<f64> {
    *rig.plant.ground().model_at(&Vector4::zeros())
}

/// `rig`'s winding with its factors for steps of `dt` and its input per ampere; the
/// stand-in for a lane that never evaluates one (no driver).
fn winding_of(rig: &SlopeRig<f64>, dt: f64, stand_in: (Winding<f64>, f64)) -> (Winding<f64>, f64) {
    rig.plant.driven_winding().map_or(stand_in, |(mut w, per_amp)| {
        w.prepare(dt);
        (w, per_amp)
    })
}

/// `$run::<GEAR, DRIVE, GEARED, CHANGES>(args)` for the plants' kinds (`$drive`: what
/// drives the plant); GEARED only while some lane's trains are open (`$engaged`: all
/// engaged is the plain plant, bit for bit); CHANGES: the slope changes along the path that
/// a lane picks among (`Hills::changes`). `@outside`: the stick band's law as the slip
/// law (`OUTSIDE`), every train engaged.
macro_rules! by_kind {
    (@outside $self:ident, $drive:expr, $run:ident($($arg:expr),*)) => {
        match $self.hills.changes {
            0 => by_kind!(@drive $self, $drive, $run, OUTSIDE, false, 0, $($arg),*),
            FEW_CHANGES => by_kind!(@drive $self, $drive, $run, OUTSIDE, false, FEW_CHANGES, $($arg),*),
            _ => by_kind!(@drive $self, $drive, $run, OUTSIDE, false, MAX_SLOPE_CHANGES, $($arg),*),
        }
    };
    ($self:ident, $drive:expr, $engaged:ident, $run:ident($($arg:expr),*)) => {
        match ($self.hills.changes, $self.geared && $engaged.iter().any(|&e| !e)) {
            (0, false) => by_kind!(@gear $self, $drive, $run, false, 0, $($arg),*),
            (0, true) => by_kind!(@gear $self, $drive, $run, true, 0, $($arg),*),
            (FEW_CHANGES, false) => by_kind!(@gear $self, $drive, $run, false, FEW_CHANGES, $($arg),*),
            (FEW_CHANGES, true) => by_kind!(@gear $self, $drive, $run, true, FEW_CHANGES, $($arg),*),
            (_, false) => by_kind!(@gear $self, $drive, $run, false, MAX_SLOPE_CHANGES, $($arg),*),
            (_, true) => by_kind!(@gear $self, $drive, $run, true, MAX_SLOPE_CHANGES, $($arg),*),
        }
    };
    (@gear $self:ident, $drive:expr, $run:ident, $geared:literal, $changes:tt, $($arg:expr),*) => {
        match $self.gear {
            FREE => by_kind!(@drive $self, $drive, $run, FREE, $geared, $changes, $($arg),*),
            SLIP => by_kind!(@drive $self, $drive, $run, SLIP, $geared, $changes, $($arg),*),
            _ => by_kind!(@drive $self, $drive, $run, STICK, $geared, $changes, $($arg),*),
        }
    };
    (@drive $self:ident, $drive:expr, $run:ident, $gear:ident, $geared:literal, $changes:tt, $($arg:expr),*) => {
        match $drive {
            HELD => super::out_of_line_in::<COPY, _>(#[inline(always)] || $self.$run::<$gear, HELD, $geared, $changes>($($arg),*)),
            STEADY => super::out_of_line_in::<COPY, _>(#[inline(always)] || $self.$run::<$gear, STEADY, $geared, $changes>($($arg),*)),
            _ => super::out_of_line_in::<COPY, _>(#[inline(always)] || $self.$run::<$gear, STEPPED, $geared, $changes>($($arg),*)),
        }
    };
}

// Each kind's loop is a function of its own per kernel copy (`out_of_line_in`), compiled
// with that copy's instructions and shared by the controller laws.
impl RigPlants {
    #[inline(always)]
    fn field<const GEAR: u8, const DRIVE: u8, const GEARED: bool, const CHANGES: usize>(&self, terms: &[Lanes; SIN_COS.len()], l: usize, u: f64, engaged: bool) -> RigField<'_, GEAR, DRIVE, GEARED, CHANGES> {
        let (winding, per_amp) = self.windings.lane(l);
        let (k, friction, u) = (self.plants.lane(l), &self.friction, Fused(u));
        let force = self.forces.lane(l, Fused);
        RigField { k, terms: lane_terms(terms, l), friction, u, winding, per_amp, engaged, force, hills: &self.hills, lane: l, band: Cell::new(false) }
    }

    /// The derivative at the step's start on every lane (RK4's first stage, which the
    /// sensors sample too): where [`Self::outside`], by the slip law, which has the stick
    /// band's bits at a state clear of the band.
    #[inline(always)]
    fn k1<const COPY: u8>(&self, x: &[Lanes; 4], u: &Lanes, engaged: &[bool; LANES]) -> [Lanes; 4] {
        if self.outside(x, engaged) {
            return by_kind!(@outside self, self.drive, k1_of(x, u, engaged));
        }
        by_kind!(self, self.drive, engaged, k1_of(x, u, engaged))
    }

    #[cfg_attr(not(debug_assertions), inline(always))]
    fn k1_of<const GEAR: u8, const DRIVE: u8, const GEARED: bool, const CHANGES: usize>(&self, x: &[Lanes; 4], u: &Lanes, engaged: &[bool; LANES]) -> [Lanes; 4] {
        let (mut out, terms) = ([[0.0; LANES]; 4], self.plants.sin_cos_terms());
        for l in 0..LANES {
            let d = self.field::<GEAR, DRIVE, GEARED, CHANGES>(terms, l, u[l], engaged[l]).at(&lane(x, l).map(Fused));
            for i in 0..4 {
                out[i][l] = d[i].0;
            }
        }
        out
    }

    /// The derivative (into `d`: returned, it was copied twice a step) and gearhead torque
    /// per wheel on every lane with the trains as they are, under the lumped `current` held
    /// (what `RealPlant::gear_next` weighs); where [`Self::outside`], by the slip law, as
    /// [`Self::k1`].
    #[inline(always)]
    fn geared_motion<const COPY: u8>(&self, x: &[Lanes; 4], current: &Lanes, engaged: &[bool; LANES], d: &mut [Lanes; 4]) -> Lanes {
        // The lumped current is the input, whatever the winding.
        if self.outside(x, engaged) {
            return by_kind!(@outside self, HELD, geared_motion_of(x, current, engaged, d));
        }
        by_kind!(self, HELD, engaged, geared_motion_of(x, current, engaged, d))
    }

    #[cfg_attr(not(debug_assertions), inline(always))]
    fn geared_motion_of<const GEAR: u8, const DRIVE: u8, const GEARED: bool, const CHANGES: usize>(&self, x: &[Lanes; 4], current: &Lanes, engaged: &[bool; LANES], d: &mut [Lanes; 4]) -> Lanes {
        let (mut tau, terms) = ([0.0; LANES], self.plants.sin_cos_terms());
        for l in 0..LANES {
            let (dl, tl) = self.field::<GEAR, DRIVE, GEARED, CHANGES>(terms, l, current[l], engaged[l]).motion(&lane(x, l).map(Fused));
            for i in 0..4 {
                d[i][l] = dl[i].0;
            }
            tau[l] = tl.0;
        }
        tau
    }

    /// One RK4 step from `k1` on every lane into `next`, the input held. Where
    /// [`Self::outside`], the later stages first take the slip law (`OUTSIDE`): the same bits
    /// while no wheel enters the band, else the step is taken again with the band's solve.
    /// Measured, with the first stage's too, against the band's solve at every stage
    /// (`sweep_throughput`, paired builds, 8 rounds, the same bits, an AVX-512 EPYC): the
    /// thesis-like rig 1.049x on `avx512`, 1.066x on its forced `avx2` copy; the 3-DOF rig
    /// 1.177x and 1.221x.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn rk4<const COPY: u8>(&self, x: &[Lanes; 4], u: &Lanes, engaged: &[bool; LANES], k1: &[Lanes; 4], dt: f64, next: &mut [Lanes; 4]) {
        if self.outside(x, engaged) {
            let band = by_kind!(@outside self, self.drive, rk4_of(x, u, engaged, k1, dt, next));
            if !band {
                return;
            }
        }
        by_kind!(self, self.drive, engaged, rk4_of(x, u, engaged, k1, dt, next));
    }

    /// Whether a stick band's law may be taken as the slip law from `x` on: every train is
    /// `engaged` and every lane's wheels are at least twice the band's half-width from rest
    /// relative to the body. So no wheel is in the band at `x` (the first stage's state), and
    /// seldom within the step, so that the step's first try is seldom wasted.
    #[inline(always)]
    fn outside(&self, x: &[Lanes; 4], engaged: &[bool; LANES]) -> bool {
        let open = self.geared && engaged.iter().any(|&e| !e);
        self.gear == STICK && !open && (0..LANES).all(|l| clear_of_band(&self.friction, x[3][l] - x[1][l]))
    }

    #[cfg_attr(not(debug_assertions), inline(always))]
    fn rk4_of<const GEAR: u8, const DRIVE: u8, const GEARED: bool, const CHANGES: usize>(
        &self,
        x: &[Lanes; 4],
        u: &Lanes,
        engaged: &[bool; LANES],
        k1: &[Lanes; 4],
        dt: f64,
        out: &mut [Lanes; 4],
    ) -> bool {
        let terms = self.plants.sin_cos_terms();
        let mut band = false;
        for l in 0..LANES {
            let field = self.field::<GEAR, DRIVE, GEARED, CHANGES>(terms, l, u[l], engaged[l]);
            let next = rk4(&field, &lane(x, l).map(Fused), &lane(k1, l).map(Fused), Fused(dt));
            for i in 0..4 {
                out[i][l] = next[i].0;
            }
            band |= field.band.get();
        }
        band
    }
}

/// The IMU on lanes: one `Mpu6050` per [`WIDTH`] lanes (the converter, filters and
/// registers every lane's alike, the state each lane's own), each lane sampled on its own
/// rig's clock (a sweep's lanes all at once; an env's robots start apart) with its own
/// noise: copies of its rig's stream and of its IMU's normals drawn ahead, which give the
/// very numbers its run draws. Kept here, the lanes' per-step work touches no rig; the
/// registers go to each lane's sensors before the firmware reads them.
struct ImuLanes {
    imus: [Mpu6050<Wide>; CHUNKS],
    clocks: [ImuClock<f64>; LANES],
    noise: NoiseLanes<LANES, 1>,
    g: Lanes,
}

impl ImuLanes {
    /// None without an IMU (every lane's rig has the same parts).
    fn new(rigs: &[SlopeRig<f64>], models: &[SlopeModel<f64>; LANES]) -> Option<Self> {
        let imu = rigs[0].sensors.imu()?.map(Wide::splat);
        let (clock, rng, noise) = rigs[0].sensors.imu_noise_parts()?;
        let (mut parts, mut clocks) = ([(rng, [noise]); LANES], [clock; LANES]);
        for (l, rig) in rigs.iter().enumerate() {
            let (clock, rng, noise) = rig.sensors.imu_noise_parts()?;
            (parts[l], clocks[l]) = ((rng, [noise]), clock);
        }
        Some(Self { imus: [imu; CHUNKS], clocks, noise: NoiseLanes::new(&parts), g: core::array::from_fn(|l| models[l].params().g) })
    }

    /// `BalanceSensors::sample` on every lane: at its time `ts`, state `x` and derivative
    /// `xdot`, on the ground `hills` (the sensors' ground and wheels are the plant's).
    #[cfg_attr(not(debug_assertions), inline(always))]
    fn sample(&mut self, hills: &Hills, ts: &Lanes, x: &[Lanes; 4], xdot: &[Lanes; 4]) {
        let due = core::array::from_fn(|l| self.clocks[l].due(ts[l]));
        if due.iter().any(|&d| d) {
            self.sample_where(hills, &due, x, xdot);
        }
    }

    /// The lanes `due` sample (the others' IMUs stay as they are).
    #[cfg_attr(not(debug_assertions), inline(always))]
    fn sample_where(&mut self, hills: &Hills, due: &[bool; LANES], x: &[Lanes; 4], xdot: &[Lanes; 4]) {
        let trig = hills.trig_at(&x[2]);
        let [noise] = self.noise.draw(due);
        for (c, imu) in self.imus.iter_mut().enumerate() {
            let lanes = &due[c * WIDTH..(c + 1) * WIDTH];
            if !lanes.iter().any(|&d| d) {
                continue;
            }
            // The IMU as it was, for the lanes not due: only when some are not.
            let before = if lanes.iter().all(|&d| d) { None } else { Some(*imu) };
            sample_chunk(imu, c, hills, &self.g, &trig, noise, x, xdot);
            if let Some(before) = before {
                imu.zip_state(&before, |now, was| Wide(core::array::from_fn(|j| if lanes[j] { now.0[j] } else { was.0[j] })));
            }
        }
    }

    /// Lane `l`'s IMU is `rig`'s, new (its robot `model` started anew), and takes its first
    /// sample as [`Self::new`]'s lanes take theirs: at the state `x` and derivative `xdot`.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    fn restart(&mut self, l: usize, rig: &SlopeRig<f64>, model: &SlopeModel<f64>, hills: &Hills, x: &[Lanes; 4], xdot: &[Lanes; 4]) {
        let (Some(fresh), Some((clock, rng, noise))) = (rig.sensors.imu(), rig.sensors.imu_noise_parts()) else { return };
        (self.clocks[l], self.g[l]) = (clock, model.params().g);
        self.noise.restart(l, rng, &[noise]);
        let due: [bool; LANES] = core::array::from_fn(|m| m == l && self.clocks[l].due(0.0));
        let (c, j) = (l / WIDTH, l % WIDTH);
        let take_j = lane_from(j);
        // Its filters start from its first sample: on a copy of its chunk, unprimed for it,
        // whose lane j is its own (the other lanes' numbers there are not kept; sampled in the
        // chunk itself, the chunk was copied to put them back, 4-5 copies of 5.8 kB a restart).
        let [noise] = self.noise.draw(&due);
        let mut first = self.imus[c];
        first.zip_state(&fresh.map(Wide::splat), take_j);
        first.unprime();
        if due[l] {
            sample_chunk(&mut first, c, hills, &self.g, &hills.trig_at(&x[2]), noise, x, xdot);
        }
        self.imus[c].zip_state(&first, take_j);
    }

    /// The latest registers into each lane's sensors (which the firmware's read takes).
    fn to_sensors(&self, rigs: &mut [SlopeRig<f64>]) {
        for (c, imu) in self.imus.iter().enumerate() {
            let r = imu.reading();
            for j in 0..WIDTH {
                let reading = ImuReading { accel_x: r.accel_x.0[j], accel_z: r.accel_z.0[j], gyro: r.gyro.0[j] };
                rigs[c * WIDTH + j].sensors.set_imu_reading(reading);
            }
        }
    }
}

/// `BalanceSensors::sample`'s IMU sample on chunk `c`'s lanes of `imu` (every lane of the
/// chunk: the caller keeps the lanes due): state `x`, derivative `xdot`, the ground's (sin,
/// cos) `trig` under each lane, gravity `g` and the noise `noise` of every lane.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn sample_chunk(imu: &mut Mpu6050<Wide>, c: usize, hills: &Hills, g: &Lanes, [sin, cos]: &[Lanes; 2], noise: &[Lanes; 4], x: &[Lanes; 4], xdot: &[Lanes; 4]) {
    let (xs, ds) = (state_chunk(x, c), state_chunk(xdot, c));
    let height = imu.settings().height;
    let (radius, g) = (chunk(&hills.radius, c), chunk(g, c));
    let (fx, fz) = specific_force_of(&xs, &ds, chunk(sin, c), chunk(cos, c), radius, height, g);
    imu.sample_with(fx, fz, xs[1], core::array::from_fn(|i| chunk(&noise[i], c)));
}


/// Lane `l` of a state, as the lanes' arithmetic takes it.
#[inline(always)]
fn lane(x: &[Lanes; 4], l: usize) -> [f64; 4] {
    [x[0][l], x[1][l], x[2][l], x[3][l]]
}

/// The 2-DOF rig on a block of lanes: every lane's rig and state, and what carries over
/// from one plant step to the next (the inputs held and pending, the gear trains), so that
/// a loop can step it, stop, and go on. Invalid or missing lanes run an idle copy of a
/// valid robot's rig, whose numbers no one keeps.
pub(crate) struct RigLanes {
    /// Each lane's model (the sample's).
    pub(super) models: [SlopeModel<f64>; LANES],
    /// Each lane's rig, the state, the reading and the input held.
    pub(crate) context: Context,
    plants: RigPlants,
    /// On the heap, as the rigs: it holds every lane's stream and drawn-ahead normals.
    imus: Option<Box<ImuLanes>>,
    dt: f64,
    /// The winding of lanes without a driver.
    stand_in: (Winding<f64>, f64),
    /// Without play and pushes, the steps skip the per-lane work between them (measured:
    /// ~1.1x the rig's speed, `sweep_throughput realism-lanes` with RIG_DROP=friction,backlash).
    idle: bool,
    /// With play, so does each lane that is never pushed while its trains are engaged (but
    /// for a winding without inductance: the trains weigh its lumped current, which
    /// `step_start` gives per lane). That per-lane test also covers `idle`, but without play
    /// the rig measured 1.04-1.06x the CPU time through it (paired timings, 20 and 24 pairs).
    quiet_engaged: [bool; LANES],
    /// Each lane's gear trains over the last step.
    engaged: [bool; LANES],
}

/// The 2-DOF rigs' [`RigContext`].
type Context = RigContext<SlopePlant<f64>, BalanceSensors<f64>, RealActuator<f64>, Lanes, 4, 1>;

impl RigLanes {
    /// The rigs `built` (per lane: its model and rig, or None for an idle lane) at rest in
    /// `x0[l]`, their estimators settled as a run settles them (reads every `period` [s]),
    /// their sensors' registers holding a sample of the initial state; plant steps of `dt`.
    /// None when no lane has a rig.
    /// `x0` is an array, not a closure, so that this is one function: given the kernels'
    /// closures it was compiled once per law and kernel copy (9 times in the wheel, 5-8 s of
    /// the optimiser's time each; LLVM's time trace), though it runs once per block.
    pub(crate) fn start(built: Vec<Option<(SlopeModel<f64>, SlopeRig<f64>)>>, x0: [[f64; 4]; LANES], dt: f64, period: f64) -> Result<Option<Self>, TwipError> {
        let Some(fallback) = built.iter().flatten().next().copied() else {
            return Ok(None);
        };
        let models: [SlopeModel<f64>; LANES] = core::array::from_fn(|l| built.get(l).copied().flatten().map_or(fallback.0, |b| b.0));
        let mut rigs: Vec<SlopeRig<f64>> = (0..LANES).map(|l| built.get(l).copied().flatten().map_or(fallback.1, |b| b.1)).collect();
        let stand_in = stand_in()?;
        let plants = RigPlants::new(&rigs, &models, dt, stand_in);
        let x: [Lanes; 4] = core::array::from_fn(|i| core::array::from_fn(|l| x0[l][i]));
        // The scalar runner's settle, each lane's estimator its own (`Rig::simulate`).
        Self::settle(&mut rigs.iter_mut().enumerate().map(|(l, rig)| (rig, lane(&x, l))).collect::<Vec<_>>(), period);
        // The sensors' registers hold a sample of the initial state.
        let mut imus = ImuLanes::new(&rigs, &models).map(Box::new);
        if let Some(imus) = imus.as_mut() {
            let mut xdot = [[0.0; LANES]; 4];
            for (l, rig) in rigs.iter().enumerate() {
                let d = rig.plant.deriv(&Vector4::from(lane(&x, l)), &SVector::<f64, 1>::zeros());
                for i in 0..4 {
                    xdot[i][l] = d[i];
                }
            }
            imus.sample(&plants.hills, &[0.0; LANES], &x, &xdot);
        }
        let engaged = core::array::from_fn(|l| rigs[l].plant.engaged());
        let idle = rigs.iter().all(|rig| rig.plant.idle_between_steps());
        let quiet_engaged = core::array::from_fn(|l| rigs[l].plant.unpushed() && plants.drive != STEADY);
        Ok(Some(Self {
            models,
            context: RigContext::new(rigs, x),
            plants,
            imus,
            dt,
            stand_in,
            idle,
            quiet_engaged,
            engaged,
        }))
    }

    /// Each rig's sensors settled at rest in its `x0`, reads every `period` [s], as a run
    /// settles them before it starts (`Rig::simulate`), side by side.
    pub(crate) fn settle(robots: &mut [(&mut SlopeRig<f64>, [f64; 4])], period: f64) {
        settle_side_by_side(&mut robots.iter_mut().map(|(rig, x0)| (&mut rig.sensors, x0[0])).collect::<Vec<_>>(), period);
    }

    /// Lane `l` runs `rig` (its robot `model`, [`Self::settle`]d) from rest in `x0`, started
    /// as [`Self::start`] starts a lane (an env's robot started anew); the other lanes go on
    /// as they were.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn restart(&mut self, l: usize, model: SlopeModel<f64>, rig: SlopeRig<f64>, x0: [f64; 4]) {
        self.models[l] = model;
        self.context.restart(l, rig, &Vector4::from(x0));
        let rigs = &mut self.context.rigs;
        self.plants.restart_lane(l, rigs, &self.models, self.dt, self.stand_in);
        let plant = &rigs[l].plant;
        (self.engaged[l], self.quiet_engaged[l]) = (plant.engaged(), plant.unpushed() && self.plants.drive != STEADY);
        if let Some(imus) = self.imus.as_mut() {
            let mut xdot = [[0.0; LANES]; 4];
            let d = rigs[l].plant.deriv(&Vector4::from(x0), &SVector::<f64, 1>::zeros());
            for i in 0..4 {
                xdot[i][l] = d[i];
            }
            imus.restart(l, &rigs[l], &model, &self.plants.hills, &self.context.x, &xdot);
            imus.to_sensors(rigs);
        }
        // The firmware's first read, at t = 0 (as `read_at` reads the lanes `start` started).
        self.context.read_lane(l, 0.0, self.plants.geared);
    }

    /// What the firmware reads at `t`: the IMU's latest registers and the encoders through
    /// each lane's tilt estimator (`RigContext::read_at`).
    #[inline(always)]
    pub(super) fn read(&mut self, t: f64) -> &[Lanes; 4] {
        self.read_at(&[t; LANES])
    }

    /// [`Self::read`] with each lane at its own time `ts`.
    #[inline(always)]
    pub(crate) fn read_at(&mut self, ts: &Lanes) -> &[Lanes; 4] {
        if let Some(imus) = self.imus.as_ref() {
            imus.to_sensors(&mut self.context.rigs);
        }
        self.context.read_at(ts, self.plants.geared)
    }

    /// Plant step `k` (from t = k·dt) under the input held: the pieces that act between
    /// steps, the gear trains, the IMU's sample and RK4. Writes the state after the step
    /// into `next` (the caller moves the lanes that go on there, `x`; written in place, as
    /// a returned array it was copied twice a step) and returns what the plants got at the
    /// step's start (`Observer::drive`; [`Self::beyond`]: whether the commands applied are
    /// beyond the drivers).
    #[inline(always)]
    pub(super) fn step<const COPY: u8>(&mut self, k: usize, next: &mut [Lanes; 4]) -> Lanes {
        self.step_at::<COPY>(&[k; LANES], next)
    }

    /// [`Self::step`] with each lane at its own step `ks` (an env's robots start apart).
    /// A function of its own per kernel copy (`out_of_line_in`), shared by the laws' kernels
    /// and the envs: inlined, it was compiled again for each of them and copy (LLVM's time trace).
    #[inline(always)]
    pub(crate) fn step_at<const COPY: u8>(&mut self, ks: &[usize; LANES], next: &mut [Lanes; 4]) -> Lanes {
        super::out_of_line_in::<COPY, _>(#[inline(always)] || self.step_in::<COPY>(ks, next))
    }

    #[inline(always)]
    fn step_in<const COPY: u8>(&mut self, ks: &[usize; LANES], next: &mut [Lanes; 4]) -> Lanes {
        let (dt, u) = (self.dt, self.context.input());
        let ts: Lanes = core::array::from_fn(|l| dt * ks[l] as f64);
        let (plants, x, engaged) = (&mut self.plants, &mut self.context.x, &mut self.engaged);
        // What the plants get at the step's start (`Observer::drive`): the held current,
        // or a winding's current (with inductance, once the last step has ended, below).
        let mut delivered = u;
        if plants.drive == STEADY {
            for (l, rig) in self.context.rigs.iter().enumerate() {
                delivered[l] = rig.plant.delivered(&Vector4::from(lane(x, l)), &SVector::<f64, 1>::new(u[l]))[0];
            }
        }
        // Per lane, the last step's `step_ended` and this one's `between_steps`: with
        // backlash, open rotors that reach a flank engage in an impact that sets the
        // velocities; the winding's step starts (with inductance, on lanes: the motors'
        // speeds where the last step ended and this one starts); then the trains weigh the
        // derivative at the step's start (on lanes) and may open.
        let stepped = plants.drive == STEPPED;
        let (mut current, mut finished, mut starts) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        if self.idle {
            // Nothing acts between steps: what the lanes' plants take is known on lanes.
            match plants.drive {
                // The motors turn with the wheels (`RealPlant::motor_speeds` without an open rotor).
                STEPPED => {
                    finished = core::array::from_fn(|l| x[3][l] - x[1][l]);
                    starts = finished;
                }
                // The current is the input.
                HELD => current = u,
                // The stages turn the duty into current (`input`); only play reads `current`.
                _ => {}
            }
        } else {
            for (l, rig) in self.context.rigs.iter_mut().enumerate() {
                if self.quiet_engaged[l] && engaged[l] {
                    // Nothing acts between steps (`RealPlant::unpushed`): as when `idle`.
                    if stepped {
                        finished[l] = x[3][l] - x[1][l];
                        starts[l] = finished[l];
                    } else {
                        current[l] = u[l];
                    }
                    continue;
                }
                let mut xl = Vector4::from(lane(x, l));
                if stepped {
                    finished[l] = rig.plant.motor_speed(&xl).unwrap_or_default();
                    rig.plant.ground_start(ts[l], dt, &mut xl);
                    starts[l] = rig.plant.motor_speed(&xl).unwrap_or_default();
                } else {
                    current[l] = rig.plant.lumped_step_start(ts[l], dt, &mut xl, u[l]);
                }
                for i in 0..4 {
                    x[i][l] = xl[i];
                }
                engaged[l] = rig.plant.engaged();
            }
        }
        if stepped {
            plants.windings.step(&ks.map(|k| k > 0), &finished, &u, &starts, &mut current);
            plants.windings.delivered(&mut delivered);
        }
        let before = *engaged;
        // The trains weigh the derivative at the step's start; with the trains as they
        // were, it is RK4's first stage. (Written in place, not as an `Option`: moving the
        // Option cost two copies of it per step.)
        let mut k1 = [[0.0; LANES]; 4];
        if plants.geared {
            let tau = plants.geared_motion::<COPY>(x, &current, engaged, &mut k1);
            for (l, rig) in self.context.rigs.iter_mut().enumerate() {
                // Trains engaged that stay so: no step to take, nothing to turn.
                if before[l] && rig.plant.lumped_stays_engaged(current[l], k1[3][l] - k1[1][l], tau[l]) {
                    continue;
                }
                let xl = Vector4::from(lane(x, l));
                let mean = if stepped { plants.windings.mean(l) } else { rig.plant.mean_current(&xl, u[l]) };
                rig.plant.lumped_gear_next(&xl, current[l], mean, &Vector4::from(lane(&k1, l)), tau[l]);
                engaged[l] = rig.plant.engaged();
                // `turn_motors`: the motors turn with the rotors of trains that just opened
                // (the step's end reads their speed; those open before turn so already).
                if before[l] && !engaged[l] {
                    rig.plant.turn_motors();
                }
            }
        }
        // Held over the step: the lumped current at its start (with inductance, the
        // winding's step gives the later stages'), or the duty a winding without inductance
        // turns into current at each stage.
        let input = if plants.drive == STEADY { u } else { current };
        if !(plants.geared && *engaged == before) {
            k1 = plants.k1::<COPY>(x, &input, engaged);
        }
        if let Some(imus) = self.imus.as_mut() {
            imus.sample(&plants.hills, &ts, x, &k1);
        }
        plants.rk4::<COPY>(x, &input, engaged, &k1, dt, next);
        delivered
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hardware::realism::Realism;
    use crate::sweep::block::kinds::state_bits as bits;
    use crate::sweep::block::KernelCopy;

    const COPY: u8 = KernelCopy::Baseline as u8;
    const DT: f64 = 1e-3;

    /// A step's first stage by the slip law (`OUTSIDE`) has the stick band's bits, and so do
    /// its later stages while no wheel meets the band; the first try says when one does, and
    /// `rk4` then takes the step again, so it has the band's bits either way. The thesis-like
    /// robot's stick band (0.1 rad/s), no play (every train engaged) and no driver (the
    /// current held), on flat ground; each lane's wheels start a little faster relative to
    /// the body than the one before.
    #[test]
    fn a_step_clear_of_the_stick_band_has_its_bits_and_one_into_it_is_taken_again() {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
        let realism = Realism { motor: None, backlash: None, ..Realism::thesis_like() };
        let rigs: Vec<SlopeRig<f64>> = (0..LANES).map(|_| realism.build(&model, DT).unwrap()).collect();
        let plants = RigPlants::new(&rigs, &[model; LANES], DT, stand_in().unwrap());
        assert_eq!((plants.gear, plants.drive, plants.hills.changes), (STICK, HELD, 0));
        let engaged = [true; LANES];
        // (wheel speed relative to the body, current): far from the band and staying so;
        // near it (0.25 rad/s), braked into it within the step.
        for (w0, current, enters) in [(3.0, 0.5, false), (0.25, -4.0, true)] {
            let pitch_rate: Lanes = core::array::from_fn(|l| 0.1 * l as f64 / LANES as f64);
            let x = [[0.02; LANES], pitch_rate, [0.0; LANES], core::array::from_fn(|l| pitch_rate[l] + w0 + 0.002 * l as f64)];
            let u = [current; LANES];
            assert!(plants.outside(&x, &engaged), "w0 = {w0}: the first try is taken");
            // The first stage, at a state clear of the band, by the slip law: the band's bits.
            let k1 = plants.k1::<COPY>(&x, &u, &engaged);
            assert_eq!(bits(&k1), bits(&plants.k1_of::<STICK, HELD, false, 0>(&x, &u, &engaged)), "w0 = {w0}");
            let (mut stick, mut outside) = ([[f64::NAN; LANES]; 4], [[f64::NAN; LANES]; 4]);
            let stick_band = plants.rk4_of::<STICK, HELD, false, 0>(&x, &u, &engaged, &k1, DT, &mut stick);
            let band = plants.rk4_of::<OUTSIDE, HELD, false, 0>(&x, &u, &engaged, &k1, DT, &mut outside);
            assert!(!stick_band, "only the first try notes the band");
            assert_eq!(band, enters, "w0 = {w0}");
            // Into the band the slip law is not the band's: the step must be taken again,
            // over the first try's state in `next`. From NaN, so that either try leaving a
            // lane unwritten fails.
            assert_eq!(bits(&outside) == bits(&stick), !enters, "w0 = {w0}");
            let mut next = [[f64::NAN; LANES]; 4];
            plants.rk4::<COPY>(&x, &u, &engaged, &k1, DT, &mut next);
            assert_eq!(bits(&next), bits(&stick), "w0 = {w0}");
        }
    }
}
