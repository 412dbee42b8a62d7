//! "Does this controller still work on my robot?": the 2-DOF loop with the robot's real
//! parts, each optional. [`Realism`] says which; [`Realism::build`] turns it into
//! - a plant, [`SlopePlant`]: the slope model on its slope profile with the force, pushes,
//!   gear play and motor driver the realism has ([`RealPlant`](crate::hardware::rig_plant::RealPlant), the 3-DOF rig's too);
//! - a [`Sensor`], [`BalanceSensors`]: MPU-6050 + tilt estimator + encoder, or the truth
//!   for each part left out;
//! - an [`Actuator`], [`RealActuator`]: the firmware's current → PWM mapping, or none;
//!
//! and [`simulate_rig`] runs them through the one loop, `runner::run_loop`, with what
//! happens to the plant between steps (pushes, the winding current) and the
//! measurement, duty and motor current logged beside the controller's internals. Nothing allocates; noise comes from
//! one [`Sfc64`] stream (seed, stream), so a run is bitwise repeatable.
use nalgebra::{SVector, Vector4};

use crate::control::{Controller, Reference};
use crate::hardware::disturbance::{Force, Pushes, SlopePlant, SlopeProfile, MAX_SLOPE_CHANGES};
use crate::hardware::driver::{MotorDriver, PwmActuator, Winding};
use crate::hardware::encoder::Encoder;
use crate::hardware::imu::{specific_force, ImuClock, ImuReading, ImuSettings, Mpu6050, NoiseBatch};
use crate::hardware::backlash::Backlash;
use crate::hardware::settle::{Settle, Settles, Settling};
use crate::model::friction::{Friction, GB37_STICK_SPEED};
#[cfg(all(test, feature = "std"))]
use crate::model::integrate::Stage;
use crate::rng::Sfc64;
use crate::sim::runner::{run_loop, Actuator, Loop, Observer, Outcome, Plant, Sensor, Signals, SimConfig, MAX_RAW};
use crate::hardware::tilt::{accel_tilt, TiltEstimator, TiltFilter};
#[cfg(all(test, feature = "std"))]
use crate::Dynamics;
use crate::{c, Real, RobotParams, SlopeModel, TwipError};

/// How long the thesis-like rig's robot stands still before its run [s]: two of the
/// complementary filter's time constants.
pub const THESIS_LIKE_SETTLE: f64 = 2.0;

/// Which real parts are in the loop. `Default` is the ideal loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Realism<T: Real> {
    /// The MPU-6050 and the tilt estimator that reads it (None: the true φ, φ̇).
    pub imu: Option<ImuSettings<T>>,
    pub estimator: TiltEstimator<T>,
    /// Encoder counts per wheel revolution (None: the true θ, θ̇).
    pub encoder_cpr: Option<T>,
    /// Battery, bridge and motors (None: the plant gets the commanded current).
    pub motor: Option<MotorDriver<T>>,
    /// Apply each command one control period late.
    pub delay: bool,
    /// The firmware's loop period [s] (None: the controller's own).
    pub control_period: Option<T>,
    pub pushes: Pushes<T>,
    pub force: Force<T>,
    /// Slope changes along the path; the base is the plant's own slope.
    pub slope_profile: SlopeProfile<T>,
    /// Gearhead friction per wheel (None: the model's own, if any).
    pub friction: Option<Friction<T>>,
    /// Free play in each wheel's gear train (None: none).
    pub backlash: Option<Backlash<T>>,
    /// Seconds the robot stands still at its initial pitch before the run while the
    /// firmware's loop reads the IMU through the estimator ([`Settle`]; None or 0: the
    /// estimator starts at the run's first read).
    pub settle: Option<T>,
    pub seed: u64,
    pub stream: u64,
}

impl<T: Real> Default for Realism<T> {
    fn default() -> Self {
        Self::ideal()
    }
}

impl<T: Real> Realism<T> {
    /// Every part ideal: the same run as without realism.
    pub fn ideal() -> Self {
        Self {
            imu: None,
            estimator: TiltEstimator::complementary(),
            encoder_cpr: None,
            motor: None,
            delay: false,
            control_period: None,
            pushes: Pushes::none(),
            force: Force::none(),
            slope_profile: SlopeProfile::constant(T::zero()),
            friction: None,
            backlash: None,
            settle: None,
            seed: 0,
            stream: 0,
        }
    }

