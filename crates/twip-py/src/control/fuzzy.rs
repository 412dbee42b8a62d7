//! `twip.Trapezoid`, `twip.Triangle`, `twip.Gaussian`, `twip.FuzzyBasis` and
//! `twip.FuzzyController` (fuzzy adaptive backstepping + PD, thesis 4.1.2).
use numpy::{AllowTypeChange, IntoPyArray, PyArrayLikeDyn};
use pyo3::prelude::*;
use twip_core::control::fuzzy_basis::{grid_product, normalised_memberships, Membership, ThesisBasis};
use twip_core::control::fuzzy::{fuzzy_internal_names, Adaptation, FuzzyController, FuzzyGains, DEFAULT_GAMMA, DEFAULT_SIGMA};
use twip_core::control::fuzzy_grid::{FuzzyGrid, SetKind};
use twip_core::TwipError;

use crate::convert::{real, real_array, reals, scalar, series, Real};
use crate::errors::{CoreResult, InvalidParameterError, PyTwipError};
use crate::model::models::PySlopeModel;
use crate::settings::Reduced;

/// A core error with the object it came from in front of its message.
fn in_context(e: TwipError, what: impl core::fmt::Display) -> PyErr {
    match e {
        TwipError::InvalidParameter { .. } => InvalidParameterError::new_err(format!("{what}: {e}")),
        other => PyTwipError(other).into(),
    }
}

/// Refuses a NaN input (its first, in row-major order) naming it; +-inf is an input a
/// set can take (a shoulder's side).
fn no_nan<'a>(name: &'static str, values: impl IntoIterator<Item = &'a f64>) -> PyResult<()> {
    match values.into_iter().enumerate().find(|(_, v)| v.is_nan()) {
        Some((index, &value)) => Err(PyTwipError(TwipError::NonFinite { name, index, value }).into()),
        None => Ok(()),
    }
}

/// μ(x) for a float (a float back) or any array of real numbers (an array of the same shape).
fn eval_any<'py>(m: &Membership<f64>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let py = x.py();
    // Anything but a real number (a bool too) is read as an array, which names it.
    if let Ok(Real(v)) = x.extract::<Real>() {
        no_nan("x", [&v])?;
        return Ok(m.eval(v).into_pyobject(py)?.into_any());
    }
    let arr: PyArrayLikeDyn<'py, f64, AllowTypeChange> = real_array("x", x)?.extract()?;
    no_nan("x", arr.as_array().iter())?;
    Ok(arr.as_array().mapv(|v| m.eval(v)).into_pyarray(py).into_any())
}

fn fmt_set(m: &Membership<f64>) -> String {
    match *m {
        Membership::Trapezoid { a, b, c, d } => format!("Trapezoid({a:?}, {b:?}, {c:?}, {d:?})"),
        Membership::Gaussian { mean, sigma } => format!("Gaussian({mean:?}, {sigma:?})"),
    }
}

/// Trapezoidal membership (4.31): a <= b <= c <= d; a = b = -inf is a left shoulder,
/// c = d = +inf a right one. Call it on a float or an array.
#[pyclass(name = "Trapezoid", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyTrapezoid {
    pub inner: Membership<f64>,
}

#[pymethods]
impl PyTrapezoid {
    #[new]
    fn new(a: Real, b: Real, c: Real, d: Real) -> PyResult<Self> {
        let (a, b, c, d) = (a.0, b.0, c.0, d.0);
        let inner = Membership::trapezoid(a, b, c, d)
            .map_err(|e| in_context(e, format_args!("Trapezoid(a={a:?}, b={b:?}, c={c:?}, d={d:?})")))?;
        Ok(Self { inner })
    }

