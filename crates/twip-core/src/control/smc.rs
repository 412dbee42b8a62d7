//! Sliding-mode backstepping trajectory tracker (thesis 4.71–4.98, 4.120–4.121) and its
//! fuzzy adaptive form (4.99–4.119), on the 3-DOF model.
//!
//! ```text
//! errors      e1, e2, e3 = rotation(ψ) (x_r − x, y_r − y), wrap(ψ_r − ψ)        (4.73), (4.75)
//! virtual     λ1 = −k_φ (φ − φ_s)                                              (4.74)
//!             λ2 = v_r cos e3 + k1 e1                                          (4.81)
//!             λ3 = ρ(1 + k3 e1) [k2 ē3 + e2 v_r sin e3 ρ(ē3) + k3 v_r sin e3 + ω_r],  ē3 = e3 + k3 e2   (4.82)
//! yaw         S_η = ω − λ3,   C_y = [λ̇3 − F̂1 − (g_y3 − k_η3) σ(S_η) + k_η4 S_η] / g23      (4.85), (4.106)
//! pitch/speed S1 = r1 S_φ + r2 S_v,  S_φ = φ̇ − λ1,  S_v = v − λ2                (4.92), (4.94)
//!             C_ψ = −F̂2 − (k_s3 − g_y4) σ(S1) − k_s4 S1                            (4.115)
//! wheels      u_r = (C_ψ + C_y)/2,  u_l = (C_ψ − C_y)/2                             (4.120)–(4.121)
//! ```
//!
//! F̂1 and F̂2 are what the equivalent control needs: f23 and
//! (r1 f21 + r2 f22 − r1 λ̇1 − r2 λ̇2)/(r1 g21 + r2 g22). Without fuzzy adaptation they come from
//! the controller's own model (4.89, 4.97); with it they are the fuzzy estimates Ĉ1ᵀξ1, Ĉ2ᵀξ2,
//! adapted by Ĉ̇1 = ξ1 S_η/Γ1 (4.107), Ĉ̇2 = ξ2 S1 (r1 g21 + r2 g22)/Γ2 (4.116), and only
//! g21, g22, g23 come from the model.
//!
//! twip's readings and guards (docs/errata.md T4–T12): r1 acts on the pitch measured positive
//! leaning *backward* ([`PitchSign::Backward`]); the gains follow (4.115)'s sign convention
//! (negative stabilises), including (4.106)'s; σ is sgn, or sat(S/w) in a boundary layer of
//! width w; ρ(x) = 1/x for |x| ≥ δ and x/δ² inside (continuous, odd, bounded by 1/δ); φ_s is the
//! controller model's steady pitch at (v_r, ω_r) (0 in the thesis).
use nalgebra::SVector;

use crate::error::invalid;
use crate::control::Controller;
use crate::control::fuzzy_basis::{GridBasis, Membership};
use crate::control::fuzzy_grid::{FuzzyGrid, RuleBase, MAX_RULES};
use crate::hardware::motor::DcMotor;
use crate::control::pid::relative_wheel_speeds;
use crate::model::lane::{clamp, saturate, Lane};
use crate::model::planar::{accelerations, PlanarCoefficients, PlanarModel};
use crate::control::trajectory::{wrap_angle, PlanarRef};
use crate::{c, Dynamics, Real, TwipError};

/// The gains, SI (torques in N m, rates in rad/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmcGains<T> {
    /// Kinematic backstepping (4.81), (4.82), (4.77), all > 0. The thesis gives none of them.
    pub k1: T,
    pub k2: T,
    pub k3: T,
    /// Pitch virtual control (4.74), > 0; not given either.
    pub k_phi: T,
    /// Second-layer surface (4.94) on the controller's pitch.
    pub r1: T,
    pub r2: T,
    /// (4.115): switching gain (the thesis's second "k3", ≤ 0) and linear gain (< 0) [N m],
    /// and the bound g_ymax4 ≥ 0 on the estimate's error [N m].
    pub k_s3: T,
    pub k_s4: T,
    pub g_y4: T,
    /// (4.106): switching gain ≤ 0 [rad/s²], linear gain < 0 [1/s], g_ymax3 ≥ 0 [rad/s²].
    pub k_eta3: T,
    pub k_eta4: T,
    pub g_y3: T,
}

