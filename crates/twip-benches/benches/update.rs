//! One update through the C ABI beside the same f32 core controller called from Rust: the
//! ABI's price (finiteness checks, tag check, copies) is the difference.
//! Run: cargo bench -p twip-benches --bench update
//! The fuzzy controller and the sliding-mode tracker run with the thesis's 3 × 3 trapezoids
//! and with docs/fuzzy_sets.md's 5 × 5 Gaussian grids, side by side (the grids' cost ratio).
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use twip_core::control::fuzzy::FuzzyController;
use twip_core::control::fuzzy_grid::{FuzzyGrid, SetKind};
use twip_core::control::lqr::{DesignPoint, LqrController};
use twip_core::control::pid::PidTracker;
use twip_core::control::reference::SpeedRef;
use twip_core::control::smc::{Adaptation, SmcGains, SmcOptions, SmcTracker};
use twip_core::control::trajectory::{Circle, Direction, PlanarRef};
use twip_core::control::{Controller, Reference};
use twip_core::hardware::motor::DcMotor;
use twip_core::{PlanarModel, RobotParams, SlopeModel};
use twip_ffi::*;

const PERIOD: f32 = 0.005;
const Y2: [f32; 4] = [0.02, 0.1, 0.3, 0.05];
const Y3: [f32; 7] = [0.02, 0.01, 0.1, 0.03, -0.1, 0.1, 0.2];

fn slope() -> SlopeModel<f64> {
    SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap()
}

fn smc() -> SmcTracker<f64> {
    let model = PlanarModel::new(RobotParams::balanbot()).unwrap();
    let motor = DcMotor::gb37y3530();
    let gains = SmcGains::thesis(motor.torque_per_count());
    SmcTracker::new(gains, SmcOptions::default(), model, Some(motor), Some(Adaptation::default()), PERIOD as f64).unwrap()
}

/// [`smc`] with the fuzzy-sets study's 5 × 5 Gaussian grids (σ half the spacing).
fn smc_gaussian_5x5() -> SmcTracker<f64> {
    let (phi, omega, rate) = ([-0.3, -0.15, 0.0, 0.15, 0.3], [-1.0, -0.5, 0.0, 0.5, 1.0], [-2.0, -1.0, 0.0, 1.0, 2.0]);
    let yaw = FuzzyGrid::regular(SetKind::Gaussian, [&phi, &omega], [&[0.075; 5], &[0.25; 5]]).unwrap();
    let pitch = FuzzyGrid::regular(SetKind::Gaussian, [&phi, &rate], [&[0.075; 5], &[0.5; 5]]).unwrap();
    smc().with_bases(yaw, pitch).unwrap()
}

fn planar_ref() -> (TwipPlanarRef, PlanarRef<f32>) {
    let circle = Circle::from_origin(0.45f32, core::f32::consts::PI / 30.0, Direction::CounterClockwise).unwrap();
    let r = circle.sample(3.0);
    let c = TwipPlanarRef { x: r.x, y: r.y, psi: r.psi, v: r.v, omega: r.omega, v_dot: r.v_dot, omega_dot: r.omega_dot };
    (c, r)
}

