//! `twip.Realism` and its parts: `Imu`, `Dlpf`, `TiltEstimator`, `MotorDriver`, `Push`,
//! `Force`. Each is a frozen, validated settings object; `Realism.to_core` turns them into
//! the core's `Realism` for one robot (heights left out default to its centre of mass).
use crate::model::friction::PyFriction;
use numpy::ndarray::s;
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use twip_core::hardware::backlash::Backlash;
use twip_core::hardware::disturbance::{Force, Push, Pushes, SlopeProfile};
use twip_core::hardware::driver::{MotorDriver, PwmActuator};
use twip_core::hardware::imu::{dlpf_config, Channel, Dlpf, ImuSettings, DLPF_TABLE, STANDARD_GRAVITY};
use twip_core::hardware::realism::Realism;
use twip_core::hardware::tilt::{accel_tilt, TiltEstimator, TiltFilter};
use twip_core::{RobotParams, TwipError};

use crate::convert::{ints, real, scalar, series, Int, Real};
use crate::errors::{key, naming_argument, positive_param, CoreResult, InvalidParameterError, PyTwipError};
use crate::model::params::PyRobotParams;
use crate::settings::Reduced;

const DEG: f64 = std::f64::consts::PI / 180.0;

fn positive_rate(name: &'static str, rate: f64) -> CoreResult<f64> {
    Ok(1.0 / positive_param(name, rate)?)
}

// --- IMU ------------------------------------------------------------------------------

/// The MPU-6050 of the Balance Shield: DLPF (Table 2.2), noise, bias, ranges, LSB.
/// SI units; the ranges as the data sheet's settings (deg/s, g). Defaults: the data
/// sheet's noise densities, no bias, DLPF 44/42 Hz, +-250 deg/s, +-2 g, 1 kHz.
#[pyclass(name = "Imu", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyImu {
    pub inner: ImuSettings<f64>,
    /// As given (the settings hold the row, rad/s and m/s²).
    dlpf_hz: f64,
    gyro_range_dps: f64,
    accel_range_g: f64,
}

/// The core's error on a field it holds in SI, named and valued as the caller gave it
/// (gyro_range = 5.236 rad/s was the 300 deg/s given as gyro_range_dps).
fn in_given_units(e: TwipError, sample_rate: f64, gyro_range_dps: f64, accel_range_g: f64) -> TwipError {
    match e {
        TwipError::InvalidParameter { name: "sample_period", reason, .. } => {
            TwipError::InvalidParameter { name: "sample_rate", value: sample_rate, reason }
        }
        TwipError::InvalidParameter { name: "gyro_range", reason, .. } => {
            TwipError::InvalidParameter { name: "gyro_range_dps", value: gyro_range_dps, reason }
        }
        TwipError::InvalidParameter { name: "accel_range", reason, .. } => {
            TwipError::InvalidParameter { name: "accel_range_g", value: accel_range_g, reason }
        }
        e => e,
    }
}

#[pymethods]
impl PyImu {
    #[new]
    #[pyo3(signature = (*, dlpf_hz = 42.0, height = 0.12, gyro_noise = Real(0.005 * DEG), accel_noise = Real(400e-6 * STANDARD_GRAVITY),
                        gyro_bias = 0.0, gyro_bias_walk = 0.0, accel_bias = (Real(0.0), Real(0.0)), gyro_range_dps = 250.0,
                        accel_range_g = 2.0, quantise = true, sample_rate = 1000.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        #[pyo3(from_py_with = real)] dlpf_hz: f64,
        #[pyo3(from_py_with = real)] height: f64,
        gyro_noise: Real,
        accel_noise: Real,
        #[pyo3(from_py_with = real)] gyro_bias: f64,
        #[pyo3(from_py_with = real)] gyro_bias_walk: f64,
        accel_bias: (Real, Real),
        #[pyo3(from_py_with = real)] gyro_range_dps: f64,
        #[pyo3(from_py_with = real)] accel_range_g: f64,
        quantise: bool,
        #[pyo3(from_py_with = real)] sample_rate: f64,
    ) -> CoreResult<Self> {
        let (Real(accel_bias_x), Real(accel_bias_z)) = accel_bias;
        let inner = ImuSettings {
            dlpf: dlpf_config(dlpf_hz)?,
            sample_period: positive_rate("sample_rate", sample_rate)?,
            height,
            gyro_noise: gyro_noise.0,
            accel_noise: accel_noise.0,
            gyro_bias,
            gyro_bias_walk,
            accel_bias: [accel_bias_x, accel_bias_z],
            gyro_range: gyro_range_dps * DEG,
            accel_range: accel_range_g * STANDARD_GRAVITY,
            quantise,
        }
        .validate()
        .map_err(|e| in_given_units(e, sample_rate, gyro_range_dps, accel_range_g))?;
        Ok(Self { inner, dlpf_hz, gyro_range_dps, accel_range_g })
    }

    /// The data sheet's sensor (the defaults).
    #[staticmethod]
    fn data_sheet() -> Self {
        Self { inner: ImuSettings::data_sheet(), dlpf_hz: 42.0, gyro_range_dps: 250.0, accel_range_g: 2.0 }
    }

    /// The data sheet's sensor with the residual errors of a start-up calibration:
    /// gyro bias 0.1 deg/s drifting 0.005 deg/s/sqrt(s), accelerometer x bias 5 mg.
    #[staticmethod]
    fn thesis_like() -> Self {
        Self { inner: ImuSettings::thesis_like(), dlpf_hz: 42.0, gyro_range_dps: 250.0, accel_range_g: 2.0 }
    }

    /// The filter of one sensor ("accel" or "gyro") as set up here.
    #[pyo3(signature = (sensor = "gyro"))]
    fn dlpf(&self, sensor: &str) -> PyResult<PyDlpf> {
        PyDlpf::mpu6050(self.dlpf_hz, sensor, 1.0 / self.inner.sample_period)
    }

}

