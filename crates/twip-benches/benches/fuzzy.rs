//! The fuzzy basis ξ of the thesis's 2 inputs × 3 sets (f64, f32), one control update of
//! the fuzzy adaptive controller with the thesis's 3 × 3 trapezoids and with a 5 × 5
//! Gaussian grid (f64, f32: docs/fuzzy_sets.md), and 10 s of flat-fuzzy (1 m at 180°/s,
//! hold, back) at dt = 1 ms with metrics, no log.
//! Run: cargo bench -p twip-benches --bench fuzzy
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Vector4;
use twip_core::control::fuzzy_basis::ThesisBasis;
use twip_core::control::fuzzy::FuzzyController;
use twip_core::control::fuzzy_grid::{FuzzyGrid, SetKind};
use twip_core::control::reference::SpeedRef;
use twip_core::control::Controller;
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

/// The 5 × 5 Gaussian grid of docs/fuzzy_sets.md.
fn gaussian_5x5<T: Real>() -> FuzzyGrid<T> {
    let t = |v: [f64; 5]| v.map(nalgebra::convert::<f64, T>);
    let (phi, rate) = (t([-0.3, -0.15, 0.0, 0.15, 0.3]), t([-2.0, -1.0, 0.0, 1.0, 2.0]));
    FuzzyGrid::regular(SetKind::Gaussian, [&phi, &rate], [&t([0.075; 5]), &t([0.5; 5])]).unwrap()
}

/// One update (ξ, the law, the weights' Euler step) at a state where φ and φ̇ sit between sets.
fn update<T: Real>(c: &mut Criterion, name: &str, basis: FuzzyGrid<T>) {
    let model = SlopeModel::<T>::new(RobotParams::balanbot(), T::zero()).unwrap();
    let ctrl = FuzzyController::thesis_flat(model, nalgebra::convert(0.005)).unwrap();
    let mut ctrl = FuzzyController::new(model, ctrl.gains(), ctrl.adaptation(), basis, ctrl.period()).unwrap();
    let y = Vector4::<T>::new(nalgebra::convert(0.15), nalgebra::convert(-1.0), T::zero(), T::zero());
    let r = SpeedRef { theta: T::zero(), theta_dot: nalgebra::convert(0.5) };
    c.bench_function(name, |b| b.iter(|| ctrl.update(T::zero(), black_box(&y), black_box(&r))));
}

fn updates(c: &mut Criterion) {
    update::<f64>(c, "fuzzy_update_3x3_trapezoid_f64", FuzzyGrid::default());
    update::<f64>(c, "fuzzy_update_5x5_gaussian_f64", gaussian_5x5());
    update::<f32>(c, "fuzzy_update_3x3_trapezoid_f32", FuzzyGrid::default());
    update::<f32>(c, "fuzzy_update_5x5_gaussian_f32", gaussian_5x5());
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

criterion_group!(benches, basis, updates, closed_loop);
criterion_main!(benches);
