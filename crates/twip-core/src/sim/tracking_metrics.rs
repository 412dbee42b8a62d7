//! Metrics of a planar tracking run, accumulated sample by sample (Table 5.2's and more).
use nalgebra::SVector;

use crate::sim::drive_metrics::DriveTally;
use crate::sim::metrics::DrivePeaks;
use crate::sim::runner::Observer;
use crate::control::trajectory::{Path, PlanarRef};
use crate::model::lane::Lane;
use crate::{c, Real, RobotParams};

/// What [`TrackingMetrics`] reports. "Settled" means from the settle time on (one lap of
/// a circle, say), where the start-up transient no longer counts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackingSummary<T> {
    /// Mean |x − x_r| and |y − y_r| over the whole run [m] (Table 5.2's).
    pub mean_abs_x_error: T,
    pub mean_abs_y_error: T,
    /// The same from the settle time on [m].
    pub mean_abs_x_error_settled: T,
    pub mean_abs_y_error_settled: T,
    /// Largest distance to the path (not to the moving reference point) from the settle time on [m].
    pub max_path_error_settled: T,
    /// Mean |φ| [rad].
    pub mean_abs_pitch: T,
    /// Largest |u_r|, |u_l| [N m].
    pub peak_abs_torque: T,
    pub samples: usize,
    pub settled_samples: usize,
}

crate::sim::named_metrics!(TrackingSummary {
    mean_abs_x_error,
    mean_abs_y_error,
    mean_abs_x_error_settled,
    mean_abs_y_error_settled,
    max_path_error_settled,
    mean_abs_pitch,
    peak_abs_torque,
});

/// The running sums and peaks of [`TrackingMetrics`], written once over `Lane`: a run's
/// observer and a sweep's lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TrackingTally<S> {
    pub sum_x: S,
    pub sum_y: S,
    pub sum_x_settled: S,
    pub sum_y_settled: S,
    pub sum_pitch: S,
    pub max_path_error_settled: S,
    pub peak_abs_torque: S,
}

/// How many sums and peaks [`TrackingTally`] holds.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
pub(crate) const TRACKING_TALLIES: usize = 7;

#[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
impl<S: Copy> TrackingTally<S> {
    /// The fields in declaration order (a sweep keeps one array per field).
    #[inline(always)]
    pub(crate) fn to_array(self) -> [S; TRACKING_TALLIES] {
        [self.sum_x, self.sum_y, self.sum_x_settled, self.sum_y_settled, self.sum_pitch, self.max_path_error_settled, self.peak_abs_torque]
    }

    /// The tally from [`Self::to_array`]'s order.
    #[inline(always)]
    pub(crate) fn from_array(a: [S; TRACKING_TALLIES]) -> Self {
        let [sum_x, sum_y, sum_x_settled, sum_y_settled, sum_pitch, max_path_error_settled, peak_abs_torque] = a;
        Self { sum_x, sum_y, sum_x_settled, sum_y_settled, sum_pitch, max_path_error_settled, peak_abs_torque }
    }
}

impl<S: Lane> TrackingTally<S> {
    pub(crate) fn new() -> Self {
        let z = S::splat(0.0);
        Self { sum_x: z, sum_y: z, sum_x_settled: z, sum_y_settled: z, sum_pitch: z, max_path_error_settled: z, peak_abs_torque: z }
    }

    /// Adds the sample (x, u) against r where `on` holds; the settled sums and the path
    /// error too when `settled` (the time is past the settle time, the same for every
    /// lane). `distance` is the distance to the path, asked only then.
    #[inline(always)]
    pub(crate) fn observe(&mut self, on: S::Mask, settled: bool, x: &[S; 7], u: [S; 2], r: &PlanarRef<S>, distance: impl FnOnce() -> S) {
        let add = |sum: S, v: S| S::select(on, sum + v, sum);
        let (ex, ey) = ((x[0] - r.x).magnitude(), (x[1] - r.y).magnitude());
        self.sum_x = add(self.sum_x, ex);
        self.sum_y = add(self.sum_y, ey);
        self.sum_pitch = add(self.sum_pitch, x[3].magnitude());
        if settled {
            self.sum_x_settled = add(self.sum_x_settled, ex);
            self.sum_y_settled = add(self.sum_y_settled, ey);
            let worst = self.max_path_error_settled.larger(distance());
            self.max_path_error_settled = S::select(on, worst, self.max_path_error_settled);
        }
        let peak = self.peak_abs_torque.larger(u[0].magnitude()).larger(u[1].magnitude());
        self.peak_abs_torque = S::select(on, peak, self.peak_abs_torque);
    }
}