impl<T: Real> SmcGains<T> {
    /// The published gains (4.3.2), with k_s3, k_s4 and g_ymax4 read in units of
    /// `torque_unit` N m (errata T7: one PWM count, [`DcMotor::torque_per_count`]), and
    /// twip's k1 = k2 = 2, k3 = 4, k_φ = 2 (errata T4; the zero dynamics of S1 = 0 are fastest near k_φ = k1, T6).
    pub fn thesis(torque_unit: T) -> Self {
        Self {
            k1: c(2.0),
            k2: c(2.0),
            k3: c(4.0),
            k_phi: c(2.0),
            r1: c(-25.0),
            r2: c(3.0),
            k_s3: c::<T>(-2.0) * torque_unit,
            k_s4: -torque_unit,
            g_y4: torque_unit,
            k_eta3: c(-2.0),
            k_eta4: c(-5.0),
            g_y3: c(1.0),
        }
    }

    fn validate(&self) -> Result<(), TwipError> {
        let positive = [("k1", self.k1), ("k2", self.k2), ("k3", self.k3), ("k_phi", self.k_phi)];
        for (name, v) in positive {
            if !(v.is_finite() && v > T::zero()) {
                return Err(invalid(name, v, "must be finite and > 0"));
            }
        }
        for (name, v) in [("r1", self.r1), ("r2", self.r2)] {
            if !v.is_finite() {
                return Err(invalid(name, v, "must be finite"));
            }
        }
        const NEG: &str = "must be < 0 (the thesis's convention: negative gains stabilise)";
        const NON_POS: &str = "must be <= 0 (the thesis's convention: negative gains stabilise)";
        let signed = [
            ("k_s3", self.k_s3, false),
            ("k_s4", self.k_s4, true),
            ("k_eta3", self.k_eta3, false),
            ("k_eta4", self.k_eta4, true),
        ];
        for (name, v, strict) in signed {
            if !v.is_finite() || v > T::zero() || (strict && v == T::zero()) {
                return Err(invalid(name, v, if strict { NEG } else { NON_POS }));
            }
        }
        for (name, v) in [("g_y3", self.g_y3), ("g_y4", self.g_y4)] {
            if !(v.is_finite() && v >= T::zero()) {
                return Err(invalid(name, v, "must be finite and >= 0"));
            }
        }
        Ok(())
    }
}

/// Which way the controller's pitch is positive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PitchSign {
    /// twip's: leaning towards forward travel.
    Forward,
    /// Leaning backward: the convention under which the published r1 = −25, r2 = 3 keep
    /// r1 g21 + r2 g22 < 0 (4.113) and S1 = 0 stable (errata T6).
    Backward,
}

/// Surfaces, guards and the steady pitch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmcOptions<T> {
    pub pitch: PitchSign,
    /// Boundary-layer widths of S_η [rad/s] and S1; 0 gives sgn (chattering).
    pub width_eta: T,
    pub width_s1: T,
    /// Guards δ of (4.82): 1/ē3 and 1/(1 + k3 e1) are exact where |·| ≥ δ, linear inside.
    pub guard_e3: T,
    pub guard_d: T,
    /// λ1 aims at the controller model's steady pitch at (v_r, ω_r) instead of 0 (errata T8).
    pub pitch_offset: bool,
}

impl<T: Real> Default for SmcOptions<T> {
    fn default() -> Self {
        Self {
            pitch: PitchSign::Backward,
            width_eta: c(0.02),
            width_s1: c(0.5),
            guard_e3: c(0.05),
            guard_d: c(0.2),
            pitch_offset: true,
        }
    }
}

/// Adaptation of the fuzzy estimates (4.107), (4.116), with optional leakage σ (Ĉ̇ −= σ Ĉ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptation<T> {
    pub gamma1: T,
    pub gamma2: T,
    pub leakage: T,
}

impl<T: Real> Adaptation<T> {
    /// Checks the gains (finite, > 0) and the leakage (finite, >= 0).
    pub fn validate(self) -> Result<Self, TwipError> {
        for (name, v) in [("gamma1", self.gamma1), ("gamma2", self.gamma2)] {
            if !(v.is_finite() && v > T::zero()) {
                return Err(invalid(name, v, "must be finite and > 0"));
            }
        }
        if !(self.leakage.is_finite() && self.leakage >= T::zero()) {
            return Err(invalid("leakage", self.leakage, "must be finite and >= 0"));
        }
        Ok(self)
    }
}

impl<T: Real> Default for Adaptation<T> {
    fn default() -> Self {
        Self { gamma1: c(0.05), gamma2: c(1000.0), leakage: T::zero() }
    }
}

/// The internals before the fuzzy weights: the law's 15 values.
const HEAD: usize = 15;
/// Room for the internals with the largest grids.
const MAX_INTERNALS: usize = HEAD + 2 * MAX_RULES;

