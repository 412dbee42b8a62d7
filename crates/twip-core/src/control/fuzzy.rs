//! Fuzzy adaptive backstepping on the pitch with a PD on the wheel position
//! (thesis 4.37–4.56, 4.62–4.63; errata F1–F8 applied):
//!
//! ```text
//! e1 = φ − φ_s(θ̇_ref)          φ_s: corrected (4.42) on the controller's own model
//! z2 = φ̇ + k1 e1               (α1 = −k1 e1)
//! u  = −(1/G1) [e1 + Ŝᵀξ(φ, φ̇) + k1 φ̇ + (½ + k2) z2] + kp e + kd ė + ki ∫e dt
//! Ŝ̇  = Γ⁻¹ z2 ξ − σ Ŝ          (σ-modification; Γ = γ I)
//! e  = θ_ref − θ,  ė = θ̇_ref − θ̇
//! ```
//!
//! G1 is the first entry of G = M(φ)⁻¹ η τ_i [−1, 1]ᵀ: the controller knows how the
//! current moves the pitch (from its own model, at the measured φ) and learns the rest of
//! φ̈, F1, with the fuzzy system Ŝᵀξ.
//!
//! `ki` is ours, not the thesis's (0 by default): σ slowly hands a steady load (the slope)
//! from Ŝ to kp·e, so without it the robot creeps towards e = u_s/kp while it holds; an
//! integral on e holds the stop (docs/scenarios.md, "Stops").
//!
//! Discrete time, as on the robot: every `period` the law is evaluated with the current
//! Ŝ and ∫e, then both advance by forward Euler over the period (σ·period < 1 keeps the
//! leakage step a contraction).
use nalgebra::SVector;

use crate::error::invalid;
use crate::control::Controller;
use crate::control::fuzzy_grid::{FuzzyGrid, RuleBase, MAX_RULES};
use crate::control::reference::{SpeedRef, SpeedSchedule};
use crate::model::lane::Lane;
use crate::model::slope::{inverse_pitch_input_gain, inverse_pitch_input_gain_at, pitch_input_gain, SlopeCoefficients, SlopeModel};
use crate::{c, Real, TwipError};

/// k1, k2 of the backstepping, kp, kd of the PD on the wheel position (4.56), and our
/// optional integral gain ki. kp, kd (and a useful ki) are negative in the thesis's
/// sign convention: a positive current tips the body back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FuzzyGains<T> {
    pub k1: T,
    pub k2: T,
    pub kp: T,
    pub kd: T,
    pub ki: T,
}

impl<T: Real> FuzzyGains<T> {
    /// The thesis's slope gains (4.1.2): k1 = 10, k2 = 13, kp = −0.01, kd = −0.09.
    pub fn thesis_slope() -> Self {
        Self { k1: c(10.0), k2: c(13.0), kp: c(-0.01), kd: c(-0.09), ki: T::zero() }
    }

    /// The thesis's flat gains (4.2.1): k1 = 30, k2 = 33, kp = −0.1, kd = −0.9.
    pub fn thesis_flat() -> Self {
        Self { k1: c(30.0), k2: c(33.0), kp: c(-0.1), kd: c(-0.9), ki: T::zero() }
    }

    fn validate(self) -> Result<Self, TwipError> {
        for (name, v) in [("k1", self.k1), ("k2", self.k2)] {
            if !(v.is_finite() && v > T::zero()) {
                return Err(invalid(name, v, "must be finite and > 0"));
            }
        }
        for (name, v) in [("kp", self.kp), ("kd", self.kd), ("ki", self.ki)] {
            if !v.is_finite() {
                return Err(invalid(name, v, "must be finite"));
            }
        }
        Ok(self)
    }
}

/// The adaptation law (4.49): Γ = `gamma`·I, leakage `sigma`. With `enabled = false` the
/// weights stay at their initial value (plain backstepping + PD with a fixed Ŝ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptation<T> {
    pub gamma: T,
    pub sigma: T,
    pub enabled: bool,
}

/// twip's Γ = γ I (not in the thesis; docs/scenarios.md says why).
pub const DEFAULT_GAMMA: f64 = 0.02;
/// twip's σ [1/s] (not in the thesis; docs/scenarios.md says why).
pub const DEFAULT_SIGMA: f64 = 0.05;