impl<T: Real> TrackingTally<T> {
    /// The summary of `samples` observations, `settled` of them past the settle time.
    pub(crate) fn summary(&self, samples: usize, settled: usize) -> TrackingSummary<T> {
        let n = c::<T>(samples.max(1) as f64);
        let m = c::<T>(settled.max(1) as f64);
        // A run that ended before the settle time has no settled part: NaN, not 0.
        let none = |v: T| if settled == 0 { c::<T>(f64::NAN) } else { v };
        TrackingSummary {
            mean_abs_x_error: self.sum_x / n,
            mean_abs_y_error: self.sum_y / n,
            mean_abs_x_error_settled: none(self.sum_x_settled / m),
            mean_abs_y_error_settled: none(self.sum_y_settled / m),
            max_path_error_settled: none(self.max_path_error_settled),
            mean_abs_pitch: self.sum_pitch / n,
            peak_abs_torque: self.peak_abs_torque,
            samples,
            settled_samples: settled,
        }
    }
}

/// Accumulates [`TrackingSummary`]; `path` gives the distance to the curve.
#[derive(Clone, Copy, Debug)]
pub struct TrackingMetrics<T: Real, P> {
    path: P,
    settle: T,
    tally: TrackingTally<T>,
    drive: DriveTally<T>,
    /// The driver's gearbox efficiency ([`Observer::drive_efficiency`]; 1 without one).
    efficiency: T,
    samples: usize,
    settled_samples: usize,
}

impl<T: Real, P: Path<T>> TrackingMetrics<T, P> {
    pub fn new(path: P, settle: T) -> Self {
        Self { path, settle, tally: TrackingTally::new(), drive: DriveTally::new(), efficiency: T::one(), samples: 0, settled_samples: 0 }
    }

    pub fn summary(&self) -> TrackingSummary<T> {
        self.tally.summary(self.samples, self.settled_samples)
    }

    /// What the motors of the robot `params` saw ([`DrivePeaks`]).
    pub fn drive_peaks(&self, params: &RobotParams<T>) -> DrivePeaks<T> {
        let share = self.drive.saturation_share();
        DrivePeaks::from_wheel_torque(params, self.drive.peak_delivered, self.tally.peak_abs_torque, share, self.efficiency)
    }
}

impl<T: Real, P: Path<T>> Observer<T, 7, 2, PlanarRef<T>> for TrackingMetrics<T, P> {
    fn observe(&mut self, t: T, x: &SVector<T, 7>, u: &SVector<T, 2>, r: &PlanarRef<T>, _: &[T]) {
        let settled = t >= self.settle;
        let path = &self.path;
        self.tally.observe(true, settled, &(*x).into(), [u[0], u[1]], r, || path.distance(x[0], x[1]));
        self.samples += 1;
        self.settled_samples += settled as usize;
    }

    #[inline(always)]
    fn drive(&mut self, delivered: &SVector<T, 2>, beyond: Option<bool>) {
        let largest = delivered[0].magnitude().larger(delivered[1].magnitude());
        self.drive.observe(true, largest, beyond.is_some(), beyond == Some(true));
    }

    fn drive_efficiency(&mut self, efficiency: T) {
        self.efficiency = efficiency;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Reference;
    use crate::control::trajectory::{Circle, Direction};

    #[test]
    fn a_robot_one_centimetre_outside_the_circle() {
        let circle = Circle::from_origin(0.5, 0.1, Direction::CounterClockwise).unwrap();
        let mut m = TrackingMetrics::new(circle, 1.0);
        for k in 0..=200 {
            let t = k as f64 * 0.01;
            let r = circle.sample(t);
            // Radially out by 1 cm from the reference point.
            let (dx, dy) = (r.x - 0.0, r.y - 0.5);
            let x = SVector::<f64, 7>::from([r.x + 0.02 * dx, r.y + 0.02 * dy, 0.0, -0.1, 0.0, 0.0, 0.0]);
            m.observe(t, &x, &SVector::from([0.3, -0.5]), &r, &[]);
        }
        let s = m.summary();
        assert_eq!((s.samples, s.settled_samples), (201, 101));
        assert!((s.max_path_error_settled - 0.01).abs() < 1e-12);
        assert!((s.mean_abs_pitch - 0.1).abs() < 1e-12);
        assert_eq!(s.peak_abs_torque, 0.5);
        assert!(s.mean_abs_x_error_settled > 0.0 && s.mean_abs_x_error_settled < 0.01);
    }

    #[test]
    fn a_run_shorter_than_the_settle_time_has_no_settled_metrics() {
        let circle = Circle::from_origin(0.5, 0.1, Direction::CounterClockwise).unwrap();
        let mut m = TrackingMetrics::new(circle, 5.0);
        for k in 0..=100 {
            let t = k as f64 * 0.01;
            m.observe(t, &SVector::<f64, 7>::zeros(), &SVector::zeros(), &circle.sample(t), &[]);
        }
        let s = m.summary();
        assert_eq!(s.settled_samples, 0);
        assert!(s.mean_abs_x_error_settled.is_nan() && s.mean_abs_y_error_settled.is_nan());
        assert!(s.max_path_error_settled.is_nan());
        assert!(s.mean_abs_x_error.is_finite());
    }
}
