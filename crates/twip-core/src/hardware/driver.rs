//! The motor drive of the 2-DOF robot (thesis chapter 2): the Arduino's 8-bit PWM, the
//! Balance Shield's L298P bridge on three 18650 cells, two GB37Y3530 gear motors.
//!
//! Plant side, [`Driven`] (per motor; both motors get the same command in 2-DOF):
//!
//! ```text
//! V = pwm / 255 · (V_bat − V_drop)         averaged over a PWM period, |pwm| ≤ 255
//! L di/dt = V − R i − τ_i η (θ̇ − φ̇)          back-EMF from the wheel's speed relative to the body
//! |i| ≤ i_max                              the driver's rating, as a hard clamp
//! u = 2 ε i                                the lumped current of `SlopeModel` (torque η τ_i u)
//! ```
//!
//! ε is [`MotorDriver::efficiency`] (the share of the winding's torque that reaches the
//! wheel; 1 by default) and 2 the number of motors.
//!
//! With L = 0 the current is algebraic and computed inside `deriv` (the back-EMF damping
//! is then implicit in RK4). With L > 0 the current is updated once per plant step by the
//! exact solution for a voltage and speed held over the step; the step's average current
//! drives the mechanics (see [`Driven::advance`]). The electrical time constant L/R
//! (≈ 0.6 ms) is shorter than a typical step, which rules out an RK4 state.
//!
//! Controller side, [`PwmActuator`]: the controllers output a lumped current; the firmware
//! turns it into a duty by feed-forward, `V = R i + τ_i η ω̂` with the *measured* relative
//! wheel speed ω̂ = θ̂̇ − φ̂̇ (the encoder's), rounded to an integer count and saturated.
//!
//! The motor constants come from [`crate::hardware::motor::DcMotor`] (R = 12 V / 7 A from the data
//! sheet) with the torque constant and gear ratio of the plant's `RobotParams`, so that
//! the back-EMF and the torque use the same τ_i. The no-load current of the data sheet is
//! the plant's `mu_bearing` (docs/parameters.md); it is not added here.
use nalgebra::{SVector, Vector4};

use crate::hardware::motor::{DcMotor, BALANBOT_SUPPLY, PWM_MAX};
use crate::model::lane::Lane;
use crate::sim::runner::Actuator;
use crate::{c, Dynamics, Real, RobotParams, TwipError};

/// Motors driven by one 2-DOF command (left and right, lumped).
pub const MOTORS: f64 = 2.0;

/// Battery, bridge and motor electrics. SI units; currents per motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorDriver<T> {
    /// Battery voltage [V] (three 3.7 V cells: 11.1 V).
    pub battery: T,
    /// Voltage lost in the bridge's two conducting transistors [V] (L298: about 2 V).
    pub bridge_drop: T,
    /// Winding resistance [Ω].
    pub resistance: T,
    /// Winding inductance [H]; 0 makes the current algebraic.
    pub inductance: T,
    /// Gearbox efficiency in (0, 1]: the share of η τ_i i that reaches the wheel.
    pub efficiency: T,
    /// Largest current per motor [A]; infinite for none.
    pub current_limit: T,
    /// The battery voltage the firmware's feed-forward assumes [V] (the actual one
    /// by default: a full or flat battery is a gain error).
    pub assumed_battery: T,
}

fn check<T: Real>(name: &'static str, v: T, ok: bool, reason: &'static str) -> Result<T, TwipError> {
    if ok {
        Ok(v)
    } else {
        Err(TwipError::InvalidParameter { name, value: crate::to_f64(v), reason })
    }
}

impl<T: Real> MotorDriver<T> {
    /// The data sheet's motor (Table 2.3: R = 12 V / 7 A) on the 11.1 V battery, with no
    /// bridge drop, no inductance, no limit and a lossless gearbox.
    pub fn gb37y3530() -> Self {
        let battery = c::<T>(BALANBOT_SUPPLY);
        Self {
            battery,
            bridge_drop: T::zero(),
            resistance: DcMotor::<T>::gb37y3530().resistance(),
            inductance: T::zero(),
            efficiency: T::one(),
            current_limit: T::one() / T::zero(),
            assumed_battery: battery,
        }
    }

    /// [`Self::gb37y3530`] with the L298's drop (2 V), an assumed 1 mH winding and the
    /// L298's 2 A DC rating per bridge (docs/parameters.md).
    pub fn thesis_like() -> Self {
        Self { bridge_drop: c(2.0), inductance: c(1e-3), current_limit: c(2.0), ..Self::gb37y3530() }
    }

