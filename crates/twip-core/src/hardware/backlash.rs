//! Gearbox backlash: free play between each motor's rotor and its wheel.
//!
//! Each gear train has `gap` of play, measured at the wheel. While the rotor is against
//! one flank the train is engaged and the robot is the model as it is (the rotor's
//! inertia on the wheel, the motor's torque and the gearhead friction through it). When
//! the contact torque would pull the flanks apart the train opens: the wheel then gets
//! neither torque nor friction and loses the rotor's inertia (`deriv_geared` of either
//! model), while the rotor turns on its own under its motor and the gearhead friction,
//! J γ̈ = τ_m − τ_f(γ̇). It crosses the play at the relative speed γ̇ − w and meets the
//! other (or the same) flank in a plastic impact: one impulse between rotor and wheel
//! that leaves both at one speed, conserving momentum and losing the energy of the
//! relative speed.
//!
//! The rotor's state lives here, not in the model's state vector: the rig advances it
//! between plant steps (one RK4 step of the rotor alone, the motor torque held), and the
//! flanks are checked at the step's end. The impact is located within the step: the
//! offset, interpolated over the step, says when the rotor reached the flank
//! ([`Hit::late`]); the plant takes the state back to then along the open motion, applies
//! the impact, and brings it to the step's end along the engaged motion (Heun's rule each
//! way). An impact that a parameter moves across a step's end then moves the motion
//! continuously (to second order in the step), not by a whole step's jump. The motor's back-EMF follows the rotor while the train is open.
use crate::model::friction::Friction;
use crate::{c, to_f64, Real, TwipError};
use nalgebra::SVector;

/// The free play of each wheel's gear train.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Backlash<T> {
    /// Total play of one gear train, at the wheel [rad] (0: none).
    pub gap: T,
}

impl<T: Real> Backlash<T> {
    /// 1° at the output: the data sheet gives none; small spur gearheads (37 mm, 1:43.7)
    /// are commonly sold with 1–3° of output backlash, and 1° is the tighter end.
    pub fn gb37() -> Self {
        Self { gap: c(core::f64::consts::PI / 180.0) }
    }

    pub fn validate(&self) -> Result<Self, TwipError> {
        if !(self.gap.is_finite() && self.gap >= T::zero()) {
            // Named as the user sets it: `Realism(backlash=...)`, the play in rad.
            return Err(TwipError::InvalidParameter {
                name: "backlash",
                value: to_f64(self.gap),
                reason: "the gear play [rad] must be finite and >= 0",
            });
        }
        Ok(*self)
    }
}

/// What one gear train did at a plant step's start: `hit` the flank its rotor struck at
/// the end of the step before (+1 ahead, −1 behind, 0 none), `opened` whether its engaged
/// flanks parted. A run's events, step by step, are its hybrid schedule: a shooting run
/// perturbed for a finite difference replays its base run's (`sysid`), so that the
/// difference sees how the motion moves with the schedule held, not the jump of an impact
/// moved across a step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GearEvent {
    pub hit: i8,
    pub opened: bool,
}

/// An open rotor that reached a flank during the step that has just ended
/// ([`GearPlay::elapsed`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit<T> {
    /// The rotor's speed when it reached the flank [rad/s at the wheel] (its speed at the
    /// step's end taken back by `late` at its acceleration there): the impact's.
    pub rotor: T,
    /// How long before the step's end the rotor reached the flank [s]: the offset's
    /// overshoot past the flank over its change during the step, times the step (0 to
    /// the step; a scripted hit extrapolates, within −1 to 2 steps). The plant takes its
    /// state back by this along the open motion, applies the impact there, and brings it
    /// forward along the engaged motion ([`heun`]): the impact at its time.
    pub late: T,
}

/// `x` moved by `h` [s] (negative: back) along `f`, by Heun's rule (second order): how the
/// plants take a state to an impact located within a step ([`Hit::late`]) and on from it.
#[inline(always)]
pub(crate) fn heun<T: Real, const N: usize>(x: &SVector<T, N>, h: T, f: impl Fn(&SVector<T, N>) -> SVector<T, N>) -> SVector<T, N> {
    let k1 = f(x);
    let k2 = f(&(x + k1 * h));
    x + (k1 + k2) * (h * c::<T>(0.5))
}