crate::settings::settings_class!(PyImu, "Imu",
    settings {
        dlpf_hz: f64 = |s| s.dlpf_hz;
        height: f64 = |s| s.inner.height;
        gyro_noise: f64 = |s| s.inner.gyro_noise;
        accel_noise: f64 = |s| s.inner.accel_noise;
        gyro_bias: f64 = |s| s.inner.gyro_bias;
        gyro_bias_walk: f64 = |s| s.inner.gyro_bias_walk;
        accel_bias: (f64, f64) = |s| (s.inner.accel_bias[0], s.inner.accel_bias[1]);
        gyro_range_dps: f64 = |s| s.gyro_range_dps;
        accel_range_g: f64 = |s| s.accel_range_g;
        quantise: bool = |s| s.inner.quantise;
        sample_rate: f64 = |s| 1.0 / s.inner.sample_period;
    }
    derived {
        /// DLPF_CFG, the row of Table 2.2.
        dlpf_cfg: usize = |s| s.inner.dlpf;
    }
);

// --- DLPF ------------------------------------------------------------------------------

/// A Table 2.2 low-pass: a second-order section solved from (bandwidth, delay), plus a
/// pure delay where the section cannot reach the delay (see docs/parameters.md).
#[pyclass(name = "Dlpf", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyDlpf {
    inner: Dlpf<f64>,
    bandwidth: f64,
    delay: f64,
    sample_rate: f64,
}

#[pymethods]
impl PyDlpf {
    /// The filter with -3 dB `bandwidth_hz` and DC delay `delay` [s] at `sample_rate` [Hz].
    #[new]
    #[pyo3(signature = (bandwidth_hz, delay, sample_rate = 1000.0))]
    fn new(bandwidth_hz: Real, delay: Real, #[pyo3(from_py_with = real)] sample_rate: f64) -> CoreResult<Self> {
        let (bandwidth_hz, delay) = (bandwidth_hz.0, delay.0);
        let inner = Dlpf::new(bandwidth_hz, delay, positive_rate("sample_rate", sample_rate)?)?;
        Ok(Self { inner, bandwidth: bandwidth_hz, delay, sample_rate })
    }

    /// The MPU-6050's filter for the row whose bandwidth is `dlpf_hz`, for the "accel"
    /// or "gyro" column.
    #[staticmethod]
    #[pyo3(signature = (dlpf_hz, sensor = "gyro", sample_rate = 1000.0))]
    fn mpu6050(#[pyo3(from_py_with = real)] dlpf_hz: f64, sensor: &str, #[pyo3(from_py_with = real)] sample_rate: f64) -> PyResult<Self> {
        let cfg = dlpf_config(dlpf_hz).map_err(PyTwipError)?;
        let row = DLPF_TABLE[cfg];
        let (channel, bandwidth, delay) = match sensor {
            "accel" => (Channel::Accel, row.accel_hz, row.accel_delay),
            "gyro" => (Channel::Gyro, row.gyro_hz, row.gyro_delay),
            other => {
                return Err(InvalidParameterError::new_err(format!("sensor = '{other}': must be 'accel' or 'gyro'")));
            }
        };
        let inner = Dlpf::mpu6050(cfg, channel, positive_rate("sample_rate", sample_rate)?).map_err(PyTwipError)?;
        Ok(Self { inner, bandwidth, delay, sample_rate })
    }

    /// Table 2.2 as (accel_hz, accel_delay [s], gyro_hz, gyro_delay [s]) per DLPF_CFG.
    #[staticmethod]
    fn table() -> Vec<(f64, f64, f64, f64)> {
        DLPF_TABLE.iter().map(|r| (r.accel_hz, r.accel_delay, r.gyro_hz, r.gyro_delay)).collect()
    }

