//! Sweep throughput: the LQR lane kernel against the general per-sample runner, in
//! sample-steps per second (closed-loop 2-DOF + LQR, RK4 at 1 ms, 10 s per sample).
//! Run: cargo bench -p twip-core --features parallel --bench sweep
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::{Matrix4, Vector4};
use twip_core::lqr_control::{design, DesignPoint, LqrController};
use twip_core::reference::SpeedSchedule;
use twip_core::runner::SimConfig;
use twip_core::sweep::{draw, run_lqr_samples, run_slope_sample, Nominal, Perturbation, Spread, Target};
use twip_core::{RobotParams, SlopeModel};

fn setup() -> (LqrController<f64>, SpeedSchedule<f64>, SimConfig<f64>, Nominal, Vec<Perturbation>) {
    let params = RobotParams::balanbot();
    let model = SlopeModel::new(params, 0.0).unwrap();
    let speed = 180f64.to_radians();
    let q = Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
    let d = design(&model, speed, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
    let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 1e-3).unwrap();
    let perturb = vec![
        Perturbation { target: Target::Param(0), spread: Spread::Uniform { low: 0.66, high: 1.0 } },
        Perturbation { target: Target::Param(8), spread: Spread::Uniform { low: 0.04, high: 0.06 } },
    ];
    let nominal = Nominal { params, slope: 0.0, x0: Vector4::zeros() };
    (ctrl, SpeedSchedule::constant(speed).unwrap(), SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 }, nominal, perturb)
}

fn sweep(c: &mut Criterion) {
    let (ctrl, schedule, config, nominal, perturb) = setup();
    let samples = 64u64;
    let mut group = c.benchmark_group("sweep_flat_lqr_10s");
    group.sample_size(10);
    group.throughput(Throughput::Elements(samples * 10_000));
    group.bench_function("lanes_1_thread", |b| {
        b.iter(|| run_lqr_samples(&ctrl, &schedule, &config, &nominal, &perturb, 1, 0..black_box(samples), &|| false).unwrap())
    });
    group.bench_function("general_1_thread", |b| {
        b.iter(|| {
            (0..black_box(samples))
                .map(|i| run_slope_sample(&ctrl, &schedule, &config, &draw(&nominal, &perturb, 1, i), &|| false))
                .collect::<Vec<_>>()
        })
    });
    group.finish();
}

criterion_group!(benches, sweep);
criterion_main!(benches);
