//! The 3-DOF references: `twip.Circle`, `Line`, `FigureEight`, `Waypoints`.
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::Reference;
use twip_core::sim::log::LogRow;
use twip_core::control::trajectory::{Circle, Direction, FigureEight, Line, Path, PlanarRef, Trajectory, Waypoints};

use crate::convert::{real, scalar, Real};
use crate::errors::{finite_param, CoreResult, InvalidParameterError, PyTwipError};


fn sample_dict<'py>(py: Python<'py>, s: &PlanarRef<f64>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let values = [s.x, s.y, s.psi, s.v, s.omega, s.v_dot, s.omega_dot];
    for (name, v) in <PlanarRef<f64> as LogRow<f64>>::NAMES.iter().zip(values) {
        d.set_item(name, v)?;
    }
    Ok(d)
}

// --- trajectories ------------------------------------------------------------------------

/// Constant speed round a circle. `direction` +1 (or "ccw") turns left, -1 ("cw") right.
/// By default it starts at the origin heading along +x, centre (0, direction * radius).
#[pyclass(name = "Circle", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyCircle {
    pub inner: Circle<f64>,
}

fn direction(obj: &Bound<'_, PyAny>) -> PyResult<Direction> {
    if let Ok(s) = obj.extract::<String>() {
        return match s.as_str() {
            "ccw" | "left" => Ok(Direction::CounterClockwise),
            "cw" | "right" => Ok(Direction::Clockwise),
            other => Err(InvalidParameterError::new_err(format!(
                "direction = '{other}': must be +1 / 'ccw' (left turns) or -1 / 'cw'"
            ))),
        };
    }
    match obj.extract::<Real>() {
        Ok(Real(1.0)) => Ok(Direction::CounterClockwise),
        Ok(Real(-1.0)) => Ok(Direction::Clockwise),
        _ => Err(InvalidParameterError::new_err(format!(
            "direction = {obj}: must be +1 / 'ccw' (left turns) or -1 / 'cw'"
        ))),
    }
}

#[pymethods]
impl PyCircle {
    #[new]
    #[pyo3(signature = (radius, speed, centre = None, direction = None, phase = None))]
    fn new(
        radius: Real,
        speed: Real,
        centre: Option<(Real, Real)>,
        direction: Option<&Bound<'_, PyAny>>,
        phase: Option<Real>,
    ) -> PyResult<Self> {
        let (radius, speed) = (radius.0, speed.0);
        let dir = match direction {
            Some(d) => self::direction(d)?,
            None => Direction::CounterClockwise,
        };
        // By default the circle starts at the origin heading along +x.
        let s = if dir == Direction::CounterClockwise { 1.0 } else { -1.0 };
        let centre = centre.map_or((0.0, s * radius), |(Real(x), Real(y))| (x, y));
        let phase = phase.map_or(-s * std::f64::consts::FRAC_PI_2, |p| p.0);
        let inner = Circle::new([centre.0, centre.1], radius, speed, dir, phase).map_err(PyTwipError)?;
        Ok(Self { inner })
    }

    /// The reference at time t: dict of x, y, psi, v, omega, v_dot, omega_dot (SI).
    fn sample<'py>(&self, py: Python<'py>, t: Real) -> PyResult<Bound<'py, PyDict>> {
        sample_dict(py, &self.inner.sample(finite_param("t", t.0)?))
    }

    /// Distance from (x, y) to the circle [m].
    fn distance(&self, x: Real, y: Real) -> CoreResult<f64> {
        Ok(self.inner.distance(scalar("x", x.0)?, scalar("y", y.0)?))
    }

}

/// A straight line from `start` along `heading` [rad] at constant `speed`.
#[pyclass(name = "Line", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyLine {
    pub inner: Line<f64>,
}

#[pymethods]
impl PyLine {
    #[new]
    #[pyo3(signature = (speed, heading = 0.0, start = (Real(0.0), Real(0.0))))]
    fn new(speed: Real, #[pyo3(from_py_with = real)] heading: f64, start: (Real, Real)) -> CoreResult<Self> {
        let (Real(x), Real(y)) = start;
        Ok(Self { inner: Line::new([x, y], heading, speed.0)? })
    }

    fn sample<'py>(&self, py: Python<'py>, t: Real) -> PyResult<Bound<'py, PyDict>> {
        sample_dict(py, &self.inner.sample(finite_param("t", t.0)?))
    }

    fn distance(&self, x: Real, y: Real) -> CoreResult<f64> {
        Ok(self.inner.distance(scalar("x", x.0)?, scalar("y", y.0)?))
    }

}

/// The lemniscate of Gerono x = a sin(Wt), y = (a/2) sin(2Wt), W = 2 pi/period, about
/// `centre` (right lobe clockwise, left lobe counter-clockwise).
#[pyclass(name = "FigureEight", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyFigureEight {
    pub inner: FigureEight<f64>,
}