fn slope_family(c: &mut Criterion) {
    let gains = [-11.0091734, -1.69875395, -0.0500031523, -0.0456435457];
    let lqr = LqrController::new(gains, slope(), DesignPoint::OperatingPoint, PERIOD as f64).unwrap();
    let fuzzy = FuzzyController::thesis_flat(slope(), PERIOD as f64).unwrap();
    let (lqr_config, fuzzy_config) = (TwipLqrConfig::from_core(&lqr).unwrap(), TwipFuzzyConfig::from_core(&fuzzy).unwrap());
    let (mut lqr, mut fuzzy) = (lqr_config.build().unwrap(), fuzzy_config.build().unwrap());
    let core_ref = SpeedRef { theta: 0.0, theta_dot: 0.5 };
    let c_ref = TwipSpeedRef { theta: 0.0, theta_dot: 0.5 };
    let y = Y2.into();
    let mut u = [0.0f32];

    let mut state = TwipLqr { words: [0; TWIP_LQR_WORDS] };
    assert_eq!(unsafe { twip_lqr_init(&mut state, &lqr_config) }, TWIP_OK);
    c.bench_function("core_lqr_update_f32", |b| b.iter(|| lqr.update(0.0, black_box(&y), black_box(&core_ref))));
    c.bench_function("twip_lqr_update", |b| {
        b.iter(|| unsafe { twip_lqr_update(&mut state, 0.0, black_box(Y2.as_ptr()), black_box(&c_ref), u.as_mut_ptr()) })
    });

    let mut state = TwipFuzzy { words: [0; TWIP_FUZZY_WORDS] };
    assert_eq!(unsafe { twip_fuzzy_init(&mut state, &fuzzy_config) }, TWIP_OK);
    c.bench_function("core_fuzzy_update_f32", |b| b.iter(|| fuzzy.update(0.0, black_box(&y), black_box(&core_ref))));
    c.bench_function("twip_fuzzy_update", |b| {
        b.iter(|| unsafe { twip_fuzzy_update(&mut state, 0.0, black_box(Y2.as_ptr()), black_box(&c_ref), u.as_mut_ptr()) })
    });

    // The 5 × 5 Gaussian grid of docs/fuzzy_sets.md, the same way.
    let (phi, rate) = ([-0.3, -0.15, 0.0, 0.15, 0.3], [-2.0, -1.0, 0.0, 1.0, 2.0]);
    let grid = FuzzyGrid::regular(SetKind::Gaussian, [&phi, &rate], [&[0.075; 5], &[0.5; 5]]).unwrap();
    let g = FuzzyController::thesis_flat(slope(), PERIOD as f64).unwrap();
    let gaussian = FuzzyController::new(*g.model(), g.gains(), g.adaptation(), grid, g.period()).unwrap();
    let gaussian_config = TwipFuzzyConfig::from_core(&gaussian).unwrap();
    let mut gaussian = gaussian_config.build().unwrap();
    let mut state = TwipFuzzy { words: [0; TWIP_FUZZY_WORDS] };
    assert_eq!(unsafe { twip_fuzzy_init(&mut state, &gaussian_config) }, TWIP_OK);
    c.bench_function("core_fuzzy_5x5_gaussian_update_f32", |b| b.iter(|| gaussian.update(0.0, black_box(&y), black_box(&core_ref))));
    c.bench_function("twip_fuzzy_5x5_gaussian_update", |b| {
        b.iter(|| unsafe { twip_fuzzy_update(&mut state, 0.0, black_box(Y2.as_ptr()), black_box(&c_ref), u.as_mut_ptr()) })
    });
}

fn planar_family(c: &mut Criterion) {
    let (c_ref, core_ref) = planar_ref();
    let y = Y3.into();
    let mut u = [0.0f32; 2];
    let pid = PidTracker::table_4_1(&RobotParams::balanbot(), DcMotor::gb37y3530(), PERIOD as f64).unwrap();
    let (pid_config, smc_config) = (TwipPidConfig::from_core(&pid).unwrap(), TwipSmcConfig::from_core(&smc()).unwrap());
    let (mut pid, mut smc) = (pid_config.build().unwrap(), smc_config.build().unwrap());

    let mut state = TwipPid { words: [0; TWIP_PID_WORDS] };
    assert_eq!(unsafe { twip_pid_init(&mut state, &pid_config) }, TWIP_OK);
    c.bench_function("core_pid_update_f32", |b| b.iter(|| pid.update(0.0, black_box(&y), black_box(&core_ref))));
    c.bench_function("twip_pid_update", |b| {
        b.iter(|| unsafe { twip_pid_update(&mut state, 0.0, black_box(Y3.as_ptr()), black_box(&c_ref), u.as_mut_ptr()) })
    });

    let mut state = TwipSmc { words: [0; TWIP_SMC_WORDS] };
    assert_eq!(unsafe { twip_smc_init(&mut state, &smc_config) }, TWIP_OK);
    c.bench_function("core_smc_fuzzy_update_f32", |b| b.iter(|| smc.update(0.0, black_box(&y), black_box(&core_ref))));
    c.bench_function("twip_smc_update", |b| {
        b.iter(|| unsafe { twip_smc_update(&mut state, 0.0, black_box(Y3.as_ptr()), black_box(&c_ref), u.as_mut_ptr()) })
    });

    let gaussian_config = TwipSmcConfig::from_core(&smc_gaussian_5x5()).unwrap();
    let mut gaussian = gaussian_config.build().unwrap();
    let mut state = TwipSmc { words: [0; TWIP_SMC_WORDS] };
    assert_eq!(unsafe { twip_smc_init(&mut state, &gaussian_config) }, TWIP_OK);
    c.bench_function("core_smc_5x5_gaussian_update_f32", |b| b.iter(|| gaussian.update(0.0, black_box(&y), black_box(&core_ref))));
    c.bench_function("twip_smc_5x5_gaussian_update", |b| {
        b.iter(|| unsafe { twip_smc_update(&mut state, 0.0, black_box(Y3.as_ptr()), black_box(&c_ref), u.as_mut_ptr()) })
    });
}

criterion_group!(benches, slope_family, planar_family);
criterion_main!(benches);
