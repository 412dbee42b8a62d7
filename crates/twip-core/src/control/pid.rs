//! The PID trajectory tracker (thesis 4.64–4.70, Table 4.1), in the Arduino's units.
//!
//! ```text
//! u_φ = k_pφ φ + k_dφ φ̇                        balance PD          (4.67)
//! u_v = k_pv e_v + k_iv Σ e_v                   speed PI, e_v = v_r − v          (4.68)
//! u_ψ = k_pψ e_ψ + k_iψ Σ e_ψ + k_dψ ė_ψ        heading PID, e_ψ = ψ_r − ψ     (4.69)
//! pwm_R = u_φ + u_v + u_ψ,  pwm_L = u_φ + u_v − u_ψ   (4.70), saturated at ±255
//! ```
//!
//! Table 4.1's gains act on the Arduino's numbers, not SI: [`PidUnits`] says what one unit
//! of each measured quantity is, and the outputs are PWM counts. The controller is discrete
//! (its own period) and its output is what the plant feels: each wheel gets
//! [`DcMotor::torque`] of its PWM voltage at the wheel-body speed measured at the update,
//! held until the next one (the motor's electrical time constant is far below the period).
//! The tracker only follows the speed and heading of the reference: it never sees x, y,
//! so a position error once made is never corrected. docs/errata.md T1–T3 say why the
//! units and signs are read as they are.
use nalgebra::SVector;

use crate::error::invalid;
use crate::control::Controller;
use crate::hardware::motor::DcMotor;
use crate::control::trajectory::{wrap_angle, PlanarRef};
use crate::model::lane::{saturate, Lane};
use crate::{c, Real, RobotParams, TwipError};

/// The gains of (4.67)–(4.69): outputs in PWM counts per unit of [`PidUnits`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidGains<T> {
    pub kp_pitch: T,
    pub kd_pitch: T,
    pub kp_speed: T,
    pub ki_speed: T,
    pub kp_yaw: T,
    pub ki_yaw: T,
    pub kd_yaw: T,
}

impl<T: Real> PidGains<T> {
    /// Table 4.1 as published (its angle I and velocity D are 0 and have no term in 4.67–4.68).
    pub fn table_4_1() -> Self {
        Self {
            kp_pitch: c(25.0),
            kd_pitch: c(3.0),
            kp_speed: c(-25.0),
            ki_speed: c(-0.005),
            kp_yaw: c(-8.0),
            ki_yaw: c(-0.001),
            kd_yaw: c(-0.03),
        }
    }

    fn to_array(self) -> [(&'static str, T); 7] {
        [
            ("kp_pitch", self.kp_pitch),
            ("kd_pitch", self.kd_pitch),
            ("kp_speed", self.kp_speed),
            ("ki_speed", self.ki_speed),
            ("kp_yaw", self.kp_yaw),
            ("ki_yaw", self.ki_yaw),
            ("kd_yaw", self.kd_yaw),
        ]
    }
}

/// What one unit of each quantity the gains act on is, per SI unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidUnits<T> {
    /// Pitch units per rad (the rate is in the same units per second).
    pub pitch: T,
    /// Wheel speed units per m/s.
    pub speed: T,
    /// Heading units per rad (the rate in the same units per second); negative when the
    /// robot's heading is measured clockwise.
    pub heading: T,
    /// What one update adds to an integral per unit of error: 1 for a running sum (the
    /// Arduino's), the period for ∫ e dt.
    pub integral_step: T,
}

/// Encoder counts per wheel turn at the gearbox shaft (Table 2.3).
pub const ENCODER_CPR: f64 = 700.0;

impl<T: Real> PidUnits<T> {
    /// twip's reading of the robot's units (errata T1–T3): pitch in degrees (the MPU-6050's),
    /// wheel speed in encoder counts (700 per turn) per update, heading in degrees measured
    /// clockwise, integrals summed once per update.
    pub fn arduino(wheel_radius: T, period: T) -> Self {
        let deg = c::<T>(180.0) / T::pi();
        Self {
            pitch: deg,
            speed: c::<T>(ENCODER_CPR) / (T::two_pi() * wheel_radius) * period,
            heading: -deg,
            integral_step: T::one(),
        }
    }

