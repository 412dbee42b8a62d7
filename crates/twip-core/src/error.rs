//! The one error type of the core: every fallible call returns `Result<_, TwipError>`.
use core::fmt;

/// Everything that can go wrong on user input, with what is needed to say why.
#[derive(Clone, Debug, PartialEq)]
pub enum TwipError {
    /// A named parameter has a value outside its domain (`reason` says which).
    InvalidParameter { name: &'static str, value: f64, reason: &'static str },
    /// An array or matrix argument has the wrong shape.
    Shape { name: &'static str, expected: (usize, usize), got: (usize, usize) },
    /// A state or input contains NaN or an infinity.
    NonFinite { name: &'static str, index: usize, value: f64 },
    /// The operating point asked for does not exist (e.g. slope too steep to stand on).
    NoEquilibrium { reason: &'static str, value: f64 },
    /// A mass matrix that should be positive definite is singular.
    SingularMassMatrix { det: f64 },
    /// The (A, B) pair cannot be stabilised by state feedback: A's mode at `eigenvalue`
    /// (real and imaginary parts) is unstable and no input reaches it.
    NotStabilizable { eigenvalue: (f64, f64) },
    /// The (A, Q) pair (Q ⪰ 0) has an unobservable mode on the stability boundary, at
    /// `eigenvalue` (real and imaginary parts).
    NotDetectable { eigenvalue: (f64, f64) },
    /// The CARE has no stabilising solution (its Hamiltonian has imaginary-axis eigenvalues).
    NoStabilizingSolution,
    /// An iterative method stopped at its cap without converging.
    NoConvergence { what: &'static str, iterations: usize },
    /// A buffer sized by `name` could not be reserved (the allocator refused `bytes`).
    OutOfMemory { name: &'static str, bytes: u64 },
}

/// A value as a reader wants it in a message: as Rust prints it between 1e-4 and 1e16 (and
/// for 0, infinities and NaN), else in scientific notation, where plain printing would write
/// hundreds of digits (`1e300`, not `1000…000`). The same switch as Python's `repr`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Readable(pub f64);

/// The error for a parameter `name` whose value `v` is refused for `reason`.
pub(crate) fn invalid<T: crate::Real>(name: &'static str, v: T, reason: &'static str) -> TwipError {
    TwipError::InvalidParameter { name, value: crate::to_f64(v), reason }
}

impl fmt::Display for Readable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        let plain = v == 0.0 || !v.is_finite() || (1e-4..1e16).contains(&v.abs());
        if plain {
            write!(f, "{v}")
        } else {
            write!(f, "{v:e}")
        }
    }
}

/// An eigenvalue (re, im) as a message gives it: `λ = 1.5`, `λ = 0.2 ± 3i` (the pair).
struct Eigenvalue((f64, f64));

impl fmt::Display for Eigenvalue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (re, im) = self.0;
        if im == 0.0 {
            write!(f, "λ = {}", Readable(re))
        } else {
            write!(f, "λ = {} ± {}i", Readable(re), Readable(im.abs()))
        }
    }
}

impl fmt::Display for TwipError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TwipError::InvalidParameter { name, value, reason } => {
                write!(f, "invalid {name} = {}: {reason}", Readable(*value))
            }
            TwipError::Shape { name, expected, got } => write!(
                f,
                "{name} has shape {}x{}, expected {}x{}",
                got.0, got.1, expected.0, expected.1
            ),
            TwipError::NonFinite { name, index, value } => {
                write!(f, "{name}[{index}] = {} is not finite", Readable(*value))
            }
            TwipError::NoEquilibrium { reason, value } => {
                write!(f, "no equilibrium: {reason} (value {})", Readable(*value))
            }
            TwipError::SingularMassMatrix { det } => {
                write!(f, "mass matrix is singular (determinant {})", Readable(*det))
            }
            TwipError::NotStabilizable { eigenvalue } => write!(
                f,
                "the pair (A, B) is not stabilizable: A's mode at {} is unstable and no input reaches \
                 it, so no gain can stabilise it",
                Eigenvalue(*eigenvalue)
            ),
            TwipError::NotDetectable { eigenvalue } => write!(
                f,
                "the pair (A, Q) is not detectable: A's undamped mode at {} is invisible to the cost, \
                 so no stabilising solution exists",
                Eigenvalue(*eigenvalue)
            ),
            TwipError::NoStabilizingSolution => write!(
                f,
                "the Riccati equation has no stabilising solution: its Hamiltonian has eigenvalues \
                 on the imaginary axis (check Q, or that the undamped modes of A are visible in Q)"
            ),
            TwipError::NoConvergence { what, iterations } => {
                write!(f, "{what} did not converge within {iterations} iterations")
            }
            TwipError::OutOfMemory { name, bytes } => {
                write!(f, "{name}: could not reserve {bytes} bytes of memory")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for TwipError {}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use std::string::ToString;

    #[test]
    fn values_print_readably_at_any_magnitude() {
        let shown = |v: f64| TwipError::InvalidParameter { name: "m_body", value: v, reason: "r" }.to_string();
        assert_eq!(shown(1e300), "invalid m_body = 1e300: r", "not 301 digits");
        assert_eq!(shown(-1e39), "invalid m_body = -1e39: r");
        assert_eq!(shown(1e-50), "invalid m_body = 1e-50: r", "not 50 zeros");
        assert_eq!(shown(0.005), "invalid m_body = 0.005: r");
        assert_eq!(shown(-2.5), "invalid m_body = -2.5: r");
        assert_eq!(shown(0.0), "invalid m_body = 0: r");
        assert_eq!(shown(f64::NEG_INFINITY), "invalid m_body = -inf: r");
        assert_eq!(shown(1234567.0), "invalid m_body = 1234567: r");
        assert_eq!(shown(1e16), "invalid m_body = 1e16: r");
        let nonfinite = TwipError::NonFinite { name: "x0", index: 2, value: f64::NAN }.to_string();
        assert_eq!(nonfinite, "x0[2] = NaN is not finite");
    }
}
