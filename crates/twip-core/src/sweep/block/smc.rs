//! The sliding-mode tracker (with or without fuzzy adaptation) on lanes: `SmcLaw::step`
//! on each lane, [`WIDTH`](crate::model::lane::WIDTH) lanes at a time in [`Wide`] numbers
//! (the fuzzy sets' selects and guards, which a loop over lanes would not vectorise).
use super::planar::{lane_ref, PlanarLaneLaw};
use super::{chunk, put, CHUNKS};
use crate::control::fuzzy_basis::Trapezoid;
use crate::control::smc::SmcTracker;
use crate::control::trajectory::PlanarRef;
use crate::control::Controller;
use crate::model::lane::{fill, Lane, Wide};
use crate::model::planar::deriv;
use crate::sweep::lanes::{Lanes, LANES};

/// The prototype, whose steady pitch is cached as its update caches it, and its fuzzy
/// sets in lanes' numbers.
#[derive(Clone, Debug)]
pub struct SmcLanes {
    controller: SmcTracker<f64>,
    /// The yaw basis's sets and the pitch basis's.
    sets: [[[Trapezoid<Wide>; 3]; 2]; 2],
}

/// Each lane's fuzzy weights Ĉ1, Ĉ2, one array per weight.
#[derive(Clone, Debug)]
pub struct SmcState {
    c1: [Lanes; 9],
    c2: [Lanes; 9],
}

impl SmcLanes {
    /// `None` when a set is not a trapezoid, or when the tracker without adaptation takes
    /// its equivalent control from a model with gearhead friction (the lanes evaluate the
    /// thesis's frictionless model): such sweeps take the general runner.
    pub fn new(prototype: &SmcTracker<f64>) -> Option<Self> {
        if prototype.adaptation().is_none() && prototype.model().friction().is_some() {
            return None;
        }
        let (yaw, pitch) = prototype.bases();
        let mut controller = *prototype;
        controller.reset();
        Some(Self { controller, sets: [yaw.trapezoids(Wide::splat)?, pitch.trapezoids(Wide::splat)?] })
    }
}

impl PlanarLaneLaw for SmcLanes {
    type State = SmcState;

    fn period(&self) -> f64 {
        self.controller.period()
    }

    fn start(&self) -> SmcState {
        let (c1, c2) = self.controller.weights();
        SmcState { c1: c1.map(|w| [w; LANES]), c2: c2.map(|w| [w; LANES]) }
    }

    #[inline(always)]
    fn update(&mut self, state: &mut SmcState, x: &[Lanes; 7], r: &PlanarRef<f64>, u: &mut [Lanes; 2]) {
        let phi_s = Wide::splat(self.controller.cached_steady_pitch(r.v, r.omega));
        let law = self.controller.law(Wide::splat, [&self.sets[0], &self.sets[1]]);
        let r = lane_ref(r);
        let idle = [Wide::splat(0.0); 2];
        for c in 0..CHUNKS {
            let y: [Wide; 7] = fill(|i| chunk(&x[i], c));
            let c1: [Wide; 9] = fill(|j| chunk(&state.c1[j], c));
            let c2: [Wide; 9] = fill(|j| chunk(&state.c2[j], c));
            let step = law.step(&y, &r, phi_s, &c1, &c2, || deriv(&law.model, &y, idle));
            for j in 0..9 {
                put(&mut state.c1[j], c, step.c1[j]);
                put(&mut state.c2[j], c, step.c2[j]);
            }
            put(&mut u[0], c, step.u[0]);
            put(&mut u[1], c, step.u[1]);
        }
    }
}