#[pymethods]
impl PyFigureEight {
    #[new]
    #[pyo3(signature = (half_width, period, centre = (Real(0.0), Real(0.0))))]
    fn new(half_width: Real, period: Real, centre: (Real, Real)) -> CoreResult<Self> {
        let (Real(x), Real(y)) = centre;
        Ok(Self { inner: FigureEight::new([x, y], half_width.0, period.0)? })
    }

    fn sample<'py>(&self, py: Python<'py>, t: Real) -> PyResult<Bound<'py, PyDict>> {
        sample_dict(py, &self.inner.sample(finite_param("t", t.0)?))
    }

    fn distance(&self, x: Real, y: Real) -> CoreResult<f64> {
        Ok(self.inner.distance(scalar("x", x.0)?, scalar("y", y.0)?))
    }

}

/// Straight legs through `points` (2 to 16 (x, y) pairs) at constant `speed`, inner corners
/// rounded by arcs of `corner_radius` (0: sharp; smaller where a leg is short, sharp at a
/// near-reversal). The reference stops at the last point.
#[pyclass(name = "Waypoints", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyWaypoints {
    pub inner: Waypoints<f64>,
}

#[pymethods]
impl PyWaypoints {
    #[new]
    #[pyo3(signature = (points, speed, corner_radius = 0.0))]
    fn new(points: Vec<(Real, Real)>, speed: Real, #[pyo3(from_py_with = real)] corner_radius: f64) -> CoreResult<Self> {
        let pts: Vec<[f64; 2]> = points.into_iter().map(|(Real(x), Real(y))| [x, y]).collect();
        Ok(Self { inner: Waypoints::new(&pts, speed.0, corner_radius)? })
    }

    fn sample<'py>(&self, py: Python<'py>, t: Real) -> PyResult<Bound<'py, PyDict>> {
        sample_dict(py, &self.inner.sample(finite_param("t", t.0)?))
    }

    fn distance(&self, x: Real, y: Real) -> CoreResult<f64> {
        Ok(self.inner.distance(scalar("x", x.0)?, scalar("y", y.0)?))
    }

}

crate::settings::settings_class!(PyCircle, "Circle",
    settings {
        radius: f64 = |s| s.inner.radius();
        speed: f64 = |s| s.inner.speed();
        centre: (f64, f64) = |s| (s.inner.centre()[0], s.inner.centre()[1]);
        /// +1 counter-clockwise, -1 clockwise.
        direction: i32 = |s| match s.inner.direction() {
            Direction::CounterClockwise => 1,
            Direction::Clockwise => -1,
        };
        phase: f64 = |s| s.inner.phase();
    }
    derived {
        /// One lap [s].
        period: f64 = |s| s.inner.period();
    }
);

crate::settings::settings_class!(PyLine, "Line",
    settings {
        speed: f64 = |s| s.inner.speed();
        heading: f64 = |s| s.inner.heading();
        start: (f64, f64) = |s| (s.inner.start()[0], s.inner.start()[1]);
    }
);

crate::settings::settings_class!(PyFigureEight, "FigureEight",
    settings {
        half_width: f64 = |s| s.inner.half_width();
        period: f64 = |s| s.inner.period();
        centre: (f64, f64) = |s| (s.inner.centre()[0], s.inner.centre()[1]);
    }
);

crate::settings::settings_class!(PyWaypoints, "Waypoints",
    settings {
        points: Vec<(f64, f64)> = |s| s.inner.points().iter().map(|p| (p[0], p[1])).collect();
        speed: f64 = |s| s.inner.speed();
        corner_radius: f64 = |s| s.inner.corner_radius();
    }
    derived {
        /// Length of the rounded path [m].
        length: f64 = |s| s.inner.length();
        /// Time to reach the last point [s].
        duration: f64 = |s| s.inner.duration();
    }
);

pub(crate) fn trajectory(obj: &Bound<'_, PyAny>) -> PyResult<Trajectory<f64>> {
    if let Ok(c) = obj.cast::<PyCircle>() {
        return Ok(Trajectory::Circle(c.get().inner));
    }
    if let Ok(l) = obj.cast::<PyLine>() {
        return Ok(Trajectory::Line(l.get().inner));
    }
    if let Ok(f) = obj.cast::<PyFigureEight>() {
        return Ok(Trajectory::FigureEight(f.get().inner));
    }
    if let Ok(w) = obj.cast::<PyWaypoints>() {
        return Ok(Trajectory::Waypoints(w.get().inner));
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "reference must be a twip.Circle, Line, FigureEight or Waypoints, got {}",
        obj.get_type().name().map(|n| n.to_string()).unwrap_or_default()
    )))
}
