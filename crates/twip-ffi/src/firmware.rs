//! The firmware-side pieces around a controller, the same code the simulator's realism rig
//! runs: tilt estimators (complementary, Kalman), the encoder's angle and speed from its
//! counter, and the command-to-PWM feed-forward of the motor driver.
use twip_core::hardware::driver::PwmActuator;
use twip_core::hardware::encoder::Encoder;
use twip_core::hardware::tilt::{accel_tilt, TiltEstimator, TiltFilter};

use crate::config::TwipMotor;
use crate::controllers::init;
use crate::slot::{self, fits};
use crate::{TwipStatus, TWIP_ERR_NOT_FINITE, TWIP_ERR_NULL, TWIP_OK};

pub const TWIP_TILT_WORDS: usize = 8;
pub const TWIP_ENCODER_WORDS: usize = 4;
pub const TWIP_PWM_WORDS: usize = 6;
const _: () = assert!(fits::<TiltFilter<f32>>(TWIP_TILT_WORDS));
const _: () = assert!(fits::<Encoder<f32>>(TWIP_ENCODER_WORDS));
const _: () = assert!(fits::<PwmActuator<f32>>(TWIP_PWM_WORDS));

const TILT_TAG: u64 = u64::from_le_bytes(*b"twipTLT\0");
const ENCODER_TAG: u64 = u64::from_le_bytes(*b"twipENC\0");
const PWM_TAG: u64 = u64::from_le_bytes(*b"twipPWM\0");

/// A tilt estimator: `kind` 0 is the complementary filter with `time_constant` τ [s];
/// 1 the Kalman filter with angle and bias random walks `q_angle` [rad²/s], `q_bias`
/// [rad²/s³] and accelerometer variance `r_angle` [rad²].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipTiltConfig {
    pub kind: i32,
    pub time_constant: f32,
    pub q_angle: f32,
    pub q_bias: f32,
    pub r_angle: f32,
}

impl TwipTiltConfig {
    pub fn build(&self) -> Result<TiltFilter<f32>, twip_core::TwipError> {
        let kind = match self.kind {
            0 => TiltEstimator::Complementary { time_constant: self.time_constant },
            1 => TiltEstimator::Kalman { q_angle: self.q_angle, q_bias: self.q_bias, r_angle: self.r_angle },
            k => {
                return Err(twip_core::TwipError::InvalidParameter {
                    name: "kind",
                    value: k as f64,
                    reason: "must be 0 (complementary) or 1 (kalman)",
                })
            }
        };
        TiltFilter::new(kind)
    }
}

/// The command-to-PWM feed-forward: the duty that gives a command (lumped current [A] for
/// the 2-DOF controllers, one wheel's torque [N m] for the trackers) at the measured
/// relative wheel speed, with the motor as the firmware believes it is.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipPwmConfig {
    pub motor: TwipMotor,
    /// Command per motor ampere: 2 × efficiency for the lumped current, efficiency × gear
    /// ratio × torque constant for a wheel torque.
    pub command_per_amp: f32,
}

impl TwipPwmConfig {
    pub fn build(&self) -> Result<PwmActuator<f32>, twip_core::TwipError> {
        PwmActuator::from_parts(self.motor.to_core()?, self.command_per_amp)
    }

    pub fn from_core(a: &PwmActuator<f64>) -> Self {
        let (motor, command_per_amp) = a.parts();
        Self { motor: TwipMotor::from_core(&motor), command_per_amp: command_per_amp as f32 }
    }
}

/// State of a tilt estimator (opaque).
#[repr(C)]
pub struct TwipTilt {
    pub words: [u64; TWIP_TILT_WORDS],
}

/// State of one encoder (opaque).
#[repr(C)]
pub struct TwipEncoder {
    pub words: [u64; TWIP_ENCODER_WORDS],
}

/// State of the PWM feed-forward (opaque).
#[repr(C)]
pub struct TwipPwm {
    pub words: [u64; TWIP_PWM_WORDS],
}

