//! c2d and expm on scales far apart (the audit's cases), against 80-digit references
//! (mpmath's Taylor `expm` of the ZOH block).
use nalgebra::DMatrix;

use super::*;

fn m(rows: usize, cols: usize, data: &[f64]) -> DMatrix<f64> {
    DMatrix::from_row_slice(rows, cols, data)
}

/// The largest elementwise relative error (absolute where the reference is 0).
fn worst(got: &DMatrix<f64>, exact: &DMatrix<f64>) -> f64 {
    got.iter().zip(exact.iter()).fold(0.0, |acc, (g, e)| acc.max(if *e == 0.0 { g.abs() } else { ((g - e) / e).abs() }))
}

#[test]
fn c2d_a_large_b_does_not_cost_the_state_its_digits() {
    // Was Ad = 1.0 for B = 1e18 (exact e^-1), 2.3e-7 off for B = 1e10.
    let e = (-1.0f64).exp();
    for b in [1e10, 1e18, 1e300] {
        let (ad, bd) = c2d(&m(1, 1, &[-1.0]), &m(1, 1, &[b]), 1.0).unwrap();
        assert!((ad[(0, 0)] - e).abs() <= 2e-16, "B = {b}: Ad = {}", ad[(0, 0)]);
        assert!((bd[(0, 0)] / (b * (1.0 - e)) - 1.0).abs() <= 1e-15, "B = {b}: Bd = {}", bd[(0, 0)]);
    }
}

#[test]
fn c2d_keeps_the_slow_mode_of_a_stiff_triangular_a() {
    // diag(-1e20, -1): the slow mode was Ad = 1, Bd = 1 (exact 0.368, 0.632).
    let e = (-1.0f64).exp();
    let (ad, bd) = c2d(&m(2, 2, &[-1e20, 0.0, 0.0, -1.0]), &m(2, 1, &[1.0, 1.0]), 1.0).unwrap();
    assert!(worst(&ad, &m(2, 2, &[0.0, 0.0, 0.0, e])) <= 2e-16, "{ad}");
    assert!(worst(&bd, &m(2, 1, &[1e-20, 1.0 - e])) <= 1e-15, "{bd}");
    // Lower triangular: triangular after a permutation.
    let (ad, bd) = c2d(&m(2, 2, &[-1e20, 0.0, 1.0, -1.0]), &m(2, 1, &[1.0, 1.0]), 1.0).unwrap();
    assert!(worst(&ad, &m(2, 2, &[0.0, 0.0, 3.678794411714423e-21, e])) <= 1e-15, "{ad}");
    assert!(worst(&bd, &m(2, 1, &[1e-20, 0.6321205588285577])) <= 1e-15, "{bd}");
    // Non-normal: [[-1, 1e8], [0, -2]] was 1.6e-9 off.
    let (ad, bd) = c2d(&m(2, 2, &[-1.0, 1e8, 0.0, -2.0]), &m(2, 1, &[0.0, 1.0]), 1.0).unwrap();
    let exact_ad = m(2, 2, &[0.36787944117144233, 23254415.793482963, 0.0, 0.1353352832366127]);
    assert!(worst(&ad, &exact_ad) <= 1e-15, "{ad}");
    assert!(worst(&bd, &m(2, 1, &[19978820.044686403, 0.43233235838169365])) <= 1e-15, "{bd}");
}

#[test]
fn c2d_of_states_in_mixed_units_is_accurate_entrywise() {
    // A = D A0 D⁻¹, B = D 1, D = diag(logspace(-4, 4, 4)), T = 0.1: entries were up to 29 % off.
    #[rustfmt::skip]
    let a = m(4, 4, &[
        0.38275716027076095, 0.0006881570766012143, -1.66592800514788e-06, -1.9016352983759946e-08,
        -50.55373848710696, -0.8037318485206765, 0.0023271415268748415, -1.3403353897495213e-06,
        17984.220295970677, -394.35215165309523, -0.5106224678981267, -2.4847228179860157e-05,
        -148537518.42635453, 64780.64410125008, -49.23437871592257, -1.1857198050052338,
    ]);
    let b = m(4, 1, &[0.0001, 0.046415888336127774, 21.54434690031882, 10000.0]);
    #[rustfmt::skip]
    let exact_ad = m(4, 4, &[
        1.0526930086407404, 6.490143735924941e-05, -1.5427199714925516e-07, -1.8411781350375407e-09,
        -3.8172602401544284, 0.9179628223035676, 0.00021818697849063472, -1.1755406168449036e-07,
        1895.1002261801973, -36.81323872225506, 0.945761075605892, -1.5573679935292331e-06,
        -14367241.43191823, 5471.749911010357, -2.693457360219688, 0.9010871654545283,
    ]);
    let exact_bd = m(4, 1, &[9.29292339387579e-06, 0.004610112301786761, 2.0180552194818304, 884.564549370693]);
    let (ad, bd) = c2d(&a, &b, 0.1).unwrap();
    assert!(worst(&ad, &exact_ad) <= 1e-13, "{}", worst(&ad, &exact_ad));
    assert!(worst(&bd, &exact_bd) <= 1e-13, "{}", worst(&bd, &exact_bd));
}

#[test]
fn c2d_refuses_a_stiff_full_a_rather_than_lose_its_slow_mode() {
    // Coupled modes near -1e20 and -1: no permutation makes A triangular, and 2^64 squarings
    // would round the slow mode away.
    let err = c2d(&m(2, 2, &[-1e20, 1.0, 1.0, -1.0]), &m(2, 1, &[1.0, 1.0]), 1.0).unwrap_err();
    assert!(matches!(err, TwipError::InvalidParameter { name: "period", value, .. } if value == 1.0), "{err:?}");
}

#[test]
fn expm_of_nilpotent_and_huge_entries() {
    // A = 0 with a huge B: exp = I + M exactly.
    let (ad, bd) = c2d(&m(2, 2, &[0.0; 4]), &m(2, 1, &[0.0, 1e10]), 1e290).unwrap();
    assert_eq!(ad, DMatrix::identity(2, 2));
    assert_eq!(bd, m(2, 1, &[0.0, 1e300]));
    // A = -1e300: Ad underflows to 0, Bd = 1e-300.
    let (ad, bd) = c2d(&m(1, 1, &[-1e300]), &m(1, 1, &[1.0]), 1.0).unwrap();
    assert_eq!(ad[(0, 0)], 0.0);
    assert!((bd[(0, 0)] / 1e-300 - 1.0).abs() < 1e-15, "{bd}");
}