    /// Checks every field and names the first bad one.
    pub fn validate(&self) -> Result<Self, TwipError> {
        let z = T::zero();
        check("battery", self.battery, self.battery.is_finite() && self.battery > z, "must be finite and > 0")?;
        let drop = self.bridge_drop;
        check("bridge_drop", drop, drop.is_finite() && drop >= z && drop < self.battery, "must be >= 0 and below the battery voltage")?;
        check("resistance", self.resistance, self.resistance.is_finite() && self.resistance > z, "must be finite and > 0")?;
        check("inductance", self.inductance, self.inductance.is_finite() && self.inductance >= z, "must be finite and >= 0")?;
        let eff = self.efficiency;
        check("efficiency", eff, eff > z && eff <= T::one(), "must be in (0, 1]")?;
        check("current_limit", self.current_limit, self.current_limit > z, "must be > 0 (inf for no limit)")?;
        let assumed = self.assumed_battery;
        check("assumed_battery", assumed, assumed.is_finite() && assumed > drop, "must be finite and above the bridge drop")?;
        Ok(*self)
    }

    /// One motor as the plant has it: `params`' torque constant and gear ratio, the
    /// bridge's output at full duty as the supply.
    pub fn motor(&self, params: &RobotParams<T>) -> Result<DcMotor<T>, TwipError> {
        let d = self.validate()?;
        DcMotor::new(d.resistance, params.torque_constant, params.gear_ratio, T::zero(), d.battery - d.bridge_drop, c(PWM_MAX))
    }

    /// Winding current [A] of one motor at terminal voltage `voltage` and relative wheel
    /// speed θ̇ − φ̇ [rad/s], clamped to the limit (steady state: no inductance).
    pub fn current(&self, params: &RobotParams<T>, voltage: T, relative_speed: T) -> Result<T, TwipError> {
        let m = self.motor(params)?;
        Ok(clamp(m.current(voltage, relative_speed), self.current_limit))
    }

    /// Torque of one motor on its wheel [N m] at `voltage` and relative wheel speed.
    pub fn wheel_torque(&self, params: &RobotParams<T>, voltage: T, relative_speed: T) -> Result<T, TwipError> {
        Ok(self.efficiency * params.torque_per_amp() * self.current(params, voltage, relative_speed)?)
    }
}

#[inline(always)]
fn clamp<S: Lane>(v: S, limit: S) -> S {
    v.larger(-limit).smaller(limit)
}

/// One motor's winding behind the bridge: the current a duty gives at a relative wheel
/// speed, algebraic or (with inductance) advanced once per plant step.
#[derive(Clone, Copy, Debug)]
pub struct Winding<T> {
    motor: DcMotor<T>,
    /// The motor's constants for the hot path: volts per count, back-EMF per rad/s, 1/R.
    volts_per_count: T,
    back_emf: T,
    conductance: T,
    limit: T,
    /// L / R [s]; 0 when the current is algebraic.
    tau: T,
    /// (dt, e^(−dt/τ), τ/dt (1 − e^(−dt/τ))) of the last step size.
    factors: (T, T, T),
    /// Current at the start of the step [A] (inductive only).
    current: T,
    /// Average current over the step [A] (inductive only).
    held: T,
}

impl<T: Real> Winding<T> {
    pub fn new(driver: &MotorDriver<T>, params: &RobotParams<T>) -> Result<Self, TwipError> {
        let motor = driver.motor(params)?;
        Ok(Self {
            volts_per_count: motor.supply() / motor.pwm_max(),
            back_emf: motor.k_t() * motor.gear_ratio(),
            conductance: T::one() / motor.resistance(),
            motor,
            limit: driver.current_limit,
            tau: driver.inductance / driver.resistance,
            factors: (T::zero(), T::zero(), T::zero()),
            current: T::zero(),
            held: T::zero(),
        })
    }

    pub fn motor(&self) -> &DcMotor<T> {
        &self.motor
    }

    /// Whether the winding's inductance is modelled.
    pub fn inductive(&self) -> bool {
        self.tau > T::zero()
    }

    /// Current now [A]: the state when inductive, else algebraic.
    #[inline]
    pub fn current(&self, pwm: T, relative_speed: T) -> T {
        if self.inductive() {
            self.current
        } else {
            self.steady_current(pwm, relative_speed)
        }
    }

