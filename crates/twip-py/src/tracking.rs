//! Trajectory tracking on the 3-DOF model: `twip.Circle`, `Line`, `FigureEight`,
//! `Waypoints`, `DcMotor`, `PidTracker`, `SmcTracker` and the planar runner.
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::{Controller, Reference};
use twip_core::sim::log::{LogRow, TrajectoryLog};
use twip_core::hardware::motor::{DataSheet, DcMotor};
use twip_core::control::pid::{PidGains, PidTracker, PidUnits};
use twip_core::hardware::planar_rig::PLANAR_RIG_SIGNALS;
use twip_core::sim::runner::{simulate_until, Outcome, SimConfig};
use twip_core::control::smc::{Adaptation, PitchSign, SmcGains, SmcOptions, SmcTracker};
use twip_core::sim::metrics::DrivePeaks;
use twip_core::sim::tracking_metrics::TrackingMetrics;
use twip_core::control::trajectory::{Circle, Direction, FigureEight, Line, Path, PlanarRef, Trajectory, Waypoints};

use crate::convert::vector;
use crate::errors::{invalid, CoreResult, InvalidParameterError, PyTwipError};
use crate::models::PyPlanarModel;
use crate::params::PyRobotParams;
use crate::user_controller::{is_user_controller, UserController};

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
    match obj.extract::<f64>() {
        Ok(1.0) => Ok(Direction::CounterClockwise),
        Ok(-1.0) => Ok(Direction::Clockwise),
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
        radius: f64,
        speed: f64,
        centre: Option<(f64, f64)>,
        direction: Option<&Bound<'_, PyAny>>,
        phase: Option<f64>,
    ) -> PyResult<Self> {
        let dir = match direction {
            Some(d) => self::direction(d)?,
            None => Direction::CounterClockwise,
        };
        // By default the circle starts at the origin heading along +x.
        let s = if dir == Direction::CounterClockwise { 1.0 } else { -1.0 };
        let centre = centre.unwrap_or((0.0, s * radius));
        let phase = phase.unwrap_or(-s * std::f64::consts::FRAC_PI_2);
        let inner = Circle::new([centre.0, centre.1], radius, speed, dir, phase).map_err(PyTwipError)?;
        Ok(Self { inner })
    }

    #[getter]
    fn radius(&self) -> f64 {
        self.inner.radius()
    }

    #[getter]
    fn speed(&self) -> f64 {
        self.inner.speed()
    }

    #[getter]
    fn centre(&self) -> (f64, f64) {
        let c = self.inner.centre();
        (c[0], c[1])
    }

    /// +1 counter-clockwise, -1 clockwise.
    #[getter]
    fn direction(&self) -> i32 {
        match self.inner.direction() {
            Direction::CounterClockwise => 1,
            Direction::Clockwise => -1,
        }
    }

    #[getter]
    fn phase(&self) -> f64 {
        self.inner.phase()
    }

    /// One lap [s].
    #[getter]
    fn period(&self) -> f64 {
        self.inner.period()
    }

    /// The reference at time t: dict of x, y, psi, v, omega, v_dot, omega_dot (SI).
    fn sample<'py>(&self, py: Python<'py>, t: f64) -> PyResult<Bound<'py, PyDict>> {
        sample_dict(py, &self.inner.sample(t))
    }

    /// Distance from (x, y) to the circle [m].
    fn distance(&self, x: f64, y: f64) -> f64 {
        self.inner.distance(x, y)
    }

    fn __repr__(&self) -> String {
        format!(
            "Circle(radius={:?}, speed={:?}, centre={:?}, direction={}, phase={:?})",
            self.radius(),
            self.speed(),
            self.centre(),
            self.direction(),
            self.phase()
        )
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
    #[pyo3(signature = (speed, heading = 0.0, start = (0.0, 0.0)))]
    fn new(speed: f64, heading: f64, start: (f64, f64)) -> CoreResult<Self> {
        Ok(Self { inner: Line::new([start.0, start.1], heading, speed)? })
    }

    #[getter]
    fn speed(&self) -> f64 {
        self.inner.speed()
    }

    #[getter]
    fn heading(&self) -> f64 {
        self.inner.heading()
    }

    #[getter]
    fn start(&self) -> (f64, f64) {
        let s = self.inner.start();
        (s[0], s[1])
    }

    fn sample<'py>(&self, py: Python<'py>, t: f64) -> PyResult<Bound<'py, PyDict>> {
        sample_dict(py, &self.inner.sample(t))
    }

    fn distance(&self, x: f64, y: f64) -> f64 {
        self.inner.distance(x, y)
    }

    fn __repr__(&self) -> String {
        format!("Line(speed={:?}, heading={:?}, start={:?})", self.speed(), self.heading(), self.start())
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
    #[pyo3(signature = (half_width, period, centre = (0.0, 0.0)))]
    fn new(half_width: f64, period: f64, centre: (f64, f64)) -> CoreResult<Self> {
        Ok(Self { inner: FigureEight::new([centre.0, centre.1], half_width, period)? })
    }

    #[getter]
    fn half_width(&self) -> f64 {
        self.inner.half_width()
    }

    #[getter]
    fn period(&self) -> f64 {
        self.inner.period()
    }

    #[getter]
    fn centre(&self) -> (f64, f64) {
        let c = self.inner.centre();
        (c[0], c[1])
    }

    fn sample<'py>(&self, py: Python<'py>, t: f64) -> PyResult<Bound<'py, PyDict>> {
        sample_dict(py, &self.inner.sample(t))
    }

    fn distance(&self, x: f64, y: f64) -> f64 {
        self.inner.distance(x, y)
    }

    fn __repr__(&self) -> String {
        format!("FigureEight(half_width={:?}, period={:?}, centre={:?})", self.half_width(), self.period(), self.centre())
    }
}

