//! The 3-DOF rig on a block of [`LANES`] robots, as a state object stepped one plant step
//! at a time ([`PlanarRigLanes`]): what a closed loop around it needs (the sensors' read,
//! the actuator's drive, the held input and its delay, one plant step), with the loop's
//! controller and metrics outside it (`planar_rig::run_planar_rig_block`).
//!
//! Each lane's actuator, windings, gear play, pushes, encoders and tilt estimator are its
//! own rig's parts, the very objects a run uses: they act between steps or once per control
//! period on a lane's numbers. The plant's RK4 (`model::planar::engaged_motion`, and
//! `open_motion` for a lane whose gear trains are open: the gearhead friction's law, the
//! body force and the windings' `Winding::steady_current` or, with inductance,
//! `Winding::stepped_current`) and the IMUs (`planar_rig::sample_imus`, each lane's noise
//! from a copy of its rig's stream) are the run's own source on lanes, which the compiler
//! vectorises; the gear trains weigh the lanes' first stage.
use alloc::boxed::Box;
use alloc::vec::Vec;
use core::cell::Cell;

use nalgebra::SVector;

use super::planar::Plants;
use super::planar_terrain::TerrainLanes;
use super::rig_context::{lane, set_lane, RigContext};
use super::winding::WindingLanes;
use super::{chunk, CHUNKS};
use crate::Dynamics;
use crate::hardware::disturbance::Force;
use crate::hardware::driver::{MotorDriver, Winding};
use crate::hardware::imu::{lane_from, ImuClock, ImuReading, Mpu6050, NoiseLanes};
use crate::hardware::planar_rig::{body_force, flank_contact, sample_imus, sample_imus_in_frame, PlanarActuator, PlanarPlant, PlanarRig, PlanarSensors};
use crate::hardware::realism::RigPlant as _;
use crate::hardware::settle::settle_side_by_side;
use crate::model::friction::{Friction, Gearhead};
use crate::model::integrate::{rk4, Field, Stage};
use crate::model::lane::{fill, Fused, Lane, Wide, WIDTH};
use crate::model::dynamics::Halt;
use crate::model::planar::{engaged_motion, open_motion, wheel_speeds, PlanarCoefficients, PlanarModel};
use crate::model::terrain_model::{geared_in_frame, motion_of, normal_forces_of, pitch_acceleration_of, plane_state, Frame};
use crate::sweep::lanes::{Lanes, LANES};
use crate::{RobotParams, TwipError};

// The plant's kinds, decided once per block (`kinds`): the gearhead friction's (`GEAR`; a stick
// band's law as the slip law, `OUTSIDE`, decided per step) and what drives it (`DRIVE`: the
// motor torques held over the step, or the windings').
use super::kinds::{clear_of_band, FREE, HELD, OUTSIDE, SLIP, STEADY, STEPPED, STICK};

/// One lane's plant over a step, its trains as they are (`GEARED`: some lane's in the block
/// may be open): the motor torques held, or at the step's start with the windings' steps
/// under way (`STEPPED`), or (`STEADY`) the duties, which the windings turn into current at
/// each stage at the wheels' speeds.
struct RigField<'a, const GEAR: u8, const DRIVE: u8, const GEARED: bool> {
    k: PlanarCoefficients<Fused>,
    /// Which gear trains are engaged over this step (backlash: set between steps), and the
    /// rotor inertia per wheel that an open one takes off.
    engaged: [bool; 2],
    rotor: Fused,
    friction: &'a Friction<Fused>,
    u: [Fused; 2],
    windings: [Winding<Fused>; 2],
    per_amp: Fused,
    /// A constant force on the body (zero: none), always added: a branch on it would keep
    /// the lanes' loop from vectorising, and zeros change nothing but the sign of a zero.
    force: Force<Fused>,
    /// Whether some stage found a wheel in the stick band (`OUTSIDE` only).
    band: Cell<bool>,
}

impl<const GEAR: u8, const DRIVE: u8, const GEARED: bool> RigField<'_, GEAR, DRIVE, GEARED> {
    /// The derivative and each wheel's gearhead torque (`RealPlant::deriv`'s) at
    /// the step's start.
    #[inline(always)]
    fn motion(&self, x: &[Fused; 7]) -> ([Fused; 7], [Fused; 2]) {
        // As `RealPlant::inputs_at` with the trains engaged (motor speed = wheel speed; an
        // open train's torque is not read).
        let u = if DRIVE == STEADY {
            let [w_r, w_l] = wheel_speeds(&self.k, x);
            [self.per_amp * self.windings[0].steady_current(self.u[0], w_r), self.per_amp * self.windings[1].steady_current(self.u[1], w_l)]
        } else {
            self.u
        };
        self.motion_under(x, u)
    }

    /// The gearheads' law this kernel instance was compiled for (`GEAR`).
    #[inline(always)]
    fn gearhead(&self) -> Gearhead<'_, Fused> {
        match GEAR {
            FREE => Gearhead::Free,
            SLIP => Gearhead::Slip(self.friction),
            OUTSIDE => Gearhead::Outside(self.friction, &self.band),
            _ => Gearhead::Stick(self.friction),
        }
    }

    /// [`Self::motion`] under the wheel torques `u`.
    #[inline(always)]
    fn motion_under(&self, x: &[Fused; 7], u: [Fused; 2]) -> ([Fused; 7], [Fused; 2]) {
        let gear = self.gearhead();
        let force = self.force;
        let extra = |s, cp| Some(body_force(&force, s, cp));
        let (d, tau) = engaged_motion(&self.k, gear, x, u, extra);
        if !GEARED {
            return (d, tau);
        }
        // With a train open somewhere in the block: both computed and one kept, no branch per lane.
        let (open_d, open_tau) = open_motion(&self.k, gear, x, u, self.engaged, self.rotor, extra);
        let all = self.engaged[0] & self.engaged[1];
        (fill(|i| Fused::select(all, d[i], open_d[i])), fill(|i| Fused::select(all, tau[i], open_tau[i])))
    }
}

