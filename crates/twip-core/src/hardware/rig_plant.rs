//! The rig's plant, one design for both models: [`RealPlant`] is a model on its ground
//! ([`RigGround`]: the 2-DOF slope model on its slope profile, `Slopes`; the 3-DOF model,
//! flat or on terrain, `PlanarGround`) with the robot's real parts, each optional:
//! - drives ([`Drives`]): each input's bridge and motor winding (input: the duties), else
//!   the model's own input (lumped current, wheel torques);
//! - play ([`GearPlay`]): one gear train per input with backlash, its rotor turning on its
//!   own while the train is open;
//! - pushes, and a constant force on the body.
//!
//! Between steps (`Plant::between_steps`) the open rotors take their elapsed step (an
//! impact located within it jumps the velocities), pushes due jump them, the windings'
//! steps start, and the trains weigh the derivative at the step's start (those pulled
//! apart open); within a step each RK4 stage feels the windings' currents at its time
//! (`Dynamics::deriv_at_stage`). Each model writes only what is its own ([`RigGround`]):
//! the 2-DOF plant is `SlopePlant` (`N` = 1: the lumped pair of motors and trains), the
//! 3-DOF plant `PlanarPlant` (`N` = 2: one per wheel).
use nalgebra::SVector;

use crate::hardware::backlash::{heun, Backlash, GearPlay, Hit};
use crate::hardware::disturbance::{Force, Push, Pushes};
use crate::hardware::driver::{MotorDriver, Winding};
use crate::hardware::realism::RigPlant;
use crate::model::dynamics::Halt;
use crate::model::friction::Friction;
use crate::model::integrate::Stage;
use crate::sim::runner::Plant;
use crate::{Dynamics, Real, RobotParams, TwipError};

/// What a model on its ground does in a rig: the part of [`RealPlant`] each model writes
/// itself. `NX` states, `N` inputs (lumped current or wheel torques), one gear train each.
pub trait RigGround<T: Real, const NX: usize, const N: usize> {
    /// Index of the body pitch in the state.
    const PITCH: usize;

    /// Each train's wheel speed relative to the body [rad/s].
    fn wheel_speeds(&self, x: &SVector<T, NX>) -> [T; N];

    /// The derivative under the input `u` with the trains not `engaged` open (None: no
    /// play, every train engaged), with `force` on the body (None: none).
    fn deriv(&self, x: &SVector<T, NX>, u: &SVector<T, N>, engaged: Option<[bool; N]>, force: Option<&Force<T>>) -> SVector<T, NX>;

    /// The derivative under `u` with the trains not `engaged` open, and each train's
    /// gearhead friction torque.
    fn deriv_geared(&self, x: &SVector<T, NX>, u: &SVector<T, N>, engaged: [bool; N], force: Option<&Force<T>>) -> (SVector<T, NX>, [T; N]);

    /// Each engaged train's flank contact torque τ_m − τ_f − J ẇ at `x` under `u`, from
    /// the derivative `d` there, the gearhead torques `friction` and the rotor inertia `j`.
    fn contact(&self, x: &SVector<T, NX>, d: &SVector<T, NX>, u: &SVector<T, N>, friction: [T; N], j: T) -> [T; N];

    /// The motors' torques at the wheels [N m] for the input `u`.
    fn motor_torques(&self, u: &SVector<T, N>) -> [T; N];

    /// The input that gives the motors' torques `torques` (an impact's motion).
    fn input_of(&self, torques: [T; N]) -> SVector<T, N>;

    /// The plastic impact of train `train`'s rotor at `rotor_speed` on its wheel's flank,
    /// the trains `engaged` before it: the velocities in `x` jump.
    fn impact(&self, x: &mut SVector<T, NX>, train: usize, rotor_speed: T, engaged: [bool; N]);

    /// The push `p`'s impulse on the body at `x`: the velocities jump.
    fn push(&self, x: &mut SVector<T, NX>, p: &Push<T>);

