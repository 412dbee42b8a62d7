//! `twip.Terrain`: the ground the 3-DOF model can stand on (docs/terrain.md).
use std::sync::Arc;

use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use twip_core::model::terrain::{Grid, Terrain};
use twip_core::sweep::terrain::SweepTerrain;
use twip_core::TwipError;

use crate::convert::{real, real_array, Real};
use crate::errors::{CoreResult, ShapeError};


/// A ground shape: a height z = h(x, y) [m] and its gradient. Build one with
/// `Terrain.plane`, `Terrain.ramp`, `Terrain.bumps` or `Terrain.grid`.
#[pyclass(name = "Terrain", module = "twip", frozen)]
#[derive(Clone)]
pub struct PyTerrain {
    pub inner: Terrain<f64>,
    /// What rebuilds it (pickling, repr): the constructor's name and arguments.
    recipe: Recipe,
}

#[derive(Clone)]
enum Recipe {
    Plane(f64, f64),
    Ramp(f64, f64, f64, f64),
    Bumps(f64, f64),
    Grid(Vec<f64>, Vec<f64>, Vec<f64>),
}

impl PyTerrain {
    /// What a sweep's slope and heading axes redraw of this terrain.
    pub(crate) fn sweep_terrain(&self) -> SweepTerrain {
        match self.recipe {
            Recipe::Plane(slope, uphill_heading) => SweepTerrain::Plane { slope, uphill_heading },
            Recipe::Ramp(slope, uphill_heading, start, blend) => SweepTerrain::Ramp { slope, uphill_heading, start, blend },
            _ => SweepTerrain::Fixed(self.inner.clone()),
        }
    }

    /// A sweep sample's terrain: `terrain` at `ground` = [slope, uphill heading] (`given`,
    /// the model's own, when it has no plane to redraw; level ground when there is none).
    pub(crate) fn of_sweep(terrain: &SweepTerrain, [slope, heading]: [f64; 2], given: Option<&PyTerrain>) -> Result<Self, TwipError> {
        let recipe = match *terrain {
            SweepTerrain::Plane { .. } => Recipe::Plane(slope, heading),
            SweepTerrain::Ramp { start, blend, .. } => Recipe::Ramp(slope, heading, start, blend),
            SweepTerrain::Fixed(_) => return Ok(given.cloned().unwrap_or(Self { inner: Terrain::flat(), recipe: Recipe::Plane(0.0, 0.0) })),
        };
        Ok(Self { inner: terrain.at([slope, heading])?, recipe })
    }
}

#[pymethods]
impl PyTerrain {
    /// A plane rising at `slope` [rad, in [0, pi/2)] towards `uphill_heading` [rad from +x].
    #[staticmethod]
    #[pyo3(signature = (slope, uphill_heading = 0.0))]
    fn plane(slope: Real, #[pyo3(from_py_with = real)] uphill_heading: f64) -> CoreResult<Self> {
        let slope = slope.0;
        Ok(Self { inner: Terrain::plane(slope, uphill_heading)?, recipe: Recipe::Plane(slope, uphill_heading) })
    }

    /// Level ground up to the line `start` [m] from the origin along `uphill_heading`, then a
    /// plane of `slope`; the grade rises smoothly (cubic smoothstep) over `blend` [m] past
    /// the line (0: a kink).
    #[staticmethod]
    #[pyo3(signature = (slope, uphill_heading = 0.0, start = 0.0, blend = 0.1))]
    fn ramp(
        slope: Real,
        #[pyo3(from_py_with = real)] uphill_heading: f64,
        #[pyo3(from_py_with = real)] start: f64,
        #[pyo3(from_py_with = real)] blend: f64,
    ) -> CoreResult<Self> {
        let slope = slope.0;
        Ok(Self { inner: Terrain::ramp(slope, uphill_heading, start, blend)?, recipe: Recipe::Ramp(slope, uphill_heading, start, blend) })
    }

    /// An egg-crate of bumps: h = (height/2) sin(2 pi x / wavelength) sin(2 pi y / wavelength),
    /// `height` [m] from hollow to crest, level at the origin.
    #[staticmethod]
    #[pyo3(signature = (height, wavelength))]
    fn bumps(height: Real, wavelength: Real) -> CoreResult<Self> {
        let (height, wavelength) = (height.0, wavelength.0);
        Ok(Self { inner: Terrain::bumps(height, wavelength)?, recipe: Recipe::Bumps(height, wavelength) })
    }