    /// The thesis's robot as built (chapter 2, docs/parameters.md): a 5 ms Arduino loop
    /// that applies its command one period late, the MPU-6050 at DLPF 44/42 Hz with its
    /// data-sheet noise and calibrated residual biases, a complementary filter, 700 CPR
    /// encoders, the L298P on 11.1 V, and the GB37 gearheads: their friction, the data
    /// sheet's no-load torque split beside the Balanbot's viscous bearing (0.0117 N m
    /// Coulomb per wheel) with a stick band ([`Self::thesis_like_friction`]), and 1° of
    /// backlash ([`Backlash::gb37`]). The firmware's estimator settles for
    /// [`THESIS_LIKE_SETTLE`] at rest before the motors run. No disturbances.
    pub fn thesis_like() -> Self {
        Self {
            imu: Some(ImuSettings::thesis_like()),
            encoder_cpr: Some(c(crate::control::pid::ENCODER_CPR)),
            motor: Some(MotorDriver::thesis_like()),
            delay: true,
            control_period: Some(c(5e-3)),
            friction: Some(Self::thesis_like_friction()),
            backlash: Some(Backlash::gb37()),
            settle: Some(c(THESIS_LIKE_SETTLE)),
            ..Self::ideal()
        }
    }

    /// The Balanbot's GB37 gearhead friction per wheel: `Friction::gb37_beside` its
    /// fitted viscous bearing, with the stick band [`GB37_STICK_SPEED`].
    pub fn thesis_like_friction() -> Friction<T> {
        let bearing_per_wheel = RobotParams::<T>::balanbot().mu_bearing / c(2.0);
        Friction::gb37_beside(bearing_per_wheel).with_stick(c(GB37_STICK_SPEED))
    }

    /// The gearhead friction a rig's plant gets: this realism's, else the model's.
    pub fn friction_on(&self, model: Option<&Friction<T>>) -> Option<Friction<T>> {
        self.friction.or(model.copied())
    }

    pub fn with_stream(self, stream: u64) -> Self {
        Self { stream, ..self }
    }

    pub fn validate(&self) -> Result<Self, TwipError> {
        if let Some(imu) = &self.imu {
            imu.validate()?;
        }
        self.estimator.validate()?;
        if let Some(f) = &self.friction {
            f.validate()?;
        }
        if let Some(b) = &self.backlash {
            b.validate()?;
        }
        if let Some(cpr) = self.encoder_cpr {
            Encoder::new(cpr)?;
        }
        if let Some(seconds) = self.settle {
            crate::hardware::settle::check(seconds)?;
        }
        if let Some(m) = &self.motor {
            m.validate()?;
        }
        if let Some(p) = self.control_period {
            if !(p.is_finite() && p > T::zero()) {
                let value = crate::to_f64(p);
                return Err(TwipError::InvalidParameter { name: "control_period", value, reason: "must be finite and > 0" });
            }
        }
        self.force.validate()?;
        Ok(*self)
    }

    /// The plant, sensor and actuator for a run of `model` at plant step `dt`.
    pub fn build(&self, model: &SlopeModel<T>, dt: T) -> Result<SlopeRig<T>, TwipError> {
        let s = self.validate()?;
        let params = *model.params();
        let profile = s.slope_profile.with_base(model.slope());
        let mut pushes = s.pushes;
        pushes.rewind();
        let plant = SlopePlant::disturbed(params, profile, s.force, pushes)?
            .with_friction(s.friction_on(model.friction()))?
            .with_backlash(s.backlash)?
            .with_driver(s.motor.as_ref(), &params)?;
        let actuator = match &s.motor {
            None => RealActuator::Ideal,
            Some(m) => RealActuator::Pwm(PwmActuator::new(m, &params)?, m.current_limit, m.efficiency),
        };
        let sensors = BalanceSensors::new(s.imu.as_ref(), s.estimator, s.encoder_cpr, profile, &params, dt, s.seed, s.stream)?
            .settled(Settle::new(s.settle, dt, s.seed, s.stream)?);
        Ok(Rig { plant, sensors, actuator, delay: s.delay })
    }
}

/// A realism rig: everything a run needs besides the controller and reference.
#[derive(Clone, Copy, Debug)]
pub struct Rig<P, S, A> {
    pub plant: P,
    pub sensors: S,
    pub actuator: A,
    pub delay: bool,
}

/// The 2-DOF rig ([`Realism::build`]).
pub type SlopeRig<T> = Rig<SlopePlant<T>, BalanceSensors<T>, RealActuator<T>>;

