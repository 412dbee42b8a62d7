//! DARE, dlqr, Stein and c2d tests: closed forms, singular R, error paths.
use super::*;
use crate::control::c2d::{c2d, expm};
use crate::control::care::schur::schur;
use nalgebra::DMatrix;

fn m(rows: usize, cols: usize, data: &[f64]) -> DMatrix<f64> {
    DMatrix::from_row_slice(rows, cols, data)
}

fn residual(a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, r: &DMatrix<f64>, x: &DMatrix<f64>) -> f64 {
    let xa = x * a;
    let xb = x * b;
    let k = (r + b.transpose() * &xb).lu().solve(&(xb.transpose() * a)).unwrap();
    (a.transpose() * &xa - x - a.transpose() * &xb * k + q).amax()
}

#[test]
fn scalar_closed_form() {
    // b² x² + (r (1 − a²) − q b²) x − q r = 0, the positive root.
    for &(a, b, q, r) in &[(1.0, 1.0, 1.0, 1.0), (0.5, 2.0, 3.0, 0.1), (2.0, 1.0, 1e-9, 1.0), (-3.0, 0.1, 10.0, 1e3), (0.0, 1.0, 1.0, 1.0)] {
        let x = dare(&m(1, 1, &[a]), &m(1, 1, &[b]), &m(1, 1, &[q]), &m(1, 1, &[r])).unwrap()[(0, 0)];
        let p: f64 = r * (1.0 - a * a) - q * b * b;
        let disc = (p * p + 4.0 * b * b * q * r).sqrt();
        // Cancellation-free root.
        let exact = if p < 0.0 { (disc - p) / (2.0 * b * b) } else { 2.0 * q * r / (p + disc) };
        assert!((x - exact).abs() <= 1e-12 * exact.abs(), "{a} {b} {q} {r}: {x} vs {exact}");
    }
}

#[test]
fn dlqr_of_a_discretised_double_integrator() {
    let (ad, bd) = c2d(&m(2, 2, &[0.0, 1.0, 0.0, 0.0]), &m(2, 1, &[0.0, 1.0]), 0.1).unwrap();
    assert!((&ad - m(2, 2, &[1.0, 0.1, 0.0, 1.0])).amax() < 1e-15);
    assert!((&bd - m(2, 1, &[0.005, 0.1])).amax() < 1e-15);
    let (q, r) = (DMatrix::identity(2, 2), m(1, 1, &[1.0]));
    let sol = dlqr(&ad, &bd, &q, &r).unwrap();
    assert!(residual(&ad, &bd, &q, &r, &sol.x) < 1e-12);
    let k_again = (&r + bd.transpose() * &sol.x * &bd).lu().solve(&(bd.transpose() * &sol.x * &ad)).unwrap();
    assert!((&sol.k - k_again).amax() < 1e-12);
    assert!(sol.poles.iter().all(|p| p.norm() < 1.0));
    assert!(sol.poles[0].re <= sol.poles[1].re);
}

#[test]
fn singular_r_where_the_pencil_allows_it() {
    // DAREX #3 (SciPy's case 6): R = 0, and R + Bᵀ X B > 0 at the solution.
    let (a, b, q, r) = (m(2, 2, &[2.0, -1.0, 1.0, 0.0]), m(2, 1, &[1.0, 0.0]), m(2, 2, &[0.0, 0.0, 0.0, 1.0]), m(1, 1, &[0.0]));
    let x = dare(&a, &b, &q, &r).unwrap();
    assert!(residual(&a, &b, &q, &r, &x) < 1e-12, "{x}");
    assert!(stabilising(&a, &b, &q, &r, &x));
    // R = 0 with B = 0 on an unstable A: not stabilizable.
    let err = dare(&a, &m(2, 1, &[0.0, 0.0]), &q, &r).unwrap_err();
    // A's double eigenvalue 1 (a Jordan block: found to about √ε).
    assert!(matches!(err, TwipError::NotStabilizable { eigenvalue: (re, _) } if (re - 1.0).abs() < 1e-7), "{err:?}");
}

