//! Gearhead friction beyond the models' viscous `mu_bearing`: Coulomb + viscous +
//! Stribeck, with the Stribeck peak as the breakaway (static) torque, acting between
//! body and wheel on each side. Off unless a model is given one (`with_friction`), so
//! the thesis's all-viscous models stay as they are.
//!
//! One wheel's friction torque at the relative speed `w` = θ̇_side − φ̇ [rad/s]:
//!
//! ```text
//! τ_f(w) = (τ_c + (τ_s − τ_c) exp(−(w/ω_s)²)) tanh(w/ω_ε) + b_v w
//! ```
//!
//! The sign function of Coulomb friction is regularised by `tanh(w/ω_ε)`: smooth (C^∞),
//! so RK4 keeps its 4th order away from |w| ≲ ω_ε, odd, and with `w τ_f(w) ≥ 0` it only
//! ever dissipates. Stiction is the Stribeck peak τ_s: an applied torque below it is
//! held with the wheel creeping at |w| < ω_ε atanh(τ/τ_s), not stuck exactly (a
//! regularised model has no stick state; ω_ε sets how slowly it creeps).
//!
//! **Stick state** (`stick_speed` ω_k > 0, Karnopp's model): a wheel slower than ω_k
//! relative to the body is held. Friction then supplies whatever torque, up to the
//! breakaway τ_s, makes ẇ = −w/T_k ([`STICK_TIME`]): the wheel comes to rest and stays
//! there exactly while the torque that would move it is below τ_s. Beyond that torque
//! it breaks away at ±τ_s; outside the band the slip law above holds with sign(w)
//! exact. The holding torque depends on everything else acting on the wheel, so the
//! models compute it ([`Friction::torques`] takes the wheels' accelerations without
//! friction and their response to it). The law is smooth inside and outside the band,
//! so RK4 keeps its order away from the band's edge and from breakaway.
use crate::model::lane::{fill, Lane};
use core::cell::Cell;
use crate::{c, to_f64, Real, TwipError};

/// T_k: how fast a held wheel comes to rest [s]. 5 ms brings it to rest within a few
/// 1 ms steps, and RK4 stays stable on −1/T_k for steps up to 2.78 T_k = 13.9 ms.
pub const STICK_TIME: f64 = 5e-3;

/// One wheel's gearhead friction, at the wheel (N m, rad/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Friction<T> {
    /// Coulomb (sliding) torque τ_c [N m].
    pub coulomb: T,
    /// Breakaway (static) torque τ_s ≥ τ_c: the peak at low speed [N m].
    pub breakaway: T,
    /// Stribeck speed ω_s: how fast the torque falls from τ_s to τ_c [rad/s].
    pub stribeck_speed: T,
    /// Viscous coefficient b_v, on top of the model's `mu_bearing` [N m s/rad].
    pub viscous: T,
    /// Regularisation speed ω_ε of the sign function [rad/s] (the law without a stick band).
    pub smoothing_speed: T,
    /// Half-width ω_k of the stick band [rad/s]; 0 is no stick state (the regularised law).
    pub stick_speed: T,
}

/// The GB37Y3530-12V-251R data sheet's no-load point (Table 2.3, docs/parameters.md).
pub const GB37_NO_LOAD_CURRENT: f64 = 0.35;
/// No-load speed at the gearbox output [rad/s] (251 rpm).
pub const GB37_NO_LOAD_SPEED: f64 = 251.0 * core::f64::consts::PI / 30.0;
/// The stick band for the GB37 laws, ω_k = 0.1 rad/s at the wheel (0.32 encoder counts
/// per 5 ms loop): braked at τ_s = 0.19 N m through the reflected rotor (5.1e-3 kg m²), a
/// wheel loses 0.037 rad/s per 1 ms step, well under the band's width.
pub const GB37_STICK_SPEED: f64 = 0.1;
/// k_t = k_e from the no-load point [N m/A] (docs/parameters.md).
pub const GB37_TORQUE_CONSTANT: f64 = 9.925e-3;
/// The gear ratio η.
pub const GB37_GEAR_RATIO: f64 = 43.7;

impl<T: Real> Friction<T> {
    /// The data sheet's no-load torque read as Coulomb friction: the motor draws I₀ =
    /// 0.35 A at no load, so the gearhead resists with η k_t I₀ = 0.1518 N m per wheel.
    /// The breakaway torque is 1.25 τ_c and the Stribeck speed 1 rad/s (typical of
    /// small spur gearheads; the data sheet gives neither); no extra viscous part (the
    /// model's `mu_bearing` is the viscous part); ω_ε = 0.1 rad/s, well below one
    /// encoder count per 5 ms loop (1.8 rad/s).
    pub fn gb37() -> Self {
        let coulomb = GB37_GEAR_RATIO * GB37_TORQUE_CONSTANT * GB37_NO_LOAD_CURRENT;
        Self {
            coulomb: c(coulomb),
            breakaway: c(1.25 * coulomb),
            stribeck_speed: c(1.0),
            viscous: T::zero(),
            smoothing_speed: c(0.1),
            stick_speed: T::zero(),
        }
    }

    /// This friction with a stick state of half-width `stick_speed` [rad/s] (0: none).
    /// [`GB37_STICK_SPEED`] suits 1 ms steps: a wheel braked at τ_s loses less than the
    /// band's width in one step, so it cannot jump across the band.
    pub fn with_stick(self, stick_speed: T) -> Self {
        Self { stick_speed, ..self }
    }

    /// [`Self::gb37`] beside a viscous bearing of `viscous_per_wheel` [N m s/rad]: the
    /// no-load torque η k_t I₀ split so that the two together give it at the no-load
    /// speed, the Coulomb part being the rest, max(0, η k_t I₀ − b ω₀). For
    /// `RobotParams::balanbot()` (μ_s/2 = 5.33e-3) that is 0.0117 N m.
    pub fn gb37_beside(viscous_per_wheel: T) -> Self {
        let full = Self::gb37();
        let rest = full.coulomb - viscous_per_wheel * c::<T>(GB37_NO_LOAD_SPEED);
        let coulomb = rest.max(T::zero());
        Self { coulomb, breakaway: c::<T>(1.25) * coulomb, ..full }
    }

