//! `twip.envs`' native batches: N robots of `twip/Balance-v0` or `twip/Track-v0` stepped in
//! Rust (`twip_core::envs`), the GIL released while they move.
pub mod balance;
pub mod track;

use std::sync::Arc;

use numpy::ndarray::Array2;
use numpy::{PyArray2, IntoPyArray};
use pyo3::prelude::*;
use twip_core::envs::RealismFor;
use twip_core::TwipError;

use crate::hardware::realism::PyRealism;

/// The rig each drawn robot gets, from the Python `Realism`.
pub(crate) fn realism_for(realism: Option<&PyRealism>) -> Option<RealismFor> {
    realism.map(|r| {
        let r = r.clone();
        Arc::new(move |p: &twip_core::RobotParams<f64>| r.to_core(p)) as RealismFor
    })
}

/// Resets lanes `lanes` through `reset(lanes, seeds)` (the batch's `reset_many`): with
/// `seeds` (one per lane) episode 0 of that seed, else the lane's next episode.
pub(crate) fn reset_lanes(
    py: Python<'_>,
    lanes: &[usize],
    seeds: Option<Vec<u64>>,
    reset: impl FnOnce(&[usize], Option<&[u64]>) -> Result<(), TwipError> + Send,
) -> PyResult<()> {
    py.detach(|| reset(lanes, seeds.as_deref())).map_err(crate::errors::PyTwipError)?;
    Ok(())
}

/// `$class`, a pyclass named `$name` over an `Envs` batch (`inner`) of robots with
/// `$states` states and observations of `$obs` entries (lane l's: `$observation(inner, l)`),
/// with the methods both envs' batches share; each env's own `#[pymethods]` add `new` and
/// the observations. The actions' and the falls' buffers are reused from step to step.
macro_rules! batch_class {
    ($(#[$doc:meta])* $class:ident, $name:literal, $envs:ty, $states:literal, $obs:expr, $observation:expr) => {
        $(#[$doc])*
        #[pyclass(name = $name, module = "twip._core")]
        pub struct $class {
            inner: $envs,
            actions: Vec<f64>,
            fell: Vec<bool>,
            /// Every robot's observation (rows of `$obs`) made since the last step (the
            /// ideal plant's true ones, which the rewards read), handed out once by
            /// `observations` instead of made again; a reset makes the rows of the lanes it
            /// starts anew.
            kept: Option<Vec<f64>>,
        }

        impl $class {
            /// The kept observations after `lanes` started anew (`reset`, which gave
            /// `reset`): those lanes' rows made again, the others' as they were; none kept
            /// after an error or a reset of many lanes (the rows are then made on the
            /// threads when asked for).
            fn refresh_kept(&mut self, lanes: &[usize], reset: &PyResult<()>) {
                let (inner, kept) = (&self.inner, &mut self.kept);
                match kept.as_mut() {
                    Some(rows) if reset.is_ok() && lanes.len() <= $crate::envs::KEPT_REFRESH => {
                        for &l in lanes {
                            let row: [f64; $obs] = ($observation)(inner, l);
                            rows[l * $obs..(l + 1) * $obs].copy_from_slice(&row);
                        }
                    }
                    _ => *kept = None,
                }
            }
        }

        impl $class {
            fn wrap(inner: $envs) -> Self {
                Self { inner, actions: Vec::new(), fell: Vec::new(), kept: None }
            }

            /// A step's `actions` into the reused buffer and room for the falls (the kept
            /// observations dropped: the step moves the robots); returns the robots' count.
            fn hold_actions(&mut self, actions: numpy::PyReadonlyArray1<'_, f64>) -> PyResult<usize> {
                self.kept = None;
                self.actions.clear();
                self.actions.extend_from_slice(actions.as_slice()?);
                self.fell.resize(self.inner.len(), false);
                Ok(self.inner.len())
            }
        }

        #[pymethods]
        impl $class {
            #[getter]
            fn num_envs(&self) -> usize {
                self.inner.len()
            }

            #[getter]
            fn has_rig(&self) -> bool {
                self.inner.has_rig()
            }

            /// Starts the next episode of each lane in `lanes`: with `seeds` (one per lane),
            /// episode 0 of that seed; else the lane's next episode.
            #[pyo3(signature = (lanes, seeds = None))]
            fn reset(
                &mut self,
                py: Python<'_>,
                lanes: Vec<$crate::convert::Int<usize>>,
                seeds: Option<Vec<$crate::convert::Int<u64>>>,
            ) -> PyResult<()> {
                let (lanes, seeds) = ($crate::convert::ints(lanes), seeds.map($crate::convert::ints));
                let inner = &mut self.inner;
                let reset = $crate::envs::reset_lanes(py, &lanes, seeds, |lanes, seeds| inner.reset_many(lanes, seeds));
                self.refresh_kept(&lanes, &reset);
                reset
            }

            /// One control period of every robot under `actions` (the model's inputs of
            /// each robot, robot after robot); returns which fell.
            fn step<'py>(&mut self, py: Python<'py>, actions: numpy::PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, numpy::PyArray1<bool>>> {
                self.hold_actions(actions)?;
                let (inner, actions, fell) = (&mut self.inner, &self.actions, &mut self.fell);
                py.detach(|| inner.step(actions, fell)).map_err(crate::errors::PyTwipError)?;
                Ok(numpy::PyArray1::from_slice(py, &self.fell))
            }

            /// Every robot's true state (num_envs rows).
            fn states<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
                let inner = &self.inner;
                $crate::envs::rows::<$states>(py, inner.len(), |out| inner.rows_into(out, |envs, l| envs.state(l).data.0[0]))
            }

            /// Every robot's (seed, episode) key, as two uint64 arrays.
            fn keys<'py>(&self, py: Python<'py>) -> (Bound<'py, numpy::PyArray1<u64>>, Bound<'py, numpy::PyArray1<u64>>) {
                use numpy::IntoPyArray;
                let (seeds, episodes): (Vec<u64>, Vec<u64>) = (0..self.inner.len()).map(|l| self.inner.key(l)).unzip();
                (seeds.into_pyarray(py), episodes.into_pyarray(py))
            }
        }
    };
}
pub(crate) use batch_class;

