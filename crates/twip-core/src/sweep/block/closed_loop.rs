//! The lanes' side of the one closed-loop step (`sim::closed_loop`), ideal and through a rig,
//! 2-DOF and 3-DOF alike: the loop's [`Hooks`] on a block of lanes, made of a [`Plant`] (its
//! state, what the law reads, how its input reaches the plants, the step, the ground) and an
//! [`Observer`] (the reference's bookkeeping, the metrics), whose hooks each kernel's shape
//! has, inlined into the loop, so each kernel is one function as before.
use super::{finite_at, go_on};
use super::law::{LaneLaw, Ref, Shape, U, X};
use crate::model::dynamics::Halt;
use crate::sim::closed_loop::{self as one, Ended, Hooks};
pub(super) use crate::sim::closed_loop::Aligned;
use crate::sim::runner::SimConfig;
use crate::sweep::lanes::{Lanes, LANES};

/// A shape's input lanes, as the loop checks them.
pub trait Inputs: Copy {
    /// Zero on every lane.
    const ZERO: Self;
    /// Whether lane `l`'s every input is finite.
    fn finite_at(&self, l: usize) -> bool;
}

impl Inputs for Lanes {
    const ZERO: Self = [0.0; LANES];

    #[inline(always)]
    fn finite_at(&self, l: usize) -> bool {
        self[l].is_finite()
    }
}

impl<const N: usize> Inputs for [Lanes; N] {
    const ZERO: Self = [[0.0; LANES]; N];

    #[inline(always)]
    fn finite_at(&self, l: usize) -> bool {
        finite_at(self, l)
    }
}

/// The lanes whose input `u` is not finite: an ideal plant's drive that diverged
/// (`Plant::apply`).
#[inline(always)]
pub(super) fn not_finite<U: Inputs>(u: &U) -> [bool; LANES] {
    core::array::from_fn(|l| !u.finite_at(l))
}

/// The plant side of a block of lanes in the loop: where its state lives, what the law reads
/// (the state, or a rig's sensors), how its input reaches the plants (as is, or through a
/// rig's drivers, delay and play) and the step. Every hook is `#[inline(always)]`: the loop
/// with its hooks is each kernel's one function, as when each kernel wrote it out.
pub(super) trait Plant {
    /// The model.
    type Shape: Shape;
    /// Every lane's state.
    fn state(&self) -> &X<Self::Shape>;
    fn state_mut(&mut self) -> &mut X<Self::Shape>;
    /// Every lane's input `u` from `controller` at time `t`, on what it reads (with what the
    /// ground feeds forward). `COPY`: the kernel copy that runs the loop (`out_of_line_in`),
    /// here and below.
    fn update<C: LaneLaw<Shape = Self::Shape>, const COPY: u8>(&mut self, controller: &mut C, state: &mut C::State, t: f64, r: &Ref<Self::Shape>, u: &mut U<Self::Shape>);
    /// The law's input `u` at `t` applied from now on; returns the lanes whose drive is not
    /// finite (diverged).
    fn apply(&mut self, t: f64, u: &U<Self::Shape>) -> [bool; LANES];
    /// What the metrics observe as the input, the law's input being `u`: the command the
    /// plants get now (a delayed rig's: the last period's).
    fn command<'s>(&'s self, u: &'s U<Self::Shape>) -> &'s U<Self::Shape>;
    /// Step `k` (of `dt`) under the input held, on every lane: the new state, into `next` (the
    /// caller moves the lanes that go on there). A rig tells `drive` what its plants got at the
    /// step's start and whether each lane's command is beyond its driver (`Observer::drive`);
    /// ideal plants get `u`, and do not.
    fn step<const COPY: u8>(&mut self, k: usize, u: &U<Self::Shape>, dt: f64, drive: impl FnOnce(&U<Self::Shape>, &[bool; LANES]), next: &mut X<Self::Shape>);
    /// [`Self::step`], knowing which lanes are `live` (only their new states count).
    #[inline(always)]
    fn step_live<const COPY: u8>(&mut self, k: usize, u: &U<Self::Shape>, dt: f64, live: &[bool; LANES], drive: impl FnOnce(&U<Self::Shape>, &[bool; LANES]), next: &mut X<Self::Shape>) {
        let _ = live;
        self.step::<COPY>(k, u, dt, drive, next);
    }
    /// What ends each lane at `next` under `u` besides a fall (None: nothing can).
    fn halts<const COPY: u8>(&self, next: &X<Self::Shape>, u: &U<Self::Shape>) -> Option<[Option<Halt>; LANES]>;
}