/// The accelerometer's tilt [rad] from the specific force along the sensor's x (forward)
/// and z (up the body) axes, any unit. NaN for NaN inputs.
#[no_mangle]
pub extern "C" fn twip_accel_tilt(fx: f32, fz: f32) -> f32 {
    accel_tilt(fx, fz)
}

/// # Safety
/// `state` and `config` are NULL or valid pointers.
#[no_mangle]
pub unsafe extern "C" fn twip_tilt_init(state: *mut TwipTilt, config: *const TwipTiltConfig) -> TwipStatus {
    init(state.cast(), TILT_TAG, config, TwipTiltConfig::build)
}

/// One estimator step: the accelerometer tilt [rad] and gyroscope rate [rad/s], `dt` [s]
/// after the previous step; `angle` and `rate` receive the estimated pitch and pitch rate.
///
/// # Safety
/// Pointers are NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn twip_tilt_update(
    state: *mut TwipTilt,
    tilt: f32,
    gyro_rate: f32,
    dt: f32,
    angle: *mut f32,
    rate: *mut f32,
) -> TwipStatus {
    if angle.is_null() || rate.is_null() {
        return TWIP_ERR_NULL;
    }
    let filter = match slot::get::<TiltFilter<f32>>(state.cast(), TILT_TAG) {
        Ok(f) => f,
        Err(status) => return status,
    };
    if !(tilt.is_finite() && gyro_rate.is_finite() && dt.is_finite() && dt >= 0.0) {
        return TWIP_ERR_NOT_FINITE;
    }
    let (a, r) = filter.update(tilt, gyro_rate, dt);
    angle.write(a);
    rate.write(r);
    TWIP_OK
}

/// An encoder of `counts_per_revolution` counts per turn of the wheel (≥ 1).
///
/// # Safety
/// `state` is NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn twip_encoder_init(state: *mut TwipEncoder, counts_per_revolution: f32) -> TwipStatus {
    init(state.cast(), ENCODER_TAG, &counts_per_revolution, |&cpr| Encoder::new(cpr))
}

/// The wheel's angle relative to the body [rad] and its speed [rad/s] from the hardware
/// counter's value `count`, `dt` [s] after the previous read (speed 0 at the first read).
///
/// # Safety
/// Pointers are NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn twip_encoder_read(
    state: *mut TwipEncoder,
    count: i32,
    dt: f32,
    angle: *mut f32,
    speed: *mut f32,
) -> TwipStatus {
    if angle.is_null() || speed.is_null() {
        return TWIP_ERR_NULL;
    }
    let encoder = match slot::get::<Encoder<f32>>(state.cast(), ENCODER_TAG) {
        Ok(e) => e,
        Err(status) => return status,
    };
    if !(dt.is_finite() && dt >= 0.0) {
        return TWIP_ERR_NOT_FINITE;
    }
    let (a, s) = encoder.read_count(count as f32, dt);
    angle.write(a);
    speed.write(s);
    TWIP_OK
}

/// # Safety
/// `state` and `config` are NULL or valid pointers.
#[no_mangle]
pub unsafe extern "C" fn twip_pwm_init(state: *mut TwipPwm, config: *const TwipPwmConfig) -> TwipStatus {
    init(state.cast(), PWM_TAG, config, TwipPwmConfig::build)
}

/// The PWM duty [counts, a whole number within ±pwm_max] for `command` at the wheel's
/// speed relative to the body [rad/s].
///
/// # Safety
/// Pointers are NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn twip_pwm_duty(
    state: *mut TwipPwm,
    command: f32,
    relative_speed: f32,
    duty: *mut f32,
) -> TwipStatus {
    if duty.is_null() {
        return TWIP_ERR_NULL;
    }
    let pwm = match slot::get::<PwmActuator<f32>>(state.cast(), PWM_TAG) {
        Ok(p) => p,
        Err(status) => return status,
    };
    if !(command.is_finite() && relative_speed.is_finite()) {
        return TWIP_ERR_NOT_FINITE;
    }
    duty.write(pwm.duty(command, relative_speed));
    TWIP_OK
}
