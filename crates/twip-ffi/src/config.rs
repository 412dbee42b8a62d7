//! The configurations a firmware fills in, as plain C structs of `float`s in SI units, and
//! their two conversions: into the core's `f32` controllers (what `twip_X_init` runs), and
//! from the core's `f64` ones (what `twip export` writes after tuning in simulation). That
//! second conversion refuses a value that f32 cannot hold, naming the f64 value given.
use twip_core::control::fuzzy::{Adaptation as FuzzyAdaptation, FuzzyController, FuzzyGains};
use twip_core::control::fuzzy_basis::Membership;
use twip_core::control::fuzzy_grid::{FuzzyGrid, MAX_RULES, MAX_SETS};
use twip_core::control::lqr::{DesignPoint, LqrController};
use twip_core::control::pid::{PidGains, PidTracker, PidUnits};
use twip_core::control::smc::{Adaptation as SmcAdaptation, PitchSign, SmcGains, SmcOptions, SmcTracker};
use twip_core::control::Controller;
use twip_core::hardware::motor::DcMotor;
use twip_core::model::friction::Friction;
use twip_core::model::params::FIELD_NAMES;
use twip_core::{PlanarModel, RobotParams, SlopeModel, TwipError};

/// `v` as the firmware's `f32`, refused when it does not fit: a finite value beyond ±3.4e38
/// would become an infinity and a nonzero one below 1.4e-45 a zero, so the error names the
/// f64 value given (an infinite gain of the f32 conversion is not what the user wrote).
/// NaN and infinities pass unchanged, for the controllers' own checks to name.
pub fn narrow(name: &'static str, v: f64) -> Result<f32, TwipError> {
    let n = v as f32;
    if (v.is_finite() && n.is_infinite()) || (v != 0.0 && n == 0.0) {
        let reason = "does not fit in f32, the firmware's numbers (magnitudes 1.4e-45 to 3.4e38, or 0)";
        return Err(TwipError::InvalidParameter { name, value: v, reason });
    }
    Ok(n)
}