/// Straight legs through `points` (2 to 16 (x, y) pairs) at constant `speed`, inner corners
/// rounded by arcs of `corner_radius` (0: sharp). The reference stops at the last point.
#[pyclass(name = "Waypoints", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyWaypoints {
    pub inner: Waypoints<f64>,
}

#[pymethods]
impl PyWaypoints {
    #[new]
    #[pyo3(signature = (points, speed, corner_radius = 0.0))]
    fn new(points: Vec<(f64, f64)>, speed: f64, corner_radius: f64) -> CoreResult<Self> {
        let pts: Vec<[f64; 2]> = points.into_iter().map(|(x, y)| [x, y]).collect();
        Ok(Self { inner: Waypoints::new(&pts, speed, corner_radius)? })
    }

    #[getter]
    fn points(&self) -> Vec<(f64, f64)> {
        self.inner.points().iter().map(|p| (p[0], p[1])).collect()
    }

    #[getter]
    fn speed(&self) -> f64 {
        self.inner.speed()
    }

    #[getter]
    fn corner_radius(&self) -> f64 {
        self.inner.corner_radius()
    }

    /// Length of the rounded path [m].
    #[getter]
    fn length(&self) -> f64 {
        self.inner.length()
    }

    /// Time to reach the last point [s].
    #[getter]
    fn duration(&self) -> f64 {
        self.inner.duration()
    }

