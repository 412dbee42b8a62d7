//! The one closed-loop step of the lanes, ideal and through a rig, 2-DOF and 3-DOF alike:
//! `runner::run_loop`'s loop over a block of lanes, step for step. What differs between the
//! kernels are the hooks of a [`Shape`], inlined into the loop, so each kernel is one function
//! as before: the [`Plant`] (its state, what the law reads, how its input reaches the plants,
//! the step, the ground) and the [`Observer`] (the reference's bookkeeping, the metrics).
use super::{finite_at, go_on};
use super::law::{LaneLaw, Ref, Shape, U, X};
use crate::model::dynamics::Halt;
use crate::sim::runner::{SimConfig, STOP_CHECK_STEPS};
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

/// The ideal lanes' state (in their kernel's frame, `Plant::state`), the loop's input and the
/// new state on a cache line's boundary, as the metrics' arrays
/// (`Metrics`): their lanes are moved a vector at a time, and a vector that straddles two lines
/// costs (as `Plants` says). Left to the frame's layout when this loop was first written once,
/// the planar kernels made ~100 of their AVX-512 stack accesses off a 64-byte boundary (8 to 16
/// before; `objdump`), and circle-pid swept at 0.92-0.94x.
#[repr(C, align(64))]
pub(super) struct Aligned<T>(pub(super) T);

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
    /// Step `k` (of `dt`) under the input held, on every lane: the new state (the caller moves
    /// the lanes that go on there). A rig tells `drive` what its plants got at the step's start
    /// and whether each lane's command is beyond its driver (`Observer::drive`); ideal plants
    /// get `u`, and do not.
    fn step<const COPY: u8>(&mut self, k: usize, u: &U<Self::Shape>, dt: f64, drive: impl FnOnce(&U<Self::Shape>, &[bool; LANES])) -> X<Self::Shape>;
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

/// `runner::run_loop` on a block of lanes, the `active` lanes' starts in `plant`, `n` steps
/// with the law `controller` updated every `per_update`: the reference sampled, the law's
/// update and its input applied (a lane whose drive is not finite ends as fallen there,
/// unobserved), the metrics' observation, the step (and what the plants got, observed), the
/// lanes that end (past the fall limit, not finite, halted by the ground). `should_stop` is
/// asked every `runner::STOP_CHECK_STEPS` steps; None means it said yes. The same loop for the
/// ideal lanes and the rigs', 2-DOF and 3-DOF.
/// The law is borrowed, as the loop written out used it where its caller put it: taken by
/// value, it was copied into the kernel's frame (11 KB for the fuzzy law), and the `avx2`
/// fuzzy lanes read 0.96x of the loop written out in three runs of paired timings (0.98x and
/// 1.01x borrowed).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn closed_loop<C, P, O, const NX: usize, const COPY: u8>(
    controller: &mut C,
    mut plant: P,
    mut observer: O,
    active: [bool; LANES],
    (n, per_update): (usize, usize),
    config: &SimConfig<f64>,
    should_stop: &dyn Fn() -> bool,
) -> Option<O::Out>
where
    P: Plant,
    O: Observer<Shape = P::Shape>,
    P::Shape: Shape<X = [Lanes; NX]>,
    C: LaneLaw<Shape = P::Shape>,
{
    let dt = config.dt;
    let mut state = controller.start();
    let mut u = Aligned(U::<P::Shape>::ZERO);
    let u = &mut u.0;
    let mut alive = active;
    // (fell, t_end, steps) of each lane that has ended.
    let mut ended = [(false, 0.0f64, 0u64); LANES];
    for k in 0..n {
        let t = dt * k as f64;
        if k % STOP_CHECK_STEPS == 0 && k > 0 && should_stop() {
            return None;
        }
        let r = observer.reference(t);
        let update = k % per_update == 0;
        if update {
            plant.update::<C, COPY>(controller, &mut state, t, &r, u);
            // A lane whose drive is not finite has diverged: it ends as fallen, unobserved.
            let diverged = plant.apply(t, u);
            let mut finite = true;
            for (l, &a) in alive.iter().enumerate() {
                finite &= !diverged[l] | !a;
            }
            if !finite {
                for l in 0..LANES {
                    if alive[l] && diverged[l] {
                        alive[l] = false;
                        ended[l] = (true, t, k as u64);
                    }
                }
            }
        }
        observer.observe(&alive, t, plant.state(), plant.command(u), &r);
        // Not wrapped in `Aligned`: wrapped, the new state was copied there from `step`'s own
        // array every step (a `memcpy` call, 896 bytes in the planar kernels, with a
        // `vzeroupper` before it and the loop's registers reloaded after), and circle-pid swept
        // at 0.91x.
        let next = &plant.step::<COPY>(k, u, dt, |delivered, beyond| observer.drive(&alive, delivered, update, beyond));
        let halts = plant.halts::<COPY>(next, u);
        // Lanes that go on take the new state; the few that end are handled below.
        // `go_on`, not `advance` (which made the array of the lanes that end, and the rig
        // kernels' own loops used until they ran this one): with `advance` the 2-DOF LQR kernel measured ~9 % slower (median of 10 alternating runs, 2048
        // samples, one pinned core: 0.745 against 0.68 s CPU), and 1.15x on the AVX-512 VM
        // with the lanes that end handled as the rig kernel does (11 paired timings,
        // `sweep_throughput lanes 8192`). The branch below is as touchy: with an array of the
        // lanes that end made in it, the kernel ran 1.24x slower.
        let (goes_on, mut any_ends) = go_on(plant.state_mut(), next, &alive, O::PITCH, config.fall_limit);
        // A lane whose finite new state the ground halts ends there too (having moved there
        // if it went on), as the runner ends a run.
        let halted: Option<[bool; LANES]> = halts.map(|h| core::array::from_fn(|l| alive[l] && h[l].is_some() && finite_at(next, l)));
        if let Some(h) = &halted {
            any_ends |= h.iter().any(|&e| e);
        }
        if any_ends {
            let t_next = dt * (k + 1) as f64;
            for l in 0..LANES {
                if !alive[l] || (goes_on[l] != 0 && !halted.is_some_and(|h| h[l])) {
                    continue;
                }
                alive[l] = false;
                ended[l] = (true, t_next, (k + 1) as u64);
                if finite_at(next, l) {
                    // Fell: the runner observes the state past the limit, then stops.
                    let x = plant.state_mut();
                    for i in 0..NX {
                        x[i][l] = next[i][l];
                    }
                    observer.observe_end(l, t_next, plant.state(), plant.command(u), halts.and_then(|h| h[l]));
                }
            }
            if !alive.iter().any(|&a| a) {
                break;
            }
        }
    }
    Some(observer.finish((&alive, &active, &mut ended), plant.state(), plant.command(u), (dt * n as f64, n)))
}
