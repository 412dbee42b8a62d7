//! The closed-loop runner: RK4 on the plant, the controller's input held between its
//! updates (zero-order hold), fall and divergence detection, and observers that
//! accumulate metrics or a decimated log while it runs. Nothing here allocates.
use nalgebra::SVector;

use crate::control::{Controller, Reference};
use crate::model::dynamics::Halt;
use crate::model::integrate::{rk4_step_from_k1, Stage};
use crate::sim::closed_loop::{closed_loop, End, Ended, Hooks};
use crate::sim::held::Held;
use crate::{c, Dynamics, Real, TwipError};

/// Step size, duration and fall limit of one run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig<T> {
    /// Plant integration step [s].
    pub dt: T,
    /// Duration [s].
    pub t_final: T,
    /// The robot has fallen when |pitch| exceeds this [rad].
    pub fall_limit: T,
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome<T> {
    Completed,
    /// |pitch| passed the fall limit at `t`.
    Fell { t: T },
    /// The state or the input stopped being finite at `t`.
    Diverged { t: T },
    /// Stopped at `t` on request (Ctrl-C); everything up to `t` was observed.
    Interrupted { t: T },
    /// A wheel's normal force went negative at `t` (the terrain model).
    Lifted { t: T },
    /// The robot drove off the terrain (a grid's edge) at `t`.
    OffTerrain { t: T },
}

impl<T: Copy> Outcome<T> {
    /// When a run that ended early (it fell or diverged) ended; None for one that completed
    /// or was interrupted.
    pub fn ended_early(&self) -> Option<T> {
        match *self {
            Self::Fell { t } | Self::Diverged { t } | Self::Lifted { t } | Self::OffTerrain { t } => Some(t),
            Self::Completed | Self::Interrupted { .. } => None,
        }
    }
}

/// The most plant steps a control period (or a settle) may take. A rig's settle runs at least
/// one whole period before the run, where Ctrl-C cannot stop it: control_period = 1e7 s was
/// still settling after 40 s, 1e300 s would never end. 1e8 of the settle's steps took 0.19 s
/// (a 2 s settle at dt = 2e-8, the 0.1.13 wheel).
pub const MAX_STEPS_PER_PERIOD: f64 = 1e8;

impl<T: Real> SimConfig<T> {
    /// `dt`, `t_final` and the fall limit, by default [`DEFAULT_FALL_LIMIT`].
    pub fn new(dt: T, t_final: T, fall_limit: Option<T>) -> Self {
        Self { dt, t_final, fall_limit: fall_limit.unwrap_or_else(|| c(DEFAULT_FALL_LIMIT)) }
    }

    /// Number of plant steps and plant steps per controller update; checks that the
    /// control period is a whole number of steps.
    pub fn steps(&self, control_period: T) -> Result<(usize, usize), TwipError> {
        let bad = |name, v: T, reason| {
            Err(TwipError::InvalidParameter { name, value: crate::to_f64(v), reason })
        };
        if !(self.dt.is_finite() && self.dt > T::zero()) {
            return bad("dt", self.dt, "must be finite and > 0");
        }
        if !(self.t_final.is_finite() && self.t_final > T::zero()) {
            return bad("t_final", self.t_final, "must be finite and > 0");
        }
        if self.fall_limit.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return bad("fall_limit", self.fall_limit, "must be > 0");
        }
        if !(control_period.is_finite() && control_period > T::zero()) {
            return bad("control_period", control_period, "must be finite and > 0");
        }
        let ratio = control_period / self.dt;
        let per_update = ratio.round();
        if per_update < T::one() || (ratio - per_update).abs() > c::<T>(1e-6) * ratio {
            return bad("control_period", control_period, "must be a whole multiple of dt");
        }
        if per_update > c(MAX_STEPS_PER_PERIOD) {
            return bad("control_period", control_period, "over dt is more than 1e8 plant steps (a rig's settle runs a whole period, uninterruptibly)");
        }
        let n = (self.t_final / self.dt).round();
        if crate::to_f64(n) > 1e12 {
            return bad("t_final", self.t_final, "needs more than 1e12 steps of dt");
        }
        Ok(((crate::to_f64(n) as usize).max(1), crate::to_f64(per_update) as usize))
    }
}

