//! The motor's quadrature encoder (Table 2.3: 700 counts per turn of the gearbox shaft;
//! 2797 with 4× decoding, 2.3.2). The motor is fixed to the body, so it counts the wheel's
//! angle relative to the body, β = θ − φ; the firmware adds its pitch estimate to get
//! θ̂ = β̂ + φ̂ and differences the counts over the control period for the speed.
//!
//! The counter changes at edges fixed on the shaft, every 2π/CPR: the count is
//! ⌊β · CPR / 2π⌋, zero when wheel and body were aligned. Differencing two counts errs
//! by less than one count, so the speed errs by less than (2π/CPR)/T against the mean
//! speed over the period.
use crate::{Real, TwipError};

/// One encoder and its last count.
#[derive(Clone, Copy, Debug)]
pub struct Encoder<T> {
    counts_per_rad: T,
    rad_per_count: T,
    last: Option<T>,
}

impl<T: Real> Encoder<T> {
    /// `cpr` counts per revolution of the wheel (the gearbox shaft).
    pub fn new(cpr: T) -> Result<Self, TwipError> {
        if !(cpr.is_finite() && cpr >= T::one()) {
            return Err(TwipError::InvalidParameter { name: "encoder_cpr", value: crate::to_f64(cpr), reason: "must be finite and >= 1" });
        }
        Ok(Self { counts_per_rad: cpr / T::two_pi(), rad_per_count: T::two_pi() / cpr, last: None })
    }

    /// The counter at relative angle `beta` [rad].
    #[inline]
    pub fn count(&self, beta: T) -> T {
        (beta * self.counts_per_rad).floor()
    }

    /// (angle, speed) the firmware reads at relative angle `beta`, `dt` after its last
    /// read: the counted angle and the counts' difference over `dt` (0 at the first read).
    pub fn read(&mut self, beta: T, dt: T) -> (T, T) {
        self.read_count(self.count(beta), dt)
    }

    /// (angle, speed) from the counter's value `count` (what a firmware reads from its
    /// hardware counter), `dt` after the last read; the speed is 0 at the first read.
    pub fn read_count(&mut self, count: T, dt: T) -> (T, T) {
        let speed = match self.last {
            Some(last) if dt > T::zero() => self.speed_of(count - last, dt),
            _ => T::zero(),
        };
        self.last = Some(count);
        (count * self.rad_per_count, speed)
    }

    /// The speed [rad/s] of `counts` counts in `dt` [s] (> 0): for a firmware that
    /// differences its integer counter itself, exactly (a float count loses whole counts
    /// past 2^24 in f32).
    #[inline]
    pub fn speed_of(&self, counts: T, dt: T) -> T {
        counts * self.rad_per_count / dt
    }

    /// One count [rad].
    pub fn resolution(&self) -> T {
        self.rad_per_count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speed_error_is_below_one_count_per_period() {
        let mut e = Encoder::<f64>::new(700.0).unwrap();
        let dt = 0.005;
        let bound = e.resolution() / dt;
        e.read(0.0, dt);
        let mut beta = 0.0;
        for k in 1..2000 {
            let next = beta + dt * (3.0 * (k as f64 * 0.01).sin() + 0.3);
            let (angle, speed) = e.read(next, dt);
            let mean = (next - beta) / dt;
            assert!((speed - mean).abs() < bound, "k {k}: {speed} vs {mean}");
            assert!(next - angle >= 0.0 && next - angle < e.resolution());
            beta = next;
        }
        assert!(Encoder::<f64>::new(0.0).is_err());
    }
}
