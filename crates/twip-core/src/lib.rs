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

#[cfg(feature = "alloc")]
pub mod care;
pub mod control;
pub mod disturbance;
pub mod drive;
pub mod dynamics;
pub mod encoder;
pub mod error;
pub mod fuzzy;
pub mod fuzzy_control;
pub mod imu;
pub mod integrate;
#[cfg(feature = "alloc")]
pub mod log;
pub mod lqr_control;
pub mod math;
pub mod metrics;
pub mod motor;
pub mod params;
pub mod pid_tracking;
pub mod planar;
pub mod reference;
pub mod realism;
pub mod rng;
pub mod runner;
pub mod slope;
pub mod smc_tracking;
pub mod tilt;
#[cfg(feature = "std")]
pub mod sweep;
pub mod tracking_metrics;
pub mod trajectory;

#[cfg(feature = "alloc")]
pub use care::{care, lqr, Lqr};
pub use dynamics::Dynamics;
pub use error::TwipError;
pub use integrate::rk4_step;
pub use params::RobotParams;
pub use planar::PlanarModel;

pub use slope::SlopeModel;

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
