//! The firmware-side pieces around a controller, the same code the simulator's realism rig
//! runs: tilt estimators (complementary, Kalman), the encoder's angle and speed from its
//! counter, and the command-to-PWM feed-forward of the motor driver.
use twip_core::hardware::driver::PwmActuator;
use twip_core::hardware::encoder::Encoder;
use twip_core::hardware::tilt::{accel_tilt, TiltEstimator, TiltFilter};

use crate::config::{narrow, TwipMotor};
use crate::controllers::init;
use crate::slot::{self, fits};
use crate::{TwipStatus, TWIP_ERR_INVALID, TWIP_ERR_NOT_FINITE, TWIP_ERR_NULL, TWIP_ERR_OVERFLOW, TWIP_OK};

pub const TWIP_TILT_WORDS: usize = 8;
pub const TWIP_ENCODER_WORDS: usize = 4;
pub const TWIP_PWM_WORDS: usize = 6;
const _: () = assert!(fits::<TiltFilter<f32>>(TWIP_TILT_WORDS));
const _: () = assert!(fits::<CountEncoder>(TWIP_ENCODER_WORDS));
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

    pub fn from_core(a: &PwmActuator<f64>) -> Result<Self, twip_core::TwipError> {
        let (motor, command_per_amp) = a.parts();
        Ok(Self { motor: TwipMotor::from_core(&motor)?, command_per_amp: narrow("command_per_amp", command_per_amp)? })
    }
}

/// The encoder behind the C ABI: the core's, with the last count kept as the hardware's
/// integer. Differenced as integers, then converted: an f32 count loses whole counts past
/// 2^24 and jumps by 2^32 across the counter's wrap.
#[derive(Clone, Copy, Debug)]
struct CountEncoder {
    encoder: Encoder<f32>,
    last: Option<i32>,
}

/// Checks a step's `dt` [s]: NaN or infinite is not finite, negative is out of its domain.
fn check_dt(dt: f32) -> Result<(), TwipStatus> {
    match dt {
        _ if !dt.is_finite() => Err(TWIP_ERR_NOT_FINITE),
        _ if dt < 0.0 => Err(TWIP_ERR_INVALID),
        _ => Ok(()),
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
/// TWIP_ERR_NOT_FINITE for a NaN or infinite input, TWIP_ERR_INVALID for `dt` < 0,
/// TWIP_ERR_OVERFLOW when finite inputs (a gyro glitch of 3e38, a huge `dt`) make the
/// estimate or the filter's state NaN or infinite: the state is then as before the call.
/// On any error the outputs are untouched.
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
    if !(tilt.is_finite() && gyro_rate.is_finite()) {
        return TWIP_ERR_NOT_FINITE;
    }
    if let Err(status) = check_dt(dt) {
        return status;
    }
    // Finite inputs can still overflow (a gyro glitch of 3e38, a huge dt): kept, an
    // infinite angle or NaN covariance would poison every later update.
    let before = *filter;
    let (a, r) = filter.update(tilt, gyro_rate, dt);
    if !(a.is_finite() && r.is_finite() && filter.state_is_finite()) {
        *filter = before;
        return TWIP_ERR_OVERFLOW;
    }
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
    init(state.cast(), ENCODER_TAG, &counts_per_revolution, |&cpr| Ok(CountEncoder { encoder: Encoder::new(cpr)?, last: None }))
}

/// The wheel's angle relative to the body [rad] and its speed [rad/s] from the counter's
/// value `count`, `dt` [s] after the previous read (speed 0 at the first read, and with `dt`
/// = 0). `count` is a 32-bit running count that wraps from INT32_MAX to INT32_MIN: the
/// speed comes from the counts' difference modulo 2^32, exact across the wrap while fewer
/// than 2^31 counts pass between reads. A narrower hardware counter must be extended to 32
/// bits by the caller, for example with a 16-bit timer `total += (int16_t)(hw - last_hw);
/// last_hw = hw;` at every read (more often than every 2^15 counts): passed as it is, its
/// wrap from 65535 to 0 reads as a jump of 65535 counts. The angle is `count` × 2π/CPR
/// in f32, so it wraps with the counter and its step grows past 2^24 counts.
/// TWIP_ERR_NOT_FINITE for a NaN or infinite `dt`, TWIP_ERR_INVALID for `dt` < 0,
/// TWIP_ERR_OVERFLOW when the speed is infinite (a tiny `dt`, 1e-40): the previous count is
/// kept, so the next read's speed spans both periods. On any error the outputs are untouched.
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
    let reader = match slot::get::<CountEncoder>(state.cast(), ENCODER_TAG) {
        Ok(e) => e,
        Err(status) => return status,
    };
    if let Err(status) = check_dt(dt) {
        return status;
    }
    let speed_now = match reader.last {
        Some(last) if dt > 0.0 => reader.encoder.speed_of(count.wrapping_sub(last) as f32, dt),
        _ => 0.0,
    };
    // A tiny dt (1e-40) makes the speed infinite: refused before the last count is kept.
    if !speed_now.is_finite() {
        return TWIP_ERR_OVERFLOW;
    }
    reader.last = Some(count);
    angle.write(count as f32 * reader.encoder.resolution());
    speed.write(speed_now);
    TWIP_OK
}

/// # Safety
/// `state` and `config` are NULL or valid pointers.
#[no_mangle]
pub unsafe extern "C" fn twip_pwm_init(state: *mut TwipPwm, config: *const TwipPwmConfig) -> TwipStatus {
    init(state.cast(), PWM_TAG, config, TwipPwmConfig::build)
}

/// The PWM duty [counts, a whole number within ±pwm_max] for `command` at the wheel's
/// speed relative to the body [rad/s]. TWIP_ERR_NOT_FINITE for a NaN or infinite input;
/// TWIP_ERR_OVERFLOW when finite inputs near f32's limit give no duty (the current's and
/// the back-EMF's volts both overflow, opposite: NaN, which a driver would read as full
/// power). `duty` is written only with TWIP_OK.
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
    let d = pwm.duty(command, relative_speed);
    if d.is_nan() {
        return TWIP_ERR_OVERFLOW;
    }
    duty.write(d);
    TWIP_OK
}