    fn sample<'py>(&self, py: Python<'py>, t: f64) -> PyResult<Bound<'py, PyDict>> {
        sample_dict(py, &self.inner.sample(t))
    }

    fn distance(&self, x: f64, y: f64) -> f64 {
        self.inner.distance(x, y)
    }

    fn __repr__(&self) -> String {
        format!("Waypoints({:?}, speed={:?}, corner_radius={:?})", self.points(), self.speed(), self.corner_radius())
    }
}

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
    fn new(resistance: f64, k_t: f64, gear_ratio: f64, friction: f64, supply: f64, pwm_max: f64) -> CoreResult<Self> {
        Ok(Self { inner: DcMotor::new(resistance, k_t, gear_ratio, friction, supply, pwm_max)? })
    }

    /// The thesis's GB37Y3530-12V-251R (Table 2.3) on a `supply` V battery (3 x 3.7 V).
    #[staticmethod]
    #[pyo3(signature = (supply = 11.1))]
    fn gb37y3530(supply: f64) -> CoreResult<Self> {
        Ok(Self { inner: DcMotor::gb37y3530().with_supply(supply)? })
    }

    /// R = V/I_stall, k_t = k_e = (V - I_0 R)/w_0, friction = k_t I_0/w_0 (at the motor shaft).
    #[staticmethod]
    #[pyo3(signature = (rated_voltage, no_load_rpm, no_load_current, stall_current, gear_ratio, supply = 11.1))]
    fn from_data_sheet(
        rated_voltage: f64,
        no_load_rpm: f64,
        no_load_current: f64,
        stall_current: f64,
        gear_ratio: f64,
        supply: f64,
    ) -> CoreResult<Self> {
        let sheet = DataSheet { rated_voltage, no_load_rpm, no_load_current, stall_current, gear_ratio };
        Ok(Self { inner: DcMotor::from_data_sheet(&sheet, supply)? })
    }

    #[getter]
    fn resistance(&self) -> f64 {
        self.inner.resistance()
    }

    #[getter]
    fn k_t(&self) -> f64 {
        self.inner.k_t()
    }

    #[getter]
    fn gear_ratio(&self) -> f64 {
        self.inner.gear_ratio()
    }

    /// Viscous friction at the motor shaft [N m s/rad].
    #[getter]
    fn friction(&self) -> f64 {
        self.inner.friction()
    }

    #[getter]
    fn supply(&self) -> f64 {
        self.inner.supply()
    }

    #[getter]
    fn pwm_max(&self) -> f64 {
        self.inner.pwm_max()
    }

    fn current(&self, voltage: f64, relative_speed: f64) -> f64 {
        self.inner.current(voltage, relative_speed)
    }

    /// Wheel torque [N m] at terminal `voltage` and relative wheel speed [rad/s].
    fn torque(&self, voltage: f64, relative_speed: f64) -> f64 {
        self.inner.torque(voltage, relative_speed)
    }

    fn voltage_for_torque(&self, torque: f64, relative_speed: f64) -> f64 {
        self.inner.voltage_for_torque(torque, relative_speed)
    }

    fn pwm_voltage(&self, pwm: f64) -> f64 {
        self.inner.pwm_voltage(pwm)
    }

    fn torque_from_pwm(&self, pwm: f64, relative_speed: f64) -> f64 {
        self.inner.torque_from_pwm(pwm, relative_speed)
    }

    /// (full reverse, full forward) torque at `relative_speed`.
    fn torque_limits(&self, relative_speed: f64) -> (f64, f64) {
        self.inner.torque_limits(relative_speed)
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

    fn __repr__(&self) -> String {
        let m = &self.inner;
        format!(
            "DcMotor(resistance={:?}, k_t={:?}, gear_ratio={:?}, friction={:?}, supply={:?}, pwm_max={:?})",
            m.resistance(),
            m.k_t(),
            m.gear_ratio(),
            m.friction(),
            m.supply(),
            m.pwm_max()
        )
    }
}

fn motor_or_default(motor: Option<&PyDcMotor>) -> DcMotor<f64> {
    motor.map(|m| m.inner).unwrap_or_else(DcMotor::gb37y3530)
}

// --- PID ---------------------------------------------------------------------------------------

const PID_GAINS: [&str; 7] = ["kp_pitch", "kd_pitch", "kp_speed", "ki_speed", "kp_yaw", "ki_yaw", "kd_yaw"];
const PID_UNITS: [&str; 4] = ["pitch", "speed", "heading", "integral_step"];

/// Reads `names` from a dict over `defaults`; unknown keys are an error.
fn fields<const N: usize>(what: &str, names: [&str; N], defaults: [f64; N], d: Option<&Bound<'_, PyDict>>) -> PyResult<[f64; N]> {
    let mut out = defaults;
    if let Some(d) = d {
        for (k, v) in d.iter() {
            let key: String = k.extract()?;
            let i = names.iter().position(|n| *n == key).ok_or_else(|| {
                InvalidParameterError::new_err(format!("unknown {what} '{key}'; expected: {}", names.join(", ")))
            })?;
            out[i] = v.extract::<f64>().map_err(|_| {
                InvalidParameterError::new_err(format!("{what} '{key}' must be a number, got {v}"))
            })?;
        }
    }
    Ok(out)
}

