//! Exact zero-order-hold discretisation: `c2d(A, B, T)` and the matrix exponential behind it
//! (scaling and squaring with Padé approximants, [`expm`]), on dense heap matrices.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use nalgebra::DMatrix;

use crate::control::care::checks::finite;
use crate::{to_f64, Real, TwipError};

mod expm;
#[cfg(test)]
mod tests;
mod triangular;

pub use expm::expm;
use expm::{expm_checked, ExpmFailure};

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
    let e = expm_checked(&block).map_err(|failure| TwipError::InvalidParameter {
        name: "period",
        value: to_f64(period),
        reason: match failure {
            ExpmFailure::Overflow => "exp(A period) overflows: the period is too long for this A",
            ExpmFailure::TooStiff => {
                "A period spans scales too far apart for an accurate exp (its slow modes would be \
                 lost in rounding): shorten the period or rescale the states"
            }
        },
    })?;
    Ok((e.view((0, 0), (n, n)).into_owned(), e.view((0, n), (n, m)).into_owned()))
}
