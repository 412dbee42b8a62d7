//! Exact zero-order-hold discretisation: `c2d(A, B, T)` and the matrix exponential behind it
//! (scaling and squaring with Padé approximants, Higham 2005), on dense heap matrices.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use nalgebra::DMatrix;

use crate::control::care::checks::finite;
use crate::{c, to_f64, Real, TwipError};

/// Padé degrees with the largest 1-norm θ_m each is accurate to double precision for
/// (Higham 2005, table 2.3), and the numerator coefficients b_0..b_m.
const PADE: [(f64, &[f64]); 5] = [
    (1.495585217958292e-2, &[120.0, 60.0, 12.0, 1.0]),
    (2.539398330063230e-1, &[30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0]),
    (9.504178996162932e-1, &[17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0]),
    (
        2.097847961257068,
        &[17643225600.0, 8821612800.0, 2075673600.0, 302702400.0, 30270240.0, 2162160.0, 110880.0, 3960.0, 90.0, 1.0],
    ),
    (
        5.371920351148152,
        &[
            64764752532480000.0,
            32382376266240000.0,
            7771770303897600.0,
            1187353796428800.0,
            129060195264000.0,
            10559470521600.0,
            670442572800.0,
            33522128640.0,
            1323241920.0,
            40840800.0,
            960960.0,
            16380.0,
            182.0,
            1.0,
        ],
    ),
];

/// The exponential of a square matrix, or `None` if it overflows (or `m` is not finite).
pub fn expm<T: Real>(m: &DMatrix<T>) -> Option<DMatrix<T>> {
    let n = m.nrows();
    let norm1 = (0..n).map(|j| m.column(j).iter().fold(T::zero(), |acc, v| acc + v.abs())).fold(T::zero(), |a, v| a.max(v));
    if !norm1.is_finite() {
        return None;
    }
    // The lowest degree accurate at this norm, else degree 13 on M / 2^s.
    let (mut squarings, mut chosen) = (0i32, PADE.len() - 1);
    match PADE.iter().position(|(theta, _)| norm1 <= c::<T>(*theta)) {
        Some(i) => chosen = i,
        None => {
            let ratio = norm1 / c::<T>(PADE[chosen].0);
            squarings = to_f64((ratio.ln() / T::ln_2()).ceil().max(T::zero())) as i32;
        }
    }
    let scaled = m * c::<T>(2.0).powi(-squarings);
    let coefficients = PADE[chosen].1;
    // U = A Σ b_{2j+1} A^{2j}, V = Σ b_{2j} A^{2j}.
    let square = &scaled * &scaled;
    let mut power = DMatrix::<T>::identity(n, n);
    let (mut odd, mut even) = (DMatrix::<T>::zeros(n, n), DMatrix::<T>::zeros(n, n));
    for (j, pair) in coefficients.chunks(2).enumerate() {
        if j > 0 {
            power = &power * &square;
        }
        even += &power * c::<T>(pair[0]);
        if let Some(&b_odd) = pair.get(1) {
            odd += &power * c::<T>(b_odd);
        }
    }
    let u = &scaled * odd;
    let mut e = (&even - &u).lu().solve(&(even + u))?;
    for _ in 0..squarings {
        e = &e * &e;
        if e.iter().any(|v| !v.is_finite()) {
            return None;
        }
    }
    e.iter().all(|v| v.is_finite()).then_some(e)
}

/// Exact zero-order-hold discretisation of `ẋ = A x + B u` over `period`: `(Ad, Bd)` with
/// `x[k+1] = Ad x[k] + Bd u[k]`, from `exp([[A, B], [0, 0]] · period) = [[Ad, Bd], [0, I]]`
/// (SciPy's `cont2discrete(..., method="zoh")`).
pub fn c2d<T: Real>(a: &DMatrix<T>, b: &DMatrix<T>, period: T) -> Result<(DMatrix<T>, DMatrix<T>), TwipError> {
    let n = a.nrows();
    if n == 0 || a.ncols() != n {
        return Err(TwipError::Shape { name: "A", expected: (n.max(1), n.max(1)), got: a.shape() });
    }
    let m = b.ncols();
    if b.nrows() != n || m == 0 {
        return Err(TwipError::Shape { name: "B", expected: (n, m.max(1)), got: b.shape() });
    }
    finite("A", a)?;
    finite("B", b)?;
    if !(period.is_finite() && period > T::zero()) {
        return Err(TwipError::InvalidParameter { name: "period", value: to_f64(period), reason: "must be finite and > 0" });
    }
    let mut block = DMatrix::<T>::zeros(n + m, n + m);
    block.view_mut((0, 0), (n, n)).copy_from(&(a * period));
    block.view_mut((0, n), (n, m)).copy_from(&(b * period));
    let e = expm(&block).ok_or(TwipError::InvalidParameter {
        name: "period",
        value: to_f64(period),
        reason: "exp(A period) overflows: the period is too long for this A",
    })?;
    Ok((e.view((0, 0), (n, n)).into_owned(), e.view((0, n), (n, m)).into_owned()))
}
