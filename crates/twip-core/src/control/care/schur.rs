//! The real Schur form with an iteration cap, and the eigenvalues of its blocks.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use alloc::vec::Vec;

use nalgebra::DMatrix;

use super::*;

pub(crate) fn schur_cap(n: usize) -> usize {
    100 + 40 * n
}

/// Real Schur form `M = U T Uᵀ` with an iteration cap. nalgebra's QR sweeps have no
/// exceptional shifts; if they stall, a second try runs on an orthogonally similar matrix,
/// a third on `Mᵀ` (CAREX #6, n = 30, stalls on every orthogonal similarity tried, not on
/// its transpose).
pub(crate) fn schur<T: Real>(m: DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
    schur_direct(m.clone())
        .or_else(|| schur_reflected(m.clone()))
        .or_else(|| schur_transposed(m))
}

pub(crate) fn schur_direct<T: Real>(m: DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
    let cap = schur_cap(m.nrows());
    // nalgebra rescales only from 3×3 up; a power of two keeps 2×2 blocks from overflowing.
    let k = pow2_exponent::<T>(m.amax());
    let m = scaled_pow2(&m, -k);
    Schur::try_new(m, T::default_epsilon(), cap).map(|s| {
        let (u, t) = s.unpack();
        (u, scaled_pow2(&t, k))
    })
}

/// Schur form of `P M P` with the reflector `P = I − 2 v vᵀ / (vᵀ v)` (symmetric,
/// orthogonal), mapped back: `M = (P U) T (P U)ᵀ`.
pub(crate) fn schur_reflected<T: Real>(m: DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
    let n = m.nrows();
    let v = DMatrix::<T>::from_fn(n, 1, |i, _| T::one() / c::<T>((i + 2) as f64));
    let p = DMatrix::<T>::identity(n, n) - (&v * v.transpose()) * (c::<T>(2.0) / v.norm_squared());
    let (u, t) = schur_direct(&p * m * &p)?;
    Some((p * u, t))
}

/// Schur form of `M` from that of `Mᵀ = V S Vᵀ`: with the index reversal `P`,
/// `M = (V P) (P Sᵀ P) (V P)ᵀ`, and `P Sᵀ P` is upper quasi-triangular again (the 2×2 blocks
/// stay on the diagonal, each transposed and reversed).
pub(crate) fn schur_transposed<T: Real>(m: DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
    let n = m.nrows();
    let (v, s) = schur_direct(m.transpose())?;
    let u = DMatrix::from_fn(n, n, |i, j| v[(i, n - 1 - j)]);
    let t = DMatrix::from_fn(n, n, |i, j| s[(n - 1 - j, n - 1 - i)]);
    Some((u, t))
}

/// The diagonal blocks (start, size) of a real quasi-triangular Schur factor.
pub(crate) fn quasi_blocks<T: Real>(t: &DMatrix<T>) -> Vec<(usize, usize)> {
    let n = t.nrows();
    let mut blocks = Vec::with_capacity(n);
    let mut i = 0;
    while i < n {
        if i + 1 < n && !t[(i + 1, i)].is_zero() {
            blocks.push((i, 2));
            i += 2;
        } else {
            blocks.push((i, 1));
            i += 1;
        }
    }
    blocks
}

/// Eigenvalues of a real quasi-triangular matrix, from its 1×1 and 2×2 diagonal blocks.
pub(crate) fn quasi_eigenvalues<T: Real>(t: &DMatrix<T>) -> Vec<Complex<T>> {
    let mut out = Vec::with_capacity(t.nrows());
    for (i, size) in quasi_blocks(t) {
        if size == 1 {
            out.push(Complex::new(t[(i, i)], T::zero()));
            continue;
        }
        let (a, b, cc, d) = (t[(i, i)], t[(i, i + 1)], t[(i + 1, i)], t[(i + 1, i + 1)]);
        // On the block scaled to unit size, so that the discriminant cannot overflow.
        let size = a.abs().max(b.abs()).max(cc.abs()).max(d.abs());
        let size = if size > T::zero() { size } else { T::one() };
        let (a, b, cc, d) = (a / size, b / size, cc / size, d / size);
        let half_tr = (a + d) * c::<T>(0.5);
        let half_diff = (a - d) * c::<T>(0.5);
        let disc = half_diff * half_diff + b * cc;
        if disc >= T::zero() {
            let s = disc.sqrt();
            out.push(Complex::new((half_tr - s) * size, T::zero()));
            out.push(Complex::new((half_tr + s) * size, T::zero()));
        } else {
            let s = (-disc).sqrt();
            out.push(Complex::new(half_tr * size, s * size));
            out.push(Complex::new(half_tr * size, -s * size));
        }
    }
    out
}


/// The eigenvalues of `m`, sorted by real part then imaginary part (the poles of a closed loop).
pub(crate) fn sorted_eigenvalues<T: Real>(m: DMatrix<T>) -> Result<Vec<Complex<T>>, TwipError> {
    let n = m.nrows();
    let (_, t) = schur(m).ok_or(TwipError::NoConvergence {
        what: "Schur decomposition of the closed loop A - B K",
        iterations: schur_cap(n),
    })?;
    let mut poles = quasi_eigenvalues(&t);
    poles.sort_by(|u, v| {
        u.re.partial_cmp(&v.re)
            .unwrap_or(Ordering::Equal)
            .then(u.im.partial_cmp(&v.im).unwrap_or(Ordering::Equal))
    });
    Ok(poles)
}