impl<P, S, A> Rig<P, S, A> {
    /// Runs `controller` through this rig's plant, sensors, actuator and delay with the
    /// one loop (`runner::run_loop`): the observer sees the command being applied and,
    /// after the controller's internals, the rig's signals ([`RigSignals`]);
    /// `should_stop` is asked every [`STOP_CHECK_STEPS`](crate::sim::runner::STOP_CHECK_STEPS) steps.
    #[allow(clippy::too_many_arguments)]
    pub fn simulate<T, C, R, O, F, const NX: usize, const NU: usize>(
        &mut self,
        controller: &mut C,
        reference: &R,
        x0: &SVector<T, NX>,
        config: &SimConfig<T>,
        observer: &mut O,
        should_stop: F,
    ) -> Result<(Outcome<T>, usize), TwipError>
    where
        T: Real,
        P: RigPlant<T, NX, NU>,
        S: Sensor<T, NX>,
        A: Actuator<T, NX, NU>,
        R: Reference<T>,
        C: Controller<T, NX, NU, Reference = R::Sample>,
        O: Observer<T, NX, NU, R::Sample>,
        F: FnMut() -> bool,
    {
        let (_, per_update) = config.steps(controller.period())?;
        self.sensors.settle(x0, config.dt * c::<T>(per_update as f64));
        let parts = Loop {
            sensor: &mut self.sensors,
            actuator: &mut self.actuator,
            observer,
            should_stop,
            delay_one_period: self.delay,
        };
        run_loop(&mut self.plant, controller, reference, x0, config, parts, &mut RigSignals::<T, NX, NU>::new())
    }
}

/// The IMU samples on the plant's grid: its period must be whole steps of `dt`.
pub(crate) fn check_imu_grid<T: Real>(settings: &ImuSettings<T>, dt: T) -> Result<(), TwipError> {
    let ratio = settings.sample_period / dt;
    let whole = ratio.round();
    if !(dt.is_finite() && dt > T::zero()) || whole < T::one() || (ratio - whole).abs() > c::<T>(1e-6) * ratio {
        return Err(TwipError::InvalidParameter {
            name: "dt",
            value: crate::to_f64(dt),
            reason: "must divide the IMU's sample period (1 / its sample_rate)",
        });
    }
    Ok(())
}

/// The IMU + tilt estimator + encoder of the 2-DOF robot, as one sensor.
#[derive(Clone, Copy, Debug)]
pub struct BalanceSensors<T: Real> {
    imu: Option<Mpu6050<T>>,
    tilt: TiltFilter<T>,
    encoder: Option<Encoder<T>>,
    /// The ground under the robot (the accelerometer feels its slope), and sin, cos of
    /// each of its slopes.
    ground: SlopeProfile<T>,
    ground_trig: [(T, T); MAX_SLOPE_CHANGES + 1],
    radius: T,
    g: T,
    /// When the IMU samples.
    clock: ImuClock<T>,
    rng: Sfc64,
    last_read: Option<T>,
    /// The motor shaft's angle minus the wheels' (backlash): the encoder counts the shaft.
    shaft: T,
    settle: Option<Settle<T>>,
}

impl<T: Real> BalanceSensors<T> {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        imu: Option<&ImuSettings<T>>,
        estimator: TiltEstimator<T>,
        encoder_cpr: Option<T>,
        ground: SlopeProfile<T>,
        params: &RobotParams<T>,
        dt: T,
        seed: u64,
        stream: u64,
    ) -> Result<Self, TwipError> {
        let imu = imu.map(Mpu6050::new).transpose()?;
        if let Some(m) = &imu {
            check_imu_grid(m.settings(), dt)?;
        }
        // Without an IMU the clock is never asked: any period.
        let clock = ImuClock::new(imu.as_ref().map_or(T::one(), |m| m.settings().sample_period), dt);
        let mut ground_trig = [ground.base().sin_cos(); MAX_SLOPE_CHANGES + 1];
        for (i, (_, slope)) in ground.changes().enumerate() {
            ground_trig[i + 1] = slope.sin_cos();
        }
        Ok(Self {
            imu,
            tilt: TiltFilter::new(estimator)?,
            encoder: encoder_cpr.map(Encoder::new).transpose()?,
            ground,
            ground_trig,
            radius: params.wheel_radius,
            g: params.g,
            clock,
            rng: Sfc64::new(seed, stream),
            last_read: None,
            shaft: T::zero(),
            settle: None,
        })
    }

    /// These sensors with a firmware's start at rest before the run ([`Settle`]).
    pub fn settled(self, settle: Option<Settle<T>>) -> Self {
        Self { settle, ..self }
    }

    /// The IMU's latest registers, if there is an IMU.
    pub fn imu(&self) -> Option<&Mpu6050<T>> {
        self.imu.as_ref()
    }

    /// Whether the IMU samples at `t` (its period come round: the clock advances), and
    /// then the (sin, cos) of the ground's slope under `x`. None without an IMU.
    #[inline]
    pub(crate) fn imu_due(&mut self, t: T, x: &Vector4<T>) -> Option<(T, T)> {
        self.imu.as_ref()?;
        self.clock.due(t).then(|| self.ground_trig_at(x))
    }

    /// (sin, cos) of the ground's slope under `x` (what the accelerometer feels).
    #[inline]
    fn ground_trig_at(&self, x: &Vector4<T>) -> (T, T) {
        self.ground_trig[self.ground.segment(x[2] * self.radius)]
    }

    /// The IMU's clock, this rig's stream and the IMU's normals drawn ahead, as they stand
    /// (None without an IMU): a sweep's lanes sample for the IMU from copies of them, and
    /// draw the same numbers.
    #[cfg_attr(not(feature = "std"), allow(dead_code))]
    pub(crate) fn imu_noise_parts(&self) -> Option<(ImuClock<T>, Sfc64, NoiseBatch)> {
        self.imu.as_ref().map(|imu| (self.clock, self.rng, imu.noise()))
    }

    /// Sets the IMU's registers (a sweep's lanes sample for it).
    #[cfg_attr(not(feature = "std"), allow(dead_code))]
    pub(crate) fn set_imu_reading(&mut self, reading: ImuReading<T>) {
        if let Some(imu) = self.imu.as_mut() {
            imu.set_reading(reading);
        }
    }
}

