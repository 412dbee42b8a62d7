//! `twip.Friction`: gearhead friction per wheel, for `SlopeModel(..., friction=)` and
//! `PlanarModel(..., friction=)`.
use pyo3::prelude::*;
use twip_core::model::friction::Friction;

use crate::convert::{real, scalar, Real};
use crate::errors::{invalid, CoreResult};

/// One wheel's gearhead friction (N m, rad/s): Coulomb + viscous + Stribeck, the sign
/// regularised by tanh(w / smoothing_speed); `breakaway` is the static (peak) torque.
/// `stick_speed` > 0 adds a stick state: a wheel slower than it relative to the body is
/// held while the torque that would move it stays below `breakaway`.
#[pyclass(name = "Friction", module = "twip", frozen, eq)]
#[derive(Clone, Copy, PartialEq)]
pub struct PyFriction {
    pub inner: Friction<f64>,
}

#[pymethods]
impl PyFriction {
    #[new]
    #[pyo3(signature = (coulomb, breakaway = None, stribeck_speed = 1.0, viscous = 0.0, smoothing_speed = 0.1, stick_speed = 0.0))]
    fn new(
        coulomb: Real,
        breakaway: Option<Real>,
        #[pyo3(from_py_with = real)] stribeck_speed: f64,
        #[pyo3(from_py_with = real)] viscous: f64,
        #[pyo3(from_py_with = real)] smoothing_speed: f64,
        #[pyo3(from_py_with = real)] stick_speed: f64,
    ) -> CoreResult<Self> {
        let coulomb = coulomb.0;
        let breakaway = breakaway.map_or(coulomb, |b| b.0);
        let inner = Friction { coulomb, breakaway, stribeck_speed, viscous, smoothing_speed, stick_speed }.validate()?;
        Ok(Self { inner })
    }

    /// The GB37 data sheet's no-load torque eta k_t I0 = 0.152 N m read as Coulomb
    /// friction; breakaway 1.25x; Stribeck speed 1 rad/s; smoothing 0.1 rad/s.
    #[staticmethod]
    fn gb37() -> Self {
        Self { inner: Friction::gb37() }
    }

    /// `gb37()` beside a viscous bearing of `viscous_per_wheel` [N m s/rad]: the Coulomb
    /// part is what the viscous one leaves of the no-load torque at the no-load speed
    /// (0.0117 N m beside `RobotParams.balanbot()`'s mu_bearing / 2).
    #[staticmethod]
    fn gb37_beside(viscous_per_wheel: Real) -> CoreResult<Self> {
        let viscous_per_wheel = viscous_per_wheel.0;
        if !(viscous_per_wheel.is_finite() && viscous_per_wheel >= 0.0) {
            return Err(invalid("viscous_per_wheel", viscous_per_wheel, "must be finite and >= 0"));
        }
        Ok(Self { inner: Friction::gb37_beside(viscous_per_wheel).validate()? })
    }

    /// This friction with a stick band of half-width `stick_speed` [rad/s]
    /// (0.1 rad/s suits 1 ms steps, see docs/parameters.md; 0: none).
    fn with_stick(&self, stick_speed: Real) -> CoreResult<Self> {
        Ok(Self { inner: self.inner.with_stick(stick_speed.0).validate()? })
    }

    /// The slip law's torque [N m] at the wheel's speed relative to the body `w` [rad/s]
    /// (with a stick band, a wheel inside it is held by whatever torque that needs).
    fn torque(&self, w: Real) -> CoreResult<f64> {
        Ok(self.inner.torque(scalar("w", w.0)?))
    }
}

crate::settings::settings_class!(PyFriction, "Friction",
    settings {
        coulomb: f64 = |s| s.inner.coulomb;
        breakaway: f64 = |s| s.inner.breakaway;
        stribeck_speed: f64 = |s| s.inner.stribeck_speed;
        viscous: f64 = |s| s.inner.viscous;
        smoothing_speed: f64 = |s| s.inner.smoothing_speed;
        stick_speed: f64 = |s| s.inner.stick_speed;
    }
);
