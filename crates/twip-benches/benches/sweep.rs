//! Sweep throughput of each path, one thread, in sample-steps per second (RK4 at 1 ms):
//! the LQR lane kernel against the general per-sample runner (closed-loop 2-DOF + LQR,
//! 10 s per sample), the fuzzy family on lanes and on the general runner (the thesis's
//! flat gains, controller every 1 ms as the LQR's), the same samples through the thesis-like rig (realism), and the
//! 3-DOF PID tracker on its circle (4 s per sample) on the general runner and on lanes.
//! Run: cargo bench -p twip-benches --bench sweep
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::{Matrix4, Vector4};
use twip_core::control::fuzzy::FuzzyController;
use twip_core::control::lqr::{design, DesignPoint, LqrController};
use twip_core::control::reference::SpeedSchedule;
use twip_core::sim::runner::SimConfig;
use twip_core::hardware::motor::DcMotor;
use twip_core::control::pid::PidTracker;
use twip_core::hardware::realism::Realism;
use twip_core::sweep::planar::{self, PlanarNominal};
use twip_core::sweep::rig::{for_sweep, run_rig_sample};
use twip_core::sweep::block::{FuzzyLanes, PidLanes};
use twip_core::sweep::{draw, run_lane_samples, run_lqr_samples, run_slope_sample, Nominal, Perturbation, Spread, Target};
use twip_core::control::trajectory::{Circle, Direction};
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
    let fuzzy = FuzzyController::thesis_flat(*ctrl.model(), 1e-3).unwrap();
    let fuzzy_lanes = FuzzyLanes::new(&fuzzy);
    group.bench_function("fuzzy_lanes_1_thread", |b| {
        b.iter(|| run_lane_samples(&fuzzy_lanes, &schedule, &config, &nominal, &perturb, 1, 0..black_box(samples), &|| false).unwrap())
    });
    group.bench_function("fuzzy_general_1_thread", |b| {
        b.iter(|| {
            (0..black_box(samples))
                .map(|i| run_slope_sample(&fuzzy, &schedule, &config, &draw(&nominal, &perturb, 1, i), &|| false))
                .collect::<Vec<_>>()
        })
    });
    // The thesis-like robot runs its controller every 5 ms, one period late.
    let rig = for_sweep(&Realism::thesis_like(), 1);
    let ctrl_5ms = ctrl.with_period(5e-3).unwrap();
    group.bench_function("realism_1_thread", |b| {
        b.iter(|| {
            (0..black_box(samples))
                .map(|i| run_rig_sample(&ctrl_5ms, &schedule, &config, &draw(&nominal, &perturb, 1, i), &rig, &|| false))
                .collect::<Vec<_>>()
        })
    });
    group.finish();
}

fn sweep_planar(c: &mut Criterion) {
    let params = RobotParams::balanbot();
    let ctrl = PidTracker::table_4_1(&params, DcMotor::gb37y3530(), 0.005).unwrap();
    let circle = Circle::from_origin(0.6, core::f64::consts::PI * params.wheel_radius, Direction::CounterClockwise).unwrap();
    let config = SimConfig { dt: 1e-3, t_final: 4.0, fall_limit: 60f64.to_radians() };
    let nominal = PlanarNominal { params, x0: nalgebra::SVector::zeros() };
    let perturb = [Perturbation { target: Target::Param(0), spread: Spread::Uniform { low: 0.66, high: 1.0 } }];
    let samples = 16u64;
    let mut group = c.benchmark_group("sweep_circle_pid_4s");
    group.sample_size(10);
    group.throughput(Throughput::Elements(samples * 4_000));
    group.bench_function("planar_1_thread", |b| {
        b.iter(|| {
            (0..black_box(samples))
                .map(|i| planar::run_planar_sample(&ctrl, &circle, &config, &planar::draw(&nominal, &perturb, 1, i), 0.0, None, &|| false))
                .collect::<Vec<_>>()
        })
    });
    let lanes = PidLanes::new(&ctrl);
    group.bench_function("planar_lanes_1_thread", |b| {
        b.iter(|| planar::run_planar_lane_samples(&lanes, &circle, &config, &nominal, &perturb, 1, 0..black_box(samples), 0.0, &|| false, None).unwrap())
    });
    // Through the thesis-like rig: the general runner, and the planar rig's lane kernel.
    let rig = for_sweep(&Realism::thesis_like(), 1);
    group.bench_function("planar_realism_1_thread", |b| {
        b.iter(|| {
            (0..black_box(samples))
                .map(|i| planar::run_planar_sample(&ctrl, &circle, &config, &planar::draw(&nominal, &perturb, 1, i), 0.0, Some(&rig), &|| false))
                .collect::<Vec<_>>()
        })
    });
    group.bench_function("planar_realism_lanes_1_thread", |b| {
        b.iter(|| {
            let realism_of = |_: &RobotParams<f64>| Ok(rig);
            planar::run_planar_rig_lane_samples(&lanes, &circle, &config, &nominal, &perturb, 1, 0..black_box(samples), 0.0, &realism_of, &|| false, None).unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, sweep, sweep_planar);
criterion_main!(benches);
