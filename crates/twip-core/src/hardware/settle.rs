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
use crate::sim::runner::MAX_STEPS_PER_PERIOD;
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
        // In steps too: 2 s at dt = 1e-9 would be 2e9 of them, as uninterruptible.
        if seconds / dt > c(MAX_STEPS_PER_PERIOD) {
            return Err(TwipError::InvalidParameter { name: "settle", value: crate::to_f64(seconds), reason: "over dt is more than 1e8 plant steps" });
        }
        Ok((seconds > T::zero()).then(|| Self { seconds, dt, rng: Sfc64::new(seed ^ SETTLE_SEED, stream) }))
    }

    /// Feeds `tilt` a copy of `imu` reading the robot at rest at pitch `phi` (the specific
    /// force of gravity alone), for whole loop periods `period` covering the settle, each
    /// period's read as `run_loop` takes it (the sample before the first, then a read and a
    /// sample per step). Returns the time of the last read relative to t = 0 (−period).
    pub fn run(&self, tilt: &mut TiltFilter<T>, imu: &Mpu6050<T>, phi: T, g: T, period: T) -> T {
        let (mut imu, mut rng) = (*imu, self.rng);
        let dt = self.dt;
        let (per_update, reads) = self.grid(period);
        let mut clock = ImuClock::new(imu.settings().sample_period, dt);
        let (fx, fz) = rest_force(phi, imu.settings().height, g);
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

    /// Plant steps per loop period `period`, and the reads that cover the settle.
    fn grid(&self, period: T) -> (usize, usize) {
        let per_update = crate::to_f64((period / self.dt).round().max(T::one())) as usize;
        (per_update, crate::to_f64((self.seconds / period).ceil().max(T::one())) as usize)
    }
}

/// The specific force at the IMU `height` up a robot at rest at pitch `phi` under gravity
/// `g`: at rest the ground's slope and the wheel's radius drop out.
fn rest_force<T: Real>(phi: T, height: T, g: T) -> (T, T) {
    let (rest, still) = (Vector4::new(phi, T::zero(), T::zero(), T::zero()), Vector4::zeros());
    specific_force(&rest, &still, T::zero(), T::one(), T::zero(), height, g)
}

/// What a settle reads and sets of one robot's sensors: its settle, its estimator, the IMU
/// the settle copies, the pitch it stands at, gravity, and the time of the last read.
pub(crate) struct Settling<'a, T> {
    pub settle: &'a Settle<T>,
    pub tilt: &'a mut TiltFilter<T>,
    pub imu: &'a Mpu6050<T>,
    pub phi: T,
    pub g: T,
    pub last_read: &'a mut Option<T>,
}

impl<T: Real> Settling<'_, T> {
    /// [`Settle::run`] on this robot, reads every `period`.
    pub(crate) fn run(&mut self, period: T) {
        *self.last_read = Some(self.settle.run(self.tilt, self.imu, self.phi, self.g, period));
    }
}

/// Sensors a [`Settle`] settles (the 2-DOF and the 3-DOF robot's), standing at pitch `phi`:
/// their [`Settling`], None without a settle or an IMU.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // the lanes'
pub(crate) trait Settles {
    fn settling(&mut self, phi: f64) -> Option<Settling<'_, f64>>;
}

#[cfg(feature = "std")]
pub(crate) use lanes::{settle_side_by_side, SETTLE_LANES};

/// Many robots' settles side by side, on lanes: the robots that reset together (an env's)
/// or start together (a sweep's block). A settle costs as much as a few hundred plant steps.
#[cfg(feature = "std")]
mod lanes {
    use super::*;
    use crate::hardware::imu::NoiseLanes;
    use crate::model::lane::{Lane as _, Wide};
    use crate::sweep::block::multiversioned;

    /// Robots settled on one set of lanes. 8, chosen without a measurement yet: with fewer
    /// robots reset at once, the padding costs less than with 16. An env's reset hands its
    /// robots' settles to its threads this many at a time.
    pub(crate) const SETTLE_LANES: usize = 8;