impl<const GEAR: u8, const DRIVE: u8, const GEARED: bool> Field<Fused, 7> for RigField<'_, GEAR, DRIVE, GEARED> {
    #[inline(always)]
    fn at(&self, x: &[Fused; 7]) -> [Fused; 7] {
        self.motion(x).0
    }

    // As `RealPlant::deriv_at_stage`.
    #[inline(always)]
    fn at_stage(&self, x: &[Fused; 7], stage: Stage) -> [Fused; 7] {
        if DRIVE == STEPPED {
            // Written out, not through a closure: a profile found such a closure out of
            // line in a kernel 3x slower than this one.
            let [w_r, w_l] = wheel_speeds(&self.k, x);
            let torques = [self.per_amp * self.windings[0].stepped_current(stage, w_r), self.per_amp * self.windings[1].stepped_current(stage, w_l)];
            self.motion_under(x, torques).0
        } else {
            self.motion(x).0
        }
    }
}

/// On terrain (docs/terrain.md, "The rig on terrain"): as `RealPlant::deriv_at_stage`
/// with its ground, the terrain model's geared derivative (`geared_in_frame`, a run's own
/// source) on the ground `g` = (gradient x, gradient y, (M_b + M_w) g) under the lane, the
/// windings driven at the wheels' speeds relative to the body's pitch about the axle.
impl<const GEAR: u8, const DRIVE: u8, const GEARED: bool> RigField<'_, GEAR, DRIVE, GEARED> {
    /// [`Self::motion`] on the ground `g`.
    #[inline(always)]
    fn motion_on(&self, x: &[Fused; 7], g: [Fused; 3]) -> ([Fused; 7], [Fused; 2]) {
        let (f, xp) = in_frame(x, g);
        let u = if DRIVE == STEADY {
            let [w_r, w_l] = wheel_speeds(&self.k, &xp);
            [self.per_amp * self.windings[0].steady_current(self.u[0], w_r), self.per_amp * self.windings[1].steady_current(self.u[1], w_l)]
        } else {
            self.u
        };
        self.motion_in(x, &f, &xp, u, g[2])
    }

    /// [`Field::at_stage`] on the ground `g`.
    #[inline(always)]
    fn at_stage_on(&self, x: &[Fused; 7], stage: Stage, g: [Fused; 3]) -> [Fused; 7] {
        if DRIVE != STEPPED {
            return self.motion_on(x, g).0;
        }
        let (f, xp) = in_frame(x, g);
        let [w_r, w_l] = wheel_speeds(&self.k, &xp);
        let torques = [self.per_amp * self.windings[0].stepped_current(stage, w_r), self.per_amp * self.windings[1].stepped_current(stage, w_l)];
        self.motion_in(x, &f, &xp, torques, g[2]).0
    }

    /// The derivative and gearhead torques under the wheel torques `u` in the frame `f`
    /// (`xp`: the state in it), the robot's weight `weight`.
    #[inline(always)]
    fn motion_in(&self, x: &[Fused; 7], f: &Frame<Fused>, xp: &[Fused; 7], u: [Fused; 2], weight: Fused) -> ([Fused; 7], [Fused; 2]) {
        let gear = self.gearhead();
        let force = self.force;
        let extra = |s, cp| Some(body_force(&force, s, cp));
        let (nu, tau) = geared_in_frame(&self.k, weight, gear, f, xp, u, None, extra);
        if !GEARED {
            return (motion_of(x, &nu, f), tau);
        }
        // With a train open somewhere in the block: both computed and one kept, as on flat ground.
        let (open_nu, open_tau) = geared_in_frame(&self.k, weight, gear, f, xp, u, Some((self.engaged, self.rotor)), extra);
        let all = self.engaged[0] & self.engaged[1];
        let nu = fill(|i| Fused::select(all, nu[i], open_nu[i]));
        (motion_of(x, &nu, f), fill(|i| Fused::select(all, tau[i], open_tau[i])))
    }
}

/// The local plane's frame at `x` on the ground `g` (its gradient first) and the state in it.
#[inline(always)]
fn in_frame(x: &[Fused; 7], g: [Fused; 3]) -> (Frame<Fused>, [Fused; 7]) {
    let (s, co) = Fused::sincos(x[2]);
    let f = Frame::new(g[0], g[1], s, co);
    (f, plane_state(x, &f))
}

/// One lane's rig plant on its ground over a step, its trains as they are: its local plane
/// looked up at every RK4 stage (a drawn plane's gradient is the lane's constant), so that a
/// lane's whole step stays one loop body, as on flat ground.
struct LaneOnGround<'a, const GEAR: u8, const DRIVE: u8, const GEARED: bool> {
    field: RigField<'a, GEAR, DRIVE, GEARED>,
    ground: &'a TerrainLanes,
    l: usize,
    weight: Fused,
}

impl<const GEAR: u8, const DRIVE: u8, const GEARED: bool> LaneOnGround<'_, GEAR, DRIVE, GEARED> {
    /// The ground under `x`: its gradient and the robot's weight.
    #[inline(always)]
    fn at(&self, x: &[Fused; 7]) -> [Fused; 3] {
        let [gx, gy] = self.ground.gradient(self.l, x[0].0, x[1].0);
        [Fused(gx), Fused(gy), self.weight]
    }
}

impl<const GEAR: u8, const DRIVE: u8, const GEARED: bool> Field<Fused, 7> for LaneOnGround<'_, GEAR, DRIVE, GEARED> {
    #[inline(always)]
    fn at(&self, x: &[Fused; 7]) -> [Fused; 7] {
        self.field.motion_on(x, LaneOnGround::at(self, x)).0
    }

    #[inline(always)]
    fn at_stage(&self, x: &[Fused; 7], stage: Stage) -> [Fused; 7] {
        self.field.at_stage_on(x, stage, LaneOnGround::at(self, x))
    }
}

/// The lanes' plants: coefficients per lane, the friction all share, each lane's force and
/// windings.
struct RigPlants {
    plants: Plants,
    gear: u8,
    friction: Friction<Fused>,
    drive: u8,
    /// Each lane's right and left windings and the torque per ampere, when there is a
    /// driver (else any, unused).
    windings: [WindingLanes; 2],
    /// Side by side (`Force::side_by_side`).
    forces: Force<Lanes>,
    /// Each lane's rotor inertia per wheel (an open train takes it off).
    rotors: Lanes,
}

/// Any valid windings, for lanes that never evaluate one (no driver).
fn stand_in() -> Result<([Winding<f64>; 2], f64), TwipError> {
    Ok(([Winding::new(&MotorDriver::gb37y3530(), &RobotParams::balanbot())?; 2], 1.0))
}