    /// Pickled as Trapezoid(a, b, c, d) (a Dask worker gets a sweep's sets so).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> (Bound<'py, PyAny>, (f64, f64, f64, f64)) {
        (slf.get_type().into_any(), slf.get().breakpoints())
    }

    /// (a, b, c, d).
    #[getter]
    fn breakpoints(&self) -> (f64, f64, f64, f64) {
        match self.inner {
            Membership::Trapezoid { a, b, c, d } => (a, b, c, d),
            Membership::Gaussian { .. } => unreachable!("a Trapezoid holds a trapezoid"),
        }
    }

    fn __call__<'py>(&self, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        eval_any(&self.inner, x)
    }

    fn eval<'py>(&self, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        eval_any(&self.inner, x)
    }

    fn __repr__(&self) -> String {
        fmt_set(&self.inner)
    }
}

/// Triangular membership with feet a, c and peak b (the trapezoid (a, b, b, c)).
#[pyclass(name = "Triangle", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyTriangle {
    pub inner: Membership<f64>,
}

#[pymethods]
impl PyTriangle {
    #[new]
    fn new(a: Real, b: Real, c: Real) -> PyResult<Self> {
        let (a, b, c) = (a.0, b.0, c.0);
        let inner = Membership::triangle(a, b, c)
            .map_err(|e| in_context(e, format_args!("Triangle(a={a:?}, b={b:?}, c={c:?})")))?;
        Ok(Self { inner })
    }

    /// Pickled as Triangle(a, b, c).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> (Bound<'py, PyAny>, (f64, f64, f64)) {
        (slf.get_type().into_any(), slf.get().breakpoints())
    }

    /// (a, b, c).
    #[getter]
    fn breakpoints(&self) -> (f64, f64, f64) {
        match self.inner {
            Membership::Trapezoid { a, b, d, .. } => (a, b, d),
            Membership::Gaussian { .. } => unreachable!("a Triangle holds a trapezoid"),
        }
    }

    fn __call__<'py>(&self, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        eval_any(&self.inner, x)
    }

    fn eval<'py>(&self, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        eval_any(&self.inner, x)
    }

    fn __repr__(&self) -> String {
        let (a, b, c) = self.breakpoints();
        format!("Triangle({a:?}, {b:?}, {c:?})")
    }
}

/// Gaussian membership exp(-(x - mean)^2 / (2 sigma^2)), sigma > 0.
#[pyclass(name = "Gaussian", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyGaussian {
    pub inner: Membership<f64>,
}

#[pymethods]
impl PyGaussian {
    #[new]
    fn new(mean: Real, sigma: Real) -> PyResult<Self> {
        let (mean, sigma) = (mean.0, sigma.0);
        let inner = Membership::gaussian(mean, sigma)
            .map_err(|e| in_context(e, format_args!("Gaussian(mean={mean:?}, sigma={sigma:?})")))?;
        Ok(Self { inner })
    }

    /// Pickled as Gaussian(mean, sigma).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> (Bound<'py, PyAny>, (f64, f64)) {
        let me = slf.get();
        (slf.get_type().into_any(), (me.mean(), me.sigma()))
    }

    #[getter]
    fn mean(&self) -> f64 {
        match self.inner {
            Membership::Gaussian { mean, .. } => mean,
            Membership::Trapezoid { .. } => unreachable!("a Gaussian holds a Gaussian"),
        }
    }

    #[getter]
    fn sigma(&self) -> f64 {
        match self.inner {
            Membership::Gaussian { sigma, .. } => sigma,
            Membership::Trapezoid { .. } => unreachable!("a Gaussian holds a Gaussian"),
        }
    }

    fn __call__<'py>(&self, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        eval_any(&self.inner, x)
    }

    fn eval<'py>(&self, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        eval_any(&self.inner, x)
    }

    fn __repr__(&self) -> String {
        fmt_set(&self.inner)
    }
}

fn membership_of(obj: &Bound<'_, PyAny>, where_: impl Fn() -> String) -> PyResult<Membership<f64>> {
    if let Ok(m) = obj.cast::<PyTrapezoid>() {
        return Ok(m.get().inner);
    }
    if let Ok(m) = obj.cast::<PyTriangle>() {
        return Ok(m.get().inner);
    }
    if let Ok(m) = obj.cast::<PyGaussian>() {
        return Ok(m.get().inner);
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "{} must be a twip.Trapezoid, Triangle or Gaussian, got {}",
        where_(),
        obj.get_type().name().map(|n| n.to_string()).unwrap_or_default()
    )))
}