impl<T: Real> BalanceSensors<T> {
    /// What a settle at pitch `phi` reads and sets (None without a settle or an IMU).
    fn settling_at(&mut self, phi: T) -> Option<Settling<'_, T>> {
        let (Some(settle), Some(imu)) = (&self.settle, &self.imu) else { return None };
        Some(Settling { settle, tilt: &mut self.tilt, imu, phi, g: self.g, last_read: &mut self.last_read })
    }
}

impl Settles for BalanceSensors<f64> {
    fn settling(&mut self, phi: f64) -> Option<Settling<'_, f64>> {
        self.settling_at(phi)
    }
}

impl<T: Real> Sensor<T, 4> for BalanceSensors<T> {
    /// Samples the IMU when its period has come round (from t = 0 on).
    #[inline]
    fn sample(&mut self, t: T, x: &Vector4<T>, xdot: &Vector4<T>) {
        let Some((sin_slope, cos_slope)) = self.imu_due(t, x) else { return };
        if let Some(imu) = self.imu.as_mut() {
            let height = imu.settings().height;
            let (fx, fz) = specific_force(x, xdot, sin_slope, cos_slope, self.radius, height, self.g);
            imu.sample(fx, fz, x[1], &mut self.rng);
        }
    }

    /// The IMU's registers and the encoder's count (NaN for a part the rig lacks).
    fn raw(&self, x: &Vector4<T>, out: &mut [T]) -> usize {
        let nan = c::<T>(f64::NAN);
        let r = self.imu.as_ref().map(|imu| imu.reading());
        out[0] = r.map_or(nan, |r| r.gyro);
        out[1] = r.map_or(nan, |r| r.accel_x);
        out[2] = r.map_or(nan, |r| r.accel_z);
        out[3] = self.encoder.as_ref().map_or(nan, |e| e.count(x[2] - x[0] + self.shaft));
        4
    }

    #[inline(always)]
    fn shaft_offsets(&mut self, offsets: [T; 2]) {
        self.shaft = offsets[0];
    }

    /// The estimator reads the IMU at rest at `x0`'s pitch ([`Settle`]).
    fn settle(&mut self, x0: &Vector4<T>, period: T) {
        if let Some(mut s) = self.settling_at(x0[0]) {
            s.run(period);
        }
    }

    // Inlined: out of line, a sweep's SIMD kernel called a copy built for the baseline
    // CPU, whose floor (the encoder's count) is a libm call.
    #[inline]
    fn read(&mut self, t: T, x: &Vector4<T>) -> Vector4<T> {
        let dt = self.last_read.map_or(T::zero(), |last| t - last);
        self.last_read = Some(t);
        let (phi, phi_dot) = match &self.imu {
            Some(imu) => {
                let r = imu.reading();
                self.tilt.update(accel_tilt(r.accel_x, r.accel_z), r.gyro, dt)
            }
            None => (x[0], x[1]),
        };
        let (theta, theta_dot) = match self.encoder.as_mut() {
            Some(e) => {
                let (beta, beta_dot) = e.read(x[2] - x[0] + self.shaft, dt);
                (beta + phi, beta_dot + phi_dot)
            }
            None => (x[2], x[3]),
        };
        Vector4::new(phi, phi_dot, theta, theta_dot)
    }
}

