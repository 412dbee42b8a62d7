//! A brushed DC gear motor driven by PWM (the thesis's GB37Y3530-12V-251R through the
//! Balance Shield's L298P, chapter 2), quasi-static: the winding's inductance is neglected
//! (its L/R is far shorter than a control period), so
//!
//! ```text
//! V = pwm / pwm_max · supply                 (the bridge switches the battery)
//! i = (V − k_e η ω) / R                      (ω: the wheel's speed relative to the body)
//! τ = η k_t i                                (at the wheel; k_t = k_e in SI)
//! ```
//!
//! `R`, `k_t` and the friction come from the data sheet (Table 2.3): R = V/I_stall;
//! k_e = (V − I_0 R)/ω_0 at the no-load speed ω_0 and current I_0; the no-load current
//! is all friction, k_t I_0 at ω_0, read as viscous. [`DcMotor::torque`] is the
//! electromagnetic torque: that friction is already the plant's `mu_bearing` (docs/parameters.md),
//! so it is reported ([`DcMotor::friction_at_wheel`]) but not subtracted again.
use crate::error::invalid;
use crate::model::lane::{saturate, Lane};
use crate::{c, Real, TwipError};

/// The numbers a gear motor's data sheet gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DataSheet<T> {
    /// Voltage the speeds and currents are given at [V].
    pub rated_voltage: T,
    /// No-load speed at the gearbox output [rpm].
    pub no_load_rpm: T,
    /// No-load current [A].
    pub no_load_current: T,
    /// Stall current [A].
    pub stall_current: T,
    /// Gear reduction.
    pub gear_ratio: T,
}

impl<T: Real> DataSheet<T> {
    /// GB37Y3530-12V-251R (Table 2.3): 12 V, 251 rpm and 350 mA no-load, 7 A stall, 43.7:1.
    pub fn gb37y3530() -> Self {
        Self {
            rated_voltage: c(12.0),
            no_load_rpm: c(251.0),
            no_load_current: c(0.35),
            stall_current: c(7.0),
            gear_ratio: c(43.7),
        }
    }
}

/// The battery of the thesis's robot: three 3.7 V 18650 cells in series [V].
pub const BALANBOT_SUPPLY: f64 = 11.1;
/// Full scale of the Arduino's 8-bit PWM.
pub const PWM_MAX: f64 = 255.0;

/// One motor with its gearbox and PWM drive. SI units; speeds and torques at the wheel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DcMotor<T> {
    /// Winding resistance [Ω].
    resistance: T,
    /// Torque constant = back-EMF constant at the motor shaft [N m/A = V s/rad].
    k_t: T,
    gear_ratio: T,
    /// Viscous friction at the motor shaft [N m s/rad].
    friction: T,
    /// Battery voltage the bridge switches [V].
    supply: T,
    /// PWM full scale (255 for 8 bits).
    pwm_max: T,
}

fn check<T: Real>(name: &'static str, v: T, allow_zero: bool) -> Result<T, TwipError> {
    let ok = v.is_finite() && (v > T::zero() || (allow_zero && v == T::zero()));
    if ok {
        Ok(v)
    } else {
        let reason = if allow_zero { "must be finite and >= 0" } else { "must be finite and > 0" };
        Err(invalid(name, v, reason))
    }
}

/// Finite, > 0 and not subnormal (as f64).
fn normal<T: Real>(v: T) -> bool {
    v > T::zero() && crate::to_f64(v).is_normal()
}

impl<T: Real> DcMotor<T> {
    pub fn new(resistance: T, k_t: T, gear_ratio: T, friction: T, supply: T, pwm_max: T) -> Result<Self, TwipError> {
        Ok(Self {
            resistance: check("resistance", resistance, false)?,
            k_t: check("k_t", k_t, false)?,
            gear_ratio: check("gear_ratio", gear_ratio, false)?,
            friction: check("friction", friction, true)?,
            supply: check("supply", supply, false)?,
            pwm_max: check("pwm_max", pwm_max, false)?,
        })
    }