/// [`narrow`] of each value, named by `names`.
fn narrow_all<const N: usize>(names: &[&'static str; N], v: [f64; N]) -> Result<[f32; N], TwipError> {
    let mut out = [0.0f32; N];
    for ((o, name), x) in out.iter_mut().zip(names).zip(v) {
        *o = narrow(name, x)?;
    }
    Ok(out)
}

const GAIN_NAMES: [&str; 4] = ["gains[0]", "gains[1]", "gains[2]", "gains[3]"];

/// The most fuzzy sets per input and rules a configuration holds (the core's capacity).
pub const TWIP_FUZZY_MAX_SETS: usize = 7;
pub const TWIP_FUZZY_MAX_RULES: usize = 49;
const _: () = assert!(TWIP_FUZZY_MAX_SETS == MAX_SETS && TWIP_FUZZY_MAX_RULES == MAX_RULES);
/// `field[i][j]` for every set of a configuration's grid, as `'static` names for errors.
macro_rules! set_names {
    ($field:literal) => {
        [set_names!(@row $field "[0]"), set_names!(@row $field "[1]")]
    };
    (@row $field:literal $i:literal) => {
        [
            concat!($field, $i, "[0]"),
            concat!($field, $i, "[1]"),
            concat!($field, $i, "[2]"),
            concat!($field, $i, "[3]"),
            concat!($field, $i, "[4]"),
            concat!($field, $i, "[5]"),
            concat!($field, $i, "[6]"),
        ]
    };
}
type SetNames = [[&'static str; TWIP_FUZZY_MAX_SETS]; 2];
const SET_NAMES: SetNames = set_names!("sets");
const YAW_SET_NAMES: SetNames = set_names!("yaw_sets");
const PITCH_SET_NAMES: SetNames = set_names!("pitch_sets");

/// The C ABI version a controller configuration was written for: its first field, which
/// `twip_X_init` reads before any other (`TWIP_ERR_ABI` when it is not `TWIP_ABI_VERSION`).
/// A default configuration is of this library's version.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TwipAbiVersion(pub i32);

impl Default for TwipAbiVersion {
    fn default() -> Self {
        Self(crate::TWIP_ABI_VERSION)
    }
}

/// A configuration whose first field is its [`TwipAbiVersion`].
///
/// # Safety
/// The implementing type is `repr(C)` with `abi_version: TwipAbiVersion` as its first field.
pub unsafe trait Versioned {}

/// The robot's physical parameters [SI], in the order of twip-core's `FIELD_NAMES`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipRobot {
    pub m_body: f32,
    pub m_wheels: f32,
    pub i_body: f32,
    pub i_wheels: f32,
    pub i_motor: f32,
    pub gear_ratio: f32,
    pub torque_constant: f32,
    pub wheel_radius: f32,
    pub com_height: f32,
    pub mu_bearing: f32,
    pub mu_ground: f32,
    pub half_track: f32,
    pub i_body_roll: f32,
    pub i_body_yaw: f32,
    pub i_wheel_diam: f32,
    pub g: f32,
}

// Sixteen f32 fields under repr(C) lie exactly as [f32; 16] (no padding between fields of
// one type); tests/header.rs checks that their order is the core's FIELD_NAMES.
const _: () = assert!(core::mem::size_of::<TwipRobot>() == 16 * 4);

impl TwipRobot {
    fn to_array(self) -> [f32; 16] {
        // SAFETY: same size (checked above) and layout; every bit pattern is an f32.
        unsafe { core::mem::transmute::<Self, [f32; 16]>(self) }
    }

    fn from_array(v: [f32; 16]) -> Self {
        // SAFETY: as in to_array.
        unsafe { core::mem::transmute::<[f32; 16], Self>(v) }
    }

    pub fn to_core(self) -> RobotParams<f32> {
        RobotParams::from_array(&self.to_array())
    }

    pub fn from_core(p: &RobotParams<f64>) -> Result<Self, TwipError> {
        Ok(Self::from_array(narrow_all(&FIELD_NAMES, p.to_array())?))
    }
}

/// Gearhead friction per wheel (twip-core's `Friction`), used when `enabled` is nonzero.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipFriction {
    pub enabled: i32,
    pub coulomb: f32,
    pub breakaway: f32,
    pub stribeck_speed: f32,
    pub viscous: f32,
    pub smoothing_speed: f32,
    /// Half-width of the stick band [rad/s]; 0: no stick state.
    pub stick_speed: f32,
}

impl TwipFriction {
    pub fn to_core(self) -> Option<Friction<f32>> {
        (self.enabled != 0).then_some(Friction {
            coulomb: self.coulomb,
            breakaway: self.breakaway,
            stribeck_speed: self.stribeck_speed,
            viscous: self.viscous,
            smoothing_speed: self.smoothing_speed,
            stick_speed: self.stick_speed,
        })
    }

    pub fn from_core(f: Option<&Friction<f64>>) -> Result<Self, TwipError> {
        let Some(f) = f else { return Ok(Self::default()) };
        Ok(Self {
            enabled: 1,
            coulomb: narrow("coulomb", f.coulomb)?,
            breakaway: narrow("breakaway", f.breakaway)?,
            stribeck_speed: narrow("stribeck_speed", f.stribeck_speed)?,
            viscous: narrow("viscous", f.viscous)?,
            smoothing_speed: narrow("smoothing_speed", f.smoothing_speed)?,
            stick_speed: narrow("stick_speed", f.stick_speed)?,
        })
    }
}

/// A DC gearmotor behind an H-bridge (twip-core's `DcMotor`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipMotor {
    /// Winding resistance [Ω].
    pub resistance: f32,
    /// Torque constant at the motor shaft [N m/A].
    pub k_t: f32,
    pub gear_ratio: f32,
    /// Viscous friction at the motor shaft [N m s/rad].
    pub friction: f32,
    /// Battery voltage [V].
    pub supply: f32,
    /// PWM full scale [counts] (255 for 8 bits).
    pub pwm_max: f32,
}