impl<T: Real> Adaptation<T> {
    /// (4.49)'s forward Euler step over `period` as Ŝ ← keep · Ŝ + (z2 · per_z2) · ξ:
    /// (keep, per_z2) = (1 − period σ, period / γ), constants of the law, so an update
    /// neither divides nor multiplies out the leakage per weight.
    pub(crate) fn euler(&self, period: T) -> (T, T) {
        (T::one() - period * self.sigma, period / self.gamma)
    }
}

impl<T: Real> Default for Adaptation<T> {
    fn default() -> Self {
        Self { gamma: c(DEFAULT_GAMMA), sigma: c(DEFAULT_SIGMA), enabled: true }
    }
}

/// Names of [`FuzzyController::internals`] of the thesis's 3 × 3 grid, in order: ξ, Ŝ
/// before the update, then the law's scalars ([`fuzzy_internal_names`] for any n).
pub const FUZZY_INTERNALS: [&str; 24] = [
    "xi1", "xi2", "xi3", "xi4", "xi5", "xi6", "xi7", "xi8", "xi9", //
    "S1", "S2", "S3", "S4", "S5", "S6", "S7", "S8", "S9", //
    "z2", "e1", "phi_s", "V2", "e", "e_int",
];

/// ξ1…ξk, S1…Sk (k = n²), then the law's scalars, as literals: the names are `'static`.
macro_rules! names {
    ($($k:literal)*) => {
        &[$(concat!("xi", $k),)* $(concat!("S", $k),)* "z2", "e1", "phi_s", "V2", "e", "e_int"]
    };
}

/// Names of the internals of an n × n grid's controller, in order (n from 2 to
/// [`crate::control::fuzzy_grid::MAX_SETS`]; none for any other n, which no grid has).
pub fn fuzzy_internal_names(n: usize) -> &'static [&'static str] {
    const N2: &[&str] = names!(1 2 3 4);
    const N4: &[&str] = names!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16);
    const N5: &[&str] = names!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25);
    const N6: &[&str] = names!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32 33 34 35 36);
    const N7: &[&str] = names!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32 33 34 35 36 37 38 39 40 41 42 43 44 45 46 47 48 49);
    match n {
        2 => N2,
        3 => &FUZZY_INTERNALS,
        4 => N4,
        5 => N5,
        6 => N6,
        7 => N7,
        _ => &[],
    }
}

/// The law's scalars logged after ξ and Ŝ.
const SCALARS: usize = 6;
/// Room for the internals of the largest grid.
const MAX_INTERNALS: usize = 2 * MAX_RULES + SCALARS;

/// The discrete-time fuzzy adaptive backstepping + PD controller.
#[derive(Clone, Copy, Debug)]
pub struct FuzzyController<T: Real> {
    model: SlopeModel<T>,
    basis: FuzzyGrid<T>,
    gains: FuzzyGains<T>,
    adaptation: Adaptation<T>,
    period: T,
    /// The weights' start and current values, the first `basis.rules()` in use.
    s0: [T; MAX_RULES],
    s_hat: [T; MAX_RULES],
    e_int: T,
    /// (θ̇_ref, φ_s) of the last reference speed seen: speeds change rarely.
    cache: Option<(T, T)>,
    internals: [T; MAX_INTERNALS],
}

