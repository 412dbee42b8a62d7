//! CARE and LQR tests: closed forms, hard cases, error paths.
use super::*;
use nalgebra::DMatrix;

fn m(rows: usize, cols: usize, data: &[f64]) -> DMatrix<f64> {
    DMatrix::from_row_slice(rows, cols, data)
}

fn rel_residual(a: &DMatrix<f64>, b: &DMatrix<f64>, q: &DMatrix<f64>, r: &DMatrix<f64>, x: &DMatrix<f64>) -> f64 {
    let bh = b * r.clone().cholesky().unwrap().l().try_inverse().unwrap().transpose();
    residual(a, &bh, q, x).2
}

#[test]
fn double_integrator() {
    let a = m(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let b = m(2, 1, &[0.0, 1.0]);
    let q = DMatrix::identity(2, 2);
    let r = m(1, 1, &[1.0]);
    let sol = lqr(&a, &b, &q, &r).unwrap();
    let s3 = 3f64.sqrt();
    assert!((sol.k[(0, 0)] - 1.0).abs() < 1e-12, "{}", sol.k);
    assert!((sol.k[(0, 1)] - s3).abs() < 1e-12, "{}", sol.k);
    let x_exact = m(2, 2, &[s3, 1.0, 1.0, s3]);
    assert!((&sol.x - x_exact).amax() < 1e-12, "{}", sol.x);
    // Closed loop s² + √3 s + 1: poles −√3/2 ± i/2.
    assert_eq!(sol.poles.len(), 2);
    for p in &sol.poles {
        assert!(
            (p.re + s3 / 2.0).abs() < 1e-12 && (p.im.abs() - 0.5).abs() < 1e-12,
            "{p}"
        );
    }
    assert!(sol.poles[0].im < sol.poles[1].im);
}

#[test]
fn scalar_closed_forms() {
    // 2 a x − b² x² / r + q = 0  →  x = r (a + √(a² + b² q / r)) / b².
    for &(a, b, q, r) in &[
        (1.0, 1.0, 1.0, 1.0),
        (-2.0, 0.5, 3.0, 0.1),
        (0.0, 1.0, 1.0, 1.0),
        (5.0, 2.0, 1e-9, 1.0),
        (1e3, 1e-2, 1e-4, 1e6),
        (-1e-3, 1e2, 1e4, 1e-6),
    ] {
        let x = care(&m(1, 1, &[a]), &m(1, 1, &[b]), &m(1, 1, &[q]), &m(1, 1, &[r])).unwrap()[(0, 0)];
        let disc: f64 = a * a + b * b * q / r;
        // Cancellation-free form when a < 0: x = q / (√disc − a).
        let exact = if a > 0.0 {
            r * (a + disc.sqrt()) / (b * b)
        } else {
            q / (disc.sqrt() - a)
        };
        assert!(
            (x - exact).abs() <= 1e-13 * exact.abs().max(f64::MIN_POSITIVE),
            "{a} {b} {q} {r}: {x} vs {exact}"
        );
    }
    // q = 0 with a stable a: x = 0 and the pole stays; the minimum-energy limit
    // (q → 0 with an unstable a) mirrors the pole.
    let x = care(&m(1, 1, &[-3.0]), &m(1, 1, &[1.0]), &m(1, 1, &[0.0]), &m(1, 1, &[1.0])).unwrap();
    assert_eq!(x[(0, 0)], 0.0);
    let sol = lqr(&m(1, 1, &[3.0]), &m(1, 1, &[1.0]), &m(1, 1, &[1e-12]), &m(1, 1, &[1.0])).unwrap();
    assert!((sol.poles[0].re + 3.0).abs() < 1e-12);
}

#[test]
fn f32_matches_f64() {
    let a = DMatrix::<f32>::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let b = DMatrix::<f32>::from_row_slice(2, 1, &[0.0, 1.0]);
    let sol = lqr(&a, &b, &DMatrix::identity(2, 2), &DMatrix::identity(1, 1)).unwrap();
    assert!((sol.k[(0, 1)] - 3f32.sqrt()).abs() < 1e-5);
}

#[test]
fn larger_problem_with_oscillators() {
    // Two undamped oscillators and an integrator, cross-coupled inputs.
    let a = m(
        5,
        5,
        &[
            0.0, 1.0, 0.0, 0.0, 0.0, //
            -4.0, 0.0, 0.0, 0.0, 0.0, //
            0.0, 0.0, 0.0, 1.0, 0.0, //
            0.0, 0.0, -9.0, 0.0, 0.0, //
            1.0, 0.0, 0.0, 0.0, 0.0,
        ],
    );
    let b = m(5, 2, &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0]);
    let q = DMatrix::identity(5, 5);
    let r = m(2, 2, &[1.0, 0.2, 0.2, 2.0]);
    let sol = lqr(&a, &b, &q, &r).unwrap();
    assert!(rel_residual(&a, &b, &q, &r, &sol.x) < 1e-13);
    assert!(sol.poles.iter().all(|p| p.re < 0.0));
    assert!((&sol.x - sol.x.transpose()).amax() == 0.0);
}