impl TwipMotor {
    pub fn to_core(self) -> Result<DcMotor<f32>, TwipError> {
        DcMotor::new(self.resistance, self.k_t, self.gear_ratio, self.friction, self.supply, self.pwm_max)
    }

    pub fn from_core(m: &DcMotor<f64>) -> Result<Self, TwipError> {
        Ok(Self {
            resistance: narrow("resistance", m.resistance())?,
            k_t: narrow("k_t", m.k_t())?,
            gear_ratio: narrow("gear_ratio", m.gear_ratio())?,
            friction: narrow("friction", m.friction())?,
            supply: narrow("supply", m.supply())?,
            pwm_max: narrow("pwm_max", m.pwm_max())?,
        })
    }
}

/// LQR with integral action on the wheel speed. `u` is the lumped motor current [A].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipLqrConfig {
    /// `TWIP_ABI_VERSION` when the configuration was written (checked first by the init).
    pub abi_version: TwipAbiVersion,
    /// The controller's own model of the robot (steady state and feed-forward).
    pub robot: TwipRobot,
    /// Ground slope [rad].
    pub slope: f32,
    pub friction: TwipFriction,
    /// [k_phi [A/rad], k_phi_dot [A s/rad], k_theta_dot [A s/rad], k_z [A/rad]].
    pub gains: [f32; 4],
    /// 0: the thesis's design point (φ = 0); 1: the true operating point.
    pub operating_point: i32,
    /// Update period [s].
    pub period: f32,
}

fn slope_model(robot: TwipRobot, slope: f32, friction: TwipFriction) -> Result<SlopeModel<f32>, TwipError> {
    SlopeModel::new(robot.to_core(), slope)?.with_friction(friction.to_core())
}

impl TwipLqrConfig {
    pub fn build(&self) -> Result<LqrController<f32>, TwipError> {
        let point = if self.operating_point != 0 { DesignPoint::OperatingPoint } else { DesignPoint::Thesis };
        LqrController::new(self.gains, slope_model(self.robot, self.slope, self.friction)?, point, self.period)
    }

    pub fn from_core(c: &LqrController<f64>) -> Result<Self, TwipError> {
        let model = c.model();
        Ok(Self {
            abi_version: TwipAbiVersion::default(),
            robot: TwipRobot::from_core(model.params())?,
            slope: narrow("slope", model.slope())?,
            friction: TwipFriction::from_core(model.friction())?,
            gains: narrow_all(&GAIN_NAMES, c.gains())?,
            operating_point: i32::from(c.point() == DesignPoint::OperatingPoint),
            period: narrow("period", c.period())?,
        })
    }
}

/// A membership function: `kind` 0 is a trapezoid (a, b, c, d) = `p` (±INFINITY for
/// shoulders), 1 a Gaussian (mean, sigma) = `p[0], p[1]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipMembership {
    pub kind: i32,
    pub p: [f32; 4],
}

impl TwipMembership {
    fn to_core(self) -> Result<Membership<f32>, TwipError> {
        let [a, b, c, d] = self.p;
        match self.kind {
            0 => Membership::trapezoid(a, b, c, d),
            1 => Membership::gaussian(a, b),
            k => Err(TwipError::InvalidParameter {
                name: "kind",
                value: k as f64,
                reason: "must be 0 (trapezoid) or 1 (gaussian)",
            }),
        }
    }

    fn from_core(m: &Membership<f64>, name: &'static str) -> Result<Self, TwipError> {
        Ok(match *m {
            Membership::Trapezoid { a, b, c, d } => Self { kind: 0, p: narrow_all(&[name; 4], [a, b, c, d])? },
            Membership::Gaussian { mean, sigma } => Self { kind: 1, p: narrow_all(&[name; 4], [mean, sigma, 0.0, 0.0])? },
        })
    }
}