impl<T: Real> FuzzyController<T> {
    /// `model` is the controller's own model (φ_s and G1 come from it; it may differ
    /// from the plant). `basis` is an n × n grid ([`FuzzyGrid`], or the thesis's fixed
    /// [`crate::control::fuzzy_basis::ThesisBasis`]). The weights start at zero.
    pub fn new(
        model: SlopeModel<T>,
        gains: FuzzyGains<T>,
        adaptation: Adaptation<T>,
        basis: impl Into<FuzzyGrid<T>>,
        period: T,
    ) -> Result<Self, TwipError> {
        let gains = gains.validate()?;
        if !(period.is_finite() && period > T::zero()) {
            return Err(invalid("period", period, "must be finite and > 0"));
        }
        if !(adaptation.gamma.is_finite() && adaptation.gamma > T::zero()) {
            return Err(invalid("gamma", adaptation.gamma, "must be finite and > 0 (use adapt=False to freeze the weights)"));
        }
        if !(adaptation.sigma.is_finite() && adaptation.sigma > T::zero()) {
            return Err(invalid("sigma", adaptation.sigma, "must be finite and > 0"));
        }
        if adaptation.sigma * period >= T::one() {
            return Err(invalid("sigma", adaptation.sigma, "sigma * period must be < 1 (forward-Euler leakage)"));
        }
        let basis = FuzzyGrid::new(basis.into().sets())?;
        let zero = [T::zero(); MAX_RULES];
        Ok(Self {
            model,
            basis,
            gains,
            adaptation,
            period,
            s0: zero,
            s_hat: zero,
            e_int: T::zero(),
            cache: None,
            internals: [T::zero(); MAX_INTERNALS],
        })
    }

    /// The thesis's slope gains, twip's sets, Γ and σ, at `period`.
    pub fn thesis_slope(model: SlopeModel<T>, period: T) -> Result<Self, TwipError> {
        Self::new(model, FuzzyGains::thesis_slope(), Adaptation::default(), FuzzyGrid::default(), period)
    }

    /// The thesis's flat gains, twip's sets, Γ and σ, at `period`.
    pub fn thesis_flat(model: SlopeModel<T>, period: T) -> Result<Self, TwipError> {
        Self::new(model, FuzzyGains::thesis_flat(), Adaptation::default(), FuzzyGrid::default(), period)
    }

    /// Starts (and resets) the weights at `s0` (one per rule) instead of zero.
    pub fn with_initial_weights(mut self, s0: impl AsRef<[T]>) -> Result<Self, TwipError> {
        let s0 = s0.as_ref();
        let rules = self.basis.rules();
        if s0.len() != rules {
            return Err(TwipError::Shape { name: "s0", expected: (rules, 1), got: (s0.len(), 1) });
        }
        for (index, v) in s0.iter().enumerate() {
            if !v.is_finite() {
                return Err(TwipError::NonFinite { name: "s0", index, value: crate::to_f64(*v) });
            }
        }
        self.s0[..rules].copy_from_slice(s0);
        self.s_hat = self.s0;
        Ok(self)
    }

    pub fn with_period(self, period: T) -> Result<Self, TwipError> {
        Self::new(self.model, self.gains, self.adaptation, self.basis, period)?.with_initial_weights(self.initial_weights())
    }

    pub fn model(&self) -> &SlopeModel<T> {
        &self.model
    }

    pub fn gains(&self) -> FuzzyGains<T> {
        self.gains
    }

    pub fn adaptation(&self) -> Adaptation<T> {
        self.adaptation
    }

    pub fn basis(&self) -> &FuzzyGrid<T> {
        &self.basis
    }

    /// Ŝ's start, one weight per rule.
    pub fn initial_weights(&self) -> &[T] {
        &self.s0[..self.basis.rules()]
    }

    /// The current weights Ŝ.
    pub fn weights(&self) -> &[T] {
        &self.s_hat[..self.basis.rules()]
    }

    /// Whether what the next update starts from (the weights Ŝ, the error's integral) is finite.
    pub fn state_is_finite(&self) -> bool {
        self.e_int.is_finite() && self.s_hat.iter().all(|w| w.is_finite())
    }

    /// φ_s the controller aims for at a reference speed (corrected (4.42), own model).
    pub fn steady_pitch(&self, theta_dot_ref: T) -> Result<T, TwipError> {
        Ok(self.model.equilibrium(theta_dot_ref)?.0[0])
    }

    /// Fails if some speed of `schedule` (or standing still) has no steady pitch.
    pub fn check_reference(&self, schedule: &SpeedSchedule<T>) -> Result<(), TwipError> {
        self.steady_pitch(T::zero())?;
        for speed in schedule.speeds() {
            self.steady_pitch(speed)?;
        }
        Ok(())
    }

    /// G1 = [M(φ)⁻¹ η τ_i [−1, 1]ᵀ]₀ = −η τ_i (M22 + M12) / det M: how one ampere
    /// accelerates the pitch (negative: the reaction tips the body back). The same as
    /// the thesis's A⁻¹ b̄ of (4.32)–(4.35), whose rows are M's first row and the sum.
    pub fn g1(&self, phi: T) -> T {
        pitch_input_gain(&self.model.coefficients(), phi)
    }
}

