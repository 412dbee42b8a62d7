//! The motor drive of the 2-DOF robot (thesis chapter 2): the Arduino's 8-bit PWM, the
//! Balance Shield's L298P bridge on three 18650 cells, two GB37Y3530 gear motors.
//!
//! Plant side, [`Winding`] (per motor; the rig's plant, `RealPlant`, drives its model by one
//! per input: both motors get the same command in 2-DOF):
//!
//! ```text
//! V = pwm / 255 · (V_bat − V_drop)         averaged over a PWM period, |pwm| ≤ 255
//! L di/dt = V − R i − τ_i η (θ̇ − φ̇)          back-EMF from the wheel's speed relative to the body
//! |i| ≤ i_max                              the driver's rating, as a hard clamp
//! u = 2 ε i                                the lumped current of `SlopeModel` (torque η τ_i u)
//! ```
//!
//! ε is [`MotorDriver::efficiency`] (the share of the winding's torque that reaches the
//! wheel; 1 by default, [`GB37_GEARBOX_EFFICIENCY`] on the thesis-like robot) and 2 the
//! number of motors.
//!
//! With L = 0 the current is algebraic and computed inside `deriv` at each RK4 stage (the
//! back-EMF damping is then implicit in RK4). With L > 0 the current is a state carried
//! from step to step, and each RK4 stage feels the current at its own time and speed: the
//! exact solution for the duty held and the motor's speed linear in time from the step's
//! start to the stage (`Winding::stepped_current`; the first stage weighs the decaying
//! transient so that RK4 integrates it exactly); the next step starts from that solution
//! at the step's end state. It converges at second order in the step against the coupled
//! ODE, and as L → 0 it becomes the algebraic current, stage by stage (tests below). The
//! electrical time constant L/R (≈ 0.6 ms) is shorter than a typical step, which rules
//! out the current as a fifth RK4 state.
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
use crate::model::integrate::Stage;
use crate::model::lane::{saturate, Lane};
#[cfg(feature = "std")] // sweeps' lanes
use crate::model::lane::{Fused, Wide};
use crate::sim::runner::Actuator;
use crate::{c, Real, RobotParams, TwipError};

/// Motors driven by one 2-DOF command (left and right, lumped).
pub const MOTORS: f64 = 2.0;

/// Gearbox efficiency of a 37 mm spur gearmotor at the GB37's 43.7:1 (Table 2.3 gives none):
/// Pololu's 37D data sheet, stall torque over ratio × bare-motor stall torque, 0.93 at 30:1
/// and 0.84 at 50:1, linear in the ratio between them (docs/parameters.md).
pub const GB37_GEARBOX_EFFICIENCY: f64 = 0.87;

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

    /// [`Self::gb37y3530`] with the L298's drop (2 V), an assumed 1 mH winding, the L298's
    /// 2 A DC rating per bridge and a 37 mm gearbox's losses ([`GB37_GEARBOX_EFFICIENCY`];
    /// docs/parameters.md).
    pub fn thesis_like() -> Self {
        Self {
            bridge_drop: c(2.0),
            inductance: c(1e-3),
            efficiency: c(GB37_GEARBOX_EFFICIENCY),
            current_limit: c(2.0),
            ..Self::gb37y3530()
        }
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
        Ok(saturate(m.current(voltage, relative_speed), self.current_limit))
    }

    /// Torque of one motor on its wheel [N m] at `voltage` and relative wheel speed.
    pub fn wheel_torque(&self, params: &RobotParams<T>, voltage: T, relative_speed: T) -> Result<T, TwipError> {
        Ok(self.efficiency * params.torque_per_amp() * self.current(params, voltage, relative_speed)?)
    }
}

/// One motor's winding behind the bridge: the current a duty gives at a relative wheel
/// speed, algebraic or (with inductance) a state that moves within each plant step.
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
    /// The current's solution over the last step size (inductive only).
    factors: StepFactors<T>,
    /// The step under way (inductive only).
    pub(crate) step: WindingStep<T>,
}

