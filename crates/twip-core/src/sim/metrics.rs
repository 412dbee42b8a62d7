//! Metrics of a 2-DOF run, accumulated sample by sample (Table 5.1's and settling).
use nalgebra::SVector;

use crate::control::reference::SpeedRef;
use crate::sim::drive_metrics::DriveTally;
use crate::sim::runner::Observer;
use crate::model::lane::Lane;
use crate::model::slope::SlopeModel;
use crate::{c, Real, RobotParams};

/// What [`SlopeMetrics`] reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlopeSummary<T> {
    /// Mean |φ − φ_s(θ̇_ref)| with the plant's true steady pitch [rad].
    pub mean_abs_pitch_error: T,
    /// Mean |θ̇ − θ̇_ref| [rad/s].
    pub mean_abs_speed_error: T,
    /// Last time |φ − φ_s| was outside its band (2 % of the initial pitch step, ≥ 0.25°) [s]
    /// (the end, for a run that fell or diverged: [`Self::ended_early`]).
    pub pitch_settling_time: T,
    /// Last time |θ̇ − θ̇_ref| was outside 2 % of the largest reference speed [s] (the
    /// end, for a run that fell or diverged).
    pub speed_settling_time: T,
    /// (θ_ref − θ) r at the last sample [m], signed along the last leg travelled (the last
    /// nonzero reference speed): positive short of the goal, negative past it, both ways.
    pub final_position_error: T,
    /// Largest |u| [A] (the lumped current of both motors the controller commanded).
    pub peak_abs_input: T,
    /// Largest current in one motor [A] and torque at one wheel [N m] after the driver,
    /// the largest current commanded of one motor [A], and the share of control periods
    /// whose command was beyond the driver: see [`DrivePeaks`].
    pub peak_current: T,
    pub peak_torque: T,
    pub peak_command: T,
    pub saturation_share: T,
    pub samples: usize,
}

crate::sim::named_metrics!(SlopeSummary {
    mean_abs_pitch_error,
    mean_abs_speed_error,
    pitch_settling_time,
    speed_settling_time,
    final_position_error,
    peak_abs_input,
    peak_current,
    peak_torque,
    peak_command,
    saturation_share,
});

impl<T: Copy> SlopeSummary<T> {
    /// The summary of a run that ended early at `t_end`: it fell, or its state or input
    /// stopped being finite. It never settled, so both settling times are `t_end`. (A
    /// diverged run's last state is not observed, so its samples alone could read as
    /// settled, at 0 if it blew up at the first step; a fallen run's wheel speed could read
    /// as settled before it fell.)
    pub fn ended_early(self, t_end: T) -> Self {
        Self { pitch_settling_time: t_end, speed_settling_time: t_end, ..self }
    }
}

/// What the motors saw, to hold against a motor's data sheet (stall current) and a
/// driver's rating: the largest current one motor carried [A] and torque one wheel got
/// [N m] after the driver's clamps (the current limit, the duty at full), beside the
/// largest current the controller commanded of one motor [A], and the share of control
/// periods whose command was beyond the driver (0 without one). The 2-DOF model's input
/// is the lumped current of both motors (each carries u/2, the wheels share η τ_i u); the
/// 3-DOF model's inputs are the wheel torques (a motor carries τ / (η τ_i)). With a driver
/// whose gearbox efficiency is ε, the winding's current is 1/ε of what the torque reads as,
/// and so is the current the firmware asks for a command: both currents are the winding's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrivePeaks<T> {
    pub current: T,
    pub torque: T,
    pub command: T,
    pub saturation_share: T,
}