    /// The gearhead friction an open rotor feels (the model's, per train).
    fn friction(&self) -> Option<&Friction<T>>;

    /// A rotor's inertia at the wheel, and how many gear trains one train stands for.
    fn rotors(&self) -> (T, T);

    /// The model's input per motor ampere through `driver` (its gearbox efficiency in).
    fn input_per_amp(&self, driver: &MotorDriver<T>, params: &RobotParams<T>) -> T;

    /// The motor currents a rig logs for the input `u`, given the windings' currents and
    /// the input per ampere when there is a driver.
    fn logged_currents(&self, u: &SVector<T, N>, windings: Option<(SVector<T, N>, T)>) -> SVector<T, N>;

    /// Each wheel's motor shaft angle minus its wheel's (right, left) from the trains' offsets.
    fn shafts(offsets: [T; N]) -> [T; 2];

    fn energy(&self, x: &SVector<T, NX>) -> T;

    /// Whether the ground ends a run at `x` under the input `u()` with the trains `engaged`.
    #[inline(always)]
    fn halted(&self, _x: &SVector<T, NX>, _u: impl FnOnce() -> SVector<T, N>, _engaged: [bool; N], _force: Option<&Force<T>>) -> Option<Halt> {
        None
    }
}

/// Each input's bridge and motor (input: the duties).
#[derive(Clone, Copy, Debug)]
pub struct Drives<T, const N: usize> {
    windings: [Winding<T>; N],
    /// The model's input per motor ampere: 2 ε (2-DOF lumped current), ε η τ_i (3-DOF wheel
    /// torque); ε the driver's `efficiency`.
    per_amp: T,
}

/// A model on its ground with the rig's parts (module docs): `NX` states, `N` inputs.
#[derive(Clone, Copy, Debug)]
pub struct RealPlant<T: Real, G, const NX: usize, const N: usize> {
    ground: G,
    drives: Option<Drives<T, N>>,
    force: Force<T>,
    has_force: bool,
    pushes: Pushes<T>,
    /// Each gear train's play and rotor (backlash).
    play: Option<GearPlay<T, N>>,
    /// The motors' speeds relative to the body while their trains are open, as of the last
    /// [`Self::turn_motors`] (None: with their wheels, as the 2-DOF rig's before the first
    /// step; the 3-DOF rig's start as the trains say, [`Self::motors_as_trains`]).
    open: [Option<T>; N],
}

impl<T: Real, G, const NX: usize, const N: usize> RealPlant<T, G, NX, N> {
    /// `ground` with the constant `force` on the body and `pushes` (from their first);
    /// neither drives nor play.
    pub fn new(ground: G, force: Force<T>, mut pushes: Pushes<T>) -> Result<Self, TwipError> {
        let force = force.validate()?;
        pushes.rewind();
        Ok(Self { ground, drives: None, has_force: !force.is_zero(), force, pushes, play: None, open: [None; N] })
    }

    /// The model on its ground.
    pub fn ground(&self) -> &G {
        &self.ground
    }

    /// The same plant on `ground` (the same robot's).
    pub(crate) fn with_ground(self, ground: G) -> Self {
        Self { ground, ..self }
    }

    /// The constant force on the body (zero components: none).
    #[inline(always)]
    pub fn force(&self) -> Force<T> {
        self.force
    }

    #[inline(always)]
    fn force_on(&self) -> Option<&Force<T>> {
        self.has_force.then_some(&self.force)
    }

    /// The gear trains' play and rotors, when the plant has backlash.
    pub fn play(&self) -> Option<&GearPlay<T, N>> {
        self.play.as_ref()
    }

    /// The gear trains to set (a shooting segment's start): the motors follow them at the
    /// next step's start or [`Self::settle`].
    pub fn play_mut(&mut self) -> Option<&mut GearPlay<T, N>> {
        self.play.as_mut()
    }

    /// Whether the gear trains have play (backlash).
    #[inline(always)]
    pub fn has_play(&self) -> bool {
        self.play.is_some()
    }

