//! The one trait every plant model implements.
use nalgebra::SVector;

use crate::model::integrate::Stage;
use crate::Real;

/// A continuous-time plant `ẋ = f(x, u)` with `NX` states and `NU` inputs.
pub trait Dynamics<T: Real, const NX: usize, const NU: usize> {
    /// Index of the body pitch in the state (the runner's fall detection reads it).
    const PITCH: usize = 0;

    /// The state derivative. Pure: no allocation, no internal state.
    fn deriv(&self, x: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NX>;

    /// The derivative at a later stage of an RK4 step (`deriv` is its first): `deriv`, but
    /// for a plant whose input moves within the step (an inductive winding's current,
    /// which the plant sets up between steps).
    #[inline(always)]
    fn deriv_at_stage(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, _stage: Stage) -> SVector<T, NX> {
        self.deriv(x, u)
    }

    /// Total mechanical energy (kinetic + potential) where the model defines one.
    fn energy(&self, x: &SVector<T, NX>) -> T;

    /// Whether a run must end at state `x` under the input `u` held over the last step,
    /// and why (the terrain model's lifted wheel or edge of its grid). None for the rest.
    #[inline(always)]
    fn halted(&self, _x: &SVector<T, NX>, _u: &SVector<T, NU>) -> Option<Halt> {
        None
    }
}

/// Why a model ends a run that has neither fallen nor diverged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Halt {
    /// A wheel's normal force went below zero: it leaves the ground, which the model
    /// (both wheels on the ground) does not describe.
    Lifted,
    /// The contact point left the terrain (a grid's edge): there is no ground to extrapolate.
    OffTerrain,
}