impl<T: Copy> DrivePeaks<T> {
    /// The metrics' names: ("peak_current", current), ("peak_torque", torque),
    /// ("peak_command", command), ("saturation_share", saturation_share).
    pub fn named(&self) -> [(&'static str, T); 4] {
        [
            ("peak_current", self.current),
            ("peak_torque", self.torque),
            ("peak_command", self.command),
            ("saturation_share", self.saturation_share),
        ]
    }
}

impl<T: Real> DrivePeaks<T> {
    /// From the largest lumped current delivered and commanded [A] (2-DOF), through a
    /// driver of gearbox efficiency `efficiency` (1 without one).
    pub fn from_lumped_current(
        params: &RobotParams<T>,
        delivered: T,
        commanded: T,
        saturation_share: T,
        efficiency: T,
    ) -> Self {
        let lossless = delivered / c::<T>(2.0);
        let torque = params.gear_ratio * params.torque_constant * lossless;
        let command = commanded / c::<T>(2.0) / efficiency;
        Self { current: lossless / efficiency, torque, command, saturation_share }
    }

    /// From the largest wheel torque delivered and commanded [N m] (3-DOF), through a
    /// driver of gearbox efficiency `efficiency` (1 without one).
    pub fn from_wheel_torque(
        params: &RobotParams<T>,
        delivered: T,
        commanded: T,
        saturation_share: T,
        efficiency: T,
    ) -> Self {
        let per_amp = params.gear_ratio * params.torque_constant * efficiency;
        Self { current: delivered / per_amp, torque: delivered, command: commanded / per_amp, saturation_share }
    }

    /// From a run's [`DriveTally`] and its largest command (2-DOF: lumped current).
    pub(crate) fn of_slope_run(params: &RobotParams<T>, drive: &DriveTally<T>, commanded: T, efficiency: T) -> Self {
        Self::from_lumped_current(params, drive.peak_delivered, commanded, drive.saturation_share(), efficiency)
    }
}

/// The running sums and records behind [`SlopeSummary`], written once over [`Lane`] (a
/// run's and a sweep lane's) without branches, so that a sweep's lanes vectorise it.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Tally<S> {
    pub sum_pitch: S,
    pub sum_speed: S,
    pub pitch_settle: S,
    pub speed_settle: S,
    pub final_position_error: S,
    pub peak_abs_input: S,
}

/// What an observation is measured against.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Aim<S> {
    pub t: S,
    /// The plant's own steady pitch at the reference speed.
    pub phi_s: S,
    /// The pitch's settling band ([`pitch_band`]).
    pub band: S,
    /// The reference's wheel speed and angle.
    pub theta_dot: S,
    pub theta: S,
    /// 2 % of the largest reference speed so far: the speed's settling band.
    pub speed_band: S,
    /// The sign of the last nonzero reference speed: which way "short of the goal" is.
    pub direction: S,
    pub wheel_radius: S,
}

/// The pitch's settling band, set at the first sample: 2 % of the step from the initial
/// pitch to the steady one, at least 0.25°.
#[inline(always)]
pub(crate) fn pitch_band<S: Lane>(phi_s: S, pitch: S) -> S {
    (S::splat(0.02) * (phi_s - pitch).magnitude()).larger(S::splat(0.25f64.to_radians()))
}

impl<S: Lane> Tally<S> {
    pub(crate) fn new() -> Self {
        let z = S::splat(0.0);
        Self { sum_pitch: z, sum_speed: z, pitch_settle: z, speed_settle: z, final_position_error: z, peak_abs_input: z }
    }

    /// Adds the sample of state `x` and input `u` where `on` (a sweep lane that has ended
    /// adds nothing).
    #[inline(always)]
    pub(crate) fn observe(&mut self, on: S::Mask, x: &[S; 4], u: S, aim: &Aim<S>) {
        let pitch_error = (x[0] - aim.phi_s).magnitude();
        let speed_error = (x[3] - aim.theta_dot).magnitude();
        self.pitch_settle = S::select(on & pitch_error.gt(aim.band), aim.t, self.pitch_settle);
        self.speed_settle = S::select(on & speed_error.gt(aim.speed_band), aim.t, self.speed_settle);
        self.sum_pitch = S::select(on, self.sum_pitch + pitch_error, self.sum_pitch);
        self.sum_speed = S::select(on, self.sum_speed + speed_error, self.sum_speed);
        let position = aim.direction * (aim.theta - x[2]) * aim.wheel_radius;
        self.final_position_error = S::select(on, position, self.final_position_error);
        self.peak_abs_input = S::select(on, self.peak_abs_input.larger(u.magnitude()), self.peak_abs_input);
    }
}