/// A realism plant: it may change between steps, and it knows its motor currents.
pub trait RigPlant<T: Real, const NX: usize, const NU: usize>: Plant<T, NX, NU> {
    /// The motor current behind each input now [A] (2-DOF: the lumped current).
    fn currents(&self, x: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NU>;

    /// The input the plant gets now, in the command's units (lumped current, wheel
    /// torques), after the driver's clamps: the currents, for the 2-DOF lumped current.
    #[inline]
    fn delivered(&self, x: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NU> {
        self.currents(x, u)
    }
}

/// For tests: plant `P`, each derivative it shares between steps checked bit for bit
/// against its `deriv` there and then withheld, so that the runner evaluates every first
/// stage itself. Counts the steps that shared one and those that did not.
#[cfg(all(test, feature = "std"))]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Unshared<P> {
    pub plant: P,
    pub shared: usize,
    pub not_shared: usize,
}

#[cfg(all(test, feature = "std"))]
impl<P> Unshared<P> {
    /// Over a 10 s run (`name`): with backlash most steps shared the first stage and some,
    /// where a train opened, could not; without backlash none did.
    pub(crate) fn assert_counts(&self, name: &str, backlash: bool) {
        let (shared, not_shared) = (self.shared, self.not_shared);
        std::println!("{name}: {shared} steps shared the first stage, {not_shared} did not");
        if backlash {
            assert!(shared > 9000 && not_shared > 0, "{name}: {shared} {not_shared}");
        } else {
            assert_eq!(shared, 0, "{name}");
        }
    }
}

#[cfg(all(test, feature = "std"))]
impl<T: Real, P: Dynamics<T, NX, NU>, const NX: usize, const NU: usize> Dynamics<T, NX, NU> for Unshared<P> {
    const PITCH: usize = P::PITCH;

    fn deriv(&self, x: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NX> {
        self.plant.deriv(x, u)
    }

    fn deriv_at_stage(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, stage: Stage) -> SVector<T, NX> {
        self.plant.deriv_at_stage(x, u, stage)
    }

    fn energy(&self, x: &SVector<T, NX>) -> T {
        self.plant.energy(x)
    }
}

#[cfg(all(test, feature = "std"))]
impl<T: Real, P: Plant<T, NX, NU>, const NX: usize, const NU: usize> Plant<T, NX, NU> for Unshared<P> {
    fn between_steps(&mut self, t: T, dt: T, x: &mut SVector<T, NX>, u: &SVector<T, NU>) {
        match self.plant.between_steps_with_derivative(t, dt, x, u) {
            Some(d) => {
                assert_eq!(d, self.plant.deriv(x, u), "the derivative shared at t = {t:?}");
                self.shared += 1;
            }
            None => self.not_shared += 1,
        }
    }

    fn step_ended(&mut self, x: &SVector<T, NX>) {
        self.plant.step_ended(x);
    }

    fn shaft_offsets(&self) -> [T; 2] {
        self.plant.shaft_offsets()
    }
}

#[cfg(all(test, feature = "std"))]
impl<T: Real, P: RigPlant<T, NX, NU>, const NX: usize, const NU: usize> RigPlant<T, NX, NU> for Unshared<P> {
    fn currents(&self, x: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NU> {
        self.plant.currents(x, u)
    }
}

// What a sweep's rig lanes ask of each lane's plant (`sweep::block::run_rig_block`): the
// 2-DOF plant's one input and one (lumped) train as numbers.
#[cfg_attr(not(feature = "std"), allow(dead_code))]
impl<T: Real> SlopePlant<T> {
    /// Whether the gear trains are engaged (always, without backlash).
    #[inline(always)]
    pub(crate) fn engaged(&self) -> bool {
        self.trains()[0]
    }

    /// `between_steps` up to the trains' next step (`gear_next_with`): the open rotors'
    /// elapsed step and impacts, pushes, the winding's step (turning with the open rotors).
    /// Returns the lumped current that drives the mechanics at RK4's first stage: for the
    /// input `u` a current, or a duty through the winding (within the step its current
    /// follows the state: its input is the duty, [`Self::driven_winding`]).
    #[inline(always)]
    pub(crate) fn lumped_step_start(&mut self, t: T, dt: T, x: &mut Vector4<T>, u: T) -> T {
        self.step_start(t, dt, x, &SVector::<T, 1>::new(u))[0]
    }

    /// The motors' speed relative to the body at `x` (an open train's rotor's), when driven.
    #[inline(always)]
    pub(crate) fn motor_speed(&self, x: &Vector4<T>) -> Option<T> {
        self.drives().map(|_| self.motor_speeds(x)[0])
    }

