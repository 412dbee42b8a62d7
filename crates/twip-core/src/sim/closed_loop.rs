//! The one closed-loop step, written once: the order of what happens in a plant step, for
//! the scalar runner (`runner::run_loop`, one lane) and the sweeps' blocks of lanes
//! (`sweep::block`, [`LANES`](crate::sweep::lanes::LANES) at once, ideal and through a rig,
//! 2-DOF and 3-DOF). What differs between them are the [`Hooks`], inlined into the loop:
//! where the state lives and each side's own arithmetic (the runner's plain operations on
//! vectors of any `Real`, the lanes' fused multiply-adds on arrays of `f64`), so that each
//! keeps its bits.
use crate::model::dynamics::Halt;
use crate::sim::runner::{SimConfig, STOP_CHECK_STEPS};
use crate::{c, Real};

/// Why a lane ended before the run's end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum End {
    /// Its drive (at a controller update) or its state (after a step) stopped being finite;
    /// unobserved there.
    Diverged,
    /// Its pitch passed the fall limit.
    Fell,
    /// The ground ended it (`Dynamics::halted`).
    Halted(Halt),
}

/// How each of a block's lanes that ended did: why, at what time and after how many steps.
pub(crate) type Ended<T, const W: usize> = [(End, T, u64); W];

/// A value on a cache line's boundary: the loop's input, as the lanes' metrics' arrays (their
/// lanes are moved a vector at a time, and a vector that straddles two lines costs). Left to
/// the frame's layout when the lanes' loop was first written once, the planar kernels made
/// ~100 of their AVX-512 stack accesses off a 64-byte boundary (8 to 16 before; `objdump`),
/// and circle-pid swept at 0.92-0.94x.
#[repr(C, align(64))]
pub(crate) struct Aligned<T>(pub(crate) T);

/// What a closed loop on `W` lanes does at each point of a step (the runner: one lane; a
/// sweep's block: [`LANES`](crate::sweep::lanes::LANES)), with the law `C`. Every hook is
/// `#[inline(always)]`: the loop with its hooks is one function, as when each loop was
/// written out. `COPY`: the kernel copy that runs the loop (`sweep::block::out_of_line_in`;
/// the runner, compiled once, ignores it).
pub(crate) trait Hooks<C, const W: usize> {
    /// The numbers: time, step and fall limit (`f64` on lanes).
    type T: Real;
    /// Every lane's state.
    type X: Copy;
    /// Every lane's input from the law.
    type U;
    /// The reference, the same for every lane (sampled once per step).
    type Ref;
    /// What the law keeps per lane outside itself (the lanes' own controller states).
    type LawState;
    /// The run's result.
    type Out;
    /// The law's input before its first update.
    fn no_input() -> Self::U;
    /// The law's state at the start.
    fn start(controller: &C) -> Self::LawState;
    /// The reference at time `t`.
    fn reference(&mut self, t: Self::T) -> Self::Ref;
    /// A controller update at `t`: what the law reads, its input `u`, applied from now on
    /// (through a driver, a period late with a delay). Returns the lanes whose drive is not
    /// finite: they have diverged.
    fn update<const COPY: u8>(&mut self, controller: &mut C, state: &mut Self::LawState, t: Self::T, r: &Self::Ref, u: &mut Self::U) -> [bool; W];
    /// Observes the lanes that are `live` at `t` (the state, the input applied, `r`).
    fn observe(&mut self, live: &[bool; W], t: Self::T, controller: &C, u: &Self::U, r: &Self::Ref);
    /// Step `k` (from `t`, of `dt`) under the input held, on every lane: observes what the
    /// `live` lanes' plants get at its start (at a controller `update`, whether each
    /// command is beyond its driver), then the new state (the lanes that go on are moved
    /// there by [`Self::go_on`]), written into `next`.
    #[allow(clippy::too_many_arguments)]
    fn step<const COPY: u8>(&mut self, k: usize, t: Self::T, update: bool, live: &[bool; W], u: &Self::U, dt: Self::T, next: &mut Self::X);
    /// Every lane's state now.
    fn state(&self) -> &Self::X;
    /// What ends each lane at `next` under `u` besides a fall (None: nothing can).
    fn halts<const COPY: u8>(&self, next: &Self::X, u: &Self::U) -> Option<[Option<Halt>; W]>;
    /// Moves the lanes that go on (alive, `next` finite and its pitch within `fall_limit`)
    /// to `next`; returns each lane's mask, all ones where it went on, and whether some lane
    /// alive ends.
    fn go_on(&mut self, next: &Self::X, alive: &[bool; W], fall_limit: Self::T) -> ([u64; W], bool);
    /// Whether lane `l` of `x` is finite.
    fn finite_at(x: &Self::X, l: usize) -> bool;
    /// Lane `l` ends in `next` at `t`, ended by the ground (`halt`) or fallen: moves it there
    /// and observes it a last time.
    fn observe_end(&mut self, l: usize, next: &Self::X, t: Self::T, controller: &C, u: &Self::U, halt: Option<Halt>);
    /// The last observation at `t_end` (after `n` steps) of the lanes still `alive`, and the
    /// result for the `active` ones, with how each `ended`.
    #[allow(clippy::type_complexity)]
    fn finish(self, lanes: (&[bool; W], &[bool; W], &Ended<Self::T, W>), controller: &C, u: &Self::U, end: (Self::T, usize)) -> Self::Out;
}