/// Accumulates [`SlopeSummary`] against the plant's own steady state.
#[derive(Clone, Copy, Debug)]
pub struct SlopeMetrics<T: Real> {
    plant: SlopeModel<T>,
    tally: Tally<T>,
    drive: DriveTally<T>,
    /// The driver's gearbox efficiency ([`Observer::drive_efficiency`]; 1 without one).
    efficiency: T,
    samples: usize,
    pitch_band: Option<T>,
    speed_scale: T,
    steady: Option<(T, T)>,
    direction: T,
}

impl<T: Real> SlopeMetrics<T> {
    pub fn new(plant: SlopeModel<T>) -> Self {
        Self {
            plant,
            tally: Tally::new(),
            drive: DriveTally::new(),
            efficiency: T::one(),
            samples: 0,
            pitch_band: None,
            speed_scale: T::zero(),
            steady: None,
            direction: T::one(),
        }
    }

    /// The plant's steady pitch at a reference speed (cached: speeds change rarely).
    #[inline(always)]
    fn steady_pitch(&mut self, speed: T) -> T {
        match self.steady {
            Some((s, phi)) if s == speed => phi,
            _ => self.solve_steady_pitch(speed),
        }
    }

    #[cold]
    #[inline(never)]
    fn solve_steady_pitch(&mut self, speed: T) -> T {
        let phi = steady_pitch(&self.plant, speed);
        self.steady = Some((speed, phi));
        phi
    }

    pub fn summary(&self) -> SlopeSummary<T> {
        let n = c::<T>(self.samples.max(1) as f64);
        let t = &self.tally;
        let peaks = DrivePeaks::of_slope_run(self.plant.params(), &self.drive, t.peak_abs_input, self.efficiency);
        SlopeSummary {
            mean_abs_pitch_error: t.sum_pitch / n,
            mean_abs_speed_error: t.sum_speed / n,
            pitch_settling_time: t.pitch_settle,
            speed_settling_time: t.speed_settle,
            final_position_error: t.final_position_error,
            peak_abs_input: t.peak_abs_input,
            peak_current: peaks.current,
            peak_torque: peaks.torque,
            peak_command: peaks.command,
            saturation_share: peaks.saturation_share,
            samples: self.samples,
        }
    }
}

/// The plant's own steady pitch at reference speed `speed` (90° when it has none: every
/// sample is then far from it).
pub(crate) fn steady_pitch<T: Real>(plant: &SlopeModel<T>, speed: T) -> T {
    plant.equilibrium(speed).map(|(x, _)| x[0]).unwrap_or(T::frac_pi_2())
}

impl<T: Real> Observer<T, 4, 1, SpeedRef<T>> for SlopeMetrics<T> {
    #[inline(always)]
    fn observe(&mut self, t: T, x: &SVector<T, 4>, u: &SVector<T, 1>, r: &SpeedRef<T>, _: &[T]) {
        let phi_s = self.steady_pitch(r.theta_dot);
        let band = *self.pitch_band.get_or_insert_with(|| pitch_band(phi_s, x[0]));
        self.speed_scale = self.speed_scale.max(r.theta_dot.abs());
        if r.theta_dot != T::zero() {
            self.direction = r.theta_dot.signum();
        }
        let aim = Aim {
            t,
            phi_s,
            band,
            theta_dot: r.theta_dot,
            theta: r.theta,
            speed_band: c::<T>(0.02) * self.speed_scale,
            direction: self.direction,
            wheel_radius: self.plant.params().wheel_radius,
        };
        self.tally.observe(true, &[x[0], x[1], x[2], x[3]], u[0], &aim);
        self.samples += 1;
    }

    #[inline(always)]
    fn drive(&mut self, delivered: &SVector<T, 1>, beyond: Option<bool>) {
        self.drive.observe(true, delivered[0].abs(), beyond.is_some(), beyond == Some(true));
    }

    fn drive_efficiency(&mut self, efficiency: T) {
        self.efficiency = efficiency;
    }
}