    /// The current the mechanics feel over the step [A].
    #[inline(always)]
    pub fn mechanical_current(&self, pwm: T, relative_speed: T) -> T {
        if self.inductive() {
            self.held
        } else {
            self.steady_current(pwm, relative_speed)
        }
    }

    /// Inductive only: advances the current over a step of `dt` at the relative speed at
    /// its start with the duty held. Exact for the voltage and speed held constant:
    /// i(s) = i_ss + (i₀ − i_ss) e^(−s/τ); the step's average drives the mechanics.
    pub fn advance(&mut self, pwm: T, relative_speed: T, dt: T) {
        if !self.inductive() {
            return;
        }
        if self.factors.0 != dt {
            let decay = (-dt / self.tau).exp();
            self.factors = (dt, decay, self.tau / dt * (T::one() - decay));
        }
        let (_, decay, average) = self.factors;
        let target = self.free_current(pwm, relative_speed);
        let gap = self.current - target;
        self.held = clamp(target + gap * average, self.limit);
        self.current = clamp(target + gap * decay, self.limit);
    }

    /// Inductive only: the current set to its steady value for `pwm` at `relative_speed`,
    /// as if that duty had been held for many time constants (a prediction that starts
    /// mid-run, where the current is not known).
    pub fn settle(&mut self, pwm: T, relative_speed: T) {
        if self.inductive() {
            self.current = self.steady_current(pwm, relative_speed);
        }
    }
}

// The winding's algebraic current, written once over `Lane`: a run's and a sweep's lanes.
impl<S: Lane> Winding<S> {
    /// The current at once for a duty and relative speed (no inductance):
    /// `DcMotor::current` at `DcMotor::pwm_voltage`, unclamped.
    #[inline(always)]
    fn free_current(&self, pwm: S, relative_speed: S) -> S {
        let pwm_max = self.motor.pwm_max();
        let volts = pwm.larger(-pwm_max).smaller(pwm_max) * self.volts_per_count;
        (volts - self.back_emf * relative_speed) * self.conductance
    }

    /// The steady current (no inductance), clamped to the driver's rating.
    #[inline(always)]
    pub(crate) fn steady_current(&self, pwm: S, relative_speed: S) -> S {
        clamp(self.free_current(pwm, relative_speed), self.limit)
    }
}

impl<T: Copy> Winding<T> {
    /// The same winding in another number type (a sweep's lanes).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub(crate) fn map<S>(&self, f: impl Fn(T) -> S + Copy) -> Winding<S> {
        let (dt, decay, average) = self.factors;
        Winding {
            motor: self.motor.map(f),
            volts_per_count: f(self.volts_per_count),
            back_emf: f(self.back_emf),
            conductance: f(self.conductance),
            limit: f(self.limit),
            tau: f(self.tau),
            factors: (f(dt), f(decay), f(average)),
            current: f(self.current),
            held: f(self.held),
        }
    }
}

/// A 2-DOF plant driven through the bridge: its input is the PWM duty [counts].
#[derive(Clone, Copy, Debug)]
pub struct Driven<T, P> {
    plant: P,
    /// Both motors: they get the same duty and turn at the same relative speed.
    winding: Winding<T>,
    /// 2 ε: lumped current per motor ampere.
    lumped_per_amp: T,
    /// The motors' speed relative to the body while their gear trains are open (backlash;
    /// None: the wheels' β̇).
    open_rotor: Option<T>,
}

impl<T: Real, P> Driven<T, P> {
    /// `plant` driven by `driver`; `params` gives the torque constant and gear ratio.
    pub fn new(plant: P, driver: &MotorDriver<T>, params: &RobotParams<T>) -> Result<Self, TwipError> {
        Ok(Self {
            plant,
            winding: Winding::new(driver, params)?,
            lumped_per_amp: c::<T>(MOTORS) * driver.efficiency,
            open_rotor: None,
        })
    }

    pub fn plant_mut(&mut self) -> &mut P {
        &mut self.plant
    }

    pub fn plant(&self) -> &P {
        &self.plant
    }

    pub fn motor(&self) -> &DcMotor<T> {
        self.winding.motor()
    }

    /// Whether the winding's inductance is modelled.
    pub fn inductive(&self) -> bool {
        self.winding.inductive()
    }