    /// Which gear trains are engaged (every one, without backlash).
    #[inline(always)]
    pub fn trains(&self) -> [bool; N] {
        self.play.as_ref().map_or([true; N], |p| p.engaged())
    }

    /// Whether no push ever acts. With the trains engaged as well, nothing acts between
    /// steps: an engaged train's rotor turns with its wheel (`gear_elapsed` changes nothing).
    #[inline(always)]
    pub fn unpushed(&self) -> bool {
        self.pushes.as_slice().is_empty()
    }

    /// Whether nothing acts on the plant between steps: no play and no pushes.
    #[inline(always)]
    pub fn idle_between_steps(&self) -> bool {
        self.play.is_none() && self.unpushed()
    }

    /// Each input's winding and the model's input per motor ampere, when there is a driver.
    #[inline(always)]
    pub fn drives(&self) -> Option<([Winding<T>; N], T)> {
        self.drives.map(|d| (d.windings, d.per_amp))
    }

    /// The motors now turn as the trains say: an open train's at its rotor's speed. A step's
    /// start and end turn them (`between_steps`); a sweep's lanes, which take the trains'
    /// next step themselves (`gear_next_with`), turn them after it.
    #[inline(always)]
    pub(crate) fn turn_motors(&mut self) {
        if let Some(play) = &self.play {
            self.open = play.open_rotors();
        }
    }

    /// The same plant with its motors turning as the trains say before the first step (open
    /// trains: at their rotors' speed, at rest until the first step), not with the wheels.
    pub(crate) fn motors_as_trains(mut self) -> Self {
        self.turn_motors();
        self
    }
}

impl<T: Real, G: RigGround<T, NX, N>, const NX: usize, const N: usize> RealPlant<T, G, NX, N> {
    /// The same plant with `backlash` in its gear trains (None or no gap: none); the open
    /// rotors take the model's gearhead friction.
    pub fn with_backlash(mut self, backlash: Option<Backlash<T>>) -> Result<Self, TwipError> {
        self.play = match backlash {
            Some(b) if b.validate()?.gap > T::zero() => {
                let (inertia, trains) = self.ground.rotors();
                Some(GearPlay::new(&b, inertia, trains)?)
            }
            _ => None,
        };
        Ok(self)
    }

    /// The same plant driven through `driver` (None: by its own input), each input by a
    /// motor of `params`' torque constant and gear ratio.
    pub fn with_driver(mut self, driver: Option<&MotorDriver<T>>, params: &RobotParams<T>) -> Result<Self, TwipError> {
        self.drives = match driver {
            None => None,
            Some(d) => Some(Drives { windings: [Winding::new(d, params)?; N], per_amp: self.ground.input_per_amp(d, params) }),
        };
        Ok(self)
    }

    /// Each motor's speed relative to the body [rad/s at the wheel]: its wheel's, or an
    /// open train's rotor's.
    #[inline(always)]
    pub fn motor_speeds(&self, x: &SVector<T, NX>) -> [T; N] {
        let wheels = self.ground.wheel_speeds(x);
        core::array::from_fn(|i| self.open[i].unwrap_or(wheels[i]))
    }

    /// Each wheel's speed relative to the body.
    #[inline(always)]
    pub fn wheel_speeds(&self, x: &SVector<T, NX>) -> [T; N] {
        self.ground.wheel_speeds(x)
    }

    /// The model's input at an RK4 stage of the step at `x` under `u`: `u` itself, or each
    /// winding's current at the stage (`Winding::current_at`) in the input's units.
    #[inline(always)]
    pub fn inputs_at(&self, x: &SVector<T, NX>, u: &SVector<T, N>, stage: Stage) -> SVector<T, N> {
        self.inputs_by(x, u, |w, duty, speed| w.current_at(duty, speed, stage))
    }

