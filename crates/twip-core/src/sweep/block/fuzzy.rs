//! Fuzzy adaptive backstepping + PD on lanes: `control::fuzzy::Law` on each lane, whose
//! weights Ŝ adapt on their own.
use super::LaneLaw;
use crate::control::fuzzy::{FuzzyController, FuzzyGains, Law};
use crate::control::fuzzy_basis::{Member, Prepared, Trapezoid};
use crate::control::reference::SpeedRef;
use crate::control::Controller;
use super::{chunk, put, state_chunk, CHUNKS};
use crate::model::lane::{fill, Lane, Wide};
use crate::model::slope::SlopeCoefficients;
use crate::sweep::lanes::{Lanes, LANES};

/// The prototype's constants in lanes' numbers, shared by the lanes.
#[derive(Clone, Debug)]
pub struct FuzzyLanes {
    controller: FuzzyController<f64>,
    gains: FuzzyGains<Wide>,
    sets: Sets,
    model: SlopeCoefficients<Wide>,
    /// (θ̇_ref, φ_s) of the last reference speed.
    steady: Option<(f64, f64)>,
}

/// The basis's sets in lanes' numbers: all trapezoids (the thesis's), evaluated without a
/// match per set (measured: the match costs the trapezoid law 21 % more instructions), or
/// any sets.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)] // both ~2.5 KB, one per worker's law: no box needed
enum Sets {
    Trapezoids([[Trapezoid<Wide>; 3]; 2]),
    Any([[Prepared<Wide>; 3]; 2]),
}

/// Each lane's weights Ŝ and the PD's integral, one array per quantity.
#[derive(Clone, Debug)]
pub struct FuzzyState {
    s_hat: [Lanes; 9],
    e_int: Lanes,
}

impl FuzzyLanes {
    /// Any sets: trapezoids, triangles and Gaussians (whose e^x is the lanes' polynomial).
    pub fn new(prototype: &FuzzyController<f64>) -> Self {
        let g = prototype.gains();
        let k = prototype.model().coefficients();
        let f = Wide::splat;
        Self {
            controller: *prototype,
            gains: FuzzyGains { k1: f(g.k1), k2: f(g.k2), kp: f(g.kp), kd: f(g.kd), ki: f(g.ki) },
            sets: match prototype.basis().trapezoids(Wide::splat) {
                Some(trapezoids) => Sets::Trapezoids(trapezoids),
                None => Sets::Any(prototype.basis().prepared_in(Wide::splat)),
            },
            model: SlopeCoefficients {
                m11: f(k.m11),
                m22: f(k.m22),
                m11_m22: f(k.m11_m22),
                mrl: f(k.mrl),
                mrl_cos: f(k.mrl_cos),
                mrl_sin: f(k.mrl_sin),
                rotor: f(k.rotor),
                mgl: f(k.mgl),
                grade: f(k.grade),
                torque_per_amp: f(k.torque_per_amp),
                mu_bearing: f(k.mu_bearing),
                mu_ground: f(k.mu_ground),
                sin_slope: f(k.sin_slope),
                cos_slope: f(k.cos_slope),
            },
            steady: None,
        }
    }

    /// φ_s at `speed`, as `FuzzyController::update` finds it: cached, since speeds change
    /// rarely.
    #[inline(always)]
    fn steady_pitch(&mut self, speed: f64) -> f64 {
        match self.steady {
            Some((s, phi_s)) if s == speed => phi_s,
            _ => self.solve_steady_pitch(speed),
        }
    }

    /// The law with `sets` on every chunk of lanes.
    #[inline(always)]
    fn update_with<M: Member<Wide>>(&self, sets: &[[M; 3]; 2], phi_s: Wide, state: &mut FuzzyState, x: &[Lanes; 4], r: &SpeedRef<f64>, u: &mut Lanes) {
        let a = self.controller.adaptation();
        let law = Law {
            gains: self.gains,
            gamma: Wide::splat(a.gamma),
            sigma: Wide::splat(a.sigma),
            adapt: a.enabled,
            period: Wide::splat(self.period()),
            sets,
            model: &self.model,
        };
        let (theta, theta_dot) = (Wide::splat(r.theta), Wide::splat(r.theta_dot));
        for c in 0..CHUNKS {
            let mut s_hat: [Wide; 9] = fill(|j| chunk(&state.s_hat[j], c));
            let mut e_int = chunk(&state.e_int, c);
            let step = law.update(&mut s_hat, &mut e_int, phi_s, &state_chunk(x, c), theta, theta_dot);
            for (j, s) in s_hat.iter().enumerate() {
                put(&mut state.s_hat[j], c, *s);
            }
            put(&mut state.e_int, c, e_int);
            put(u, c, step.u);
        }
    }

    #[cold]
    #[inline(never)]
    fn solve_steady_pitch(&mut self, speed: f64) -> f64 {
        let phi_s = self.controller.steady_pitch(speed).unwrap_or(0.0);
        self.steady = Some((speed, phi_s));
        phi_s
    }
}

impl LaneLaw for FuzzyLanes {
    type State = FuzzyState;

    fn period(&self) -> f64 {
        self.controller.period()
    }

    fn start(&self) -> FuzzyState {
        let s0 = self.controller.initial_weights();
        FuzzyState { s_hat: s0.map(|w| [w; LANES]), e_int: [0.0; LANES] }
    }

    #[inline(always)]
    fn update(&mut self, state: &mut FuzzyState, x: &[Lanes; 4], r: &SpeedRef<f64>, u: &mut Lanes) {
        let phi_s = Wide::splat(self.steady_pitch(r.theta_dot));
        match &self.sets {
            Sets::Trapezoids(sets) => self.update_with(sets, phi_s, state, x, r, u),
            Sets::Any(sets) => self.update_with(sets, phi_s, state, x, r, u),
        }
    }
}

