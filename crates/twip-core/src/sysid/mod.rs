//! System identification's numerical kernel: predictions of a logged run by multiple
//! shooting. The run is cut into segments; each segment is integrated from its own start
//! state with the logged input held between samples (zero-order hold), so an unstable
//! plant is only ever followed over one short segment. The estimator (Python,
//! `twip.sysid`) makes the start states unknowns beside the robot's parameters.
use nalgebra::{SVector, Vector4};

use crate::model::dynamics::Dynamics;
use crate::model::integrate::rk4_step_from_k1;
use crate::{Real, TwipError};

#[cfg(feature = "parallel")]
pub mod parallel;

/// A logged run's time base and held inputs, cut into segments.
#[derive(Clone, Copy, Debug)]
pub struct Shooting<'a, T> {
    t: &'a [T],
    u: &'a [T],
    segments: &'a [usize],
    max_step: T,
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> TwipError {
    TwipError::InvalidParameter { name, value, reason }
}

impl<'a, T: Real> Shooting<'a, T> {
    /// `t` strictly increasing and finite; `u[i]` held over [t_i, t_i+1); `segments` the
    /// first sample of each segment (0 first, strictly increasing, each < n); intervals
    /// longer than `max_step` are split into equal RK4 steps.
    pub fn new(t: &'a [T], u: &'a [T], segments: &'a [usize], max_step: T) -> Result<Self, TwipError> {
        let n = t.len();
        if n < 2 {
            return Err(invalid("t", n as f64, "needs at least 2 samples"));
        }
        if u.len() != n {
            return Err(invalid("u", u.len() as f64, "needs one value per sample of t"));
        }
        for i in 0..n {
            if !t[i].is_finite() || (i > 0 && t[i] <= t[i - 1]) {
                return Err(invalid("t", i as f64, "row where t is not finite and strictly increasing"));
            }
            if !u[i].is_finite() {
                return Err(invalid("u", i as f64, "row where u is not finite"));
            }
        }
        if segments.first() != Some(&0) {
            return Err(invalid("segments", segments.first().map_or(-1.0, |&s| s as f64), "the first segment starts at sample 0"));
        }
        for (k, w) in segments.windows(2).enumerate() {
            if w[1] <= w[0] || w[1] >= n {
                return Err(invalid("segments", (k + 1) as f64, "segment starts must increase and stay below the sample count"));
            }
        }
        if !(max_step.is_finite() && max_step > T::zero()) {
            return Err(invalid("max_step", crate::to_f64(max_step), "must be finite and > 0"));
        }
        Ok(Self { t, u, segments, max_step })
    }

    pub fn samples(&self) -> usize {
        self.t.len()
    }

    pub fn segment_count(&self) -> usize {
        self.segments.len()
    }

    /// The samples of segment `k`.
    pub fn range(&self, k: usize) -> core::ops::Range<usize> {
        let end = self.segments.get(k + 1).copied().unwrap_or(self.t.len());
        self.segments[k]..end
    }

    /// Predicts every sample: `states[i]` the state, `rates[i]` its derivative under the
    /// input held from sample i, and `ends[k]` segment k's state carried on to the next
    /// segment's first sample (what continuity compares with that segment's start; the
    /// last segment's is NaN). A segment that leaves the finite numbers stays NaN to its end.
    pub fn run<M: Dynamics<T, 4, 1>>(
        &self,
        model: &M,
        starts: &[Vector4<T>],
        states: &mut [Vector4<T>],
        rates: &mut [Vector4<T>],
        ends: &mut [Vector4<T>],
    ) -> Result<(), TwipError> {
        let n = self.samples();
        if starts.len() != self.segment_count() {
            return Err(invalid("starts", starts.len() as f64, "needs one start state per segment"));
        }
        if states.len() != n || rates.len() != n {
            return Err(invalid("states", states.len() as f64, "needs one row per sample"));
        }
        if ends.len() != starts.len() {
            return Err(invalid("ends", ends.len() as f64, "needs one row per segment"));
        }
        for (k, start) in starts.iter().enumerate() {
            let range = self.range(k);
            let mut x = *start;
            for i in range.clone() {
                let u = SVector::<T, 1>::new(self.u[i]);
                let k1 = model.deriv(&x, &u);
                states[i] = x;
                rates[i] = k1;
                ends[k] = Vector4::repeat(crate::c::<T>(f64::NAN));
                if i + 1 == n {
                    break;
                }
                x = self.advance(model, &x, &u, &k1, self.t[i + 1] - self.t[i]);
                if !x.iter().all(|v| v.is_finite()) {
                    x = Vector4::repeat(crate::c::<T>(f64::NAN));
                }
                if i + 1 == range.end {
                    ends[k] = x;
                }
            }
        }
        Ok(())
    }