    /// Filters `x` (samples at the sample rate), starting in the steady state of x[0]. With
    /// `segments` (each segment's first sample: 0 first, increasing), each segment is
    /// filtered on its own, from the steady state of its own first sample.
    #[pyo3(signature = (x, segments = None))]
    fn filter<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>, segments: Option<Vec<Int<i64>>>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let x = series("x", x)?;
        let x = x.as_array();
        let starts = segment_starts(segments.map_or_else(|| vec![0], ints), x.len())?;
        let mut out = Vec::with_capacity(x.len());
        for (k, &start) in starts.iter().enumerate() {
            let end = starts.get(k + 1).copied().unwrap_or(x.len());
            let mut f = self.inner;
            f.prime(x.get(start).copied().unwrap_or(0.0));
            out.extend(x.slice(s![start..end]).iter().map(|v| f.filter(*v)));
        }
        Ok(out.into_pyarray(py))
    }

}

/// Segments' first samples in a series of `len`: 0 first, increasing, each inside it.
fn segment_starts(starts: Vec<i64>, len: usize) -> PyResult<Vec<usize>> {
    let refuse = |what: String| InvalidParameterError::new_err(format!("segments: {what}; give each segment's first sample, 0 first, increasing"));
    match starts.first() {
        None => return Err(refuse("none given".into())),
        Some(&first) if first != 0 => return Err(refuse(format!("the first is {first}, not 0"))),
        _ => {}
    }
    for (i, w) in starts.windows(2).enumerate() {
        if w[1] <= w[0] || w[1] as u64 >= len as u64 {
            return Err(refuse(format!("segments[{}] = {} after {} in a series of {len} samples", i + 1, w[1], w[0])));
        }
    }
    Ok(starts.into_iter().map(|s| s as usize).collect())
}

crate::settings::settings_class!(PyDlpf, "Dlpf",
    settings {
        bandwidth_hz: f64 = |s| s.bandwidth;
        delay: f64 = |s| s.delay;
        sample_rate: f64 = |s| s.sample_rate;
    }
    derived {
        /// Damping of the second-order section.
        zeta: f64 = |s| s.inner.zeta();
        /// Natural frequency of the (analogue) section [rad/s].
        natural_frequency: f64 = |s| s.inner.natural_frequency();
        /// The pure delay after the section [s].
        pure_delay: f64 = |s| s.inner.pure_delay();
    }
);

// --- tilt estimator ---------------------------------------------------------------------

/// How the firmware estimates the pitch from the IMU: `complementary(time_constant)` or
/// `kalman(q_angle, q_bias, r_angle)` (angle and gyro bias).
#[pyclass(name = "TiltEstimator", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyTiltEstimator {
    pub inner: TiltEstimator<f64>,
}

#[pymethods]
impl PyTiltEstimator {
    /// phi <- a (phi + T omega) + (1 - a) phi_acc, a = tau / (tau + T); tau [s].
    #[staticmethod]
    #[pyo3(signature = (time_constant = 1.0))]
    fn complementary(#[pyo3(from_py_with = real)] time_constant: f64) -> CoreResult<Self> {
        Ok(Self { inner: TiltEstimator::Complementary { time_constant }.validate()? })
    }

    /// Kalman filter on (angle, gyro bias): q_angle [rad^2/s], q_bias [rad^2/s^3],
    /// r_angle [rad^2] (the accelerometer tilt's variance while driving).
    #[staticmethod]
    #[pyo3(signature = (q_angle = 1e-3, q_bias = 1e-6, r_angle = 0.2))]
    fn kalman(
        #[pyo3(from_py_with = real)] q_angle: f64,
        #[pyo3(from_py_with = real)] q_bias: f64,
        #[pyo3(from_py_with = real)] r_angle: f64,
    ) -> CoreResult<Self> {
        Ok(Self { inner: TiltEstimator::Kalman { q_angle, q_bias, r_angle }.validate()? })
    }