/// An inductive winding's step under way: the current and the motor's speed at its start,
/// and the steady current there under the step's duty (unclamped).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct WindingStep<T> {
    current: T,
    speed: T,
    steady: T,
}

/// What the current's solution needs of a step of `dt`, computed once per step size: at
/// each RK4 stage, the weight of the transient i₀ − i_ss(ω₀) and the current's change per
/// rad/s of the speed's ([`Winding::stepped_current`]); and the transient's mean over the
/// step, τ (1 − e^(−dt/τ))/dt.
#[derive(Clone, Copy, Debug)]
struct StepFactors<T> {
    dt: T,
    start: (T, T),
    half: (T, T),
    end: (T, T),
    mean: T,
}

impl<T: Real> StepFactors<T> {
    fn new(tau: T, per_speed: T, dt: T) -> Self {
        // At s into the step: e^(−s/τ), and k/R (1 − τ (1 − e^(−s/τ))/s).
        let at = |s: T| {
            let decay = (-s / tau).exp();
            (decay, per_speed * (T::one() - tau / s * (T::one() - decay)))
        };
        let (half, end) = (at(dt / c(2.0)), at(dt));
        let mean = tau / dt * (T::one() - end.0);
        // RK4 weighs its stages' (start, half, end) 1/6, 4/6, 1/6 (Simpson): with this at
        // the start it integrates the transient e^(−s/τ) exactly. 1 − O((dt/τ)^4) for a
        // long τ, 0 as τ → 0 (the current at once: the algebraic one).
        let first = c::<T>(6.0) * mean - c::<T>(4.0) * half.0 - end.0;
        Self { dt, start: (first, T::zero()), half, end, mean }
    }
}

impl<T: Real> Winding<T> {
    pub fn new(driver: &MotorDriver<T>, params: &RobotParams<T>) -> Result<Self, TwipError> {
        let motor = driver.motor(params)?;
        let z = T::zero();
        Ok(Self {
            volts_per_count: motor.supply() / motor.pwm_max(),
            back_emf: motor.k_t() * motor.gear_ratio(),
            conductance: T::one() / motor.resistance(),
            motor,
            limit: driver.current_limit,
            tau: driver.inductance / driver.resistance,
            factors: StepFactors { dt: z, start: (z, z), half: (z, z), end: (z, z), mean: z },
            step: WindingStep { current: z, speed: z, steady: z },
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
            self.step.current
        } else {
            self.steady_current(pwm, relative_speed)
        }
    }

    /// Current [A] at an RK4 stage of the step, the motor turning at `relative_speed` there:
    /// the exact solution of the step under way (module docs) when inductive, else algebraic.
    #[inline(always)]
    pub fn current_at(&self, pwm: T, relative_speed: T, stage: Stage) -> T {
        if self.inductive() {
            self.stepped_current(stage, relative_speed)
        } else {
            self.steady_current(pwm, relative_speed)
        }
    }

    /// The current's mean over the step [A] with the motor's speed held at
    /// `relative_speed` (what an open gear train's rotor is driven by: its speed moves on
    /// its own, per step).
    #[inline]
    pub fn mean_current(&self, pwm: T, relative_speed: T) -> T {
        if self.inductive() {
            self.stepped_mean()
        } else {
            self.steady_current(pwm, relative_speed)
        }
    }

    /// Inductive only: a step of `dt` starts with the duty `pwm` held over it and the motor
    /// at `relative_speed`.
    pub fn start_step(&mut self, pwm: T, relative_speed: T, dt: T) {
        if self.inductive() {
            self.prepare(dt);
            self.begin_step(pwm, relative_speed);
        }
    }

    /// Inductive only: the step under way ended with the motor at `relative_speed`.
    pub fn end_step(&mut self, relative_speed: T) {
        if self.inductive() {
            self.finish_step(relative_speed);
        }
    }

    /// The factors of the current's solution for steps of `dt` (the sweeps' lanes take
    /// them once per block).
    #[inline]
    pub(crate) fn prepare(&mut self, dt: T) {
        if self.factors.dt != dt {
            self.factors = StepFactors::new(self.tau, self.back_emf * self.conductance, dt);
        }
    }

    /// Inductive only: the current set to its steady value for `pwm` at `relative_speed`,
    /// as if that duty had been held for many time constants (a prediction that starts
    /// mid-run, where the current is not known).
    pub fn settle(&mut self, pwm: T, relative_speed: T) {
        if self.inductive() {
            self.step.current = self.steady_current(pwm, relative_speed);
        }
    }
}

// The winding's current, written once over `Lane`: a run's and a sweep's lanes.
impl<S: Lane> Winding<S> {
    /// The current at once for a duty and relative speed (no inductance):
    /// `DcMotor::current` at `DcMotor::pwm_voltage`, unclamped.
    #[inline(always)]
    fn free_current(&self, pwm: S, relative_speed: S) -> S {
        let pwm_max = self.motor.pwm_max();
        let volts = saturate(pwm, pwm_max) * self.volts_per_count;
        (volts - self.back_emf * relative_speed) * self.conductance
    }