/// Sees every sample of a run: the time, the state, the input held over the next step,
/// the reference and the controller's internals.
pub trait Observer<T: Real, const NX: usize, const NU: usize, S> {
    fn observe(&mut self, t: T, x: &SVector<T, NX>, u: &SVector<T, NU>, r: &S, internals: &[T]);

    /// The run's final sample (at the end, or past the fall limit). A decimating
    /// observer keeps it whatever its stride.
    fn observe_last(&mut self, t: T, x: &SVector<T, NX>, u: &SVector<T, NU>, r: &S, internals: &[T]) {
        self.observe(t, x, u, r, internals);
    }

    /// What the plant gets at the start of the step about to be taken (each sample but the
    /// last, before it is observed): its input after the driver (`delivered`: a current or
    /// wheel torques, as the command is), and at a controller update whether the command
    /// applied from then on is beyond the driver (`beyond`: None between updates). Ignored
    /// by default.
    #[inline(always)]
    fn drive(&mut self, _delivered: &SVector<T, NU>, _beyond: Option<bool>) {}

    /// The driver's gearbox efficiency ε (the share of the winding's torque that reaches
    /// the wheel; 1 without a driver), told once before the run: a motor carries 1/ε of the
    /// current its delivered torque reads as. Ignored by default.
    #[inline(always)]
    fn drive_efficiency(&mut self, _efficiency: T) {}
}

impl<T: Real, const NX: usize, const NU: usize, S> Observer<T, NX, NU, S> for () {
    fn observe(&mut self, _: T, _: &SVector<T, NX>, _: &SVector<T, NU>, _: &S, _: &[T]) {}
}

impl<T, A, B, const NX: usize, const NU: usize, S> Observer<T, NX, NU, S> for (A, B)
where
    T: Real,
    A: Observer<T, NX, NU, S>,
    B: Observer<T, NX, NU, S>,
{
    fn observe(&mut self, t: T, x: &SVector<T, NX>, u: &SVector<T, NU>, r: &S, internals: &[T]) {
        self.0.observe(t, x, u, r, internals);
        self.1.observe(t, x, u, r, internals);
    }

    fn observe_last(&mut self, t: T, x: &SVector<T, NX>, u: &SVector<T, NU>, r: &S, internals: &[T]) {
        self.0.observe_last(t, x, u, r, internals);
        self.1.observe_last(t, x, u, r, internals);
    }

    #[inline(always)]
    fn drive(&mut self, delivered: &SVector<T, NU>, beyond: Option<bool>) {
        self.0.drive(delivered, beyond);
        self.1.drive(delivered, beyond);
    }

    fn drive_efficiency(&mut self, efficiency: T) {
        self.0.drive_efficiency(efficiency);
        self.1.drive_efficiency(efficiency);
    }
}

/// What the controller measures. Called every plant step (`sample`) and at each
/// controller update (`read`). [`Ideal`] hands over the true state.
pub trait Sensor<T: Real, const NX: usize> {
    /// The true state `x` and its derivative at time `t`: once before the run, then
    /// each plant step after the controller's update, with the derivative over the
    /// coming step (RK4's first stage, so an accelerometer costs no extra evaluation).
    fn sample(&mut self, t: T, x: &SVector<T, NX>, xdot: &SVector<T, NX>);

    /// The measurement the controller gets at an update at time `t`.
    fn read(&mut self, t: T, x: &SVector<T, NX>) -> SVector<T, NX>;

    /// The raw readings a log of the robot would hold at state `x` (IMU registers, encoder
    /// counts), written into `out` (at most [`MAX_RAW`]); returns how many. None by default.
    #[inline(always)]
    fn raw(&self, _x: &SVector<T, NX>, _out: &mut [T]) -> usize {
        0
    }

    /// Each wheel's motor shaft angle minus its wheel's [rad at the wheel] now (gearbox
    /// backlash, [`Plant::shaft_offsets`]): what an encoder on the motor shaft adds to the
    /// wheel's angle. Ignored by default.
    #[inline(always)]
    fn shaft_offsets(&mut self, _offsets: [T; 2]) {}

    /// Before a run from `x0` whose reads come every `period`: what the sensor does while
    /// the robot stands still (a rig's settle). Nothing by default.
    fn settle(&mut self, _x0: &SVector<T, NX>, _period: T) {}
}

/// Most raw readings a sensor logs per sample.
pub const MAX_RAW: usize = 4;

