//! twip-core: physics and control of two-wheeled inverted pendulum (TWIP) robots.
//!
//! The models follow the thesis *Fuzzy Adaptive Control of a Two-Wheeled Inverted
//! Pendulum*, re-derived from the Lagrangian; every place where the code differs from
//! the printed equations is listed in `docs/errata.md`.
//!
//! `#![no_std]` unless the `std` feature is on; nothing on the simulation hot path
//! allocates. Everything is generic over the scalar (`f32` for a microcontroller,
//! `f64` for analysis) through [`Real`].
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(feature = "alloc")]
extern crate alloc;

pub mod control;
pub mod error;
pub mod hardware;
pub mod model;
pub mod rng;
pub mod sim;
pub mod sysid;
#[cfg(feature = "std")]
pub mod sweep;
#[cfg(feature = "parallel")]
pub mod envs;

#[cfg(feature = "alloc")]
pub use control::care::{care, lqr, Lqr};
#[cfg(feature = "alloc")]
pub use control::c2d::c2d;
#[cfg(feature = "alloc")]
pub use control::dare::{dare, dlqr};
pub use model::dynamics::Dynamics;
pub use error::{Readable, TwipError};
pub use model::integrate::rk4_step;
pub use model::params::RobotParams;
pub use model::planar::PlanarModel;
pub use model::slope::SlopeModel;

/// The scalar every model is generic over: `f32` or `f64`.
pub trait Real: nalgebra::RealField + Copy {}
impl<T: nalgebra::RealField + Copy> Real for T {}

/// Converts an `f64` constant into the scalar type.
#[inline(always)]
pub(crate) fn c<T: Real>(v: f64) -> T {
    nalgebra::convert(v)
}

/// Converts a scalar to `f64` for error messages.
#[inline]
pub(crate) fn to_f64<T: Real>(v: T) -> f64 {
    v.to_subset().unwrap_or(f64::NAN)
}