    impl Settling<'_, f64> {
        /// Whether this robot's settle and `other`'s run on lanes as one: the same length,
        /// step and IMU (but for its state).
        fn alike(&self, other: &Self) -> bool {
            (self.settle.seconds, self.settle.dt) == (other.settle.seconds, other.settle.dt) && self.imu.alike(other.imu)
        }
    }

    multiversioned! {
        /// Settles each robot of `robots` (its sensors, the pitch it stands at) as
        /// [`Settle::run`] settles it, bit for bit: runs of robots whose settles are alike
        /// side by side on lanes (the IMU's arithmetic is written once over `Lane`, the noise
        /// each lane's own stream's), a robot alone as `run` runs it.
        #[allow(private_bounds)]
        pub fn settle_side_by_side, settle_avx512, settle_avx2, settle_baseline = settle_all<S: Settles>(robots: &mut [(&mut S, f64)], period: f64) -> ()
    }

    #[inline(always)]
    fn settle_all<S: Settles>(robots: &mut [(&mut S, f64)], period: f64) {
        let mut settling: alloc::vec::Vec<Settling<'_, f64>> = robots.iter_mut().filter_map(|(s, phi)| s.settling(*phi)).collect();
        let mut rest = &mut settling[..];
        while !rest.is_empty() {
            let n = rest.iter().take(SETTLE_LANES).take_while(|s| s.alike(&rest[0])).count();
            let (group, tail) = rest.split_at_mut(n);
            if n == 1 {
                group[0].run(period);
            } else {
                run_lanes::<SETTLE_LANES>(group, period);
            }
            rest = tail;
        }
    }

    /// [`Settle::run`] on up to `N` alike robots at once (the lanes past them copy the last).
    #[inline(always)]
    fn run_lanes<const N: usize>(robots: &mut [Settling<'_, f64>], period: f64) {
        let lane = |l: usize| &robots[l.min(robots.len() - 1)];
        let (settle, first) = (*lane(0).settle, *lane(0).imu);
        let mut imu = Mpu6050::lanes(&core::array::from_fn::<_, N, _>(|l| lane(l).imu));
        let mut noise = NoiseLanes::<N, 1>::new(&core::array::from_fn(|l| (lane(l).settle.rng, [lane(l).imu.noise()])));
        let dt = settle.dt;
        let (per_update, reads) = settle.grid(period);
        let mut clock = ImuClock::new(first.settings().sample_period, dt);
        // Each lane's as `run` computes it (its sine is the scalar one).
        let force: [(f64, f64); N] = core::array::from_fn(|l| rest_force(lane(l).phi, first.settings().height, lane(l).g));
        let (fx, fz, zero) = (Wide(force.map(|f| f.0)), Wide(force.map(|f| f.1)), Wide::splat(0.0));
        // A function always inlined, not a closure: the closure, called twice, was left out
        // of line and so built without the kernel copy's instructions (SSE2 code in the
        // AVX-512 copy: `perf annotate` of the env's settle, a quarter of the 2-DOF rig env's time).
        #[inline(always)]
        fn sample<const N: usize>(imu: &mut Mpu6050<Wide<N>>, clock: &mut ImuClock<f64>, noise: &mut NoiseLanes<N, 1>, force: [Wide<N>; 3], t: f64) {
            if clock.due(t) {
                let [n] = noise.draw(&[true; N]);
                imu.sample_with(force[0], force[1], force[2], n.map(Wide));
            }
        }
        let force = [fx, fz, zero];
        sample(&mut imu, &mut clock, &mut noise, force, 0.0);
        let mut last: Option<f64> = None;
        for k in 0..reads * per_update {
            let t = dt * k as f64;
            if k % per_update == 0 {
                let r = imu.reading();
                for (j, robot) in robots.iter_mut().enumerate() {
                    robot.tilt.update(accel_tilt(r.accel_x.0[j], r.accel_z.0[j]), r.gyro.0[j], last.map_or(0.0, |l| t - l));
                }
                last = Some(t);
            }
            sample(&mut imu, &mut clock, &mut noise, force, t);
        }
        for robot in robots.iter_mut() {
            *robot.last_read = Some(-(dt * per_update as f64));
        }
    }
}