    /// SI throughout, integrals in time (gains then are per rad, per m/s, …).
    pub fn si(period: T) -> Self {
        Self { pitch: T::one(), speed: T::one(), heading: T::one(), integral_step: period }
    }
}

/// Names of [`PidTracker::internals`], in order (Arduino units, PWM counts).
pub const PID_INTERNALS: [&str; 9] = ["u_phi", "u_v", "u_psi", "e_v", "e_psi", "int_v", "int_psi", "pwm_r", "pwm_l"];

/// The discrete PID tracker with its motor.
#[derive(Clone, Copy, Debug)]
pub struct PidTracker<T: Real> {
    /// Gains, units, motor and the geometry the wheel speeds are turned with.
    law: PidLaw<T>,
    period: T,
    int_v: T,
    int_psi: T,
    internals: [T; 9],
}

impl<T: Real> PidTracker<T> {
    /// `params` gives the wheel radius and half track that turn (v, ω, φ̇) into the
    /// wheels' speeds relative to the body (what the encoders measure).
    pub fn new(
        gains: PidGains<T>,
        units: PidUnits<T>,
        motor: DcMotor<T>,
        params: &RobotParams<T>,
        period: T,
    ) -> Result<Self, TwipError> {
        let p = params.validate()?;
        Self::build(gains, units, motor, p.wheel_radius, p.half_track, period)
    }

    /// As [`Self::new`] from the two lengths it needs of the robot (a firmware has no
    /// `RobotParams`): the wheel radius and half track [m], both finite and > 0.
    pub fn with_geometry(
        gains: PidGains<T>,
        units: PidUnits<T>,
        motor: DcMotor<T>,
        wheel_radius: T,
        half_track: T,
        period: T,
    ) -> Result<Self, TwipError> {
        for (name, v) in [("wheel_radius", wheel_radius), ("half_track", half_track)] {
            if !(v.is_finite() && v > T::zero()) {
                return Err(invalid(name, v, "must be finite and > 0"));
            }
        }
        Self::build(gains, units, motor, wheel_radius, half_track, period)
    }

    fn build(gains: PidGains<T>, units: PidUnits<T>, motor: DcMotor<T>, radius: T, half_track: T, period: T) -> Result<Self, TwipError> {
        // First: a bad period also spoils the Arduino's speed unit (counts per update).
        if !(period.is_finite() && period > T::zero()) {
            return Err(invalid("period", period, "must be finite and > 0"));
        }
        for (name, g) in gains.to_array() {
            if !g.is_finite() {
                return Err(invalid(name, g, "must be finite"));
            }
        }
        let scales = [("pitch", units.pitch), ("speed", units.speed), ("heading", units.heading)];
        for (name, s) in scales {
            if !(s.is_finite() && s != T::zero()) {
                return Err(invalid(name, s, "unit must be finite and non-zero"));
            }
        }
        if !(units.integral_step.is_finite() && units.integral_step > T::zero()) {
            return Err(invalid("integral_step", units.integral_step, "must be finite and > 0"));
        }
        Ok(Self {
            law: PidLaw { gains, units, motor, radius, half_track },
            period,
            int_v: T::zero(),
            int_psi: T::zero(),
            internals: [T::zero(); 9],
        })
    }

    /// Table 4.1's gains in [`PidUnits::arduino`] at `period` (5 ms: an Arduino loop).
    pub fn table_4_1(params: &RobotParams<T>, motor: DcMotor<T>, period: T) -> Result<Self, TwipError> {
        Self::new(PidGains::table_4_1(), PidUnits::arduino(params.wheel_radius, period), motor, params, period)
    }

