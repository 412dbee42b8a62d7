//! Physical parameters of one robot, shared by the 2-DOF and the 3-DOF model.
use crate::{c, to_f64, Real, TwipError};

/// One robot, SI units. Thesis symbols in brackets.
///
/// The 2-DOF model lumps both sides: `m_wheels`, `i_wheels` and `i_motor` are both
/// wheels (rotors) together and the input is the lumped current. The 3-DOF model gives
/// each side half of them. See `docs/parameters.md` for the sources of `balanbot()`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotParams<T> {
    /// Body mass, motors' stators included [M_b], kg.
    pub m_body: T,
    /// Mass of both wheels together [M_w], kg.
    pub m_wheels: T,
    /// Body pitch inertia about its centre of mass [I_b, I_yy], kg m².
    pub i_body: T,
    /// Both wheels' inertia about the axle [I_w], kg m².
    pub i_wheels: T,
    /// Both motor rotors' inertia, at the motor shaft [I_M], kg m².
    pub i_motor: T,
    /// Gear reduction ratio [eta].
    pub gear_ratio: T,
    /// Motor torque constant at the motor shaft [tau_i], N m / A.
    pub torque_constant: T,
    /// Wheel radius [r, R], m.
    pub wheel_radius: T,
    /// Axle to body centre of mass [l, c_z], m.
    pub com_height: T,
    /// Viscous friction between body and wheels, both sides [mu_s], N m s / rad.
    pub mu_bearing: T,
    /// Viscous friction between wheels and ground, both sides [mu_g], N m s / rad.
    pub mu_ground: T,
    /// Half the distance between the wheels [b], m.
    pub half_track: T,
    /// Body roll inertia about its centre of mass [I_xx], kg m².
    pub i_body_roll: T,
    /// Body yaw inertia about its centre of mass [I_zz], kg m².
    pub i_body_yaw: T,
    /// One wheel's inertia about a diameter [I_wd], kg m².
    pub i_wheel_diam: T,
    /// Gravitational acceleration, m / s².
    pub g: T,
}

/// How a field is checked.
#[derive(Clone, Copy)]
enum Domain {
    Positive,
    NonNegative,
}

/// The field names in declaration order (the order of [`RobotParams::to_array`]).
pub const FIELD_NAMES: [&str; 16] = [
    "m_body",
    "m_wheels",
    "i_body",
    "i_wheels",
    "i_motor",
    "gear_ratio",
    "torque_constant",
    "wheel_radius",
    "com_height",
    "mu_bearing",
    "mu_ground",
    "half_track",
    "i_body_roll",
    "i_body_yaw",
    "i_wheel_diam",
    "g",
];

const DOMAINS: [Domain; 16] = {
    use Domain::*;
    [
        Positive,    // m_body
        Positive,    // m_wheels
        Positive,    // i_body
        Positive,    // i_wheels
        NonNegative, // i_motor: 0 models a direct drive
        Positive,    // gear_ratio
        Positive,    // torque_constant
        Positive,    // wheel_radius
        Positive,    // com_height
        NonNegative, // mu_bearing
        NonNegative, // mu_ground
        Positive,    // half_track
        Positive,    // i_body_roll
        Positive,    // i_body_yaw
        Positive,    // i_wheel_diam
        Positive,    // g
    ]
};

impl<T: Real> RobotParams<T> {
    /// The thesis's robot (Balanbot, GB37Y3530-12V-251R motors, 43.7:1); see
    /// `docs/parameters.md` for where each number comes from.
    pub fn balanbot() -> Self {
        Self::from_array(&BALANBOT.map(c::<T>))
    }

    /// All fields in the order of [`FIELD_NAMES`].
    pub fn to_array(&self) -> [T; 16] {
        [
            self.m_body,
            self.m_wheels,
            self.i_body,
            self.i_wheels,
            self.i_motor,
            self.gear_ratio,
            self.torque_constant,
            self.wheel_radius,
            self.com_height,
            self.mu_bearing,
            self.mu_ground,
            self.half_track,
            self.i_body_roll,
            self.i_body_yaw,
            self.i_wheel_diam,
            self.g,
        ]
    }

    /// Builds from values in the order of [`FIELD_NAMES`] (not validated).
    pub fn from_array(v: &[T; 16]) -> Self {
        Self {
            m_body: v[0],
            m_wheels: v[1],
            i_body: v[2],
            i_wheels: v[3],
            i_motor: v[4],
            gear_ratio: v[5],
            torque_constant: v[6],
            wheel_radius: v[7],
            com_height: v[8],
            mu_bearing: v[9],
            mu_ground: v[10],
            half_track: v[11],
            i_body_roll: v[12],
            i_body_yaw: v[13],
            i_wheel_diam: v[14],
            g: v[15],
        }
    }