    /// "complementary" or "kalman".
    #[getter]
    fn kind(&self) -> &'static str {
        match self.inner {
            TiltEstimator::Complementary { .. } => "complementary",
            TiltEstimator::Kalman { .. } => "kalman",
        }
    }

    /// The tuning as a dict.
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match self.inner {
            TiltEstimator::Complementary { time_constant } => d.set_item("time_constant", time_constant)?,
            TiltEstimator::Kalman { q_angle, q_bias, r_angle } => {
                d.set_item("q_angle", q_angle)?;
                d.set_item("q_bias", q_bias)?;
                d.set_item("r_angle", r_angle)?;
            }
        }
        Ok(d)
    }

    /// Pickled as TiltEstimator.complementary(...) or .kalman(...) with its parameters.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Reduced<'py, Bound<'py, PyTuple>>> {
        let me = slf.get();
        let ctor = slf.get_type().getattr(me.kind())?;
        Ok((ctor, me.parameters(slf.py())?.values().to_tuple()))
    }

    /// Runs the estimator over IMU readings taken every `dt` [s]: specific force along
    /// the sensor's x and z [m/s^2] and pitch rate [rad/s]. Returns (phi_hat, phi_dot_hat).
    #[allow(clippy::type_complexity)]
    fn filter<'py>(
        &self,
        py: Python<'py>,
        accel_x: &Bound<'py, PyAny>,
        accel_z: &Bound<'py, PyAny>,
        gyro: &Bound<'py, PyAny>,
        dt: Real,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>)> {
        let dt = dt.0;
        let (accel_x, accel_z, gyro) = (series("accel_x", accel_x)?, series("accel_z", accel_z)?, series("gyro", gyro)?);
        let (ax, az, g) = (accel_x.as_array(), accel_z.as_array(), gyro.as_array());
        if ax.len() != az.len() || ax.len() != g.len() {
            let got = (az.len().min(g.len()), 1);
            return Err(PyTwipError(TwipError::Shape { name: "accel_z, gyro", expected: (ax.len(), 1), got }).into());
        }
        positive_param("dt", dt)?;
        let mut f = TiltFilter::new(self.inner).map_err(PyTwipError)?;
        let (mut phi, mut rate) = (Vec::with_capacity(ax.len()), Vec::with_capacity(ax.len()));
        for k in 0..ax.len() {
            let (p, r) = f.update(accel_tilt(ax[k], az[k]), g[k], if k == 0 { 0.0 } else { dt });
            // The readings are finite (checked): a non-finite estimate is dt's (1e160 s
            // overflowed the Kalman filter's covariance), not a result to hand back.
            if !(p.is_finite() && r.is_finite()) {
                return Err(PyTwipError(TwipError::InvalidParameter { name: "dt", value: dt, reason: "overflows the estimator's state: its estimate is not finite" }).into());
            }
            phi.push(p);
            rate.push(r);
        }
        Ok((phi.into_pyarray(py), rate.into_pyarray(py)))
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!("TiltEstimator.{}({})", self.kind(), crate::settings::kwargs_repr(&self.parameters(py)?)?))
    }
}

fn estimator_from(obj: &Bound<'_, PyAny>) -> PyResult<TiltEstimator<f64>> {
    if let Ok(e) = obj.cast::<PyTiltEstimator>() {
        return Ok(e.get().inner);
    }
    match obj.extract::<String>().as_deref() {
        Ok("complementary") => Ok(TiltEstimator::complementary()),
        Ok("kalman") => Ok(TiltEstimator::kalman()),
        _ => Err(InvalidParameterError::new_err(format!(
            "estimator = {}: must be 'complementary', 'kalman' or a twip.TiltEstimator",
            obj.repr()?
        ))),
    }
}

// --- motor driver -----------------------------------------------------------------------

/// Battery, L298P bridge and the two GB37Y3530 motors (per motor). Defaults: the data
/// sheet's motor (R = 12 V / 7 A) on 3 x 3.7 V, no bridge drop, no inductance, a lossless
/// gearbox and no current limit; `assumed_battery` (default: `battery`) is what the
/// firmware's feed-forward believes.
#[pyclass(name = "MotorDriver", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyMotorDriver {
    pub inner: MotorDriver<f64>,
}

fn params_or_default(params: Option<&PyRobotParams>) -> RobotParams<f64> {
    params.map_or_else(RobotParams::balanbot, |p| p.inner)
}