    /// The same controller at another period; the units are kept as they are.
    pub fn with_period(self, period: T) -> Result<Self, TwipError> {
        let l = self.law;
        Self::build(l.gains, l.units, l.motor, l.radius, l.half_track, period)
    }

    pub fn gains(&self) -> PidGains<T> {
        self.law.gains
    }

    pub fn units(&self) -> PidUnits<T> {
        self.law.units
    }

    pub fn motor(&self) -> &DcMotor<T> {
        &self.law.motor
    }

    /// The wheel radius and half track [m] the tracker turns speeds with.
    pub fn geometry(&self) -> (T, T) {
        (self.law.radius, self.law.half_track)
    }

    /// Whether what the next update starts from (the speed and heading integrals) is finite.
    pub fn state_is_finite(&self) -> bool {
        self.int_v.is_finite() && self.int_psi.is_finite()
    }
}

/// The right and left wheels' speeds relative to the body [rad/s]: what drives the back-EMF.
#[inline(always)]
pub(crate) fn relative_wheel_speeds<S: Lane>(y: &[S; 7], radius: S, half_track: S) -> [S; 2] {
    let (phi_dot, v, omega) = (y[4], y[5], y[6]);
    [S::madd(half_track, omega, v) / radius - phi_dot, S::madd(-half_track, omega, v) / radius - phi_dot]
}

/// What one update of the tracker gives: the wheels' torques, the internals
/// ([`PID_INTERNALS`]) and the two integrals after it.
pub(crate) struct PidStep<S> {
    pub torque: [S; 2],
    pub internals: [S; 9],
    pub integrals: [S; 2],
}

/// The tracker's parameters in the number type of a run or of a sweep's lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PidLaw<S> {
    pub gains: PidGains<S>,
    pub units: PidUnits<S>,
    pub motor: DcMotor<S>,
    pub radius: S,
    pub half_track: S,
}

impl<S: Lane> PidLaw<S> {
    /// (4.67)–(4.70) at measurement `y` and reference `r` with the integrals `[Σ e_v, Σ e_ψ]`
    /// before this update, written once: a run's update and a sweep's lanes.
    #[inline(always)]
    pub(crate) fn step(&self, y: &[S; 7], r: &PlanarRef<S>, integrals: [S; 2]) -> PidStep<S> {
        let (g, u) = (&self.gains, &self.units);
        let [int_v, int_psi] = integrals;
        let u_phi = S::madd(g.kp_pitch * u.pitch, y[3], g.kd_pitch * u.pitch * y[4]);
        let e_v = u.speed * (r.v - y[5]);
        let u_v = S::madd(g.kp_speed, e_v, g.ki_speed * int_v);
        let e_psi = u.heading * wrap_angle(r.psi - y[2]);
        // The heading error's rate from the gyro: ψ̇_r − ω.
        let u_psi = S::madd(g.kd_yaw * u.heading, r.omega - y[6], S::madd(g.kp_yaw, e_psi, g.ki_yaw * int_psi));
        let limit = self.motor.pwm_max();
        let pwm = [saturate(u_phi + u_v + u_psi, limit), saturate(u_phi + u_v - u_psi, limit)];
        let speeds = relative_wheel_speeds(y, self.radius, self.half_track);
        PidStep {
            torque: [self.motor.torque_from_pwm(pwm[0], speeds[0]), self.motor.torque_from_pwm(pwm[1], speeds[1])],
            internals: [u_phi, u_v, u_psi, e_v, e_psi, int_v, int_psi, pwm[0], pwm[1]],
            // Forward Euler, as the Arduino does: the sums hold the errors up to this update.
            integrals: [S::madd(u.integral_step, e_v, int_v), S::madd(u.integral_step, e_psi, int_psi)],
        }
    }
}