/// What a gear train with play carries from one plant step to the next: each rotor's
/// offset from its wheel, its speed, the flank it is engaged on, and the step under way
/// (the motors' torques over it, the wheels' speeds at its start). A shooting segment of
/// a log (`sysid`) starts from the previous segment's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlayState<T, const N: usize> {
    offset: [T; N],
    rotor: [T; N],
    flank: [i8; N],
    motor: [T; N],
    before: Option<[T; N]>,
}

/// The rotors of `N` gear trains with play (N = 1: the 2-DOF model's lumped pair).
#[derive(Clone, Copy, Debug)]
pub struct GearPlay<T, const N: usize> {
    half: T,
    /// Rotor inertia at the wheel [kg m²].
    inertia: T,
    /// How many gear trains each entry stands for (2: the lumped pair), for the friction.
    trains: T,
    /// Rotor angle minus wheel angle, both relative to the body [rad], within ±half.
    offset: [T; N],
    /// Rotor speed relative to the body, at the wheel [rad/s].
    rotor: [T; N],
    /// +1 or −1: engaged on that flank (the rotor ahead or behind); 0: open.
    flank: [i8; N],
    /// The motors' torques over the step under way [N m at the wheel], and the wheel
    /// speeds at its start (None before the first step).
    motor: [T; N],
    before: Option<[T; N]>,
    /// The events the step under way must have (None: those its motion gives), and those it had.
    script: Option<[GearEvent; N]>,
    events: [GearEvent; N],
}

impl<T: Real, const N: usize> GearPlay<T, N> {
    /// Trains with `backlash`'s play, each entry's rotor of `inertia` [kg m² at the wheel]
    /// standing for `trains` gear trains; they start open, centred in their play, each
    /// rotor turning with its wheel (set at the first step, [`Self::next_step`]).
    pub fn new(backlash: &Backlash<T>, inertia: T, trains: T) -> Result<Self, TwipError> {
        let b = backlash.validate()?;
        if !(inertia.is_finite() && inertia > T::zero()) {
            return Err(TwipError::InvalidParameter {
                name: "i_motor",
                value: to_f64(inertia),
                reason: "backlash needs a rotor inertia > 0 (the rotor turns on its own in the play)",
            });
        }
        let zero = [T::zero(); N];
        Ok(Self { half: b.gap / c(2.0), inertia, trains, offset: zero, rotor: zero, flank: [0; N], motor: zero, before: None, script: None, events: [GearEvent::default(); N] })
    }

    /// The trains' state between steps ([`PlayState`]).
    pub fn state(&self) -> PlayState<T, N> {
        PlayState { offset: self.offset, rotor: self.rotor, flank: self.flank, motor: self.motor, before: self.before }
    }

    /// The trains in `state` (the play's width and the rotors' inertia stay this one's).
    pub fn set_state(&mut self, state: &PlayState<T, N>) {
        (self.offset, self.rotor, self.flank, self.motor, self.before) = (state.offset, state.rotor, state.flank, state.motor, state.before);
    }

    /// The next step's events, imposed (None: the step's motion decides them). A scripted
    /// hit puts the rotor on that flank (it engages there whatever its offset), a scripted
    /// 0 leaves it open; a scripted opening parts an engaged train. Consumed by the step.
    pub fn script(&mut self, events: Option<[GearEvent; N]>) {
        self.script = events;
    }

    /// What the last step's start did ([`GearEvent`]).
    pub fn events(&self) -> [GearEvent; N] {
        self.events
    }

    /// Which trains are engaged.
    #[inline(always)]
    pub fn engaged(&self) -> [bool; N] {
        core::array::from_fn(|i| self.flank[i] != 0)
    }

    /// Each rotor's offset from its wheel [rad].
    pub fn offsets(&self) -> [T; N] {
        self.offset
    }

    /// The speed each motor turns at: its rotor's when open, else its wheel's `wheel[i]`.
    #[inline(always)]
    pub fn motor_speeds(&self, wheel: [T; N]) -> [T; N] {
        core::array::from_fn(|i| if self.flank[i] == 0 { self.rotor[i] } else { wheel[i] })
    }

    /// Each open train's rotor speed (None: engaged, the motor turns with its wheel).
    #[inline(always)]
    pub fn open_rotors(&self) -> [Option<T>; N] {
        core::array::from_fn(|i| (self.flank[i] == 0).then_some(self.rotor[i]))
    }

