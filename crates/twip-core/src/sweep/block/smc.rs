//! The sliding-mode tracker (with or without fuzzy adaptation) on lanes: `SmcLaw::step`
//! on each lane, [`WIDTH`](crate::model::lane::WIDTH) lanes at a time in [`Wide`] numbers
//! (the fuzzy sets' selects and guards, which a loop over lanes would not vectorise).
use super::law::{LaneLaw, Planar};
use super::planar::lane_ref;
use super::{chunk, out_of_line_in, put, CHUNKS};
use crate::control::fuzzy_basis::Trapezoid;
use crate::control::fuzzy_grid::{RuleBase, Sized, MAX_RULES, MAX_SETS};
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
    sets: Sets,
}

/// The yaw basis's sets and the pitch basis's: 3 × 3 fixed when compiling (the thesis's,
/// as fast as before other sizes came), any other n × n sized at run time.
#[derive(Clone, Debug)]
enum Sets {
    Three([[[Trapezoid<Wide>; 3]; 2]; 2]),
    Sized([[[Trapezoid<Wide>; MAX_SETS]; 2]; 2], usize),
}

/// Each lane's fuzzy weights Ĉ1, Ĉ2 (n² each), one array per weight.
#[derive(Clone, Debug)]
pub struct SmcState {
    c1: Vec<Lanes>,
    c2: Vec<Lanes>,
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
        let sets = [yaw.trapezoids(Wide::splat)?, pitch.trapezoids(Wide::splat)?];
        let sets = match yaw.n() {
            3 => Sets::Three(sets.map(|b| b.map(|row| [row[0], row[1], row[2]]))),
            n => Sets::Sized(sets, n),
        };
        Some(Self { controller, sets })
    }

    /// The law on every chunk of lanes, with the bases `bases` of `R` rule slots.
    #[inline(always)]
    fn update_with<const R: usize, B: RuleBase<Wide, R>>(
        controller: &SmcTracker<f64>,
        phi_s: f64,
        bases: [&B; 2],
        state: &mut SmcState,
        x: &[Lanes; 7],
        r: &PlanarRef<f64>,
        u: &mut [Lanes; 2],
    ) {
        let phi_s = Wide::splat(phi_s);
        let law = controller.law(Wide::splat, bases);
        let r = lane_ref(r);
        let idle = [Wide::splat(0.0); 2];
        let rules = bases[0].rules();
        let zero = Wide::splat(0.0);
        for c in 0..CHUNKS {
            let y: [Wide; 7] = fill(|i| chunk(&x[i], c));
            let (w1, w2) = (&state.c1[..rules], &state.c2[..rules]);
            let c1: [Wide; R] = fill(|j| w1.get(j).map_or(zero, |w| chunk(w, c)));
            let c2: [Wide; R] = fill(|j| w2.get(j).map_or(zero, |w| chunk(w, c)));
            let step = law.step(&y, &r, phi_s, &c1, &c2, #[inline(always)] || deriv(&law.model, &y, idle));
            for (j, (w1, w2)) in state.c1.iter_mut().zip(state.c2.iter_mut()).enumerate() {
                put(w1, c, step.c1[j]);
                put(w2, c, step.c2[j]);
            }
            put(&mut u[0], c, step.u[0]);
            put(&mut u[1], c, step.u[1]);
        }
    }
}

impl LaneLaw for SmcLanes {
    type Shape = Planar;
    type State = SmcState;

    fn period(&self) -> f64 {
        self.controller.period()
    }

    fn start(&self) -> SmcState {
        let (c1, c2) = self.controller.weights();
        SmcState { c1: c1.iter().map(|w| [*w; LANES]).collect(), c2: c2.iter().map(|w| [*w; LANES]).collect() }
    }

    /// The sized n × n sets' law is a function of its own per kernel copy (`out_of_line_in`),
    /// as `FuzzyLanes`' is, shared by the kernels; the 3 × 3 stays inlined.
    #[inline(always)]
    fn update<const COPY: u8>(&mut self, state: &mut SmcState, x: &[Lanes; 7], r: &PlanarRef<f64>, u: &mut [Lanes; 2]) {
        let phi_s = self.controller.cached_steady_pitch(r.v, r.omega);
        let controller = &self.controller;
        match &self.sets {
            Sets::Three(sets) => Self::update_with::<9, _>(controller, phi_s, [&sets[0], &sets[1]], state, x, r, u),
            Sets::Sized(sets, n) => out_of_line_in::<COPY, _>(#[inline(always)] || {
                let bases = [Sized { sets: &sets[0], n: *n }, Sized { sets: &sets[1], n: *n }];
                Self::update_with::<MAX_RULES, _>(controller, phi_s, [&bases[0], &bases[1]], state, x, r, u)
            }),
        }
    }
}