fn pid_gains_array(g: &PidGains<f64>) -> [f64; 7] {
    [g.kp_pitch, g.kd_pitch, g.kp_speed, g.ki_speed, g.kp_yaw, g.ki_yaw, g.kd_yaw]
}

/// The PID tracker (4.64-4.70) in the Arduino's units: outputs PWM counts, turned into
/// wheel torques by `motor` at the measured wheel speeds. `gains` (dict, over Table 4.1's)
/// and `units` ("arduino", "si" or a dict of pitch, speed, heading, integral_step).
#[pyclass(name = "PidTracker", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyPidTracker {
    pub inner: PidTracker<f64>,
}

#[pymethods]
impl PyPidTracker {
    #[new]
    #[pyo3(signature = (params, gains = None, units = None, motor = None, period = 0.005))]
    fn new(
        params: &PyRobotParams,
        gains: Option<&Bound<'_, PyDict>>,
        units: Option<&Bound<'_, PyAny>>,
        motor: Option<&PyDcMotor>,
        period: f64,
    ) -> PyResult<Self> {
        let g = fields("PID gain", PID_GAINS, pid_gains_array(&PidGains::table_4_1()), gains)?;
        let gains = PidGains { kp_pitch: g[0], kd_pitch: g[1], kp_speed: g[2], ki_speed: g[3], kp_yaw: g[4], ki_yaw: g[5], kd_yaw: g[6] };
        let arduino = PidUnits::arduino(params.inner.wheel_radius, period);
        let units = match units {
            None => arduino,
            Some(u) => {
                if let Ok(s) = u.extract::<String>() {
                    match s.as_str() {
                        "arduino" => arduino,
                        "si" => PidUnits::si(period),
                        other => {
                            return Err(InvalidParameterError::new_err(format!(
                                "units = '{other}': must be 'arduino', 'si' or a dict of {}",
                                PID_UNITS.join(", ")
                            )))
                        }
                    }
                } else {
                    let d = u.cast::<PyDict>().map_err(|_| {
                        InvalidParameterError::new_err("units must be 'arduino', 'si' or a dict")
                    })?;
                    let a = [arduino.pitch, arduino.speed, arduino.heading, arduino.integral_step];
                    let v = fields("PID unit", PID_UNITS, a, Some(d))?;
                    PidUnits { pitch: v[0], speed: v[1], heading: v[2], integral_step: v[3] }
                }
            }
        };
        let inner = PidTracker::new(gains, units, motor_or_default(motor), &params.inner, period).map_err(PyTwipError)?;
        Ok(Self { inner })
    }

    /// Table 4.1's gains as published, in twip's reading of the Arduino's units.
    #[staticmethod]
    #[pyo3(signature = (params = None, motor = None, period = 0.005))]
    fn table_4_1(params: Option<&PyRobotParams>, motor: Option<&PyDcMotor>, period: f64) -> CoreResult<Self> {
        let p = params.map(|p| p.inner).unwrap_or_else(twip_core::RobotParams::balanbot);
        Ok(Self { inner: PidTracker::table_4_1(&p, motor_or_default(motor), period)? })
    }