/// Fuzzy adaptive backstepping + PD on the wheel (thesis 4.3.1). `u` is the lumped
/// motor current [A].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwipFuzzyConfig {
    pub abi_version: TwipAbiVersion,
    pub robot: TwipRobot,
    pub slope: f32,
    pub friction: TwipFriction,
    /// Backstepping gains k1 [1/s], k2 [1/s]; wheel PD(+I) gains kp, kd, ki.
    pub k1: f32,
    pub k2: f32,
    pub kp: f32,
    pub kd: f32,
    pub ki: f32,
    /// Adaptation rate γ and leakage σ of the weights; `adapt` 0 freezes them at `s0`.
    pub gamma: f32,
    pub sigma: f32,
    pub adapt: i32,
    /// Sets per input n, from 2 to `TWIP_FUZZY_MAX_SETS` (the thesis's N, Z, P: 3): the
    /// first n of each row of `sets` and n × n weights of `s0` are read.
    pub n_sets: i32,
    /// Sets of the inputs φ [rad] and φ̇ [rad/s].
    pub sets: [[TwipMembership; TWIP_FUZZY_MAX_SETS]; 2],
    /// Initial weights of the n × n rules (φ's set k / n, φ̇'s k % n).
    pub s0: [f32; TWIP_FUZZY_MAX_RULES],
    pub period: f32,
}

impl Default for TwipFuzzyConfig {
    /// Zeros, with the thesis's 3 sets per input (arrays this long have no derived default).
    fn default() -> Self {
        Self {
            abi_version: TwipAbiVersion::default(),
            robot: TwipRobot::default(),
            slope: 0.0,
            friction: TwipFriction::default(),
            k1: 0.0,
            k2: 0.0,
            kp: 0.0,
            kd: 0.0,
            ki: 0.0,
            gamma: 0.0,
            sigma: 0.0,
            adapt: 0,
            n_sets: 3,
            sets: [[TwipMembership::default(); TWIP_FUZZY_MAX_SETS]; 2],
            s0: [0.0; TWIP_FUZZY_MAX_RULES],
            period: 0.0,
        }
    }
}

impl TwipFuzzyConfig {
    pub fn build(&self) -> Result<FuzzyController<f32>, TwipError> {
        let basis = grid_of(self.n_sets, &self.sets, &SET_NAMES)?;
        let gains = FuzzyGains { k1: self.k1, k2: self.k2, kp: self.kp, kd: self.kd, ki: self.ki };
        let adaptation = FuzzyAdaptation { gamma: self.gamma, sigma: self.sigma, enabled: self.adapt != 0 };
        let model = slope_model(self.robot, self.slope, self.friction)?;
        FuzzyController::new(model, gains, adaptation, basis, self.period)?.with_initial_weights(&self.s0[..basis.rules()])
    }

    pub fn from_core(c: &FuzzyController<f64>) -> Result<Self, TwipError> {
        let (model, g, a) = (c.model(), c.gains(), c.adaptation());
        let mut s0 = [0.0f32; TWIP_FUZZY_MAX_RULES];
        for (o, w) in s0.iter_mut().zip(c.initial_weights()) {
            *o = narrow("s0", *w)?;
        }
        Ok(Self {
            abi_version: TwipAbiVersion::default(),
            robot: TwipRobot::from_core(model.params())?,
            slope: narrow("slope", model.slope())?,
            friction: TwipFriction::from_core(model.friction())?,
            k1: narrow("k1", g.k1)?,
            k2: narrow("k2", g.k2)?,
            kp: narrow("kp", g.kp)?,
            kd: narrow("kd", g.kd)?,
            ki: narrow("ki", g.ki)?,
            gamma: narrow("gamma", a.gamma)?,
            sigma: narrow("sigma", a.sigma)?,
            adapt: i32::from(a.enabled),
            n_sets: c.basis().n() as i32,
            sets: sets_of(c.basis(), &SET_NAMES)?,
            s0,
            period: narrow("period", c.period())?,
        })
    }
}