    /// The lumped current's mean over the step started at `x` under `u`, the motors'
    /// speed held: what drives an open gear train's rotor (for a winding with inductance,
    /// not the first stage's).
    #[inline(always)]
    pub(crate) fn mean_current(&self, x: &Vector4<T>, u: T) -> T {
        self.mean_inputs(x, &SVector::<T, 1>::new(u))[0]
    }

    /// `RealPlant::gear_next_with` for the lumped `current` at RK4's first stage, its
    /// `mean` over the step and the gearhead torque per wheel `friction`.
    #[inline(always)]
    pub(crate) fn lumped_gear_next(&mut self, x: &Vector4<T>, current: T, mean: T, d: &Vector4<T>, friction: T) {
        self.gear_next_with(x, &SVector::<T, 1>::new(current), &SVector::<T, 1>::new(mean), d, [friction]);
    }

    /// Whether the lumped trains are engaged and stay so at the `current` of RK4's first
    /// stage, β̈ = θ̈ − φ̈ there and the gearhead torque per wheel `friction`
    /// (`GearPlay::stays_engaged`): a sweep's lanes skip [`Self::lumped_gear_next`] then.
    #[inline(always)]
    pub(crate) fn lumped_stays_engaged(&self, current: T, beta_ddot: T, friction: T) -> bool {
        self.rotor_inertia().is_some_and(|j| self.stays_engaged([self.ground().lumped_contact(current, friction, j, beta_ddot)]))
    }

    /// A driver's winding and the lumped current per ampere.
    pub(crate) fn driven_winding(&self) -> Option<(Winding<T>, T)> {
        self.drives().map(|([w], per_amp)| (w, per_amp))
    }
}

/// The actuator of a realism run.
#[derive(Clone, Copy, Debug)]
pub enum RealActuator<T> {
    Ideal,
    /// The firmware's mapping, the driver's current limit [A per motor] and its gearbox
    /// efficiency.
    Pwm(PwmActuator<T>, T, T),
}

impl<T: Real> Actuator<T, 4, 1> for RealActuator<T> {
    #[inline]
    fn drive(&mut self, t: T, command: &SVector<T, 1>, y: &Vector4<T>) -> SVector<T, 1> {
        match self {
            Self::Ideal => *command,
            Self::Pwm(a, ..) => a.drive(t, command, y),
        }
    }

    #[inline]
    fn beyond(&self, command: &SVector<T, 1>, y: &Vector4<T>) -> bool {
        match self {
            Self::Ideal => false,
            Self::Pwm(a, limit, _) => a.beyond(command[0], y[3] - y[1], *limit),
        }
    }

    #[inline]
    fn efficiency(&self) -> T {
        match self {
            Self::Ideal => T::one(),
            Self::Pwm(.., efficiency) => *efficiency,
        }
    }
}

/// What [`simulate_rig`] logs after the controller's internals: the measurement, the
/// plant's input and current, then the raw readings (gyro [rad/s], specific force
/// [m/s^2], the wheels' encoder count relative to the body; NaN for a part the rig lacks).
pub const RIG_SIGNALS: [&str; 10] = [
    "phi_hat", "phi_dot_hat", "theta_hat", "theta_dot_hat", "drive", "motor_current", "gyro", "accel_x", "accel_z", "enc",
];

/// Most controller internals [`simulate_rig`] passes on.
pub const MAX_INTERNALS: usize = 64 - RIG_SIGNALS.len();

/// The width of a rig's log row after the time and state.
const RIG_ROW: usize = 64;

/// The rig's log: the controller's internals at its last update, then the measurement
/// it read (NX), the plant's inputs (duty or current, NU) and the motor currents (NU):
/// [`RIG_SIGNALS`] for the 2-DOF rig, `PLANAR_RIG_SIGNALS` for the 3-DOF one.
pub struct RigSignals<T, const NX: usize, const NU: usize> {
    buffer: [T; RIG_ROW],
    width: usize,
}

impl<T: Real, const NX: usize, const NU: usize> RigSignals<T, NX, NU> {
    /// Most controller internals the rig passes on.
    pub const MAX_INTERNALS: usize = RIG_ROW - NX - 2 * NU - MAX_RAW;

    pub fn new() -> Self {
        Self { buffer: [T::zero(); RIG_ROW], width: 0 }
    }
}

impl<T: Real, const NX: usize, const NU: usize> Default for RigSignals<T, NX, NU> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, P: RigPlant<T, NX, NU>, const NX: usize, const NU: usize> Signals<T, P, NX, NU> for RigSignals<T, NX, NU> {
    const OBSERVE_COMMAND: bool = true;