    /// Checks every field: finite; τ_c, b_v ≥ 0; τ_s ≥ τ_c; ω_s, ω_ε > 0.
    pub fn validate(&self) -> Result<Self, TwipError> {
        let fields = [
            ("coulomb", self.coulomb, self.coulomb >= T::zero(), "must be >= 0"),
            ("breakaway", self.breakaway, self.breakaway >= self.coulomb, "must be >= coulomb"),
            ("stribeck_speed", self.stribeck_speed, self.stribeck_speed > T::zero(), "must be > 0"),
            ("viscous", self.viscous, self.viscous >= T::zero(), "must be >= 0"),
            ("smoothing_speed", self.smoothing_speed, self.smoothing_speed > T::zero(), "must be > 0"),
            ("stick_speed", self.stick_speed, self.stick_speed >= T::zero(), "must be >= 0"),
        ];
        for (name, value, ok, reason) in fields {
            if !value.is_finite() {
                return Err(TwipError::InvalidParameter { name, value: to_f64(value), reason: "must be finite" });
            }
            if !ok {
                return Err(TwipError::InvalidParameter { name, value: to_f64(value), reason });
            }
        }
        Ok(*self)
    }
}

impl<T: Copy> Friction<T> {
    /// The same friction in another number type (a sweep's lanes).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub(crate) fn map<S>(&self, f: impl Fn(T) -> S) -> Friction<S> {
        Friction {
            coulomb: f(self.coulomb),
            breakaway: f(self.breakaway),
            stribeck_speed: f(self.stribeck_speed),
            viscous: f(self.viscous),
            smoothing_speed: f(self.smoothing_speed),
            stick_speed: f(self.stick_speed),
        }
    }
}