/// The thesis's discrete PID tracker (Table 4.1). Its gains are in the units of
/// `units`: counts of PWM per unit of pitch, speed and heading as the Arduino measured
/// them. `u` is the two wheels' torques [N m] (right, left).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipPidConfig {
    pub abi_version: TwipAbiVersion,
    pub kp_pitch: f32,
    pub kd_pitch: f32,
    pub kp_speed: f32,
    pub ki_speed: f32,
    pub kp_yaw: f32,
    pub ki_yaw: f32,
    pub kd_yaw: f32,
    /// SI per firmware unit: pitch [rad per unit], speed [rad/s of wheel per unit],
    /// heading [rad per unit]; and the integrators' step [s].
    pub unit_pitch: f32,
    pub unit_speed: f32,
    pub unit_heading: f32,
    pub integral_step: f32,
    pub motor: TwipMotor,
    /// [m]
    pub wheel_radius: f32,
    pub half_track: f32,
    pub period: f32,
}

impl TwipPidConfig {
    pub fn build(&self) -> Result<PidTracker<f32>, TwipError> {
        let gains = PidGains {
            kp_pitch: self.kp_pitch,
            kd_pitch: self.kd_pitch,
            kp_speed: self.kp_speed,
            ki_speed: self.ki_speed,
            kp_yaw: self.kp_yaw,
            ki_yaw: self.ki_yaw,
            kd_yaw: self.kd_yaw,
        };
        let units = PidUnits {
            pitch: self.unit_pitch,
            speed: self.unit_speed,
            heading: self.unit_heading,
            integral_step: self.integral_step,
        };
        PidTracker::with_geometry(gains, units, self.motor.to_core()?, self.wheel_radius, self.half_track, self.period)
    }

    pub fn from_core(c: &PidTracker<f64>) -> Result<Self, TwipError> {
        let (g, u) = (c.gains(), c.units());
        let (wheel_radius, half_track) = c.geometry();
        Ok(Self {
            abi_version: TwipAbiVersion::default(),
            kp_pitch: narrow("kp_pitch", g.kp_pitch)?,
            kd_pitch: narrow("kd_pitch", g.kd_pitch)?,
            kp_speed: narrow("kp_speed", g.kp_speed)?,
            ki_speed: narrow("ki_speed", g.ki_speed)?,
            kp_yaw: narrow("kp_yaw", g.kp_yaw)?,
            ki_yaw: narrow("ki_yaw", g.ki_yaw)?,
            kd_yaw: narrow("kd_yaw", g.kd_yaw)?,
            unit_pitch: narrow("unit_pitch", u.pitch)?,
            unit_speed: narrow("unit_speed", u.speed)?,
            unit_heading: narrow("unit_heading", u.heading)?,
            integral_step: narrow("integral_step", u.integral_step)?,
            motor: TwipMotor::from_core(c.motor())?,
            wheel_radius: narrow("wheel_radius", wheel_radius)?,
            half_track: narrow("half_track", half_track)?,
            period: narrow("period", c.period())?,
        })
    }
}

