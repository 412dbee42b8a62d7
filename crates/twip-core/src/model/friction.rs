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
use crate::{c, to_f64, Real, TwipError};

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
    /// Regularisation speed ω_ε of the sign function [rad/s].
    pub smoothing_speed: T,
}

/// The GB37Y3530-12V-251R data sheet's no-load point (Table 2.3, docs/parameters.md).
pub const GB37_NO_LOAD_CURRENT: f64 = 0.35;
/// No-load speed at the gearbox output [rad/s] (251 rpm).
pub const GB37_NO_LOAD_SPEED: f64 = 251.0 * core::f64::consts::PI / 30.0;
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
        }
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

    /// The friction torque τ_f(w) opposing the relative speed `w` [N m].
    #[inline(always)]
    pub fn torque(&self, w: T) -> T {
        let (level, sign, _, _) = self.parts(w);
        level * sign + self.viscous * w
    }

    /// dτ_f/dw (for linearisation).
    pub fn slope(&self, w: T) -> T {
        let (level, sign, d_level, d_sign) = self.parts(w);
        d_level * sign + level * d_sign + self.viscous
    }

    /// The power the friction dissipates at `w`, w τ_f(w) ≥ 0 [W].
    pub fn dissipation(&self, w: T) -> T {
        w * self.torque(w)
    }

    /// The Stribeck level, the regularised sign, and their derivatives in w.
    #[inline(always)]
    fn parts(&self, w: T) -> (T, T, T, T) {
        let z = w / self.stribeck_speed;
        let hump = (-z * z).exp();
        let peak = self.breakaway - self.coulomb;
        let level = self.coulomb + peak * hump;
        let d_level = -c::<T>(2.0) * z / self.stribeck_speed * peak * hump;
        let sign = (w / self.smoothing_speed).tanh();
        let d_sign = (T::one() - sign * sign) / self.smoothing_speed;
        (level, sign, d_level, d_sign)
    }
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

    /// Both models with friction on, and their per-wheel relative speeds.
    mod in_the_models {
        use super::*;
        use crate::model::planar::PlanarState;
        use crate::{rk4_step, Dynamics, PlanarModel, RobotParams, SlopeModel};
        use nalgebra::{SVector, Vector4};

        /// Uniform in [lo, hi) from a fixed sequence (no dependencies).
        struct Lcg(u64);
        impl Lcg {
            fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
                self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
            }
        }

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
            let f = rough();
            let mut rng = Lcg(3);
            let mut worst: f64 = 0.0;
            for i in 0..500 {
                let slope = rng.uniform(-0.3, 0.3);
                let m = SlopeModel::new(p, slope).unwrap().with_friction(Some(f)).unwrap();
                let x = Vector4::new(rng.uniform(-1.0, 1.0), rng.uniform(-3.0, 3.0), rng.uniform(-5.0, 5.0), rng.uniform(-8.0, 8.0));
                // Near zero speed too, where the regularisation acts.
                let x = if i % 5 == 0 { Vector4::new(x[0], x[1], x[2], x[1] + rng.uniform(-0.2, 0.2)) } else { x };
                let u = rng.uniform(-1.0, 1.0);
                let beta_dot = x[3] - x[1];
                let power = p.torque_per_amp() * u * beta_dot;
                let dissipation = p.mu_bearing * beta_dot * beta_dot
                    + p.mu_ground * x[3] * x[3]
                    + 2.0 * f.dissipation(beta_dot);
                let rate = energy_rate(&m, &x, &SVector::from([u]));
                let scale = power.abs() + dissipation;
                let err = (rate - (power - dissipation)).abs() / scale.max(1e-3);
                worst = worst.max(err);
            }
            std::println!("2-DOF, friction on: worst relative energy-balance residual {worst:.1e}");
            assert!(worst < 1e-7, "{worst:e}");
        }

        #[test]
        fn planar_model_energy_rate_is_input_power_minus_dissipation() {
            let p = RobotParams::<f64>::balanbot();
            let f = rough();
            let m = PlanarModel::new(p).unwrap().with_friction(Some(f)).unwrap();
            let mut rng = Lcg(5);
            let mut worst: f64 = 0.0;
            let r = p.wheel_radius;
            for _ in 0..500 {
                let x = PlanarState::from(core::array::from_fn(|_| rng.uniform(-1.2, 1.2)));
                let u = SVector::from([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)]);
                let (w_r, w_l) = m.wheel_speeds(&x);
                let b = p.half_track;
                let (spin_r, spin_l) = ((x[5] + b * x[6]) / r, (x[5] - b * x[6]) / r);
                let power = u[0] * w_r + u[1] * w_l;
                let side = |w: f64, spin: f64| 0.5 * p.mu_bearing * w * w + 0.5 * p.mu_ground * spin * spin + f.dissipation(w);
                let dissipation = side(w_r, spin_r) + side(w_l, spin_l);
                let rate = energy_rate(&m, &x, &u);
                let err = (rate - (power - dissipation)).abs() / (power.abs() + dissipation).max(1e-3);
                worst = worst.max(err);
            }
            std::println!("3-DOF, friction on: worst relative energy-balance residual {worst:.1e}");
            assert!(worst < 1e-7, "{worst:e}");
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
            let f = rough();
            let slope = SlopeModel::new(p, 0.05).unwrap().with_friction(Some(f)).unwrap();
            let (a, b) = order_ratios(&slope, &Vector4::new(0.2, 1.0, 0.0, 12.0), &SVector::from([0.5]), |x| (x[3] - x[1]).abs());
            std::println!("2-DOF with friction: RK4 error ratio per halving {a:.4}, {b:.4}");
            let planar = PlanarModel::new(p).unwrap().with_friction(Some(f)).unwrap();
            let x0 = PlanarState::from([0.0, 0.0, 0.0, 0.2, 1.0, 0.4, 2.0]);
            let (c, d) = order_ratios(&planar, &x0, &SVector::from([0.2, 0.15]), |x| {
                let (w_r, w_l) = planar.wheel_speeds(x);
                w_r.abs().min(w_l.abs())
            });
            std::println!("3-DOF with friction: RK4 error ratio per halving {c:.4}, {d:.4}");
            for r in [a, b, c, d] {
                assert!((12.0..20.0).contains(&r), "ratio {r} (4th order gives 16)");
            }
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
    }
}
