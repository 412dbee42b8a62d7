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
