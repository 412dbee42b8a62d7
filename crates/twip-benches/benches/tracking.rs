//! Trajectory tracking on the 3-DOF model: one update of each tracker, and 60 s of
//! circle-smc-fuzzy (r = 0.45 m, v = π/30 m/s) at dt = 1 ms with the tracking metrics, no log.
//! Run: cargo bench -p twip-benches --bench tracking
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::SVector;
use twip_core::control::{Controller, Reference};
use twip_core::hardware::motor::DcMotor;
use twip_core::control::pid::PidTracker;
use twip_core::sim::runner::{simulate, SimConfig};
use twip_core::control::smc::{Adaptation, SmcGains, SmcOptions, SmcTracker};
use twip_core::sim::tracking_metrics::TrackingMetrics;
use twip_core::control::trajectory::{Circle, Direction};
use twip_core::{PlanarModel, RobotParams};

fn smc(fuzzy: bool) -> SmcTracker<f64> {
    let model = PlanarModel::new(RobotParams::balanbot()).unwrap();
    let motor = DcMotor::gb37y3530();
    let adaptation = fuzzy.then(Adaptation::default);
    SmcTracker::new(SmcGains::thesis(motor.torque_per_count()), SmcOptions::default(), model, Some(motor), adaptation, 0.005)
        .unwrap()
}

fn updates(c: &mut Criterion) {
    let circle = Circle::from_origin(0.45, core::f64::consts::PI / 30.0, Direction::CounterClockwise).unwrap();
    let r = circle.sample(3.0);
    let y = SVector::<f64, 7>::from([0.02, 0.01, 0.1, 0.03, -0.1, 0.1, 0.2]);
    let mut pid = PidTracker::table_4_1(&RobotParams::balanbot(), DcMotor::gb37y3530(), 0.005).unwrap();
    c.bench_function("pid_tracker_update", |b| b.iter(|| pid.update(0.0, black_box(&y), black_box(&r))));
    for (name, fuzzy) in [("smc_tracker_update", false), ("smc_fuzzy_tracker_update", true)] {
        let mut t = smc(fuzzy);
        c.bench_function(name, |b| b.iter(|| t.update(0.0, black_box(&y), black_box(&r))));
    }
}

fn closed_loop(c: &mut Criterion) {
    let plant = PlanarModel::new(RobotParams::<f64>::balanbot()).unwrap();
    let circle = Circle::from_origin(0.45, core::f64::consts::PI / 30.0, Direction::CounterClockwise).unwrap();
    let ctrl = smc(true);
    let config = SimConfig { dt: 1e-3, t_final: 60.0, fall_limit: 1.0 };
    c.bench_function("circle_smc_fuzzy_60s_closed_loop", |b| {
        b.iter(|| {
            let mut ctrl = ctrl;
            let mut metrics = TrackingMetrics::new(circle, circle.period());
            simulate(&plant, &mut ctrl, &circle, &SVector::zeros(), &config, &mut metrics).unwrap()
        })
    });
}

/// The same 60 000 RK4 steps of the plant alone (held zero input): what the loop costs
/// before any tracker, reference or metric.
fn plant_alone(c: &mut Criterion) {
    let plant = PlanarModel::new(RobotParams::<f64>::balanbot()).unwrap();
    let u = SVector::<f64, 2>::zeros();
    c.bench_function("planar_60s_rk4_plant_only", |b| {
        b.iter(|| {
            let mut x = SVector::<f64, 7>::zeros();
            for _ in 0..60_000 {
                x = twip_core::rk4_step(&plant, black_box(&x), &u, 1e-3);
            }
            x
        })
    });
}

criterion_group!(benches, updates, closed_loop, plant_alone);
criterion_main!(benches);