    /// The input's mean over the step at `x` under `u`, the motors' speeds held: what
    /// drives an open train's rotor (for a winding with inductance, not the first stage's).
    #[inline(always)]
    pub fn mean_inputs(&self, x: &SVector<T, NX>, u: &SVector<T, N>) -> SVector<T, N> {
        self.inputs_by(x, u, Winding::mean_current)
    }

    /// The input for `u` at `x`, each winding's current given by `current` (winding, duty,
    /// the motor's speed).
    #[inline(always)]
    fn inputs_by(&self, x: &SVector<T, NX>, u: &SVector<T, N>, current: impl Fn(&Winding<T>, T, T) -> T) -> SVector<T, N> {
        match &self.drives {
            None => *u,
            Some(d) => {
                let speeds = self.motor_speeds(x);
                SVector::from(core::array::from_fn(|i| d.per_amp * current(&d.windings[i], u[i], speeds[i])))
            }
        }
    }

    /// Each winding's current now [A] (the state when inductive, else algebraic).
    #[inline(always)]
    fn winding_currents(&self, d: &Drives<T, N>, x: &SVector<T, NX>, u: &SVector<T, N>) -> SVector<T, N> {
        let speeds = self.motor_speeds(x);
        SVector::from(core::array::from_fn(|i| d.windings[i].current(u[i], speeds[i])))
    }

    /// Inductive windings only: each current set to its steady value at `x` for the duties
    /// `u` (`Winding::settle`), the motors turning as the trains say.
    pub fn settle(&mut self, x: &SVector<T, NX>, u: &SVector<T, N>) {
        self.turn_motors();
        let speeds = self.motor_speeds(x);
        if let Some(d) = self.drives.as_mut() {
            for (i, w) in d.windings.iter_mut().enumerate() {
                w.settle(u[i], speeds[i]);
            }
        }
    }

    /// The start of a step of `dt` at time `t` under `u`, before the gear trains weigh it:
    /// [`Self::ground_start`], then the windings' steps start. Returns the input at RK4's
    /// first stage.
    // Always inlined: out of line, the lanes' copies for AVX called it compiled for the
    // baseline CPU.
    #[inline(always)]
    pub(crate) fn step_start(&mut self, t: T, dt: T, x: &mut SVector<T, NX>, u: &SVector<T, N>) -> SVector<T, N> {
        self.ground_start(t, dt, x);
        let speeds = self.motor_speeds(x);
        if let Some(d) = self.drives.as_mut() {
            for (i, w) in d.windings.iter_mut().enumerate() {
                w.start_step(u[i], speeds[i], dt);
            }
        }
        self.inputs_at(x, u, Stage::Start)
    }

    /// [`Self::step_start`] but for the windings' steps (which a sweep's lanes take on
    /// lanes): the open rotors' elapsed step and impacts, pushes due, and the motors turning
    /// with the open rotors.
    #[inline(always)]
    pub(crate) fn ground_start(&mut self, t: T, dt: T, x: &mut SVector<T, NX>) {
        self.gear_elapsed(dt, x);
        while let Some(p) = self.pushes.due(t, dt) {
            self.ground.push(x, &p);
        }
        self.turn_motors();
    }

    /// The step under way has ended at `x`: the open trains' rotors advance; those that
    /// reach a flank engage in a plastic impact (the velocities in `x` jump), located
    /// within the step ([`Hit::late`]).
    #[inline(always)]
    fn gear_elapsed(&mut self, dt: T, x: &mut SVector<T, NX>) {
        // By reference: a copy of the play costs a sweep's lanes.
        let wheels = self.ground.wheel_speeds(x);
        let Some(play) = self.play.as_mut() else { return };
        let hits = play.elapsed(dt, wheels, self.ground.friction());
        for (i, hit) in hits.into_iter().enumerate() {
            if let Some(hit) = hit {
                let speed = self.impact_at_its_time(x, i, hit);
                if let Some(play) = self.play.as_mut() {
                    play.engage(i, speed);
                }
            }
        }
    }