/// A gearhead friction with its kind decided once: none, the slip law, or with a stick
/// band, solved or taken as the slip law outside it (a sweep's friction is every lane's,
/// so its lanes branch on it together).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Gearhead<'a, S: Lane> {
    Free,
    Slip(&'a Friction<S>),
    Stick(&'a Friction<S>),
    /// The stick band's law where the caller expects no wheel in the band: there it is the
    /// slip law with the exact sign, bit for bit, without the holding torques' solve. The
    /// cell notes whether some wheel was in the band after all (then the caller takes the
    /// step again with `Stick`).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // the sweeps' rig lanes take it
    Outside(&'a Friction<S>, &'a Cell<S::Mask>),
}

impl<'a, S: Lane> Gearhead<'a, S> {
    #[inline(always)]
    pub(crate) fn of(friction: Option<&'a Friction<S>>) -> Self {
        match friction {
            Some(f) if f.sticks() => Self::Stick(f),
            Some(f) => Self::Slip(f),
            None => Self::Free,
        }
    }

    /// The torques of a stick band's law on `N` wheels ([`Friction::held_torques`]); for
    /// `Outside`, what that gives while no wheel is in the band, noting whether one is. None
    /// without a band.
    #[inline(always)]
    pub(crate) fn held_torques<const N: usize>(&self, w: [S; N], a0: [S; N], s: [[S; N]; N]) -> [S; N] {
        match self {
            Self::Stick(f) => f.held_torques(w, a0, s),
            Self::Outside(f, band) => {
                for wi in w {
                    band.set(band.get() | wi.magnitude().lt(f.stick_speed));
                }
                fill(|i| f.torque_as(w[i], true))
            }
            _ => [S::splat(0.0); N],
        }
    }

    /// Both wheels' slip-law torque at the relative speed `w` (0 without friction and with
    /// a stick band, whose torque the model adds once it knows what holds the wheels).
    #[inline(always)]
    pub(crate) fn slip_pair(&self, w: S) -> S {
        match self {
            Self::Slip(f) => S::splat(2.0) * f.torque_as(w, false),
            _ => S::splat(0.0),
        }
    }
}

// The law, written once over `Lane`: a run evaluates it in `T`, a sweep's lanes in
// `Fused`. Its branches on the friction's own constants (`sticks`) are taken by all lanes
// together (a sweep's friction is the same for every lane); those on the speeds are masks.
impl<S: Lane> Friction<S> {
    /// Whether this friction has a stick state.
    #[inline(always)]
    pub fn sticks(&self) -> bool {
        S::any(self.stick_speed.gt(S::splat(0.0)))
    }

    /// The slip law's torque τ_f(w) opposing the relative speed `w` [N m]: the whole law
    /// without a stick band; with one, what acts outside it (see [`Self::torques`]).
    #[inline(always)]
    pub fn torque(&self, w: S) -> S {
        self.torque_as(w, self.sticks())
    }

    /// [`Self::torque`] with the kind of law decided by the caller (`sticks`: the exact
    /// sign), as a sweep's lanes do once for all of them.
    #[inline(always)]
    fn torque_as(&self, w: S, sticks: bool) -> S {
        let (level, sign, _, _) = self.parts_as(w, sticks);
        level * sign + self.viscous * w
    }

    /// dτ_f/dw (for linearisation).
    pub fn slope(&self, w: S) -> S {
        let (level, sign, d_level, d_sign) = self.parts(w);
        d_level * sign + level * d_sign + self.viscous
    }

    /// The power the friction dissipates at `w`, w τ_f(w) ≥ 0 [W].
    pub fn dissipation(&self, w: S) -> S {
        w * self.torque(w)
    }

    /// The Stribeck level, the sign (regularised without a stick band, exact with one),
    /// and their derivatives in w.
    #[inline(always)]
    fn parts(&self, w: S) -> (S, S, S, S) {
        self.parts_as(w, self.sticks())
    }

    #[inline(always)]
    fn parts_as(&self, w: S, sticks: bool) -> (S, S, S, S) {
        let (zero, one) = (S::splat(0.0), S::splat(1.0));
        // w / ω_s as a product: 1/ω_s is the same for every stage (off their chain), and the
        // same number when ω_s is a power of two (the GB37 laws' 1 rad/s).
        let z = w * (one / self.stribeck_speed);
        let hump = (-z * z).decay();
        let peak = self.breakaway - self.coulomb;
        let level = self.coulomb + peak * hump;
        let d_level = -S::splat(2.0) * z / self.stribeck_speed * peak * hump;
        if sticks {
            let sign = S::select(w.gt(zero), one, S::select(w.lt(zero), -one, zero));
            return (level, sign, d_level, zero);
        }
        let sign = (w / self.smoothing_speed).hyperbolic_tangent();
        let d_sign = (one - sign * sign) / self.smoothing_speed;
        (level, sign, d_level, d_sign)
    }

    /// The friction torques on `N` wheels (N = 1 or 2) at relative speeds `w`, given their
    /// accelerations without this friction `a0` and their response `s` to it: the wheels
    /// accelerate at ẇ = a0 − s τ (s symmetric positive definite, from the model's mass
    /// matrix). Without a stick band this is the slip law. With one, each wheel inside
    /// the band is held (ẇ = −w/T_k) by the torque that needs, while that is within
    /// ±τ_s; a wheel that would need more breaks away at ±τ_s, and the others are held
    /// against it.
    // Always inlined: out of line, the lanes' copies for AVX would call it compiled for the
    // baseline CPU, each fused multiply-add a libm call.
    #[inline(always)]
    pub fn torques<const N: usize>(&self, w: [S; N], a0: [S; N], s: [[S; N]; N]) -> [S; N] {
        if !self.sticks() {
            return fill(|i| self.torque_as(w[i], false));
        }
        self.held_torques(w, a0, s)
    }

    /// [`Self::torques`] of a friction with a stick band.
    #[inline(always)]
    pub(crate) fn held_torques<const N: usize>(&self, w: [S; N], a0: [S; N], s: [[S; N]; N]) -> [S; N] {
        const { assert!(N == 1 || N == 2, "one or two wheels") };
        // Plain loops (`fill`), not `from_fn`: its closures, left out of line, ran the lane
        // kernels' baseline code (the fuzzy rig 1.5x slower).
        let mut tau: [S; N] = fill(|i| self.torque_as(w[i], true));
        let mut held = [S::mask(false); N];
        for i in 0..N {
            held[i] = w[i].magnitude().lt(self.stick_speed);
        }
        let rate = S::splat(1.0) / S::splat(STICK_TIME);
        let (breakaway, zero) = (self.breakaway, S::splat(0.0));
        // Each pass either holds every wheel in the band or releases one. A lane is done at
        // its first pass that releases none; a lane that releases its last held wheel has
        // its torques too (the released one at ±τ_s, the others already released), so N
        // passes are enough (an N + 1st would release none and change nothing). All passes
        // run (no exit when every lane is done), so that a loop over lanes vectorises.
        let mut done = S::mask(false);
        for _ in 0..N {
            let need = hold(&held, &tau, &w, &a0, &s, rate);
            // The held wheel that needs most beyond ±τ_s breaks away first: releasing the
            // first in index order could release a wheel whose partner, released, would let
            // it be held (both at ±τ_s where one held wheel was consistent).
            let mut worst = zero;
            let mut release = [S::mask(false); N];
            for i in 0..N {
                let excess = need[i].magnitude() - breakaway;
                let more = !done & held[i] & excess.gt(worst);
                for r in release.iter_mut().take(i) {
                    *r = *r & !more;
                }
                release[i] = more;
                worst = S::select(more, excess, worst);
            }
            let mut released = S::mask(false);
            for i in 0..N {
                held[i] = held[i] & !release[i];
                tau[i] = S::select(release[i], S::select(need[i].gt(zero), breakaway, -breakaway), tau[i]);
                released = released | release[i];
            }
            let finish = !done & !released;
            for i in 0..N {
                tau[i] = S::select(finish & held[i], need[i], tau[i]);
            }
            done = done | finish;
        }
        tau
    }
}

/// The torques on the `held` wheels that give them ẇ = −rate·w with the others' torques
/// `tau` fixed: S_hh τ_h = a0_h + rate w_h − S_h,other τ_other (N ≤ 2: one division or
/// Cramer's rule). Entries of wheels not held are left as they are.
#[inline(always)]
fn hold<S: Lane, const N: usize>(held: &[S::Mask; N], tau: &[S; N], w: &[S; N], a0: &[S; N], s: &[[S; N]; N], rate: S) -> [S; N] {
    let rhs: [S; N] = fill(|i| {
        let mut v = a0[i] + rate * w[i];
        for j in 0..N {
            // Only the wheels not held (j = i is held wherever rhs[i] is used).
            v = S::select(held[j], v, v - s[i][j] * tau[j]);
        }
        v
    });
    let mut out = *tau;
    if N == 1 {
        out[0] = S::select(held[0], rhs[0] / s[0][0], tau[0]);
    } else {
        let (i, j) = (0, N - 1);
        let det = s[i][i] * s[j][j] - s[i][j] * s[j][i];
        let both = held[i] & held[j];
        // A held wheel's torque is one quotient: Cramer's when both are held, else by its
        // own entry. Its numerator and divisor are picked first, so that each wheel takes
        // one division, not two (the same quotient: the same bits).
        let num_i = S::select(both, s[j][j] * rhs[i] - s[i][j] * rhs[j], rhs[i]);
        let num_j = S::select(both, s[i][i] * rhs[j] - s[j][i] * rhs[i], rhs[j]);
        out[i] = S::select(held[i], num_i / S::select(both, det, s[i][i]), tau[i]);
        out[j] = S::select(held[j], num_j / S::select(both, det, s[j][j]), tau[j]);
    }
    out
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    #[test]
    fn gb37_defaults_come_from_the_no_load_point() {
        let f = Friction::<f64>::gb37();
        assert!((f.coulomb - 0.15181).abs() < 1e-4, "{}", f.coulomb);
        assert!(f.validate().is_ok());
        // At the no-load speed the torque is the Coulomb torque (the hump has died out).
        let at_no_load = f.torque(GB37_NO_LOAD_SPEED);
        assert!((at_no_load - f.coulomb).abs() < 1e-12 * f.coulomb, "{at_no_load}");
        assert!((GB37_NO_LOAD_SPEED - 26.285).abs() < 1e-3);
    }

    #[test]
    fn the_wheel_that_needs_most_breaks_away_first() {
        // Both held would need (1.2, -2.0) against a breakaway of 1. Released in index order,
        // wheel 0 went first and then wheel 1 too: (1, -1), although with wheel 1 at -1
        // wheel 0 needs only 0.4 to be held. Wheel 1 needs more: it goes, wheel 0 is held.
        let f = Friction { breakaway: 1.0, ..Friction::<f64>::gb37() }.with_stick(0.1);
        let (s, tau_both) = ([[1.0, 0.8], [0.8, 1.0]], [1.2, -2.0]);
        let a0 = [s[0][0] * tau_both[0] + s[0][1] * tau_both[1], s[1][0] * tau_both[0] + s[1][1] * tau_both[1]];
        let tau = f.torques([0.0, 0.0], a0, s);
        assert!((tau[0] - 0.4).abs() < 1e-12 && tau[1] == -1.0, "{tau:?}");
        // The mirror image: the same with the wheels' roles swapped.
        let tau = f.torques([0.0, 0.0], [a0[1], a0[0]], s);
        assert!((tau[1] - 0.4).abs() < 1e-12 && tau[0] == -1.0, "{tau:?}");
    }

    #[test]
    fn odd_dissipative_peaks_near_zero() {
        let f = Friction::<f64>::gb37();
        let mut peak: f64 = 0.0;
        for i in -2000..=2000 {
            let w = i as f64 * 1e-3;
            assert_eq!(f.torque(-w), -f.torque(w));
            assert!(f.dissipation(w) >= 0.0);
            peak = peak.max(f.torque(w));
        }
        assert!(peak > f.coulomb && peak < f.breakaway, "{peak}");
        assert!(peak > 0.95 * f.breakaway, "the breakaway torque is reached near zero speed: {peak}");
    }

    #[test]
    fn slope_is_the_derivative() {
        let f = Friction::<f64> { viscous: 0.003, ..Friction::gb37() };
        for w in [-3.0, -0.4, -0.05, 0.0, 0.02, 0.3, 1.0, 5.0] {
            let h = 1e-6;
            let numeric = (f.torque(w + h) - f.torque(w - h)) / (2.0 * h);
            assert!((f.slope(w) - numeric).abs() < 1e-6 * f.slope(w).abs().max(1.0), "w = {w}");
        }
    }

    #[test]
    fn bad_fields_are_named() {
        let f = Friction::<f64> { breakaway: 0.1, ..Friction::gb37() };
        assert!(matches!(f.validate(), Err(TwipError::InvalidParameter { name: "breakaway", .. })));
        let f = Friction::<f64> { smoothing_speed: 0.0, ..Friction::gb37() };
        assert!(matches!(f.validate(), Err(TwipError::InvalidParameter { name: "smoothing_speed", .. })));
        let f = Friction::<f64> { coulomb: f64::NAN, ..Friction::gb37() };
        assert!(matches!(
            f.validate(),
            Err(TwipError::InvalidParameter { name: "coulomb", reason: "must be finite", .. })
        ));
    }

    /// Uniform in [lo, hi) from a fixed sequence (no dependencies).
    struct Lcg(u64);

    impl Lcg {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
        }

        /// Two coupled wheels: a response S (symmetric positive definite), speeds within ±`w`
        /// and accelerations without friction.
        fn coupled_pair(&mut self, w: f64) -> ([[f64; 2]; 2], [f64; 2], [f64; 2]) {
            let (d0, d1, off) = (self.uniform(50.0, 400.0), self.uniform(50.0, 400.0), self.uniform(-0.9, 0.9));
            let s = [[d0, off * (d0 * d1).sqrt()], [off * (d0 * d1).sqrt(), d1]];
            (s, [self.uniform(-w, w), self.uniform(-w, w)], [self.uniform(-80.0, 80.0), self.uniform(-80.0, 80.0)])
        }
    }

    #[test]
    fn the_stick_solver_holds_within_breakaway_and_breaks_away_at_it() {
        // Random coupled pairs: S symmetric positive definite, wheels in or out of the band.
        let f = Friction::<f64>::gb37().with_stick(GB37_STICK_SPEED);
        let mut rng = Lcg(11);
        let rate = 1.0 / STICK_TIME;
        let (mut held, mut broke) = (0, 0);
        for _ in 0..20_000 {
            let (s, w, a0) = rng.coupled_pair(0.2);
            let tau = f.torques(w, a0, s);
            for i in 0..2 {
                let accel = a0[i] - s[i][0] * tau[0] - s[i][1] * tau[1];
                if w[i].abs() >= f.stick_speed {
                    assert_eq!(tau[i], f.torque(w[i]), "outside the band: the slip law");
                } else if tau[i].abs() < f.breakaway {
                    held += 1;
                    assert!((accel + rate * w[i]).abs() < 1e-9 * (1.0 + a0[i].abs()), "held: ẇ = −w/T_k ({accel})");
                } else {
                    broke += 1;
                    assert_eq!(tau[i].abs(), f.breakaway, "breaking away at τ_s");
                    // It breaks away because holding would take more, in the same direction.
                    let alone = (a0[i] + rate * w[i] - s[i][1 - i] * tau[1 - i]) / s[i][i];
                    assert!(alone.abs() >= f.breakaway * (1.0 - 1e-12) || tau[1 - i].abs() == f.breakaway, "{alone}");
                }
            }
        }
        std::println!("held {held}, broke away {broke} of the in-band wheels");
        assert!(held > 1000 && broke > 1000);
    }

    #[test]
    fn outside_the_band_the_slip_law_is_the_stick_laws_bits_and_notes_a_wheel_in_it() {
        // As above, one or two wheels, some of them in the band.
        let f = Friction::<f64>::gb37().with_stick(GB37_STICK_SPEED);
        let mut rng = Lcg(5);
        let (mut clear, mut in_band) = (0, 0);
        for _ in 0..20_000 {
            let (s, w, a0) = rng.coupled_pair(1.0);
            let band = Cell::new(false);
            let outside = Gearhead::Outside(&f, &band);
            let two = outside.held_torques(w, a0, s);
            let wheels_in = w.iter().any(|v| v.abs() < f.stick_speed);
            assert_eq!(band.get(), wheels_in, "{w:?}");
            if !wheels_in {
                clear += 1;
                assert_eq!(two.map(f64::to_bits), Gearhead::Stick(&f).held_torques(w, a0, s).map(f64::to_bits));
            } else {
                in_band += 1;
            }
            let one = Cell::new(false);
            let [tau] = Gearhead::Outside(&f, &one).held_torques([w[0]], [a0[0]], [[s[0][0]]]);
            assert_eq!(one.get(), w[0].abs() < f.stick_speed);
            if !one.get() {
                assert_eq!(tau.to_bits(), f.held_torques([w[0]], [a0[0]], [[s[0][0]]])[0].to_bits());
            }
        }
        assert!(clear > 1000 && in_band > 1000, "{clear} clear, {in_band} in the band");
    }

    /// Both models with friction on, and their per-wheel relative speeds.
    mod in_the_models {
        use super::*;
        use crate::model::planar::PlanarState;
        use crate::{rk4_step, Dynamics, PlanarModel, RobotParams, SlopeModel};
        use nalgebra::{SVector, Vector4};

        fn rough() -> Friction<f64> {
            Friction { viscous: 2e-3, ..Friction::gb37() }
        }

        /// dE/dt along the flow, by a central difference (error O(h²)).
        fn energy_rate<M: Dynamics<f64, N, U>, const N: usize, const U: usize>(
            m: &M,
            x: &SVector<f64, N>,
            u: &SVector<f64, U>,
        ) -> f64 {
            let h = 1e-6;
            let f = m.deriv(x, u);
            (m.energy(&(x + f * h)) - m.energy(&(x - f * h))) / (2.0 * h)
        }

        #[test]
        fn slope_model_energy_rate_is_input_power_minus_dissipation() {
            let p = RobotParams::<f64>::balanbot();
            for (label, f) in [("slip law", rough()), ("stick band", sticky())] {
                let mut rng = Lcg(3);
                let mut worst: f64 = 0.0;
                for i in 0..500 {
                    let slope = rng.uniform(-0.3, 0.3);
                    let m = SlopeModel::new(p, slope).unwrap().with_friction(Some(f)).unwrap();
                    let x = Vector4::new(rng.uniform(-1.0, 1.0), rng.uniform(-3.0, 3.0), rng.uniform(-5.0, 5.0), rng.uniform(-8.0, 8.0));
                    // Near zero speed too, where the regularisation or the stick band acts.
                    let x = if i % 5 == 0 { Vector4::new(x[0], x[1], x[2], x[1] + rng.uniform(-0.2, 0.2)) } else { x };
                    let u = rng.uniform(-1.0, 1.0);
                    let beta_dot = x[3] - x[1];
                    let power = p.torque_per_amp() * u * beta_dot;
                    // The gearhead's power is w τ for whatever τ acts (held or slipping).
                    let gearhead = 2.0 * beta_dot * m.gearhead_torque_at(&x, u);
                    let dissipation = p.mu_bearing * beta_dot * beta_dot + p.mu_ground * x[3] * x[3] + gearhead;
                    let rate = energy_rate(&m, &x, &SVector::from([u]));
                    let scale = power.abs() + dissipation.abs();
                    let err = (rate - (power - dissipation)).abs() / scale.max(1e-3);
                    worst = worst.max(err);
                }
                std::println!("2-DOF, friction on ({label}): worst relative energy-balance residual {worst:.1e}");
                assert!(worst < 1e-7, "{label}: {worst:e}");
            }
        }

        #[test]
        fn planar_model_energy_rate_is_input_power_minus_dissipation() {
            let p = RobotParams::<f64>::balanbot();
            for (label, f) in [("slip law", rough()), ("stick band", sticky())] {
                let m = PlanarModel::new(p).unwrap().with_friction(Some(f)).unwrap();
                let mut rng = Lcg(5);
                let mut worst: f64 = 0.0;
                let (r, b) = (p.wheel_radius, p.half_track);
                for i in 0..500 {
                    let mut x = PlanarState::from(core::array::from_fn(|_| rng.uniform(-1.2, 1.2)));
                    if i % 5 == 0 {
                        // The right wheel inside or near the band.
                        x[5] = r * (x[4] - b / r * x[6] + rng.uniform(-0.2, 0.2));
                    }
                    let u = SVector::from([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)]);
                    let (w_r, w_l) = m.wheel_speeds(&x);
                    let (spin_r, spin_l) = ((x[5] + b * x[6]) / r, (x[5] - b * x[6]) / r);
                    let power = u[0] * w_r + u[1] * w_l;
                    let [tau_r, tau_l] = m.gearhead_torques_at(&x, &u);
                    let side = |w: f64, spin: f64, tau: f64| 0.5 * p.mu_bearing * w * w + 0.5 * p.mu_ground * spin * spin + w * tau;
                    let dissipation = side(w_r, spin_r, tau_r) + side(w_l, spin_l, tau_l);
                    let rate = energy_rate(&m, &x, &u);
                    let err = (rate - (power - dissipation)).abs() / (power.abs() + dissipation.abs()).max(1e-3);
                    worst = worst.max(err);
                }
                std::println!("3-DOF, friction on ({label}): worst relative energy-balance residual {worst:.1e}");
                assert!(worst < 1e-7, "{label}: {worst:e}");
            }
        }

        /// One wheel's train open (backlash): the engaged wheel's friction, slipping or held,
        /// works against the mass matrix without the open rotor. The energy without that
        /// rotor's then changes at the engaged motor's power less what friction and the
        /// viscous terms dissipate; the open wheel gets no gearhead torque.
        #[test]
        fn planar_energy_balances_with_one_train_open() {
            let p = RobotParams::<f64>::balanbot();
            for (label, f) in [("slip law", rough()), ("stick band", sticky())] {
                let m = PlanarModel::new(p).unwrap().with_friction(Some(f)).unwrap();
                let j = m.rotor_per_wheel();
                let mut rng = Lcg(8);
                let mut worst: f64 = 0.0;
                let (r, b) = (p.wheel_radius, p.half_track);
                let mut held = 0;
                for i in 0..600 {
                    let on = i % 2;
                    let engaged = [on == 0, on == 1];
                    let mut x = PlanarState::from(core::array::from_fn(|_| rng.uniform(-1.2, 1.2)));
                    if i % 3 == 0 {
                        // The engaged wheel inside or near the band.
                        let turn = if on == 0 { b / r * x[6] } else { -b / r * x[6] };
                        x[5] = r * (x[4] - turn + rng.uniform(-0.1, 0.1));
                    }
                    let u = SVector::from([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)]);
                    let (d, tau) = m.deriv_geared(&x, &u, engaged, |_, _| None);
                    let (w_r, w_l) = m.wheel_speeds(&x);
                    let w = [w_r, w_l];
                    assert_eq!(tau[1 - on], 0.0, "the open wheel gets no gearhead torque");
                    held += (w[on].abs() < GB37_STICK_SPEED && tau[on].abs() < f.breakaway) as usize;
                    let energy = |x: &PlanarState<f64>| {
                        let (w_r, w_l) = m.wheel_speeds(x);
                        m.energy(x) - 0.5 * j * [w_r, w_l][1 - on].powi(2)
                    };
                    let h = 1e-6;
                    let rate = (energy(&(x + d * h)) - energy(&(x - d * h))) / (2.0 * h);
                    let (spin_r, spin_l) = ((x[5] + b * x[6]) / r, (x[5] - b * x[6]) / r);
                    let viscous = |w: f64, spin: f64| 0.5 * p.mu_bearing * w * w + 0.5 * p.mu_ground * spin * spin;
                    let dissipation = viscous(w_r, spin_r) + viscous(w_l, spin_l) + w[on] * tau[on];
                    let power = u[on] * w[on];
                    worst = worst.max((rate - (power - dissipation)).abs() / (power.abs() + dissipation.abs()).max(1e-3));
                }
                std::println!("3-DOF, one train open ({label}): worst relative energy-balance residual {worst:.1e}, {held} held");
                assert!(worst < 1e-7, "{label}: {worst:e}");
                assert!(label == "slip law" || held > 20, "{label}: only {held} states held");
            }
        }

        fn sticky() -> Friction<f64> {
            rough().with_stick(GB37_STICK_SPEED)
        }

        #[test]
        fn at_rest_a_held_wheel_takes_the_motor_torque_up_to_breakaway() {
            // Upright and at rest, a wheel held to the body makes the motor torque internal:
            // friction must take all of it, and nothing moves.
            let p = RobotParams::<f64>::balanbot();
            let f = sticky();
            let m = SlopeModel::new(p, 0.0).unwrap().with_friction(Some(f)).unwrap();
            let rest = Vector4::zeros();
            let current = |per_wheel: f64| 2.0 * per_wheel / p.torque_per_amp();
            let held = current(0.9 * f.breakaway);
            assert!(m.deriv(&rest, &SVector::from([held])).norm() < 1e-12, "{}", m.deriv(&rest, &SVector::from([held])));
            assert!((m.gearhead_torque_at(&rest, held) - 0.9 * f.breakaway).abs() < 1e-12);
            // Above breakaway the wheels turn forward against τ_s.
            let slips = current(1.1 * f.breakaway);
            let d = m.deriv(&rest, &SVector::from([slips]));
            assert!(d[3] - d[1] > 1.0, "β̈ = {}", d[3] - d[1]);
            assert_eq!(m.gearhead_torque_at(&rest, slips), f.breakaway);
            // 3-DOF: each wheel on its own; the right one held, the left one breaking away.
            let planar = PlanarModel::new(p).unwrap().with_friction(Some(f)).unwrap();
            let still = PlanarState::zeros();
            let u = SVector::from([0.9 * f.breakaway, -0.5 * f.breakaway]);
            assert!(planar.deriv(&still, &u).norm() < 1e-12);
            let u = SVector::from([0.5 * f.breakaway, -1.2 * f.breakaway]);
            let [tau_r, tau_l] = planar.gearhead_torques_at(&still, &u);
            assert_eq!(tau_l, -f.breakaway);
            assert!(tau_r.abs() < f.breakaway, "the right wheel is held against the left: {tau_r}");
            // The wheels' relative accelerations, from the derivative's ν̇ = (φ̈, v̇, ω̇).
            let d = planar.deriv(&still, &u);
            let (acc_r, acc_l) = planar.wheel_speeds(&PlanarState::from([0.0, 0.0, 0.0, 0.0, d[4], d[5], d[6]]));
            assert!(acc_r.abs() < 1e-9 && acc_l < -1.0, "right {acc_r} held, left {acc_l} turning back");
        }

        #[test]
        fn held_wheels_hold_against_a_force_on_the_body() {
            // A force on the body (the rigs' `Force`) enters before the holding torques are
            // found: the held wheels still relax at ẇ = −w/T_k.
            let p = RobotParams::<f64>::balanbot();
            let m = PlanarModel::new(p).unwrap().with_friction(Some(sticky())).unwrap();
            let x = PlanarState::from([0.0, 0.0, 0.0, -4.2e-5, -1e-10, 4.8e-6, 3.8e-4]);
            let u = SVector::from([0.01, 0.012]);
            let d = m.deriv_plus(&x, &u, |_, _| Some(nalgebra::Vector2::new(0.01, 0.02)));
            let (acc_r, acc_l) = m.wheel_speeds(&PlanarState::from([0.0, 0.0, 0.0, 0.0, d[4], d[5], d[6]]));
            let (w_r, w_l) = m.wheel_speeds(&x);
            let rate = 1.0 / STICK_TIME;
            std::println!("{:?}", d.as_slice());
            assert!((acc_r + rate * w_r).abs() < 1e-9 && (acc_l + rate * w_l).abs() < 1e-9, "{acc_r} {acc_l}");
            let free = PlanarModel::new(p).unwrap();
            assert!((d[4] - free.deriv_plus(&x, &u, |_, _| Some(nalgebra::Vector2::new(0.01, 0.02)))[4]).abs() > 0.1);
            let slope = SlopeModel::new(p, 0.1).unwrap().with_friction(Some(sticky())).unwrap();
            let x = Vector4::new(0.01, 0.2, 0.0, 0.25);
            let d = slope.deriv_plus(&x, 0.05, |_, _| Some(nalgebra::Vector2::new(0.02, -0.03)));
            assert!((d[3] - d[1] + rate * (x[3] - x[1])).abs() < 1e-9, "{}", d[3] - d[1]);
        }

        #[test]
        fn the_stick_state_holds_where_the_regularised_law_creeps() {
            // Upright at rest with a steady torque below breakaway on each wheel: held, the
            // robot stays exactly at rest; the regularised law lets the wheels creep.
            let p = RobotParams::<f64>::balanbot();
            let u = SVector::from([0.6 * sticky().breakaway, 0.6 * sticky().breakaway]);
            let drift = |f: Friction<f64>| {
                let m = PlanarModel::new(p).unwrap().with_friction(Some(f)).unwrap();
                let mut x = PlanarState::zeros();
                for _ in 0..1000 {
                    x = rk4_step(&m, &x, &u, 1e-3);
                }
                x
            };
            let held = drift(sticky());
            let creeping = drift(rough());
            std::println!("after 1 s at 0.6 τ_s: held {:.1e}, regularised {:.1e}", held.norm(), creeping.norm());
            assert!(held.norm() < 1e-12, "{held}");
            assert!(creeping.norm() > 1e-4, "{creeping}");
        }

        #[test]
        fn a_wheel_in_the_band_comes_to_rest() {
            let p = RobotParams::<f64>::balanbot();
            let m = PlanarModel::new(p).unwrap().with_friction(Some(sticky())).unwrap();
            // Rolling slowly forward, unpowered: w = v/R inside the band on both wheels.
            let mut x = PlanarState::from([0.0, 0.0, 0.0, 0.0, 0.0, 0.5 * GB37_STICK_SPEED * p.wheel_radius, 0.0]);
            for _ in 0..60 {
                x = rk4_step(&m, &x, &SVector::zeros(), 1e-3);
            }
            let (w_r, w_l) = m.wheel_speeds(&x);
            // 60 ms = 12 T_k: e^-12 of 0.05 rad/s, give or take the ground's pull.
            assert!(w_r.abs() < 1e-5 && w_l.abs() < 1e-5, "{w_r} {w_l}");
        }

        #[test]
        fn friction_off_is_the_thesis_model_bit_for_bit() {
            let p = RobotParams::<f64>::balanbot();
            let x = Vector4::new(0.1, -0.4, 2.0, 3.0);
            let plain = SlopeModel::new(p, 0.1).unwrap();
            let off = plain.with_friction(None).unwrap();
            assert_eq!(plain.deriv(&x, &SVector::from([0.3])), off.deriv(&x, &SVector::from([0.3])));
            let xp = PlanarState::from([0.1, 0.2, 0.3, 0.1, -0.4, 0.5, 1.0]);
            let plain = PlanarModel::new(p).unwrap();
            let u = SVector::from([0.05, -0.02]);
            assert_eq!(plain.deriv(&xp, &u), plain.with_friction(None).unwrap().deriv(&xp, &u));
            // And friction on changes it.
            assert_ne!(plain.deriv(&xp, &u), plain.with_friction(Some(rough())).unwrap().deriv(&xp, &u));
        }

        /// ‖x(T; h) − x(T; h/2)‖ for h = 4, 2, 1 ms: RK4's error falls ~16x per halving.
        fn order_ratios<M: Dynamics<f64, N, U>, const N: usize, const U: usize>(
            m: &M,
            x0: &SVector<f64, N>,
            u: &SVector<f64, U>,
            speeds: impl Fn(&SVector<f64, N>) -> f64,
        ) -> (f64, f64) {
            let run = |h: f64| {
                let mut x = *x0;
                let mut slowest = f64::INFINITY;
                for _ in 0..(0.256 / h).round() as usize {
                    x = rk4_step(m, &x, u, h);
                    slowest = slowest.min(speeds(&x));
                }
                // Away from stick-slip: no wheel comes near zero relative speed.
                assert!(slowest > 1.0, "a wheel slowed to {slowest} rad/s");
                x
            };
            let xs: [_; 4] = core::array::from_fn(|i| run(8e-3 / (1 << i) as f64));
            let d: [f64; 3] = core::array::from_fn(|i| (xs[i] - xs[i + 1]).norm());
            (d[0] / d[1], d[1] / d[2])
        }

        #[test]
        fn rk4_stays_fourth_order_with_friction_on() {
            let p = RobotParams::<f64>::balanbot();
            for (label, f) in [("slip law", rough()), ("stick band", sticky())] {
                let slope = SlopeModel::new(p, 0.05).unwrap().with_friction(Some(f)).unwrap();
                let (a, b) = order_ratios(&slope, &Vector4::new(0.2, 1.0, 0.0, 12.0), &SVector::from([0.5]), |x| (x[3] - x[1]).abs());
                std::println!("2-DOF with friction ({label}): RK4 error ratio per halving {a:.4}, {b:.4}");
                let planar = PlanarModel::new(p).unwrap().with_friction(Some(f)).unwrap();
                let x0 = PlanarState::from([0.0, 0.0, 0.0, 0.2, 1.0, 0.4, 2.0]);
                let (c, d) = order_ratios(&planar, &x0, &SVector::from([0.2, 0.15]), |x| {
                    let (w_r, w_l) = planar.wheel_speeds(x);
                    w_r.abs().min(w_l.abs())
                });
                std::println!("3-DOF with friction ({label}): RK4 error ratio per halving {c:.4}, {d:.4}");
                for r in [a, b, c, d] {
                    assert!((12.0..20.0).contains(&r), "{label}: ratio {r} (4th order gives 16)");
                }
            }
        }

        #[test]
        fn rk4_stays_fourth_order_while_the_wheels_are_held() {
            // The body tips over with the wheels held to it: the holding torque is smooth in
            // the state, and stays below breakaway for the whole run.
            let p = RobotParams::<f64>::balanbot();
            let f = sticky();
            let m = SlopeModel::new(p, 0.0).unwrap().with_friction(Some(f)).unwrap();
            let u = SVector::from([0.0]);
            let run = |h: f64| {
                let mut x = Vector4::new(0.05, 0.0, 0.0, 0.0);
                for _ in 0..(0.256 / h).round() as usize {
                    x = rk4_step(&m, &x, &u, h);
                    assert!(m.gearhead_torque_at(&x, 0.0).abs() < f.breakaway, "broke away");
                }
                x
            };
            let xs: [_; 4] = core::array::from_fn(|i| run(8e-3 / (1 << i) as f64));
            assert!((xs[3][3] - xs[3][1]).abs() < 1e-12, "held: β̇ = {}", xs[3][3] - xs[3][1]);
            assert!(xs[3][0] > 0.06, "the body tips: φ = {}", xs[3][0]);
            let d: [f64; 3] = core::array::from_fn(|i| (xs[i] - xs[i + 1]).norm());
            let (a, b) = (d[0] / d[1], d[1] / d[2]);
            std::println!("2-DOF, wheels held: RK4 error ratio per halving {a:.4}, {b:.4}");
            assert!((12.0..20.0).contains(&a) && (12.0..20.0).contains(&b), "{a} {b}");
        }

        #[test]
        fn equilibrium_pays_the_friction_and_keeps_phi_s() {
            let p = RobotParams::<f64>::balanbot();
            let plain = SlopeModel::new(p, 0.0).unwrap();
            let m = plain.with_friction(Some(Friction::gb37())).unwrap();
            let speed = 180f64.to_radians();
            let (xs, us) = m.equilibrium(speed).unwrap();
            let (xs0, us0) = plain.equilibrium(speed).unwrap();
            assert_eq!(xs, xs0, "gearhead friction is internal: it does not move phi_s");
            let extra = (us - us0) * p.torque_per_amp();
            assert!((extra - 2.0 * Friction::<f64>::gb37().torque(speed)).abs() < 1e-12);
            let d = m.deriv(&xs, &SVector::from([us]));
            assert!(d[1].abs() < 1e-12 && d[3].abs() < 1e-12, "accelerations {} {}", d[1], d[3]);
        }

        #[test]
        fn linearisation_with_friction_matches_finite_differences() {
            let p = RobotParams::<f64>::balanbot();
            let m = SlopeModel::new(p, 0.1).unwrap().with_friction(Some(rough())).unwrap();
            // Near zero relative speed, where friction's slope is steepest.
            let x0 = Vector4::new(0.05, 0.3, 0.0, 0.32);
            let (a, b) = m.linearize(&x0, 0.2);
            let h = 1e-7;
            for j in 0..4 {
                let mut e = Vector4::zeros();
                e[j] = h;
                let col = (m.deriv(&(x0 + e), &SVector::from([0.2])) - m.deriv(&(x0 - e), &SVector::from([0.2]))) / (2.0 * h);
                assert!((col - a.column(j)).norm() < 1e-5 * col.norm().max(1.0), "column {j}");
            }
            let col = (m.deriv(&x0, &SVector::from([0.2 + h])) - m.deriv(&x0, &SVector::from([0.2 - h]))) / (2.0 * h);
            assert!((col - b).norm() < 1e-5 * col.norm());
        }

        #[test]
        fn with_a_stick_band_the_linearisation_is_the_slip_law_that_acts_outside_it() {
            // Outside the band the Jacobians are the model's own; inside it, where the held
            // wheels take no input, they are the same law's, which does not depend on the
            // band's width (a narrower band leaves the point outside: finite differences).
            // They had mixed the two: an A row of [24.8, -0.10, 0, -0.06] in the band.
            let p = RobotParams::<f64>::balanbot();
            let model = |band: f64| SlopeModel::new(p, 0.1).unwrap().with_friction(Some(Friction::gb37().with_stick(band))).unwrap();
            let (wide, narrow) = (model(0.1), model(1e-3));
            let u = SVector::from([0.2]);
            for x0 in [Vector4::new(0.05, 0.3, 0.0, 0.32), Vector4::new(-0.1, 1.0, 0.0, 1.5)] {
                let (a, b) = wide.linearize(&x0, 0.2);
                assert_eq!((a, b), narrow.linearize(&x0, 0.2));
                let h = 1e-7;
                for j in 0..4 {
                    let e = Vector4::from_fn(|i, _| if i == j { h } else { 0.0 });
                    let col = (narrow.deriv(&(x0 + e), &u) - narrow.deriv(&(x0 - e), &u)) / (2.0 * h);
                    assert!((col - a.column(j)).norm() < 1e-5 * col.norm().max(1.0), "column {j}: {col} vs {}", a.column(j));
                }
                let col = (narrow.deriv(&x0, &SVector::from([0.2 + h])) - narrow.deriv(&x0, &SVector::from([0.2 - h]))) / (2.0 * h);
                assert!((col - b).norm() < 1e-5 * col.norm());
            }
        }
    }
}