#[test]
fn cyclic_matrix_does_not_stall() {
    // A cyclic permutation: eigenvalues on the unit circle, a classic hard case for QR.
    let a = m(3, 3, &[0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let b = DMatrix::identity(3, 3);
    let q = DMatrix::identity(3, 3);
    let sol = lqr(&a, &b, &q, &DMatrix::identity(3, 3)).unwrap();
    assert!(rel_residual(&a, &b, &q, &DMatrix::identity(3, 3), &sol.x) < 1e-13);
}

#[test]
fn errors() {
    let a = m(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let b = m(2, 1, &[0.0, 1.0]);
    let q = DMatrix::identity(2, 2);
    let r = m(1, 1, &[1.0]);
    let name = |e: TwipError| match e {
        TwipError::Shape { name, .. }
        | TwipError::InvalidParameter { name, .. }
        | TwipError::NonFinite { name, .. } => name,
        other => panic!("unexpected {other:?}"),
    };
    assert_eq!(name(care(&m(2, 3, &[0.0; 6]), &b, &q, &r).unwrap_err()), "A");
    assert_eq!(name(care(&a, &m(3, 1, &[0.0; 3]), &q, &r).unwrap_err()), "B");
    assert_eq!(name(care(&a, &b, &DMatrix::identity(3, 3), &r).unwrap_err()), "Q");
    assert_eq!(name(care(&a, &b, &q, &DMatrix::identity(2, 2)).unwrap_err()), "R");
    assert_eq!(
        name(care(&a, &b, &m(2, 2, &[1.0, 0.5, 0.0, 1.0]), &r).unwrap_err()),
        "Q"
    );
    assert_eq!(
        name(care(&a, &m(2, 2, &[1.0, 0.0, 0.0, 1.0]), &q, &m(2, 2, &[1.0, 0.1, 0.0, 1.0])).unwrap_err()),
        "R"
    );
    assert_eq!(name(care(&a, &b, &q, &m(1, 1, &[0.0])).unwrap_err()), "R");
    assert_eq!(name(care(&a, &b, &q, &m(1, 1, &[-1.0])).unwrap_err()), "R");
    let e = care(&a, &b, &q, &m(1, 1, &[f64::NAN])).unwrap_err();
    assert!(
        matches!(
            e,
            TwipError::NonFinite {
                name: "R",
                index: 0,
                ..
            }
        ),
        "{e:?}"
    );
    let e = care(&m(2, 2, &[0.0, 1.0, f64::INFINITY, 0.0]), &b, &q, &r).unwrap_err();
    assert!(
        matches!(
            e,
            TwipError::NonFinite {
                name: "A",
                index: 2,
                ..
            }
        ),
        "{e:?}"
    );
    // Unstabilizable: the unstable mode 1 is not driven.
    let a2 = m(2, 2, &[1.0, 0.0, 0.0, -1.0]);
    let err = care(&a2, &b, &q, &r).unwrap_err();
    assert!(matches!(err, TwipError::NotStabilizable { eigenvalue: (re, im) } if (re - 1.0).abs() < 1e-12 && im == 0.0), "{err:?}");
    // Marginal and undriven: the integrator of the double integrator with B = e1.
    let err = care(&a, &m(2, 1, &[1.0, 0.0]), &q, &r).unwrap_err();
    assert!(matches!(err, TwipError::NotStabilizable { eigenvalue: (re, im) } if re.abs() < 1e-12 && im == 0.0), "{err:?}");
    // Undetectable: the unstable mode 1 is invisible to Q. The stabilising solution still
    // exists (as in SciPy): it mirrors the mode to −1, with X = diag(2, 0) by hand
    // (X11 solves 2 X11 − X11² = 0; the other entries stay 0).
    let a3 = m(2, 2, &[1.0, 0.0, 0.0, -1.0]);
    let b3 = m(2, 1, &[1.0, 0.0]);
    let q3 = m(2, 2, &[0.0, 0.0, 0.0, 1.0]);
    let x3 = care(&a3, &b3, &q3, &r).unwrap();
    assert!((x3 - m(2, 2, &[2.0, 0.0, 0.0, 0.5])).amax() < 1e-14);
    // An undamped oscillator invisible to Q: a Hamiltonian eigenvalue on the axis.
    let a4 = m(2, 2, &[0.0, 1.0, -1.0, 0.0]);
    let err = care(&a4, &b, &DMatrix::zeros(2, 2), &r).unwrap_err();
    assert!(matches!(err, TwipError::NotDetectable { eigenvalue: (re, im) } if re.abs() < 1e-12 && (im - 1.0).abs() < 1e-12), "{err:?}");
}

/// Both fallbacks of `schur` give `M = U T Uᵀ` with `U` orthogonal and `T` quasi-triangular.
#[test]
fn schur_fallbacks_are_schur_forms() {
    let mm = m(
        4,
        4,
        &[
            1.0, 2.0, 0.0, -1.0, 0.5, -3.0, 1.0, 0.0, 0.0, 1.0, 0.0, 2.0, -2.0, 0.0, 1.0, 1.0,
        ],
    );
    for (u, t) in [schur_reflected(mm.clone()).unwrap(), schur_transposed(mm.clone()).unwrap()] {
        assert!((&u * &t * u.transpose() - &mm).amax() < 1e-13);
        assert!((u.transpose() * &u - DMatrix::identity(4, 4)).amax() < 1e-14);
        for (i, size) in quasi_blocks(&t) {
            for r in (i + size)..4 {
                for cc in i..(i + size) {
                    assert_eq!(t[(r, cc)], 0.0);
                }
            }
        }
    }
}

#[test]
fn no_input_is_a_lyapunov_equation() {
    // B = 0 with a stable A: Aᵀ X + X A + Q = 0.
    let a = m(2, 2, &[-1.0, 2.0, 0.0, -3.0]);
    let q = m(2, 2, &[2.0, 1.0, 1.0, 4.0]);
    let x = care(&a, &DMatrix::zeros(2, 1), &q, &m(1, 1, &[1.0])).unwrap();
    assert!((a.transpose() * &x + &x * &a + &q).amax() < 1e-14);
}

#[test]
fn badly_scaled_states_are_exactly_rescaled() {
    // x' = T⁻¹ x with T = diag(2⁻¹⁰, 1, 2¹²): X' = T X T, entry by entry.
    let a = m(3, 3, &[0.5, 1.0, -0.3, -2.0, 0.1, 1.0, 0.2, -1.0, -0.4]);
    let b = m(3, 2, &[1.0, 0.0, 0.3, 1.0, -0.5, 2.0]);
    let q = m(3, 3, &[2.0, 0.5, 0.0, 0.5, 1.0, 0.2, 0.0, 0.2, 3.0]);
    let r = m(2, 2, &[1.0, 0.1, 0.1, 0.5]);
    let t = [2f64.powi(-10), 1.0, 2f64.powi(12)];
    let a2 = DMatrix::from_fn(3, 3, |i, j| a[(i, j)] * t[j] / t[i]);
    let b2 = DMatrix::from_fn(3, 2, |i, j| b[(i, j)] / t[i]);
    let q2 = DMatrix::from_fn(3, 3, |i, j| q[(i, j)] * t[i] * t[j]);
    let x = care(&a, &b, &q, &r).unwrap();
    let x2 = care(&a2, &b2, &q2, &r).unwrap();
    for i in 0..3 {
        for j in 0..3 {
            let want = x[(i, j)] * t[i] * t[j];
            assert!(
                (x2[(i, j)] - want).abs() <= 1e-12 * want.abs().max(1e-300),
                "{i} {j}: {} vs {want}",
                x2[(i, j)]
            );
        }
    }
}

#[test]
fn solve_small_and_lyapunov() {
    // A 3×3 with a complex pair: check Mᵀ D + D M = F directly.
    let mm = m(3, 3, &[-1.0, 2.0, 0.5, -3.0, -1.0, 0.0, 0.2, 0.1, -0.5]);
    let f = m(3, 3, &[1.0, 0.2, 0.3, 0.2, 2.0, 0.1, 0.3, 0.1, 3.0]);
    let (u, t) = schur(mm.clone()).unwrap();
    let d = lyapunov_schur(&u, &t, &f);
    let err = (mm.transpose() * &d + &d * &mm - &f).amax();
    assert!(err < 1e-13, "{err}");
}

#[test]
fn indefinite_q_has_a_stabilising_solution_when_the_hamiltonian_allows() {
    // Scalar: 2 a X − X² + q = 0, stabilising X = a + √(a² + q), which exists iff a² + q > 0.
    let one = m(1, 1, &[1.0]);
    let x = care(&m(1, 1, &[2.0]), &one, &m(1, 1, &[-3.0]), &one).unwrap();
    assert!((x[(0, 0)] - 3.0).abs() < 1e-14, "{x}");
    assert_eq!(
        care(&m(1, 1, &[1.0]), &one, &m(1, 1, &[-2.0]), &one).unwrap_err(),
        TwipError::NoStabilizingSolution
    );
    // The double integrator with a negative weight on the speed: still stabilisable by a
    // cost that rewards speed a little (the Hamiltonian stays off the axis).
    let a = m(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let b = m(2, 1, &[0.0, 1.0]);
    let q = m(2, 2, &[1.0, 0.0, 0.0, -0.5]);
    let l = lqr(&a, &b, &q, &one).unwrap();
    assert!(l.poles.iter().all(|p| p.re < 0.0), "{:?}", l.poles);
    let res = &l.x * &a + a.transpose() * &l.x - &l.x * &b * b.transpose() * &l.x + &q;
    assert!(res.amax() < 1e-13, "{res}");
}

/// The closed loop's largest real part.
fn max_re(a: &DMatrix<f64>, b: &DMatrix<f64>, r: &DMatrix<f64>, x: &DMatrix<f64>) -> f64 {
    let k = r.clone().lu().solve(&(b.transpose() * x)).unwrap();
    (a - b * k).complex_eigenvalues().iter().fold(f64::NEG_INFINITY, |acc, l| acc.max(l.re))
}

#[test]
fn stabilizable_whatever_the_units_of_the_states() {
    // A = D A0 D⁻¹, B = D B0, D = diag(1e-4, 1, 1e4) (A0, B0: numpy default_rng(3) normals):
    // was NotStabilizable; SciPy solves it with the closed loop's max Re = −0.079.
    let a0 = m(3, 3, &[
        2.0409191213851825, -2.5556650313141818, 0.41809884672577885,
        -0.5677696061279298, -0.45264929211044586, -0.2155971630897659,
        -2.019986129147251, -0.23193237764418947, -0.8652130762749417,
    ]);
    let b0 = m(3, 1, &[3.3229995166448827, 0.22578661322792176, -0.3526307943415954]);
    let d = [1e-4, 1.0, 1e4];
    let a = DMatrix::from_fn(3, 3, |i, j| d[i] * a0[(i, j)] / d[j]);
    let b = DMatrix::from_fn(3, 1, |i, j| d[i] * b0[(i, j)]);
    let (q, r) = (DMatrix::identity(3, 3), m(1, 1, &[1.0]));
    let x = care(&a, &b, &q, &r).unwrap();
    assert!(rel_residual(&a, &b, &q, &r, &x) < 1e-12);
    let worst = max_re(&a, &b, &r, &x);
    assert!((worst + 0.079).abs() < 1e-3, "{worst}");
}

#[test]
fn stabilizable_whatever_the_units_of_the_input() {
    // care(A, c B, Q, 1) is care(A, B, Q, 1/c²): c = 1e-12 was refused as not stabilizable.
    let (a, b, q) = (m(2, 2, &[0.0, 1.0, 2.0, -1.0]), m(2, 1, &[0.0, 1.0]), DMatrix::identity(2, 2));
    let x = care(&a, &(&b * 1e-12), &q, &m(1, 1, &[1.0])).unwrap();
    let same = care(&a, &b, &q, &m(1, 1, &[1e24])).unwrap();
    assert!((&x - &same).amax() <= 1e-10 * same.amax(), "{x} vs {same}");
    // c = 1e16 (Q/R = 1e32 in effect) is stabilizable too, whatever the solver makes of it.
    let err = care(&a, &(&b * 1e16), &q, &m(1, 1, &[1.0])).err();
    assert!(!matches!(err, Some(TwipError::NotStabilizable { .. })), "{err:?}");
}

#[test]
fn a_tiny_q_on_an_unstable_a_is_no_imaginary_axis() {
    // Q = s I, s ≤ 1e-17, was NoStabilizingSolution while Q = 0 gives [[8, 4], [4, 2]]
    // (SciPy's answer for 1e-20 matches it to 1e-15).
    let (a, b, r) = (m(2, 2, &[0.0, 1.0, 2.0, -1.0]), m(2, 1, &[0.0, 1.0]), m(1, 1, &[1.0]));
    let limit = care(&a, &b, &DMatrix::zeros(2, 2), &r).unwrap();
    assert!((&limit - m(2, 2, &[8.0, 4.0, 4.0, 2.0])).amax() < 1e-13, "{limit}");
    for s in [1e-17, 1e-20, 1e-30] {
        let q = DMatrix::identity(2, 2) * s;
        let x = care(&a, &b, &q, &r).map_err(|e| (s, e)).unwrap();
        assert!((&x - &limit).amax() < 1e-13, "{s}: {x}");
        assert!(max_re(&a, &b, &r, &x) < 0.0);
    }
}