    /// Train `i`'s impact `hit`: `x` taken back by `hit.late` along the open motion under
    /// the step's motor torques, the impact, and forward along the engaged motion (`heun`,
    /// both ways). Returns the speed rotor and wheel share at the step's end.
    // Out of line and cold: inlined, the compiler computed the impact's sin φ and cos φ
    // (libm) on every step, ahead of the rare branch that needs them.
    #[cold]
    #[inline(never)]
    fn impact_at_its_time(&self, x: &mut SVector<T, NX>, i: usize, hit: Hit<T>) -> T {
        let Some(play) = &self.play else { return T::zero() };
        let u = self.ground.input_of(play.motors());
        let before = play.engaged();
        let mut after = before;
        after[i] = true;
        let motion = |engaged: [bool; N]| move |x: &SVector<T, NX>| self.ground.deriv_geared(x, &u, engaged, self.force_on()).0;
        *x = heun(x, -hit.late, motion(before));
        self.ground.impact(x, i, hit.rotor, before);
        *x = heun(x, hit.late, motion(after));
        self.ground.wheel_speeds(x)[i]
    }

    /// A step starts at `x` under `u`, its input at the first stage being `input`: engaged
    /// trains whose contact torque would pull the flanks apart open, and the motors'
    /// torques over the step are noted. Returns the derivative the trains weighed when they
    /// stay as they were (then it is `deriv` at `x` under `u`: an engaged train's rotor,
    /// which this sets, is not read); None without backlash.
    #[inline(always)]
    fn gear_next(&mut self, x: &SVector<T, NX>, u: &SVector<T, N>, input: &SVector<T, N>) -> Option<SVector<T, NX>> {
        let engaged = self.play.as_ref()?.engaged();
        let (d, friction) = self.ground.deriv_geared(x, input, engaged, self.force_on());
        let mean = self.mean_inputs(x, u);
        self.gear_next_with(x, input, &mean, &d, friction).then_some(d)
    }

    /// [`Self::gear_next`] given the derivative `d` and the gearhead torques `friction` at
    /// `x` under the first stage's `input` with the trains as they are (`deriv_geared`'s),
    /// and the input's mean `mean` ([`Self::mean_inputs`]), which a sweep's lanes compute:
    /// whether the trains stayed as they were (always, without backlash).
    #[inline(always)]
    pub(crate) fn gear_next_with(&mut self, x: &SVector<T, NX>, input: &SVector<T, N>, mean: &SVector<T, N>, d: &SVector<T, NX>, friction: [T; N]) -> bool {
        let Some(j) = self.rotor_inertia() else { return true };
        let contact = self.ground.contact(x, d, input, friction, j);
        self.gear_next_at(self.ground.wheel_speeds(x), contact, mean)
    }

    /// [`Self::gear_next_with`] given each train's wheel speed `wheels` and flank contact
    /// torque `contact` at the step's start, which a sweep's 3-DOF lanes on flat ground work
    /// out side by side.
    #[inline(always)]
    pub(crate) fn gear_next_at(&mut self, wheels: [T; N], contact: [T; N], mean: &SVector<T, N>) -> bool {
        let motor = self.ground.motor_torques(mean);
        let Some(play) = self.play.as_mut() else { return true };
        let engaged = play.engaged();
        play.next_step(wheels, contact, motor);
        play.engaged() == engaged
    }

    /// Whether the gear trains' next step would leave them all engaged at the flank contact
    /// torques `contact`, with nothing to note (`GearPlay::stays_engaged`); false without play.
    #[inline(always)]
    pub(crate) fn stays_engaged(&self, contact: [T; N]) -> bool {
        self.play.as_ref().is_some_and(|p| p.stays_engaged(contact))
    }

    /// The gear trains' rotor inertia (None: no play).
    #[inline(always)]
    pub(crate) fn rotor_inertia(&self) -> Option<T> {
        self.play.as_ref().map(|p| p.inertia())
    }
}

