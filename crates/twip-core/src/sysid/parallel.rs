//! Many shooting runs at once on all cores: the finite-difference columns of a Jacobian
//! (one perturbed robot or start-state set per run) are independent.
use nalgebra::Vector4;
use rayon::prelude::*;

use super::{Shooting, ShootingModel};
use crate::TwipError;

/// One run's outputs: states and rates per sample, ends per segment.
pub struct Prediction {
    pub states: Vec<Vector4<f64>>,
    pub rates: Vec<Vector4<f64>>,
    pub ends: Vec<Vector4<f64>>,
}

/// Runs `models[k]` from `starts[k]` into `out[k]`, in parallel.
pub fn run_all<M: ShootingModel<f64> + Sync>(
    shooting: &Shooting<'_, f64>,
    models: &[M],
    starts: &[Vec<Vector4<f64>>],
    out: &mut [Prediction],
) -> Result<(), TwipError> {
    models
        .par_iter()
        .zip(starts.par_iter())
        .zip(out.par_iter_mut())
        .try_for_each(|((model, starts), p)| shooting.run(model, starts, &mut p.states, &mut p.rates, &mut p.ends))
}