    /// The steady current (no inductance), clamped to the driver's rating.
    #[inline(always)]
    pub(crate) fn steady_current(&self, pwm: S, relative_speed: S) -> S {
        saturate(self.free_current(pwm, relative_speed), self.limit)
    }

    /// Inductive: the current at an RK4 stage of the step under way, s into it (`stage`),
    /// the motor turning at ω_s = `relative_speed` there. With the duty held,
    /// τ di/dσ = i_ss(ω) − i, where the steady current i_ss(ω) = (V − k ω)/R is affine in
    /// ω; for ω linear in time from the step's start (ω₀, current i₀) to the stage, the
    /// exact solution is
    ///   i(s) = i_ss(ω₀) + e^(−s/τ) (i₀ − i_ss(ω₀)) − k/R (ω_s − ω₀) (1 − τ (1 − e^(−s/τ))/s),
    /// clamped to the rating; the first stage weighs the transient i₀ − i_ss(ω₀) so that
    /// RK4 integrates it exactly (`StepFactors::new`). As τ → 0 it is i_ss(ω_s), the
    /// algebraic current at every stage. Second order in the step (tests below).
    #[inline(always)]
    pub(crate) fn stepped_current(&self, stage: Stage, relative_speed: S) -> S {
        let (decay, follow) = match stage {
            Stage::Start => self.factors.start,
            Stage::Half => self.factors.half,
            Stage::End => self.factors.end,
        };
        let WindingStep { current, speed, steady } = self.step;
        saturate(S::madd(decay, current - steady, steady) - follow * (relative_speed - speed), self.limit)
    }

    /// Inductive: a step starts under the duty `pwm` with the motor at `relative_speed`,
    /// from the current the last one ended with (its factors prepared for the step size).
    #[inline(always)]
    pub(crate) fn begin_step(&mut self, pwm: S, relative_speed: S) {
        self.step = WindingStep { current: self.step.current, speed: relative_speed, steady: self.free_current(pwm, relative_speed) };
    }

    /// Inductive: the step under way ended with the motor at `relative_speed`; the current
    /// there is the next step's start.
    #[inline(always)]
    pub(crate) fn finish_step(&mut self, relative_speed: S) {
        self.step.current = self.stepped_current(Stage::End, relative_speed);
    }

    /// Inductive: the current now (where the last step ended, or the step under way began).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    #[inline(always)]
    pub(crate) fn step_current(&self) -> S {
        self.step.current
    }

