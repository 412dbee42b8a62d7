//! `twip.DcMotor`: the brushed gear motor the 3-DOF trackers drive.
use pyo3::prelude::*;
use twip_core::hardware::motor::{DataSheet, DcMotor};

use crate::convert::{real, scalar, Real};
use crate::errors::CoreResult;

// --- motor -------------------------------------------------------------------------------------

/// A brushed DC gear motor on PWM, quasi-static: i = (V - k_e eta w)/R, wheel torque
/// eta k_t i, w the wheel's speed relative to the body [rad/s]. SI units.
#[pyclass(name = "DcMotor", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyDcMotor {
    pub inner: DcMotor<f64>,
}

#[pymethods]
impl PyDcMotor {
    #[new]
    #[pyo3(signature = (resistance, k_t, gear_ratio, friction = 0.0, supply = 11.1, pwm_max = 255.0))]
    fn new(
        resistance: Real,
        k_t: Real,
        gear_ratio: Real,
        #[pyo3(from_py_with = real)] friction: f64,
        #[pyo3(from_py_with = real)] supply: f64,
        #[pyo3(from_py_with = real)] pwm_max: f64,
    ) -> CoreResult<Self> {
        Ok(Self { inner: DcMotor::new(resistance.0, k_t.0, gear_ratio.0, friction, supply, pwm_max)? })
    }

    /// The thesis's GB37Y3530-12V-251R (Table 2.3) on a `supply` V battery (3 x 3.7 V).
    #[staticmethod]
    #[pyo3(signature = (supply = 11.1))]
    fn gb37y3530(#[pyo3(from_py_with = real)] supply: f64) -> CoreResult<Self> {
        Ok(Self { inner: DcMotor::gb37y3530().with_supply(supply)? })
    }

    /// R = V/I_stall, k_t = k_e = (V - I_0 R)/w_0, friction = k_t I_0/w_0 (at the motor shaft).
    #[staticmethod]
    #[pyo3(signature = (rated_voltage, no_load_rpm, no_load_current, stall_current, gear_ratio, supply = 11.1))]
    fn from_data_sheet(
        rated_voltage: Real,
        no_load_rpm: Real,
        no_load_current: Real,
        stall_current: Real,
        gear_ratio: Real,
        #[pyo3(from_py_with = real)] supply: f64,
    ) -> CoreResult<Self> {
        let sheet = DataSheet {
            rated_voltage: rated_voltage.0,
            no_load_rpm: no_load_rpm.0,
            no_load_current: no_load_current.0,
            stall_current: stall_current.0,
            gear_ratio: gear_ratio.0,
        };
        Ok(Self { inner: DcMotor::from_data_sheet(&sheet, supply)? })
    }

    fn current(&self, voltage: Real, relative_speed: Real) -> CoreResult<f64> {
        Ok(self.inner.current(scalar("voltage", voltage.0)?, scalar("relative_speed", relative_speed.0)?))
    }

    /// Wheel torque [N m] at terminal `voltage` and relative wheel speed [rad/s].
    fn torque(&self, voltage: Real, relative_speed: Real) -> CoreResult<f64> {
        Ok(self.inner.torque(scalar("voltage", voltage.0)?, scalar("relative_speed", relative_speed.0)?))
    }

    fn voltage_for_torque(&self, torque: Real, relative_speed: Real) -> CoreResult<f64> {
        Ok(self.inner.voltage_for_torque(scalar("torque", torque.0)?, scalar("relative_speed", relative_speed.0)?))
    }

    fn pwm_voltage(&self, pwm: Real) -> CoreResult<f64> {
        Ok(self.inner.pwm_voltage(scalar("pwm", pwm.0)?))
    }

    fn torque_from_pwm(&self, pwm: Real, relative_speed: Real) -> CoreResult<f64> {
        Ok(self.inner.torque_from_pwm(scalar("pwm", pwm.0)?, scalar("relative_speed", relative_speed.0)?))
    }

    /// (full reverse, full forward) torque at `relative_speed`.
    fn torque_limits(&self, relative_speed: Real) -> CoreResult<(f64, f64)> {
        Ok(self.inner.torque_limits(scalar("relative_speed", relative_speed.0)?))
    }

    /// Stall torque of one PWM count [N m].
    fn torque_per_count(&self) -> f64 {
        self.inner.torque_per_count()
    }

    /// Wheel speed with no load at full supply [rad/s].
    fn no_load_speed(&self) -> f64 {
        self.inner.no_load_speed()
    }

    /// eta^2 x friction [N m s/rad].
    fn friction_at_wheel(&self) -> f64 {
        self.inner.friction_at_wheel()
    }

}

crate::settings::settings_class!(PyDcMotor, "DcMotor",
    settings {
        resistance: f64 = |s| s.inner.resistance();
        k_t: f64 = |s| s.inner.k_t();
        gear_ratio: f64 = |s| s.inner.gear_ratio();
        /// Viscous friction at the motor shaft [N m s/rad].
        friction: f64 = |s| s.inner.friction();
        supply: f64 = |s| s.inner.supply();
        pwm_max: f64 = |s| s.inner.pwm_max();
    }
);

pub(crate) fn motor_or_default(motor: Option<&PyDcMotor>) -> DcMotor<f64> {
    motor.map(|m| m.inner).unwrap_or_else(DcMotor::gb37y3530)
}
