//! One absurd but finite reading (a sensor glitch) must not poison a controller: an update
//! whose command or carried state (integrator, adaptive weights) would overflow is refused
//! with TWIP_ERR_OVERFLOW and leaves the state as it was, so the following updates answer
//! exactly what they would have answered without the glitch.
use twip_core::control::lqr::{DesignPoint, LqrController};
use twip_core::control::pid::PidTracker;
use twip_core::control::smc::{Adaptation, SmcGains, SmcOptions, SmcTracker};
use twip_core::hardware::motor::DcMotor;
use twip_core::{PlanarModel, RobotParams, SlopeModel};
use twip_ffi::*;

const PERIOD: f32 = 0.005;

fn lqr_config() -> TwipLqrConfig {
    let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
    let gains = [-11.0091734, -1.69875395, -0.0500031523, -0.0456435457];
    TwipLqrConfig::from_core(&LqrController::new(gains, model, DesignPoint::OperatingPoint, PERIOD as f64).unwrap()).unwrap()
}

fn smc_config(motor: bool) -> TwipSmcConfig {
    let model = PlanarModel::new(RobotParams::balanbot()).unwrap();
    let gb37 = DcMotor::gb37y3530();
    let gains = SmcGains::thesis(gb37.torque_per_count());
    let smc = SmcTracker::new(gains, SmcOptions::default(), model, motor.then_some(gb37), Some(Adaptation::default()), PERIOD as f64);
    TwipSmcConfig::from_core(&smc.unwrap()).unwrap()
}

/// `updates` ordinary updates through `update`, with `glitch` (a measurement) slipped in
/// before the second; the statuses and commands of the ordinary ones, and the glitch's status.
fn run<S, R: Copy, const NX: usize, const NU: usize>(
    state: &mut S,
    update: unsafe extern "C" fn(*mut S, f32, *const f32, *const R, *mut f32) -> TwipStatus,
    reference: R,
    ordinary: [f32; NX],
    glitch: Option<[f32; NX]>,
) -> (Vec<(TwipStatus, [f32; NU])>, Option<TwipStatus>) {
    let mut out = Vec::new();
    let mut glitch_status = None;
    for k in 0..400 {
        let t = k as f32 * PERIOD;
        if let (1, Some(y)) = (k, glitch) {
            let mut u = [123.0f32; NU];
            glitch_status = Some(unsafe { update(state, t, y.as_ptr(), &reference, u.as_mut_ptr()) });
            assert_eq!(u, [123.0; NU], "a refused update writes no command");
        }
        let mut u = [0.0f32; NU];
        let status = unsafe { update(state, t, ordinary.as_ptr(), &reference, u.as_mut_ptr()) };
        out.push((status, u));
    }
    (out, glitch_status)
}

#[test]
fn a_huge_pitch_reading_leaves_the_sliding_mode_tracker_as_it_was() {
    let ordinary = [0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0];
    for motor in [true, false] {
        let config = smc_config(motor);
        let mut clean = TwipSmc { words: [0; TWIP_SMC_WORDS] };
        assert_eq!(unsafe { twip_smc_init(&mut clean, &config) }, TWIP_OK);
        let (expected, _) = run::<_, _, 7, 2>(&mut clean, twip_smc_update, TwipPlanarRef::default(), ordinary, None);
        // Near f32's limit: the law overflows. A pitch of 1e12-1e30 rad overflows nothing
        // (sin and cos reduce it exactly) and is taken as it is (docs/firmware.md).
        for pitch in [3e38f32, f32::MAX] {
            let mut state = TwipSmc { words: [0; TWIP_SMC_WORDS] };
            assert_eq!(unsafe { twip_smc_init(&mut state, &config) }, TWIP_OK);
            let mut glitch = ordinary;
            glitch[3] = pitch;
            let (got, status) = run::<_, _, 7, 2>(&mut state, twip_smc_update, TwipPlanarRef::default(), ordinary, Some(glitch));
            assert_eq!(status, Some(TWIP_ERR_OVERFLOW), "motor {motor}, pitch {pitch:e}");
            assert_eq!(got, expected, "motor {motor}, pitch {pitch:e}: the later updates are as without the glitch");
            assert!(got.iter().all(|(s, u)| *s == TWIP_OK && u.iter().all(|v| v.is_finite())));
        }
    }
}

#[test]
fn a_huge_wheel_speed_leaves_the_lqr_integrator_as_it_was() {
    let config = lqr_config();
    let reference = TwipSpeedRef::default();
    let ordinary = [0.01, 0.0, 0.0, 0.0];
    let mut clean = TwipLqr { words: [0; TWIP_LQR_WORDS] };
    assert_eq!(unsafe { twip_lqr_init(&mut clean, &config) }, TWIP_OK);
    let (expected, _) = run::<_, _, 4, 1>(&mut clean, twip_lqr_update, reference, ordinary, None);
    let mut state = TwipLqr { words: [0; TWIP_LQR_WORDS] };
    assert_eq!(unsafe { twip_lqr_init(&mut state, &config) }, TWIP_OK);
    // A garbled frame: the command overflows to an infinity while the integrator takes
    // θ̇ T = 1.5e36, finite; kept, it would hold u near 6.8e34 A for ever after.
    let glitch = [3e38, 3e38, 0.0, 3e38];
    let (got, status) = run::<_, _, 4, 1>(&mut state, twip_lqr_update, reference, ordinary, Some(glitch));
    assert_eq!(status, Some(TWIP_ERR_OVERFLOW));
    assert_eq!(got, expected);
}