    /// Inductive: the current's mean over the step under way with the motor's speed held.
    #[inline(always)]
    pub(crate) fn stepped_mean(&self) -> S {
        let WindingStep { current, steady, .. } = self.step;
        saturate(S::madd(current - steady, self.factors.mean, steady), self.limit)
    }
}

impl<T: Copy> Winding<T> {
    /// The same winding in another number type (a sweep's lanes).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    #[inline(always)]
    pub(crate) fn map<S>(&self, f: impl Fn(T) -> S + Copy) -> Winding<S> {
        self.zip(self, move |&v, _| f(v))
    }

    /// Each number with `other`'s, combined by `f` (windings side by side on a sweep's
    /// lanes, [`Winding::side_by_side`]). The numbers are passed by reference: a lane's
    /// winding taken from a block's ([`Winding::lane`]) reads only its lane.
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    #[inline(always)]
    pub(crate) fn zip<U, S>(&self, other: &Winding<U>, f: impl Fn(&T, &U) -> S + Copy) -> Winding<S> {
        let (a, b) = (&self.factors, &other.factors);
        let pair = |x: &(T, T), y: &(U, U)| (f(&x.0, &y.0), f(&x.1, &y.1));
        let (s, o) = (&self.step, &other.step);
        Winding {
            motor: self.motor.zip(&other.motor, f),
            volts_per_count: f(&self.volts_per_count, &other.volts_per_count),
            back_emf: f(&self.back_emf, &other.back_emf),
            conductance: f(&self.conductance, &other.conductance),
            limit: f(&self.limit, &other.limit),
            tau: f(&self.tau, &other.tau),
            factors: StepFactors {
                dt: f(&a.dt, &b.dt),
                start: pair(&a.start, &b.start),
                half: pair(&a.half, &b.half),
                end: pair(&a.end, &b.end),
                mean: f(&a.mean, &b.mean),
            },
            step: WindingStep { current: f(&s.current, &o.current), speed: f(&s.speed, &o.speed), steady: f(&s.steady, &o.steady) },
        }
    }
}

#[cfg(feature = "std")] // sweeps' lanes
impl Winding<f64> {
    /// `N` windings side by side, lane j's numbers the j-th of each (a sweep's lanes).
    pub(crate) fn side_by_side<const N: usize>(windings: &[Winding<f64>; N]) -> Winding<Wide<N>> {
        let mut out = windings[0].map(|v| Wide([v; N]));
        for (j, w) in windings.iter().enumerate().skip(1) {
            out = out.zip(w, |&lanes, &v| {
                let mut lanes = lanes;
                lanes.0[j] = v;
                lanes
            });
        }
        out
    }
}

#[cfg(feature = "std")] // sweeps' lanes
impl<const N: usize> Winding<Wide<N>> {
    /// Lane `j`'s winding: inlined into a loop over lanes, it reads only the numbers used.
    #[inline(always)]
    pub(crate) fn lane(&self, j: usize) -> Winding<Fused> {
        self.zip(self, |w, _| Fused(w.0[j]))
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
        let (_, counts) = self.wanted(command, relative_speed);
        saturate(counts, self.motor.pwm_max())
    }

    /// Whether a command at a relative wheel speed is beyond what a driver with
    /// `current_limit` [A per motor] delivers: its duty past full (the supply cannot give
    /// the voltage) or its current past the limit (the driver clamps it).
    #[inline]
    pub fn beyond(&self, command: T, relative_speed: T, current_limit: T) -> bool {
        let (i, counts) = self.wanted(command, relative_speed);
        counts.abs() > self.motor.pwm_max() || i.abs() > current_limit
    }