    /// The winding, and the lumped current per motor ampere (2 ε).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub(crate) fn winding(&self) -> (&Winding<T>, T) {
        (&self.winding, self.lumped_per_amp)
    }

    /// The motors now turn at `speed` relative to the body (an open gear train's rotor),
    /// or with the wheels (None).
    pub fn turn_motors_at(&mut self, speed: Option<T>) {
        self.open_rotor = speed;
    }

    /// The motors' speed relative to the body at state `x`.
    #[inline(always)]
    fn motor_speed(&self, x: &Vector4<T>) -> T {
        self.open_rotor.unwrap_or(x[3] - x[1])
    }

    /// Current per motor now [A]: the state when inductive, else algebraic.
    #[inline]
    pub fn current(&self, x: &Vector4<T>, pwm: T) -> T {
        self.winding.current(pwm, self.motor_speed(x))
    }

    /// The lumped current of `SlopeModel` now [A] (both motors, efficiency included).
    #[inline]
    pub fn lumped_current(&self, x: &Vector4<T>, pwm: T) -> T {
        self.lumped_per_amp * self.current(x, pwm)
    }

    /// The lumped current the mechanics feel over the step [A].
    #[inline(always)]
    pub fn mechanical_current(&self, x: &Vector4<T>, pwm: T) -> T {
        self.lumped_per_amp * self.winding.mechanical_current(pwm, self.motor_speed(x))
    }

    /// Inductive only: advances the current over a step of `dt` from the state `x` with
    /// the duty held ([`Winding::advance`]).
    pub fn advance(&mut self, x: &Vector4<T>, pwm: T, dt: T) {
        self.winding.advance(pwm, self.motor_speed(x), dt);
    }

    /// Inductive only: the current set to its steady value at the state `x` for the duty
    /// `pwm` ([`Winding::settle`]).
    pub fn settle(&mut self, x: &Vector4<T>, pwm: T) {
        self.winding.settle(pwm, self.motor_speed(x));
    }
}

impl<T: Real, P: Dynamics<T, 4, 1>> Dynamics<T, 4, 1> for Driven<T, P> {
    const PITCH: usize = P::PITCH;

    // Always inlined: out of line, RK4 reloads the model's constants every stage.
    #[inline(always)]
    fn deriv(&self, x: &Vector4<T>, pwm: &SVector<T, 1>) -> Vector4<T> {
        self.plant.deriv(x, &SVector::<T, 1>::new(self.mechanical_current(x, pwm[0])))
    }

    fn energy(&self, x: &Vector4<T>) -> T {
        self.plant.energy(x)
    }
}

/// The firmware's command → PWM mapping (feed-forward on the measured wheel speed).
#[derive(Clone, Copy, Debug)]
pub struct PwmActuator<T> {
    /// The motor as the firmware believes it is (assumed battery).
    motor: DcMotor<T>,
    /// The command per motor ampere: 2 ε for the lumped current, ε η τ_i for a wheel torque.
    command_per_amp: T,
}

impl<T: Real> PwmActuator<T> {
    /// For the 2-DOF model's lumped current.
    pub fn new(driver: &MotorDriver<T>, params: &RobotParams<T>) -> Result<Self, TwipError> {
        let assumed = MotorDriver { battery: driver.assumed_battery, ..*driver };
        Ok(Self { motor: assumed.motor(params)?, command_per_amp: c::<T>(MOTORS) * driver.efficiency })
    }

    /// For one wheel's torque [N m] (the 3-DOF model's input).
    pub fn per_wheel_torque(driver: &MotorDriver<T>, params: &RobotParams<T>) -> Result<Self, TwipError> {
        let lumped = Self::new(driver, params)?;
        Ok(Self { command_per_amp: driver.efficiency * params.torque_per_amp(), ..lumped })
    }

    /// The actuator from its two parts: the motor as the firmware believes it is, and
    /// the command per motor ampere (> 0).
    pub fn from_parts(motor: DcMotor<T>, command_per_amp: T) -> Result<Self, TwipError> {
        if !(command_per_amp.is_finite() && command_per_amp > T::zero()) {
            return Err(TwipError::InvalidParameter {
                name: "command_per_amp",
                value: crate::to_f64(command_per_amp),
                reason: "must be finite and > 0",
            });
        }
        Ok(Self { motor, command_per_amp })
    }

    /// (motor, command per motor ampere): what [`Self::from_parts`] takes.
    pub fn parts(&self) -> (DcMotor<T>, T) {
        (self.motor, self.command_per_amp)
    }