#[test]
fn indefinite_r_and_q_as_scipy_allows() {
    // A stable A with a small indefinite Q and R: the pencil stays off the unit circle.
    let a = m(2, 2, &[0.5, 0.1, 0.0, -0.3]);
    let b = m(2, 2, &[1.0, 0.0, 0.0, 1.0]);
    let q = m(2, 2, &[0.1, 0.0, 0.0, -0.05]);
    let r = m(2, 2, &[1.0, 0.0, 0.0, -2.0]);
    let x = dare(&a, &b, &q, &r).unwrap();
    assert!(residual(&a, &b, &q, &r, &x) < 1e-12);
    assert!(stabilising(&a, &b, &q, &r, &x));
}

#[test]
fn named_errors() {
    let (q, r) = (DMatrix::identity(2, 2), m(1, 1, &[1.0]));
    // An unstable mode the input cannot reach.
    let a = m(2, 2, &[2.0, 0.0, 0.0, 0.5]);
    let err = dare(&a, &m(2, 1, &[0.0, 1.0]), &q, &r).unwrap_err();
    assert!(matches!(err, TwipError::NotStabilizable { eigenvalue: (re, im) } if (re - 2.0).abs() < 1e-12 && im == 0.0), "{err:?}");
    // A mode on the unit circle that Q cannot see.
    let err = dare(&m(1, 1, &[1.0]), &m(1, 1, &[1.0]), &m(1, 1, &[0.0]), &m(1, 1, &[1.0])).unwrap_err();
    assert!(matches!(err, TwipError::NotDetectable { eigenvalue: (re, im) } if re == 1.0 && im == 0.0), "{err:?}");
    // A rotation on the unit circle, invisible to an indefinite Q: no stabilising solution.
    let rot = m(2, 2, &[0.0, -1.0, 1.0, 0.0]);
    let err = dare(&rot, &m(2, 1, &[1.0, 0.0]), &m(2, 2, &[0.0, 0.0, 0.0, 0.0]), &r).unwrap_err();
    assert!(matches!(err, TwipError::NotDetectable { .. } | TwipError::NoStabilizingSolution), "{err:?}");
    // Shapes, NaN, asymmetry.
    assert!(matches!(dare(&a, &m(1, 1, &[1.0]), &q, &r), Err(TwipError::Shape { name: "B", .. })));
    assert!(matches!(dare(&a, &m(2, 1, &[0.0, 1.0]), &q, &DMatrix::identity(2, 2)), Err(TwipError::Shape { name: "R", .. })));
    let nan = m(2, 2, &[1.0, f64::NAN, 0.0, 1.0]);
    assert!(matches!(dare(&nan, &m(2, 1, &[0.0, 1.0]), &q, &r), Err(TwipError::NonFinite { name: "A", index: 1, .. })));
    let skew = m(2, 2, &[1.0, 0.5, 0.0, 1.0]);
    assert!(matches!(dare(&a, &m(2, 1, &[1.0, 1.0]), &skew, &r), Err(TwipError::InvalidParameter { name: "Q", .. })));
    // R singular where the pencil does not allow it: R = 0 and Bᵀ X B = 0 for a B the
    // cost never sees (Q = 0 on a stable A gives X = 0).
    let err = dare(&m(1, 1, &[0.5]), &m(1, 1, &[1.0]), &m(1, 1, &[0.0]), &m(1, 1, &[0.0])).unwrap_err();
    assert_eq!(err, TwipError::NoStabilizingSolution);
}

#[test]
fn f32_matches_f64() {
    let a = DMatrix::<f32>::from_row_slice(2, 2, &[1.0, 0.1, 0.0, 1.0]);
    let b = DMatrix::<f32>::from_row_slice(2, 1, &[0.005, 0.1]);
    let x32 = dare(&a, &b, &DMatrix::identity(2, 2), &DMatrix::identity(1, 1)).unwrap();
    let x64 = dare(&a.map(f64::from), &b.map(f64::from), &DMatrix::identity(2, 2), &DMatrix::identity(1, 1)).unwrap();
    assert!((x32.map(f64::from) - &x64).amax() < 1e-4 * x64.amax());
}