impl<T: Copy> PidLaw<T> {
    /// The same law in the number type `f` maps to (a sweep's lanes).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub(crate) fn map<S>(&self, f: impl Fn(T) -> S + Copy) -> PidLaw<S> {
        let (g, u) = (self.gains, self.units);
        PidLaw {
            gains: PidGains {
                kp_pitch: f(g.kp_pitch),
                kd_pitch: f(g.kd_pitch),
                kp_speed: f(g.kp_speed),
                ki_speed: f(g.ki_speed),
                kp_yaw: f(g.kp_yaw),
                ki_yaw: f(g.ki_yaw),
                kd_yaw: f(g.kd_yaw),
            },
            units: PidUnits { pitch: f(u.pitch), speed: f(u.speed), heading: f(u.heading), integral_step: f(u.integral_step) },
            motor: self.motor.map(f),
            radius: f(self.radius),
            half_track: f(self.half_track),
        }
    }
}

impl<T: Real> PidTracker<T> {
    /// The tracker's law (gains, units, motor, geometry).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub(crate) fn law(&self) -> &PidLaw<T> {
        &self.law
    }
}

impl<T: Real> Controller<T, 7, 2> for PidTracker<T> {
    type Reference = PlanarRef<T>;

    fn period(&self) -> T {
        self.period
    }

    fn reset(&mut self) {
        self.int_v = T::zero();
        self.int_psi = T::zero();
        self.internals = [T::zero(); 9];
    }

    fn update(&mut self, _t: T, y: &SVector<T, 7>, r: &PlanarRef<T>) -> SVector<T, 2> {
        let step = self.law.step(&(*y).into(), r, [self.int_v, self.int_psi]);
        self.internals = step.internals;
        [self.int_v, self.int_psi] = step.integrals;
        SVector::<T, 2>::from(step.torque)
    }

    fn internals(&self) -> &[T] {
        &self.internals
    }

    fn internal_names(&self) -> &'static [&'static str] {
        &PID_INTERNALS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balance_and_turn_directions() {
        let p = RobotParams::<f64>::balanbot();
        let mut pid = PidTracker::table_4_1(&p, DcMotor::gb37y3530(), 0.005).unwrap();
        let at_rest = PlanarRef::default();
        // Leaning forward: both wheels drive forward.
        let u = pid.update(0.0, &SVector::from([0.0, 0.0, 0.0, 0.05, 0.0, 0.0, 0.0]), &at_rest);
        assert!(u[0] > 0.0 && u[0] == u[1]);
        // Heading to the right of the reference (ψ < ψ_r): turn left, u_r > u_l.
        pid.reset();
        let u = pid.update(0.0, &SVector::from([0.0, 0.0, -0.1, 0.0, 0.0, 0.0, 0.0]), &at_rest);
        assert!(u[0] > u[1]);
    }

    #[test]
    fn pwm_saturates_and_back_emf_opposes() {
        let p = RobotParams::<f64>::balanbot();
        let m = DcMotor::gb37y3530();
        let mut pid = PidTracker::table_4_1(&p, m, 0.005).unwrap();
        let u = pid.update(0.0, &SVector::from([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]), &PlanarRef::default());
        assert_eq!(u[0], m.torque(11.1, 0.0));
        // Same full PWM while the wheels already spin forward: less torque.
        let u2 = pid.update(0.0, &SVector::from([0.0, 0.0, 0.0, 1.0, 0.0, 0.3, 0.0]), &PlanarRef::default());
        assert!(u2[0] < u[0]);
        let mut bad = PidGains::<f64>::table_4_1();
        bad.kd_yaw = f64::NAN;
        let err = PidTracker::new(bad, PidUnits::si(0.005), m, &p, 0.005).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "kd_yaw", .. }));
    }

    #[test]
    fn a_nan_pitch_is_not_hidden_by_the_pwm_limit() {
        let p = RobotParams::<f64>::balanbot();
        let mut pid = PidTracker::table_4_1(&p, DcMotor::gb37y3530(), 0.005).unwrap();
        let u = pid.update(0.0, &SVector::from([0.0, 0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0]), &PlanarRef::default());
        assert!(u.iter().all(|v| v.is_nan()), "{u:?}");
    }
}