    #[getter]
    fn gains<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in PID_GAINS.iter().zip(pid_gains_array(&self.inner.gains())) {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    #[getter]
    fn units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let u = self.inner.units();
        let d = PyDict::new(py);
        for (k, v) in PID_UNITS.iter().zip([u.pitch, u.speed, u.heading, u.integral_step]) {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    #[getter]
    fn motor(&self) -> PyDcMotor {
        PyDcMotor { inner: *self.inner.motor() }
    }

    #[getter]
    fn period(&self) -> f64 {
        self.inner.period()
    }

    fn __repr__(&self) -> String {
        format!("PidTracker(gains={:?}, period={:?})", pid_gains_array(&self.inner.gains()), self.inner.period())
    }
}

// --- sliding mode --------------------------------------------------------------------------------

const SMC_GAINS: [&str; 12] =
    ["k1", "k2", "k3", "k_phi", "r1", "r2", "k_s3", "k_s4", "g_y4", "k_eta3", "k_eta4", "g_y3"];

fn smc_gains_array(g: &SmcGains<f64>) -> [f64; 12] {
    [g.k1, g.k2, g.k3, g.k_phi, g.r1, g.r2, g.k_s3, g.k_s4, g.g_y4, g.k_eta3, g.k_eta4, g.g_y3]
}

fn smc_gains_from(v: [f64; 12]) -> SmcGains<f64> {
    SmcGains {
        k1: v[0],
        k2: v[1],
        k3: v[2],
        k_phi: v[3],
        r1: v[4],
        r2: v[5],
        k_s3: v[6],
        k_s4: v[7],
        g_y4: v[8],
        k_eta3: v[9],
        k_eta4: v[10],
        g_y3: v[11],
    }
}

/// N m per unit of the published torque gains: "pwm" (one PWM count of `motor`), "si" or a number.
fn torque_unit(obj: &Bound<'_, PyAny>, motor: &DcMotor<f64>) -> PyResult<f64> {
    if let Ok(s) = obj.extract::<String>() {
        return match s.as_str() {
            "pwm" => Ok(motor.torque_per_count()),
            "si" => Ok(1.0),
            other => Err(InvalidParameterError::new_err(format!(
                "torque_unit = '{other}': must be 'pwm' (one PWM count of the motor), 'si' or a number [N m]"
            ))),
        };
    }
    let v: f64 = obj.extract().map_err(|_| InvalidParameterError::new_err("torque_unit must be 'pwm', 'si' or a number"))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(invalid("torque_unit", v, "must be finite and > 0").into());
    }
    Ok(v)
}

fn pair(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
    if let Ok(v) = obj.extract::<f64>() {
        return Ok((v, v));
    }
    obj.extract::<(f64, f64)>()
        .map_err(|_| InvalidParameterError::new_err(format!("{name} must be a number or a pair of numbers")))
}

/// The sliding-mode backstepping tracker (4.71-4.98) or, with `fuzzy=True`, its fuzzy
/// adaptive form (4.99-4.121). `gains` (dict, SI) override the published ones, whose
/// torque gains (k_s3, k_s4, g_y4) are read in `torque_unit`; `boundary_layer` is the
/// width of sat(S/w) for (S_eta, S1), one number for both, 0 for sgn; `pitch` is
/// "backward" (the reading under which the published r1, r2 work) or "forward".
#[pyclass(name = "SmcTracker", module = "twip", frozen)]
#[derive(Clone)]
pub struct PySmcTracker {
    pub inner: SmcTracker<f64>,
}

#[pymethods]
impl PySmcTracker {
    #[new]
    #[pyo3(signature = (
        model, fuzzy = false, boundary_layer = None, gains = None, torque_unit = None, pitch = "backward",
        guards = (0.05, 0.2), gamma = (0.05, 1000.0), leakage = 0.0, pitch_offset = true, motor = None,
        motor_limits = true, period = 0.005
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &PyPlanarModel,
        fuzzy: bool,
        boundary_layer: Option<&Bound<'_, PyAny>>,
        gains: Option<&Bound<'_, PyDict>>,
        torque_unit: Option<&Bound<'_, PyAny>>,
        pitch: &str,
        guards: (f64, f64),
        gamma: (f64, f64),
        leakage: f64,
        pitch_offset: bool,
        motor: Option<&PyDcMotor>,
        motor_limits: bool,
        period: f64,
    ) -> PyResult<Self> {
        let motor = motor_or_default(motor);
        let unit = match torque_unit {
            Some(u) => self::torque_unit(u, &motor)?,
            None => motor.torque_per_count(),
        };
        let g = fields("SMC gain", SMC_GAINS, smc_gains_array(&SmcGains::thesis(unit)), gains)?;
        let defaults = SmcOptions::<f64>::default();
        let (width_eta, width_s1) = match boundary_layer {
            Some(b) => pair("boundary_layer", b)?,
            None => (defaults.width_eta, defaults.width_s1),
        };
        let pitch = match pitch {
            "backward" => PitchSign::Backward,
            "forward" => PitchSign::Forward,
            other => {
                return Err(InvalidParameterError::new_err(format!(
                    "pitch = '{other}': must be 'backward' (pitch positive leaning backward) or 'forward'"
                )))
            }
        };
        let options = SmcOptions { pitch, width_eta, width_s1, guard_e3: guards.0, guard_d: guards.1, pitch_offset };
        let adaptation = fuzzy.then_some(Adaptation { gamma1: gamma.0, gamma2: gamma.1, leakage });
        let inner = SmcTracker::new(
            smc_gains_from(g),
            options,
            model.inner,
            motor_limits.then_some(motor),
            adaptation,
            period,
        )
        .map_err(PyTwipError)?;
        Ok(Self { inner })
    }

