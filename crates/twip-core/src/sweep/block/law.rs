//! The one trait of a controller's law on lanes ([`LaneLaw`]), written in the quantities of
//! the model it controls: its [`Shape`], 2-DOF ([`Slope`]) or 3-DOF ([`Planar`]). The lanes'
//! kernels ask a law for inputs through it alike, whatever the model.
use super::closed_loop::Inputs;
use super::out_of_line_in;
use crate::control::reference::SpeedRef;
use crate::control::trajectory::PlanarRef;
use crate::sweep::lanes::Lanes;

/// What a block of lanes on one model holds, one array per quantity, one entry per lane.
pub trait Shape {
    /// Every lane's plant state.
    type X;
    /// Every lane's input.
    type U: Inputs;
    /// The reference, the same for every lane (sampled once per step).
    type Ref;
}

/// The 2-DOF slope model: state [φ, φ̇, θ, θ̇], the motor current u [A], a speed reference.
pub struct Slope;

impl Shape for Slope {
    type X = [Lanes; 4];
    type U = Lanes;
    type Ref = SpeedRef<f64>;
}

/// The 3-DOF planar model: state [x, y, ψ, φ, φ̇, v, ω], the wheel torques [u_r, u_l] [N m],
/// a point moving along a path.
pub struct Planar;

impl Shape for Planar {
    type X = [Lanes; 7];
    type U = [Lanes; 2];
    type Ref = PlanarRef<f64>;
}

/// A shape's plant state, input and reference.
pub type X<S> = <S as Shape>::X;
pub type U<S> = <S as Shape>::U;
pub type Ref<S> = <S as Shape>::Ref;

/// A controller's law on lanes: the sweep's prototype, with each lane's own state.
pub trait LaneLaw {
    /// The model it controls.
    type Shape: Shape;
    /// Every lane's controller state, one array per quantity.
    type State;
    /// The control period [s].
    fn period(&self) -> f64;
    /// The state every lane starts from (the prototype's, reset).
    fn start(&self) -> Self::State;
    /// Every lane's input `u` for its true state `x` (sweeps sense ideally; a rig's lanes
    /// pass what its sensors read) and the reference `r`. Lanes that have ended compute on
    /// and are never kept. `COPY` is the kernel copy that asks (a
    /// [`KernelCopy`](super::KernelCopy) as `u8`), for a law that runs out of line in it
    /// ([`out_of_line_in`]).
    fn update<const COPY: u8>(&mut self, state: &mut Self::State, x: &X<Self::Shape>, r: &Ref<Self::Shape>, u: &mut U<Self::Shape>);
    /// [`Self::update`], given a 2-DOF plant's sin and cos of each lane's pitch x[0], which
    /// hold where |x[0]| ≤ `math::UNREDUCED` (taken there without the reduction by π/2), for a
    /// law that reads them rather than taking its own; the others ignore them.
    #[inline(always)]
    fn update_at_pitch<const COPY: u8>(&mut self, state: &mut Self::State, x: &X<Self::Shape>, pitch: &[Lanes; 2], r: &Ref<Self::Shape>, u: &mut U<Self::Shape>) {
        let _ = pitch;
        self.update::<COPY>(state, x, r, u)
    }
}

/// `controller.update` as a function of its own per law and kernel copy (`out_of_line_in`),
/// for the kernels where the law runs once per control period beside much more work: the
/// rigs' and the terrain's. Inlined there (three times in the 3-DOF rig kernel: flat ground,
/// terrain, terrain with feed-forward), the sliding-mode law made the rig kernel's three copies
/// 47 % of the wheel's optimiser time (LLVM's time trace: loop rotation, SROA and full
/// unrolling over one huge function). The ideal flat kernels keep it inlined.
#[inline(always)]
pub(super) fn update_out_of_line<C: LaneLaw, const COPY: u8>(controller: &mut C, state: &mut C::State, x: &X<C::Shape>, r: &Ref<C::Shape>, u: &mut U<C::Shape>) {
    out_of_line_in::<COPY, _>(#[inline(always)] || controller.update::<COPY>(state, x, r, u))
}