/// The controller's constants as its law reads them, in `S` (a run's `T`, a sweep
/// lane's `Fused`), with a rule base `B` of `R` slots (a run's sized grid, or a sweep's
/// fixed or sized sets).
pub(crate) struct Law<'a, S, B> {
    /// By reference: a sweep's lanes build a law per update, and a copy of the gains (320
    /// bytes at eight lanes) was a `memcpy` call each time in the AVX2 copy.
    pub gains: &'a FuzzyGains<S>,
    pub gamma: S,
    /// The adaptation's Euler step ([`Adaptation::euler`]).
    pub keep: S,
    pub per_z2: S,
    /// Adapt the weights Ŝ (else they stay as they are).
    pub adapt: bool,
    pub period: S,
    pub basis: &'a B,
    /// The controller's own model, for g1.
    pub model: &'a SlopeCoefficients<S>,
}

/// An update's input and the values the controller's internals show.
pub(crate) struct Step<S, const R: usize> {
    pub u: S,
    pub xi: [S; R],
    pub z2: S,
    pub e1: S,
    pub v2: S,
    pub e: S,
}

impl<S: Lane, B> Law<'_, S, B> {
    /// The backstepping law (4.36)–(4.56) with the PD on the wheel angle, written once
    /// over [`Lane`]: the input for measurement `y`, steady pitch `phi_s` and the
    /// reference's wheel angle and speed. Adapts `s_hat` (forward Euler with σ-leakage)
    /// and integrates the wheel-angle error into `e_int`. `pitch`: sin and cos of y's pitch
    /// where the caller has them (a sweep's plant), else the law takes its own.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn update<const R: usize>(&self, s_hat: &mut [S; R], e_int: &mut S, phi_s: S, y: &[S; 4], pitch: Option<(S, S)>, theta: S, theta_dot: S) -> Step<S, R>
    where
        B: RuleBase<S, R>,
    {
        let g = &self.gains;
        let half = S::splat(0.5);
        let (phi, phi_dot) = (y[0], y[1]);
        let e1 = phi - phi_s;
        let z2 = phi_dot + g.k1 * e1;
        let xi = self.basis.xi(&[phi, phi_dot]);
        let rules = self.basis.rules();
        // (4.49)'s adaptation waits for z2 alone, not for f̂1, so each weight is read, summed
        // and adapted in one pass: a weight is then dead once adapted, and the lanes' nine
        // weights need not all stay live (in registers, or spilled) between two loops.
        let rate = z2 * self.per_z2;
        // f̂1 = Σ Ŝ_k ξ_k in three running sums (rules k ≡ 0, 1, 2 mod 3): the law's input
        // waits for a chain of three multiply-adds, not nine.
        let mut parts = [S::splat(0.0); 3];
        let mut s_norm2 = S::splat(0.0);
        for (s3, x3) in s_hat[..rules].chunks_mut(3).zip(xi[..rules].chunks(3)) {
            for ((part, s), x) in parts.iter_mut().zip(s3).zip(x3) {
                *part = S::madd(*s, *x, *part);
                s_norm2 = S::madd(*s, *s, s_norm2);
                if self.adapt {
                    *s = S::madd(rate, *x, *s * self.keep);
                }
            }
        }
        let f1_hat = (parts[0] + parts[1]) + parts[2];
        let e = theta - y[2];
        let e_dot = theta_dot - y[3];
        // What does not wait for f̂1 is summed beside it; 1/g1 depends on φ alone, so its
        // division runs beside f̂1's sum too.
        let known = e1 + g.k1 * phi_dot + (half + g.k2) * z2;
        let pd = g.kp * e + g.kd * e_dot + g.ki * *e_int;
        let inverse_g1 = match pitch {
            Some((sin_phi, cos_phi)) => inverse_pitch_input_gain_at(self.model, sin_phi, cos_phi),
            None => inverse_pitch_input_gain(self.model, phi),
        };
        let backstepping = -(f1_hat + known) * inverse_g1;
        let u = backstepping + pd;
        let v2 = half * e1 * e1 + half * z2 * z2 + half * self.gamma * s_norm2;
        *e_int = *e_int + self.period * e;
        Step { u, xi, z2, e1, v2, e }
    }
}