    fn advance<M: Dynamics<T, 4, 1>>(&self, model: &M, x: &Vector4<T>, u: &SVector<T, 1>, k1: &Vector4<T>, h: T) -> Vector4<T> {
        if h <= self.max_step * crate::c::<T>(1.0 + 1e-9) {
            return rk4_step_from_k1(model, x, u, h, k1);
        }
        // A sample interval that is a whole number of max steps, up to rounding, takes that many.
        let steps = (h / self.max_step - crate::c::<T>(1e-9)).ceil();
        let dt = h / steps;
        let mut y = rk4_step_from_k1(model, x, u, dt, k1);
        let mut done = T::one();
        while done < steps {
            y = rk4_step_from_k1(model, &y, u, dt, &model.deriv(&y, u));
            done += T::one();
        }
        y
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::model::integrate::rk4_step;
    use crate::{RobotParams, SlopeModel};

    #[test]
    fn each_segment_follows_rk4_from_its_start() {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap();
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 2e-3).collect();
        let u: Vec<f64> = (0..50).map(|i| 0.3 * (i as f64 * 0.2).sin()).collect();
        let segments = [0, 20];
        let shooting = Shooting::new(&t, &u, &segments, 1e-3).unwrap();
        let starts = [Vector4::new(0.05, 0.0, 0.0, 0.0), Vector4::new(-0.02, 0.1, 0.3, 1.0)];
        let (mut states, mut rates) = (vec![Vector4::zeros(); 50], vec![Vector4::zeros(); 50]);
        let mut ends = [Vector4::zeros(); 2];
        shooting.run(&model, &starts, &mut states, &mut rates, &mut ends).unwrap();
        for (k, range) in [(0, 0..20), (1, 20..50)] {
            let mut x = starts[k];
            for i in range {
                assert_eq!(states[i], x, "sample {i}");
                let uu = SVector::<f64, 1>::new(u[i]);
                assert_eq!(rates[i], model.deriv(&x, &uu));
                // 2 ms between samples: two steps of half the interval.
                let h = (t.get(i + 1).copied().unwrap_or(0.0) - t[i]) / 2.0;
                x = rk4_step(&model, &rk4_step(&model, &x, &uu, h), &uu, h);
            }
            // Segment 0 carried on to sample 20; the last segment has no next one.
            if k == 0 {
                assert_eq!(ends[0], x);
            }
        }
        assert!(ends[1].iter().all(|v| v.is_nan()));
    }

    #[test]
    fn bad_logs_are_refused_by_name() {
        let t = [0.0, 1e-3, 1e-3];
        let u = [0.0; 3];
        let err = Shooting::new(&t, &u, &[0], 1e-3).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "t", value, .. } if value == 2.0));
        let t = [0.0, 1e-3, 2e-3];
        assert!(Shooting::new(&t, &u[..2], &[0], 1e-3).is_err());
        assert!(Shooting::new(&t, &u, &[1], 1e-3).is_err());
        assert!(Shooting::new(&t, &u, &[0, 3], 1e-3).is_err());
        assert!(Shooting::new(&t, &u, &[0], 0.0).is_err());
    }
}