/// What a NEXT_STEP step (`step_next`) hands back: which robots fell, their rewards, and
/// their true states and observations after the restarts.
pub(crate) type NextStep<'py> = (Bound<'py, numpy::PyArray1<bool>>, Bound<'py, numpy::PyArray1<f64>>, Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// Most lanes whose kept observations a reset makes again one by one (with the GIL held);
/// past them the observations are made anew, on the batch's threads.
pub(crate) const KEPT_REFRESH: usize = 512;

/// `n` rows of `W` values as an (n, W) array, which `fill` fills (a batch's `rows_into`, on
/// its threads) with the GIL released.
pub(crate) fn rows<'py, const W: usize>(
    py: Python<'py>,
    n: usize,
    fill: impl FnOnce(&mut [f64]) -> Result<(), TwipError> + Send,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    Ok(rows_array::<W>(py, n, filled_rows::<W>(py, n, fill)?))
}

/// `n` rows of `W` values, which `fill` fills with the GIL released.
pub(crate) fn filled_rows<const W: usize>(
    py: Python<'_>,
    n: usize,
    fill: impl FnOnce(&mut [f64]) -> Result<(), TwipError> + Send,
) -> PyResult<Vec<f64>> {
    let mut data = vec![0.0; n * W];
    py.detach(|| fill(&mut data)).map_err(crate::errors::PyTwipError)?;
    Ok(data)
}

/// `n` rows of `W` values (`data`) as an (n, W) array, without a copy.
pub(crate) fn rows_array<'py, const W: usize>(py: Python<'py>, n: usize, data: Vec<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_vec((n, W), data).expect("n rows of W").into_pyarray(py)
}
