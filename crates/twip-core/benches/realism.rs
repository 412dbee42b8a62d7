//! Closed-loop cost of the real robot in the loop against the ideal loop, side by side:
//! 10 s of flat-lqr at dt = 1 ms (10,000 steps, 5 ms controller) with metrics, no log.
//! "all on": MPU-6050 with noise and DLPF, complementary filter, 700 CPR encoder, PWM
//! motor driver with inductance, one-period delay, a push, a constant force and a slope
//! change. Run: cargo bench -p twip-core --bench realism
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Vector4;
use twip_core::hardware::disturbance::{Force, Push, Pushes, SlopeProfile};
use twip_core::control::lqr::{design, DesignPoint, LqrController};
use twip_core::sim::metrics::SlopeMetrics;
use twip_core::hardware::realism::{simulate_rig, Realism};
use twip_core::control::reference::SpeedSchedule;
use twip_core::sim::runner::{simulate, Loop, SimConfig};
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
    group.bench_function("all_on", |b| {
        b.iter(|| {
            let mut ctrl = ctrl;
            let mut metrics = SlopeMetrics::new(model);
            let mut rig = black_box(&realism).build(&model, config.dt).unwrap();
            let parts = Loop {
                sensor: &mut rig.sensors,
                actuator: &mut rig.actuator,
                observer: &mut metrics,
                should_stop: || false,
                delay_one_period: rig.delay,
            };
            simulate_rig(&mut rig.plant, &mut ctrl, &schedule, &Vector4::zeros(), &config, parts).unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, closed_loop);
criterion_main!(benches);