    /// The published gains (4.3.2) and twip's k1, k2, k3, k_phi, as a dict in SI with the
    /// torque gains read in `torque_unit` ("pwm": one PWM count of the GB37Y3530 at 11.1 V).
    #[staticmethod]
    #[pyo3(signature = (torque_unit = None))]
    fn thesis_gains<'py>(py: Python<'py>, torque_unit: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyDict>> {
        let motor = DcMotor::gb37y3530();
        let unit = match torque_unit {
            Some(u) => self::torque_unit(u, &motor)?,
            None => motor.torque_per_count(),
        };
        gains_dict(py, &SmcGains::thesis(unit))
    }

    #[getter]
    fn gains<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        gains_dict(py, &self.inner.gains())
    }

    #[getter]
    fn fuzzy(&self) -> bool {
        self.inner.adaptation().is_some()
    }

    /// (width of S_eta's layer, width of S1's); 0 is sgn.
    #[getter]
    fn boundary_layer(&self) -> (f64, f64) {
        let o = self.inner.options();
        (o.width_eta, o.width_s1)
    }

    #[getter]
    fn pitch(&self) -> &'static str {
        match self.inner.options().pitch {
            PitchSign::Backward => "backward",
            PitchSign::Forward => "forward",
        }
    }

    #[getter]
    fn period(&self) -> f64 {
        self.inner.period()
    }

    #[getter]
    fn model(&self) -> PyPlanarModel {
        PyPlanarModel { inner: *self.inner.model() }
    }

    /// The fuzzy weights (C1_hat, C2_hat) of a fresh tracker (zeros: they adapt during a run).
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>) {
        let (c1, c2) = self.inner.weights();
        (c1.to_vec().into_pyarray(py), c2.to_vec().into_pyarray(py))
    }

    /// (g21, g22, g23) of (4.72) for the controller's model at pitch phi.
    fn input_gains(&self, phi: f64) -> (f64, f64, f64) {
        self.inner.input_gains(phi)
    }

    /// r1 g21 + r2 g22 at pitch phi, r1 on the controller's pitch: (4.113) needs it < 0.
    fn surface_gain(&self, phi: f64) -> f64 {
        self.inner.surface_gain(phi)
    }

    /// The controller model's steady pitch driving at speed v [m/s] turning at omega [rad/s].
    fn steady_pitch(&self, v: f64, omega: f64) -> f64 {
        self.inner.steady_pitch(v, omega)
    }

    fn __repr__(&self) -> String {
        let (we, ws) = self.boundary_layer();
        format!(
            "SmcTracker(fuzzy={}, boundary_layer=({we:?}, {ws:?}), pitch='{}', period={:?})",
            if self.fuzzy() { "True" } else { "False" },
            self.pitch(),
            self.period()
        )
    }
}

fn gains_dict<'py>(py: Python<'py>, g: &SmcGains<f64>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in SMC_GAINS.iter().zip(smc_gains_array(g)) {
        d.set_item(k, v)?;
    }
    Ok(d)
}