#[pymethods]
impl PyMotorDriver {
    #[new]
    #[pyo3(signature = (*, battery = 11.1, bridge_drop = 0.0, resistance = Real(12.0 / 7.0), inductance = 0.0, efficiency = 1.0,
                        current_limit = None, assumed_battery = None))]
    fn new(
        #[pyo3(from_py_with = real)] battery: f64,
        #[pyo3(from_py_with = real)] bridge_drop: f64,
        resistance: Real,
        #[pyo3(from_py_with = real)] inductance: f64,
        #[pyo3(from_py_with = real)] efficiency: f64,
        current_limit: Option<Real>,
        assumed_battery: Option<Real>,
    ) -> CoreResult<Self> {
        let inner = MotorDriver {
            battery,
            bridge_drop,
            resistance: resistance.0,
            inductance,
            efficiency,
            current_limit: current_limit.map_or(f64::INFINITY, |c| c.0),
            assumed_battery: assumed_battery.map_or(battery, |b| b.0),
        };
        Ok(Self { inner: inner.validate()? })
    }

    /// The defaults: the data sheet's motor on the 11.1 V battery, nothing else.
    #[staticmethod]
    fn data_sheet() -> Self {
        Self { inner: MotorDriver::gb37y3530() }
    }

    /// The L298P's 2 V drop and 2 A DC rating, an assumed 1 mH winding, and the GB37
    /// gearbox's efficiency from its data sheet (docs/parameters.md).
    #[staticmethod]
    fn thesis_like() -> Self {
        Self { inner: MotorDriver::thesis_like() }
    }

    /// Steady winding current of one motor [A] at terminal `voltage` and relative wheel
    /// speed theta_dot - phi_dot [rad/s] (the robot's torque constant and gear ratio).
    #[pyo3(signature = (voltage, wheel_speed, params = None))]
    fn current(&self, voltage: Real, wheel_speed: Real, params: Option<&PyRobotParams>) -> CoreResult<f64> {
        let (voltage, wheel_speed) = (scalar("voltage", voltage.0)?, scalar("wheel_speed", wheel_speed.0)?);
        Ok(self.inner.current(&params_or_default(params), voltage, wheel_speed)?)
    }

    /// Torque of one motor on its wheel [N m] at `voltage` and relative wheel speed.
    #[pyo3(signature = (voltage, wheel_speed, params = None))]
    fn wheel_torque(&self, voltage: Real, wheel_speed: Real, params: Option<&PyRobotParams>) -> CoreResult<f64> {
        let (voltage, wheel_speed) = (scalar("voltage", voltage.0)?, scalar("wheel_speed", wheel_speed.0)?);
        Ok(self.inner.wheel_torque(&params_or_default(params), voltage, wheel_speed)?)
    }

    /// The firmware's duty [counts] for a lumped (both motors) current at a measured
    /// relative wheel speed: R i + back-EMF, rounded and saturated at +-255.
    #[pyo3(signature = (lumped_current, wheel_speed, params = None))]
    fn duty(&self, lumped_current: Real, wheel_speed: Real, params: Option<&PyRobotParams>) -> CoreResult<f64> {
        let (lumped_current, wheel_speed) = (scalar("lumped_current", lumped_current.0)?, scalar("wheel_speed", wheel_speed.0)?);
        Ok(PwmActuator::new(&self.inner, &params_or_default(params))?.duty(lumped_current, wheel_speed))
    }

}

crate::settings::settings_class!(PyMotorDriver, "MotorDriver",
    settings {
        battery: f64 = |s| s.inner.battery;
        bridge_drop: f64 = |s| s.inner.bridge_drop;
        resistance: f64 = |s| s.inner.resistance;
        inductance: f64 = |s| s.inner.inductance;
        efficiency: f64 = |s| s.inner.efficiency;
        current_limit: Option<f64> = |s| s.inner.current_limit.is_finite().then_some(s.inner.current_limit);
        assumed_battery: f64 = |s| s.inner.assumed_battery;
    }
);

// --- disturbances -----------------------------------------------------------------------

/// A horizontal push on the body: `impulse` [N s] (positive forward) at time `t` [s],
/// `height` [m] up the body's axis from the axle (default: the centre of mass).
#[pyclass(name = "Push", module = "twip", frozen)]
#[derive(Clone, Copy)]
pub struct PyPush {
    t: f64,
    impulse: f64,
    height: Option<f64>,
}

#[pymethods]
impl PyPush {
    #[new]
    #[pyo3(signature = (t, impulse, height = None))]
    fn new(t: Real, impulse: Real, height: Option<Real>) -> CoreResult<Self> {
        let (t, impulse, height) = (t.0, impulse.0, height.map(|h| h.0));
        Pushes::new(&[Push { t, impulse, height: height.unwrap_or(0.0) }])?;
        Ok(Self { t, impulse, height })
    }

}

crate::settings::settings_class!(PyPush, "Push",
    settings {
        t: f64 = |s| s.t;
        impulse: f64 = |s| s.impulse;
        height: Option<f64> = |s| s.height;
    }
);

/// A constant force on the body [N]: `horizontal` (positive forward), `vertical`
/// (positive up), at `height` [m] up the body's axis (default: the centre of mass).
#[pyclass(name = "Force", module = "twip", frozen)]
#[derive(Clone, Copy)]
pub struct PyForce {
    horizontal: f64,
    vertical: f64,
    height: Option<f64>,
}

#[pymethods]
impl PyForce {
    #[new]
    #[pyo3(signature = (horizontal = 0.0, vertical = 0.0, height = None))]
    fn new(
        #[pyo3(from_py_with = real)] horizontal: f64,
        #[pyo3(from_py_with = real)] vertical: f64,
        height: Option<Real>,
    ) -> CoreResult<Self> {
        let height = height.map(|h| h.0);
        Force { horizontal, vertical, height: height.unwrap_or(0.0) }.validate()?;
        Ok(Self { horizontal, vertical, height })
    }

}

crate::settings::settings_class!(PyForce, "Force",
    settings {
        horizontal: f64 = |s| s.horizontal;
        vertical: f64 = |s| s.vertical;
        height: Option<f64> = |s| s.height;
    }
);

