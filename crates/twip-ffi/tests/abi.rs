//! The C ABI's contract, called as C calls it: status codes for NULL, uninitialised and
//! non-finite inputs and for bad configurations; reset; and the firmware pieces answering
//! what the core's own types answer.
use core::ptr::{null, null_mut};

use twip_core::control::lqr::LqrController;
use twip_core::control::Controller;
use twip_core::hardware::encoder::Encoder;
use twip_core::hardware::tilt::{TiltEstimator, TiltFilter};
use twip_core::{RobotParams, SlopeModel};
use twip_ffi::*;

fn lqr_config() -> TwipLqrConfig {
    // flat-lqr's gains as the thesis's design gives them, on the Balanbot, at 5 ms.
    let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
    let gains = [-11.0091734, -1.69875395, -0.0500031523, -0.0456435457];
    let c = LqrController::new(gains, model, twip_core::control::lqr::DesignPoint::OperatingPoint, 0.005).unwrap();
    TwipLqrConfig::from_core(&c).unwrap()
}

fn new_lqr() -> TwipLqr {
    TwipLqr { words: [0; TWIP_LQR_WORDS] }
}

#[test]
fn update_answers_what_the_core_controller_answers() {
    let config = lqr_config();
    let mut state = new_lqr();
    assert_eq!(unsafe { twip_lqr_init(&mut state, &config) }, TWIP_OK);
    let mut core = config.build().unwrap();
    let reference = TwipSpeedRef { theta: 0.1, theta_dot: 0.5 };
    for k in 0..50 {
        let t = k as f32 * 0.005;
        let y = [0.02 * (k as f32 * 0.1).sin(), 0.1, 0.01 * k as f32, 0.3];
        let mut u = [f32::NAN];
        assert_eq!(unsafe { twip_lqr_update(&mut state, t, y.as_ptr(), &reference, u.as_mut_ptr()) }, TWIP_OK);
        let expected = core.update(t, &y.into(), &twip_core::control::reference::SpeedRef { theta: 0.1, theta_dot: 0.5 });
        assert_eq!(u[0], expected[0], "update {k}");
    }
}

#[test]
fn t_is_checked_but_unused_as_the_header_says() {
    // The integrator steps by the configured period whatever `t` says: a firmware on
    // another clock gets the same commands, so the header must say to call at the period.
    let config = lqr_config();
    let (mut a, mut b) = (new_lqr(), new_lqr());
    unsafe { (twip_lqr_init(&mut a, &config), twip_lqr_init(&mut b, &config)) };
    let r = TwipSpeedRef { theta: 0.0, theta_dot: 1.0 };
    for k in 0..20 {
        let y = [0.05f32, 0.0, 0.01 * k as f32, 0.0];
        let (mut ua, mut ub) = ([0.0f32], [0.0f32]);
        unsafe {
            twip_lqr_update(&mut a, k as f32 * 0.005, y.as_ptr(), &r, ua.as_mut_ptr());
            twip_lqr_update(&mut b, k as f32 * 0.01 + 123.0, y.as_ptr(), &r, ub.as_mut_ptr());
        }
        assert_eq!(ua, ub, "update {k}");
    }
    // The comment just above twip_lqr_update's declaration says so.
    let header = include_str!("../include/twip.h");
    let end = header.find("TwipStatus twip_lqr_update(").unwrap();
    let comment = &header[header[..end].rfind("\n\n").unwrap()..end];
    assert!(comment.contains("not otherwise") && comment.contains("`period`"), "{comment}");
}

#[test]
fn reset_returns_to_the_first_answer() {
    let config = lqr_config();
    let mut state = new_lqr();
    unsafe { twip_lqr_init(&mut state, &config) };
    let (y, r) = ([0.05f32, 0.0, 0.0, 0.0], TwipSpeedRef { theta: 0.0, theta_dot: 1.0 });
    let mut first = [0.0f32];
    let mut later = [0.0f32];
    unsafe {
        twip_lqr_update(&mut state, 0.0, y.as_ptr(), &r, first.as_mut_ptr());
        for k in 1..20 {
            twip_lqr_update(&mut state, k as f32 * 0.005, y.as_ptr(), &r, later.as_mut_ptr());
        }
        assert_ne!(first, later, "the integrator moved");
        assert_eq!(twip_lqr_reset(&mut state), TWIP_OK);
        twip_lqr_update(&mut state, 0.0, y.as_ptr(), &r, later.as_mut_ptr());
    }
    assert_eq!(first, later);
}

