//! `twip.SlopeModel`, `twip.PlanarModel` and `twip.rk4_step`.
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use twip_core::model::slope::SlopeModel;
use twip_core::{rk4_step as core_rk4, Dynamics, PlanarModel};

use crate::convert::{input, real, scalar, to_py_matrix, to_py_vector, vector, Real};
use crate::errors::CoreResult;
use crate::model::friction::PyFriction;
use crate::model::params::PyRobotParams;
use crate::model::terrain::{off_terrain, PyTerrain};
use twip_core::model::terrain::Terrain;
use twip_core::model::terrain_model::TerrainModel;
use crate::settings::Reduced;

/// The 2-DOF model on a slope; state [phi, phi_dot, theta, theta_dot], input current u [A].
#[pyclass(name = "SlopeModel", module = "twip", frozen)]
#[derive(Clone)]
pub struct PySlopeModel {
    pub inner: SlopeModel<f64>,
}

type Arr1<'py> = Bound<'py, PyArray1<f64>>;
type Arr2<'py> = Bound<'py, PyArray2<f64>>;

#[pymethods]
impl PySlopeModel {
    #[new]
    #[pyo3(signature = (params, slope = 0.0, friction = None))]
    fn new(params: &PyRobotParams, #[pyo3(from_py_with = real)] slope: f64, friction: Option<&PyFriction>) -> CoreResult<Self> {
        Ok(Self { inner: SlopeModel::new(params.inner, slope)?.with_friction(friction.map(|f| f.inner))? })
    }

    /// The gearhead friction per wheel, or None (the thesis's model).
    #[getter]
    fn friction(&self) -> Option<PyFriction> {
        self.inner.friction().map(|&inner| PyFriction { inner })
    }

    #[getter]
    fn params(&self) -> PyRobotParams {
        PyRobotParams { inner: *self.inner.params() }
    }

    /// Slope angle alpha [rad], positive when forward travel climbs.
    #[getter]
    fn slope(&self) -> f64 {
        self.inner.slope()
    }

    /// Pickled as SlopeModel(params, slope, friction) (sweeps copy Python controllers holding one).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> Reduced<'py, (PyRobotParams, f64, Option<PyFriction>)> {
        let me = slf.get();
        (slf.get_type().into_any(), (me.params(), me.slope(), me.friction()))
    }

    fn deriv<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>, u: &Bound<'py, PyAny>) -> PyResult<Arr1<'py>> {
        let x = vector::<4>("x", x)?;
        let d = self.inner.deriv(&x, &input::<1>("u", u)?);
        finite_derivative(x.as_slice(), d.as_slice())?;
        Ok(to_py_vector(py, &d))
    }

    fn energy(&self, x: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.inner.energy(&vector::<4>("x", x)?))
    }

    /// Exact Jacobians (A 4x4, B 4x1) at the operating point (x0, u0). With a friction's
    /// stick band: those of the slip law that acts outside the band, inside it too (the held
    /// wheels there take no input).
    #[pyo3(signature = (x0, u0 = 0.0))]
    fn linearize<'py>(&self, py: Python<'py>, x0: &Bound<'py, PyAny>, #[pyo3(from_py_with = real)] u0: f64) -> PyResult<(Arr2<'py>, Arr2<'py>)> {
        let (a, b) = self.inner.linearize(&vector::<4>("x0", x0)?, scalar("u0", u0)?);
        Ok((to_py_matrix(py, &a), to_py_matrix(py, &b)))
    }

    /// The thesis's linear model (4.6)-(4.10) on [phi, phi_dot, theta_dot]: (A 3x3, B 3x1, D 3x1).
    fn linearize_thesis<'py>(&self, py: Python<'py>) -> (Arr2<'py>, Arr2<'py>, Arr2<'py>) {
        let m = self.inner.linearize_thesis();
        (to_py_matrix(py, &m.a), to_py_matrix(py, &m.b), to_py_matrix(py, &m.d))
    }

    /// Steady state at wheel speed theta_dot_ref: (x_s, u_s), x_s = [phi_s, 0, 0, theta_dot_ref].
    /// `linear=True` uses the thesis's linear model, (4.12)-(4.13).
    #[pyo3(signature = (theta_dot_ref, linear = false))]
    fn equilibrium<'py>(&self, py: Python<'py>, theta_dot_ref: Real, linear: bool) -> CoreResult<(Arr1<'py>, f64)> {
        let theta_dot_ref = theta_dot_ref.0;
        let (x, u) = if linear {
            self.inner.equilibrium_linear(theta_dot_ref)?
        } else {
            self.inner.equilibrium(theta_dot_ref)?
        };
        Ok((to_py_vector(py, &x), u))
    }

    fn mass_matrix<'py>(&self, py: Python<'py>, phi: Real) -> CoreResult<Arr2<'py>> {
        Ok(to_py_matrix(py, &self.inner.mass_matrix(scalar("phi", phi.0)?)))
    }

    fn __repr__(&self) -> String {
        format!("SlopeModel(RobotParams(...), slope={:?})", self.inner.slope())
    }
}