/// Sliding mode with fuzzy adaptive backstepping (thesis 4.3.2), SI gains. `u` is the
/// two wheels' torques [N m] (right, left).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipSmcConfig {
    pub abi_version: TwipAbiVersion,
    pub robot: TwipRobot,
    pub friction: TwipFriction,
    pub k1: f32,
    pub k2: f32,
    pub k3: f32,
    pub k_phi: f32,
    pub r1: f32,
    pub r2: f32,
    pub k_s3: f32,
    pub k_s4: f32,
    pub g_y4: f32,
    pub k_eta3: f32,
    pub k_eta4: f32,
    pub g_y3: f32,
    /// 1: the controller's pitch is positive leaning forward; 0: backward (the thesis's).
    pub pitch_forward: i32,
    pub width_eta: f32,
    pub width_s1: f32,
    pub guard_e3: f32,
    pub guard_d: f32,
    pub pitch_offset: i32,
    /// Nonzero: limit each torque to what `motor` gives at the measured wheel speed.
    pub has_motor: i32,
    pub motor: TwipMotor,
    /// Nonzero: adapt the fuzzy estimates with rates gamma1, gamma2 and `leakage`.
    pub adapt: i32,
    pub gamma1: f32,
    pub gamma2: f32,
    pub leakage: f32,
    /// Sets per input n of both fuzzy estimates' grids, from 2 to `TWIP_FUZZY_MAX_SETS` (the
    /// thesis's 3): the first n of each row of `yaw_sets` and `pitch_sets` are read.
    pub n_sets: i32,
    /// Sets of Ĉ1's inputs φ [rad] and ω [rad/s] (the yaw estimate).
    pub yaw_sets: [[TwipMembership; TWIP_FUZZY_MAX_SETS]; 2],
    /// Sets of Ĉ2's inputs φ [rad] and φ̇ [rad/s] (the pitch estimate).
    pub pitch_sets: [[TwipMembership; TWIP_FUZZY_MAX_SETS]; 2],
    pub period: f32,
}

impl TwipSmcConfig {
    pub fn build(&self) -> Result<SmcTracker<f32>, TwipError> {
        let gains = SmcGains {
            k1: self.k1,
            k2: self.k2,
            k3: self.k3,
            k_phi: self.k_phi,
            r1: self.r1,
            r2: self.r2,
            k_s3: self.k_s3,
            k_s4: self.k_s4,
            g_y4: self.g_y4,
            k_eta3: self.k_eta3,
            k_eta4: self.k_eta4,
            g_y3: self.g_y3,
        };
        let options = SmcOptions {
            pitch: if self.pitch_forward != 0 { PitchSign::Forward } else { PitchSign::Backward },
            width_eta: self.width_eta,
            width_s1: self.width_s1,
            guard_e3: self.guard_e3,
            guard_d: self.guard_d,
            pitch_offset: self.pitch_offset != 0,
        };
        let model = PlanarModel::new(self.robot.to_core())?.with_friction(self.friction.to_core())?;
        let motor = if self.has_motor != 0 { Some(self.motor.to_core()?) } else { None };
        let adaptation = (self.adapt != 0).then_some(SmcAdaptation {
            gamma1: self.gamma1,
            gamma2: self.gamma2,
            leakage: self.leakage,
        });
        let (yaw, pitch) = (grid_of(self.n_sets, &self.yaw_sets, &YAW_SET_NAMES)?, grid_of(self.n_sets, &self.pitch_sets, &PITCH_SET_NAMES)?);
        SmcTracker::new(gains, options, model, motor, adaptation, self.period)?.with_bases(yaw, pitch)
    }