fn push(obj: &Bound<'_, PyAny>) -> PyResult<PyPush> {
    if let Ok(p) = obj.cast::<PyPush>() {
        return Ok(*p.get());
    }
    if let Ok((t, impulse)) = obj.extract::<(Real, Real)>() {
        return Ok(PyPush::new(t, impulse, None)?);
    }
    if let Ok((t, impulse, height)) = obj.extract::<(Real, Real, Real)>() {
        return Ok(PyPush::new(t, impulse, Some(height))?);
    }
    Err(InvalidParameterError::new_err(format!(
        "pushes: each must be a twip.Push or a (t, impulse[, height]) tuple, got {}",
        obj.repr()?
    )))
}

// --- realism ----------------------------------------------------------------------------

/// Which real parts of the robot are in the loop, for `twip.simulate(..., realism=...)`.
/// Every part is optional; `Realism()` is the ideal loop.
///
/// - `imu`: a `twip.Imu` (the MPU-6050) read through `estimator` ("complementary",
///   "kalman" or a `twip.TiltEstimator`) for phi and phi_dot; None: the true ones.
/// - `encoder_cpr`: encoder counts per wheel turn (700; 2797 with 4x decoding) for theta
///   and theta_dot; None: the true ones.
/// - `motor`: a `twip.MotorDriver`; the controller's current becomes a PWM duty. None:
///   the plant gets the current.
/// - `delay`: apply each command one control period late.
/// - `control_period`: the firmware's loop period [s] (None: the controller's own;
///   `simulate(control_period=...)` wins over it).
/// - `pushes`: `twip.Push` or (t, impulse[, height]) tuples; `force`: a `twip.Force`;
///   `slope_profile`: (distance [m], slope [rad]) changes along the path.
/// - `friction`: a `twip.Friction` per wheel on the plant (None: the model's own);
///   `backlash`: each gear train's free play at the wheel [rad] (None: none).
/// - `settle`: seconds the robot stands still at its initial pitch before the run while
///   the firmware's loop reads the IMU through the estimator (None or 0: the estimator
///   starts at the run's first read, while the robot free-rolls).
/// - `seed`, `stream`: the noise's key (its SFC64 stream); a run is bitwise repeatable.
#[pyclass(name = "Realism", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyRealism {
    imu: Option<PyImu>,
    estimator: TiltEstimator<f64>,
    encoder_cpr: Option<f64>,
    motor: Option<MotorDriver<f64>>,
    delay: bool,
    control_period: Option<f64>,
    pushes: Vec<PyPush>,
    force: Option<PyForce>,
    slope_profile: Vec<(f64, f64)>,
    friction: Option<PyFriction>,
    backlash: Option<f64>,
    settle: Option<f64>,
    seed: u64,
    stream: u64,
}

#[pymethods]
impl PyRealism {
    #[new]
    #[pyo3(signature = (*, imu = None, estimator = None, encoder_cpr = None, motor = None, delay = false, control_period = None,
                        pushes = None, force = None, slope_profile = None, friction = None, backlash = None, seed = None,
                        stream = None, settle = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        imu: Option<&PyImu>,
        estimator: Option<&Bound<'_, PyAny>>,
        encoder_cpr: Option<Real>,
        motor: Option<&PyMotorDriver>,
        delay: bool,
        control_period: Option<Real>,
        pushes: Option<&Bound<'_, PyAny>>,
        force: Option<&PyForce>,
        slope_profile: Option<Vec<(Real, Real)>>,
        friction: Option<&PyFriction>,
        backlash: Option<Real>,
        seed: Option<&Bound<'_, PyAny>>,
        stream: Option<&Bound<'_, PyAny>>,
        settle: Option<Real>,
    ) -> PyResult<Self> {
        let value = |x: Option<Real>| x.map(|r| r.0);
        let slope_profile: Option<Vec<(f64, f64)>> = slope_profile.map(|p| p.into_iter().map(|(Real(d), Real(s))| (d, s)).collect());
        let mut list = Vec::new();
        if let Some(ps) = pushes {
            for p in ps.try_iter()? {
                list.push(push(&p?)?);
            }
        }
        let r = Self {
            imu: imu.cloned(),
            estimator: estimator.map(estimator_from).transpose()?.unwrap_or_else(TiltEstimator::complementary),
            encoder_cpr: value(encoder_cpr),
            motor: motor.map(|m| m.inner),
            delay,
            control_period: value(control_period),
            pushes: list,
            force: force.copied(),
            slope_profile: slope_profile.unwrap_or_default(),
            friction: friction.copied(),
            backlash: value(backlash),
            settle: value(settle),
            seed: seed.map(|s| key("seed", s)).transpose()?.unwrap_or(0),
            stream: stream.map(|s| key("stream", s)).transpose()?.unwrap_or(0),
        };
        // Everything but the robot-dependent heights is checked now.
        r.to_core(&RobotParams::balanbot()).map_err(PyTwipError)?;
        Ok(r)
    }

    /// Every part ideal (the same run as without realism, through the realism runner).
    #[staticmethod]
    fn ideal() -> PyResult<Self> {
        Self::new(None, None, None, None, false, None, None, None, None, None, None, None, None, None)
    }

    /// The thesis's robot as built: a 5 ms loop applying its command one period late,
    /// the MPU-6050 at DLPF 42 Hz with data-sheet noise and calibrated residual biases, a
    /// complementary filter, 700 CPR encoders, the L298P on 11.1 V, and the GB37 gearheads:
    /// their friction (the no-load torque split beside the Balanbot's viscous bearing, with
    /// a stick band; `replace(friction=None)` leaves the model's own) and 1 degree of
    /// backlash (`replace(backlash=None)`: none). The estimator settles for 2 s at rest
    /// before the motors run (`replace(settle=None)`: it starts at the run's first read).
    /// docs/parameters.md.
    #[staticmethod]
    // Keys are read by `key` (a bad one is named); the defaults are 0.
    #[pyo3(signature = (*, seed = None, stream = None), text_signature = "(*, seed=0, stream=0)")]
    fn thesis_like(seed: Option<&Bound<'_, PyAny>>, stream: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let core = Realism::<f64>::thesis_like();
        let seed = seed.map(|s| key("seed", s)).transpose()?.unwrap_or(0);
        let stream = stream.map(|s| key("stream", s)).transpose()?.unwrap_or(0);
        Ok(Self {
            imu: Some(PyImu::thesis_like()),
            estimator: core.estimator,
            encoder_cpr: core.encoder_cpr,
            motor: core.motor,
            delay: core.delay,
            control_period: core.control_period,
            pushes: Vec::new(),
            force: None,
            slope_profile: Vec::new(),
            friction: core.friction.map(|inner| PyFriction { inner }),
            backlash: core.backlash.map(|b| b.gap),
            settle: core.settle,
            seed,
            stream,
        })
    }

}