#[test]
fn null_uninitialised_and_non_finite_inputs_get_codes_and_leave_u_alone() {
    let config = lqr_config();
    let y = [0.0f32; 4];
    let r = TwipSpeedRef::default();
    let mut u = [7.0f32];
    let mut state = new_lqr();
    unsafe {
        assert_eq!(twip_lqr_init(null_mut(), &config), TWIP_ERR_NULL);
        assert_eq!(twip_lqr_init(&mut state, null()), TWIP_ERR_NULL);
        assert_eq!(twip_lqr_update(&mut state, 0.0, y.as_ptr(), &r, u.as_mut_ptr()), TWIP_ERR_NOT_INITIALISED);
        assert_eq!(twip_lqr_reset(&mut state), TWIP_ERR_NOT_INITIALISED);
        assert_eq!(twip_lqr_init(&mut state, &config), TWIP_OK);
        assert_eq!(twip_lqr_update(&mut state, 0.0, null(), &r, u.as_mut_ptr()), TWIP_ERR_NULL);
        assert_eq!(twip_lqr_update(&mut state, 0.0, y.as_ptr(), null(), u.as_mut_ptr()), TWIP_ERR_NULL);
        assert_eq!(twip_lqr_update(&mut state, 0.0, y.as_ptr(), &r, null_mut()), TWIP_ERR_NULL);
        let bad_y = [0.0, f32::NAN, 0.0, 0.0];
        assert_eq!(twip_lqr_update(&mut state, 0.0, bad_y.as_ptr(), &r, u.as_mut_ptr()), TWIP_ERR_NOT_FINITE);
        let bad_r = TwipSpeedRef { theta: f32::INFINITY, theta_dot: 0.0 };
        assert_eq!(twip_lqr_update(&mut state, 0.0, y.as_ptr(), &bad_r, u.as_mut_ptr()), TWIP_ERR_NOT_FINITE);
        assert_eq!(twip_lqr_update(&mut state, f32::NAN, y.as_ptr(), &r, u.as_mut_ptr()), TWIP_ERR_NOT_FINITE);
        assert_eq!(u, [7.0], "a refused update writes nothing");
        // A state of another kind is not taken for this one.
        let mut pid = TwipPid { words: [0; TWIP_PID_WORDS] };
        pid.words[..TWIP_PID_WORDS].copy_from_slice(&state.words[..TWIP_PID_WORDS]);
        let y7 = [0.0f32; 7];
        let mut u2 = [0.0f32; 2];
        assert_eq!(
            twip_pid_update(&mut pid, 0.0, y7.as_ptr(), &TwipPlanarRef::default(), u2.as_mut_ptr()),
            TWIP_ERR_NOT_INITIALISED
        );
    }
}

#[test]
fn a_bad_configuration_is_refused_and_leaves_the_state_uninitialised() {
    let mut state = new_lqr();
    let good = lqr_config();
    unsafe {
        assert_eq!(twip_lqr_init(&mut state, &good), TWIP_OK);
        for bad in [
            TwipLqrConfig { period: 0.0, ..good },
            TwipLqrConfig { period: f32::NAN, ..good },
            TwipLqrConfig { gains: [f32::INFINITY, 0.0, 0.0, 0.0], ..good },
            TwipLqrConfig { robot: TwipRobot { m_body: -1.0, ..good.robot }, ..good },
            TwipLqrConfig { slope: 2.0, ..good },
        ] {
            assert_eq!(twip_lqr_init(&mut state, &bad), TWIP_ERR_INVALID, "{bad:?}");
            assert_eq!(twip_lqr_reset(&mut state), TWIP_ERR_NOT_INITIALISED);
        }
    }
    let mut fuzzy = TwipFuzzy { words: [0; TWIP_FUZZY_WORDS] };
    let mut sets = [[TwipMembership { kind: 1, p: [0.0, 0.1, 0.0, 0.0] }; TWIP_FUZZY_MAX_SETS]; 2];
    sets[1][2].kind = 5;
    let config = TwipFuzzyConfig { robot: good.robot, k1: 1.0, k2: 1.0, gamma: 0.02, sigma: 0.05, adapt: 1, sets, period: 0.005, ..Default::default() };
    assert_eq!(unsafe { twip_fuzzy_init(&mut fuzzy, &config) }, TWIP_ERR_INVALID);
}