    pub fn from_core(c: &SmcTracker<f64>) -> Result<Self, TwipError> {
        let (yaw, pitch) = c.bases();
        let (g, o, model) = (c.gains(), c.options(), c.model());
        let adaptation = c.adaptation();
        Ok(Self {
            abi_version: TwipAbiVersion::default(),
            robot: TwipRobot::from_core(model.params())?,
            friction: TwipFriction::from_core(model.friction())?,
            k1: narrow("k1", g.k1)?,
            k2: narrow("k2", g.k2)?,
            k3: narrow("k3", g.k3)?,
            k_phi: narrow("k_phi", g.k_phi)?,
            r1: narrow("r1", g.r1)?,
            r2: narrow("r2", g.r2)?,
            k_s3: narrow("k_s3", g.k_s3)?,
            k_s4: narrow("k_s4", g.k_s4)?,
            g_y4: narrow("g_y4", g.g_y4)?,
            k_eta3: narrow("k_eta3", g.k_eta3)?,
            k_eta4: narrow("k_eta4", g.k_eta4)?,
            g_y3: narrow("g_y3", g.g_y3)?,
            pitch_forward: i32::from(o.pitch == PitchSign::Forward),
            width_eta: narrow("width_eta", o.width_eta)?,
            width_s1: narrow("width_s1", o.width_s1)?,
            guard_e3: narrow("guard_e3", o.guard_e3)?,
            guard_d: narrow("guard_d", o.guard_d)?,
            pitch_offset: i32::from(o.pitch_offset),
            has_motor: i32::from(c.motor().is_some()),
            motor: c.motor().map_or(Ok(TwipMotor::default()), TwipMotor::from_core)?,
            adapt: i32::from(adaptation.is_some()),
            gamma1: narrow("gamma1", adaptation.map_or(0.0, |a| a.gamma1))?,
            gamma2: narrow("gamma2", adaptation.map_or(0.0, |a| a.gamma2))?,
            leakage: narrow("leakage", adaptation.map_or(0.0, |a| a.leakage))?,
            n_sets: yaw.n() as i32,
            yaw_sets: sets_of(yaw, &YAW_SET_NAMES)?,
            pitch_sets: sets_of(pitch, &PITCH_SET_NAMES)?,
            period: narrow("period", c.period())?,
        })
    }
}

// SAFETY: each is repr(C) with `abi_version` first.
unsafe impl Versioned for TwipLqrConfig {}
unsafe impl Versioned for TwipFuzzyConfig {}
unsafe impl Versioned for TwipPidConfig {}
unsafe impl Versioned for TwipSmcConfig {}

/// The n × n grid of the first `n_sets` sets of each row of `sets` (a configuration's). A set
/// the core refuses is named by `names` (which set of the configuration), with the core's
/// reason: an f64 set can be valid and its f32 not (a ramp too narrow for f32's 1/width).
fn grid_of(n_sets: i32, sets: &[[TwipMembership; TWIP_FUZZY_MAX_SETS]; 2], names: &SetNames) -> Result<FuzzyGrid<f32>, TwipError> {
    let n = usize::try_from(n_sets).ok().filter(|n| (2..=TWIP_FUZZY_MAX_SETS).contains(n)).ok_or(
        TwipError::InvalidParameter { name: "n_sets", value: n_sets as f64, reason: "must be from 2 to TWIP_FUZZY_MAX_SETS (7)" },
    )?;
    let mut core = [[Membership::Gaussian { mean: 0.0, sigma: 1.0 }; TWIP_FUZZY_MAX_SETS]; 2];
    for ((row, given), names) in core.iter_mut().zip(sets).zip(names) {
        for ((set, m), name) in row.iter_mut().zip(given).zip(names).take(n) {
            *set = m.to_core().map_err(|e| match e {
                TwipError::InvalidParameter { value, reason, .. } => TwipError::InvalidParameter { name, value, reason },
                other => other,
            })?;
        }
    }
    FuzzyGrid::new([&core[0][..n], &core[1][..n]])
}

/// A grid's sets as a configuration holds them (the slots past n zero), each named by
/// `names` when it does not fit in f32.
fn sets_of(grid: &FuzzyGrid<f64>, names: &SetNames) -> Result<[[TwipMembership; TWIP_FUZZY_MAX_SETS]; 2], TwipError> {
    let mut out = [[TwipMembership::default(); TWIP_FUZZY_MAX_SETS]; 2];
    for ((row, given), names) in out.iter_mut().zip(grid.sets()).zip(names) {
        for ((set, m), name) in row.iter_mut().zip(given).zip(names) {
            *set = TwipMembership::from_core(m, name)?;
        }
    }
    Ok(out)
}
