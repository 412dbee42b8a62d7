//! One RK4 step of each model, f64 and f32, and a closed-loop LQR run.
//! Run: cargo bench -p twip-core --bench step
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{SVector, Vector4};
use twip_core::control::lqr::{design, DesignPoint, LqrController};
use twip_core::sim::metrics::SlopeMetrics;
use twip_core::control::reference::SpeedSchedule;
use twip_core::sim::runner::{simulate, SimConfig};
use twip_core::{rk4_step, PlanarModel, Real, RobotParams, SlopeModel};

fn slope_step<T: Real>(c: &mut Criterion, name: &str) {
    let m = SlopeModel::<T>::new(RobotParams::balanbot(), nalgebra::convert(0.1)).unwrap();
    let x = Vector4::<T>::from_fn(|i, _| nalgebra::convert(0.1 * (i as f64 + 1.0)));
    let u = SVector::<T, 1>::new(nalgebra::convert(0.2));
    let dt: T = nalgebra::convert(1e-3);
    c.bench_function(name, |b| b.iter(|| rk4_step(black_box(&m), black_box(&x), black_box(&u), dt)));
}

fn planar_step<T: Real>(c: &mut Criterion, name: &str) {
    let m = PlanarModel::<T>::new(RobotParams::balanbot()).unwrap();
    let x = SVector::<T, 7>::from_fn(|i, _| nalgebra::convert(0.1 * (i as f64 + 1.0)));
    let u = SVector::<T, 2>::new(nalgebra::convert(0.2), nalgebra::convert(-0.1));
    let dt: T = nalgebra::convert(1e-3);
    c.bench_function(name, |b| b.iter(|| rk4_step(black_box(&m), black_box(&x), black_box(&u), dt)));
}

fn steps(c: &mut Criterion) {
    slope_step::<f64>(c, "slope_rk4_step_f64");
    slope_step::<f32>(c, "slope_rk4_step_f32");
    planar_step::<f64>(c, "planar_rk4_step_f64");
    planar_step::<f32>(c, "planar_rk4_step_f32");
}

/// 10 s of flat-lqr at dt = 1 ms (10,000 closed-loop steps) with metrics, no log.
fn closed_loop(c: &mut Criterion) {
    let model = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.0).unwrap();
    let speed = 180f64.to_radians();
    let q = nalgebra::Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
    let d = design(&model, speed, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
    let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 0.005).unwrap();
    let schedule = SpeedSchedule::constant(speed).unwrap();
    let config = SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 };
    c.bench_function("flat_lqr_10s_closed_loop", |b| {
        b.iter(|| {
            let mut ctrl = ctrl;
            let mut metrics = SlopeMetrics::new(model);
            simulate(&model, &mut ctrl, &schedule, &Vector4::zeros(), &config, &mut metrics).unwrap()
        })
    });
}

criterion_group!(benches, steps, closed_loop);
criterion_main!(benches);