#[test]
fn a_pid_integrator_that_would_overflow_is_refused() {
    let pid = PidTracker::table_4_1(&RobotParams::balanbot(), DcMotor::gb37y3530(), PERIOD as f64).unwrap();
    let config = TwipPidConfig::from_core(&pid).unwrap();
    let ordinary = [0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0];
    let mut clean = TwipPid { words: [0; TWIP_PID_WORDS] };
    assert_eq!(unsafe { twip_pid_init(&mut clean, &config) }, TWIP_OK);
    let (expected, _) = run::<_, _, 7, 2>(&mut clean, twip_pid_update, TwipPlanarRef::default(), ordinary, None);
    let mut state = TwipPid { words: [0; TWIP_PID_WORDS] };
    assert_eq!(unsafe { twip_pid_init(&mut state, &config) }, TWIP_OK);
    // A speed of 3e38 m/s: the speed error's integral overflows; the PWM saturation alone
    // would have hidden it in the command.
    let (got, status) = run::<_, _, 7, 2>(&mut state, twip_pid_update, TwipPlanarRef::default(), ordinary, Some([0.0, 0.0, 0.0, 0.01, 0.0, 3e38, 0.0]));
    assert_eq!(status, Some(TWIP_ERR_OVERFLOW));
    assert_eq!(got, expected);
}

#[test]
fn the_overflow_code_has_its_text() {
    let text = unsafe { core::ffi::CStr::from_ptr(twip_status_text(TWIP_ERR_OVERFLOW)) };
    assert!(text.to_str().unwrap().contains("unchanged"), "{text:?}");
}

/// 300 ordinary tilt updates, with each of `glitches` (tilt, gyro, dt) tried after the
/// first: each must be refused with the state's words unchanged and no output written.
fn tilt_run(config: &TwipTiltConfig, glitches: &[(f32, f32, f32)]) -> Vec<(f32, f32)> {
    let mut state = TwipTilt { words: [0; TWIP_TILT_WORDS] };
    assert_eq!(unsafe { twip_tilt_init(&mut state, config) }, TWIP_OK);
    let mut out = Vec::new();
    for k in 0..300 {
        if k == 1 {
            for &(tilt, gyro, dt) in glitches {
                let before = state.words;
                let (mut a, mut r) = (123.0f32, 123.0f32);
                let status = unsafe { twip_tilt_update(&mut state, tilt, gyro, dt, &mut a, &mut r) };
                assert_eq!(status, TWIP_ERR_OVERFLOW, "kind {}, glitch {tilt:e} {gyro:e} {dt:e}", config.kind);
                assert_eq!(state.words, before, "the state is as before, bit for bit");
                assert_eq!((a, r), (123.0, 123.0), "a refused update writes no output");
            }
        }
        let (mut a, mut r) = (0.0f32, 0.0f32);
        assert_eq!(unsafe { twip_tilt_update(&mut state, 0.05, 0.01, PERIOD, &mut a, &mut r) }, TWIP_OK);
        out.push((a, r));
    }
    out
}

#[test]
fn a_tilt_update_that_would_overflow_is_refused() {
    let complementary = TwipTiltConfig { kind: 0, time_constant: 1.0, ..Default::default() };
    let kalman = TwipTiltConfig { kind: 1, q_angle: 1e-3, q_bias: 3e-3, r_angle: 3e-2, ..Default::default() };
    // A gyro glitch of 3e38 over dt = 2 s takes the angle to ±inf (one of 1 s gives a
    // finite 1.5e38, taken as it is, and the next such glitch the infinity); a huge dt
    // makes the Kalman covariance (dt² p11) overflow.
    let glitches = [(0.05, 3e38, 2.0), (0.05, -3e38, 2.0), (0.05, 0.0, 1e20), (0.05, f32::MAX, 1e15)];
    for config in [complementary, kalman] {
        let expected = tilt_run(&config, &[]);
        assert!(expected.iter().all(|(a, r)| a.is_finite() && r.is_finite()));
        let glitches: &[_] = if config.kind == 0 { &glitches[..2] } else { &glitches };
        assert_eq!(tilt_run(&config, glitches), expected, "kind {}: the later updates are as without the glitch", config.kind);
    }
}

#[test]
fn an_encoder_speed_that_would_overflow_is_refused() {
    let read = |glitch: bool| {
        let mut enc = TwipEncoder { words: [0; TWIP_ENCODER_WORDS] };
        assert_eq!(unsafe { twip_encoder_init(&mut enc, 700.0) }, TWIP_OK);
        let mut out = Vec::new();
        for k in 0..10 {
            if glitch && k == 2 {
                // A subnormal dt: 1000 counts over 1e-40 s is an infinite speed.
                let before = enc.words;
                let (mut a, mut s) = (123.0f32, 123.0f32);
                assert_eq!(unsafe { twip_encoder_read(&mut enc, 1000, 1e-40, &mut a, &mut s) }, TWIP_ERR_OVERFLOW);
                assert_eq!(enc.words, before, "the last count is kept, bit for bit");
                assert_eq!((a, s), (123.0, 123.0), "a refused read writes no output");
            }
            let (mut a, mut s) = (0.0f32, 0.0f32);
            assert_eq!(unsafe { twip_encoder_read(&mut enc, 7 * k, PERIOD, &mut a, &mut s) }, TWIP_OK);
            out.push((a, s));
        }
        out
    };
    assert_eq!(read(true), read(false));
}