impl RigPlants {
    /// The plants of `rigs` (each lane's `models`' robot) for steps of `dt`.
    fn new(rigs: &[PlanarRig<f64>], models: &[PlanarModel<f64>; LANES], dt: f64, stand_in: ([Winding<f64>; 2], f64)) -> Self {
        let drives: [([Winding<f64>; 2], f64); LANES] = core::array::from_fn(|l| drives_of(&rigs[l], dt, stand_in));
        let (gear, friction, drive) = shared_parts(&rigs[0]);
        Self {
            // The rig's model: the sample's, with the realism's gearhead friction.
            plants: Plants::new(&core::array::from_fn(|l| *rigs[l].plant.model())),
            gear,
            friction,
            drive,
            windings: core::array::from_fn(|wheel| WindingLanes::new(&drives.map(|(w, per_amp)| (w[wheel], per_amp)))),
            forces: Force::side_by_side(&core::array::from_fn(|l| rigs[l].plant.force())),
            rotors: core::array::from_fn(|l| models[l].rotor_per_wheel()),
        }
    }

    /// Lane `l`'s numbers anew from its rig `rigs[l]` (a robot started anew: its windings'
    /// state too), the other lanes' as they are (their windings' states are theirs): what
    /// [`Self::new`] of `rigs` gives (a lane's numbers are its rig's and model's, which do
    /// not change, and the parts every lane shares are lane 0's), without making every lane's
    /// anew (`perf` of Track-v0's rig: 2-3 % of the samples in `new` at each restart).
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    fn restart_lane(&mut self, l: usize, rigs: &[PlanarRig<f64>], models: &[PlanarModel<f64>; LANES], dt: f64, stand_in: ([Winding<f64>; 2], f64)) {
        (self.gear, self.friction, self.drive) = shared_parts(&rigs[0]);
        self.plants.set_lane(l, rigs[l].plant.model());
        let (w, per_amp) = drives_of(&rigs[l], dt, stand_in);
        for (wheel, lanes) in self.windings.iter_mut().enumerate() {
            lanes.set_lane(l, (w[wheel], per_amp));
        }
        self.forces.set_lane(l, rigs[l].plant.force());
        self.rotors[l] = models[l].rotor_per_wheel();
    }
}

/// `rig`'s windings with their factors for steps of `dt` (their steps are set each step)
/// and the wheel torque per ampere; the stand-ins for a lane that never evaluates one (no driver).
fn drives_of(rig: &PlanarRig<f64>, dt: f64, stand_in: ([Winding<f64>; 2], f64)) -> ([Winding<f64>; 2], f64) {
    rig.plant.drives().map_or(stand_in, |(mut w, per_amp)| {
        w.iter_mut().for_each(|w| w.prepare(dt));
        (w, per_amp)
    })
}

/// What every lane's plant shares, from lane 0's rig `rig` (every lane's realism has the same
/// parts): the gearhead's kind and friction, the drive's kind.
fn shared_parts(rig: &PlanarRig<f64>) -> (u8, Friction<Fused>, u8) {
    let friction = rig.plant.model().friction().copied();
    (
        super::kinds::gear(friction.as_ref()),
        // Unused without a friction: any friction's numbers.
        friction.unwrap_or_else(Friction::gb37).map(Fused),
        super::kinds::drive(rig.plant.drives().map(|(w, _)| w[0].inductive())),
    )
}

