//! The DARE's symplectic pencil, compressed from SciPy's extended pencil, and its Cayley
//! transform: a Hamiltonian matrix whose stable invariant subspace is the pencil's stable
//! deflating subspace `[I; X]`.
use nalgebra::{DMatrix, QR};

use crate::control::care::checks::symmetrise;
use crate::Real;

/// The Hamiltonian `Z = (M + N)⁻¹ (M − N) = [[Ac, −Gc], [−Qc, −Acᵀ]]` as `(Ac, Gc, Qc)`, or
/// `None` when `M + N` is singular (−1 is an eigenvalue of the pencil, or the pencil is
/// singular: no stabilising solution either way).
///
/// `M − λN` is the extended pencil of the DARE (size 2n+m, columns `[x; p; u]`)
///
/// ```text
/// [[A, 0, B], [−Q, I, 0], [0, 0, R]] − λ [[I, 0, 0], [0, Aᵀ, 0], [0, −Bᵀ, 0]]
/// ```
///
/// with the `u` columns removed by the orthogonal complement of `[B; 0; R]` (a QR
/// decomposition): R need not be invertible. The pencil satisfies `M J Mᵀ = N J Nᵀ`
/// (for invertible R it is a left multiple of `[[A, 0], [−Q, I]] − λ [[I, G], [0, Aᵀ]]`,
/// and the identity survives left multiplication), hence `Z` is Hamiltonian; the Cayley
/// map μ = (λ − 1)/(λ + 1) sends the unit circle to the imaginary axis and λ = 0, ∞ to ∓1.
pub(crate) fn cayley_hamiltonian<T: Real>(
    a: &DMatrix<T>,
    b: &DMatrix<T>,
    q: &DMatrix<T>,
    r: &DMatrix<T>,
) -> Option<(DMatrix<T>, DMatrix<T>, DMatrix<T>)> {
    let (n, m) = b.shape();
    let rows = 2 * n + m;
    let mut inputs = DMatrix::<T>::zeros(rows, m);
    inputs.view_mut((0, 0), (n, m)).copy_from(b);
    inputs.view_mut((2 * n, 0), (m, m)).copy_from(r);
    // [E | F] = [M + N | M − N] on the first 2n columns of the extended pencil.
    let mut ef = DMatrix::<T>::zeros(rows, 4 * n);
    for j in 0..n {
        for i in 0..n {
            let (aij, aji, qij) = (a[(i, j)], a[(j, i)], q[(i, j)]);
            let eye = if i == j { T::one() } else { T::zero() };
            // M: [[A, 0], [−Q, I], [0, 0]]; N: [[I, 0], [0, Aᵀ], [0, −Bᵀ]].
            ef[(i, j)] = aij + eye;
            ef[(i, 2 * n + j)] = aij - eye;
            ef[(n + i, j)] = -qij;
            ef[(n + i, 2 * n + j)] = -qij;
            ef[(n + i, n + j)] = eye + aji;
            ef[(n + i, 3 * n + j)] = eye - aji;
        }
        for i in 0..m {
            ef[(2 * n + i, n + j)] = -b[(j, i)];
            ef[(2 * n + i, 3 * n + j)] = b[(j, i)];
        }
    }
    QR::new(inputs).q_tr_mul(&mut ef);
    let e = ef.view((m, 0), (2 * n, 2 * n)).into_owned();
    let f = ef.view((m, 2 * n), (2 * n, 2 * n)).into_owned();
    let z = e.lu().solve(&f)?;
    if z.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let ac = z.view((0, 0), (n, n)).into_owned();
    let gc = symmetrise(-z.view((0, n), (n, n)).into_owned());
    let qc = symmetrise(-z.view((n, 0), (n, n)).into_owned());
    Some((ac, gc, qc))
}
