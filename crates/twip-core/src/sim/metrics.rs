//! Metrics of a 2-DOF run, accumulated sample by sample (Table 5.1's and settling).
use nalgebra::SVector;

use crate::control::reference::SpeedRef;
use crate::sim::runner::Observer;
use crate::model::slope::SlopeModel;
use crate::{c, Real, RobotParams};

/// What [`SlopeMetrics`] reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlopeSummary<T> {
    /// Mean |φ − φ_s(θ̇_ref)| with the plant's true steady pitch [rad].
    pub mean_abs_pitch_error: T,
    /// Mean |θ̇ − θ̇_ref| [rad/s].
    pub mean_abs_speed_error: T,
    /// Last time |φ − φ_s| was outside its band (2 % of the initial pitch step, ≥ 0.25°) [s].
    pub pitch_settling_time: T,
    /// Last time |θ̇ − θ̇_ref| was outside 2 % of the largest reference speed [s].
    pub speed_settling_time: T,
    /// (θ_ref − θ) r at the last sample [m], signed along the last leg travelled (the last
    /// nonzero reference speed): positive short of the goal, negative past it, both ways.
    pub final_position_error: T,
    /// Largest |u| [A] (the lumped current of both motors).
    pub peak_abs_input: T,
    /// Largest current in one motor [A] and torque at one wheel [N m]: see [`DrivePeaks`].
    pub peak_current: T,
    pub peak_torque: T,
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
});

/// The largest current one motor carried [A] and torque one wheel got [N m], to hold
/// against a motor's data sheet (stall current). The 2-DOF model's input is the lumped
/// current of both motors (each carries u/2, the wheels share η τ_i u); the 3-DOF model's
/// inputs are the wheel torques (a motor carries τ / (η τ_i)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrivePeaks<T> {
    pub current: T,
    pub torque: T,
}

impl<T: Copy> DrivePeaks<T> {
    /// ("peak_current", current), ("peak_torque", torque): the metrics' names.
    pub fn named(&self) -> [(&'static str, T); 2] {
        [("peak_current", self.current), ("peak_torque", self.torque)]
    }
}

impl<T: Real> DrivePeaks<T> {
    pub fn from_lumped_current(params: &RobotParams<T>, peak_abs_u: T) -> Self {
        let current = peak_abs_u / c::<T>(2.0);
        Self { current, torque: params.gear_ratio * params.torque_constant * current }
    }

    pub fn from_wheel_torque(params: &RobotParams<T>, peak_abs_torque: T) -> Self {
        Self { current: peak_abs_torque / (params.gear_ratio * params.torque_constant), torque: peak_abs_torque }
    }
}

/// Accumulates [`SlopeSummary`] against the plant's own steady state.
#[derive(Clone, Copy, Debug)]
pub struct SlopeMetrics<T: Real> {
    plant: SlopeModel<T>,
    sum_pitch: T,
    sum_speed: T,
    pitch_band: Option<T>,
    speed_scale: T,
    pitch_settle: T,
    speed_settle: T,
    steady: Option<(T, T)>,
    /// The sign of the last nonzero reference speed: which way "short of the goal" is.
    direction: T,
    summary: SlopeSummary<T>,
}

impl<T: Real> SlopeMetrics<T> {
    pub fn new(plant: SlopeModel<T>) -> Self {
        Self {
            plant,
            sum_pitch: T::zero(),
            sum_speed: T::zero(),
            pitch_band: None,
            speed_scale: T::zero(),
            pitch_settle: T::zero(),
            speed_settle: T::zero(),
            steady: None,
            direction: T::one(),
            summary: SlopeSummary {
                mean_abs_pitch_error: T::zero(),
                mean_abs_speed_error: T::zero(),
                pitch_settling_time: T::zero(),
                speed_settling_time: T::zero(),
                final_position_error: T::zero(),
                peak_abs_input: T::zero(),
                peak_current: T::zero(),
                peak_torque: T::zero(),
                samples: 0,
            },
        }
    }

    /// The plant's steady pitch at a reference speed (cached: speeds change rarely).
    fn steady_pitch(&mut self, speed: T) -> T {
        match self.steady {
            Some((s, phi)) if s == speed => phi,
            _ => {
                let phi = self.plant.equilibrium(speed).map(|(x, _)| x[0]).unwrap_or(T::frac_pi_2());
                self.steady = Some((speed, phi));
                phi
            }
        }
    }

    pub fn summary(&self) -> SlopeSummary<T> {
        let mut s = self.summary;
        let n = c::<T>(s.samples.max(1) as f64);
        s.mean_abs_pitch_error = self.sum_pitch / n;
        s.mean_abs_speed_error = self.sum_speed / n;
        s.pitch_settling_time = self.pitch_settle;
        s.speed_settling_time = self.speed_settle;
        let peaks = DrivePeaks::from_lumped_current(self.plant.params(), s.peak_abs_input);
        s.peak_current = peaks.current;
        s.peak_torque = peaks.torque;
        s
    }
}

impl<T: Real> Observer<T, 4, 1, SpeedRef<T>> for SlopeMetrics<T> {
    fn observe(&mut self, t: T, x: &SVector<T, 4>, u: &SVector<T, 1>, r: &SpeedRef<T>, _: &[T]) {
        let phi_s = self.steady_pitch(r.theta_dot);
        let pitch_error = (x[0] - phi_s).abs();
        let speed_error = (x[3] - r.theta_dot).abs();
        let band = *self
            .pitch_band
            .get_or_insert_with(|| (c::<T>(0.02) * (phi_s - x[0]).abs()).max(c::<T>(0.25f64.to_radians())));
        self.speed_scale = self.speed_scale.max(r.theta_dot.abs());
        if pitch_error > band {
            self.pitch_settle = t;
        }
        if speed_error > c::<T>(0.02) * self.speed_scale {
            self.speed_settle = t;
        }
        self.sum_pitch += pitch_error;
        self.sum_speed += speed_error;
        if r.theta_dot != T::zero() {
            self.direction = r.theta_dot.signum();
        }
        let s = &mut self.summary;
        s.final_position_error = self.direction * (r.theta - x[2]) * self.plant.params().wheel_radius;
        s.peak_abs_input = s.peak_abs_input.max(u[0].abs());
        s.samples += 1;
    }
}