/// `$self.$run::<GEAR, DRIVE, GEARED>(args)` for the plants' kinds; GEARED only while
/// some lane's trains are open (`$trains`: all engaged is the plain plant, bit for bit).
macro_rules! by_kind {
    ($self:ident, $trains:ident, $run:ident($($arg:expr),*)) => {
        if $trains.iter().all(|t| t[0] & t[1]) {
            by_kind!(@gear $self, false, $run($($arg),*))
        } else {
            by_kind!(@gear $self, true, $run($($arg),*))
        }
    };
    (@gear $self:ident, $geared:literal, $run:ident($($arg:expr),*)) => {
        match $self.gear {
            FREE => by_kind!(@drive $self, FREE, $geared, $run($($arg),*)),
            SLIP => by_kind!(@drive $self, SLIP, $geared, $run($($arg),*)),
            _ => by_kind!(@drive $self, STICK, $geared, $run($($arg),*)),
        }
    };
    (@drive $self:ident, $gear:ident, $geared:literal, $run:ident($($arg:expr),*)) => {
        match $self.drive {
            HELD => super::out_of_line_in::<COPY, _>(#[inline(always)] || $self.$run::<$gear, HELD, $geared>($($arg),*)),
            STEADY => super::out_of_line_in::<COPY, _>(#[inline(always)] || $self.$run::<$gear, STEADY, $geared>($($arg),*)),
            _ => super::out_of_line_in::<COPY, _>(#[inline(always)] || $self.$run::<$gear, STEPPED, $geared>($($arg),*)),
        }
    };
}

// Each kind's loop is a function of its own per kernel copy (`out_of_line_in`), compiled
// with that copy's instructions and shared by the controller laws.
impl RigPlants {
    /// Lane `l`'s plant under the input `u` held (motor torques, at the step's start with
    /// inductance, or duties without).
    #[inline(always)]
    fn field<const GEAR: u8, const DRIVE: u8, const GEARED: bool>(&self, l: usize, u: &[Lanes; 2], trains: &[[bool; 2]; LANES]) -> RigField<'_, GEAR, DRIVE, GEARED> {
        let ((right, per_amp), (left, _)) = (self.windings[0].lane(l), self.windings[1].lane(l));
        RigField {
            k: self.plants.lane(l),
            engaged: trains[l],
            rotor: Fused(self.rotors[l]),
            friction: &self.friction,
            u: [Fused(u[0][l]), Fused(u[1][l])],
            windings: [right, left],
            per_amp,
            force: self.forces.lane(l, Fused),
            band: Cell::new(false),
        }
    }

    /// The derivative (into `d`, as the 2-DOF rig's `geared_motion`) and each wheel's
    /// gearhead torque on every lane, its trains as they are (`trains`): RK4's first stage,
    /// and what the gear trains weigh. On `ground` (None: flat ground), a runtime choice
    /// inside each kind's loop.
    #[inline(always)]
    fn motion<const COPY: u8>(&self, x: &[Lanes; 7], u: &[Lanes; 2], trains: &[[bool; 2]; LANES], ground: Option<&TerrainLanes>, d: &mut [Lanes; 7]) -> [Lanes; 2] {
        // On flat ground, where `outside`, by the slip law: the stick band's bits at a state
        // clear of the band (on terrain the law reads the wheels' speeds in the plane's frame).
        if ground.is_none() && self.outside(x, trains) {
            return by_kind!(@drive self, OUTSIDE, false, motion_of(x, u, trains, ground, d));
        }
        by_kind!(self, trains, motion_of(x, u, trains, ground, d))
    }

    #[cfg_attr(not(debug_assertions), inline(always))]
    fn motion_of<const GEAR: u8, const DRIVE: u8, const GEARED: bool>(&self, x: &[Lanes; 7], u: &[Lanes; 2], trains: &[[bool; 2]; LANES], ground: Option<&TerrainLanes>, d: &mut [Lanes; 7]) -> [Lanes; 2] {
        let mut tau = [[0.0; LANES]; 2];
        if let Some(ground) = ground {
            // The flat loop below, each lane on its ground (a loop of its own: the flat one
            // keeps its code).
            for l in 0..LANES {
                let xl = fill(|i| Fused(x[i][l]));
                let on = LaneOnGround { field: self.field::<GEAR, DRIVE, GEARED>(l, u, trains), ground, l, weight: Fused(ground.weight(l)) };
                let (dl, tl) = on.field.motion_on(&xl, on.at(&xl));
                for i in 0..7 {
                    d[i][l] = dl[i].0;
                }
                tau[0][l] = tl[0].0;
                tau[1][l] = tl[1].0;
            }
            return tau;
        }
        for l in 0..LANES {
            let (dl, tl) = self.field::<GEAR, DRIVE, GEARED>(l, u, trains).motion(&fill(|i| Fused(x[i][l])));
            for i in 0..7 {
                d[i][l] = dl[i].0;
            }
            tau[0][l] = tl[0].0;
            tau[1][l] = tl[1].0;
        }
        tau
    }

    /// RK4's later stages from each lane's first `k1` on every lane into `next`, its trains
    /// as they are over the step (`trains`). With a stick band, where every train is engaged
    /// and no lane's wheel starts near the band, first with the slip law (`OUTSIDE`), as the
    /// 2-DOF rig's steps are.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn rk4<const COPY: u8>(&self, x: &[Lanes; 7], u: &[Lanes; 2], trains: &[[bool; 2]; LANES], k1: &[Lanes; 7], dt: f64, ground: Option<&TerrainLanes>, next: &mut [Lanes; 7]) {
        if self.outside(x, trains) {
            let band = by_kind!(@drive self, OUTSIDE, false, rk4_of(x, u, trains, k1, dt, ground, next));
            if !band {
                return;
            }
        }
        by_kind!(self, trains, rk4_of(x, u, trains, k1, dt, ground, next));
    }

    /// Whether a stick band's law may be taken as the slip law from `x` on: every train
    /// engaged and every lane's wheels at least twice the band's half-width from rest
    /// relative to the body (the 2-DOF rig's `outside`).
    #[inline(always)]
    fn outside(&self, x: &[Lanes; 7], trains: &[[bool; 2]; LANES]) -> bool {
        let clear = |l: usize| self.plants.lane(l).wheels().speeds(&fill(|i| Fused(x[i][l]))).iter().all(|w| clear_of_band(&self.friction, w.0));
        self.gear == STICK && trains.iter().all(|t| t[0] & t[1]) && (0..LANES).all(clear)
    }

    #[cfg_attr(not(debug_assertions), inline(always))]
    #[allow(clippy::too_many_arguments)]
    fn rk4_of<const GEAR: u8, const DRIVE: u8, const GEARED: bool>(&self, x: &[Lanes; 7], u: &[Lanes; 2], trains: &[[bool; 2]; LANES], k1: &[Lanes; 7], dt: f64, ground: Option<&TerrainLanes>, out: &mut [Lanes; 7]) -> bool {
        let mut band = false;
        if let Some(ground) = ground {
            // The flat loop below, each lane's whole step on its ground (a loop of its own).
            for l in 0..LANES {
                let on = LaneOnGround { field: self.field::<GEAR, DRIVE, GEARED>(l, u, trains), ground, l, weight: Fused(ground.weight(l)) };
                let next = rk4(&on, &fill(|i| Fused(x[i][l])), &fill(|i| Fused(k1[i][l])), Fused(dt));
                for i in 0..7 {
                    out[i][l] = next[i].0;
                }
                band |= on.field.band.get();
            }
            return band;
        }
        for l in 0..LANES {
            let field = self.field::<GEAR, DRIVE, GEARED>(l, u, trains);
            let next = rk4(&field, &fill(|i| Fused(x[i][l])), &fill(|i| Fused(k1[i][l])), Fused(dt));
            for i in 0..7 {
                out[i][l] = next[i].0;
            }
            band |= field.band.get();
        }
        band
    }
}

/// The IMUs on lanes, as the 2-DOF rig's: per [`WIDTH`] lanes one pitch `Mpu6050` and
/// one yaw gyro (the converters, filters and registers every lane's alike, the state each
/// lane's own), each lane sampled on its own rig's clock with its own noise: copies of
/// its rig's stream and of its IMUs' normals drawn ahead, which give the very numbers its
/// run draws. The registers go to each lane's sensors before the firmware reads them.
struct ImuLanes {
    imus: [(Mpu6050<Wide>, Mpu6050<Wide>); CHUNKS],
    clocks: [ImuClock<f64>; LANES],
    noise: NoiseLanes<LANES, 2>,
    /// Each lane's wheel radius, its inverse and gravity.
    radius: Lanes,
    inv_r: Lanes,
    g: Lanes,
}

impl ImuLanes {
    /// None without an IMU (every lane's rig has the same parts).
    fn new(rigs: &[PlanarRig<f64>], models: &[PlanarModel<f64>; LANES]) -> Option<Self> {
        let ([pitch, yaw], clock, rng, noise) = rigs[0].sensors.imu_noise_parts()?;
        let (mut parts, mut clocks) = ([(rng, noise); LANES], [clock; LANES]);
        for (l, rig) in rigs.iter().enumerate() {
            let (_, clock, rng, noise) = rig.sensors.imu_noise_parts()?;
            (parts[l], clocks[l]) = ((rng, noise), clock);
        }
        let radius: Lanes = core::array::from_fn(|l| models[l].params().wheel_radius);
        Some(Self {
            imus: [(pitch.map(Wide::splat), yaw.map(Wide::splat)); CHUNKS],
            clocks,
            noise: NoiseLanes::new(&parts),
            radius,
            inv_r: radius.map(|r| 1.0 / r),
            g: core::array::from_fn(|l| models[l].params().g),
        })
    }

    /// `PlanarSensors::sample`'s IMU part on every lane, at its time `ts`, state `x` and
    /// derivative `xdot`.
    #[cfg_attr(not(debug_assertions), inline(always))]
    fn sample(&mut self, ts: &Lanes, x: &[Lanes; 7], xdot: &[Lanes; 7], ground: Option<&TerrainLanes>) {
        let due = core::array::from_fn(|l| self.clocks[l].due(ts[l]));
        if due.iter().any(|&d| d) {
            self.sample_where(&due, x, xdot, ground);
        }
    }

    /// The lanes `due` sample (the others' IMUs stay as they are).
    #[cfg_attr(not(debug_assertions), inline(always))]
    /// On `ground` (None: flat), as `PlanarSensors::sample`'s `sample_imus_on_terrain`.
    fn sample_where(&mut self, due: &[bool; LANES], x: &[Lanes; 7], xdot: &[Lanes; 7], ground: Option<&TerrainLanes>) {
        let noise = self.noise.draw(due);
        let gradients = ground.map(|g| g.gradients(&x[0], &x[1]));
        for (c, (pitch, yaw)) in self.imus.iter_mut().enumerate() {
            let lanes = &due[c * WIDTH..(c + 1) * WIDTH];
            if !lanes.iter().any(|&d| d) {
                continue;
            }
            // The IMUs as they were, for the lanes not due: only when some are not (copies of
            // 11.5 kB a chunk a step were 7.6 % of the 3-DOF rig env's step, measured by
            // `perf`, when every lane's IMU samples at every step).
            let all_due = lanes.iter().all(|&d| d);
            let before = if all_due { None } else { Some((*pitch, *yaw)) };
            let dims = (chunk(&self.radius, c), chunk(&self.inv_r, c), pitch.settings().height, chunk(&self.g, c));
            sample_chunk((pitch, yaw), c, dims, noise, x, xdot, gradients.as_ref());
            if let Some(before) = before {
                let keep = |now: Wide, was: Wide| Wide(core::array::from_fn(|j| if lanes[j] { now.0[j] } else { was.0[j] }));
                pitch.zip_state(&before.0, keep);
                yaw.zip_state(&before.1, keep);
            }
        }
    }

    /// Lane `l`'s IMUs are `rig`'s, new (its robot `model` started anew), and take their
    /// first sample as [`Self::new`]'s lanes take theirs: at the state `x` and derivative `xdot`.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    fn restart(&mut self, l: usize, rig: &PlanarRig<f64>, model: &PlanarModel<f64>, x: &[Lanes; 7], xdot: &[Lanes; 7]) {
        let Some(([pitch, yaw], clock, rng, noise)) = rig.sensors.imu_noise_parts() else { return };
        let r = model.params().wheel_radius;
        (self.clocks[l], self.radius[l], self.inv_r[l], self.g[l]) = (clock, r, 1.0 / r, model.params().g);
        self.noise.restart(l, rng, &noise);
        let due: [bool; LANES] = core::array::from_fn(|m| m == l && self.clocks[l].due(0.0));
        let (c, j) = (l / WIDTH, l % WIDTH);
        let take_j = lane_from(j);
        // Their filters start from their first sample: on a copy of the chunk's, unprimed for
        // it, whose lane j is this robot's (the other lanes' numbers there are not kept; sampled
        // in the chunk itself, the chunk was copied to put them back, 4-5 copies of 11.6 kB).
        let noise = self.noise.draw(&due);
        let (mut p, mut y) = self.imus[c];
        p.zip_state(&pitch.map(Wide::splat), take_j);
        y.zip_state(&yaw.map(Wide::splat), take_j);
        p.unprime();
        y.unprime();
        if due[l] {
            let dims = (chunk(&self.radius, c), chunk(&self.inv_r, c), p.settings().height, chunk(&self.g, c));
            sample_chunk((&mut p, &mut y), c, dims, noise, x, xdot, None);
        }
        self.imus[c].0.zip_state(&p, take_j);
        self.imus[c].1.zip_state(&y, take_j);
    }

    /// The latest registers into each lane's sensors (which the firmware's read takes).
    fn to_sensors(&self, rigs: &mut [PlanarRig<f64>]) {
        for (c, (pitch, yaw)) in self.imus.iter().enumerate() {
            let (p, y) = (pitch.reading(), yaw.reading());
            for j in 0..WIDTH {
                let at = |r: &ImuReading<Wide>| ImuReading { accel_x: r.accel_x.0[j], accel_z: r.accel_z.0[j], gyro: r.gyro.0[j] };
                rigs[c * WIDTH + j].sensors.set_imu_readings(at(&p), at(&y));
            }
        }
    }
}