/// The 3-DOF planar model; state [x, y, psi, phi, phi_dot, v, omega], input [u_r, u_l] [N m].
#[pyclass(name = "PlanarModel", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyPlanarModel {
    pub inner: PlanarModel<f64>,
    /// The ground it stands on; None: flat ground, the thesis's model (docs/terrain.md).
    pub terrain: Option<PyTerrain>,
}

impl PyPlanarModel {
    /// The flat model, for what runs on flat ground only: an error naming `what` when this
    /// model has a terrain (never silently flat).
    pub fn flat_only(&self, what: &str) -> PyResult<&PlanarModel<f64>> {
        match self.terrain {
            None => Ok(&self.inner),
            Some(_) => Err(crate::errors::InvalidParameterError::new_err(format!(
                "invalid terrain: {what} runs on flat ground only (a PlanarModel without terrain); \
                 on terrain, run twip.rk4_step, twip.simulate (ideal or with realism=) or twip.montecarlo"
            ))),
        }
    }

    /// The model on its terrain, if it has one.
    pub fn on_terrain(&self) -> Option<TerrainModel<f64>> {
        self.terrain.as_ref().map(|t| TerrainModel::new(self.inner, t.inner.clone()))
    }

    /// A state's contact point must be on the terrain (a grid's edge): never extrapolated.
    fn check_on_terrain(&self, x: &nalgebra::SVector<f64, 7>) -> PyResult<()> {
        match &self.terrain {
            Some(t) if !t.inner.contains(x[0], x[1]) => Err(off_terrain(x[0], x[1])),
            _ => Ok(()),
        }
    }
}

#[pymethods]
impl PyPlanarModel {
    #[new]
    #[pyo3(signature = (params, friction = None, terrain = None))]
    fn new(params: &PyRobotParams, friction: Option<&PyFriction>, terrain: Option<&PyTerrain>) -> CoreResult<Self> {
        let terrain = terrain.cloned();
        Ok(Self { inner: PlanarModel::new(params.inner)?.with_friction(friction.map(|f| f.inner))?, terrain })
    }

    /// The gearhead friction per wheel, or None (the thesis's model).
    #[getter]
    fn friction(&self) -> Option<PyFriction> {
        self.inner.friction().map(|&inner| PyFriction { inner })
    }

    #[getter]
    fn params(&self) -> PyRobotParams {
        PyRobotParams { inner: *self.inner.params() }
    }

    /// The ground (a twip.Terrain), or None: flat ground.
    #[getter]
    fn terrain(&self) -> Option<PyTerrain> {
        self.terrain.clone()
    }

