//! Closed-loop cost of the real robot in the loop against the ideal loop, side by side:
//! 10 s of flat-lqr at dt = 1 ms (10,000 steps, 5 ms controller) with metrics, no log.
//! "all on": MPU-6050 with noise and DLPF, complementary filter, 700 CPR encoder, PWM
//! motor driver with inductance, one-period delay, the gearheads' friction (stick band)
//! and backlash, a push, a constant force and a slope change; then the same with only the
//! friction, only the backlash, and neither. Then what the IMU's noise costs: a batch of
//! `NOISE_BATCH` normals as an IMU draws them, on one stream and on a sweep's 16 lanes side
//! by side, against the SFC64 words that they take at least (half as many: two normals a
//! word; the ziggurat's rare wedges and tail take more), and as many Philox words (the
//! noise's words before SFC64).
//! Run: cargo bench -p twip-benches --bench realism
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Vector4;
use twip_core::hardware::disturbance::{Force, Push, Pushes, SlopeProfile};
use twip_core::control::lqr::{design, DesignPoint, LqrController};
use twip_core::sim::metrics::SlopeMetrics;
use twip_core::hardware::imu::NOISE_BATCH;
use twip_core::hardware::realism::{simulate_rig, Realism};
use twip_core::rng::{Philox, Sfc64, Ziggurat};
use twip_core::sweep::lanes::LANES;
use twip_core::control::reference::SpeedSchedule;
use twip_core::sim::runner::{simulate, Loop, Outcome, SimConfig};
use twip_core::{RobotParams, SlopeModel};

fn closed_loop(c: &mut Criterion) {
    let model = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.0).unwrap();
    let speed = 180f64.to_radians();
    let q = nalgebra::Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
    let d = design(&model, speed, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
    let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 0.005).unwrap();
    let schedule = SpeedSchedule::constant(speed).unwrap();
    let config = SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 };
    let realism = Realism {
        pushes: Pushes::new(&[Push { t: 3.0, impulse: 0.05, height: 0.1 }]).unwrap(),
        force: Force { horizontal: 0.2, vertical: 0.0, height: 0.1 },
        slope_profile: SlopeProfile::new(0.0, &[(1.0, 0.05)]).unwrap(),
        ..Realism::thesis_like()
    };
    let mut group = c.benchmark_group("flat_lqr_10s");
    group.bench_function("ideal", |b| {
        b.iter(|| {
            let mut ctrl = ctrl;
            let mut metrics = SlopeMetrics::new(model);
            simulate(black_box(&model), &mut ctrl, &schedule, &Vector4::zeros(), &config, &mut metrics).unwrap()
        })
    });
    let variants = [
        ("all_on", realism),
        ("friction_only", Realism { backlash: None, ..realism }),
        ("backlash_only", Realism { friction: None, ..realism }),
        ("no_gearheads", Realism { friction: None, backlash: None, ..realism }),
    ];
    let run = |realism: &Realism<f64>| {
        let mut ctrl = ctrl;
        let mut metrics = SlopeMetrics::new(model);
        let mut rig = realism.build(&model, config.dt).unwrap();
        let parts = Loop {
            sensor: &mut rig.sensors,
            actuator: &mut rig.actuator,
            observer: &mut metrics,
            should_stop: || false,
            delay_one_period: rig.delay,
        };
        simulate_rig(&mut rig.plant, &mut ctrl, &schedule, &Vector4::zeros(), &config, parts).unwrap()
    };
    for (name, realism) in variants {
        // The same work on both sides: each run goes the whole 10 s.
        assert_eq!(run(&realism), (Outcome::Completed, 10_000), "{name}");
        group.bench_function(name, |b| b.iter(|| run(black_box(&realism))));
    }
    group.finish();
}

fn imu_normals(c: &mut Criterion) {
    let mut group = c.benchmark_group("imu_normals");
    let gauss = Ziggurat::new();
    let mut rng = Sfc64::new(1, 2);
    let mut batch = [0.0; NOISE_BATCH];
    group.bench_function(format!("ziggurat_{NOISE_BATCH}"), |b| {
        b.iter(|| {
            gauss.fill(&mut rng, NOISE_BATCH / 2, |n, [v]| batch[n] = v);
            black_box(&batch);
        })
    });
    let mut lanes = Sfc64::<LANES>::lanes(core::array::from_fn(|l| Sfc64::new(1, l as u64)));
    let mut rows = [[0.0; LANES]; NOISE_BATCH];
    group.bench_function(format!("ziggurat_{NOISE_BATCH}_on_{LANES}_lanes"), |b| {
        b.iter(|| {
            gauss.fill(&mut lanes, NOISE_BATCH / 2, |n, row| rows[n] = row);
            black_box(&rows);
        })
    });
    let mut words = [0u64; NOISE_BATCH / 2];
    group.bench_function(format!("sfc64_{}_words", NOISE_BATCH / 2), |b| {
        b.iter(|| {
            for w in words.iter_mut() {
                *w = rng.next_u64();
            }
            black_box(&words);
        })
    });
    let mut philox = Philox::new(1, 2);
    group.bench_function(format!("philox_{}_words", NOISE_BATCH / 2), |b| {
        b.iter(|| {
            for w in words.iter_mut() {
                *w = philox.next_u64();
            }
            black_box(&words);
        })
    });
    group.finish();
}

criterion_group!(benches, closed_loop, imu_normals);
criterion_main!(benches);