/// Names of [`SmcTracker::internals`] with the 3 × 3 grids, in order ([`smc_internal_names`]
/// for any n).
pub const SMC_INTERNALS: [&str; 33] = [
    "s_eta", "s1", "lambda1", "lambda2", "lambda3", "lambda3_dot", "e1", "e2", "e3", "c_psi", "c_y", "f1_hat",
    "f2_hat", "d", "phi_s", "c1_1", "c1_2", "c1_3", "c1_4", "c1_5", "c1_6", "c1_7", "c1_8", "c1_9", "c2_1", "c2_2",
    "c2_3", "c2_4", "c2_5", "c2_6", "c2_7", "c2_8", "c2_9",
];

/// The head's names, then c1_1…c1_k, c2_1…c2_k (k = n²), as literals: the names are `'static`.
macro_rules! names {
    ($($k:literal)*) => {
        &[
            "s_eta", "s1", "lambda1", "lambda2", "lambda3", "lambda3_dot", "e1", "e2", "e3", "c_psi", "c_y", "f1_hat",
            "f2_hat", "d", "phi_s", $(concat!("c1_", $k),)* $(concat!("c2_", $k),)*
        ]
    };
}

/// Names of the internals with n × n grids, in order (n from 2 to
/// [`crate::control::fuzzy_grid::MAX_SETS`]; none for any other n, which no grid has).
pub fn smc_internal_names(n: usize) -> &'static [&'static str] {
    const N2: &[&str] = names!(1 2 3 4);
    const N4: &[&str] = names!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16);
    const N5: &[&str] = names!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25);
    const N6: &[&str] = names!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32 33 34 35 36);
    const N7: &[&str] = names!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32 33 34 35 36 37 38 39 40 41 42 43 44 45 46 47 48 49);
    match n {
        2 => N2,
        3 => &SMC_INTERNALS,
        4 => N4,
        5 => N5,
        6 => N6,
        7 => N7,
        _ => &[],
    }
}

/// The basis of Ĉ1 (estimating f23): (φ [rad], ω [rad/s]) × (N, Z, P).
pub type YawBasis<T> = GridBasis<T, 2, 3, 9>;

/// N, Z, P over ±`inner` (Z's core) to ±`outer` (the shoulders'), summing to 1.
fn shoulders<T: Real>(inner: f64, outer: f64) -> [Membership<T>; 3] {
    let inf = T::one() / T::zero();
    let (i, o) = (c::<T>(inner), c::<T>(outer));
    [
        Membership::Trapezoid { a: -inf, b: -inf, c: -o, d: -i },
        Membership::Trapezoid { a: -o, b: -i, c: i, d: o },
        Membership::Trapezoid { a: i, b: o, c: inf, d: inf },
    ]
}

/// twip's choice of ξ1's sets (the thesis gives neither inputs nor sets): φ as the
/// thesis's basis, ω with Z's core ±0.25 rad/s and shoulders from ±1 rad/s.
pub fn yaw_basis<T: Real>() -> YawBasis<T> {
    GridBasis::new([shoulders(0.1, 0.3), shoulders(0.25, 1.0)]).expect("valid sets")
}

/// ρ_δ(x) = 1/x for |x| ≥ δ, x/δ² inside, and its slope.
#[inline(always)]
fn guarded_inverse<S: Lane>(x: S, width: S) -> (S, S) {
    let one = S::splat(1.0);
    let w2 = width * width;
    let outside = width.le(x.magnitude());
    (S::select(outside, one / x, x / w2), S::select(outside, -one / (x * x), one / w2))
}

/// σ(s): sgn s when `width` is 0, else sat(s / width).
#[inline(always)]
fn switch<S: Lane>(s: S, width: S) -> S {
    let (one, zero) = (S::splat(1.0), S::splat(0.0));
    let sign = S::select(s.gt(zero), one, S::select(s.lt(zero), -one, zero));
    S::select(width.eq(zero), sign, saturate(s / width, one))
}

/// The sliding-mode tracker, model-based or fuzzy adaptive.
#[derive(Clone, Copy, Debug)]
pub struct SmcTracker<T: Real> {
    gains: SmcGains<T>,
    options: SmcOptions<T>,
    model: PlanarModel<T>,
    motor: Option<DcMotor<T>>,
    adaptation: Option<Adaptation<T>>,
    /// The yaw basis (φ, ω) and the pitch basis (φ, φ̇), n × n each (the same n).
    basis1: FuzzyGrid<T>,
    basis2: FuzzyGrid<T>,
    /// The weights Ĉ1, Ĉ2, the first n² in use.
    c1: [T; MAX_RULES],
    c2: [T; MAX_RULES],
    period: T,
    /// (v_r, ω_r, φ_s) of the last reference seen: on a circle it never changes.
    steady: Option<(T, T, T)>,
    internals: [T; MAX_INTERNALS],
}