    /// The step of `dt` under way has ended at wheel speeds `after`: the open rotors
    /// advance under the motors' torques over it and the gearhead `friction` (the
    /// model's, per train). Returns, for each train whose rotor
    /// reached a flank moving into it (with a script: that the script says hit), its rotor
    /// speed and when within the step it got there ([`Hit`]): the plant applies the impact
    /// ([`Self::engage`]). A rotor at a flank moving back out stays open.
    #[inline(always)]
    pub fn elapsed(&mut self, dt: T, after: [T; N], friction: Option<&Friction<T>>) -> [Option<Hit<T>>; N] {
        let mut hits = [None; N];
        self.events = [GearEvent::default(); N];
        let Some(before) = self.before else { return hits };
        let half_step = c::<T>(0.5);
        for i in 0..N {
            if self.flank[i] != 0 {
                continue;
            }
            let start = self.rotor[i];
            let end = self.rotor_step(start, self.motor[i], dt, friction);
            self.rotor[i] = end;
            let from = self.offset[i];
            self.offset[i] += dt * half_step * ((start + end) - (before[i] + after[i]));
            let to = self.offset[i];
            let closing = end - after[i];
            let mut hit = 0;
            if self.offset[i] >= self.half {
                self.offset[i] = self.half;
                if closing > T::zero() {
                    hit = 1;
                }
            } else if self.offset[i] <= -self.half {
                self.offset[i] = -self.half;
                if closing < T::zero() {
                    hit = -1;
                }
            }
            if let Some(script) = &self.script {
                hit = script[i].hit.signum();
                if hit != 0 {
                    // On the scripted flank, wherever this run's rotor has got to.
                    self.offset[i] = if hit > 0 { self.half } else { -self.half };
                }
            }
            if hit != 0 {
                let late = self.lateness(hit, from, to, dt, self.script.is_some());
                let rotor = end - late * self.rotor_acceleration(end, self.motor[i], friction);
                hits[i] = Some(Hit { rotor, late });
            }
            self.events[i].hit = hit;
        }
        hits
    }

    /// How long before a step of `dt`'s end a rotor whose offset went `from` → `to` over
    /// it reached flank `hit`: the offset interpolated linearly over the step (its error is
    /// second order in the step). A hit of the rotor's own motion lies within the step; a
    /// scripted one (`scripted`) extrapolates, within −1 to 2 steps, so that a replayed
    /// run's impact moves with the motion as the free run's does.
    #[inline(always)]
    fn lateness(&self, hit: i8, from: T, to: T, dt: T, scripted: bool) -> T {
        let (flank, moved) = if hit > 0 { (self.half, to - from) } else { (-self.half, from - to) };
        if !(moved > T::zero()) {
            // Not moving into the flank over the step: at its end, as the script puts it.
            return T::zero();
        }
        let over = if hit > 0 { to - flank } else { flank - to };
        let late = dt * (over / moved);
        let (lo, hi) = if scripted { (-dt, dt + dt) } else { (T::zero(), dt) };
        late.max(lo).min(hi)
    }

    /// Train `i` engaged on the flank its offset is at, rotor and wheel at `speed` after the impact.
    pub fn engage(&mut self, i: usize, speed: T) {
        self.flank[i] = if self.offset[i] > T::zero() { 1 } else { -1 };
        self.rotor[i] = speed;
    }

    /// A step starts at wheel speeds `wheel`, the engaged trains' flank contact torque
    /// being `contact` (τ_m − τ_f − J ẇ: what the rotor pushes its wheel with): those
    /// it would pull apart open, their rotor leaving at the wheel's speed. `motor`: the
    /// motors' torques over the step (read with [`Self::motor_speeds`] after this call
    /// for the trains that stay engaged; an opening train's rotor has its wheel's speed).
    pub fn next_step(&mut self, wheel: [T; N], contact: [T; N], motor: [T; N]) {
        if self.before.is_none() {
            // The run's first step: the start state's wheels carry their rotors' speed
            // (the model's energy counts the rotors turning with them); a rotor at rest
            // would lose that speed in a spurious impact.
            self.rotor = wheel;
        }
        for i in 0..N {
            let Some(pushes) = self.pushes(i, contact[i]) else {
                self.events[i].opened = false;
                continue;
            };
            let opens = self.script.map_or(!pushes, |s| s[i].opened);
            self.rotor[i] = wheel[i];
            if opens {
                self.flank[i] = 0;
            }
            self.events[i].opened = opens;
        }
        self.script = None;
        self.motor = motor;
        self.before = Some(wheel);
    }

