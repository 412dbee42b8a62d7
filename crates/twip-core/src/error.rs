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
    /// The (A, B) pair cannot be stabilised by state feedback.
    NotStabilizable,
    /// The (A, Q) pair (Q ⪰ 0) has an unobservable mode on the imaginary axis.
    NotDetectable,
    /// The CARE has no stabilising solution (its Hamiltonian has imaginary-axis eigenvalues).
    NoStabilizingSolution,
    /// An iterative method stopped at its cap without converging.
    NoConvergence { what: &'static str, iterations: usize },
    /// A buffer sized by `name` could not be reserved (the allocator refused `bytes`).
    OutOfMemory { name: &'static str, bytes: u64 },
}

impl fmt::Display for TwipError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TwipError::InvalidParameter { name, value, reason } => {
                write!(f, "invalid {name} = {value}: {reason}")
            }
            TwipError::Shape { name, expected, got } => write!(
                f,
                "{name} has shape {}x{}, expected {}x{}",
                got.0, got.1, expected.0, expected.1
            ),
            TwipError::NonFinite { name, index, value } => {
                write!(f, "{name}[{index}] = {value} is not finite")
            }
            TwipError::NoEquilibrium { reason, value } => {
                write!(f, "no equilibrium: {reason} (value {value})")
            }
            TwipError::SingularMassMatrix { det } => {
                write!(f, "mass matrix is singular (determinant {det})")
            }
            TwipError::NotStabilizable => {
                write!(f, "the pair (A, B) is not stabilizable: no gain can stabilise it")
            }
            TwipError::NotDetectable => write!(
                f,
                "the pair (A, Q) is not detectable: an undamped mode of A is invisible to the cost, \
                 so no stabilising solution exists"
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