    /// The current per motor a command asks [A] and the duty it wants [counts, whole,
    /// not saturated].
    #[inline(always)]
    fn wanted(&self, command: T, relative_speed: T) -> (T, T) {
        let m = &self.motor;
        let i = command / self.command_per_amp;
        let volts = m.resistance() * i + m.k_t() * m.gear_ratio() * relative_speed;
        (i, (volts / m.supply() * m.pwm_max()).round())
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

    fn params() -> RobotParams<f64> {
        RobotParams::balanbot()
    }

    #[test]
    fn stall_current_and_no_load_speed_at_12_volts() {
        let d = MotorDriver::<f64>::gb37y3530();
        let p = params();
        assert!((d.current(&p, 12.0, 0.0).unwrap() - 7.0).abs() < 1e-12);
        assert!(d.current(&p, f64::NAN, 0.0).unwrap().is_nan(), "a NaN voltage is not hidden by the current limit");
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

    /// The thesis-like gearbox efficiency is the Pololu 37D data sheet's (12 V line): stall
    /// torque over ratio × the bare motor's 5 kg·mm stall, 140 kg·mm at 30:1 and 210 at 50:1,
    /// linear in the ratio at the GB37's 43.7:1; it takes the stall torque at the wheel from
    /// 2.81 to 2.44 N m at 11.1 V (docs/parameters.md).
    #[test]
    fn gearbox_efficiency_is_the_data_sheets_at_the_gb37s_ratio() {
        use crate::hardware::motor::DataSheet;
        let (at30, at50) = (140.0 / (30.0 * 5.0), 210.0 / (50.0 * 5.0));
        let ratio = DataSheet::<f64>::gb37y3530().gear_ratio;
        let interpolated = at30 + (ratio - 30.0) / (50.0 - 30.0) * (at50 - at30);
        assert!((interpolated - GB37_GEARBOX_EFFICIENCY).abs() < 0.005, "{interpolated}");
        assert_eq!(MotorDriver::<f64>::thesis_like().efficiency, GB37_GEARBOX_EFFICIENCY);
        let p = params();
        let lossless = MotorDriver::<f64>::gb37y3530();
        let geared = MotorDriver { efficiency: GB37_GEARBOX_EFFICIENCY, ..lossless };
        let stall = |d: &MotorDriver<f64>| d.wheel_torque(&p, BALANBOT_SUPPLY, 0.0).unwrap();
        assert!((stall(&lossless) - 2.807).abs() < 5e-4 && (stall(&geared) - 2.442).abs() < 5e-4);
    }

    #[test]
    fn inductive_current_follows_the_exact_exponential() {
        let p = params();
        let driver = MotorDriver { inductance: 2e-3, ..MotorDriver::<f64>::gb37y3530() };
        let mut w = Winding::new(&driver, &p).unwrap();
        let tau = 2e-3 / driver.resistance;
        let full = 11.1 / driver.resistance;
        let dt = 1e-4;
        for k in 1..=50 {
            w.start_step(255.0, 0.0, dt);
            w.end_step(0.0);
            let t = k as f64 * dt;
            assert!((w.current(255.0, 0.0) - full * (1.0 - (-t / tau).exp())).abs() < 1e-12);
        }
        // The rising current's mean over a step lies between its start and end values.
        w.start_step(255.0, 0.0, dt);
        let start = w.current(255.0, 0.0);
        let mean = w.mean_current(255.0, 0.0);
        w.end_step(0.0);
        assert!(start < mean && mean < w.current(255.0, 0.0));
    }

    #[test]
    fn feed_forward_inverts_the_plant_without_saturation() {
        let p = params();
        let driver = MotorDriver::<f64>::gb37y3530();
        let act = PwmActuator::new(&driver, &p).unwrap();
        let winding = Winding::new(&driver, &p).unwrap();
        let x = Vector4::new(0.0, 0.5, 0.0, 3.0);
        for u in [-1.0, -0.2, 0.0, 0.3, 1.2] {
            let pwm = act.duty(u, x[3] - x[1]);
            assert_eq!(pwm, pwm.round());
            let got = MOTORS * winding.current(pwm, x[3] - x[1]);
            // Within half a count of quantisation.
            let count = driver.battery / 255.0 / driver.resistance * MOTORS;
            assert!((got - u).abs() <= 0.5 * count + 1e-12, "{u} -> {got}");
        }
        assert_eq!(act.duty(1e3, 0.0), 255.0);
        assert_eq!(act.duty(-1e3, 0.0), -255.0);
        // A NaN command stays NaN (the runner then stops: diverged), not a full-reverse duty.
        assert!(act.duty(f64::NAN, 0.0).is_nan());
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

    /// The rig's inductive driver against the coupled ODE it stands for.
    #[cfg(feature = "std")]
    mod against_the_coupled_ode {
        use super::*;
        use crate::{Dynamics, SlopeModel};

        /// The audit's setting: the thesis-like drive (1 mH, 2 V drop) open loop on a 0.1 rad
        /// slope, a duty swinging through ±200 counts, held over control periods of 2^-8 s.
        fn open_loop_duty(t: f64) -> f64 {
            let period = 1.0 / 256.0;
            (200.0 * (30.0 * (t / period).floor() * period + 0.3).sin()).round()
        }

        const SPAN: f64 = 0.25;

        /// The rig's 2-DOF plant driven open loop through `driver` for `SPAN` in steps of `dt`,
        /// as the runner steps it; every step's (state, current per motor).
        fn rig_run(driver: &MotorDriver<f64>, dt: f64) -> std::vec::Vec<(Vector4<f64>, f64)> {
            use crate::hardware::realism::{Realism, RigPlant};
            use crate::sim::runner::Plant;
            let model = SlopeModel::new(params(), 0.1).unwrap();
            let mut plant = Realism { motor: Some(*driver), ..Realism::ideal() }.build(&model, dt).unwrap().plant;
            let mut x = Vector4::new(0.1, 0.0, 0.0, 0.0);
            let per_motor = MOTORS * driver.efficiency;
            let mut out = std::vec![(x, 0.0)];
            for k in 0..(SPAN / dt).round() as usize {
                let t = k as f64 * dt;
                let u = SVector::<f64, 1>::new(open_loop_duty(t));
                plant.between_steps(t, dt, &mut x, &u);
                x = crate::rk4_step(&plant, &x, &u, dt);
                plant.step_ended(&x);
                out.push((x, plant.currents(&x, &u)[0] / per_motor));
            }
            out
        }

        /// The coupled ODE the driver stands for, written out on its own: the four mechanical
        /// states and the winding current, L di/dt = V − R i − k_t η (θ̇ − φ̇), the current
        /// clamped to the rating (held there while it pushes past), by classical RK4 in fine
        /// steps of 2^-18 s (without the limit, its error is below 1e-9: steps of 2^-19 s give
        /// the errors below to three digits). The final (state, current).
        fn coupled_ode(driver: &MotorDriver<f64>) -> (Vector4<f64>, f64) {
            let p = params();
            let model = SlopeModel::new(p, 0.1).unwrap();
            let (emf, supply, limit) = (p.torque_constant * p.gear_ratio, driver.battery - driver.bridge_drop, driver.current_limit);
            let f = |z: &[f64; 5], duty: f64| -> [f64; 5] {
                let i = z[4].clamp(-limit, limit);
                let x = Vector4::new(z[0], z[1], z[2], z[3]);
                let d = model.deriv(&x, &SVector::<f64, 1>::new(MOTORS * driver.efficiency * i));
                let mut di = (duty / 255.0 * supply - driver.resistance * i - emf * (z[3] - z[1])) / driver.inductance;
                if (i >= limit && di > 0.0) || (i <= -limit && di < 0.0) {
                    di = 0.0;
                }
                [d[0], d[1], d[2], d[3], di]
            };
            let h = 1.0 / 262144.0;
            let mut z = [0.1, 0.0, 0.0, 0.0, 0.0];
            let add = |z: &[f64; 5], k: &[f64; 5], s: f64| -> [f64; 5] { core::array::from_fn(|i| z[i] + s * k[i]) };
            for k in 0..(SPAN / h).round() as usize {
                let duty = open_loop_duty(k as f64 * h);
                let k1 = f(&z, duty);
                let k2 = f(&add(&z, &k1, h / 2.0), duty);
                let k3 = f(&add(&z, &k2, h / 2.0), duty);
                let k4 = f(&add(&z, &k3, h), duty);
                z = core::array::from_fn(|i| z[i] + h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]));
            }
            (Vector4::new(z[0], z[1], z[2], z[3]), z[4].clamp(-limit, limit))
        }

        /// Relative error of a state against a reference's: max |difference| / max |reference|.
        fn relative(x: &Vector4<f64>, reference: &Vector4<f64>) -> f64 {
            (x - reference).amax() / reference.amax()
        }

        #[test]
        fn an_inductive_rig_converges_at_second_order_to_the_coupled_ode() {
            // Without a limit the solution is smooth: the order shows clean. Before the stages
            // felt the current within the step, the ratios were 2 (first order).
            let driver = MotorDriver { current_limit: f64::INFINITY, ..MotorDriver::thesis_like() };
            let (reference, i_ref) = coupled_ode(&driver);
            let mut errors = std::vec::Vec::new();
            for dt in [1.0 / 1024.0, 1.0 / 2048.0, 1.0 / 4096.0, 1.0 / 8192.0] {
                let &(x, i) = rig_run(&driver, dt).last().unwrap();
                std::println!("dt {dt:.3e}: relative state error {:.2e}, current error {:.2e} A", relative(&x, &reference), (i - i_ref).abs());
                errors.push(relative(&x, &reference));
            }
            let ratios: std::vec::Vec<f64> = errors.windows(2).map(|e| e[0] / e[1]).collect();
            let order = (errors[0] / errors[3]).log2() / 3.0;
            std::println!("ratios {ratios:.2?}, order {order:.2}");
            assert!(ratios.iter().all(|&r| r > 3.5) && order >= 2.0, "{ratios:?} {order}");
        }

        #[test]
        fn with_its_limit_the_inductive_rig_follows_the_coupled_ode() {
            // The thesis-like 2 A rating clamps the current at the duty's peaks: the solution
            // has kinks there, and the order is measured looser, over coarser steps (the fine
            // reference's own error is ~3e-6 here: it halves the step no more than 2^-18 s).
            let driver = MotorDriver::thesis_like();
            let (reference, _) = coupled_ode(&driver);
            let mut errors = std::vec::Vec::new();
            for dt in [1.0 / 1024.0, 1.0 / 2048.0, 1.0 / 4096.0] {
                let run = rig_run(&driver, dt);
                let peak = run.iter().map(|(_, i)| i.abs()).fold(0.0, f64::max);
                assert!(peak == driver.current_limit, "dt {dt}: peak {peak} A");
                errors.push(relative(&run.last().unwrap().0, &reference));
            }
            let order = (errors[0] / errors[2]).log2() / 2.0;
            std::println!("limited: relative state errors {:.2e} .. {:.2e}, order {order:.2}", errors[0], errors[2]);
            assert!(errors[0] < 5e-4 && order > 1.5, "{errors:?} {order}");
        }

        #[test]
        fn a_vanishing_inductance_is_the_algebraic_driver() {
            // Stage by stage, as τ → 0 the winding's solution is the current without inductance.
            let dt = 1e-3;
            let algebraic = rig_run(&MotorDriver { inductance: 0.0, ..MotorDriver::thesis_like() }, dt);
            let vanishing = rig_run(&MotorDriver { inductance: 1e-12, ..MotorDriver::thesis_like() }, dt);
            let scale = algebraic.iter().map(|(x, _)| x.amax()).fold(0.0, f64::max);
            let gap = algebraic.iter().zip(&vanishing).map(|((a, _), (b, _))| (a - b).amax()).fold(0.0, f64::max) / scale;
            std::println!("L = 1e-12 H against L = 0: relative state difference {gap:.1e}");
            assert!(gap < 1e-9, "{gap:e}");
        }
    }
}