    /// R, k_t = k_e and the friction from a data sheet (module docs), 8-bit PWM.
    pub fn from_data_sheet(sheet: &DataSheet<T>, supply: T) -> Result<Self, TwipError> {
        let volts = check("rated_voltage", sheet.rated_voltage, false)?;
        let stall = check("stall_current", sheet.stall_current, false)?;
        let idle = check("no_load_current", sheet.no_load_current, true)?;
        let eta = check("gear_ratio", sheet.gear_ratio, false)?;
        let rpm = check("no_load_rpm", sheet.no_load_rpm, false)?;
        if idle >= stall {
            return Err(invalid("no_load_current", idle, "must be below the stall current"));
        }
        // Values each finite can still give a motor beyond floating point's range (an
        // overflow, or an underflow that loses the no-load current): name the value that
        // did it, not the next derived one.
        let resistance = volts / stall;
        if !normal(resistance) {
            return Err(invalid("rated_voltage", volts, "over stall_current gives a resistance beyond floating point's range"));
        }
        let w0 = rpm * T::two_pi() / c::<T>(60.0) * eta;
        let k = (volts - idle * resistance) / w0;
        let friction = k * idle / w0;
        if !(normal(w0) && normal(k) && (normal(friction) || idle == T::zero())) {
            return Err(invalid(
                "no_load_rpm",
                rpm,
                "with rated_voltage and gear_ratio gives a torque constant or friction beyond floating point's range",
            ));
        }
        Self::new(resistance, k, eta, friction, supply, c(PWM_MAX))
    }

    /// The thesis's motor (Table 2.3) on its 11.1 V battery.
    pub fn gb37y3530() -> Self {
        Self::from_data_sheet(&DataSheet::gb37y3530(), c(BALANBOT_SUPPLY)).expect("the data sheet is valid")
    }

    /// The same motor on another battery voltage.
    pub fn with_supply(self, supply: T) -> Result<Self, TwipError> {
        Self::new(self.resistance, self.k_t, self.gear_ratio, self.friction, supply, self.pwm_max)
    }

    pub fn resistance(&self) -> T {
        self.resistance
    }

    pub fn k_t(&self) -> T {
        self.k_t
    }

    pub fn gear_ratio(&self) -> T {
        self.gear_ratio
    }

    pub fn friction(&self) -> T {
        self.friction
    }

    pub fn supply(&self) -> T {
        self.supply
    }

    /// The voltage that gives `torque` at `relative_speed` (unbounded: see [`Self::torque_limits`]).
    #[inline]
    pub fn voltage_for_torque(&self, torque: T, relative_speed: T) -> T {
        torque * self.resistance / (self.gear_ratio * self.k_t) + self.k_t * self.gear_ratio * relative_speed
    }

    /// Stall torque per PWM count [N m]: the unit of the Arduino's controller outputs.
    pub fn torque_per_count(&self) -> T {
        self.torque(self.supply / self.pwm_max, T::zero())
    }

    /// Wheel speed with no load at full supply, friction included [rad/s].
    pub fn no_load_speed(&self) -> T {
        let k = self.k_t * self.gear_ratio;
        k * self.supply / (k * k + self.resistance * self.friction * self.gear_ratio * self.gear_ratio)
    }

    /// The viscous friction seen at the wheel, η² b [N m s/rad].
    pub fn friction_at_wheel(&self) -> T {
        self.gear_ratio * self.gear_ratio * self.friction
    }
}

// What the motor does to a command, written once over `Lane`: a run's scalar and a sweep's lanes.
impl<S: Lane> DcMotor<S> {
    /// Winding current [A] at terminal voltage `voltage` and relative wheel speed [rad/s].
    #[inline(always)]
    pub fn current(&self, voltage: S, relative_speed: S) -> S {
        S::madd(-(self.k_t * self.gear_ratio), relative_speed, voltage) / self.resistance
    }

    /// Torque on the wheel [N m] (electromagnetic; see the module docs on friction).
    #[inline(always)]
    pub fn torque(&self, voltage: S, relative_speed: S) -> S {
        self.gear_ratio * self.k_t * self.current(voltage, relative_speed)
    }

    /// Terminal voltage for a PWM command, saturated at ±`pwm_max`.
    #[inline(always)]
    pub fn pwm_voltage(&self, pwm: S) -> S {
        saturate(pwm, self.pwm_max) * self.supply / self.pwm_max
    }

    /// Torque on the wheel for a PWM command at `relative_speed`.
    #[inline(always)]
    pub fn torque_from_pwm(&self, pwm: S, relative_speed: S) -> S {
        self.torque(self.pwm_voltage(pwm), relative_speed)
    }

    /// The torques full reverse and full forward give at `relative_speed`.
    #[inline(always)]
    pub fn torque_limits(&self, relative_speed: S) -> (S, S) {
        (self.torque(-self.supply, relative_speed), self.torque(self.supply, relative_speed))
    }
}