/// Turns the controller's command into the plant's input at each update (a motor
/// driver, quantisation, saturation). [`Ideal`] passes the command through.
pub trait Actuator<T: Real, const NX: usize, const NU: usize> {
    fn drive(&mut self, t: T, command: &SVector<T, NU>, measurement: &SVector<T, NX>) -> SVector<T, NU>;

    /// Whether `command` at `measurement` is beyond what the drive delivers (a duty past
    /// full, a current past the driver's limit): what the saturation share counts. Never,
    /// by default.
    #[inline(always)]
    fn beyond(&self, _command: &SVector<T, NU>, _measurement: &SVector<T, NX>) -> bool {
        false
    }

    /// The gearbox efficiency of the driver behind this actuator ([`Observer::drive_efficiency`]);
    /// 1 by default (no driver).
    #[inline(always)]
    fn efficiency(&self) -> T {
        T::one()
    }
}

/// The ideal sensor and actuator: the controller sees the true state, the plant gets
/// the command.
#[derive(Clone, Copy, Debug, Default)]
pub struct Ideal;

impl<T: Real, const NX: usize> Sensor<T, NX> for Ideal {
    #[inline(always)]
    fn sample(&mut self, _: T, _: &SVector<T, NX>, _: &SVector<T, NX>) {}

    #[inline(always)]
    fn read(&mut self, _: T, x: &SVector<T, NX>) -> SVector<T, NX> {
        *x
    }
}

impl<T: Real, const NX: usize, const NU: usize> Actuator<T, NX, NU> for Ideal {
    #[inline(always)]
    fn drive(&mut self, _: T, command: &SVector<T, NU>, _: &SVector<T, NX>) -> SVector<T, NU> {
        *command
    }
}

/// How often (in plant steps) a run asks whether it should stop early.
pub const STOP_CHECK_STEPS: usize = 1 << 12;

/// The pitch [rad] beyond which a run counts as fallen, unless told otherwise: 60°.
pub const DEFAULT_FALL_LIMIT: f64 = core::f64::consts::FRAC_PI_3;

/// The parts of a run besides the plant, controller and reference.
pub struct Loop<'a, S, A, O, F> {
    pub sensor: &'a mut S,
    pub actuator: &'a mut A,
    pub observer: &'a mut O,
    /// Asked every [`STOP_CHECK_STEPS`] steps; `true` ends the run as `Interrupted`.
    pub should_stop: F,
    /// Apply each command one controller period late (the computation delay of a
    /// microcontroller that computes during the period).
    pub delay_one_period: bool,
}

/// Runs `controller` on `plant` from `x0` with ideal sensing and actuation. Returns how
/// the run ended and the number of plant steps taken. The observer sees samples
/// 0..=steps (the last one after the end).
pub fn simulate<T, P, C, R, O, const NX: usize, const NU: usize>(
    plant: &P,
    controller: &mut C,
    reference: &R,
    x0: &SVector<T, NX>,
    config: &SimConfig<T>,
    observer: &mut O,
) -> Result<(Outcome<T>, usize), TwipError>
where
    T: Real,
    P: Dynamics<T, NX, NU> + Clone,
    R: Reference<T>,
    C: Controller<T, NX, NU, Reference = R::Sample>,
    O: Observer<T, NX, NU, R::Sample>,
{
    simulate_until(plant, controller, reference, x0, config, observer, || false)
}

/// [`simulate`] that asks `should_stop` every [`STOP_CHECK_STEPS`] steps (a sweep's
/// samples, a run Ctrl-C may end).
pub fn simulate_until<T, P, C, R, O, F, const NX: usize, const NU: usize>(
    plant: &P,
    controller: &mut C,
    reference: &R,
    x0: &SVector<T, NX>,
    config: &SimConfig<T>,
    observer: &mut O,
    should_stop: F,
) -> Result<(Outcome<T>, usize), TwipError>
where
    T: Real,
    P: Dynamics<T, NX, NU> + Clone,
    R: Reference<T>,
    C: Controller<T, NX, NU, Reference = R::Sample>,
    O: Observer<T, NX, NU, R::Sample>,
    F: FnMut() -> bool,
{
    let parts = Loop { sensor: &mut Ideal, actuator: &mut Ideal, observer, should_stop, delay_one_period: false };
    simulate_with(plant, controller, reference, x0, config, parts)
}

