//! Many shooting runs at once on all cores: the finite-difference columns of a Jacobian
//! (one perturbed robot or start-state set per run) are independent.
use alloc::vec::Vec;
use nalgebra::Vector4;
use rayon::prelude::*;

use super::{Outputs, Play, Shooting, ShootingModel};
use crate::TwipError;

/// Runs `models[k]` from `starts[k]` into `out[k]`, in parallel. With gear play, the first
/// run carries each segment's play on from the previous segment's end and records its
/// impacts and openings step by step; the others start each segment from the first run's
/// play and replay its events ([`Play::Replay`]): a finite difference (the first run the
/// base, the others perturbed) then differences the motion with the impacts' schedule
/// held. A run alone (a trial step) is free: carried. Each `out[k].events` must then have
/// one entry per plant step ([`Shooting::plant_steps`]).
pub fn run_all<M: ShootingModel<f64> + Sync>(
    shooting: &Shooting<'_, f64>,
    models: &[M],
    starts: &[Vec<Vector4<f64>>],
    out: &mut [Outputs<'_, f64>],
) -> Result<(), TwipError> {
    let geared = models.first().is_some_and(|m| m.play().is_some());
    if !geared {
        return models
            .par_iter()
            .zip(starts.par_iter())
            .zip(out.par_iter_mut())
            .try_for_each(|((model, starts), p)| shooting.run(model, starts, p.reborrow(), Play::Held));
    }
    let (base, rest) = out.split_at_mut(1);
    shooting.run(&models[0], &starts[0], base[0].reborrow(), Play::Carry)?;
    let (plays, events) = (&*base[0].plays, &*base[0].events);
    models[1..]
        .par_iter()
        .zip(starts[1..].par_iter())
        .zip(rest.par_iter_mut())
        .try_for_each(|((model, starts), p)| {
            p.plays.copy_from_slice(plays);
            if p.events.len() != events.len() {
                return Err(TwipError::InvalidParameter {
                    name: "events",
                    value: p.events.len() as f64,
                    reason: "each run needs as many gear events as the base run (one per plant step)",
                });
            }
            p.events.copy_from_slice(events);
            shooting.run(model, starts, p.reborrow(), Play::Replay)
        })
}