impl<T: Real> SmcTracker<T> {
    /// `model` is the controller's own; `motor`, if any, limits each wheel's torque to what
    /// it can give at the battery voltage and the measured wheel speed; `adaptation` makes
    /// it the fuzzy adaptive form.
    pub fn new(
        gains: SmcGains<T>,
        options: SmcOptions<T>,
        model: PlanarModel<T>,
        motor: Option<DcMotor<T>>,
        adaptation: Option<Adaptation<T>>,
        period: T,
    ) -> Result<Self, TwipError> {
        gains.validate()?;
        for (name, v) in [("width_eta", options.width_eta), ("width_s1", options.width_s1)] {
            if !(v.is_finite() && v >= T::zero()) {
                return Err(invalid(name, v, "must be finite and >= 0 (0 is sgn)"));
            }
        }
        for (name, v) in [("guard_e3", options.guard_e3), ("guard_d", options.guard_d)] {
            if !(v.is_finite() && v > T::zero()) {
                return Err(invalid(name, v, "must be finite and > 0"));
            }
        }
        if let Some(a) = adaptation {
            a.validate()?;
        }
        if !(period.is_finite() && period > T::zero()) {
            return Err(invalid("period", period, "must be finite and > 0"));
        }
        let tracker = Self {
            gains,
            options,
            model,
            motor,
            adaptation,
            basis1: yaw_basis().into(),
            basis2: FuzzyGrid::default(),
            c1: [T::zero(); MAX_RULES],
            c2: [T::zero(); MAX_RULES],
            period,
            steady: None,
            internals: [T::zero(); MAX_INTERNALS],
        };
        let d = tracker.surface_gain(T::zero());
        if d >= T::zero() || !d.is_finite() {
            return Err(invalid(
                "r1 g21 + r2 g22",
                d,
                "must be < 0 at phi = 0 (thesis 4.113); flip the pitch sign or the signs of r1, r2",
            ));
        }
        Ok(tracker)
    }

    pub fn with_period(self, period: T) -> Result<Self, TwipError> {
        Self::new(self.gains, self.options, self.model, self.motor, self.adaptation, period)?.with_bases(self.basis1, self.basis2)
    }

    /// The fuzzy estimates' bases: `yaw` over (φ, ω) for Ĉ1, `pitch` over (φ, φ̇) for Ĉ2,
    /// n × n grids with the same n (the thesis's: [`yaw_basis`] and
    /// [`crate::control::fuzzy_basis::ThesisBasis`], 3 × 3). The weights restart at zero.
    pub fn with_bases(mut self, yaw: impl Into<FuzzyGrid<T>>, pitch: impl Into<FuzzyGrid<T>>) -> Result<Self, TwipError> {
        let (yaw, pitch) = (yaw.into(), pitch.into());
        if yaw.n() != pitch.n() {
            return Err(TwipError::Shape { name: "pitch_sets", expected: (2, yaw.n()), got: (2, pitch.n()) });
        }
        (self.basis1, self.basis2) = (FuzzyGrid::new(yaw.sets())?, FuzzyGrid::new(pitch.sets())?);
        self.reset();
        Ok(self)
    }

    pub fn gains(&self) -> SmcGains<T> {
        self.gains
    }

    pub fn options(&self) -> SmcOptions<T> {
        self.options
    }

    pub fn model(&self) -> &PlanarModel<T> {
        &self.model
    }

    pub fn motor(&self) -> Option<&DcMotor<T>> {
        self.motor.as_ref()
    }

    pub fn adaptation(&self) -> Option<Adaptation<T>> {
        self.adaptation
    }

    /// The yaw basis (φ, ω) and the pitch basis (φ, φ̇) of the fuzzy estimates.
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub fn bases(&self) -> (&FuzzyGrid<T>, &FuzzyGrid<T>) {
        (&self.basis1, &self.basis2)
    }

    /// The fuzzy weights (Ĉ1, Ĉ2) as of the last update, n² each.
    pub fn weights(&self) -> (&[T], &[T]) {
        let rules = self.basis1.rules();
        (&self.c1[..rules], &self.c2[..rules])
    }

    /// Whether what the next update starts from (the fuzzy weights) is finite.
    pub fn state_is_finite(&self) -> bool {
        self.c1.iter().chain(&self.c2).all(|w| w.is_finite())
    }

    /// r1 as it acts on twip's pitch.
    fn r1(&self) -> T {
        match self.options.pitch {
            PitchSign::Forward => self.gains.r1,
            PitchSign::Backward => -self.gains.r1,
        }
    }