fn membership_to_py(py: Python<'_>, m: Membership<f64>) -> PyResult<Bound<'_, PyAny>> {
    Ok(match m {
        Membership::Trapezoid { .. } => Bound::new(py, PyTrapezoid { inner: m })?.into_any(),
        Membership::Gaussian { .. } => Bound::new(py, PyGaussian { inner: m })?.into_any(),
    })
}

/// Sets per input from a FuzzyBasis or a sequence of sequences of memberships.
fn sets_of(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Vec<Membership<f64>>>> {
    if let Ok(b) = obj.cast::<PyFuzzyBasis>() {
        return Ok(b.get().sets.clone());
    }
    let mut out = Vec::new();
    for (i, row) in obj.try_iter()?.enumerate() {
        let mut sets = Vec::new();
        for (j, m) in row?.try_iter()?.enumerate() {
            sets.push(membership_of(&m?, || format!("sets[{i}][{j}]"))?);
        }
        if sets.is_empty() {
            return Err(InvalidParameterError::new_err(format!("sets[{i}] is empty: every input needs a set")));
        }
        out.push(sets);
    }
    if out.is_empty() {
        return Err(InvalidParameterError::new_err("sets is empty: the basis needs at least one input"));
    }
    let rules = out.iter().try_fold(1usize, |n, sets| n.checked_mul(sets.len()).filter(|&n| n <= MAX_RULES));
    if rules.is_none() {
        let per_input: Vec<String> = out.iter().map(|s| s.len().to_string()).collect();
        return Err(InvalidParameterError::new_err(format!(
            "sets: {} sets per input make more than {MAX_RULES} rules (one per combination)",
            per_input.join(" x ")
        )));
    }
    Ok(out)
}

/// The most rules a basis may have (one per combination of one set per input): a basis
/// evaluates all of them at every point, 8 bytes each.
const MAX_RULES: usize = 1 << 24;

/// A basis's sets as Python objects, per input.
type SetObjects<'py> = Vec<Vec<Bound<'py, PyAny>>>;

/// The normalised fuzzy basis xi of (4.29) over a grid rule base: one rule per
/// combination of one set per input, product inference, rules in row-major order (the
/// last input varies fastest, as in (4.39)). xi is non-negative and sums to 1 everywhere;
/// where no rule fires, each silent input's nearest set fires alone (docs/scenarios.md).
#[pyclass(name = "FuzzyBasis", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyFuzzyBasis {
    sets: Vec<Vec<Membership<f64>>>,
}

impl PyFuzzyBasis {
    /// A grid's sets.
    pub(crate) fn of(grid: &FuzzyGrid<f64>) -> Self {
        Self { sets: grid.sets().iter().map(|r| r.to_vec()).collect() }
    }

    fn n_rules(&self) -> usize {
        self.sets.iter().map(Vec::len).product()
    }

    /// ξ at one point into `out`; `w` is scratch, one Vec per input.
    fn eval_into(&self, x: impl Iterator<Item = f64>, w: &mut [Vec<f64>], out: &mut [f64]) {
        for ((sets, wi), xi) in self.sets.iter().zip(w.iter_mut()).zip(x) {
            normalised_memberships(sets, xi, wi);
        }
        let views: Vec<&[f64]> = w.iter().map(Vec::as_slice).collect();
        grid_product(&views, out).expect("sizes come from the same sets");
    }
}

#[pymethods]
impl PyFuzzyBasis {
    /// `sets_per_input`: for each input, its sets (Trapezoid, Triangle, Gaussian).
    #[new]
    fn new(sets_per_input: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(Self { sets: sets_of(sets_per_input)? })
    }

    /// twip's default sets for (phi [rad], phi_dot [rad/s]), N, Z, P each, rules ordered as
    /// the thesis's (4.39); FuzzyController uses them unless given `sets`.
    #[staticmethod]
    fn default() -> Self {
        Self { sets: ThesisBasis::<f64>::default().sets().iter().map(|r| r.to_vec()).collect() }
    }

    /// A regular n x n grid over (phi [rad], phi_dot [rad/s]) for the adaptive controllers:
    /// `kind` "trapezoid" (core centre +- width, feet at the neighbours' core edges, the
    /// outer two shoulders), "triangle" (peak at the centre, feet at the neighbouring
    /// centres, the outer two shoulders; no widths) or "gaussian" (mean centre, sigma
    /// width). `centres`: per input, n strictly increasing values (n from 2 to 7);
    /// `widths`: per input, one value > 0 for every set or n of them.
    #[staticmethod]
    #[pyo3(signature = (kind, centres, widths = None))]
    fn grid(kind: &str, centres: [Vec<Real>; 2], widths: Option<[Bound<'_, PyAny>; 2]>) -> PyResult<Self> {
        let centres = centres.map(reals);
        let kind = match kind {
            "trapezoid" => SetKind::Trapezoid,
            "triangle" => SetKind::Triangle,
            "gaussian" => SetKind::Gaussian,
            other => {
                return Err(InvalidParameterError::new_err(format!(
                    "invalid kind = {other:?}: must be \"trapezoid\", \"triangle\" or \"gaussian\""
                )))
            }
        };
        let widths: [Vec<f64>; 2] = match widths {
            None => [vec![], vec![]],
            Some([w0, w1]) => {
                let per_set = |i: usize, w: Bound<'_, PyAny>, n: usize| -> PyResult<Vec<f64>> {
                    if let Ok(Real(v)) = w.extract::<Real>() {
                        return Ok(vec![v; n]);
                    }
                    match w.extract::<Vec<Real>>() {
                        Ok(v) => Ok(reals(v)),
                        Err(_) => Err(pyo3::exceptions::PyTypeError::new_err(format!(
                            "widths[{i}] = {}: must be a real number or one per set",
                            w.repr()?
                        ))),
                    }
                };
                [per_set(0, w0, centres[0].len())?, per_set(1, w1, centres[1].len())?]
            }
        };
        let grid = FuzzyGrid::regular(kind, [&centres[0], &centres[1]], [&widths[0], &widths[1]]).map_err(PyTwipError)?;
        Ok(Self::of(&grid))
    }

    /// Pickled as FuzzyBasis(sets).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Reduced<'py, (SetObjects<'py>,)>> {
        Ok((slf.get_type().into_any(), (slf.get().sets(slf.py())?,)))
    }

    #[getter]
    fn n_inputs(&self) -> usize {
        self.sets.len()
    }

    #[getter(n_rules)]
    fn n_rules_py(&self) -> usize {
        self.n_rules()
    }

    #[getter]
    fn sets<'py>(&self, py: Python<'py>) -> PyResult<SetObjects<'py>> {
        self.sets.iter().map(|row| row.iter().map(|m| membership_to_py(py, *m)).collect()).collect()
    }

    /// xi at one point x (shape (n_inputs,)) -> (n_rules,), or at many points
    /// (shape (N, n_inputs)) -> (N, n_rules).
    fn eval<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        // Through `real_array`: numpy's own cast would keep a complex entry's real part.
        let x: PyArrayLikeDyn<'py, f64, AllowTypeChange> = real_array("x", x)?.extract()?;
        let view = x.as_array();
        no_nan("x", view.iter())?;
        let n_in = self.sets.len();
        let n_rules = self.n_rules();
        let mut w: Vec<Vec<f64>> = self.sets.iter().map(|s| vec![0.0; s.len()]).collect();
        match view.shape() {
            [n] if *n == n_in => {
                let mut out = vec![0.0; n_rules];
                self.eval_into(view.iter().copied(), &mut w, &mut out);
                Ok(out.into_pyarray(py).into_any())
            }
            [rows, n] if *n == n_in => {
                let rows = *rows;
                let data: Vec<f64> = view.iter().copied().collect();
                let out = py.detach(|| {
                    let mut out = vec![0.0; rows * n_rules];
                    for (point, xi) in data.chunks_exact(n_in).zip(out.chunks_exact_mut(n_rules)) {
                        self.eval_into(point.iter().copied(), &mut w, xi);
                    }
                    out
                });
                let arr = numpy::ndarray::Array2::from_shape_vec((rows, n_rules), out)
                    .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
                Ok(arr.into_pyarray(py).into_any())
            }
            shape => Err(PyTwipError(TwipError::Shape {
                name: "x",
                expected: (n_in, 1),
                got: (shape.first().copied().unwrap_or(0), shape.get(1).copied().unwrap_or(1)),
            })
            .into()),
        }
    }

    fn __repr__(&self) -> String {
        let rows: Vec<String> =
            self.sets.iter().map(|r| format!("[{}]", r.iter().map(fmt_set).collect::<Vec<_>>().join(", "))).collect();
        format!("FuzzyBasis([{}])", rows.join(", "))
    }
}

