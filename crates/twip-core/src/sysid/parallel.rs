//! Many shooting runs at once on all cores: the finite-difference columns of a Jacobian
//! (one perturbed robot or start-state set per run) are independent.
use alloc::vec::Vec;
use nalgebra::Vector4;
use rayon::prelude::*;

use super::{Outputs, Shooting, ShootingModel};
use crate::hardware::backlash::PlayState;
use crate::TwipError;

/// One run's outputs: states, rates and what the sensors see besides per sample, ends and
/// the gear play started from per segment ([`Outputs`]).
pub struct Prediction {
    pub states: Vec<Vector4<f64>>,
    pub rates: Vec<Vector4<f64>>,
    pub sensed: Vec<[f64; 2]>,
    pub ends: Vec<Vector4<f64>>,
    pub plays: Vec<Option<PlayState<f64, 1>>>,
}

impl Prediction {
    pub fn outputs(&mut self) -> Outputs<'_, f64> {
        Outputs { states: &mut self.states, rates: &mut self.rates, sensed: &mut self.sensed, ends: &mut self.ends, plays: &mut self.plays }
    }
}

/// Runs `models[k]` from `starts[k]` into `out[k]`, in parallel. With gear play, the first
/// run carries each segment's play on from the previous segment's end, and the others
/// start each segment from the first run's: a finite difference (the first run the base,
/// the others perturbed) then holds the play where the base has it.
pub fn run_all<M: ShootingModel<f64> + Sync>(
    shooting: &Shooting<'_, f64>,
    models: &[M],
    starts: &[Vec<Vector4<f64>>],
    out: &mut [Prediction],
) -> Result<(), TwipError> {
    let geared = models.first().is_some_and(|m| m.play().is_some());
    if !geared {
        return models
            .par_iter()
            .zip(starts.par_iter())
            .zip(out.par_iter_mut())
            .try_for_each(|((model, starts), p)| shooting.run(model, starts, p.outputs(), false));
    }
    let (base, rest) = out.split_at_mut(1);
    shooting.run(&models[0], &starts[0], base[0].outputs(), true)?;
    let plays = &base[0].plays;
    models[1..]
        .par_iter()
        .zip(starts[1..].par_iter())
        .zip(rest.par_iter_mut())
        .try_for_each(|((model, starts), p)| {
            p.plays.copy_from_slice(plays);
            shooting.run(model, starts, p.outputs(), false)
        })
}