impl<T: Real> Controller<T, 4, 1> for FuzzyController<T> {
    type Reference = SpeedRef<T>;

    fn period(&self) -> T {
        self.period
    }

    fn reset(&mut self) {
        self.s_hat = self.s0;
        self.e_int = T::zero();
        self.cache = None;
        self.internals = [T::zero(); MAX_INTERNALS];
    }

    fn update(&mut self, _t: T, y: &SVector<T, 4>, r: &SpeedRef<T>) -> SVector<T, 1> {
        let phi_s = match self.cache {
            Some((speed, phi_s)) if speed == r.theta_dot => phi_s,
            _ => {
                // Speeds were checked by `check_reference`; an unchecked impossible one
                // aims at standing straight rather than failing mid-run.
                let phi_s = self.steady_pitch(r.theta_dot).unwrap_or(T::zero());
                self.cache = Some((r.theta_dot, phi_s));
                phi_s
            }
        };
        let a = &self.adaptation;
        let (keep, per_z2) = a.euler(self.period);
        let law = Law {
            gains: &self.gains,
            gamma: a.gamma,
            keep,
            per_z2,
            adapt: a.enabled,
            period: self.period,
            basis: &self.basis.sized(),
            model: &self.model.coefficients(),
        };
        let (s_hat, e_int) = (self.s_hat, self.e_int);
        let step = law.update(&mut self.s_hat, &mut self.e_int, phi_s, &[y[0], y[1], y[2], y[3]], None, r.theta, r.theta_dot);
        let rules = self.basis.rules();
        self.internals[..rules].copy_from_slice(&step.xi[..rules]);
        self.internals[rules..2 * rules].copy_from_slice(&s_hat[..rules]);
        self.internals[2 * rules..2 * rules + SCALARS].copy_from_slice(&[step.z2, step.e1, phi_s, step.v2, step.e, e_int]);
        SVector::<T, 1>::new(step.u)
    }

    fn internals(&self) -> &[T] {
        &self.internals[..2 * self.basis.rules() + SCALARS]
    }