/// The n x n grid an adaptive controller needs, from `sets` (None: `default`).
pub(crate) fn grid_basis(sets: Option<&Bound<'_, PyAny>>, default: FuzzyGrid<f64>) -> PyResult<FuzzyGrid<f64>> {
    let Some(obj) = sets else { return Ok(default) };
    let rows = sets_of(obj)?;
    if rows.len() != 2 {
        return Err(PyTwipError(TwipError::Shape { name: "sets", expected: (2, rows[0].len()), got: (rows.len(), rows[0].len()) }).into());
    }
    Ok(FuzzyGrid::new([&rows[0], &rows[1]]).map_err(PyTwipError)?)
}

/// Fuzzy adaptive backstepping on the pitch + PD on the wheel position (thesis 4.56,
/// errata F1-F8): u = -(1/G1)[e1 + S^T xi + k1 phi_dot + (1/2 + k2) z2] + kp e + kd e_dot
/// + ki int(e), S' = z2 xi / gamma - sigma S. `model` is the controller's own model (phi_s
/// and G1); `sets` the (phi, phi_dot) sets, n of each for n x n rules, n from 2 to 7
/// (a 2 x n FuzzyBasis, e.g. FuzzyBasis.grid, or nested list; default twip's 3 x 3);
/// `adapt=False` freezes S at `s0` (default zeros). A pickle or copy keeps these settings,
/// `s0` included; the weights S adapt inside each run (from `s0`), not in the controller.
#[pyclass(name = "FuzzyController", module = "twip", frozen)]
pub struct PyFuzzyController {
    pub inner: FuzzyController<f64>,
}