    /// Whether engaged train `i` pushes into its flank at the contact torque `contact` (None:
    /// it is open).
    #[inline(always)]
    fn pushes(&self, i: usize, contact: T) -> Option<bool> {
        match self.flank[i] {
            1 => Some(contact >= T::zero()),
            -1 => Some(contact <= T::zero()),
            _ => None,
        }
    }

    /// Whether [`Self::next_step`] at the contact torques `contact` would leave every train
    /// engaged, no script imposing an event. What it notes then (the rotors' and the wheels'
    /// speeds, the motors' torques) is read only while a train is open, and the step at which
    /// one opens notes it again; so a sweep's lanes skip such a step (not noting its events,
    /// which only system identification reads).
    #[inline(always)]
    pub(crate) fn stays_engaged(&self, contact: [T; N]) -> bool {
        self.script.is_none() && (0..N).all(|i| self.pushes(i, contact[i]) == Some(true))
    }

    /// The rotor inertia [kg m² at the wheel].
    pub fn inertia(&self) -> T {
        self.inertia
    }

    /// The motors' torques over the step under way [N m at the wheel]: what drives an open
    /// rotor (the mean of each motor's current over the step).
    pub fn motors(&self) -> [T; N] {
        self.motor
    }

    /// An open rotor's acceleration at `speed`, J γ̈ = τ_m − n τ_f(γ̇) over its n trains.
    #[inline(always)]
    fn rotor_acceleration(&self, speed: T, motor: T, friction: Option<&Friction<T>>) -> T {
        let (j, n) = (self.inertia, self.trains);
        match friction {
            Some(f) => (motor - n * f.torques([speed], [motor / j], [[n / j]])[0]) / j,
            None => motor / j,
        }
    }

    /// One RK4 step of an open rotor ([`Self::rotor_acceleration`]), the motor torque held.
    fn rotor_step(&self, speed: T, motor: T, dt: T, friction: Option<&Friction<T>>) -> T {
        let accel = |w: T| self.rotor_acceleration(w, motor, friction);
        let two = c::<T>(2.0);
        let k1 = accel(speed);
        let k2 = accel(speed + k1 * dt / two);
        let k3 = accel(speed + k2 * dt / two);
        let k4 = accel(speed + k3 * dt);
        speed + dt / c::<T>(6.0) * (k1 + two * k2 + two * k3 + k4)
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    extern crate std;

    use super::*;
    use crate::hardware::realism::Realism;
    use crate::model::planar::PlanarState;
    use crate::sim::runner::Plant;
    use crate::{rk4_step, Dynamics, PlanarModel, RobotParams, SlopeModel};
    use nalgebra::{SVector, Vector4};

    fn lossless() -> RobotParams<f64> {
        RobotParams { mu_bearing: 0.0, mu_ground: 0.0, ..RobotParams::balanbot() }
    }

    /// Uniform in [lo, hi) from a fixed sequence.
    struct Lcg(u64);
    impl Lcg {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
        }
    }