/// The closed loop on the `active` lanes of `hooks`, `n` steps of `config.dt` with the law
/// `controller` updated every `per_update`. Each step: the reference sampled; at an update,
/// the law's input applied (a lane whose drive is not finite ends there, diverged,
/// unobserved); the observation; the step (and what the plants got, observed); the lanes
/// that end: not finite (diverged, unobserved), past the fall limit or halted by the ground
/// (observed there, then stopped). `should_stop` is asked every [`STOP_CHECK_STEPS`] steps;
/// `Err(k)` means it said yes before step `k`. (A `&dyn Fn`, called as is: with the loop
/// generic over `impl FnMut` and given the lanes' `&dyn Fn`, the `avx512` fuzzy lanes' kernel
/// kept its rules' weights on the stack, with gathers and scatters, at 2.1-2.2x the time: 8
/// paired sweeps, and 100 ms against 46 ms in a scratch binary of that kernel alone.)
/// The law is borrowed, as the lanes' loop written out used it where its caller put it:
/// taken by value, it was copied into the kernel's frame (11 KB for the fuzzy law), and the
/// `avx2` fuzzy lanes read 0.96x of the loop written out in three runs of paired timings
/// (0.98x and 1.01x borrowed).
#[inline(always)]
pub(crate) fn closed_loop<C, H, const W: usize, const COPY: u8>(
    controller: &mut C,
    mut hooks: H,
    active: [bool; W],
    (n, per_update): (usize, usize),
    config: &SimConfig<H::T>,
    should_stop: &dyn Fn() -> bool,
) -> Result<H::Out, usize>
where
    H: Hooks<C, W>,
{
    let dt = config.dt;
    let mut state = H::start(controller);
    let mut u = Aligned(H::no_input());
    let u = &mut u.0;
    let mut alive = active;
    let mut ended: Ended<H::T, W> = [(End::Fell, c::<H::T>(0.0), 0); W];
    // Each step's new state, written in place by `step`. (Returned, the lanes' new state was
    // copied from the kernels' own arrays: `memcpy` calls of 512 or 896 bytes every step in
    // the `avx2` copy. Wrapped in `Aligned`, it was copied there too: 896 bytes a step in the
    // planar kernels, with a `vzeroupper` before and the loop's registers reloaded after, and
    // circle-pid swept at 0.91x.)
    let mut next = *hooks.state();
    for k in 0..n {
        let t = dt * c::<H::T>(k as f64);
        if k % STOP_CHECK_STEPS == 0 && k > 0 && should_stop() {
            return Err(k);
        }
        let r = hooks.reference(t);
        let update = k % per_update == 0;
        if update {
            let diverged = hooks.update::<COPY>(controller, &mut state, t, &r, u);
            let mut finite = true;
            for (l, &a) in alive.iter().enumerate() {
                finite &= !diverged[l] | !a;
            }
            if !finite {
                for l in 0..W {
                    if alive[l] && diverged[l] {
                        alive[l] = false;
                        ended[l] = (End::Diverged, t, k as u64);
                    }
                }
                if !alive.iter().any(|&a| a) {
                    break;
                }
            }
        }
        hooks.observe(&alive, t, controller, u, &r);
        hooks.step::<COPY>(k, t, update, &alive, u, dt, &mut next);
        let next = &next;
        let halts = hooks.halts::<COPY>(next, u);
        // Lanes that go on take the new state; the few that end are handled below.
        // (The lanes' `go_on`, not an array of the lanes that end: with one, the 2-DOF LQR
        // kernel measured ~9 % slower, and 1.15x on the AVX-512 VM; with such an array made
        // in the branch below, 1.24x.)
        let (goes_on, mut any_ends) = hooks.go_on(next, &alive, config.fall_limit);
        // A lane whose finite new state the ground halts ends there too (having moved there
        // if it went on).
        let halted: Option<[bool; W]> = halts.map(|h| core::array::from_fn(|l| alive[l] && h[l].is_some() && H::finite_at(next, l)));
        if let Some(h) = &halted {
            any_ends |= h.iter().any(|&e| e);
        }
        if any_ends {
            let t_next = dt * c::<H::T>((k + 1) as f64);
            for l in 0..W {
                if !alive[l] || (goes_on[l] != 0 && !halted.is_some_and(|h| h[l])) {
                    continue;
                }
                alive[l] = false;
                if H::finite_at(next, l) {
                    // Fell or halted: observed in the state it ended in, then stopped.
                    let halt = halts.and_then(|h| h[l]);
                    ended[l] = (halt.map_or(End::Fell, End::Halted), t_next, (k + 1) as u64);
                    hooks.observe_end(l, next, t_next, controller, u, halt);
                } else {
                    ended[l] = (End::Diverged, t_next, (k + 1) as u64);
                }
            }
            if !alive.iter().any(|&a| a) {
                break;
            }
        }
    }
    Ok(hooks.finish((&alive, &active, &ended), controller, u, (dt * c::<H::T>(n as f64), n)))
}
