//! Wheel speed / position schedules: the thesis's "run at a speed to a distance, hold,
//! come back" experiments, and constant-speed runs.
use crate::error::invalid;
use crate::control::Reference;
use crate::{Real, TwipError};

/// Longest schedule a [`SpeedSchedule`] holds (fixed size: no allocation, no_std).
pub const MAX_LEGS: usize = 8;

/// What the wheel should do at time t: angle θ_ref(t) [rad] and speed θ̇_ref(t) [rad/s].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpeedRef<T> {
    pub theta: T,
    pub theta_dot: T,
}

/// One leg: drive at `speed` (> 0, the sign comes from the direction) to the wheel angle
/// `goal`, then hold still for `hold` seconds. An infinite goal drives forever.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leg<T> {
    pub goal: T,
    pub speed: T,
    pub hold: T,
}

/// A time-based wheel schedule from θ = 0 at t = 0: the reference position ramps at the
/// leg's speed to its goal, holds, and so on; after the last leg it holds its goal.
#[derive(Clone, Copy, Debug)]
pub struct SpeedSchedule<T> {
    legs: [Leg<T>; MAX_LEGS],
    /// Start time of each leg's ramp.
    starts: [T; MAX_LEGS],
    /// Start angle of each leg.
    origins: [T; MAX_LEGS],
    count: usize,
}

impl<T: Real> SpeedSchedule<T> {
    /// Constant wheel speed from θ = 0 forever (the thesis's simulations).
    pub fn constant(speed: T) -> Result<Self, TwipError> {
        if !speed.is_finite() {
            return Err(invalid("speed", speed, "must be finite"));
        }
        if speed == T::zero() {
            return Self::new(&[]);
        }
        let goal = if speed > T::zero() { T::one() } else { -T::one() } / T::zero();
        Self::new(&[Leg { goal, speed: speed.abs(), hold: T::zero() }])
    }

    /// Legs in order (at most [`MAX_LEGS`]). Speeds must be > 0, holds ≥ 0, goals not NaN.
    pub fn new(legs: &[Leg<T>]) -> Result<Self, TwipError> {
        if legs.len() > MAX_LEGS {
            return Err(TwipError::InvalidParameter {
                name: "legs",
                value: legs.len() as f64,
                reason: "too many legs (at most 8)",
            });
        }
        let zero = Leg { goal: T::zero(), speed: T::one(), hold: T::zero() };
        let mut s = Self { legs: [zero; MAX_LEGS], starts: [T::zero(); MAX_LEGS], origins: [T::zero(); MAX_LEGS], count: legs.len() };
        let (mut t, mut at) = (T::zero(), T::zero());
        for (i, leg) in legs.iter().enumerate() {
            if is_nan(leg.goal) {
                return Err(invalid("goal", leg.goal, "must not be NaN"));
            }
            if !(leg.speed.is_finite() && leg.speed > T::zero()) {
                return Err(invalid("speed", leg.speed, "must be finite and > 0"));
            }
            if !(leg.hold.is_finite() && leg.hold >= T::zero()) {
                return Err(invalid("hold", leg.hold, "must be finite and >= 0"));
            }
            if i > 0 && !legs[i - 1].goal.is_finite() {
                return Err(invalid("goal", legs[i - 1].goal, "only the last leg may drive forever"));
            }
            s.legs[i] = *leg;
            s.starts[i] = t;
            s.origins[i] = at;
            t += (leg.goal - at).abs() / leg.speed + leg.hold;
            at = leg.goal;
        }
        Ok(s)
    }

    pub fn legs(&self) -> &[Leg<T>] {
        &self.legs[..self.count]
    }

    /// The signed cruise speed of each leg, in order (repeats kept; the 0 of the holds
    /// is not among them), for pre-computing.
    pub fn speeds(&self) -> impl Iterator<Item = T> + '_ {
        self.legs().iter().enumerate().map(move |(i, l)| {
            if l.goal >= self.origins[i] { l.speed } else { -l.speed }
        })
    }
}

#[allow(clippy::eq_op)] // NaN is the one value not equal to itself
fn is_nan<T: Real>(v: T) -> bool {
    v != v
}

impl<T: Real> Reference<T> for SpeedSchedule<T> {
    type Sample = SpeedRef<T>;

    fn sample(&self, t: T) -> SpeedRef<T> {
        // The active leg is the last one that has started (legs are few: a linear scan).
        let mut i = self.count;
        while i > 0 && self.starts[i - 1] > t {
            i -= 1;
        }
        if i == 0 {
            return SpeedRef { theta: T::zero(), theta_dot: T::zero() };
        }
        let leg = &self.legs[i - 1];
        let origin = self.origins[i - 1];
        let elapsed = t - self.starts[i - 1];
        let span = (leg.goal - origin).abs();
        let travelled = leg.speed * elapsed;
        if travelled < span {
            let dir = if leg.goal >= origin { T::one() } else { -T::one() };
            SpeedRef { theta: origin + dir * travelled, theta_dot: dir * leg.speed }
        } else {
            SpeedRef { theta: leg.goal, theta_dot: T::zero() }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn go_hold_return() {
        let s = SpeedSchedule::new(&[
            Leg { goal: 10.0, speed: 2.0, hold: 5.0 },
            Leg { goal: 0.0, speed: 5.0, hold: 0.0 },
        ])
        .unwrap();
        assert_eq!(s.sample(-1.0), SpeedRef { theta: 0.0, theta_dot: 0.0 });
        assert_eq!(s.sample(1.0), SpeedRef { theta: 2.0, theta_dot: 2.0 });
        assert_eq!(s.sample(6.0), SpeedRef { theta: 10.0, theta_dot: 0.0 });
        assert_eq!(s.sample(11.0), SpeedRef { theta: 5.0, theta_dot: -5.0 });
        assert_eq!(s.sample(100.0), SpeedRef { theta: 0.0, theta_dot: 0.0 });
        let mut speeds = s.speeds();
        assert_eq!((speeds.next(), speeds.next(), speeds.next()), (Some(2.0), Some(-5.0), None));
    }

    #[test]
    fn constant_runs_forever() {
        let s = SpeedSchedule::constant(-3.0).unwrap();
        assert_eq!(s.sample(2.0), SpeedRef { theta: -6.0, theta_dot: -3.0 });
        assert_eq!(SpeedSchedule::constant(0.0).unwrap().sample(5.0).theta_dot, 0.0);
    }

    #[test]
    fn bad_legs_are_named() {
        let err = SpeedSchedule::new(&[Leg { goal: 1.0, speed: 0.0, hold: 0.0 }]).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "speed", .. }));
        let err = SpeedSchedule::new(&[Leg { goal: 1.0, speed: 1.0, hold: -1.0 }]).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "hold", .. }));
    }
}
