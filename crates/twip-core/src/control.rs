//! The roles around a plant: references the robot should follow and the controllers
//! that make it. Controllers are discrete-time: the runner calls `update` once per
//! `period` and holds the input in between (zero-order hold).
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
