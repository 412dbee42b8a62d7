//! `care` on the representative problem: the 2-DOF TWIP linearised upright (n = 4, m = 1,
//! one unstable mode and one integrator), Q = diag(10, 1, 1, 1), R = 1. Target ≤ 20 µs.
//!
//! `cargo bench -p twip-benches --bench care`
use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{DMatrix, Vector4};
use std::hint::black_box;
use twip_core::{care, lqr, RobotParams, SlopeModel};

fn problem() -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let model = SlopeModel::new(RobotParams::<f64>::balanbot(), 0.0).expect("default robot");
    let (a, b) = model.linearize(&Vector4::zeros(), 0.0);
    let a = DMatrix::from_fn(4, 4, |i, j| a[(i, j)]);
    let b = DMatrix::from_fn(4, 1, |i, _| b[i]);
    let q = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![10.0, 1.0, 1.0, 1.0]));
    let r = DMatrix::from_element(1, 1, 1.0);
    (a, b, q, r)
}

fn bench_care(c: &mut Criterion) {
    let (a, b, q, r) = problem();
    c.bench_function("care_twip_4x1", |bench| {
        bench.iter(|| care(black_box(&a), black_box(&b), black_box(&q), black_box(&r)).expect("solvable"))
    });
    c.bench_function("lqr_twip_4x1", |bench| {
        bench.iter(|| lqr(black_box(&a), black_box(&b), black_box(&q), black_box(&r)).expect("solvable"))
    });
}

criterion_group!(benches, bench_care);
criterion_main!(benches);