/// What a block's metrics do in the loop: the reference they measure against, their
/// observations, the lanes' ends and the block's result. Every hook is `#[inline(always)]`.
pub(super) trait Observer {
    /// The model.
    type Shape: Shape;
    /// The block's metrics, one entry per lane.
    type Out;
    /// The state's entry whose magnitude past the fall limit is a fall: the pitch.
    const PITCH: usize;
    /// The reference at time `t`, the same for every lane (sampled once per step).
    fn reference(&mut self, t: f64) -> Ref<Self::Shape>;
    /// Observes the lanes that are `live` at time `t` in state `x` under input `u`.
    fn observe(&mut self, live: &[bool; LANES], t: f64, x: &X<Self::Shape>, u: &U<Self::Shape>, r: &Ref<Self::Shape>);
    /// What the `live` lanes' plants got at a step's start (`delivered`), and at a controller
    /// update (`update`) whether each lane's command applied from then on is `beyond` its driver.
    fn drive(&mut self, live: &[bool; LANES], delivered: &U<Self::Shape>, update: bool, beyond: &[bool; LANES]);
    /// Lane `l` has ended in `x` at `t` (fallen, or halted for `halt`): the runner observes
    /// that state, then stops.
    fn observe_end(&mut self, l: usize, t: f64, x: &X<Self::Shape>, u: &U<Self::Shape>, halt: Option<Halt>);
    /// The runner's last observation at `t_end` (after `n` steps) of the lanes still `alive`,
    /// then every `active` lane's metrics, with how each `ended` ((fell, t_end, steps)).
    #[allow(clippy::type_complexity)]
    fn finish(self, lanes: (&[bool; LANES], &[bool; LANES], &mut [(bool, f64, u64); LANES]), x: &X<Self::Shape>, u: &U<Self::Shape>, end: (f64, usize)) -> Self::Out;
}

/// The one closed loop (`sim::closed_loop`) on a block of lanes, the `active` lanes' starts
/// in `plant`, `n` steps with the law `controller` updated every `per_update`. A lane that
/// ends diverged, fallen or halted ends as fallen (`SampleMetrics::fell`). `should_stop` is
/// asked every `runner::STOP_CHECK_STEPS` steps; None means it said yes.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn closed_loop<C, P, O, const NX: usize, const COPY: u8>(
    controller: &mut C,
    plant: P,
    observer: O,
    active: [bool; LANES],
    steps: (usize, usize),
    config: &SimConfig<f64>,
    should_stop: &dyn Fn() -> bool,
) -> Option<O::Out>
where
    P: Plant,
    O: Observer<Shape = P::Shape>,
    P::Shape: Shape<X = [Lanes; NX]>,
    C: LaneLaw<Shape = P::Shape>,
{
    one::closed_loop::<C, _, LANES, COPY>(controller, Block { plant, observer }, active, steps, config, should_stop).ok()
}

/// A block's plant and observer, as the one loop's hooks.
struct Block<P, O> {
    plant: P,
    observer: O,
}

impl<C, P, O, const NX: usize> Hooks<C, LANES> for Block<P, O>
where
    P: Plant,
    O: Observer<Shape = P::Shape>,
    P::Shape: Shape<X = [Lanes; NX]>,
    C: LaneLaw<Shape = P::Shape>,
{
    type T = f64;
    type X = [Lanes; NX];
    type U = U<P::Shape>;
    type Ref = Ref<P::Shape>;
    type LawState = C::State;
    type Out = O::Out;

    #[inline(always)]
    fn no_input() -> Self::U {
        <U<P::Shape> as Inputs>::ZERO
    }

    #[inline(always)]
    fn start(controller: &C) -> C::State {
        controller.start()
    }

    #[inline(always)]
    fn reference(&mut self, t: f64) -> Self::Ref {
        self.observer.reference(t)
    }

    #[inline(always)]
    fn update<const COPY: u8>(&mut self, controller: &mut C, state: &mut C::State, t: f64, r: &Self::Ref, u: &mut Self::U) -> [bool; LANES] {
        self.plant.update::<C, COPY>(controller, state, t, r, u);
        self.plant.apply(t, u)
    }

    #[inline(always)]
    fn observe(&mut self, live: &[bool; LANES], t: f64, _: &C, u: &Self::U, r: &Self::Ref) {
        self.observer.observe(live, t, self.plant.state(), self.plant.command(u), r);
    }

    #[inline(always)]
    fn step<const COPY: u8>(&mut self, k: usize, _: f64, update: bool, live: &[bool; LANES], u: &Self::U, dt: f64, next: &mut [Lanes; NX]) {
        let Self { plant, observer } = self;
        plant.step_live::<COPY>(k, u, dt, live, |delivered, beyond| observer.drive(live, delivered, update, beyond), next);
    }

    #[inline(always)]
    fn state(&self) -> &[Lanes; NX] {
        self.plant.state()
    }

    #[inline(always)]
    fn halts<const COPY: u8>(&self, next: &[Lanes; NX], u: &Self::U) -> Option<[Option<Halt>; LANES]> {
        self.plant.halts::<COPY>(next, u)
    }

    #[inline(always)]
    fn go_on(&mut self, next: &[Lanes; NX], alive: &[bool; LANES], fall_limit: f64) -> ([u64; LANES], bool) {
        go_on(self.plant.state_mut(), next, alive, O::PITCH, fall_limit)
    }

    #[inline(always)]
    fn finite_at(x: &[Lanes; NX], l: usize) -> bool {
        finite_at(x, l)
    }

    #[inline(always)]
    fn observe_end(&mut self, l: usize, next: &[Lanes; NX], t: f64, _: &C, u: &Self::U, halt: Option<Halt>) {
        let x = self.plant.state_mut();
        for i in 0..NX {
            x[i][l] = next[i][l];
        }
        self.observer.observe_end(l, t, self.plant.state(), self.plant.command(u), halt);
    }

    #[inline(always)]
    fn finish(self, (alive, active, ended): (&[bool; LANES], &[bool; LANES], &Ended<f64, LANES>), _: &C, u: &Self::U, end: (f64, usize)) -> O::Out {
        // Every lane that ended before the end counts as fallen.
        let mut ended = ended.map(|(_, t, steps)| (true, t, steps));
        self.observer.finish((alive, active, &mut ended), self.plant.state(), self.plant.command(u), end)
    }
}
