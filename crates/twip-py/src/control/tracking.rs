//! The 3-DOF trackers: `twip.PidTracker` and `twip.SmcTracker`.
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use twip_core::control::Controller;
use twip_core::hardware::motor::DcMotor;
use twip_core::control::pid::{PidGains, PidTracker, PidUnits};
use twip_core::control::smc::{Adaptation, PitchSign, SmcGains, SmcOptions, SmcTracker};
use twip_core::RobotParams;

use crate::control::fuzzy::{grid_basis, PyFuzzyBasis};
use crate::convert::{real, scalar, Real};
use crate::errors::{positive_param, CoreResult, InvalidParameterError, PyTwipError};
use crate::model::models::PyPlanarModel;
use crate::model::params::PyRobotParams;
use crate::hardware::motor::{motor_or_default, PyDcMotor};
use crate::settings::{NamedFloats, Reduced};


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
            out[i] = v.extract::<Real>().map_err(|_| {
                InvalidParameterError::new_err(format!("{what} '{key}' must be a real number, got {v}"))
            })?.0;
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
/// A tracker holds no run state (each run starts its integrators at zero), so a pickled
/// copy is the same tracker. The heading error is wrapped to [−π, π) (docs/errata.md T2).
#[pyclass(name = "PidTracker", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyPidTracker {
    pub inner: PidTracker<f64>,
    /// The robot it was built for (it keeps the wheel radius and half track), for pickling.
    params: RobotParams<f64>,
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
        #[pyo3(from_py_with = real)] period: f64,
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
        Ok(Self { inner, params: params.inner })
    }

    /// Table 4.1's gains as published, in twip's reading of the Arduino's units.
    #[staticmethod]
    #[pyo3(signature = (params = None, motor = None, period = 0.005))]
    fn table_4_1(params: Option<&PyRobotParams>, motor: Option<&PyDcMotor>, #[pyo3(from_py_with = real)] period: f64) -> CoreResult<Self> {
        let p = params.map(|p| p.inner).unwrap_or_else(RobotParams::balanbot);
        Ok(Self { inner: PidTracker::table_4_1(&p, motor_or_default(motor), period)?, params: p })
    }

    /// The gains (Table 4.1's names), in the tracker's units.
    #[getter]
    fn gains(&self) -> NamedFloats {
        NamedFloats(&PID_GAINS, pid_gains_array(&self.inner.gains()).to_vec())
    }

    /// What one unit of each gain's input is in SI.
    #[getter]
    fn units(&self) -> NamedFloats {
        let u = self.inner.units();
        NamedFloats(&PID_UNITS, vec![u.pitch, u.speed, u.heading, u.integral_step])
    }

    #[getter]
    fn motor(&self) -> PyDcMotor {
        PyDcMotor { inner: *self.inner.motor() }
    }

    #[getter]
    fn period(&self) -> f64 {
        self.inner.period()
    }

    /// Pickled as PidTracker(params, gains, units, motor, period), the units as a dict.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> Reduced<'py, (PyRobotParams, NamedFloats, NamedFloats, PyDcMotor, f64)> {
        let me = slf.get();
        let args = (PyRobotParams { inner: me.params }, me.gains(), me.units(), me.motor(), me.period());
        (slf.get_type().into_any(), args)
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
    let Real(v) = obj.extract().map_err(|_| {
        InvalidParameterError::new_err(format!("torque_unit = {}: must be 'pwm', 'si' or a number", obj.repr().map(|r| r.to_string()).unwrap_or_default()))
    })?;
    Ok(positive_param("torque_unit", v)?)
}

fn pair(name: &'static str, obj: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
    if let Ok(Real(v)) = obj.extract::<Real>() {
        return Ok((v, v));
    }
    let (Real(a), Real(b)) = obj.extract().map_err(|_| {
        let given = obj.repr().map(|r| r.to_string()).unwrap_or_default();
        InvalidParameterError::new_err(format!("{name} = {given}: must be a number or a pair of numbers"))
    })?;
    Ok((a, b))
}

