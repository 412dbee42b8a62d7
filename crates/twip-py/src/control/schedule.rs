//! `twip.SpeedSchedule`: wheel speed / position schedules for the 2-DOF controllers.
use pyo3::prelude::*;
use twip_core::control::Reference;
use twip_core::control::reference::{Leg, SpeedSchedule};

use crate::convert::{real, scalar, Real};
use crate::errors::{finite_param, positive_param, CoreResult};
use crate::settings::Reduced;
/// A wheel schedule from theta = 0: legs of (goal [rad], speed [rad/s] > 0, hold [s]).
#[pyclass(name = "SpeedSchedule", module = "twip", frozen)]
#[derive(Clone)]
pub struct PySpeedSchedule {
    pub inner: SpeedSchedule<f64>,
}

#[pymethods]
impl PySpeedSchedule {
    #[new]
    fn new(legs: Vec<(Real, Real, Real)>) -> CoreResult<Self> {
        let legs: Vec<Leg<f64>> = legs.into_iter().map(|(Real(goal), Real(speed), Real(hold))| Leg { goal, speed, hold }).collect();
        Ok(Self { inner: SpeedSchedule::new(&legs)? })
    }

    /// Constant wheel speed [rad/s] from rest, forever.
    #[staticmethod]
    fn constant(speed: Real) -> CoreResult<Self> {
        Ok(Self { inner: SpeedSchedule::constant(speed.0)? })
    }

    /// The thesis's experiment: drive `distance` [m] at wheel speed `speed` [rad/s],
    /// hold `hold` [s], then drive back to the start and stay there.
    #[staticmethod]
    #[pyo3(signature = (distance, speed, wheel_radius, hold = 0.0))]
    fn go_and_return(distance: Real, speed: Real, wheel_radius: Real, #[pyo3(from_py_with = real)] hold: f64) -> CoreResult<Self> {
        let goal = scalar("distance", distance.0)? / positive_param("wheel_radius", wheel_radius.0)?;
        Self::new(vec![(Real(goal), speed, Real(hold)), (Real(0.0), speed, Real(0.0))])
    }

    /// Legs as (goal, speed, hold) tuples.
    #[getter]
    fn legs(&self) -> Vec<(f64, f64, f64)> {
        self.inner.legs().iter().map(|l| (l.goal, l.speed, l.hold)).collect()
    }

    /// Pickled as SpeedSchedule(legs).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> Reduced<'py, (Vec<(f64, f64, f64)>,)> {
        (slf.get_type().into_any(), (slf.get().legs(),))
    }

    /// (theta_ref, theta_dot_ref) at time t.
    fn sample(&self, t: Real) -> CoreResult<(f64, f64)> {
        let s = self.inner.sample(finite_param("t", t.0)?);
        Ok((s.theta, s.theta_dot))
    }

    fn __repr__(&self) -> String {
        format!("SpeedSchedule({:?})", self.legs())
    }
}