/// `PlanarSensors::sample`'s IMU part on chunk `c`'s lanes of the IMUs (every lane of the
/// chunk: the caller keeps the lanes due): state `x`, derivative `xdot`, the noise `noise` of
/// every lane, `dims` (radius, 1/radius, the sensor's height, gravity) of the chunk's lanes;
/// on the ground's `gradients` (None: flat), as `sample_imus_on_terrain`.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn sample_chunk(
    (pitch, yaw): (&mut Mpu6050<Wide>, &mut Mpu6050<Wide>),
    c: usize,
    dims: (Wide, Wide, Wide, Wide),
    noise: &[[Lanes; 4]; 2],
    x: &[Lanes; 7],
    xdot: &[Lanes; 7],
    gradients: Option<&[Lanes; 2]>,
) {
    let (xs, ds): ([Wide; 7], [Wide; 7]) = (fill(|i| chunk(&x[i], c)), fill(|i| chunk(&xdot[i], c)));
    let n = [fill(|i| chunk(&noise[0][i], c)), fill(|i| chunk(&noise[1][i], c))];
    match gradients {
        None => sample_imus((pitch, yaw), &xs, &ds, Wide::sincos(xs[3]).1, n, dims),
        Some([gx, gy]) => {
            let (s, co) = Wide::sincos(xs[2]);
            let f = Frame::new(chunk(gx, c), chunk(gy, c), s, co);
            let trig = (Wide::sincos(f.delta), Wide::sincos(xs[3] + f.delta).1);
            sample_imus_in_frame((pitch, yaw), &f, &xs, &ds, trig, n, dims);
        }
    }
}