#[test]
fn status_texts_are_c_strings() {
    for s in [TWIP_OK, TWIP_ERR_NULL, TWIP_ERR_INVALID, TWIP_ERR_NOT_FINITE, TWIP_ERR_NOT_INITIALISED, 42] {
        let text = unsafe { core::ffi::CStr::from_ptr(twip_status_text(s)) };
        assert!(!text.to_bytes().is_empty());
    }
}

/// A wheel turning at 3 counts per 5 ms loop reads the same speed wherever its 32-bit
/// counter is: near 0, past 2^24 counts (where an f32 count loses whole counts) and across
/// the counter's wrap from INT32_MAX to INT32_MIN (which an f32 difference read as -7.7e9 rad/s).
#[test]
fn the_encoder_speed_is_exact_at_any_count_and_across_the_wrap() {
    let core = Encoder::<f32>::new(700.0).unwrap();
    let truth = core.speed_of(3.0, 0.005);
    for start in [0i64, (1 << 24) + 1, (1 << 27) + 1, i32::MAX as i64 - 10] {
        let mut enc = TwipEncoder { words: [0; TWIP_ENCODER_WORDS] };
        assert_eq!(unsafe { twip_encoder_init(&mut enc, 700.0) }, TWIP_OK);
        for k in 0..8i64 {
            let count = (start + 3 * k) as u32 as i32; // the hardware's counter, wrapping
            let (mut angle, mut speed) = (0.0, 0.0);
            assert_eq!(unsafe { twip_encoder_read(&mut enc, count, 0.005, &mut angle, &mut speed) }, TWIP_OK);
            assert_eq!(speed, if k == 0 { 0.0 } else { truth }, "from {start}, read {k}");
            assert_eq!(angle, count as f32 * core.resolution());
        }
    }
}