crate::settings::settings_class!(PyRealism, "Realism",
    settings {
        imu: Option<PyImu> = |s| s.imu.clone();
        estimator: PyTiltEstimator = |s| PyTiltEstimator { inner: s.estimator };
        encoder_cpr: Option<f64> = |s| s.encoder_cpr;
        motor: Option<PyMotorDriver> = |s| s.motor.map(|inner| PyMotorDriver { inner });
        delay: bool = |s| s.delay;
        control_period: Option<f64> = |s| s.control_period;
        pushes: Vec<PyPush> = |s| s.pushes.clone();
        force: Option<PyForce> = |s| s.force;
        slope_profile: Vec<(f64, f64)> = |s| s.slope_profile.clone();
        /// Gearhead friction per wheel on the rig's plant (None: the model's own).
        friction: Option<PyFriction> = |s| s.friction;
        /// Each gear train's free play at the wheel [rad] (None: none).
        backlash: Option<f64> = |s| s.backlash;
        /// Seconds the estimator reads the IMU at rest before the run (None: none).
        settle: Option<f64> = |s| s.settle;
        seed: u64 = |s| s.seed;
        stream: u64 = |s| s.stream;
    }
    derived {
        /// True when every part is ideal and nothing disturbs the robot.
        is_ideal: bool = |s| {
            s.imu.is_none()
                && s.encoder_cpr.is_none()
                && s.motor.is_none()
                && !s.delay
                && s.control_period.is_none()
                && s.pushes.is_empty()
                && s.force.is_none()
                && s.slope_profile.is_empty()
                && s.friction.is_none()
                && s.backlash.is_none()
        };
    }
);