    /// (g21, g22, g23) of (4.72) for the controller's model at pitch `phi`: per N m of C_ψ on
    /// (φ̈, v̇), per N m of C_y on ω̇.
    pub fn input_gains(&self, phi: T) -> (T, T, T) {
        input_gains(&self.model.coefficients(), phi)
    }

    /// The law's parameters in the number type `f` maps to, with the fuzzy sets `sets` (the
    /// yaw basis's and the pitch basis's) in the form that type evaluates.
    pub(crate) fn law<'a, S: Copy, B>(&self, f: impl Fn(T) -> S + Copy, bases: [&'a B; 2]) -> SmcLaw<'a, S, B> {
        let g = self.gains;
        let p = self.model.params();
        SmcLaw {
            gains: SmcGains {
                k1: f(g.k1),
                k2: f(g.k2),
                k3: f(g.k3),
                k_phi: f(g.k_phi),
                r1: f(g.r1),
                r2: f(g.r2),
                k_s3: f(g.k_s3),
                k_s4: f(g.k_s4),
                g_y4: f(g.g_y4),
                k_eta3: f(g.k_eta3),
                k_eta4: f(g.k_eta4),
                g_y3: f(g.g_y3),
            },
            r1: f(self.r1()),
            widths: [f(self.options.width_eta), f(self.options.width_s1)],
            guards: [f(self.options.guard_e3), f(self.options.guard_d)],
            model: self.model.coefficients().map(f),
            radius: f(p.wheel_radius),
            half_track: f(p.half_track),
            motor: self.motor.map(|m| m.map(f)),
            adaptation: self.adaptation.map(|a| Adaptation { gamma1: f(a.gamma1), gamma2: f(a.gamma2), leakage: f(a.leakage) }),
            bases,
            period: f(self.period),
        }
    }

    /// r1 g21 + r2 g22 at pitch `phi`, r1 on the controller's pitch: (4.113) needs it < 0.
    pub fn surface_gain(&self, phi: T) -> T {
        let (g21, g22, _) = self.input_gains(phi);
        self.r1() * g21 + self.gains.r2 * g22
    }

    /// The controller model's pitch when driving steadily at speed `v` turning at `omega`:
    /// both (φ, v) rows at rest need one and the same C_ψ (Newton from 0).
    pub fn steady_pitch(&self, v: T, omega: T) -> T {
        let radius = self.model.params().wheel_radius;
        // With φ̇ = v̇ = φ̈ = 0 the rows read f_φ = C_ψ, f_v = −C_ψ/R, so f_φ + R f_v = 0.
        let residual = |phi: T| {
            let x = SVector::<T, 7>::from([T::zero(), T::zero(), T::zero(), phi, T::zero(), v, omega]);
            let acc = self.model.deriv(&x, &SVector::zeros());
            let m = self.model.mass_matrix(phi);
            let f_phi = m[(0, 0)] * acc[4] + m[(0, 1)] * acc[5];
            let f_v = m[(1, 0)] * acc[4] + m[(1, 1)] * acc[5];
            f_phi + radius * f_v
        };
        let h = c::<T>(1e-4);
        let mut phi = T::zero();
        for _ in 0..8 {
            let slope = (residual(phi + h) - residual(phi - h)) / (h + h);
            let next = phi - residual(phi) / slope;
            if !next.is_finite() {
                return T::zero();
            }
            phi = next;
        }
        phi
    }

    /// φ_s at (v, ω) as the update uses it: 0 without the pitch offset, else cached.
    pub(crate) fn cached_steady_pitch(&mut self, v: T, omega: T) -> T {
        if !self.options.pitch_offset {
            return T::zero();
        }
        match self.steady {
            Some((sv, so, phi)) if sv == v && so == omega => phi,
            _ => {
                let phi = self.steady_pitch(v, omega);
                self.steady = Some((v, omega, phi));
                phi
            }
        }
    }
}

impl<T: Real> Controller<T, 7, 2> for SmcTracker<T> {
    type Reference = PlanarRef<T>;

    fn period(&self) -> T {
        self.period
    }

    fn reset(&mut self) {
        self.c1 = [T::zero(); MAX_RULES];
        self.c2 = [T::zero(); MAX_RULES];
        self.steady = None;
        self.internals = [T::zero(); MAX_INTERNALS];
    }

