//! `twip.GradeFeedForward`: a 3-DOF tracker with the grade's feed-forward of a terrain
//! (docs/terrain.md).
use pyo3::prelude::*;
use twip_core::control::grade::GradeFeedForward;
use twip_core::model::terrain_model::TerrainModel;
use twip_core::PlanarModel;

use crate::errors::PyTwipError;
use crate::model::params::PyRobotParams;
use crate::model::terrain::PyTerrain;
use crate::settings::Reduced;
use crate::sim::simulate_planar::PlanarController;

/// `tracker` (a twip.PidTracker or SmcTracker designed on flat ground) with the grade's
/// feed-forward on `terrain`: at each update the local plane under the robot gives the rest
/// pitch and wheel torques of a robot with `params` standing there facing its heading; the
/// tracker sees its pitch from that rest pitch and the torques are added to its output
/// (held within its motor's torques). Run it with twip.simulate like the tracker itself.
#[pyclass(name = "GradeFeedForward", module = "twip", frozen)]
pub struct PyGradeFeedForward {
    tracker: Py<PyAny>,
    terrain: PyTerrain,
    params: PyRobotParams,
}

#[pymethods]
impl PyGradeFeedForward {
    #[new]
    fn new(tracker: &Bound<'_, PyAny>, terrain: &PyTerrain, params: &PyRobotParams) -> PyResult<Self> {
        PlanarController::extract(tracker)?;
        Ok(Self { tracker: tracker.clone().unbind(), terrain: terrain.clone(), params: params.clone() })
    }

    /// The tracker it wraps.
    #[getter]
    fn tracker(&self, py: Python<'_>) -> Py<PyAny> {
        self.tracker.clone_ref(py)
    }

    /// The terrain whose grade it feeds forward.
    #[getter]
    fn terrain(&self) -> PyTerrain {
        self.terrain.clone()
    }

    /// The robot whose rest on the grade it feeds forward.
    #[getter]
    fn params(&self) -> PyRobotParams {
        self.params.clone()
    }

    /// The tracker's update period [s].
    #[getter]
    fn period(&self, py: Python<'_>) -> PyResult<f64> {
        use twip_core::control::Controller;
        Ok(PlanarController::extract(self.tracker.bind(py))?.period())
    }

    /// Pickled as GradeFeedForward(tracker, terrain, params).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> Reduced<'py, (Py<PyAny>, PyTerrain, PyRobotParams)> {
        let me = slf.get();
        (slf.get_type().into_any(), (me.tracker.clone_ref(slf.py()), me.terrain.clone(), me.params.clone()))
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!("GradeFeedForward({}, {})", self.tracker.bind(py).repr()?, self.terrain.__repr__()))
    }
}

impl PyGradeFeedForward {
    /// The core controller: the tracker (at `control_period`, if given) wrapped.
    pub(crate) fn core(&self, py: Python<'_>, control_period: Option<f64>) -> PyResult<GradeFeedForward<f64, PlanarController>> {
        let mut inner = PlanarController::extract(self.tracker.bind(py))?;
        if let Some(p) = control_period {
            inner = inner.with_period(p)?;
        }
        let motor = match &inner {
            PlanarController::Pid(c) => Some(*c.motor()),
            PlanarController::Smc(c) => c.motor().copied(),
        };
        let ground = TerrainModel::new(PlanarModel::new(self.params.inner).map_err(PyTwipError)?, self.terrain.inner.clone());
        Ok(GradeFeedForward::new(inner, ground, motor))
    }
}
