//! The fuzzy basis ξ of the thesis's 2 inputs × 3 sets (f64, f32), and 10 s of flat-fuzzy
//! (1 m at 180°/s, hold, back) at dt = 1 ms with metrics, no log.
//! Run: cargo bench -p twip-core --bench fuzzy
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Vector4;
use twip_core::control::fuzzy_basis::ThesisBasis;
use twip_core::control::fuzzy::FuzzyController;
use twip_core::sim::metrics::SlopeMetrics;
use twip_core::control::reference::{Leg, SpeedSchedule};
use twip_core::sim::runner::{simulate, SimConfig};
use twip_core::{Real, RobotParams, SlopeModel};

fn xi<T: Real>(c: &mut Criterion, name: &str) {
    let basis = ThesisBasis::<T>::default();
    // φ on the Z–P ramp and φ̇ on the N–Z ramp: four rules fire, the costliest case.
    let x: [T; 2] = [nalgebra::convert(0.15), nalgebra::convert(-1.0)];
    c.bench_function(name, |b| b.iter(|| black_box(&basis).eval(black_box(&x))));
}

fn basis(c: &mut Criterion) {
    xi::<f64>(c, "fuzzy_xi_2x3_f64");
    xi::<f32>(c, "fuzzy_xi_2x3_f32");
}

fn closed_loop(c: &mut Criterion) {
    let params = RobotParams::<f64>::balanbot();
    let model = SlopeModel::new(params, 0.0).unwrap();
    let ctrl = FuzzyController::thesis_flat(model, 0.005).unwrap();
    let speed = 180f64.to_radians();
    let goal = 1.0 / params.wheel_radius;
    let schedule = SpeedSchedule::new(&[Leg { goal, speed, hold: 5.0 }, Leg { goal: 0.0, speed, hold: 5.0 }]).unwrap();
    let config = SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 };
    c.bench_function("flat_fuzzy_10s_closed_loop", |b| {
        b.iter(|| {
            let mut ctrl = ctrl;
            let mut metrics = SlopeMetrics::new(model);
            simulate(&model, &mut ctrl, &schedule, &Vector4::zeros(), &config, &mut metrics).unwrap()
        })
    });
}

criterion_group!(benches, basis, closed_loop);
criterion_main!(benches);