// --- the planar runner -----------------------------------------------------------------------------

/// Every controller of the 3-DOF model, as `SlopeController` is for the 2-DOF one.
/// Unboxed on purpose: it is copied once per run and then updated in place.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum PlanarController {
    Pid(PidTracker<f64>),
    Smc(SmcTracker<f64>),
}

crate::dispatch::controller_enum!(PlanarController, 7, 2, PlanarRef<f64>, "3-DOF"; Pid(PyPidTracker), Smc(PySmcTracker));

/// When the "_settled" metrics start: `settle` [s], by default one lap of a closed path, else 0.
pub(crate) fn settle_time(settle: Option<f64>, path: &Trajectory<f64>) -> PyResult<f64> {
    let settle = settle.or_else(|| path.period()).unwrap_or(0.0);
    if !settle.is_finite() {
        return Err(invalid("settle", settle, "must be finite").into());
    }
    Ok(settle)
}

/// One 3-DOF run's settings, for any controller.
#[derive(Clone, Copy)]
struct PlanarRun {
    plant: twip_core::PlanarModel<f64>,
    path: Trajectory<f64>,
    settle: f64,
    x0: nalgebra::SVector<f64, 7>,
    config: SimConfig<f64>,
    record_every: usize,
    /// The robot's real parts (the 3-DOF rig), or the ideal loop.
    realism: Option<twip_core::hardware::realism::Realism<f64>>,
}

type PlanarOutput = (Outcome<f64>, usize, TrackingMetrics<f64, Trajectory<f64>>, TrajectoryLog<f64>);

impl PlanarRun {
    fn run<C>(&self, ctrl: &mut C, should_stop: impl FnMut() -> bool) -> Result<PlanarOutput, twip_core::TwipError>
    where
        C: Controller<f64, 7, 2, Reference = PlanarRef<f64>>,
    {
        let (n, _) = self.config.steps(ctrl.period())?;
        let extra = if self.realism.is_some() { PLANAR_RIG_SIGNALS.len() } else { 0 };
        let widths = [7, 2, <PlanarRef<f64> as LogRow<f64>>::NAMES.len(), ctrl.internal_names().len() + extra];
        let mut observers =
            (TrackingMetrics::new(self.path, self.settle), TrajectoryLog::with_capacity(n + 1, self.record_every, widths)?);
        let (outcome, steps) = match &self.realism {
            None => simulate_until(&self.plant, ctrl, &self.path, &self.x0, &self.config, &mut observers, should_stop)?,
            Some(r) => r.build_planar(&self.plant, self.config.dt)?.simulate(
                ctrl,
                &self.path,
                &self.x0,
                &self.config,
                &mut observers,
                should_stop,
            )?,
        };
        let (metrics, log) = observers;
        Ok((outcome, steps, metrics, log))
    }
}