/// The sliding-mode backstepping tracker (4.71-4.98) or, with `fuzzy=True`, its fuzzy
/// adaptive form (4.99-4.121). `gains` (dict, SI) override the published ones, whose
/// torque gains (k_s3, k_s4, g_y4) are read in `torque_unit`; `boundary_layer` is the
/// width of sat(S/w) for (S_eta, S1), one number for both, 0 for sgn; `pitch` is
/// "backward" (the reading under which the published r1, r2 work) or "forward". A pickle
/// or copy keeps these settings; the fuzzy weights adapt inside each run (from zeros), not
/// in the tracker. The heading error ψ_r − ψ is wrapped to [−π, π) (docs/errata.md T2).
/// Logged internals: `lambda1` = −k_φ (φ − φ_s) in twip's pitch sign (the "backward" reading
/// turns r1, not λ1), `d` = r1 g21 + r2 g22 (the surface's input gain, not (4.82)'s 1 + k3 e1).
/// `yaw_sets` (over phi, omega) and `pitch_sets` (over phi, phi_dot) are the fuzzy estimates'
/// n x n grids, the same n from 2 to 7 (a FuzzyBasis, e.g. FuzzyBasis.grid; default twip's 3 x 3).
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
        guards = (Real(0.05), Real(0.2)), gamma = (Real(0.05), Real(1000.0)), leakage = 0.0, pitch_offset = true, motor = None,
        motor_limits = true, period = 0.005, yaw_sets = None, pitch_sets = None
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &PyPlanarModel,
        fuzzy: bool,
        boundary_layer: Option<&Bound<'_, PyAny>>,
        gains: Option<&Bound<'_, PyDict>>,
        torque_unit: Option<&Bound<'_, PyAny>>,
        pitch: &str,
        guards: (Real, Real),
        gamma: (Real, Real),
        #[pyo3(from_py_with = real)] leakage: f64,
        pitch_offset: bool,
        motor: Option<&PyDcMotor>,
        motor_limits: bool,
        #[pyo3(from_py_with = real)] period: f64,
        yaw_sets: Option<&Bound<'_, PyAny>>,
        pitch_sets: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (Real(guard_e3), Real(guard_d)) = guards;
        let (Real(gamma1), Real(gamma2)) = gamma;
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
        let options = SmcOptions { pitch, width_eta, width_s1, guard_e3, guard_d, pitch_offset };
        // Checked with or without fuzzy=True: a setting given is never dropped unseen.
        let adaptation = Adaptation { gamma1, gamma2, leakage }.validate().map_err(PyTwipError)?;
        let adaptation = fuzzy.then_some(adaptation);
        let inner = SmcTracker::new(
            smc_gains_from(g),
            options,
            *model.flat_only("a tracker's own model")?,
            motor_limits.then_some(motor),
            adaptation,
            period,
        )
        .map_err(PyTwipError)?;
        let (yaw, pitch) = inner.bases();
        let (yaw, pitch) = (grid_basis(yaw_sets, *yaw)?, grid_basis(pitch_sets, *pitch)?);
        let inner = inner.with_bases(yaw, pitch).map_err(PyTwipError)?;
        Ok(Self { inner })
    }

    /// The published gains (4.3.2) and twip's k1, k2, k3, k_phi, as a dict in SI with the
    /// torque gains read in `torque_unit` ("pwm": one PWM count of the GB37Y3530 at 11.1 V).
    #[staticmethod]
    #[pyo3(signature = (torque_unit = None))]
    fn thesis_gains(torque_unit: Option<&Bound<'_, PyAny>>) -> PyResult<NamedFloats> {
        let motor = DcMotor::gb37y3530();
        let unit = match torque_unit {
            Some(u) => self::torque_unit(u, &motor)?,
            None => motor.torque_per_count(),
        };
        Ok(NamedFloats(&SMC_GAINS, smc_gains_array(&SmcGains::thesis(unit)).to_vec()))
    }

    /// The fuzzy weights (C1_hat, C2_hat) of a fresh tracker (zeros: they adapt during a run).
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>) {
        let (c1, c2) = self.inner.weights();
        (c1.to_vec().into_pyarray(py), c2.to_vec().into_pyarray(py))
    }

    /// (g21, g22, g23) of (4.72) for the controller's model at pitch phi.
    fn input_gains(&self, phi: Real) -> CoreResult<(f64, f64, f64)> {
        Ok(self.inner.input_gains(scalar("phi", phi.0)?))
    }

    /// r1 g21 + r2 g22 at pitch phi, r1 on the controller's pitch: (4.113) needs it < 0.
    fn surface_gain(&self, phi: Real) -> CoreResult<f64> {
        Ok(self.inner.surface_gain(scalar("phi", phi.0)?))
    }

    /// The controller model's steady pitch driving at speed v [m/s] turning at omega [rad/s].
    fn steady_pitch(&self, v: Real, omega: Real) -> CoreResult<f64> {
        Ok(self.inner.steady_pitch(scalar("v", v.0)?, scalar("omega", omega.0)?))
    }

}

crate::settings::settings_class!(PySmcTracker, "SmcTracker",
    settings {
        /// The controller's own 3-DOF model.
        model: PyPlanarModel = |s| PyPlanarModel { inner: *s.inner.model(), terrain: None };
        fuzzy: bool = |s| s.inner.adaptation().is_some();
        /// (width of S_eta's layer, width of S1's); 0 is sgn.
        boundary_layer: (f64, f64) = |s| (s.inner.options().width_eta, s.inner.options().width_s1);
        /// The gains in SI (so `torque_unit` is "si").
        gains: NamedFloats = |s| NamedFloats(&SMC_GAINS, smc_gains_array(&s.inner.gains()).to_vec());
        /// The unit the stored gains are in: "si", always (gains read in "pwm" are converted
        /// when the tracker is built; `gains` holds them in N m).
        torque_unit: &'static str = |_| "si";
        pitch: &'static str = |s| match s.inner.options().pitch {
            PitchSign::Backward => "backward",
            PitchSign::Forward => "forward",
        };
        /// Guards delta of (4.82) for (e3, d).
        guards: (f64, f64) = |s| (s.inner.options().guard_e3, s.inner.options().guard_d);
        /// Adaptation gains (gamma1, gamma2) of the fuzzy form.
        gamma: (f64, f64) = |s| s.inner.adaptation().map_or((Adaptation::<f64>::default().gamma1, Adaptation::<f64>::default().gamma2), |a| (a.gamma1, a.gamma2));
        leakage: f64 = |s| s.inner.adaptation().map_or(0.0, |a| a.leakage);
        pitch_offset: bool = |s| s.inner.options().pitch_offset;
        motor: Option<PyDcMotor> = |s| s.inner.motor().map(|m| PyDcMotor { inner: *m });
        motor_limits: bool = |s| s.inner.motor().is_some();
        period: f64 = |s| s.inner.period();
        /// The yaw estimate's sets over (phi, omega).
        yaw_sets: PyFuzzyBasis = |s| PyFuzzyBasis::of(s.inner.bases().0);
        /// The pitch estimate's sets over (phi, phi_dot).
        pitch_sets: PyFuzzyBasis = |s| PyFuzzyBasis::of(s.inner.bases().1);
    }
);