#[test]
fn firmware_pieces_answer_as_the_core() {
    unsafe {
        let mut enc = TwipEncoder { words: [0; TWIP_ENCODER_WORDS] };
        assert_eq!(twip_encoder_init(&mut enc, 0.5), TWIP_ERR_INVALID);
        assert_eq!(twip_encoder_init(&mut enc, 700.0), TWIP_OK);
        let mut core = Encoder::<f32>::new(700.0).unwrap();
        let (mut a, mut s) = (0.0, 0.0);
        for (k, count) in [0, 3, 10, -4].into_iter().enumerate() {
            assert_eq!(twip_encoder_read(&mut enc, count, 0.005, &mut a, &mut s), TWIP_OK);
            assert_eq!((a, s), core.read_count(count as f32, 0.005), "read {k}");
        }
        assert_eq!(twip_encoder_read(&mut enc, 0, f32::NAN, &mut a, &mut s), TWIP_ERR_NOT_FINITE);
        (a, s) = (7.0, 7.0);
        assert_eq!(twip_encoder_read(&mut enc, 0, -0.005, &mut a, &mut s), TWIP_ERR_INVALID, "a negative dt is out of its domain");
        assert_eq!((a, s), (7.0, 7.0));

        let mut tilt = TwipTilt { words: [0; TWIP_TILT_WORDS] };
        let config = TwipTiltConfig { kind: 1, q_angle: 1e-3, q_bias: 3e-3, r_angle: 0.03, ..Default::default() };
        assert_eq!(twip_tilt_init(&mut tilt, &config), TWIP_OK);
        let mut core = TiltFilter::new(TiltEstimator::Kalman { q_angle: 1e-3, q_bias: 3e-3, r_angle: 0.03 }).unwrap();
        let (mut angle, mut rate) = (0.0, 0.0);
        for k in 0..20 {
            let (tilt_in, gyro) = (0.01 * k as f32, 0.2);
            assert_eq!(twip_tilt_update(&mut tilt, tilt_in, gyro, 0.005, &mut angle, &mut rate), TWIP_OK);
            assert_eq!((angle, rate), core.update(tilt_in, gyro, 0.005));
        }
        assert_eq!(twip_tilt_update(&mut tilt, 0.0, 0.0, f32::INFINITY, &mut angle, &mut rate), TWIP_ERR_NOT_FINITE);
        assert_eq!(twip_tilt_update(&mut tilt, 0.0, 0.0, -0.005, &mut angle, &mut rate), TWIP_ERR_INVALID);
        assert_eq!(twip_tilt_init(&mut tilt, &TwipTiltConfig { kind: 2, ..config }), TWIP_ERR_INVALID);

        let mut pwm = TwipPwm { words: [0; TWIP_PWM_WORDS] };
        let motor = TwipMotor { resistance: 1.714, k_t: 0.00992, gear_ratio: 43.7, friction: 0.0, supply: 9.1, pwm_max: 255.0 };
        assert_eq!(twip_pwm_init(&mut pwm, &TwipPwmConfig { motor, command_per_amp: 0.0 }), TWIP_ERR_INVALID);
        assert_eq!(twip_pwm_init(&mut pwm, &TwipPwmConfig { motor, command_per_amp: 2.0 }), TWIP_OK);
        let mut duty = 0.0;
        assert_eq!(twip_pwm_duty(&mut pwm, 1e6, 0.0, &mut duty), TWIP_OK);
        assert_eq!(duty, 255.0, "saturates at pwm_max");
        assert_eq!(twip_pwm_duty(&mut pwm, 0.2, 3.0, &mut duty), TWIP_OK);
        assert_eq!(duty, duty.round(), "whole counts");
        // Finite inputs whose volts overflow both ways (k_t gear_ratio > 1) made a NaN duty
        // with TWIP_OK, which a driver reads as full power: refused, the duty untouched.
        let geared = TwipMotor { gear_ratio: 437.0, ..motor };
        assert_eq!(twip_pwm_init(&mut pwm, &TwipPwmConfig { motor: geared, command_per_amp: 0.5 }), TWIP_OK);
        duty = 7.0;
        assert_eq!(twip_pwm_duty(&mut pwm, f32::MAX, -f32::MAX, &mut duty), TWIP_ERR_OVERFLOW);
        assert_eq!(duty, 7.0);
        assert_eq!(twip_pwm_duty(&mut pwm, f32::MAX, 0.0, &mut duty), TWIP_OK);
        assert_eq!(duty, 255.0, "one side overflowing saturates");
        assert!(twip_accel_tilt(0.0, 9.81).abs() < 1e-7);
    }
}

/// A tuned f64 value that f32 cannot hold is refused by name with the value given, not
/// as the f32 conversion's infinity or zero ("gains[0] = -inf is not finite").
#[test]
fn a_value_beyond_f32_is_named_with_its_f64_value() {
    let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
    let point = twip_core::control::lqr::DesignPoint::OperatingPoint;
    let huge = LqrController::new([-1e39, -1.7, -0.05, -0.045], model, point, 0.005).unwrap();
    let err = TwipLqrConfig::from_core(&huge).unwrap_err().to_string();
    assert!(err.starts_with("invalid gains[0] = -1e39: does not fit in f32"), "{err}");
    let tiny = LqrController::new([-11.0, -1.7, -0.05, -0.045], model, point, 1e-50).unwrap();
    let err = TwipLqrConfig::from_core(&tiny).unwrap_err().to_string();
    assert!(err.starts_with("invalid period = 1e-50: does not fit in f32"), "{err}");
}