    fn update(&mut self, _t: T, y: &SVector<T, 7>, r: &PlanarRef<T>) -> SVector<T, 2> {
        let phi_s = self.cached_steady_pitch(r.v, r.omega);
        let bases = [self.basis1.sized(), self.basis2.sized()];
        let law = self.law(|v| v, [&bases[0], &bases[1]]);
        // Without adaptation the equivalent control takes the model's own derivative
        // (with its gearhead friction, if it has some).
        let model = &self.model;
        let step = law.step(&(*y).into(), r, phi_s, &self.c1, &self.c2, || model.deriv(y, &SVector::zeros()).into());
        let rules = self.basis1.rules();
        self.internals[..HEAD].copy_from_slice(&step.head);
        self.internals[HEAD..HEAD + rules].copy_from_slice(&self.c1[..rules]);
        self.internals[HEAD + rules..HEAD + 2 * rules].copy_from_slice(&self.c2[..rules]);
        (self.c1, self.c2) = (step.c1, step.c2);
        SVector::<T, 2>::from(step.u)
    }

    fn internals(&self) -> &[T] {
        &self.internals[..HEAD + 2 * self.basis1.rules()]
    }

    fn internal_names(&self) -> &'static [&'static str] {
        smc_internal_names(self.basis1.n())
    }
}

/// Σ a_j b_j over the first `rules` entries.
#[inline(always)]
fn dot<S: Lane>(a: &[S], b: &[S], rules: usize) -> S {
    a.iter().zip(b).take(rules).fold(S::splat(0.0), |s, (x, y)| s + *x * *y)
}

/// (g21, g22, g23) of (4.72) for a model's coefficients at pitch `phi`: the model's
/// accelerations under a unit C_ψ, which B puts on (φ, v) as (−1, 1/R), and a unit C_y,
/// which it puts on ω as b/R.
#[inline(always)]
pub(crate) fn input_gains<S: Lane>(k: &PlanarCoefficients<S>, phi: S) -> (S, S, S) {
    let (s, cp) = S::sincos(phi);
    let [g21, g22, g23] = accelerations(k, &[-S::splat(1.0), k.inv_r, k.b_r], s, cp);
    (g21, g22, g23)
}

/// The tracker's parameters in the number type of a run or of a sweep's lanes, its fuzzy
/// bases as `B` (a run's sized grids, a sweep's fixed or sized trapezoids).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SmcLaw<'a, S, B> {
    pub gains: SmcGains<S>,
    /// r1 as it acts on twip's pitch.
    pub r1: S,
    /// The boundary layers of σ(S_η) and σ(S1).
    pub widths: [S; 2],
    /// δ of ρ for ē3 and for 1 + k3 e1.
    pub guards: [S; 2],
    pub model: PlanarCoefficients<S>,
    pub radius: S,
    pub half_track: S,
    pub motor: Option<DcMotor<S>>,
    pub adaptation: Option<Adaptation<S>>,
    /// The yaw basis (φ, ω) and the pitch basis (φ, φ̇).
    pub bases: [&'a B; 2],
    pub period: S,
}

/// What one update gives: the wheels' torques, the first 15 internals
/// ([`SMC_INTERNALS`]) and the fuzzy weights after it.
pub(crate) struct SmcStep<S, const R: usize> {
    pub u: [S; 2],
    pub head: [S; HEAD],
    pub c1: [S; R],
    pub c2: [S; R],
}

