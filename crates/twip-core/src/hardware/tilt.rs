//! Pitch from the IMU, as the firmware computes it once per control period: the
//! accelerometer's tilt `atan2(−f_x, f_z)` (right on average, wrong while accelerating)
//! fused with the integrated gyroscope (right over a short time, drifting with its bias).
//!
//! - Complementary filter: `φ̂ ← a (φ̂ + T ω) + (1 − a) φ_acc`, `a = τ / (τ + T)`; the rate
//!   is the gyroscope's. A gyro bias b leaves a steady error τ b.
//! - Kalman filter on (angle, gyro bias): predict `φ̂ ← φ̂ + T (ω − b̂)`, correct with φ_acc;
//!   process noise `q_angle T`, `q_bias T`, measurement noise `r_angle`. The rate is ω − b̂.
//!
//! Both start from the accelerometer's tilt at their first update.
use crate::{c, Real, TwipError};

/// Which estimator and its tuning.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TiltEstimator<T> {
    /// `time_constant` τ [s] of the crossover between accelerometer and gyroscope.
    Complementary { time_constant: T },
    /// Angle random walk `q_angle` [rad²/s], bias random walk `q_bias` [rad²/s³],
    /// accelerometer tilt variance `r_angle` [rad²].
    Kalman { q_angle: T, q_bias: T, r_angle: T },
}

impl<T: Real> TiltEstimator<T> {
    /// τ = 1 s (`0.995 (φ + ω dt) + 0.005 φ_acc` at a 5 ms loop). While the robot
    /// accelerates at a, balancing leans it by about a/g and the accelerometer reads
    /// level: a shorter τ lets that error into the speed loop (0.25 s, the common 0.98 at
    /// 5 ms, quadruples the flat LQR's pitch error; docs/parameters.md).
    pub fn complementary() -> Self {
        Self::Complementary { time_constant: c(1.0) }
    }

    /// A crossover near 1 s at a 5 ms loop (r = q τ² / T): the accelerometer's "noise" is
    /// mostly the lean while accelerating, not its white noise. The bias adapts slowly
    /// (q_bias), yet accelerations still leak into it: on the flat LQR run it does worse
    /// than the complementary filter (docs/parameters.md).
    pub fn kalman() -> Self {
        Self::Kalman { q_angle: c(1e-3), q_bias: c(1e-6), r_angle: c(0.2) }
    }

    pub fn validate(&self) -> Result<Self, TwipError> {
        let check = |name, v: T| {
            if v.is_finite() && v > T::zero() {
                Ok(())
            } else {
                Err(TwipError::InvalidParameter { name, value: crate::to_f64(v), reason: "must be finite and > 0" })
            }
        };
        match *self {
            Self::Complementary { time_constant } => check("time_constant", time_constant)?,
            Self::Kalman { q_angle, q_bias, r_angle } => {
                check("q_angle", q_angle)?;
                check("q_bias", q_bias)?;
                check("r_angle", r_angle)?;
            }
        }
        Ok(*self)
    }
}

/// Tilt of the specific force (f_x, f_z) in the sensor's axes [rad].
#[inline]
pub fn accel_tilt<T: Real>(fx: T, fz: T) -> T {
    (-fx).atan2(fz)
}

/// A running estimator.
#[derive(Clone, Copy, Debug)]
pub struct TiltFilter<T> {
    kind: TiltEstimator<T>,
    angle: T,
    bias: T,
    /// Covariance of (angle, bias) (Kalman only).
    p: [[T; 2]; 2],
    started: bool,
}

impl<T: Real> TiltFilter<T> {
    pub fn new(kind: TiltEstimator<T>) -> Result<Self, TwipError> {
        Ok(Self { kind: kind.validate()?, angle: T::zero(), bias: T::zero(), p: [[T::zero(); 2]; 2], started: false })
    }

    /// The gyroscope bias estimate [rad/s] (0 for the complementary filter).
    pub fn bias(&self) -> T {
        self.bias
    }

    /// Whether the angle, bias and covariance it carries to its next update are finite (the
    /// C ABI undoes an update that overflowed them).
    pub fn state_is_finite(&self) -> bool {
        let [[p00, p01], [p10, p11]] = self.p;
        [self.angle, self.bias, p00, p01, p10, p11].iter().all(|v| v.is_finite())
    }

    /// (φ̂, φ̂̇) after the accelerometer tilt `tilt` and the gyroscope rate `rate`, `dt`
    /// after the previous update.
    pub fn update(&mut self, tilt: T, rate: T, dt: T) -> (T, T) {
        if !self.started {
            self.started = true;
            self.angle = tilt;
            if let TiltEstimator::Kalman { r_angle, .. } = self.kind {
                // The bias is unknown to within a data-sheet-calibrated 1 °/s.
                let one_dps = core::f64::consts::PI / 180.0;
                let bias_var = c::<T>(one_dps * one_dps);
                self.p = [[r_angle, T::zero()], [T::zero(), bias_var]];
            }
            return (self.angle, rate - self.bias);
        }
        match self.kind {
            TiltEstimator::Complementary { time_constant } => {
                let a = time_constant / (time_constant + dt);
                self.angle = a * (self.angle + dt * rate) + (T::one() - a) * tilt;
            }
            TiltEstimator::Kalman { q_angle, q_bias, r_angle } => {
                // Predict with F = [[1, −dt], [0, 1]].
                self.angle += dt * (rate - self.bias);
                let [[p00, p01], [p10, p11]] = self.p;
                let p00 = p00 - dt * (p01 + p10) + dt * dt * p11 + q_angle * dt;
                let p01 = p01 - dt * p11;
                let p10 = p10 - dt * p11;
                let p11 = p11 + q_bias * dt;
                // Correct with the accelerometer's tilt (H = [1, 0]).
                let s = p00 + r_angle;
                let (k0, k1) = (p00 / s, p10 / s);
                let innovation = tilt - self.angle;
                self.angle += k0 * innovation;
                self.bias += k1 * innovation;
                self.p = [[p00 - k0 * p00, p01 - k0 * p01], [p10 - k1 * p00, p11 - k1 * p01]];
            }
        }
        (self.angle, rate - self.bias)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_converge_on_a_static_tilt_the_kalman_filter_through_a_gyro_bias() {
        // Starts level, tilted by 0.1 rad with a gyro bias of 0.01 rad/s; 2 min at 5 ms.
        let (tilt, bias, dt) = (0.1, 0.01, 0.005);
        for kind in [TiltEstimator::complementary(), TiltEstimator::kalman()] {
            let mut f = TiltFilter::<f64>::new(kind).unwrap();
            f.update(0.0, bias, dt);
            let mut out = (0.0, 0.0);
            for _ in 0..24_000 {
                out = f.update(tilt, bias, dt);
            }
            match kind {
                // The complementary filter settles τ b off.
                TiltEstimator::Complementary { time_constant } => {
                    assert!((out.0 - (tilt + time_constant * bias)).abs() < 1e-9, "{out:?}");
                }
                // The Kalman filter learns the bias and settles on the tilt.
                TiltEstimator::Kalman { .. } => {
                    assert!((out.0 - tilt).abs() < 1e-4 && out.1.abs() < 0.05 * bias, "{out:?}");
                }
            }
        }
        assert!(TiltFilter::<f64>::new(TiltEstimator::Complementary { time_constant: 0.0 }).is_err());
    }
}
