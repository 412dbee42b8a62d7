//! The roles around a plant: references the robot should follow and the controllers
//! that make it. Controllers are discrete-time: the runner calls `update` once per
//! `period` and holds the input in between (zero-order hold).
//!
//! Submodules: the CARE solver and LQR design, the controller families (LQR with integral
//! action, fuzzy adaptive backstepping + PD on the fuzzy basis, PID and sliding-mode
//! trackers), the speed references and the planar trajectories.
#[cfg(feature = "alloc")]
pub mod care;
#[cfg(feature = "alloc")]
pub mod c2d;
#[cfg(feature = "alloc")]
pub mod dare;
pub mod fuzzy;
pub mod fuzzy_basis;
pub mod fuzzy_grid;
pub mod grade;
pub mod lqr;
#[cfg(feature = "alloc")]
pub mod lqr_discrete;
pub mod pid;
pub mod reference;
pub mod smc;
pub mod trajectory;

use nalgebra::SVector;

use crate::Real;

/// A schedule of what the robot should do, sampled at time `t`.
pub trait Reference<T: Real> {
    type Sample: Copy;
    fn sample(&self, t: T) -> Self::Sample;
}

/// A discrete-time controller with its own period and internal state.
pub trait Controller<T: Real, const NX: usize, const NU: usize> {
    /// What the controller follows (a speed schedule, a planar trajectory…).
    type Reference: Copy;

    /// Update period [s].
    fn period(&self) -> T;

    /// Back to the initial internal state (integrators, adaptive weights).
    fn reset(&mut self);

    /// The input to hold until the next update, from the measurement `y` at time `t`.
    fn update(&mut self, t: T, y: &SVector<T, NX>, reference: &Self::Reference) -> SVector<T, NU>;

    /// Signals worth plotting, as of the last update, named by [`Self::internal_names`].
    fn internals(&self) -> &[T];

    fn internal_names(&self) -> &'static [&'static str];
}
