//! A firmware's start (realism's `settle`): before the motors run, the robot stands still
//! at its initial pitch while the firmware's loop reads the IMU through the tilt estimator,
//! so that the estimate has converged when the first command goes out. Without it the
//! estimator starts from the accelerometer at the run's first read, while the robot
//! free-rolls under the delayed first command (0): on a small-wheeled robot on a slope
//! that read 14.7° for a 2.6° pitch (docs/parameters.md).
//!
//! The settle reads a copy of the rig's IMU, at rest, on its own noise stream: the run's
//! IMU (its filters, bias and stream) starts at t = 0 as without a settle, and so does
//! every sweep lane's, which share one IMU state. Only the estimator carries over, and
//! the time of its last read (one loop period before t = 0).
use crate::hardware::imu::{specific_force, ImuClock, Mpu6050};
use crate::hardware::tilt::{accel_tilt, TiltFilter};
use crate::rng::Sfc64;
use crate::{c, Real, TwipError};
use nalgebra::Vector4;

/// The settle's noise key beside the run's (seed ^ this, stream): its own numbers, so that
/// the run's noise is the same with or without a settle.
const SETTLE_SEED: u64 = 0x5e77_1e00_0000_0000;

/// How long the robot stands still before the run, and what its IMU draws meanwhile.
#[derive(Clone, Copy, Debug)]
pub struct Settle<T> {
    seconds: T,
    /// The plant's step: the IMU samples on the run's grid.
    dt: T,
    rng: Sfc64,
}

impl<T: Real> Settle<T> {
    /// None without a settle (`seconds` None or 0); `seed`, `stream`: the run's noise key.
    pub fn new(seconds: Option<T>, dt: T, seed: u64, stream: u64) -> Result<Option<Self>, TwipError> {
        let Some(seconds) = seconds else { return Ok(None) };
        check(seconds)?;
        Ok((seconds > T::zero()).then(|| Self { seconds, dt, rng: Sfc64::new(seed ^ SETTLE_SEED, stream) }))
    }

    /// Feeds `tilt` a copy of `imu` reading the robot at rest at pitch `phi` (the specific
    /// force of gravity alone), for whole loop periods `period` covering the settle, each
    /// period's read as `run_loop` takes it (the sample before the first, then a read and a
    /// sample per step). Returns the time of the last read relative to t = 0 (−period).
    pub fn run(&self, tilt: &mut TiltFilter<T>, imu: &Mpu6050<T>, phi: T, g: T, period: T) -> T {
        let (mut imu, mut rng) = (*imu, self.rng);
        let dt = self.dt;
        let per_update = crate::to_f64((period / dt).round().max(T::one())) as usize;
        let reads = crate::to_f64((self.seconds / period).ceil().max(T::one())) as usize;
        let mut clock = ImuClock::new(imu.settings().sample_period, dt);
        let (rest, still) = (Vector4::new(phi, T::zero(), T::zero(), T::zero()), Vector4::zeros());
        // At rest the ground's slope and the wheel's radius drop out.
        let (fx, fz) = specific_force(&rest, &still, T::zero(), T::one(), T::zero(), imu.settings().height, g);
        let mut sample = |imu: &mut Mpu6050<T>, t: T| {
            if clock.due(t) {
                imu.sample(fx, fz, T::zero(), &mut rng);
            }
        };
        sample(&mut imu, T::zero());
        let mut last: Option<T> = None;
        for k in 0..reads * per_update {
            let t = dt * c::<T>(k as f64);
            if k % per_update == 0 {
                let r = imu.reading();
                tilt.update(accel_tilt(r.accel_x, r.accel_z), r.gyro, last.map_or(T::zero(), |l| t - l));
                last = Some(t);
            }
            sample(&mut imu, t);
        }
        -(dt * c::<T>(per_update as f64))
    }
}

/// A settle's length must be finite and ≥ 0.
pub fn check<T: Real>(seconds: T) -> Result<(), TwipError> {
    if seconds.is_finite() && seconds >= T::zero() {
        Ok(())
    } else {
        Err(TwipError::InvalidParameter { name: "settle", value: crate::to_f64(seconds), reason: "must be finite and >= 0 [s]" })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hardware::imu::ImuSettings;
    use crate::hardware::tilt::TiltEstimator;

    #[test]
    fn a_settled_estimator_reads_the_pitch_at_rest() {
        let imu = Mpu6050::new(&ImuSettings::thesis_like()).unwrap();
        let settle = Settle::new(Some(2.0), 1e-3, 0, 0).unwrap().unwrap();
        let phi: f64 = 0.1;
        for kind in [TiltEstimator::complementary(), TiltEstimator::kalman()] {
            let mut tilt = TiltFilter::new(kind).unwrap();
            assert_eq!(settle.run(&mut tilt, &imu, phi, 9.81, 5e-3), -5e-3);
            // A read an instant later holds the settled angle (the Kalman filter's, whose bias
            // state takes part of the offset, came within 0.24°).
            let (angle, _) = tilt.update(0.0, 0.0, 1e-12);
            assert!((angle - phi).abs() < 0.3f64.to_radians(), "{kind:?}: {angle}");
        }
        assert!(Settle::<f64>::new(Some(0.0), 1e-3, 0, 0).unwrap().is_none());
        assert!(Settle::<f64>::new(None, 1e-3, 0, 0).unwrap().is_none());
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(Settle::new(Some(bad), 1e-3, 0, 0), Err(TwipError::InvalidParameter { name: "settle", .. })));
        }
    }
}