/// The general runner with ideal logging: sensor, actuator, computation delay and
/// early stop on a plant that does not change between steps. The observer sees the
/// input applied and the controller's internals.
pub fn simulate_with<T, P, C, R, S, A, O, F, const NX: usize, const NU: usize>(
    plant: &P,
    controller: &mut C,
    reference: &R,
    x0: &SVector<T, NX>,
    config: &SimConfig<T>,
    parts: Loop<'_, S, A, O, F>,
) -> Result<(Outcome<T>, usize), TwipError>
where
    T: Real,
    P: Dynamics<T, NX, NU> + Clone,
    R: Reference<T>,
    C: Controller<T, NX, NU, Reference = R::Sample>,
    S: Sensor<T, NX>,
    A: Actuator<T, NX, NU>,
    O: Observer<T, NX, NU, R::Sample>,
    F: FnMut() -> bool,
{
    // The loop gets its own copy: behind a reference inside a struct, the model's
    // constants would be reloaded after every observer call.
    run_loop(&mut Fixed(plant.clone()), controller, reference, x0, config, parts, &mut ControllerSignals)
}

/// A plant as the one loop drives it: its dynamics, and what happens to it between
/// integration steps.
pub trait Plant<T: Real, const NX: usize, const NU: usize>: Dynamics<T, NX, NU> {
    /// Called after the sample at `t` and before the step to `t + dt` with the input `u`
    /// held over it (pushes jump the velocities, a winding current advances).
    fn between_steps(&mut self, t: T, dt: T, x: &mut SVector<T, NX>, u: &SVector<T, NU>);

    /// [`Self::between_steps`], and the derivative at the new step's start under `u` when
    /// it was evaluated on the way (a rig's gear trains weigh it) and still holds. The
    /// runner takes it as RK4's first stage instead of evaluating the same function of the
    /// same state again: the same bits, one derivative fewer per step. The default
    /// evaluates none.
    #[inline(always)]
    fn between_steps_with_derivative(&mut self, t: T, dt: T, x: &mut SVector<T, NX>, u: &SVector<T, NU>) -> Option<SVector<T, NX>> {
        self.between_steps(t, dt, x, u);
        None
    }

    /// Called after each RK4 step, which ended at `x` (an inductive winding's current is
    /// carried to it).
    #[inline(always)]
    fn step_ended(&mut self, _x: &SVector<T, NX>) {}

    /// Each wheel's motor shaft angle minus its wheel's [rad at the wheel] (right, left; the
    /// 2-DOF rig's lumped pair twice): nonzero inside a gearbox's backlash.
    #[inline(always)]
    fn shaft_offsets(&self) -> [T; 2] {
        [T::zero(); 2]
    }
}

/// A model that nothing changes between steps.
pub struct Fixed<P>(pub P);

impl<T: Real, P: Dynamics<T, NX, NU>, const NX: usize, const NU: usize> Dynamics<T, NX, NU> for Fixed<P> {
    const PITCH: usize = P::PITCH;

    #[inline(always)]
    fn deriv(&self, x: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NX> {
        self.0.deriv(x, u)
    }

    #[inline(always)]
    fn deriv_at_stage(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, stage: Stage) -> SVector<T, NX> {
        self.0.deriv_at_stage(x, u, stage)
    }

    fn energy(&self, x: &SVector<T, NX>) -> T {
        self.0.energy(x)
    }

    #[inline(always)]
    fn halted(&self, x: &SVector<T, NX>, u: &SVector<T, NU>) -> Option<crate::model::dynamics::Halt> {
        self.0.halted(x, u)
    }
}

impl<T: Real, P: Dynamics<T, NX, NU>, const NX: usize, const NU: usize> Plant<T, NX, NU> for Fixed<P> {
    #[inline(always)]
    fn between_steps(&mut self, _: T, _: T, _: &mut SVector<T, NX>, _: &SVector<T, NU>) {}
}

/// What the observer sees besides the state and the reference: which input, and which
/// signals after the time and state.
pub trait Signals<T: Real, P, const NX: usize, const NU: usize> {
    /// Checked once before the run, with the controller's number of internals.
    fn check(&mut self, internals: usize) -> Result<(), TwipError>;

    /// After each controller update: its internals, the measurement it read and the
    /// plant input the actuator made of its command (before any delay).
    fn updated(&mut self, internals: &[T], measurement: &SVector<T, NX>, drive: &SVector<T, NU>);

