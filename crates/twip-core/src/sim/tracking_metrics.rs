//! Metrics of a planar tracking run, accumulated sample by sample (Table 5.2's and more).
use nalgebra::SVector;

use crate::sim::runner::Observer;
use crate::control::trajectory::{Path, PlanarRef};
use crate::{c, Real};

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

/// Accumulates [`TrackingSummary`]; `path` gives the distance to the curve.
#[derive(Clone, Copy, Debug)]
pub struct TrackingMetrics<T: Real, P> {
    path: P,
    settle: T,
    sum_x: T,
    sum_y: T,
    sum_x_settled: T,
    sum_y_settled: T,
    sum_pitch: T,
    summary: TrackingSummary<T>,
}

impl<T: Real, P: Path<T>> TrackingMetrics<T, P> {
    pub fn new(path: P, settle: T) -> Self {
        let z = T::zero();
        Self {
            path,
            settle,
            sum_x: z,
            sum_y: z,
            sum_x_settled: z,
            sum_y_settled: z,
            sum_pitch: z,
            summary: TrackingSummary {
                mean_abs_x_error: z,
                mean_abs_y_error: z,
                mean_abs_x_error_settled: z,
                mean_abs_y_error_settled: z,
                max_path_error_settled: z,
                mean_abs_pitch: z,
                peak_abs_torque: z,
                samples: 0,
                settled_samples: 0,
            },
        }
    }

    pub fn summary(&self) -> TrackingSummary<T> {
        let mut s = self.summary;
        let n = c::<T>(s.samples.max(1) as f64);
        let m = c::<T>(s.settled_samples.max(1) as f64);
        s.mean_abs_x_error = self.sum_x / n;
        s.mean_abs_y_error = self.sum_y / n;
        s.mean_abs_pitch = self.sum_pitch / n;
        s.mean_abs_x_error_settled = self.sum_x_settled / m;
        s.mean_abs_y_error_settled = self.sum_y_settled / m;
        // A run that ended before the settle time has no settled part: NaN, not 0.
        if s.settled_samples == 0 {
            s.mean_abs_x_error_settled = c::<T>(f64::NAN);
            s.mean_abs_y_error_settled = c::<T>(f64::NAN);
            s.max_path_error_settled = c::<T>(f64::NAN);
        }
        s
    }
}

impl<T: Real, P: Path<T>> Observer<T, 7, 2, PlanarRef<T>> for TrackingMetrics<T, P> {
    fn observe(&mut self, t: T, x: &SVector<T, 7>, u: &SVector<T, 2>, r: &PlanarRef<T>, _: &[T]) {
        let (ex, ey) = ((x[0] - r.x).abs(), (x[1] - r.y).abs());
        self.sum_x += ex;
        self.sum_y += ey;
        self.sum_pitch += x[3].abs();
        let s = &mut self.summary;
        if t >= self.settle {
            self.sum_x_settled += ex;
            self.sum_y_settled += ey;
            s.max_path_error_settled = s.max_path_error_settled.max(self.path.distance(x[0], x[1]));
            s.settled_samples += 1;
        }
        s.peak_abs_torque = s.peak_abs_torque.max(u[0].abs()).max(u[1].abs());
        s.samples += 1;
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
