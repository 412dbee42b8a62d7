//! Random numbers, keyed so that sample `i` of a sweep draws from its own streams (key =
//! [seed, i]): its numbers do not depend on which thread runs it or on the other samples, so
//! a sweep is bitwise the same on 1 or 16 threads, and any sample can be replayed alone.
//!
//! - [`Philox`] (Philox4x64-10): a sweep's draws of its samples' robots and states.
//! - [`Sfc64`] (SFC64, started from a Philox stream): the sensors' noise, through the
//!   [`Ziggurat`]'s normals; its lanes draw side by side.
//!
//! Both streams are numpy's (`np.random.Philox(key=[seed, stream]).random_raw()`, and
//! `np.random.SFC64` given the state [`Sfc64::new`] starts from), which lets the pure-Python
//! reference draw the very same numbers.
mod philox;
mod sfc64;
mod ziggurat;
mod ziggurat_tables;

pub use philox::Philox;
pub use sfc64::Sfc64;
pub use ziggurat::Ziggurat;

/// `f64` functions that work with and without std (via nalgebra's RealField).
trait F64Ext {
    fn sqrt_f64(self) -> f64;
    fn sin_f64(self) -> f64;
    fn cos_f64(self) -> f64;
}

impl F64Ext for f64 {
    fn sqrt_f64(self) -> f64 {
        nalgebra::ComplexField::sqrt(self)
    }
    fn sin_f64(self) -> f64 {
        nalgebra::ComplexField::sin(self)
    }
    fn cos_f64(self) -> f64 {
        nalgebra::ComplexField::cos(self)
    }
}

/// A word as a uniform on [0, 1) with 53 random bits (its top 53), as numpy's `random()`.
#[inline]
fn unit_interval(word: u64) -> f64 {
    (word >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

fn ln(x: f64) -> f64 {
    nalgebra::ComplexField::ln(x)
}