    /// The signals at a sample, given the controller's internals now, the plant, the
    /// state, the input applied and the sensor's raw readings.
    fn at<'a>(&'a mut self, internals: &'a [T], plant: &P, x: &SVector<T, NX>, u: &SVector<T, NU>, raw: &[T]) -> &'a [T];

    /// Observe the controller's command (`true`) or the plant input applied (`false`).
    const OBSERVE_COMMAND: bool;

    /// The plant's input at state `x` under the input `u` applied, as the command is (a
    /// current, wheel torques), after the driver: `u` itself where the command is applied.
    fn delivered(&self, plant: &P, x: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NU>;
}

/// The controller's internals as they are, and the input applied.
pub struct ControllerSignals;

impl<T: Real, P, const NX: usize, const NU: usize> Signals<T, P, NX, NU> for ControllerSignals {
    const OBSERVE_COMMAND: bool = false;

    #[inline(always)]
    fn check(&mut self, _: usize) -> Result<(), TwipError> {
        Ok(())
    }

    #[inline(always)]
    fn updated(&mut self, _: &[T], _: &SVector<T, NX>, _: &SVector<T, NU>) {}

    #[inline(always)]
    fn at<'a>(&'a mut self, internals: &'a [T], _: &P, _: &SVector<T, NX>, _: &SVector<T, NU>, _: &[T]) -> &'a [T] {
        internals
    }

    #[inline(always)]
    fn delivered(&self, _: &P, _: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NU> {
        *u
    }
}

/// The one closed-loop runner, for ideal and realism runs of either model: the one loop
/// (`sim::closed_loop`) on one lane, with this run's parts as its hooks ([`RunHooks`]). Each
/// plant step: the controller's update when due (the sensor's read, the actuator's drive,
/// the optional one-period delay), the observation, what the plant gets at the step's start
/// (`Observer::drive`), the plant's `between_steps` (a rig's may hand back the derivative it
/// evaluated at the step's start), then RK4 with its first stage shared with the sensor's
/// `sample`, and the plant's `step_ended`. The sensor samples once before the run (its
/// registers hold a sample of the initial state) and then each step after the update, so a
/// read sees the samples up to one step before it, as firmware reads a sensor's last output.
pub fn run_loop<T, P, C, R, S, A, O, F, L, const NX: usize, const NU: usize>(
    plant: &mut P,
    controller: &mut C,
    reference: &R,
    x0: &SVector<T, NX>,
    config: &SimConfig<T>,
    parts: Loop<'_, S, A, O, F>,
    signals: &mut L,
) -> Result<(Outcome<T>, usize), TwipError>
where
    T: Real,
    P: Plant<T, NX, NU>,
    R: Reference<T>,
    C: Controller<T, NX, NU, Reference = R::Sample>,
    S: Sensor<T, NX>,
    A: Actuator<T, NX, NU>,
    O: Observer<T, NX, NU, R::Sample>,
    F: FnMut() -> bool,
    L: Signals<T, P, NX, NU>,
{
    let steps = config.steps(controller.period())?;
    for (index, value) in x0.iter().enumerate() {
        if !value.is_finite() {
            return Err(TwipError::NonFinite { name: "x0", index, value: crate::to_f64(*value) });
        }
    }
    signals.check(controller.internals().len())?;
    let Loop { sensor, actuator, observer, should_stop, delay_one_period } = parts;
    observer.drive_efficiency(actuator.efficiency());
    let hooks = RunHooks::start(plant, reference, sensor, actuator, observer, signals, x0, delay_one_period);
    // Asked as the lanes ask (`closed_loop`'s `&dyn Fn`), every `STOP_CHECK_STEPS` steps.
    let should_stop = core::cell::RefCell::new(should_stop);
    let asked = || (should_stop.borrow_mut())();
    // One lane, in no kernel copy (`COPY` = 0: the hooks do not ask).
    let end = closed_loop::<C, _, 1, 0>(controller, hooks, [true], steps, config, &asked);
    Ok(match end {
        Err(k) => (Outcome::Interrupted { t: config.dt * c::<T>(k as f64) }, k),
        Ok(None) => (Outcome::Completed, steps.0),
        Ok(Some((end, t, k))) => {
            let outcome = match end {
                End::Diverged => Outcome::Diverged { t },
                End::Fell => Outcome::Fell { t },
                End::Halted(Halt::Lifted) => Outcome::Lifted { t },
                End::Halted(Halt::OffTerrain) => Outcome::OffTerrain { t },
            };
            (outcome, k as usize)
        }
    })
}

/// A run's parts as the one loop's hooks on one lane: the plant and its state, the sensor,
/// actuator and what they hold between updates, the observer with the signals it sees.
struct RunHooks<'a, T: Real, P, R, S, A, O, L, const NX: usize, const NU: usize> {
    plant: &'a mut P,
    reference: &'a R,
    sensor: &'a mut S,
    actuator: &'a mut A,
    observer: &'a mut O,
    signals: &'a mut L,
    delay: bool,
    x: SVector<T, NX>,
    held: Held<SVector<T, NU>, 1>,
    raw: [T; MAX_RAW],
}

impl<'a, T, P, R, S, A, O, L, const NX: usize, const NU: usize> RunHooks<'a, T, P, R, S, A, O, L, NX, NU>
where
    T: Real,
    P: Plant<T, NX, NU>,
    R: Reference<T>,
    S: Sensor<T, NX>,
    A: Actuator<T, NX, NU>,
    O: Observer<T, NX, NU, R::Sample>,
    L: Signals<T, P, NX, NU>,
{
    /// The run from `x0`: the sensor samples it (its registers hold a sample of the initial
    /// state) and learns the shaft offsets.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn start(plant: &'a mut P, reference: &'a R, sensor: &'a mut S, actuator: &'a mut A, observer: &'a mut O, signals: &'a mut L, x0: &SVector<T, NX>, delay: bool) -> Self {
        let held = Held::new(SVector::zeros());
        sensor.sample(T::zero(), x0, &plant.deriv(x0, &held.u));
        sensor.shaft_offsets(plant.shaft_offsets());
        Self { plant, reference, sensor, actuator, observer, signals, delay, x: *x0, held, raw: [T::zero(); MAX_RAW] }
    }