    fn check(&mut self, internals: usize) -> Result<(), TwipError> {
        if internals > Self::MAX_INTERNALS {
            // The reason is a static str; the assertions keep its numbers right.
            const _: () = assert!(MAX_INTERNALS == 54 && RIG_ROW - 7 - 4 - MAX_RAW == 49);
            let reason = if NX == 4 { "more than 54 controller internals" } else { "more than 49 controller internals" };
            return Err(TwipError::InvalidParameter { name: "internals", value: internals as f64, reason });
        }
        self.width = internals;
        Ok(())
    }

    #[inline]
    fn updated(&mut self, internals: &[T], y: &SVector<T, NX>, drive: &SVector<T, NU>) {
        let w = self.width;
        self.buffer[..w].copy_from_slice(internals);
        self.buffer[w..w + NX].copy_from_slice(y.as_slice());
        self.buffer[w + NX..w + NX + NU].copy_from_slice(drive.as_slice());
    }

    #[inline]
    fn delivered(&self, plant: &P, x: &SVector<T, NX>, u: &SVector<T, NU>) -> SVector<T, NU> {
        plant.delivered(x, u)
    }

    #[inline]
    fn at<'a>(&'a mut self, _: &'a [T], plant: &P, x: &SVector<T, NX>, u: &SVector<T, NU>, raw: &[T]) -> &'a [T] {
        let w = self.width + NX + NU;
        self.buffer[w..w + NU].copy_from_slice(plant.currents(x, u).as_slice());
        self.buffer[w + NU..w + NU + raw.len()].copy_from_slice(raw);
        &self.buffer[..w + NU + raw.len()]
    }
}

/// Runs `controller` on the rig's `plant` through the one loop, `runner::run_loop`: the
/// plant's pushes and winding current between steps, and the observer sees the command
/// being applied (the controller's lumped current) and, after the controller's
/// internals, [`RIG_SIGNALS`].
pub fn simulate_rig<T, P, C, R, S, A, O, F>(
    plant: &mut P,
    controller: &mut C,
    reference: &R,
    x0: &Vector4<T>,
    config: &SimConfig<T>,
    parts: Loop<'_, S, A, O, F>,
) -> Result<(Outcome<T>, usize), TwipError>
where
    T: Real,
    P: RigPlant<T, 4, 1>,
    R: Reference<T>,
    C: Controller<T, 4, 1, Reference = R::Sample>,
    S: Sensor<T, 4>,
    A: Actuator<T, 4, 1>,
    O: Observer<T, 4, 1, R::Sample>,
    F: FnMut() -> bool,
{
    run_loop(plant, controller, reference, x0, config, parts, &mut RigSignals::<T, 4, 1>::new())
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::control::lqr::{design, DesignPoint, LqrController};
    use crate::control::reference::SpeedSchedule;
    use crate::sim::runner::{simulate_with, Ideal};

    /// Records states and inputs.
    #[derive(Default)]
    struct Trace(std::vec::Vec<(f64, Vector4<f64>, f64)>);

    impl<S> Observer<f64, 4, 1, S> for Trace {
        fn observe(&mut self, t: f64, x: &Vector4<f64>, u: &SVector<f64, 1>, _: &S, _: &[f64]) {
            self.0.push((t, *x, u[0]));
        }
    }

    fn setup() -> (SlopeModel<f64>, LqrController<f64>, SpeedSchedule<f64>) {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
        let speed = 180f64.to_radians();
        let q = nalgebra::Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
        let d = design(&model, speed, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
        let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 5e-3).unwrap();
        (model, ctrl, SpeedSchedule::constant(speed).unwrap())
    }

    fn run(realism: &Realism<f64>, t_final: f64) -> (Outcome<f64>, Trace) {
        let (model, mut ctrl, schedule) = setup();
        let config = SimConfig { dt: 1e-3, t_final, fall_limit: 1.0 };
        let mut rig = realism.build(&model, config.dt).unwrap();
        let mut trace = Trace::default();
        let (outcome, _) = rig.simulate(&mut ctrl, &schedule, &Vector4::zeros(), &config, &mut trace, || false).unwrap();
        (outcome, trace)
    }

    #[test]
    fn ideal_realism_is_the_plain_runner_bit_for_bit() {
        let (model, mut ctrl, schedule) = setup();
        let config = SimConfig { dt: 1e-3, t_final: 3.0, fall_limit: 1.0 };
        let mut plain = Trace::default();
        let parts =
            Loop { sensor: &mut Ideal, actuator: &mut Ideal, observer: &mut plain, should_stop: || false, delay_one_period: false };
        simulate_with(&model, &mut ctrl, &schedule, &Vector4::zeros(), &config, parts).unwrap();
        let (_, rig) = run(&Realism::ideal(), 3.0);
        assert_eq!(plain.0, rig.0);
    }

    #[test]
    fn the_rig_keeps_the_models_gearhead_friction() {
        let f = crate::model::friction::Friction::gb37();
        let model = SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap().with_friction(Some(f)).unwrap();
        let rig = Realism::ideal().build(&model, 1e-3).unwrap();
        let (x, u) = (Vector4::new(0.1, 0.3, 1.0, 0.5), SVector::<f64, 1>::new(0.2));
        assert_eq!(rig.plant.deriv(&x, &u), model.deriv(&x, &u));
        let plain = SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap();
        assert_ne!(rig.plant.deriv(&x, &u), plain.deriv(&x, &u));
    }

    /// The derivative the gear trains weighed is RK4's first stage when they stay as they
    /// were: the run is the same, bit for bit, as one that evaluates every first stage
    /// (and each shared one is `deriv` there). With backlash the trains open and close, so
    /// both kinds of step occur; without it nothing is shared.
    #[test]
    fn the_derivative_the_gear_trains_weighed_is_shared_bit_for_bit() {
        use crate::hardware::disturbance::{Push, Pushes};
        let (model, ctrl, schedule) = setup();
        let config = SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 };
        let pushed = Realism { pushes: Pushes::new(&[Push { t: 2.0, impulse: 0.05, height: 0.1 }]).unwrap(), ..Realism::thesis_like() };
        let steady = Realism { motor: Some(crate::hardware::driver::MotorDriver::gb37y3530()), ..pushed };
        for (name, realism) in [("thesis-like, pushed", pushed), ("steady winding", steady), ("no backlash", Realism { backlash: None, ..pushed })] {
            let rig = realism.build(&model, config.dt).unwrap();
            let (mut shared, mut checked) = (rig, Rig { plant: Unshared { plant: rig.plant, shared: 0, not_shared: 0 }, sensors: rig.sensors, actuator: rig.actuator, delay: rig.delay });
            let (mut a, mut b) = (Trace::default(), Trace::default());
            shared.simulate(&mut ctrl.clone(), &schedule, &Vector4::zeros(), &config, &mut a, || false).unwrap();
            checked.simulate(&mut ctrl.clone(), &schedule, &Vector4::zeros(), &config, &mut b, || false).unwrap();
            assert_eq!(a.0, b.0, "{name}");
            checked.plant.assert_counts(name, realism.backlash.is_some());
        }
    }