impl<T: Copy> DcMotor<T> {
    /// PWM full scale (255 for 8 bits).
    pub fn pwm_max(&self) -> T {
        self.pwm_max
    }

    /// The same motor in another number type (onto a sweep's lanes).
    #[inline(always)]
    pub(crate) fn map<S>(&self, f: impl Fn(T) -> S) -> DcMotor<S> {
        self.zip(self, |&v, _| f(v))
    }

    /// Each number with `other`'s, combined by `f` (motors side by side on a sweep's lanes).
    #[inline(always)]
    /// The numbers are passed by reference: a lane's motor taken from a block's
    /// (`DcMotor<Wide>`) reads only its lane.
    pub(crate) fn zip<U, S>(&self, other: &DcMotor<U>, f: impl Fn(&T, &U) -> S) -> DcMotor<S> {
        DcMotor {
            resistance: f(&self.resistance, &other.resistance),
            k_t: f(&self.k_t, &other.k_t),
            gear_ratio: f(&self.gear_ratio, &other.gear_ratio),
            friction: f(&self.friction, &other.friction),
            supply: f(&self.supply, &other.supply),
            pwm_max: f(&self.pwm_max, &other.pwm_max),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_sheet_numbers() {
        let m = DcMotor::<f64>::gb37y3530();
        assert!((m.resistance() - 12.0 / 7.0).abs() < 1e-12);
        // k_e = (12 − 0.35 · 12/7) / (251 rpm · 43.7).
        let w0 = 251.0 * core::f64::consts::TAU / 60.0 * 43.7;
        assert!((m.k_t() - (12.0 - 0.6) / w0).abs() < 1e-15);
        // At 12 V it runs at the data sheet's no-load speed drawing the no-load current.
        let at12 = m.with_supply(12.0).unwrap();
        let w = at12.no_load_speed();
        assert!((w - w0 / 43.7).abs() < 1e-9 * w);
        assert!((at12.current(12.0, w) - 0.35).abs() < 1e-9);
        // The current at stall is the stall current.
        assert!((at12.current(12.0, 0.0) - 7.0).abs() < 1e-12);
        assert!((m.torque_per_count() - 0.011013).abs() < 1e-6);
    }

    #[test]
    fn voltage_and_torque_invert() {
        let m = DcMotor::<f64>::gb37y3530();
        for (tau, w) in [(0.3, 2.0), (-0.1, -4.0), (0.0, 10.0)] {
            let v = m.voltage_for_torque(tau, w);
            assert!((m.torque(v, w) - tau).abs() < 1e-14);
        }
        assert_eq!(m.pwm_voltage(400.0), 11.1);
        assert_eq!(m.pwm_voltage(-255.0), -11.1);
        assert!(m.pwm_voltage(f64::NAN).is_nan(), "a NaN duty is not hidden by the saturation");
        let (lo, hi) = m.torque_limits(3.0);
        assert!(lo < 0.0 && hi > 0.0 && hi < m.torque_limits(0.0).1, "back-EMF lowers the forward limit");
    }

    #[test]
    fn bad_numbers_are_named() {
        assert!(matches!(
            DcMotor::<f64>::gb37y3530().with_supply(0.0),
            Err(TwipError::InvalidParameter { name: "supply", .. })
        ));
        let mut sheet = DataSheet::<f64>::gb37y3530();
        sheet.no_load_current = 8.0;
        assert!(matches!(
            DcMotor::from_data_sheet(&sheet, 11.1),
            Err(TwipError::InvalidParameter { name: "no_load_current", .. })
        ));
    }

    #[test]
    fn a_sheet_value_beyond_floating_points_range_is_named_not_the_next_field() {
        // 1e308 rpm was blamed on no_load_current; 1e300 gave a friction of 0 (the no-load
        // current lost) and 1e-308 V a subnormal resistance, both accepted.
        for (field, value) in [("no_load_rpm", 1e308), ("no_load_rpm", 1e300), ("rated_voltage", 1e-308)] {
            let mut sheet = DataSheet::<f64>::gb37y3530();
            match field {
                "no_load_rpm" => sheet.no_load_rpm = value,
                _ => sheet.rated_voltage = value,
            }
            let got = DcMotor::from_data_sheet(&sheet, 11.1);
            let named = matches!(got, Err(TwipError::InvalidParameter { name, value: v, .. }) if name == field && v == value);
            assert!(named, "{field} = {value}: {got:?}");
        }
    }
}