    /// What the observer sees as the input: the command or the plant input applied.
    #[inline(always)]
    fn seen(&self) -> SVector<T, NU> {
        if L::OBSERVE_COMMAND { self.held.command } else { self.held.u }
    }

    /// The observation at `t` of the state now, with the controller's `internals` and the
    /// sensor's raw readings: each step's (`last`: the run's final one).
    #[inline(always)]
    fn observe_at(&mut self, t: T, internals: &[T], r: &R::Sample, last: bool) {
        let seen = self.seen();
        let raw_len = self.sensor.raw(&self.x, &mut self.raw);
        let signals = self.signals.at(internals, self.plant, &self.x, &self.held.u, &self.raw[..raw_len]);
        if last {
            self.observer.observe_last(t, &self.x, &seen, r, signals);
        } else {
            self.observer.observe(t, &self.x, &seen, r, signals);
        }
    }
}

impl<T, P, C, R, S, A, O, L, const NX: usize, const NU: usize> Hooks<C, 1> for RunHooks<'_, T, P, R, S, A, O, L, NX, NU>
where
    T: Real,
    P: Plant<T, NX, NU>,
    R: Reference<T>,
    C: Controller<T, NX, NU, Reference = R::Sample>,
    S: Sensor<T, NX>,
    A: Actuator<T, NX, NU>,
    O: Observer<T, NX, NU, R::Sample>,
    L: Signals<T, P, NX, NU>,
{
    type T = T;
    type X = SVector<T, NX>;
    type U = SVector<T, NU>;
    type Ref = R::Sample;
    /// The controller keeps its own state.
    type LawState = ();
    /// How the run ended early (why, when, after how many steps), None if it did not.
    type Out = Option<(End, T, u64)>;

    #[inline(always)]
    fn no_input() -> SVector<T, NU> {
        SVector::zeros()
    }

    #[inline(always)]
    fn start(_: &C) {}

    #[inline(always)]
    fn reference(&mut self, t: T) -> R::Sample {
        self.reference.sample(t)
    }

    /// The sensor's read, the controller's command `u` and the actuator's drive of it,
    /// held (a period late with a delay) unless it is not finite.
    #[inline(always)]
    fn update<const COPY: u8>(&mut self, controller: &mut C, _: &mut (), t: T, r: &R::Sample, u: &mut SVector<T, NU>) -> [bool; 1] {
        let y = self.sensor.read(t, &self.x);
        *u = controller.update(t, &y, r);
        let drive = self.actuator.drive(t, u, &y);
        if drive.iter().any(|v| !v.is_finite()) {
            return [true];
        }
        let clamped = self.actuator.beyond(u, &y);
        self.held.hold(self.delay, drive, *u, [clamped]);
        self.signals.updated(controller.internals(), &y, &self.held.u);
        [false]
    }

    /// The one lane is live (the loop stops once it ends).
    #[inline(always)]
    fn observe(&mut self, _: &[bool; 1], t: T, controller: &C, _: &SVector<T, NU>, r: &R::Sample) {
        self.observe_at(t, controller.internals(), r, false);
    }

    #[inline(always)]
    fn step<const COPY: u8>(&mut self, _: usize, t: T, update: bool, _: &[bool; 1], _: &SVector<T, NU>, dt: T, next: &mut SVector<T, NX>) {
        let (plant, u) = (&mut *self.plant, &self.held.u);
        self.observer.drive(&self.signals.delivered(plant, &self.x, u), update.then_some(self.held.beyond[0]));
        let k1 = plant.between_steps_with_derivative(t, dt, &mut self.x, u).unwrap_or_else(|| plant.deriv(&self.x, u));
        self.sensor.sample(t, &self.x, &k1);
        *next = rk4_step_from_k1(&*plant, &self.x, u, dt, &k1);
        plant.step_ended(next);
        // What the encoders on the motor shafts add from here on: the next read's and the
        // observations' (set here, where the plant's trains change).
        self.sensor.shaft_offsets(plant.shaft_offsets());
    }

    #[inline(always)]
    fn state(&self) -> &SVector<T, NX> {
        &self.x
    }

    #[inline(always)]
    fn halts<const COPY: u8>(&self, next: &SVector<T, NX>, _: &SVector<T, NU>) -> Option<[Option<Halt>; 1]> {
        let finite = next.iter().all(|v| v.is_finite());
        Some([if finite { self.plant.halted(next, &self.held.u) } else { None }])
    }

    #[inline(always)]
    fn go_on(&mut self, next: &SVector<T, NX>, _: &[bool; 1], fall_limit: T) -> ([u64; 1], bool) {
        let goes_on = next.iter().all(|v| v.is_finite()) && next[P::PITCH].abs() <= fall_limit;
        if goes_on {
            self.x = *next;
        }
        ([if goes_on { u64::MAX } else { 0 }], !goes_on)
    }

    #[inline(always)]
    fn finite_at(x: &SVector<T, NX>, _: usize) -> bool {
        x.iter().all(|v| v.is_finite())
    }

    #[inline(always)]
    fn observe_end(&mut self, _: usize, next: &SVector<T, NX>, t: T, controller: &C, _: &SVector<T, NU>, _: Option<Halt>) {
        self.x = *next;
        let r = self.reference.sample(t);
        self.observe_at(t, controller.internals(), &r, true);
    }

    #[inline(always)]
    fn finish(mut self, (alive, _, ended): (&[bool; 1], &[bool; 1], &Ended<T, 1>), controller: &C, _: &SVector<T, NU>, (t_end, _): (T, usize)) -> Self::Out {
        if !alive[0] {
            return Some(ended[0]);
        }
        let r = self.reference.sample(t_end);
        self.observe_at(t_end, controller.internals(), &r, true);
        None
    }
}

#[cfg(test)]
mod steps_tests {
    use super::*;

    #[test]
    fn a_control_period_of_more_than_1e8_plant_steps_is_refused_by_name() {
        let config = SimConfig::new(1e-3, 1.0, None);
        assert_eq!(config.steps(5e-3).unwrap(), (1000, 5));
        assert_eq!(config.steps(MAX_STEPS_PER_PERIOD * 1e-3).unwrap().1, 100_000_000);
        for period in [1e7, 2.0 * MAX_STEPS_PER_PERIOD * 1e-3] {
            let got = config.steps(period);
            assert!(matches!(got, Err(TwipError::InvalidParameter { name: "control_period", reason, .. }) if reason.contains("1e8")), "{period}");
        }
        assert_eq!(MAX_STEPS_PER_PERIOD, 1e8, "the message names the bound");
    }
}