/// The 3-DOF rig on a block of lanes: every lane's rig and state, and what carries over
/// from one plant step to the next (the inputs held and pending, the gear trains), so that
/// a loop can step it, stop, and go on. Invalid or missing lanes run an idle copy of a
/// valid robot's rig, whose numbers no one keeps.
pub(crate) struct PlanarRigLanes {
    /// Each lane's model (the sample's).
    pub(super) models: [PlanarModel<f64>; LANES],
    /// Each lane's rig, the state, the reading and the inputs held.
    pub(crate) context: Context,
    plants: RigPlants,
    imus: Option<Box<ImuLanes>>,
    dt: f64,
    /// The windings of lanes without a driver.
    stand_in: ([Winding<f64>; 2], f64),
    /// Every lane's realism has the same parts: play in all or none.
    geared: bool,
    /// The lanes that are never pushed, which skip the work between steps while their
    /// trains are engaged (a winding without inductance starts no step: `Winding::start_step`).
    quiet_engaged: [bool; LANES],
    /// Each lane's gear trains over the last step.
    engaged: [[bool; 2]; LANES],
    /// The lanes' terrains (None: flat ground, the flat rig's code).
    ground: Option<TerrainLanes>,
}

/// The 3-DOF rigs' [`RigContext`].
type Context = RigContext<PlanarPlant<f64>, PlanarSensors<f64>, PlanarActuator<f64>, [Lanes; 2], 7, 2>;

impl PlanarRigLanes {
    /// The rigs `built` (per lane: its model and rig, or None for an idle lane) at rest in
    /// `x0[l]`, their estimators settled as a run settles them (reads every `period` [s]),
    /// their sensors at the initial state under no input; plant steps of `dt`. None when no
    /// lane has a rig. On `ground` (None: flat), each lane's rig built on its lane's terrain
    /// (`Realism::build_planar_on`). As `RigLanes::start`, one function.
    pub(crate) fn start(
        built: Vec<Option<(PlanarModel<f64>, PlanarRig<f64>)>>,
        x0: [[f64; 7]; LANES],
        dt: f64,
        period: f64,
        ground: Option<TerrainLanes>,
    ) -> Result<Option<Self>, TwipError> {
        let Some(fallback) = built.iter().flatten().next().cloned() else {
            return Ok(None);
        };
        let models: [PlanarModel<f64>; LANES] = core::array::from_fn(|l| built.get(l).cloned().flatten().map_or(fallback.0, |b| b.0));
        let mut rigs: Vec<PlanarRig<f64>> = (0..LANES).map(|l| built.get(l).cloned().flatten().map_or_else(|| fallback.1.clone(), |b| b.1)).collect();
        let stand_in = stand_in()?;
        let plants = RigPlants::new(&rigs, &models, dt, stand_in);
        let geared = rigs[0].plant.has_play();
        let x: [Lanes; 7] = core::array::from_fn(|i| core::array::from_fn(|l| x0[l][i]));
        // The sensors sample the initial state, the input zero: the encoders' wheels per
        // lane, the IMUs on lanes.
        let mut imus = ImuLanes::new(&rigs, &models).map(Box::new);
        let mut d0 = [[0.0; LANES]; 7];
        for (l, rig) in rigs.iter_mut().enumerate() {
            let xl = lane(&x, l);
            set_lane(&mut d0, l, &rig.plant.deriv(&xl, &SVector::zeros()));
        }
        Self::settle(&mut rigs.iter_mut().enumerate().map(|(l, rig)| (rig, lane(&x, l).into())).collect::<Vec<_>>(), period);
        if let Some(imus) = imus.as_mut() {
            imus.sample(&[0.0; LANES], &x, &d0, ground.as_ref());
        }
        let quiet_engaged = core::array::from_fn(|l| rigs[l].plant.unpushed());
        let engaged = core::array::from_fn(|l| rigs[l].plant.trains());
        Ok(Some(Self {
            models,
            context: RigContext::new(rigs, x),
            plants,
            imus,
            dt,
            stand_in,
            geared,
            quiet_engaged,
            engaged,
            ground,
        }))
    }

    /// Each rig's sensors at rest in its `x0` (the encoders' wheels there), settled with
    /// reads every `period` [s], as a run settles them before it starts (`Rig::simulate`),
    /// side by side.
    pub(crate) fn settle(robots: &mut [(&mut PlanarRig<f64>, [f64; 7])], period: f64) {
        for (rig, x0) in robots.iter_mut() {
            rig.sensors.follow_wheels(0.0, &SVector::from(*x0));
        }
        settle_side_by_side(&mut robots.iter_mut().map(|(rig, x0)| (&mut rig.sensors, x0[3])).collect::<Vec<_>>(), period);
    }