#[allow(clippy::too_many_arguments)]
fn build(
    model: &PySlopeModel,
    gains: FuzzyGains<f64>,
    gamma: f64,
    sigma: f64,
    adapt: bool,
    sets: Option<&Bound<'_, PyAny>>,
    period: f64,
    s0: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyFuzzyController> {
    let adaptation = Adaptation { gamma, sigma, enabled: adapt };
    let mut inner = FuzzyController::new(model.inner, gains, adaptation, grid_basis(sets, FuzzyGrid::default())?, period).map_err(PyTwipError)?;
    if let Some(s0) = s0 {
        let v = series("s0", s0)?;
        inner = inner.with_initial_weights(v.as_array().to_vec()).map_err(PyTwipError)?;
    }
    Ok(PyFuzzyController { inner })
}

/// Γ and σ when not given: the core's `Adaptation::default()`.
const GAMMA: Real = Real(DEFAULT_GAMMA);
const SIGMA: Real = Real(DEFAULT_SIGMA);

#[pymethods]
impl PyFuzzyController {
    #[new]
    #[pyo3(signature = (model, k1, k2, kp, kd, gamma = GAMMA, sigma = SIGMA, ki = 0.0, adapt = true, sets = None, period = 0.005, s0 = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &PySlopeModel,
        k1: Real,
        k2: Real,
        kp: Real,
        kd: Real,
        gamma: Real,
        sigma: Real,
        #[pyo3(from_py_with = real)] ki: f64,
        adapt: bool,
        sets: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = real)] period: f64,
        s0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let gains = FuzzyGains { k1: k1.0, k2: k2.0, kp: kp.0, kd: kd.0, ki };
        build(model, gains, gamma.0, sigma.0, adapt, sets, period, s0)
    }

    /// The thesis's slope gains k1 = 10, k2 = 13, kp = -0.01, kd = -0.09.
    #[staticmethod]
    #[pyo3(signature = (model, gamma = GAMMA, sigma = SIGMA, ki = 0.0, adapt = true, sets = None, period = 0.005, s0 = None))]
    #[allow(clippy::too_many_arguments)]
    fn thesis_slope(
        model: &PySlopeModel,
        gamma: Real,
        sigma: Real,
        #[pyo3(from_py_with = real)] ki: f64,
        adapt: bool,
        sets: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = real)] period: f64,
        s0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        build(model, FuzzyGains { ki, ..FuzzyGains::thesis_slope() }, gamma.0, sigma.0, adapt, sets, period, s0)
    }

    /// The thesis's flat gains k1 = 30, k2 = 33, kp = -0.1, kd = -0.9.
    #[staticmethod]
    #[pyo3(signature = (model, gamma = GAMMA, sigma = SIGMA, ki = 0.0, adapt = true, sets = None, period = 0.005, s0 = None))]
    #[allow(clippy::too_many_arguments)]
    fn thesis_flat(
        model: &PySlopeModel,
        gamma: Real,
        sigma: Real,
        #[pyo3(from_py_with = real)] ki: f64,
        adapt: bool,
        sets: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = real)] period: f64,
        s0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        build(model, FuzzyGains { ki, ..FuzzyGains::thesis_flat() }, gamma.0, sigma.0, adapt, sets, period, s0)
    }

    /// Names of the logged internals (SimResult.internals).
    #[getter]
    fn internal_names(&self) -> Vec<&'static str> {
        fuzzy_internal_names(self.inner.basis().n()).to_vec()
    }

    /// phi_s the controller aims for at a reference wheel speed (corrected 4.42, own model).
    fn steady_pitch(&self, theta_dot_ref: Real) -> CoreResult<f64> {
        Ok(self.inner.steady_pitch(theta_dot_ref.0)?)
    }

    /// G1 at pitch phi: the pitch acceleration per ampere (controller's model).
    fn g1(&self, phi: Real) -> CoreResult<f64> {
        Ok(self.inner.g1(scalar("phi", phi.0)?))
    }

}