    /// Pickled as PlanarModel(params, friction, terrain).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> Reduced<'py, (PyRobotParams, Option<PyFriction>, Option<PyTerrain>)> {
        let me = slf.get();
        (slf.get_type().into_any(), (me.params(), me.friction(), me.terrain()))
    }

    fn deriv<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>, u: &Bound<'py, PyAny>) -> PyResult<Arr1<'py>> {
        let x = vector::<7>("x", x)?;
        let u = input::<2>("u", u)?;
        self.check_on_terrain(&x)?;
        let d = match self.on_terrain() {
            Some(m) => m.deriv(&x, &u),
            None => self.inner.deriv(&x, &u),
        };
        finite_derivative(x.as_slice(), d.as_slice())?;
        Ok(to_py_vector(py, &d))
    }

    /// Kinetic plus potential energy [J]; on terrain the potential is from the heights of the
    /// body's and wheels' centres over the flat model's zero (docs/terrain.md).
    fn energy(&self, x: &Bound<'_, PyAny>) -> PyResult<f64> {
        let x = vector::<7>("x", x)?;
        self.check_on_terrain(&x)?;
        Ok(match self.on_terrain() {
            Some(m) => m.energy(&x),
            None => self.inner.energy(&x),
        })
    }

    /// Each wheel's normal force [N] (right, left) at state x under motor torques u: a run
    /// ends "lifted" when one goes negative. On flat ground too (a terrain-less model is
    /// level ground here).
    fn normal_forces(&self, x: &Bound<'_, PyAny>, u: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
        let x = vector::<7>("x", x)?;
        let u = input::<2>("u", u)?;
        self.check_on_terrain(&x)?;
        let m = self.on_terrain().unwrap_or_else(|| TerrainModel::new(self.inner, Terrain::flat()));
        let [n_r, n_l] = m.normal_forces(&x, &u);
        Ok((n_r, n_l))
    }

    /// The mass matrix M(phi) of M nu_dot + h = B u, with nu = (phi_dot, v, omega) (on
    /// terrain, in the ground plane's frame with phi the pitch from its normal).
    fn mass_matrix<'py>(&self, py: Python<'py>, phi: Real) -> CoreResult<Arr2<'py>> {
        Ok(to_py_matrix(py, &self.inner.mass_matrix(scalar("phi", phi.0)?)))
    }

    fn __repr__(&self) -> String {
        match &self.terrain {
            None => "PlanarModel(RobotParams(...))".to_string(),
            Some(_) => "PlanarModel(RobotParams(...), terrain=Terrain(...))".to_string(),
        }
    }
}

/// One RK4 step of either model with the input held over the step.
#[pyfunction]
pub fn rk4_step<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    x: &Bound<'py, PyAny>,
    u: &Bound<'py, PyAny>,
    dt: Real,
) -> PyResult<Arr1<'py>> {
    let dt = crate::errors::positive_param("dt", dt.0)?;
    if let Ok(m) = model.cast::<PySlopeModel>() {
        let x = vector::<4>("x", x)?;
        let next = core_rk4(&m.get().inner, &x, &input::<1>("u", u)?, dt);
        finite_derivative(x.as_slice(), next.as_slice())?;
        return Ok(to_py_vector(py, &next));
    }
    if let Ok(m) = model.cast::<PyPlanarModel>() {
        let m = m.get();
        let x = vector::<7>("x", x)?;
        let u = input::<2>("u", u)?;
        m.check_on_terrain(&x)?;
        let next = match m.on_terrain() {
            Some(t) => core_rk4(&t, &x, &u, dt),
            None => core_rk4(&m.inner, &x, &u, dt),
        };
        finite_derivative(x.as_slice(), next.as_slice())?;
        m.check_on_terrain(&next)?;
        return Ok(to_py_vector(py, &next));
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "model must be a twip.SlopeModel or twip.PlanarModel, got {}",
        model.get_type().name()?
    )))
}

/// A derivative or step that overflowed (a state of absurd size, e.g. a pitch rate of
/// 1e15 rad/s, squared) is an error naming the state, never a silent inf.
fn finite_derivative(x: &[f64], d: &[f64]) -> PyResult<()> {
    match d.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(crate::errors::NonFiniteError::new_err(format!(
            "from x = {x:?}: entry {i} of the result is {} (the state is too large for f64)",
            d[i]
        ))),
    }
}