    /// Checks every field: finite; frictions and rotor inertia ≥ 0; all else > 0; and
    /// within the range the models can compute with (magnitudes between `max^-¼` and `max^⅛`
    /// of `T`: 9e-78..1e38 in f64, 2e-10..6e4 in f32), since their coefficients
    /// multiply up to four fields and divide by such products.
    /// The rotor's reflected inertia η² I_M must stay below 1/sqrt(ε) of `T` times the
    /// rest of the robot's inertia (6.7e7 in f64, 2.9e3 in f32; the Balanbot's is 1.3).
    /// The error names the first offending field and its value.
    pub fn validate(&self) -> Result<Self, TwipError> {
        let (tiny, huge) = magnitude_range::<T>();
        for ((name, value), domain) in FIELD_NAMES.iter().zip(self.to_array()).zip(DOMAINS) {
            let reason = if !value.is_finite() {
                Some("must be finite")
            } else if value.abs() > huge || (!value.is_zero() && value.abs() < tiny) {
                Some("is out of the range the models can compute with (check its SI unit)")
            } else {
                match domain {
                    Domain::Positive if value <= T::zero() => Some("must be > 0"),
                    Domain::NonNegative if value < T::zero() => Some("must be >= 0"),
                    _ => None,
                }
            };
            if let Some(reason) = reason {
                return Err(TwipError::InvalidParameter { name, value: to_f64(value), reason });
            }
        }
        // The mass matrices hold the rotor's reflected inertia η² I_M on and off the
        // diagonal: their determinant is the difference of two products of it, and the
        // rest of the robot's inertia survives that subtraction only while η² I_M stays
        // below 1/sqrt(ε) times it (found by tests/constructors.rs: i_motor = 1.8e38
        // passed the ranges and the first RK4 step divided by a zero determinant).
        let rotor = self.gear_ratio * self.gear_ratio * self.i_motor;
        let rest = self.i_body
            + self.m_body * self.com_height * self.com_height
            + self.i_wheels
            + (self.m_body + self.m_wheels) * self.wheel_radius * self.wheel_radius;
        if rotor * T::default_epsilon().sqrt() > rest {
            return Err(TwipError::InvalidParameter {
                name: "i_motor",
                value: to_f64(self.i_motor),
                reason: "gives a reflected rotor inertia gear_ratio^2 * i_motor so far above the body's and wheels' \
                         inertia that the mass matrix cannot be inverted in this precision",
            });
        }
        Ok(*self)
    }

    /// The torque between body and wheels per ampere of lumped current, η τ_i [N m / A].
    #[inline]
    pub fn torque_per_amp(&self) -> T {
        self.gear_ratio * self.torque_constant
    }
}

/// The magnitudes a field may have: products of four fields, and their quotients, stay
/// finite and nonzero in `T`.
fn magnitude_range<T: Real>() -> (T, T) {
    let max = T::max_value().unwrap_or_else(|| c::<T>(f32::MAX as f64));
    ((T::one() / max).sqrt().sqrt(), max.sqrt().sqrt().sqrt())
}

/// Default robot, in the order of [`FIELD_NAMES`]; reasoning in `docs/parameters.md`.
const BALANBOT: [f64; 16] = [
    0.8301,     // m_body (fitted, scripts/fit_balanbot.py)
    0.07963,    // m_wheels (fitted)
    4.994e-3,   // i_body (fitted)
    4.4e-5,     // i_wheels: ½ m r² of two 40 g wheels
    5.303e-6,   // i_motor (fitted)
    43.7,       // gear_ratio: data sheet
    9.920e-3,   // torque_constant (fitted; data sheet estimate 9.9e-3)
    1.0 / 30.0, // wheel_radius: pinned by the thesis's own numbers
    0.04943,    // com_height (fitted)
    0.01066,    // mu_bearing (fitted; no-load current estimate 0.0115)
    2.483e-3,   // mu_ground (fitted)
    0.085,      // half_track: Balanbot frame
    3.5e-3,     // i_body_roll: box estimate
    2.5e-3,     // i_body_yaw: box estimate
    1.1e-5,     // i_wheel_diam: ¼ m r² of one wheel
    9.81,       // g
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balanbot_is_valid_in_both_precisions() {
        assert!(RobotParams::<f64>::balanbot().validate().is_ok());
        assert!(RobotParams::<f32>::balanbot().validate().is_ok());
    }

    #[test]
    fn invalid_field_is_named_with_its_value() {
        let mut p = RobotParams::<f64>::balanbot();
        p.com_height = -0.1;
        let err = p.validate().unwrap_err();
        assert_eq!(
            err,
            TwipError::InvalidParameter { name: "com_height", value: -0.1, reason: "must be > 0" }
        );
        let mut p = RobotParams::<f64>::balanbot();
        p.mu_ground = f64::NAN;
        assert!(matches!(
            p.validate(),
            Err(TwipError::InvalidParameter { name: "mu_ground", reason: "must be finite", .. })
        ));
        let mut p = RobotParams::<f64>::balanbot();
        p.i_motor = 0.0;
        assert!(p.validate().is_ok(), "a direct drive (no rotor) is allowed");
    }

    #[test]
    fn a_rotor_that_swamps_the_mass_matrix_is_refused() {
        // Within each field's range, yet the determinant would cancel to zero.
        let mut p = RobotParams::<f64>::balanbot();
        p.i_motor = 1.8e38;
        assert!(matches!(p.validate(), Err(TwipError::InvalidParameter { name: "i_motor", .. })));
        // The bound is 1/sqrt(eps) of the rest: f32 refuses what f64 still computes.
        let mut p = RobotParams::<f64>::balanbot();
        p.i_motor = 5.303e-6 * 1e4;
        assert!(p.validate().is_ok());
        let mut q = RobotParams::<f32>::balanbot();
        q.i_motor = 5.303e-6 * 1e4;
        assert!(q.validate().is_err());
    }

    #[test]
    fn array_round_trip() {
        let p = RobotParams::<f64>::balanbot();
        assert_eq!(RobotParams::from_array(&p.to_array()), p);
    }
}