crate::settings::settings_class!(PyFuzzyController, "FuzzyController",
    settings {
        /// The controller's own model (phi_s and G1).
        model: PySlopeModel = |s| PySlopeModel { inner: *s.inner.model() };
        k1: f64 = |s| s.inner.gains().k1;
        k2: f64 = |s| s.inner.gains().k2;
        kp: f64 = |s| s.inner.gains().kp;
        kd: f64 = |s| s.inner.gains().kd;
        gamma: f64 = |s| s.inner.adaptation().gamma;
        sigma: f64 = |s| s.inner.adaptation().sigma;
        ki: f64 = |s| s.inner.gains().ki;
        adapt: bool = |s| s.inner.adaptation().enabled;
        /// The (phi, phi_dot) sets, n of each.
        sets: PyFuzzyBasis = |s| s.basis_of();
        period: f64 = |s| twip_core::control::Controller::period(&s.inner);
        /// The weights S the controller starts from (and resets to).
        s0: Vec<f64> = |s| s.inner.initial_weights().to_vec();
    }
    derived {
        /// The (phi, phi_dot) sets (the same as `sets`).
        basis: PyFuzzyBasis = |s| s.basis_of();
    }
);

impl PyFuzzyController {
    fn basis_of(&self) -> PyFuzzyBasis {
        PyFuzzyBasis::of(self.inner.basis())
    }
}