    /// Lane `l` runs `rig` (its robot `model`, [`Self::settle`]d) from rest in `x0`, started
    /// as [`Self::start`] starts a lane (an env's robot started anew); the other lanes go on
    /// as they were.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn restart(&mut self, l: usize, model: PlanarModel<f64>, rig: PlanarRig<f64>, x0: [f64; 7]) {
        let xl = SVector::from(x0);
        let d0 = rig.plant.deriv(&xl, &SVector::zeros());
        self.models[l] = model;
        self.context.restart(l, rig, &xl);
        let rigs = &mut self.context.rigs;
        self.plants.restart_lane(l, rigs, &self.models, self.dt, self.stand_in);
        let plant = &rigs[l].plant;
        (self.engaged[l], self.quiet_engaged[l]) = (plant.trains(), plant.unpushed());
        if let Some(imus) = self.imus.as_mut() {
            let mut xdot = [[0.0; LANES]; 7];
            set_lane(&mut xdot, l, &d0);
            imus.restart(l, &rigs[l], &model, &self.context.x, &xdot);
            imus.to_sensors(rigs);
        }
        // The firmware's first read, at t = 0 (as `read_at` reads the lanes `start` started).
        self.context.read_lane(l, 0.0, self.geared);
    }

    /// What the firmware reads at `t`: the IMUs' latest registers and the encoders through
    /// each lane's tilt estimator (`RigContext::read_at`).
    #[inline(always)]
    pub(super) fn read(&mut self, t: f64) -> &[Lanes; 7] {
        self.read_at(&[t; LANES])
    }

    /// [`Self::read`] with each lane at its own time `ts`.
    #[inline(always)]
    pub(crate) fn read_at(&mut self, ts: &Lanes) -> &[Lanes; 7] {
        if let Some(imus) = self.imus.as_ref() {
            imus.to_sensors(&mut self.context.rigs);
        }
        self.context.read_at(ts, self.geared)
    }

    /// Plant step `k` (from t = k·dt) under the input held: the pieces that act between
    /// steps, the gear trains, the IMUs' sample and RK4. Writes the state after the step
    /// into `next` (the caller moves the lanes that go on there, `x`; as the 2-DOF rig's
    /// step, in place) and returns what the plants got at the step's start
    /// (`Observer::drive`; [`Self::beyond`]: whether the commands applied are beyond the
    /// drivers).
    #[inline(always)]
    pub(super) fn step<const COPY: u8>(&mut self, k: usize, next: &mut [Lanes; 7]) -> [Lanes; 2] {
        self.step_at::<COPY>(&[k; LANES], next)
    }

    /// [`Self::step`] with each lane at its own step `ks` (an env's robots start apart).
    /// A function of its own per kernel copy (`out_of_line_in`), shared by the laws' kernels
    /// and the envs: inlined, it was compiled again for each of them and copy (LLVM's time trace).
    #[inline(always)]
    pub(crate) fn step_at<const COPY: u8>(&mut self, ks: &[usize; LANES], next: &mut [Lanes; 7]) -> [Lanes; 2] {
        super::out_of_line_in::<COPY, _>(#[inline(always)] || self.step_in::<COPY>(ks, next))
    }

    #[inline(always)]
    fn step_in<const COPY: u8>(&mut self, ks: &[usize; LANES], next: &mut [Lanes; 7]) -> [Lanes; 2] {
        let (dt, u) = (self.dt, self.context.input());
        let ts: Lanes = core::array::from_fn(|l| dt * ks[l] as f64);
        let (plants, x) = (&mut self.plants, &mut self.context.x);
        // What the plants get at the step's start (`Observer::drive`): the held torques, or
        // the windings' (with inductance, once the last step has ended, below).
        let mut delivered = u;
        if plants.drive == STEADY {
            for (l, rig) in self.context.rigs.iter().enumerate() {
                set_lane(&mut delivered, l, &rig.plant.delivered(&lane(x, l), &lane(&u, l)));
            }
        }
        // Per lane, the last step's `step_ended` and this one's `between_steps`: the play's
        // impacts, pushes and the windings' steps (with inductance on lanes: the motors'
        // speeds where the last step ended and this one starts); then the trains weigh the
        // derivative at the step's start (on lanes), which is RK4's first stage when they
        // stay as they were, else it is taken again with the trains as they are now. The
        // accelerometer reads it. The input held over the step: the motor torques (with
        // inductance, at its first stage), or the duties.
        let stepped = plants.drive == STEPPED;
        let mut held = u;
        let mut trains = [[true; 2]; LANES];
        let (mut finished, mut starts) = ([[0.0; LANES]; 2], [[0.0; LANES]; 2]);
        // On flat ground the wheels' speeds on lanes, with the model's rows (a rig's plant's
        // and encoders' are its model's): once for every lane, not through each rig.
        let flat = self.ground.is_none();
        let wheels_at = |x: &[Lanes; 7]| plants.plants.wheels_of([&x[4], &x[5], &x[6]]);
        let speeds = (flat && stepped).then(|| wheels_at(x));
        for (l, rig) in self.context.rigs.iter_mut().enumerate() {
            if self.quiet_engaged[l] && self.engaged[l] == [true; 2] {
                // Nothing acts between steps (`RealPlant::unpushed`): the motors turn with
                // the wheels (the windings' steps on lanes start from their speeds).
                if stepped {
                    // (On terrain: relative to the body's pitch rate about the axle.)
                    let [right, left] = match &speeds {
                        Some(s) => [s[0][l], s[1][l]],
                        None => rig.plant.wheel_speeds(&lane(x, l)),
                    };
                    (finished[0][l], finished[1][l]) = (right, left);
                    (starts[0][l], starts[1][l]) = (right, left);
                }
                continue;
            }
            let (mut xl, ul) = (lane(x, l), lane(&u, l));
            if stepped {
                let [right, left] = rig.plant.motor_speeds(&xl);
                (finished[0][l], finished[1][l]) = (right, left);
                rig.plant.ground_start(ts[l], dt, &mut xl);
                let [right, left] = rig.plant.motor_speeds(&xl);
                (starts[0][l], starts[1][l]) = (right, left);
            } else {
                rig.plant.step_start(ts[l], dt, &mut xl, &ul);
            }
            set_lane(x, l, &xl);
            trains[l] = rig.plant.trains();
        }
        if stepped {
            for (wheel, windings) in plants.windings.iter_mut().enumerate() {
                windings.step(&ks.map(|k| k > 0), &finished[wheel], &u[wheel], &starts[wheel], &mut held[wheel]);
                windings.delivered(&mut delivered[wheel]);
            }
        }
        let ground = self.ground.as_ref();
        let mut k1 = [[0.0; LANES]; 7];
        let tau = plants.motion::<COPY>(x, &held, &trains, ground, &mut k1);
        let before = trains;
        // On flat ground, the wheels' speeds (impacts and pushes may have moved them) and
        // accelerations at the step's start, for the play and the encoders.
        let wheels = flat.then(|| (wheels_at(x), wheels_at(&k1)));
        for (l, rig) in self.context.rigs.iter_mut().enumerate() {
            let at = |w: &[Lanes; 2]| [w[0][l], w[1][l]];
            if self.geared {
                // The motors' torques at the step's start, and (read only by the play's step)
                // their mean over it.
                let inputs = (!stepped).then(|| (lane(x, l), lane(&u, l)));
                let motor = match &inputs {
                    Some((xl, ul)) => rig.plant.inputs_at(xl, ul, Stage::Start),
                    None => SVector::from(at(&held)),
                };
                // `inline(always)` (in a block: attributes on a `let`'s expression are unstable),
                // as the closure that calls it below: out of line, each was baseline code that
                // called the software fma.
                let mean_of = {
                    #[inline(always)]
                    |plant: &PlanarPlant<f64>| match &inputs {
                        Some((xl, ul)) => plant.mean_inputs(xl, ul),
                        None => SVector::from([plants.windings[0].mean(l), plants.windings[1].mean(l)]),
                    }
                };
                // Whether the trains stayed as they were, when the play took its step.
                let stepped_play = match (&wheels, rig.plant.rotor_inertia()) {
                    (Some((speeds, accels)), Some(j)) => {
                        let contact = flank_contact(&motor, at(&tau), j, at(accels));
                        // Trains engaged that stay so: no step to take, and the motors turn
                        // with the wheels already (`turn_motors` would change nothing).
                        (!rig.plant.stays_engaged(contact)).then(#[inline(always)] || {
                            let mean = mean_of(&rig.plant);
                            rig.plant.gear_next_at(at(speeds), contact, &mean)
                        })
                    }
                    _ => {
                        let mean = mean_of(&rig.plant);
                        Some(rig.plant.gear_next_with(&lane(x, l), &motor, &mean, &lane(&k1, l), at(&tau)))
                    }
                };
                if let Some(same) = stepped_play {
                    if !same {
                        trains[l] = rig.plant.trains();
                    }
                    // The motors turn as the trains now say (as a run's `between_steps` ends).
                    rig.plant.turn_motors();
                }
            }
            match &wheels {
                Some((speeds, _)) => rig.sensors.follow_speeds(ts[l], at(speeds)),
                None => rig.sensors.follow_wheels(ts[l], &lane(x, l)),
            }
        }
        if trains != before {
            // Some trains opened or closed: RK4's first stage with them as they are now.
            plants.motion::<COPY>(x, &held, &trains, ground, &mut k1);
        }
        if let Some(imus) = self.imus.as_mut() {
            imus.sample(&ts, x, &k1, ground);
        }
        plants.rk4::<COPY>(x, &held, &trains, &k1, dt, ground, next);
        self.engaged = trains;
        delivered
    }

    /// On terrain, what ends each lane at `next`, the state after the step just taken, as the
    /// rig's `halted` after `step_ended`: off its terrain, else a wheel's normal force below
    /// zero under the torques the windings deliver there with the gear trains as they are
    /// and the body force (its generalised forces from the plant's derivative there); None on
    /// flat ground.
    #[inline(always)]
    pub(super) fn halts<const COPY: u8>(&self, next: &[Lanes; 7]) -> Option<[Option<Halt>; LANES]> {
        let ground = self.ground.as_ref()?;
        let mut input = self.context.input();
        if self.plants.drive == STEPPED {
            for (l, rig) in self.context.rigs.iter().enumerate() {
                let speeds = rig.plant.motor_speeds(&lane(next, l));
                for (wheel, windings) in self.plants.windings.iter().enumerate() {
                    input[wheel][l] = windings.ended_input(l, speeds[wheel]);
                }
            }
        }
        let mut d = [[0.0; LANES]; 7];
        self.plants.motion::<COPY>(next, &input, &self.engaged, Some(ground), &mut d);
        // `inline(always)`, as the ideal lanes' (`TerrainLanes::halts`): out of line, baseline
        // code calling the software fma.
        Some(ground.halts_where(next, #[inline(always)] |l, [gx, gy], contact| {
            let (xl, dl) = (fill(|i| Fused(next[i][l])), fill(|i| Fused(d[i][l])));
            let (f, xp) = in_frame(&xl, [gx, gy, Fused(0.0)]);
            let nu = [pitch_acceleration_of(&xl, &dl, &f), dl[5], dl[6]];
            normal_forces_of(contact, &f, &xp, &nu, Fused::sincos(xp[3]))
        }))
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

    /// As the 2-DOF rig's test: the first stage by the slip law has the stick band's bits,
    /// the later ones too while no wheel meets the band, and a step braked into it is taken
    /// again. Both wheels braked, the left one harder (on its own it meets the band).
    #[test]
    fn a_step_clear_of_the_stick_band_has_its_bits_and_one_into_it_is_taken_again() {
        let model = PlanarModel::new(RobotParams::balanbot()).unwrap();
        let realism = Realism { motor: None, backlash: None, ..Realism::thesis_like() };
        let rigs: Vec<PlanarRig<f64>> = (0..LANES).map(|_| realism.build_planar(&model, DT).unwrap()).collect();
        let plants = RigPlants::new(&rigs, &[model; LANES], DT, stand_in().unwrap());
        assert_eq!((plants.gear, plants.drive), (STICK, HELD));
        let trains = [[true; 2]; LANES];
        let (r, b) = (RobotParams::<f64>::balanbot().wheel_radius, RobotParams::<f64>::balanbot().half_track);
        // (each wheel's speed relative to the body, torques): far from the band; the left
        // wheel near it (0.25 rad/s) and braked into it within the step.
        for (w, torque, enters) in [([3.0, 2.5], [0.05, 0.05], false), ([3.0, 0.25], [0.05, -2.0], true)] {
            // ν = (φ̇, v, ω) from the wheels' speeds relative to the body, each lane's φ̇ its own.
            let x: [Lanes; 7] = core::array::from_fn(|i| {
                core::array::from_fn(|l| {
                    let phi_dot = 0.1 * l as f64 / LANES as f64;
                    let (right, left) = (w[0] + phi_dot + 0.002 * l as f64, w[1] + phi_dot + 0.002 * l as f64);
                    [0.0, 0.0, 0.0, 0.02, phi_dot, r * (right + left) / 2.0, r * (right - left) / (2.0 * b)][i]
                })
            });
            let u = [[torque[0]; LANES], [torque[1]; LANES]];
            assert!(plants.outside(&x, &trains), "{w:?}: the first try is taken");
            let (mut k1, mut stick_k1) = ([[f64::NAN; LANES]; 7], [[f64::NAN; LANES]; 7]);
            plants.motion::<COPY>(&x, &u, &trains, None, &mut k1);
            plants.motion_of::<STICK, HELD, false>(&x, &u, &trains, None, &mut stick_k1);
            assert_eq!(bits(&k1), bits(&stick_k1), "{w:?}");
            let (mut stick, mut outside) = ([[f64::NAN; LANES]; 7], [[f64::NAN; LANES]; 7]);
            let stick_band = plants.rk4_of::<STICK, HELD, false>(&x, &u, &trains, &k1, DT, None, &mut stick);
            let band = plants.rk4_of::<OUTSIDE, HELD, false>(&x, &u, &trains, &k1, DT, None, &mut outside);
            assert!(!stick_band, "only the first try notes the band");
            assert_eq!(band, enters, "{w:?}");
            assert_eq!(bits(&outside) == bits(&stick), !enters, "{w:?}");
            // Taken again over the first try's state in `next` where it enters the band.
            // From NaN, so that either try leaving a lane unwritten fails.
            let mut next = [[f64::NAN; LANES]; 7];
            plants.rk4::<COPY>(&x, &u, &trains, &k1, DT, None, &mut next);
            assert_eq!(bits(&next), bits(&stick), "{w:?}");
        }
    }
}
