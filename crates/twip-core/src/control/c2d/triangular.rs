//! Upper-triangular exponentials: a permutation that makes a matrix upper triangular, and
//! the exact diagonal and first superdiagonal of `exp(2⁻ⁱ T)` that the squaring phase puts
//! back after each squaring (Al-Mohy & Higham 2009, §2; SciPy's `expm` does the same). The
//! diagonal of a stiff triangular block, e.g. `diag(−1e20, −1)`, is then exact instead of lost
//! in the rounding of `1 − 2⁻ˢ`.
use alloc::vec::Vec;

use nalgebra::DMatrix;

use crate::{c, Real};

/// An order of the indices in which `m` is upper triangular (`m[i][j] ≠ 0`, i ≠ j, only
/// for i before j), or `None`. Kahn's topological sort, the smallest index first so that an
/// already triangular `m` keeps the identity order.
pub(crate) fn triangular_order<T: Real>(m: &DMatrix<T>) -> Option<Vec<usize>> {
    let n = m.nrows();
    let mut before = (0..n).map(|j| (0..n).filter(|&i| i != j && !m[(i, j)].is_zero()).count()).collect::<Vec<_>>();
    let mut placed = alloc::vec![false; n];
    let mut order = Vec::with_capacity(n);
    for _ in 0..n {
        let next = (0..n).find(|&j| !placed[j] && before[j] == 0)?;
        placed[next] = true;
        order.push(next);
        for j in 0..n {
            if j != next && !m[(next, j)].is_zero() {
                before[j] -= 1;
            }
        }
    }
    Some(order)
}

/// `x · 2^k` in two steps, so that 2^k itself neither overflows nor underflows.
pub(crate) fn times_pow2<T: Real>(x: T, k: i32) -> T {
    let two = c::<T>(2.0);
    x * two.powi(k / 2) * two.powi(k - k / 2)
}

/// `(e^b − e^a) / (b − a)`, the divided difference of exp, without cancellation
/// (Higham 2008, eq. 10.42: `e^((a+b)/2) sinh(h)/h`, h = (b − a)/2, for |h| ≤ 1).
fn exp_divided_difference<T: Real>(a: T, b: T) -> T {
    let h = (b - a) * c::<T>(0.5);
    if h.is_zero() {
        a.exp()
    } else if h.abs() <= T::one() {
        ((a + b) * c::<T>(0.5)).exp() * (h.sinh() / h)
    } else {
        (b.exp() - a.exp()) / (b - a)
    }
}

/// Puts the exact diagonal and first superdiagonal of `exp(2^−i t)` into `x` (`t` upper
/// triangular, `x` its computed exponential).
pub(crate) fn fix_diagonals<T: Real>(x: &mut DMatrix<T>, t: &DMatrix<T>, i: i32) {
    let n = t.nrows();
    let scaled = |r: usize, col: usize| times_pow2(t[(r, col)], -i);
    for k in 0..n {
        x[(k, k)] = scaled(k, k).exp();
    }
    for k in 0..n.saturating_sub(1) {
        x[(k, k + 1)] = scaled(k, k + 1) * exp_divided_difference(scaled(k, k), scaled(k + 1, k + 1));
    }
}