    /// A controller that answers NaN from `t = 1` s: the rig's saturations (the duty, the
    /// winding's current limit) keep the NaN, so the run ends as diverged there instead of
    /// driving on at full reverse.
    #[test]
    fn a_nan_command_ends_the_rig_run_as_diverged() {
        #[derive(Clone)]
        struct NanFromOneSecond(LqrController<f64>);
        impl Controller<f64, 4, 1> for NanFromOneSecond {
            type Reference = <LqrController<f64> as Controller<f64, 4, 1>>::Reference;
            fn period(&self) -> f64 {
                self.0.period()
            }
            fn reset(&mut self) {
                self.0.reset()
            }
            fn update(&mut self, t: f64, y: &Vector4<f64>, r: &Self::Reference) -> SVector<f64, 1> {
                let u = self.0.update(t, y, r);
                if t >= 1.0 { SVector::<f64, 1>::new(f64::NAN) } else { u }
            }
            fn internals(&self) -> &[f64] {
                self.0.internals()
            }
            fn internal_names(&self) -> &'static [&'static str] {
                self.0.internal_names()
            }
        }
        let (model, ctrl, schedule) = setup();
        let config = SimConfig { dt: 1e-3, t_final: 3.0, fall_limit: 1.0 };
        let mut rig = Realism::thesis_like().build(&model, config.dt).unwrap();
        let mut ctrl = NanFromOneSecond(ctrl);
        let (outcome, _) = rig.simulate(&mut ctrl, &schedule, &Vector4::zeros(), &config, &mut Trace::default(), || false).unwrap();
        match outcome {
            Outcome::Diverged { t } => assert!((1.0..1.01).contains(&t), "diverged at {t}"),
            other => panic!("expected a divergence at 1 s, got {other:?}"),
        }
    }

    #[test]
    fn thesis_like_keeps_the_flat_robot_up_and_repeats_bit_for_bit() {
        let (outcome, a) = run(&Realism::thesis_like(), 10.0);
        assert_eq!(outcome, Outcome::Completed);
        let (_, b) = run(&Realism::thesis_like(), 10.0);
        assert_eq!(a.0, b.0);
        let (_, other) = run(&Realism::thesis_like().with_stream(1), 10.0);
        assert_ne!(a.0, other.0);
    }
}