/// Runs a tracker on the 3-DOF model; returns a dict that `twip.simulate` wraps into a
/// SimResult. `settle` [s] starts the "_settled" metrics (default: one lap of a circle or
/// figure-eight, else 0).
#[pyfunction]
#[pyo3(signature = (model, controller, x0, t_final, dt, reference, control_period = None, fall_limit = None, record_every = 1, settle = None, realism = None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate_planar_raw<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    controller: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    t_final: f64,
    dt: f64,
    reference: &Bound<'py, PyAny>,
    control_period: Option<f64>,
    fall_limit: Option<f64>,
    record_every: usize,
    settle: Option<f64>,
    realism: Option<&crate::realism::PyRealism>,
) -> PyResult<Bound<'py, PyDict>> {
    let plant = model
        .cast::<PyPlanarModel>()
        .map_err(|_| pyo3::exceptions::PyTypeError::new_err("this controller drives a twip.PlanarModel"))?
        .get()
        .inner;
    let realism = realism.map(|r| r.to_core(plant.params())).transpose().map_err(PyTwipError)?;
    // As in simulate_raw: an explicit control_period wins over the realism's loop period.
    let control_period = control_period.or(realism.and_then(|r| r.control_period));
    let path = trajectory(reference)?;
    let settle = settle_time(settle, &path)?;
    let x0 = vector::<7>("x0", x0)?;
    let config = SimConfig::new(dt, t_final, fall_limit);
    if record_every == 0 {
        return Err(invalid("record_every", 0.0, "must be >= 1").into());
    }
    let run = PlanarRun { plant, path, settle, x0, config, record_every, realism };
    let (names, (outcome, steps, metrics, log)) =
        if is_user_controller(controller) && PlanarController::extract(controller).is_err() {
            // A Python controller keeps the GIL: it is called back at every update.
            let mut ctrl = UserController::<PlanarRef<f64>, 7, 2>::new(controller, control_period, dt, "PlanarModel")?;
            let failed = ctrl.failed.clone();
            let mut interrupt = None;
            let out = run.run(&mut ctrl, || failed.get() || crate::interrupt::requested(&mut interrupt));
            if let Some(err) = ctrl.take_error().or(interrupt) {
                return Err(err);
            }
            (ctrl.internal_names(), out.map_err(PyTwipError)?)
        } else {
            let mut ctrl = PlanarController::extract(controller)?;
            if let Some(p) = control_period {
                ctrl = ctrl.with_period(p)?;
            }
            let (out, interrupt) = py.detach(move || {
                let mut interrupt = None;
                let out = run.run(&mut ctrl, || crate::interrupt::requested(&mut interrupt));
                (out, interrupt)
            });
            if let Some(err) = interrupt {
                return Err(err);
            }
            (ctrl.internal_names(), out.map_err(PyTwipError)?)
        };
    let ref_names = <PlanarRef<f64> as LogRow<f64>>::NAMES;
    let extra = if realism.is_some() { PLANAR_RIG_SIGNALS.len() } else { 0 };
    let widths = [7, 2, ref_names.len(), names.len() + extra];
    let summary = metrics.summary();
    let out = PyDict::new(py);
    let rows = log.len();
    let reshape = |v: Vec<f64>, cols: usize| -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(numpy::ndarray::Array2::from_shape_vec((rows, cols), v)
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?
            .into_pyarray(py))
    };
    out.set_item("t", log.t.into_pyarray(py))?;
    out.set_item("states", reshape(log.x, 7)?)?;
    out.set_item("inputs", reshape(log.u, 2)?)?;
    out.set_item("references", reshape(log.reference, widths[2])?)?;
    out.set_item("reference_names", ref_names.to_vec())?;
    crate::simulate::set_internals_and_signals(&out, log.internals, rows, names, extra > 0, &PLANAR_RIG_SIGNALS)?;
    let (name, t_end) = match outcome {
        Outcome::Completed => ("completed", None),
        Outcome::Fell { t } => ("fell", Some(t)),
        Outcome::Diverged { t } => ("diverged", Some(t)),
        Outcome::Interrupted { t } => ("interrupted", Some(t)),
    };
    out.set_item("outcome", name)?;
    out.set_item("t_end", t_end)?;
    out.set_item("steps", steps)?;
    let m = PyDict::new(py);
    m.set_item("mean_abs_x_error", summary.mean_abs_x_error)?;
    m.set_item("mean_abs_y_error", summary.mean_abs_y_error)?;
    m.set_item("mean_abs_x_error_settled", summary.mean_abs_x_error_settled)?;
    m.set_item("mean_abs_y_error_settled", summary.mean_abs_y_error_settled)?;
    m.set_item("max_path_error_settled", summary.max_path_error_settled)?;
    m.set_item("mean_abs_pitch", summary.mean_abs_pitch)?;
    m.set_item("peak_abs_torque", summary.peak_abs_torque)?;
    let peaks = DrivePeaks::from_wheel_torque(plant.params(), summary.peak_abs_torque);
    m.set_item("peak_current", peaks.current)?;
    m.set_item("peak_torque", peaks.torque)?;
    m.set_item("settle", settle)?;
    out.set_item("metrics", m)?;
    Ok(out)
}