impl<S: Lane, B> SmcLaw<'_, S, B> {
    /// (4.73)–(4.121) at measurement `y`, reference `r` and steady pitch `phi_s`, with the
    /// weights (Ĉ1, Ĉ2) before the update; `free` is the model's derivative at `y` without
    /// input (asked only without adaptation). Written once: a run's update and a sweep's lanes.
    #[inline(always)]
    pub(crate) fn step<const R: usize>(
        &self,
        y: &[S; 7],
        r: &PlanarRef<S>,
        phi_s: S,
        c1: &[S; R],
        c2: &[S; R],
        free: impl FnOnce() -> [S; 7],
    ) -> SmcStep<S, R>
    where
        B: RuleBase<S, R>,
    {
        let SmcGains { k1, k2, k3, k_phi, r2, .. } = self.gains;
        let (psi, phi, phi_dot, v, omega) = (y[2], y[3], y[4], y[5], y[6]);
        let one = S::splat(1.0);
        // Kinematic errors in the robot's frame (4.75) and their rates (4.76).
        let (sin_psi, cos_psi) = S::sincos(psi);
        let (dx, dy) = (r.x - y[0], r.y - y[1]);
        let e1 = cos_psi * dx + sin_psi * dy;
        let e2 = cos_psi * dy - sin_psi * dx;
        let e3 = wrap_angle(r.psi - psi);
        let (s3, c3) = S::sincos(e3);
        let e1_dot = omega * e2 - v + r.v * c3;
        let e2_dot = r.v * s3 - omega * e1;
        let e3_dot = r.omega - omega;
        // Virtual controls (4.74), (4.81), (4.82) and their exact rates.
        let lambda1 = -k_phi * (phi - phi_s);
        let lambda1_dot = -k_phi * phi_dot;
        let lambda2 = r.v * c3 + k1 * e1;
        let lambda2_dot = r.v_dot * c3 - r.v * s3 * e3_dot + k1 * e1_dot;
        let e3_bar = e3 + k3 * e2;
        let e3_bar_dot = e3_dot + k3 * e2_dot;
        let (q, q_slope) = guarded_inverse(e3_bar, self.guards[0]);
        let cross = e2 * r.v * s3;
        let cross_dot = e2_dot * r.v * s3 + e2 * r.v_dot * s3 + e2 * r.v * c3 * e3_dot;
        let n = k2 * e3_bar + cross * q + k3 * r.v * s3 + r.omega;
        let n_dot = k2 * e3_bar_dot
            + cross_dot * q
            + cross * q_slope * e3_bar_dot
            + k3 * (r.v_dot * s3 + r.v * c3 * e3_dot)
            + r.omega_dot;
        let (inv_d, inv_d_slope) = guarded_inverse(one + k3 * e1, self.guards[1]);
        let lambda3 = n * inv_d;
        let lambda3_dot = n_dot * inv_d + n * inv_d_slope * k3 * e1_dot;
        // Surfaces (4.85), (4.92), (4.94) and the model's input gains (4.72).
        let r1 = self.r1;
        let s_eta = omega - lambda3;
        let s1 = r1 * (phi_dot - lambda1) + r2 * (v - lambda2);
        let (g21, g22, g23) = input_gains(&self.model, phi);
        let d = r1 * g21 + r2 * g22;
        // What the equivalent control needs: the fuzzy estimates, or from the model.
        let zero = [S::splat(0.0); R];
        let rules = self.bases[0].rules();
        let (xi1, xi2, f1_hat, f2_hat) = match self.adaptation {
            Some(_) => {
                let xi1 = self.bases[0].xi(&[phi, omega]);
                let xi2 = self.bases[1].xi(&[phi, phi_dot]);
                (xi1, xi2, dot(c1, &xi1, rules), dot(c2, &xi2, rules))
            }
            None => {
                let f = free();
                (zero, zero, f[6], (r1 * f[4] + r2 * f[5] - r1 * lambda1_dot - r2 * lambda2_dot) / d)
            }
        };
        let g = &self.gains;
        let c_y = (lambda3_dot - f1_hat - (g.g_y3 - g.k_eta3) * switch(s_eta, self.widths[0]) + g.k_eta4 * s_eta) / g23;
        let c_psi = -f2_hat - (g.k_s3 - g.g_y4) * switch(s1, self.widths[1]) - g.k_s4 * s1;
        let half = S::splat(0.5);
        let mut u = [half * c_psi + half * c_y, half * c_psi - half * c_y];
        if let Some(m) = &self.motor {
            let speeds = relative_wheel_speeds(y, self.radius, self.half_track);
            for (ui, w) in u.iter_mut().zip(speeds) {
                let (lo, hi) = m.torque_limits(w);
                *ui = clamp(*ui, lo, hi);
            }
        }
        let (mut c1_next, mut c2_next) = (*c1, *c2);
        if let Some(a) = self.adaptation {
            // (4.107), (4.116) by forward Euler over one period.
            let (k_1, k_2) = (self.period * s_eta / a.gamma1, self.period * s1 * d / a.gamma2);
            let decay = one - self.period * a.leakage;
            for j in 0..rules {
                c1_next[j] = c1[j] * decay + k_1 * xi1[j];
                c2_next[j] = c2[j] * decay + k_2 * xi2[j];
            }
        }
        SmcStep {
            u,
            head: [s_eta, s1, lambda1, lambda2, lambda3, lambda3_dot, e1, e2, e3, c_psi, c_y, f1_hat, f2_hat, d, phi_s],
            c1: c1_next,
            c2: c2_next,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hardware::motor::DcMotor;
    use crate::RobotParams;

    fn tracker(fuzzy: bool) -> SmcTracker<f64> {
        let model = PlanarModel::new(RobotParams::balanbot()).unwrap();
        let unit = DcMotor::<f64>::gb37y3530().torque_per_count();
        let adaptation = if fuzzy { Some(Adaptation::default()) } else { None };
        SmcTracker::new(SmcGains::thesis(unit), SmcOptions::default(), model, Some(DcMotor::gb37y3530()), adaptation, 0.005)
            .unwrap()
    }

    #[test]
    fn published_surface_needs_the_backward_pitch() {
        let t = tracker(false);
        assert!(t.surface_gain(0.0) < 0.0);
        let options = SmcOptions { pitch: PitchSign::Forward, ..SmcOptions::default() };
        let err = SmcTracker::new(t.gains(), options, *t.model(), None, None, 0.005).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "r1 g21 + r2 g22", .. }));
    }

    #[test]
    fn a_nan_torque_is_not_hidden_by_the_motor_limits() {
        // The torque limits' larger/smaller would have answered the full-reverse torque.
        let mut t = tracker(true);
        let y = SVector::from([0.0, 0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0]);
        let u = t.update(0.0, &y, &PlanarRef::default());
        assert!(u.iter().all(|v| v.is_nan()), "{u:?}");
    }

    #[test]
    fn singular_points_of_4_82_give_finite_torques() {
        let mut t = tracker(false);
        let r = PlanarRef { x: 0.0, y: 0.0, psi: 0.0, v: 0.1, omega: 0.2, v_dot: 0.0, omega_dot: 0.0 };
        // e1 = −1/k3 (1 + k3 e1 = 0); and ē3 = e3 + k3 e2 = 0 with e2 = −0.05, e3 = 0.2.
        let cases = [([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 0.0), ([0.0, 0.05, 0.0, 0.0, 0.0, 0.1, 0.0], 0.2)];
        for (y, psi_r) in cases {
            let u = t.update(0.0, &SVector::from(y), &PlanarRef { psi: psi_r, ..r });
            assert!(u.iter().all(|v| v.is_finite()), "{y:?} -> {u:?}");
            assert!(t.internals()[6] == -0.25 || t.internals()[8] + 4.0 * t.internals()[7] == 0.0);
        }
    }

    #[test]
    fn steady_pitch_is_a_steady_state() {
        let t = tracker(false);
        let (v, w) = (0.1, 0.2);
        let phi = t.steady_pitch(v, w);
        // Some common C_ψ makes both accelerations vanish.
        let m = t.model();
        let x = SVector::<f64, 7>::from([0.0, 0.0, 0.0, phi, 0.0, v, w]);
        let acc = m.deriv(&x, &SVector::zeros());
        let (g21, g22, _) = t.input_gains(phi);
        let torque = -acc[5] / g22;
        assert!((acc[4] + g21 * torque).abs() < 1e-12, "phi_s = {phi}");
        assert!(phi > 0.0 && phi < 0.05, "friction makes it lean forward a little: {phi}");
    }

    #[test]
    fn f32_follows_f64() {
        fn build<T: Real>() -> SmcTracker<T> {
            let model = PlanarModel::new(RobotParams::<T>::balanbot()).unwrap();
            let motor = DcMotor::<T>::gb37y3530();
            let gains = SmcGains::thesis(motor.torque_per_count());
            SmcTracker::new(gains, SmcOptions::default(), model, Some(motor), Some(Adaptation::default()), c(0.005))
                .unwrap()
        }
        let (mut a, mut b) = (build::<f64>(), build::<f32>());
        let y = [0.01, -0.02, 0.05, 0.03, -0.1, 0.08, 0.2];
        let r = [0.0, 0.0, 0.0, 0.1, 0.2, 0.0, 0.0];
        let r64 = PlanarRef { x: r[0], y: r[1], psi: r[2], v: r[3], omega: r[4], v_dot: r[5], omega_dot: r[6] };
        let r32 = PlanarRef { x: 0.0f32, y: 0.0, psi: 0.0, v: 0.1, omega: 0.2, v_dot: 0.0, omega_dot: 0.0 };
        for _ in 0..3 {
            let u64 = a.update(0.0, &SVector::from(y), &r64);
            let u32 = b.update(0.0, &SVector::from(y.map(|v| v as f32)), &r32);
            for i in 0..2 {
                assert!((u32[i] as f64 - u64[i]).abs() < 1e-4 * u64.amax().max(1e-3), "{u32} vs {u64}");
            }
        }
    }

    #[test]
    fn bad_gains_are_named() {
        let t = tracker(true);
        let mut g = t.gains();
        g.k_s4 = 1.0;
        let err = SmcTracker::new(g, t.options(), *t.model(), None, None, 0.005).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "k_s4", .. }));
        let mut g = t.gains();
        g.k2 = 0.0;
        assert!(matches!(
            SmcTracker::new(g, t.options(), *t.model(), None, None, 0.005),
            Err(TwipError::InvalidParameter { name: "k2", .. })
        ));
        let a = Adaptation { gamma1: 0.0, ..Adaptation::default() };
        assert!(matches!(
            SmcTracker::new(t.gains(), t.options(), *t.model(), None, Some(a), 0.005),
            Err(TwipError::InvalidParameter { name: "gamma1", .. })
        ));
    }
}