    /// The duty [counts, integer in ±255] for a command (lumped current or wheel torque)
    /// at a relative wheel speed.
    #[inline]
    pub fn duty(&self, command: T, relative_speed: T) -> T {
        let m = &self.motor;
        let i = command / self.command_per_amp;
        let volts = m.resistance() * i + m.k_t() * m.gear_ratio() * relative_speed;
        let pwm_max = m.pwm_max();
        (volts / m.supply() * pwm_max).round().max(-pwm_max).min(pwm_max)
    }
}

impl<T: Real> Actuator<T, 4, 1> for PwmActuator<T> {
    #[inline]
    fn drive(&mut self, _t: T, command: &SVector<T, 1>, y: &Vector4<T>) -> SVector<T, 1> {
        SVector::<T, 1>::new(self.duty(command[0], y[3] - y[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SlopeModel;

    fn params() -> RobotParams<f64> {
        RobotParams::balanbot()
    }

    #[test]
    fn stall_current_and_no_load_speed_at_12_volts() {
        let d = MotorDriver::<f64>::gb37y3530();
        let p = params();
        assert!((d.current(&p, 12.0, 0.0).unwrap() - 7.0).abs() < 1e-12);
        // No load: the motor's torque balances the bearing friction of one side.
        let friction = p.mu_bearing / MOTORS;
        let (mut lo, mut hi) = (0.0, 100.0);
        for _ in 0..200 {
            let w = 0.5 * (lo + hi);
            if d.wheel_torque(&p, 12.0, w).unwrap() > friction * w { lo = w } else { hi = w }
        }
        let rpm = lo * 60.0 / core::f64::consts::TAU;
        assert!((rpm - 251.0).abs() < 0.1 * 251.0, "no-load {rpm} rpm");
        let i0 = d.current(&p, 12.0, lo).unwrap();
        assert!((i0 - 0.35).abs() < 0.1 * 0.35, "no-load current {i0} A");
    }

    #[test]
    fn inductive_current_follows_the_exact_exponential() {
        let p = params();
        let driver = MotorDriver { inductance: 2e-3, ..MotorDriver::<f64>::gb37y3530() };
        let plant = SlopeModel::new(p, 0.0).unwrap();
        let mut d = Driven::new(plant, &driver, &p).unwrap();
        let x = Vector4::zeros();
        let tau = 2e-3 / driver.resistance;
        let full = 11.1 / driver.resistance;
        let dt = 1e-4;
        for k in 1..=50 {
            d.advance(&x, 255.0, dt);
            let t = k as f64 * dt;
            assert!((d.current(&x, 255.0) - full * (1.0 - (-t / tau).exp())).abs() < 1e-12);
        }
        // The held average lies between the step's start and end values.
        assert!(d.winding.held < d.winding.current);
    }

    #[test]
    fn feed_forward_inverts_the_plant_without_saturation() {
        let p = params();
        let driver = MotorDriver::<f64>::gb37y3530();
        let act = PwmActuator::new(&driver, &p).unwrap();
        let plant = Driven::new(SlopeModel::new(p, 0.0).unwrap(), &driver, &p).unwrap();
        let x = Vector4::new(0.0, 0.5, 0.0, 3.0);
        for u in [-1.0, -0.2, 0.0, 0.3, 1.2] {
            let pwm = act.duty(u, x[3] - x[1]);
            assert_eq!(pwm, pwm.round());
            let got = MOTORS * plant.current(&x, pwm);
            // Within half a count of quantisation.
            let count = driver.battery / 255.0 / driver.resistance * MOTORS;
            assert!((got - u).abs() <= 0.5 * count + 1e-12, "{u} -> {got}");
        }
        assert_eq!(act.duty(1e3, 0.0), 255.0);
        assert_eq!(act.duty(-1e3, 0.0), -255.0);
    }

    #[test]
    fn bad_settings_are_named() {
        let d = MotorDriver::<f64>::gb37y3530();
        for (bad, name) in [
            (MotorDriver { battery: -1.0, ..d }, "battery"),
            (MotorDriver { bridge_drop: 20.0, ..d }, "bridge_drop"),
            (MotorDriver { resistance: 0.0, ..d }, "resistance"),
            (MotorDriver { inductance: f64::NAN, ..d }, "inductance"),
            (MotorDriver { efficiency: 1.5, ..d }, "efficiency"),
            (MotorDriver { current_limit: 0.0, ..d }, "current_limit"),
            (MotorDriver { assumed_battery: 0.0, ..d }, "assumed_battery"),
        ] {
            assert!(matches!(bad.validate(), Err(TwipError::InvalidParameter { name: n, .. }) if n == name), "{name}");
        }
    }
}