#[pymethods]
impl PyRealism {
    /// The settings as JSON text: every part as its `to_dict()`, the estimator as
    /// {"kind", ...its parameters}. `Realism.from_json` reads it back.
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        let plain = plain(self.to_dict(py)?.as_any())?;
        py.import("json")?.call_method1("dumps", (plain,))?.extract()
    }

    /// The Realism that `to_json` wrote.
    #[staticmethod]
    fn from_json<'py>(py: Python<'py>, text: &str) -> PyResult<Self> {
        let d = py.import("json")?.call_method1("loads", (text,))?;
        let d = d.cast::<PyDict>().map_err(|_| InvalidParameterError::new_err("Realism JSON must be an object"))?;
        let kw = PyDict::new(py);
        for (k, v) in d.iter() {
            let key: String = k.extract()?;
            let part = |cls: &Bound<'py, PyAny>| -> PyResult<Bound<'py, PyAny>> {
                if v.is_none() { Ok(v.clone()) } else { cls.call((), Some(&tuples(v.cast::<PyDict>()?)?)) }
            };
            // A part or entry of the wrong type is named by its key (and its field).
            let read = || -> PyResult<Bound<'py, PyAny>> {
                Ok(match key.as_str() {
                    "imu" => part(py.get_type::<PyImu>().as_any())?,
                    "motor" => part(py.get_type::<PyMotorDriver>().as_any())?,
                    "force" => part(py.get_type::<PyForce>().as_any())?,
                    "friction" => part(py.get_type::<PyFriction>().as_any())?,
                    "estimator" => {
                        let e = tuples(v.cast::<PyDict>()?)?;
                        let kind = e.get_item("kind")?.ok_or_else(|| InvalidParameterError::new_err("estimator: no 'kind'"))?;
                        e.del_item("kind")?;
                        // Only an estimator's own kinds (`PyTiltEstimator::kind`): the name picks
                        // the class's constructor, and any other attribute of it is no estimator.
                        let kind: String = kind.extract()?;
                        if !matches!(kind.as_str(), "complementary" | "kalman") {
                            return Err(InvalidParameterError::new_err(format!(
                                "estimator: kind = {kind:?}: must be \"complementary\" or \"kalman\""
                            )));
                        }
                        py.get_type::<PyTiltEstimator>().getattr(kind)?.call((), Some(&e))?
                    }
                    "pushes" => {
                        let list = PyList::empty(py);
                        for p in v.try_iter()? {
                            list.append(py.get_type::<PyPush>().call((), Some(&tuples(p?.cast::<PyDict>()?)?))?)?;
                        }
                        list.into_any()
                    }
                    "slope_profile" => {
                        let list = PyList::empty(py);
                        for c in v.try_iter()? {
                            list.append(PyTuple::new(py, c?.try_iter()?.collect::<PyResult<Vec<_>>>()?)?)?;
                        }
                        list.into_any()
                    }
                    _ => v.clone(),
                })
            };
            let value = read().map_err(|e| naming_argument(py, &format!("Realism.from_json: {key}"), e))?;
            kw.set_item(key, value)?;
        }
        let r = py.get_type::<Self>().call((), Some(&kw)).map_err(|e| naming_argument(py, "Realism.from_json", e))?;
        Ok(r.cast_into::<Self>()?.get().clone())
    }
}

/// JSON-ready values: settings objects as their `to_dict()`, a tilt estimator as
/// {"kind", ...its parameters}, tuples as lists.
fn plain<'py>(v: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let py = v.py();
    if let Ok(e) = v.cast::<PyTiltEstimator>() {
        let d = e.get().parameters(py)?;
        d.set_item("kind", e.get().kind())?;
        return Ok(d.into_any());
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let out = PyDict::new(py);
        for (k, x) in d.iter() {
            out.set_item(k, plain(&x)?)?;
        }
        return Ok(out.into_any());
    }
    if v.is_instance_of::<PyTuple>() || v.is_instance_of::<PyList>() {
        let items = v.try_iter()?.map(|x| plain(&x?)).collect::<PyResult<Vec<_>>>()?;
        return Ok(PyList::new(py, items)?.into_any());
    }
    if v.hasattr("to_dict")? {
        return plain(&v.call_method0("to_dict")?);
    }
    Ok(v.clone())
}

/// A copy of keyword arguments read from JSON with its lists as tuples (pairs such as
/// `accel_bias`).
fn tuples<'py>(d: &Bound<'py, PyDict>) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(d.py());
    for (k, v) in d.iter() {
        if let Ok(l) = v.cast::<PyList>() {
            out.set_item(k, l.to_tuple())?;
        } else {
            out.set_item(k, v)?;
        }
    }
    Ok(out)
}

impl PyRealism {
    /// The core's settings for a robot with `params` (heights default to its COM).
    pub fn to_core(&self, params: &RobotParams<f64>) -> Result<Realism<f64>, TwipError> {
        let com = params.com_height;
        let pushes: Vec<Push<f64>> =
            self.pushes.iter().map(|p| Push { t: p.t, impulse: p.impulse, height: p.height.unwrap_or(com) }).collect();
        let force = self.force.map_or(Force::none(), |f| Force {
            horizontal: f.horizontal,
            vertical: f.vertical,
            height: f.height.unwrap_or(com),
        });
        Realism {
            imu: self.imu.as_ref().map(|i| i.inner),
            estimator: self.estimator,
            encoder_cpr: self.encoder_cpr,
            motor: self.motor,
            delay: self.delay,
            control_period: self.control_period,
            pushes: Pushes::new(&pushes)?,
            force,
            slope_profile: SlopeProfile::new(0.0, &self.slope_profile)?,
            friction: self.friction.map(|f| f.inner),
            backlash: self.backlash.map(|gap| Backlash { gap }),
            settle: self.settle,
            seed: self.seed,
            stream: self.stream,
        }
        .validate()
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyImu>()?;
    m.add_class::<PyDlpf>()?;
    m.add_class::<PyTiltEstimator>()?;
    m.add_class::<PyMotorDriver>()?;
    m.add_class::<PyPush>()?;
    m.add_class::<PyForce>()?;
    m.add_class::<PyRealism>()?;
    Ok(())
}