#[test]
fn stein_against_kronecker() {
    // M with a complex pair and two real eigenvalues, all inside the unit circle.
    let mm = m(4, 4, &[0.5, -0.6, 0.1, 0.0, 0.6, 0.5, 0.0, 0.2, 0.0, 0.0, -0.7, 0.3, 0.0, 0.0, 0.0, 0.2]);
    let f = m(4, 4, &[2.0, 1.0, 0.0, 0.5, 1.0, 3.0, -1.0, 0.0, 0.0, -1.0, 1.0, 0.2, 0.5, 0.0, 0.2, 4.0]);
    let (u, t) = schur(mm.clone()).unwrap();
    let d = stein::stein_schur(&u, &t, &f);
    let back = mm.transpose() * &d * &mm - &d;
    assert!((back - &f).amax() < 1e-13);
}

#[test]
fn c2d_closed_forms_and_errors() {
    let (ad, bd) = c2d(&m(1, 1, &[-2.0]), &m(1, 1, &[1.0]), 0.1).unwrap();
    let e = (-0.2f64).exp();
    assert!((ad[(0, 0)] - e).abs() < 1e-15 && (bd[(0, 0)] - (1.0 - e) / 2.0).abs() < 1e-15, "{ad} {bd}");
    // A rotation generator with a large norm (scaling and squaring): exp = rotation by 30 rad.
    let w = 30.0f64;
    let rot = expm(&m(2, 2, &[0.0, -w, w, 0.0])).unwrap();
    let exact = m(2, 2, &[w.cos(), -w.sin(), w.sin(), w.cos()]);
    assert!((rot - exact).amax() < 1e-13);
    assert!(matches!(c2d(&m(1, 1, &[1.0]), &m(1, 1, &[1.0]), 0.0), Err(TwipError::InvalidParameter { name: "period", .. })));
    assert!(matches!(c2d(&m(1, 1, &[1e3]), &m(1, 1, &[1.0]), 1e3), Err(TwipError::InvalidParameter { name: "period", .. })));
    assert!(matches!(c2d(&m(1, 1, &[f64::INFINITY]), &m(1, 1, &[1.0]), 1.0), Err(TwipError::NonFinite { name: "A", .. })));
    assert!(matches!(c2d(&m(2, 2, &[0.0; 4]), &m(1, 1, &[1.0]), 1.0), Err(TwipError::Shape { name: "B", .. })));
}

#[test]
fn stabilizable_whatever_the_units_of_the_input() {
    // dare(A, c B, Q, 1) is dare(A, B, Q, 1/c²): c = 1e-12 was refused.
    let (a, b, q) = (m(2, 2, &[1.2, 0.3, 0.1, 0.5]), m(2, 1, &[0.0, 1.0]), DMatrix::identity(2, 2));
    let x = dare(&a, &(&b * 1e-12), &q, &m(1, 1, &[1.0])).unwrap();
    let same = dare(&a, &b, &q, &m(1, 1, &[1e24])).unwrap();
    assert!((&x - &same).amax() <= 1e-10 * same.amax(), "{x} vs {same}");
}

#[test]
fn a_tiny_q_on_an_unstable_a_is_no_unit_circle() {
    // 0.7 [[0, 1], [2, −1]] (eigenvalues 0.7, −1.4) with Q = s I, s ≤ 1e-17: was refused.
    let (a, b, r) = (m(2, 2, &[0.0, 0.7, 1.4, -0.7]), m(2, 1, &[0.0, 1.0]), m(1, 1, &[1.0]));
    let limit = dare(&a, &b, &DMatrix::zeros(2, 2), &r).unwrap();
    for s in [1e-17, 1e-20, 1e-30] {
        let q = DMatrix::identity(2, 2) * s;
        let x = dare(&a, &b, &q, &r).map_err(|e| (s, e)).unwrap();
        assert!((&x - &limit).amax() < 1e-12 * limit.amax(), "{s}: {x} vs {limit}");
        assert!(stabilising(&a, &b, &q, &r, &x));
    }
}