impl<T: Real, G: RigGround<T, NX, N>, const NX: usize, const N: usize> Dynamics<T, NX, N> for RealPlant<T, G, NX, N> {
    const PITCH: usize = G::PITCH;

    // Always inlined: out of line, RK4 reloads the model's constants every stage.
    #[inline(always)]
    fn deriv(&self, x: &SVector<T, NX>, u: &SVector<T, N>) -> SVector<T, NX> {
        self.deriv_at_stage(x, u, Stage::Start)
    }

    /// The derivative with the gear trains as they are (open ones neither driven nor
    /// braked), under the windings' currents at the RK4 stage.
    #[inline(always)]
    fn deriv_at_stage(&self, x: &SVector<T, NX>, u: &SVector<T, N>, stage: Stage) -> SVector<T, NX> {
        let input = self.inputs_at(x, u, stage);
        self.ground.deriv(x, &input, self.play.as_ref().map(|p| p.engaged()), self.force_on())
    }

    fn energy(&self, x: &SVector<T, NX>) -> T {
        self.ground.energy(x)
    }

    /// The ground's: on terrain, off a grid, or a wheel's normal force below zero under the
    /// torques the windings deliver at `x` with the gear trains as they are.
    #[inline]
    fn halted(&self, x: &SVector<T, NX>, u: &SVector<T, N>) -> Option<Halt> {
        self.ground.halted(x, || self.inputs_at(x, u, Stage::Start), self.trains(), self.force_on())
    }
}

impl<T: Real, G: RigGround<T, NX, N>, const NX: usize, const N: usize> Plant<T, NX, N> for RealPlant<T, G, NX, N> {
    /// The gear trains' elapsed step, pushes, the windings' steps; then the trains at the
    /// new step's start.
    #[inline]
    fn between_steps(&mut self, t: T, dt: T, x: &mut SVector<T, NX>, u: &SVector<T, N>) {
        self.between_steps_with_derivative(t, dt, x, u);
    }

    /// The derivative the gear trains weighed, when they stay as they were: the motors
    /// then turn as they did when it was evaluated (`turn_motors` changes nothing), and the
    /// input is the one `deriv` computes.
    #[inline]
    fn between_steps_with_derivative(&mut self, t: T, dt: T, x: &mut SVector<T, NX>, u: &SVector<T, N>) -> Option<SVector<T, NX>> {
        let input = self.step_start(t, dt, x, u);
        let first = self.gear_next(x, u, &input);
        self.turn_motors();
        first
    }

    /// The windings' currents are carried to the step's end.
    #[inline]
    fn step_ended(&mut self, x: &SVector<T, NX>) {
        let speeds = self.motor_speeds(x);
        if let Some(d) = self.drives.as_mut() {
            for (i, w) in d.windings.iter_mut().enumerate() {
                w.end_step(speeds[i]);
            }
        }
    }

    #[inline(always)]
    fn shaft_offsets(&self) -> [T; 2] {
        self.play.as_ref().map_or([T::zero(); 2], |p| G::shafts(p.offsets()))
    }
}

impl<T: Real, G: RigGround<T, NX, N>, const NX: usize, const N: usize> RigPlant<T, NX, N> for RealPlant<T, G, NX, N> {
    #[inline]
    fn currents(&self, x: &SVector<T, NX>, u: &SVector<T, N>) -> SVector<T, N> {
        let windings = self.drives.as_ref().map(|d| (self.winding_currents(d, x, u), d.per_amp));
        self.ground.logged_currents(u, windings)
    }

    /// The input the windings' currents give (the input applied, without a driver).
    // Always inlined: a sweep's 2-DOF lanes without inductance ask it of every lane every
    // step; out of line (as `#[inline]` left it), those sweeps ran 1.09x slower.
    #[inline(always)]
    fn delivered(&self, x: &SVector<T, NX>, u: &SVector<T, N>) -> SVector<T, N> {
        match &self.drives {
            None => *u,
            Some(d) => self.winding_currents(d, x, u) * d.per_amp,
        }
    }
}