    #[test]
    fn an_open_train_takes_the_rotor_off_its_wheel() {
        // Energy without the open rotors' kinetic energy: along deriv_geared its rate is the
        // engaged motors' power minus what friction dissipates (none here) — the open wheel
        // neither gets torque nor carries its rotor.
        let p = lossless();
        let planar = PlanarModel::new(p).unwrap();
        let j = planar.rotor_per_wheel();
        let mut rng = Lcg(9);
        let mut worst: f64 = 0.0;
        for i in 0..300 {
            let x = PlanarState::from(core::array::from_fn(|_| rng.uniform(-1.0, 1.0)));
            let u = SVector::from([rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2)]);
            let engaged = [i % 3 == 0, i % 2 == 0];
            let energy = |x: &PlanarState<f64>| {
                let (w_r, w_l) = planar.wheel_speeds(x);
                let open: f64 = [w_r, w_l].iter().zip(engaged).filter(|(_, e)| !e).map(|(w, _)| 0.5 * j * w * w).sum();
                planar.energy(x) - open
            };
            let f = planar.deriv_geared(&x, &u, engaged, |_, _| None).0;
            let h = 1e-6;
            let rate = (energy(&(x + f * h)) - energy(&(x - f * h))) / (2.0 * h);
            let (w_r, w_l) = planar.wheel_speeds(&x);
            let power: f64 = [u[0] * w_r, u[1] * w_l].iter().zip(engaged).filter(|(_, e)| *e).map(|(p, _)| p).sum();
            // Relative to the power, or to 0.05 W when it is smaller: the central difference
            // of an energy of about 1 J rounds to ~1e-10 W.
            worst = worst.max((rate - power).abs() / power.abs().max(0.05));
        }
        std::println!("3-DOF with open trains: worst relative energy-rate residual {worst:.1e}");
        assert!(worst < 1e-7, "{worst:e}");
        // The 2-DOF model, both trains open: no input power at all.
        let slope = SlopeModel::new(p, 0.0).unwrap();
        let j = slope.rotor_inertia();
        for _ in 0..100 {
            let x = Vector4::new(rng.uniform(-1.0, 1.0), rng.uniform(-3.0, 3.0), 0.0, rng.uniform(-5.0, 5.0));
            let energy = |x: &Vector4<f64>| slope.energy(x) - 0.5 * j * (x[3] - x[1]) * (x[3] - x[1]);
            let f = slope.deriv_geared(&x, 0.7, false, |_, _| None).0;
            let h = 1e-6;
            let rate = (energy(&(x + f * h)) - energy(&(x - f * h))) / (2.0 * h);
            assert!(rate.abs() < 1e-7, "{rate}");
        }
        // Engaged is the model itself, bit for bit.
        let x = PlanarState::from([0.1, 0.2, 0.3, 0.1, -0.4, 0.5, 1.0]);
        let u = SVector::from([0.05, -0.02]);
        assert_eq!(planar.deriv_geared(&x, &u, [true, true], |_, _| None).0, planar.deriv(&x, &u));
    }

    #[test]
    fn the_impact_leaves_rotor_and_wheel_at_one_speed_and_loses_energy() {
        let p = RobotParams::<f64>::balanbot();
        let planar = PlanarModel::new(p).unwrap();
        let j = planar.rotor_per_wheel();
        let mut x = PlanarState::from([0.0, 0.0, 0.0, 0.05, 0.3, 0.1, 0.4]);
        let rotor = 6.0;
        let open = |x: &PlanarState<f64>| {
            let (w_r, _) = planar.wheel_speeds(x);
            planar.energy(x) - 0.5 * j * w_r * w_r + 0.5 * j * rotor * rotor
        };
        let before = open(&x);
        let (closing, _) = planar.wheel_speeds(&x);
        let closing = rotor - closing;
        let speed = planar.engage(&mut x, 0, rotor, [false, true]);
        let (w_r, _) = planar.wheel_speeds(&x);
        assert!((w_r - speed).abs() < 1e-12, "{w_r} {speed}");
        // A plastic impact loses part of the closing speed's energy, less than the rotor's
        // own (the wheel side is not infinitely heavy).
        let loss = before - planar.energy(&x);
        assert!(loss > 0.0 && loss < 0.5 * j * closing * closing, "{loss}");
        // No closing speed, no impulse.
        let mut y = x;
        assert!((planar.engage(&mut y, 0, w_r, [false, true]) - w_r).abs() < 1e-12);
        assert!((y - x).norm() < 1e-12);
        // 2-DOF: the same.
        let slope = SlopeModel::new(p, 0.1).unwrap();
        let mut x = Vector4::new(0.05, 0.3, 0.0, 1.0);
        let j = slope.rotor_inertia();
        let before = slope.energy(&x) - 0.5 * j * (x[3] - x[1]).powi(2) + 0.5 * j * 25.0;
        let speed = slope.engage(&mut x, 5.0);
        assert!((x[3] - x[1] - speed).abs() < 1e-12);
        assert!(slope.energy(&x) < before);
    }

    /// Steps a rig plant as the runner does: between steps, then RK4.
    fn step<P: Plant<f64, N, U>, const N: usize, const U: usize>(plant: &mut P, x: &mut SVector<f64, N>, u: &SVector<f64, U>, t: f64, dt: f64) {
        plant.between_steps(t, dt, x, u);
        *x = rk4_step(plant, x, u, dt);
    }

    #[test]
    fn the_wheels_feel_the_motors_only_once_the_rotors_have_crossed_half_the_play() {
        // Upright at rest, no friction, a constant torque: each rotor crosses half the play
        // in √(2 (gap/2) J / τ) before its wheel feels anything.
        let p = lossless();
        let backlash = Backlash::<f64>::gb37();
        let realism = Realism { backlash: Some(backlash), ..Realism::ideal() };
        let dt = 1e-4;
        let model = PlanarModel::new(p).unwrap();
        let tau: f64 = 0.02;
        let expected = (2.0 * backlash.gap / 2.0 * model.rotor_per_wheel() / tau).sqrt();
        let mut rig = realism.build_planar(&model, dt).unwrap();
        let mut x = PlanarState::zeros();
        let u = SVector::from([tau, tau]);
        let mut t = 0.0;
        while x.norm() == 0.0 && t < 1.0 {
            step(&mut rig.plant, &mut x, &u, t, dt);
            t += dt;
        }
        std::println!("3-DOF: wheels first move at {t:.4} s; the rotor crosses half the play in {expected:.4} s");
        assert!((t - expected).abs() <= 2.0 * dt, "{t} vs {expected}");
        // 2-DOF: both trains at once.
        let slope = SlopeModel::new(p, 0.0).unwrap();
        let mut rig = realism.build(&slope, dt).unwrap();
        let current = 2.0 * tau / p.torque_per_amp();
        let expected = (2.0 * backlash.gap / 2.0 * slope.rotor_inertia() / (2.0 * tau)).sqrt();
        let mut x = Vector4::zeros();
        let mut t = 0.0;
        while x.norm() == 0.0 && t < 1.0 {
            step(&mut rig.plant, &mut x, &SVector::from([current]), t, dt);
            t += dt;
        }
        std::println!("2-DOF: wheels first move at {t:.4} s; expected {expected:.4} s");
        assert!((t - expected).abs() <= 2.0 * dt, "{t} vs {expected}");
    }

    #[test]
    fn a_reversing_torque_opens_the_train_and_crosses_the_whole_play() {
        // Engaged forward, the torque reverses: the train opens and the rotor crosses the
        // whole play back; meanwhile the wheels coast (no torque on them).
        let p = lossless();
        let realism = Realism { backlash: Some(Backlash::gb37()), ..Realism::ideal() };
        let dt = 1e-4;
        let model = PlanarModel::new(p).unwrap();
        let mut rig = realism.build_planar(&model, dt).unwrap();
        let mut x = PlanarState::zeros();
        let mut t = 0.0;
        for _ in 0..2000 {
            step(&mut rig.plant, &mut x, &SVector::from([0.02, 0.02]), t, dt);
            t += dt;
        }
        let play = rig.plant.play().unwrap();
        assert_eq!(play.engaged(), [true, true]);
        let mut open_steps = 0;
        let mut opened = false;
        for _ in 0..20000 {
            step(&mut rig.plant, &mut x, &SVector::from([-0.02, -0.02]), t, dt);
            t += dt;
            let engaged = rig.plant.play().unwrap().engaged();
            if engaged == [false, false] {
                opened = true;
                open_steps += 1;
            } else if opened {
                break;
            }
        }
        let crossing = open_steps as f64 * dt;
        std::println!("the rotors cross the whole play back in {crossing:.4} s");
        assert!(opened && crossing > 0.05 && crossing < 1.0, "{crossing}");
        assert_eq!(rig.plant.play().unwrap().offsets()[0], -Backlash::<f64>::gb37().gap / 2.0);
    }

    #[test]
    fn a_rolling_start_keeps_its_speed_through_a_tiny_play() {
        // The start state's wheels turn relative to the body: their rotors turn with them,
        // so a play of 1e-12 rad is the rigid train (rotors at rest lost 3/4 of a 10 rad/s
        // wheel speed in a spurious impact at the first step). Not bit for bit: each
        // contact is found at its step's end and taken back to its time within the step
        // (measured: 9e-8 of the speed; with the impacts at the steps' ends, 1.4e-5).
        let p = RobotParams::<f64>::balanbot();
        let tiny = Realism { backlash: Some(Backlash { gap: 1e-12 }), ..Realism::ideal() };
        let rigid = Realism { backlash: None, ..tiny };
        let dt = 1e-3;
        let slope = SlopeModel::new(p, 0.0).unwrap();
        let (mut a, mut b) = (tiny.build(&slope, dt).unwrap(), rigid.build(&slope, dt).unwrap());
        let (mut xa, mut xb) = (Vector4::new(0.0, 0.0, 0.0, 10.0), Vector4::new(0.0, 0.0, 0.0, 10.0));
        for k in 0..20 {
            step(&mut a.plant, &mut xa, &SVector::from([0.0]), k as f64 * dt, dt);
            step(&mut b.plant, &mut xb, &SVector::from([0.0]), k as f64 * dt, dt);
        }
        std::println!("2-DOF after 20 ms: wheel speed {} with the play, {} without", xa[3], xb[3]);
        assert!((xa - xb).norm() < 1e-4 * xb.norm(), "{xa} vs {xb}");
        let planar = PlanarModel::new(p).unwrap();
        let (mut a, mut b) = (tiny.build_planar(&planar, dt).unwrap(), rigid.build_planar(&planar, dt).unwrap());
        let start = PlanarState::from([0.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.5]);
        let (mut xa, mut xb) = (start, start);
        for k in 0..20 {
            step(&mut a.plant, &mut xa, &SVector::from([0.0, 0.0]), k as f64 * dt, dt);
            step(&mut b.plant, &mut xb, &SVector::from([0.0, 0.0]), k as f64 * dt, dt);
        }
        std::println!("3-DOF after 20 ms: speed {} with the play, {} without", xa[5], xb[5]);
        assert!((xa - xb).norm() < 1e-4 * xb.norm(), "{xa} vs {xb}");
    }

    #[test]
    fn the_encoder_counts_the_motor_shaft_inside_the_play() {
        // 10° of play, a constant torque from rest: the rotors turn while the wheels have not
        // moved, and the encoder on the motor shaft counts them.
        use crate::sim::runner::Sensor;
        let p = lossless();
        let backlash = Backlash { gap: 10f64.to_radians() };
        let realism = Realism { backlash: Some(backlash), encoder_cpr: Some(700.0), ..Realism::ideal() };
        let dt = 1e-3;
        let slope = SlopeModel::new(p, 0.0).unwrap();
        let mut rig = realism.build(&slope, dt).unwrap();
        let current = 0.04 / p.torque_per_amp();
        let mut x = Vector4::zeros();
        for k in 0..150 {
            step(&mut rig.plant, &mut x, &SVector::from([current]), k as f64 * dt, dt);
        }
        assert_eq!(x, Vector4::zeros(), "the wheels have not moved yet");
        rig.sensors.shaft_offsets(rig.plant.shaft_offsets());
        let y = rig.sensors.read(0.15, &x);
        let counts = y[2] / (core::f64::consts::TAU / 700.0);
        std::println!("after 0.15 s the encoder reads {counts} counts of the rotor, the wheels still");
        assert!(counts >= 3.0, "{counts}");
    }

    #[test]
    fn the_impact_is_located_within_its_step_to_second_order() {
        // A rotor from rest under a constant torque, its wheel held: it reaches the flank at
        // t* = √(2 (gap/2) J / τ). The step's end is late by up to a step; the time located
        // within the step (the end minus `Hit::late`) misses by the offset's interpolation,
        // at most dt²/(8 t*).
        let (j, tau) = (2e-4, 0.02);
        let play = GearPlay::<f64, 1>::new(&Backlash::gb37(), j, 1.0).unwrap();
        let exact = (2.0 * Backlash::<f64>::gb37().gap / 2.0 * j / tau).sqrt();
        let mut worst_end: f64 = 0.0;
        for dt in [1e-3, 7e-4, 5e-4, 3e-4, 2.5e-4, 1.25e-4] {
            let mut p = play;
            let mut k = 0;
            let hit = loop {
                p.next_step([0.0], [0.0], [tau]);
                k += 1;
                if let Some(hit) = p.elapsed(dt, [0.0], None)[0] {
                    break hit;
                }
                assert!(k < 100_000);
            };
            let (end, located) = (k as f64 * dt, k as f64 * dt - hit.late);
            std::println!("dt {dt:.2e}: step end misses t* = {exact:.6} s by {:.2e}, located by {:.2e} (bound {:.2e})", end - exact, located - exact, dt * dt / (8.0 * exact));
            assert!((0.0..=dt).contains(&hit.late), "{}", hit.late);
            assert!((located - exact).abs() <= dt * dt / (8.0 * exact) * 1.01 + 1e-15, "{located} vs {exact}");
            worst_end = worst_end.max(end - exact);
        }
        assert!(worst_end > 1e-4, "the step's end alone is late: {worst_end}");
    }

    /// The 2-DOF rig with `gap` of play (no gearhead friction), upright at rest, driven by a
    /// lumped current `current` that reverses at 0.1 s (the trains open there, at a step's
    /// end for every `dt` below): its state at `t_final`.
    fn reversed_run(dt: f64, current: f64, gap: f64, t_final: f64) -> Vector4<f64> {
        let p = RobotParams::<f64>::balanbot();
        let realism = Realism { backlash: Some(Backlash { gap }), ..Realism::ideal() };
        let slope = SlopeModel::new(p, 0.0).unwrap();
        let mut rig = realism.build(&slope, dt).unwrap();
        let mut x = Vector4::zeros();
        let steps = (t_final / dt).round() as usize;
        let reverse = (0.1 / dt).round() as usize;
        for k in 0..steps {
            let u = if k < reverse { current } else { -current };
            step(&mut rig.plant, &mut x, &SVector::from([u]), k as f64 * dt, dt);
        }
        x
    }

    #[test]
    fn a_geared_run_converges_at_second_order_in_its_step() {
        // Two impacts (the rotors crossing half the play, then the whole play back after
        // the current reverses), located within their steps: the state at 0.25 s converges
        // as dt². Where in its step an impact falls varies with dt, so the error is the RMS
        // over eight currents. (Each impact at its step's end: as dt.)
        let gap = 3f64.to_radians();
        let scale = Vector4::new(1.0, 10.0, 1.0, 10.0);
        let currents: std::vec::Vec<f64> = (0..8).map(|i| 0.15 * (1.0 + 0.05 * f64::from(i))).collect();
        let tf = 0.25;
        let references: std::vec::Vec<Vector4<f64>> = currents.iter().map(|&c| reversed_run(1e-3 / 512.0, c, gap, tf)).collect();
        let errors: std::vec::Vec<f64> = (0..5)
            .map(|k| {
                let dt = 1e-3 / f64::from(1 << k);
                let sum: f64 = currents.iter().zip(&references).map(|(&c, r)| (reversed_run(dt, c, gap, tf) - r).component_div(&scale).norm_squared()).sum();
                (sum / currents.len() as f64).sqrt()
            })
            .collect();
        let order = (errors[0] / errors[4]).log2() / 4.0;
        std::println!("RMS state errors at dt = 1e-3 / 2^k, k = 0..4: {errors:?}; order {order:.2}");
        assert!(order > 1.7, "{order}: {errors:?}");
    }

    #[test]
    fn an_impact_moved_across_a_steps_end_moves_the_run_continuously() {
        // The current scanned so that the first impact moves across three plant steps: the
        // state at 0.25 s changes smoothly, no neighbour pair much apart from the others
        // (each impact at its step's end: the state jumped where it crossed a step's end,
        // the largest change 40x the median before).
        let (dt, gap, t_final) = (1e-3, 3f64.to_radians(), 0.25);
        let scale = Vector4::new(1.0, 10.0, 1.0, 10.0);
        let n = 120;
        let runs: std::vec::Vec<Vector4<f64>> = (0..=n).map(|k| reversed_run(dt, 0.15 * (1.0 + 0.12 * k as f64 / n as f64), gap, t_final)).collect();
        let mut changes: std::vec::Vec<f64> = runs.windows(2).map(|w| (w[1] - w[0]).component_div(&scale).norm()).collect();
        let largest = changes.iter().cloned().fold(0.0, f64::max);
        changes.sort_by(f64::total_cmp);
        let median = changes[changes.len() / 2];
        std::println!("neighbouring runs' state change: largest {largest:.2e}, median {median:.2e} ({:.1}x)", largest / median);
        assert!(largest < 3.0 * median, "{largest} vs {median}");
    }

    #[test]
    fn no_play_is_no_backlash_bit_for_bit() {
        let p = RobotParams::<f64>::balanbot();
        let model = PlanarModel::new(p).unwrap();
        let none = Realism { backlash: None, ..Realism::<f64>::thesis_like() };
        let zero = Realism { backlash: Some(Backlash { gap: 0.0 }), ..none };
        let (mut a, mut b) = (none.build_planar(&model, 1e-3).unwrap(), zero.build_planar(&model, 1e-3).unwrap());
        let (mut xa, mut xb) = (PlanarState::from([0.0, 0.0, 0.0, 0.05, 0.0, 0.0, 0.0]), PlanarState::from([0.0, 0.0, 0.0, 0.05, 0.0, 0.0, 0.0]));
        for i in 0..500 {
            let u = SVector::from([100.0, -80.0]);
            step(&mut a.plant, &mut xa, &u, i as f64 * 1e-3, 1e-3);
            step(&mut b.plant, &mut xb, &u, i as f64 * 1e-3, 1e-3);
        }
        assert_eq!(xa, xb);
        assert!(matches!(Backlash { gap: -1.0 }.validate(), Err(TwipError::InvalidParameter { name: "backlash", .. })));
    }
}