    /// A height map: `z[i, j]` [m] at (`x[i]`, `y[j]`), x and y strictly increasing (at least
    /// 2 points each), heights finite; a C1 bicubic Hermite interpolant between the nodes.
    /// Off the grid there is no ground: the model raises OffTerrainError and a run ends
    /// with the outcome "off_terrain".
    #[staticmethod]
    fn grid(x: &Bound<'_, PyAny>, y: &Bound<'_, PyAny>, z: &Bound<'_, PyAny>) -> PyResult<Self> {
        let axis = |name: &'static str, a: &Bound<'_, PyAny>| -> PyResult<Vec<f64>> {
            let a = real_array(name, a)?;
            let v: numpy::PyReadonlyArray1<'_, f64> =
                a.extract().map_err(|_| ShapeError::new_err(format!("{name} must be a 1-D array of numbers")))?;
            Ok(v.as_slice()?.to_vec())
        };
        let (xs, ys) = (axis("x", x)?, axis("y", y)?);
        let z = real_array("z", z)?;
        let z: PyReadonlyArray2<'_, f64> =
            z.extract().map_err(|_| ShapeError::new_err(format!("z must be a 2-D array of shape ({}, {})", xs.len(), ys.len())))?;
        let z = z.as_array();
        let shape = z.shape();
        if shape != [xs.len(), ys.len()] {
            return Err(ShapeError::new_err(format!("z has shape ({}, {}), expected (len(x), len(y)) = ({}, {})", shape[0], shape[1], xs.len(), ys.len())));
        }
        let heights: Vec<f64> = z.iter().copied().collect();
        let grid = Grid::new(xs.clone(), ys.clone(), &heights).map_err(crate::errors::PyTwipError)?;
        Ok(Self { inner: Terrain::Grid(Arc::new(grid)), recipe: Recipe::Grid(xs, ys, heights) })
    }

    /// (height [m], dh/dx, dh/dy) at (x, y); OffTerrainError off a grid.
    fn local(&self, x: Real, y: Real) -> PyResult<(f64, f64, f64)> {
        let (x, y) = (x.0, y.0);
        let l = self.inner.local(x, y).ok_or_else(|| off_terrain(x, y))?;
        Ok((l.height, l.gx, l.gy))
    }

    /// Whether (x, y) is on the terrain (always, except off a grid).
    fn contains(&self, x: Real, y: Real) -> bool {
        self.inner.contains(x.0, y.0)
    }

    /// The plane's slope [rad] (a plane or a ramp; None for bumps and a grid): a sweep's
    /// `slope` axis draws it.
    #[getter]
    fn slope(&self) -> Option<f64> {
        match self.recipe {
            Recipe::Plane(s, _) | Recipe::Ramp(s, ..) => Some(s),
            _ => None,
        }
    }

    /// The plane's uphill heading [rad from +x] (a plane or a ramp; None for bumps and a
    /// grid): a sweep's `heading` axis draws it.
    #[getter]
    fn uphill_heading(&self) -> Option<f64> {
        match self.recipe {
            Recipe::Plane(_, h) | Recipe::Ramp(_, h, ..) => Some(h),
            _ => None,
        }
    }

    /// Pickled as the constructor call that made it.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, pyo3::types::PyTuple>)> {
        let py = slf.py();
        let me = slf.get();
        let cls = slf.get_type();
        let (name, args) = match &me.recipe {
            Recipe::Plane(a, b) => ("plane", (a, b).into_pyobject(py)?),
            Recipe::Ramp(a, b, c, d) => ("ramp", (a, b, c, d).into_pyobject(py)?),
            Recipe::Bumps(a, b) => ("bumps", (a, b).into_pyobject(py)?),
            Recipe::Grid(x, y, z) => {
                let z = numpy::ndarray::Array2::from_shape_vec((x.len(), y.len()), z.clone()).expect("checked shape");
                let z = numpy::PyArray2::from_owned_array(py, z);
                ("grid", (x.clone(), y.clone(), z).into_pyobject(py)?)
            }
        };
        Ok((cls.getattr(name)?, args))
    }

    pub fn __repr__(&self) -> String {
        match &self.recipe {
            Recipe::Plane(a, b) => format!("Terrain.plane({a:?}, {b:?})"),
            Recipe::Ramp(a, b, c, d) => format!("Terrain.ramp({a:?}, {b:?}, start={c:?}, blend={d:?})"),
            Recipe::Bumps(a, b) => format!("Terrain.bumps({a:?}, {b:?})"),
            Recipe::Grid(x, y, _) => format!("Terrain.grid(<{} x {} nodes>)", x.len(), y.len()),
        }
    }
}

/// The error for a point off the terrain.
pub fn off_terrain(x: f64, y: f64) -> PyErr {
    crate::errors::OffTerrainError::new_err(format!("(x, y) = ({x}, {y}) is off the terrain (outside its grid): no ground there to stand on"))
}