    fn internal_names(&self) -> &'static [&'static str] {
        fuzzy_internal_names(self.basis.n())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::metrics::SlopeMetrics;
    use crate::sim::runner::{simulate, Outcome, SimConfig};
    use crate::{Dynamics, RobotParams};
    use nalgebra::Vector4;

    #[test]
    fn g1_is_the_input_column_of_the_model() {
        let model = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.26).unwrap();
        let ctrl = FuzzyController::thesis_slope(model, 0.005).unwrap();
        for phi in [-0.5, 0.0, 0.2, 0.9] {
            let x = Vector4::new(phi, 0.3, 1.0, 2.0);
            let du = model.deriv(&x, &SVector::<f64, 1>::new(1.0)) - model.deriv(&x, &SVector::<f64, 1>::new(0.0));
            assert!((du[1] - ctrl.g1(phi)).abs() < 1e-12 * du[1].abs(), "phi = {phi}");
            assert!(ctrl.g1(phi) < 0.0);
        }
    }

    #[test]
    fn the_adaptation_step_is_the_euler_step_of_4_49() {
        // keep · Ŝ + (z2 · per_z2) · ξ against Ŝ + T (z2 ξ / γ − σ Ŝ) as (4.49) writes it.
        for (gamma, sigma, period) in [(0.02f64, 0.05, 1e-3), (5.0, 20.0, 5e-3), (1e-4, 0.0, 0.01)] {
            let (keep, per_z2) = Adaptation { gamma, sigma, enabled: true }.euler(period);
            for (s, xi, z2) in [(0.3f64, 0.25, -1.7), (-2.0, 1.0, 0.04), (1e-3, 0.5, 30.0), (7.0, 0.0, -3.0)] {
                let direct = s + period * (z2 * xi / gamma - sigma * s);
                let stepped = keep * s + (z2 * per_z2) * xi;
                let scale = s.abs() + (period * z2 * xi / gamma).abs();
                assert!((stepped - direct).abs() <= 4.0 * f64::EPSILON * scale, "{gamma} {sigma} {period}: {stepped} vs {direct}");
            }
        }
    }

    #[test]
    #[cfg(feature = "std")] // the lanes' types
    fn the_inverse_input_gain_is_one_over_g1_on_runs_and_lanes() {
        use crate::model::lane::{Fused, Wide};
        use crate::model::slope::inverse_pitch_input_gain;
        for slope in [0.0, 0.26] {
            let model = SlopeModel::<f64>::new(RobotParams::balanbot(), slope).unwrap();
            let ctrl = FuzzyController::thesis_slope(model, 0.005).unwrap();
            let k = model.coefficients();
            let lanes = k.map(Wide::<8>::splat);
            let fused = k.map(Fused);
            for phi in [-1.2, -0.5, 0.0, 0.2, 0.9, 3.0] {
                let inv = inverse_pitch_input_gain(&k, phi);
                assert!((inv * ctrl.g1(phi) - 1.0).abs() <= 4.0 * f64::EPSILON, "{slope} {phi}");
                let (wide, one) = (inverse_pitch_input_gain(&lanes, Wide::splat(phi)), inverse_pitch_input_gain(&fused, Fused(phi)).0);
                assert!(wide.0.iter().all(|w| w.to_bits() == one.to_bits()), "{slope} {phi}: the lanes' types disagree");
                // Fused and plain roundings differ by what the two sums' cancellation makes of
                // an ulp (det M = M11 M22 − M12², and M22 + M12 where M12 < 0 upside down).
                let m12 = crate::model::slope::m12(&k, phi.sin(), phi.cos(), k.rotor);
                let cancel = (k.m11_m22 + m12 * m12) / (k.m11_m22 - m12 * m12) + (k.m22 + m12.abs()) / (k.m22 + m12).abs();
                assert!((one - inv).abs() <= 4.0 * f64::EPSILON * cancel * inv.abs(), "{slope} {phi}: a lane {one} vs a run {inv}");
            }
        }
    }

    #[test]
    fn slope_run_stays_up_in_f64_and_f32() {
        fn run<T: Real>() -> Outcome<T> {
            let model = SlopeModel::<T>::new(RobotParams::balanbot(), c(15f64.to_radians())).unwrap();
            let mut ctrl = FuzzyController::thesis_slope(model, c(0.005)).unwrap();
            let schedule = SpeedSchedule::constant(c(180f64.to_radians())).unwrap();
            let config = SimConfig { dt: c(1e-3), t_final: c(10.0), fall_limit: c(1.0) };
            let mut metrics = SlopeMetrics::new(model);
            simulate(&model, &mut ctrl, &schedule, &Vector4::zeros(), &config, &mut metrics).unwrap().0
        }
        assert_eq!(run::<f64>(), Outcome::Completed);
        assert_eq!(run::<f32>(), Outcome::Completed);
    }

    #[test]
    fn bad_parameters_are_named() {
        let model = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.0).unwrap();
        let basis = FuzzyGrid::<f64>::default();
        let name = |gains: FuzzyGains<f64>, a: Adaptation<f64>, period: f64| match FuzzyController::new(model, gains, a, basis, period) {
            Err(TwipError::InvalidParameter { name, .. }) => name,
            other => panic!("expected an error, got {other:?}"),
        };
        let g = FuzzyGains::thesis_flat();
        let a = Adaptation::default();
        assert_eq!(name(FuzzyGains { k1: 0.0, ..g }, a, 0.005), "k1");
        assert_eq!(name(FuzzyGains { k2: -1.0, ..g }, a, 0.005), "k2");
        assert_eq!(name(FuzzyGains { ki: f64::NAN, ..g }, a, 0.005), "ki");
        assert_eq!(name(g, Adaptation { gamma: 0.0, ..a }, 0.005), "gamma");
        assert_eq!(name(g, Adaptation { sigma: 0.0, ..a }, 0.005), "sigma");
        assert_eq!(name(g, Adaptation { sigma: 300.0, ..a }, 0.005), "sigma");
        assert_eq!(name(g, a, 0.0), "period");
    }
}
