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

/// Resets lanes `lanes` through `reset(lane, seed)`: with `seeds` (one per lane) episode 0
/// of that seed, else the lane's next episode.
pub(crate) fn reset_lanes(
    py: Python<'_>,
    lanes: &[usize],
    seeds: Option<Vec<u64>>,
    mut reset: impl FnMut(usize, Option<u64>) -> Result<(), TwipError> + Send,
) -> PyResult<()> {
    if let Some(s) = &seeds {
        if s.len() != lanes.len() {
            return Err(crate::errors::invalid("seeds", s.len() as f64, "one seed per lane reset").into());
        }
    }
    py.detach(|| {
        for (i, &l) in lanes.iter().enumerate() {
            reset(l, seeds.as_ref().map(|s| s[i]))?;
        }
        Ok::<(), TwipError>(())
    })
    .map_err(crate::errors::PyTwipError)?;
    Ok(())
}

/// `n` rows of `W` values as an (n, W) array.
pub(crate) fn rows<'py, const W: usize>(py: Python<'py>, n: usize, row: impl Fn(usize) -> [f64; W]) -> Bound<'py, PyArray2<f64>> {
    let data: Vec<f64> = (0..n).flat_map(row).collect();
    Array2::from_shape_vec((n, W), data).expect("n rows of W").into_pyarray(py)
}