/// The longest settle [s]. The tilt estimator settles within seconds; a settle runs the IMU
/// at its sample rate before every run, uninterruptibly: 1e9 s (1e12 steps at 1 ms) hung
/// simulate and the envs past any wait (SIGINT ignored).
pub const MAX_SETTLE: f64 = 600.0;

/// A settle's length must be finite, ≥ 0 and at most [`MAX_SETTLE`].
pub fn check<T: Real>(seconds: T) -> Result<(), TwipError> {
    if seconds.is_finite() && seconds >= T::zero() && seconds <= c(MAX_SETTLE) {
        Ok(())
    } else {
        Err(TwipError::InvalidParameter { name: "settle", value: crate::to_f64(seconds), reason: "must be finite, >= 0 and <= 600 [s]" })
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
        for bad in [-1.0, f64::NAN, f64::INFINITY, MAX_SETTLE * (1.0 + f64::EPSILON), 1e9] {
            let got = Settle::new(Some(bad), 1e-3, 0, 0);
            assert!(matches!(got, Err(TwipError::InvalidParameter { name: "settle", reason, .. }) if reason.contains("<= 600 [s]")));
        }
        assert_eq!(MAX_SETTLE, 600.0, "the message names the bound");
        assert!(Settle::<f64>::new(Some(MAX_SETTLE), 1e-3, 0, 0).unwrap().is_some());
        let tiny_dt = Settle::<f64>::new(Some(2.0), 1e-9, 0, 0);
        assert!(matches!(tiny_dt, Err(TwipError::InvalidParameter { name: "settle", reason, .. }) if reason.contains("1e8")));
    }

    /// A robot's parts a settle takes, for [`settle_side_by_side`].
    #[cfg(feature = "std")]
    struct Robot {
        settle: Settle<f64>,
        tilt: TiltFilter<f64>,
        imu: Mpu6050<f64>,
        g: f64,
        last_read: Option<f64>,
    }

    #[cfg(feature = "std")]
    impl Settles for Robot {
        fn settling(&mut self, phi: f64) -> Option<Settling<'_, f64>> {
            Some(Settling { settle: &self.settle, tilt: &mut self.tilt, imu: &self.imu, phi, g: self.g, last_read: &mut self.last_read })
        }
    }

    /// Side by side, each robot's estimator ends as `run` leaves it alone, bit for bit: 19
    /// robots (two full sets of lanes and three more), each its own pitch, gravity, seed and
    /// estimator, two with another IMU (which breaks the runs of alike robots) and one with
    /// a shorter settle.
    #[cfg(feature = "std")]
    #[test]
    fn side_by_side_is_each_robot_alone() {
        let (thesis, sheet) = (ImuSettings::thesis_like(), ImuSettings::data_sheet());
        let mut robots: alloc::vec::Vec<(Robot, f64)> = (0..19u64)
            .map(|i| {
                let settings = if i == 4 || i == 13 { &sheet } else { &thesis };
                let kind = if i % 3 == 0 { TiltEstimator::kalman() } else { TiltEstimator::complementary() };
                let seconds = if i == 9 { 0.3 } else { 2.0 };
                let robot = Robot {
                    settle: Settle::new(Some(seconds), 1e-3, i * 7919, i).unwrap().unwrap(),
                    tilt: TiltFilter::new(kind).unwrap(),
                    imu: Mpu6050::new(settings).unwrap(),
                    g: 9.81 + 0.01 * i as f64,
                    last_read: None,
                };
                (robot, 0.02 * i as f64 - 0.15)
            })
            .collect();
        let alone: alloc::vec::Vec<_> = robots
            .iter()
            .map(|(r, phi)| {
                let mut tilt = r.tilt;
                let last = r.settle.run(&mut tilt, &r.imu, *phi, r.g, 5e-3);
                (tilt, last)
            })
            .collect();
        settle_side_by_side(&mut robots.iter_mut().map(|(r, phi)| (r, *phi)).collect::<alloc::vec::Vec<_>>(), 5e-3);
        for (i, ((robot, _), (tilt, last))) in robots.iter().zip(&alone).enumerate() {
            assert_eq!(format!("{:?}", robot.tilt), format!("{tilt:?}"), "robot {i}");
            assert_eq!(robot.last_read, Some(*last), "robot {i}");
        }
    }
}
