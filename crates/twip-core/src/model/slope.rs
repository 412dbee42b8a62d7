//! The 2-DOF model of a TWIP on a slope (thesis 3.1–3.28), re-derived.
//!
//! Coordinates: body pitch `phi` from the vertical and absolute wheel angle `theta`.
//! With the slope `alpha` (forward travel climbs when positive):
//!
//! ```text
//! T = ½ M11 φ̇² + M12(φ) φ̇ θ̇ + ½ M22 θ̇²
//!     M11 = I_b + M_b l² + η² I_M,   M22 = (M_b + M_w) r² + I_w + η² I_M
//!     M12 = M_b r l cos(φ + α) − η² I_M
//! U = M_b g l cos φ + (M_b + M_w) g r θ sin α
//! D = ½ μ_s (θ̇ − φ̇)² + ½ μ_g θ̇²,   the motor torque η τ_i u acts on θ − φ.
//! ```
//!
//! Lagrange's equations give `M(φ) [φ̈, θ̈]ᵀ = f` with
//!
//! ```text
//! f_φ = M_b g l sin φ + μ_s (θ̇ − φ̇) − η τ_i u
//! f_θ = M_b r l sin(φ + α) φ̇² − (M_b + M_w) g r sin α − μ_s (θ̇ − φ̇) − μ_g θ̇ + η τ_i u
//! ```
//!
//! The thesis's second equation (3.21) is the sum of these two rows; its (3.20) carries
//! a Coriolis term that cancels in a correct derivation (docs/errata.md, E1–E3).
use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3, Vector4};

use crate::model::friction::{Friction, Gearhead};
use crate::model::lane::Lane;
use crate::{c, Dynamics, Real, RobotParams, TwipError};

/// State `[phi, phi_dot, theta, theta_dot]`.
pub type SlopeState<T> = Vector4<T>;

/// The 2-DOF slope model; `slope = 0` is the flat-ground model.
#[derive(Clone, Copy, Debug)]
pub struct SlopeModel<T> {
    params: RobotParams<T>,
    slope: T,
    k: SlopeCoefficients<T>,
    /// Gearhead friction per wheel beyond `mu_bearing` (None: the thesis's model).
    friction: Option<Friction<T>>,
}

/// The constants of the equations of motion (see the module docs for the symbols), with
/// the products the derivative needs folded once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlopeCoefficients<T> {
    /// I_b + M_b l² + η² I_M
    pub m11: T,
    /// (M_b + M_w) r² + I_w + η² I_M
    pub m22: T,
    /// m11 · m22, the constant part of det M(φ).
    pub m11_m22: T,
    /// M_b r l
    pub mrl: T,
    /// M_b r l cos α and M_b r l sin α: with them, sin and cos of φ + α need only φ's.
    pub mrl_cos: T,
    pub mrl_sin: T,
    /// η² I_M, the rotors' inertia at the wheels.
    pub rotor: T,
    /// M_b g l
    pub mgl: T,
    /// (M_b + M_w) g r sin α: the slope's load on the wheels.
    pub grade: T,
    /// η τ_i
    pub torque_per_amp: T,
    pub mu_bearing: T,
    pub mu_ground: T,
    pub sin_slope: T,
    pub cos_slope: T,
}

impl<T: Copy> SlopeCoefficients<T> {
    /// Every constant through `f` (into a lane's numbers, say).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // the sweeps' lanes use it
    pub(crate) fn map<U>(&self, f: impl Fn(T) -> U) -> SlopeCoefficients<U> {
        SlopeCoefficients {
            m11: f(self.m11),
            m22: f(self.m22),
            m11_m22: f(self.m11_m22),
            mrl: f(self.mrl),
            mrl_cos: f(self.mrl_cos),
            mrl_sin: f(self.mrl_sin),
            rotor: f(self.rotor),
            mgl: f(self.mgl),
            grade: f(self.grade),
            torque_per_amp: f(self.torque_per_amp),
            mu_bearing: f(self.mu_bearing),
            mu_ground: f(self.mu_ground),
            sin_slope: f(self.sin_slope),
            cos_slope: f(self.cos_slope),
        }
    }
}

/// The thesis's linear model (4.6–4.10) on the reduced state `[phi, phi_dot, theta_dot]`:
/// `ẋ = A x + B u + D`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThesisLinearModel<T: Real> {
    pub a: SMatrix<T, 3, 3>,
    pub b: Vector3<T>,
    pub d: Vector3<T>,
}

impl<T: Real> SlopeModel<T> {
    /// Builds the model; validates the parameters and the slope (|α| < 90°).
    pub fn new(params: RobotParams<T>, slope: T) -> Result<Self, TwipError> {
        let p = params.validate()?;
        if !slope.is_finite() || slope.abs() >= T::frac_pi_2() {
            return Err(TwipError::InvalidParameter {
                name: "slope",
                value: crate::to_f64(slope),
                reason: "must be finite and within (-pi/2, pi/2) rad",
            });
        }
        let (sin_slope, cos_slope) = slope.sin_cos();
        let rotor = p.gear_ratio * p.gear_ratio * p.i_motor;
        let r = p.wheel_radius;
        let l = p.com_height;
        let m11 = p.i_body + p.m_body * l * l + rotor;
        let m22 = (p.m_body + p.m_wheels) * r * r + p.i_wheels + rotor;
        let mrl = p.m_body * r * l;
        let k = SlopeCoefficients {
            m11,
            m22,
            m11_m22: m11 * m22,
            mrl,
            mrl_cos: mrl * cos_slope,
            mrl_sin: mrl * sin_slope,
            rotor,
            mgl: p.m_body * p.g * l,
            grade: (p.m_body + p.m_wheels) * p.g * r * sin_slope,
            torque_per_amp: p.torque_per_amp(),
            mu_bearing: p.mu_bearing,
            mu_ground: p.mu_ground,
            sin_slope,
            cos_slope,
        };
        Ok(Self { params: p, slope, k, friction: None })
    }

    /// This model with gearhead friction on both wheels (validated); `None` turns it off.
    pub fn with_friction(self, friction: Option<Friction<T>>) -> Result<Self, TwipError> {
        let friction = friction.map(|f| f.validate()).transpose()?;
        Ok(Self { friction, ..self })
    }

    /// The gearhead friction per wheel, if any.
    pub fn friction(&self) -> Option<&Friction<T>> {
        self.friction.as_ref()
    }

    /// Each wheel's gearhead friction torque [N m] at state `x` under current `u` (0
    /// without friction): the slip law, or with a stick band whatever holds the wheels.
    pub fn gearhead_torque_at(&self, x: &SlopeState<T>, u: T) -> T {
        self.motion(x, u, |_, _| None).1
    }

    pub fn params(&self) -> &RobotParams<T> {
        &self.params
    }

    pub fn slope(&self) -> T {
        self.slope
    }

    /// The constant coefficients of `deriv`, for code that evaluates many robots at once.
    pub fn coefficients(&self) -> SlopeCoefficients<T> {
        self.k
    }

    /// The mass matrix M(φ) (symmetric positive definite).
    #[inline]
    pub fn mass_matrix(&self, phi: T) -> Matrix2<T> {
        let (s, co) = crate::model::math::sin_cos(phi);
        let m12 = m12(&self.k, s, co, self.k.rotor);
        Matrix2::new(self.k.m11, m12, m12, self.k.m22)
    }

    /// `deriv` with extra generalised forces `extra(sin φ, cos φ)` on (φ, θ): the
    /// disturbed plant's constant force. `|_, _| None` is `deriv`, bit for bit.
    #[inline(always)]
    pub(crate) fn deriv_plus(&self, x: &SlopeState<T>, u: T, extra: impl Fn(T, T) -> Option<Vector2<T>>) -> SlopeState<T> {
        self.motion(x, u, extra).0
    }

    /// The derivative under `extra`, and each wheel's gearhead friction torque
    /// ([`motion`], the one source).
    #[inline(always)]
    fn motion(&self, x: &SlopeState<T>, u: T, extra: impl Fn(T, T) -> Option<Vector2<T>>) -> (SlopeState<T>, T) {
        let (d, tau) = motion(&self.k, Gearhead::of(self.friction.as_ref()), &[x[0], x[1], x[2], x[3]], u, |s, co| extra(s, co).map(|q| [q[0], q[1]]), <T as Lane>::sincos(x[0]));
        (Vector4::from(d), tau)
    }

    /// The derivative with both wheels' gear trains open when not `engaged` (gearbox
    /// backlash, `hardware::backlash`): the wheels get neither the motors' torque nor the
    /// gearhead friction, and the rotors' inertia η² I_M leaves them (the rotors turn on
    /// their own). Also the gearhead friction torque per wheel. Engaged is `deriv_plus`.
    // Always inlined: it is the rigs' derivative under backlash, called at every RK4 stage.
    #[inline(always)]
    pub fn deriv_geared(
        &self,
        x: &SlopeState<T>,
        u: T,
        engaged: bool,
        extra: impl Fn(T, T) -> Option<Vector2<T>>,
    ) -> (SlopeState<T>, T) {
        if engaged {
            return self.motion(x, u, extra);
        }
        let open = open_motion(&self.k, &[x[0], x[1], x[2], x[3]], |s, co| extra(s, co).map(|q| [q[0], q[1]]), <T as Lane>::sincos(x[0]));
        (Vector4::from(open), T::zero())
    }

    /// The plastic impact of the open trains' rotors, turning at `rotor_speed` relative
    /// to the body, on the wheels' flanks (gearbox backlash): one impulse P on β = θ − φ
    /// against the rotorless mass matrix leaves rotors and wheels at one relative speed.
    /// Updates φ̇ and θ̇ in `x`; returns that speed.
    pub fn engage(&self, x: &mut SlopeState<T>, rotor_speed: T) -> T {
        let j = self.k.rotor;
        // The response to a torque on β: it enters f as (−1, 1).
        let (s, co) = crate::model::math::sin_cos(x[0]);
        let r = self.rotorless_accelerations(&[-T::one(), T::one()], s, co);
        let impulse = (rotor_speed - (x[3] - x[1])) / ((r[1] - r[0]) + T::one() / j);
        x[1] += r[0] * impulse;
        x[3] += r[1] * impulse;
        rotor_speed - impulse / j
    }

    /// The reflected rotor inertia η² I_M of both motors, at the wheels [kg m²].
    pub fn rotor_inertia(&self) -> T {
        self.k.rotor
    }

    /// q̈ = M(φ)⁻¹ q: the accelerations generalised forces `q` give at pitch `φ`.
    pub fn solve_mass(&self, phi: T, q: &Vector2<T>) -> Vector2<T> {
        let (s, co) = crate::model::math::sin_cos(phi);
        self.accelerations(&[q[0], q[1]], m12(&self.k, s, co, self.k.rotor))
    }

    /// Accelerations [φ̈, θ̈] under forces `f` given M12 (one division).
    #[inline(always)]
    fn accelerations(&self, f: &[T; 2], m12: T) -> Vector2<T> {
        Vector2::from(cramer(self.k.m11, self.k.m22, self.k.m11_m22, m12, f))
    }

    /// The same without the rotors (both gear trains open): they add η² I_M to M11 and
    /// M22 and take it from M12.
    #[inline(always)]
    fn rotorless_accelerations(&self, f: &[T; 2], sin_phi: T, cos_phi: T) -> Vector2<T> {
        Vector2::from(rotorless_accelerations(&self.k, f, sin_phi, cos_phi))
    }

    /// Exact Jacobians `(A, B)` of `ẋ = f(x, u)` at any operating point `(x0, u0)`. With a
    /// gearhead friction's stick band, the Jacobians of the slip law that acts outside the
    /// band, there too: inside it the held wheels take no input (B = 0), which is no model
    /// to design on (upright at rest is inside), and the law is not smooth at its edge.
    pub fn linearize(&self, x0: &SlopeState<T>, u0: T) -> (SMatrix<T, 4, 4>, Vector4<T>) {
        let p = &self.params;
        let (mut out, _) = forces_plus(&self.k, Gearhead::of(self.friction.as_ref()), &[x0[0], x0[1], x0[2], x0[3]], u0, |_, _| None, <T as Lane>::sincos(x0[0]));
        if let Some(f) = self.friction.as_ref().filter(|f| f.sticks()) {
            // The band's model adds its torque once it knows what holds the wheels; here
            // it is the slip law's, as outside the band.
            let slip = c::<T>(2.0) * f.torque(x0[3] - x0[1]);
            out.f = [out.f[0] + slip, out.f[1] - slip];
        }
        let (sin_phi, cos_phi) = (out.sin_phi, out.cos_phi);
        let qdd = self.accelerations(&out.f, m12(&self.k, sin_phi, cos_phi, self.k.rotor));
        // M_b r l sin(φ + α) and M_b r l cos(φ + α).
        let (mrl_sin_pa, mrl_cos_pa) = (mrl_sin_pa(&self.k, sin_phi, cos_phi), m12(&self.k, sin_phi, cos_phi, T::zero()));
        let m = self.mass_matrix(x0[0]);
        // M is positive definite for valid parameters, so the inverse exists.
        let minv = m.try_inverse().unwrap_or_else(Matrix2::zeros);
        let phi_dot = x0[1];
        // d f / d(phi, phi_dot, theta_dot, u); theta does not enter.
        let df_dphi = Vector2::new(
            self.k.mgl * x0[0].cos(),
            mrl_cos_pa * phi_dot * phi_dot,
        );
        // dM/dphi only has the off-diagonal -M_b r l sin(phi + alpha).
        let dm12 = -mrl_sin_pa;
        let dm_qdd = Vector2::new(dm12 * qdd[1], dm12 * qdd[0]);
        let col_phi = minv * (df_dphi - dm_qdd);
        let two = c::<T>(2.0);
        // The bearing's slope d(torque)/dβ̇: viscous plus the gearhead friction's.
        let mu = p.mu_bearing + self.friction.map_or(T::zero(), |f| two * f.slope(x0[3] - phi_dot));
        let col_phi_dot = minv * Vector2::new(-mu, two * mrl_sin_pa * phi_dot + mu);
        let col_theta_dot = minv * Vector2::new(mu, -mu - p.mu_ground);
        let col_u = minv * Vector2::new(-self.k.torque_per_amp, self.k.torque_per_amp);
        let (z, o) = (T::zero(), T::one());
        #[rustfmt::skip]
        let a = SMatrix::<T, 4, 4>::new(
            z,          o,              z, z,
            col_phi[0], col_phi_dot[0], z, col_theta_dot[0],
            z,          z,              z, o,
            col_phi[1], col_phi_dot[1], z, col_theta_dot[1],
        );
        (a, Vector4::new(z, col_u[0], z, col_u[1]))
    }

    /// The thesis's linear model (4.2)–(4.10), linearised at φ = 0 with cos(φ+α) ≈ cos α,
    /// with the slope term of (4.5) corrected to (M_w + M_b) g r sin α (errata E4).
    pub fn linearize_thesis(&self) -> ThesisLinearModel<T> {
        let p = &self.params;
        let mrl_c = self.k.mrl * self.k.cos_slope;
        let l = p.com_height;
        // (4.2): row 1 is the pitch equation, row 2 the sum of both (3.24).
        let a = Matrix2::new(
            self.k.m11,
            mrl_c - self.k.rotor,
            mrl_c + p.m_body * l * l + p.i_body,
            (p.m_body + p.m_wheels) * p.wheel_radius * p.wheel_radius + mrl_c + p.i_wheels,
        );
        let ainv = a.try_inverse().unwrap_or_else(Matrix2::zeros);
        #[rustfmt::skip]
        let cm = SMatrix::<T, 2, 3>::new(
            -self.k.mgl, p.mu_bearing, -p.mu_bearing,
            -self.k.mgl, T::zero(),    p.mu_ground,
        );
        let abar = -(ainv * cm);
        let dbar = -(ainv * Vector2::new(T::zero(), self.k.grade));
        let bbar = ainv * Vector2::new(-self.k.torque_per_amp, T::zero());
        let (z, o) = (T::zero(), T::one());
        #[rustfmt::skip]
        let a3 = SMatrix::<T, 3, 3>::new(
            z,          o,          z,
            abar[(0, 0)], abar[(0, 1)], abar[(0, 2)],
            abar[(1, 0)], abar[(1, 1)], abar[(1, 2)],
        );
        ThesisLinearModel {
            a: a3,
            b: Vector3::new(z, bbar[0], bbar[1]),
            d: Vector3::new(z, dbar[0], dbar[1]),
        }
    }

    /// Steady state of the nonlinear model at wheel speed `theta_dot_ref`:
    /// `x_s = [φ_s, 0, 0, θ̇_ref]` (θ is free; 0 is returned) and the current `u_s`.
    /// φ_s is the corrected (4.42): sin φ_s = ((M_b + M_w) g r sin α + μ_g θ̇_ref) / (M_b g l).
    pub fn equilibrium(&self, theta_dot_ref: T) -> Result<(SlopeState<T>, T), TwipError> {
        check_speed(theta_dot_ref)?;
        let sin_phi = (self.k.grade + self.params.mu_ground * theta_dot_ref) / self.k.mgl;
        if sin_phi.abs() >= T::one() {
            return Err(TwipError::NoEquilibrium {
                reason: "slope load and ground friction exceed what gravity on the body can balance (sin phi_s)",
                value: crate::to_f64(sin_phi),
            });
        }
        let phi_s = sin_phi.asin();
        // Gearhead friction needs more current but, internal to the robot, leaves φ_s alone.
        let bearing = self.params.mu_bearing * theta_dot_ref
            + self.friction.map_or(T::zero(), |f| c::<T>(2.0) * f.torque(theta_dot_ref));
        let u_s = (self.k.mgl * sin_phi + bearing) / self.k.torque_per_amp;
        Ok((Vector4::new(phi_s, T::zero(), T::zero(), theta_dot_ref), u_s))
    }

    /// Steady state of the thesis's linear model, (4.12) and (4.13).
    pub fn equilibrium_linear(&self, theta_dot_ref: T) -> Result<(SlopeState<T>, T), TwipError> {
        check_speed(theta_dot_ref)?;
        let m = self.linearize_thesis();
        let (a11, a13, a21, a23) = (m.a[(1, 0)], m.a[(1, 2)], m.a[(2, 0)], m.a[(2, 2)]);
        let (b1, b2, d1, d2) = (m.b[1], m.b[2], m.d[1], m.d[2]);
        let phi_s = ((a23 * b1 - a13 * b2) * theta_dot_ref + b1 * d2 - b2 * d1) / (a11 * b2 - a21 * b1);
        let u_s = ((a11 * a23 - a13 * a21) * theta_dot_ref + a11 * d2 - a21 * d1) / (a21 * b1 - a11 * b2);
        Ok((Vector4::new(phi_s, T::zero(), T::zero(), theta_dot_ref), u_s))
    }
}

fn check_speed<T: Real>(theta_dot_ref: T) -> Result<(), TwipError> {
    if theta_dot_ref.is_finite() {
        Ok(())
    } else {
        Err(TwipError::InvalidParameter {
            name: "theta_dot_ref",
            value: crate::to_f64(theta_dot_ref),
            reason: "must be finite",
        })
    }
}

impl<T: Real> Dynamics<T, 4, 1> for SlopeModel<T> {
    #[inline(always)]
    fn deriv(&self, x: &SlopeState<T>, u: &SVector<T, 1>) -> SlopeState<T> {
        // The thesis's plant on a path of its own, the same operations as `deriv_plus`'s
        // without friction: through it, a run matched the gearhead's kind at every RK4
        // stage and computed the friction law's w/ω_s ahead of the match.
        if self.friction.is_none() {
            return Vector4::from(deriv(&self.k, &[x[0], x[1], x[2], x[3]], u[0]));
        }
        self.deriv_plus(x, u[0], |_, _| None)
    }

    fn energy(&self, x: &SlopeState<T>) -> T {
        let half = c::<T>(0.5);
        let m = self.mass_matrix(x[0]);
        let (phi_dot, theta_dot) = (x[1], x[3]);
        let kinetic = half * m[(0, 0)] * phi_dot * phi_dot
            + m[(0, 1)] * phi_dot * theta_dot
            + half * m[(1, 1)] * theta_dot * theta_dot;
        kinetic + self.k.mgl * x[0].cos() + self.k.grade * x[2]
    }
}

// The equations of motion, written once over `Lane`: a run evaluates them in `T`, a
// sweep's lanes in `Fused` (multiply-adds fused).

/// The generalised forces f of `M(φ) q̈ = f`, with sin φ and cos φ for reuse.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Forces<S> {
    pub f: [S; 2],
    pub sin_phi: S,
    pub cos_phi: S,
}

/// f at state `x` under current `u`, given (sin φ, cos φ) of x's pitch.
#[inline(always)]
pub(crate) fn forces_at<S: Lane>(k: &SlopeCoefficients<S>, x: &[S; 4], u: S, (s, c): (S, S)) -> Forces<S> {
    let (phi_dot, theta_dot) = (x[1], x[3]);
    let bearing = k.mu_bearing * (theta_dot - phi_dot);
    let motor = k.torque_per_amp * u;
    let f_phi = S::madd(k.mgl, s, bearing) - motor;
    // k_t u − the grade's pull, less the bearing and the ground's friction.
    let drive = S::madd(k.torque_per_amp, u, -k.grade);
    let friction = S::madd(-k.mu_ground, theta_dot, drive - bearing);
    // M_b r l sin(φ + α) φ̇², the centripetal term.
    let f_theta = S::madd(mrl_sin_pa(k, s, c) * phi_dot, phi_dot, friction);
    Forces { f: [f_phi, f_theta], sin_phi: s, cos_phi: c }
}

/// M_b r l sin(φ + α) from sin φ and cos φ.
#[inline(always)]
pub(crate) fn mrl_sin_pa<S: Lane>(k: &SlopeCoefficients<S>, sin_phi: S, cos_phi: S) -> S {
    S::madd(k.mrl_cos, sin_phi, k.mrl_sin * cos_phi)
}

/// M12 = M_b r l cos(φ + α) − `rotor` (η² I_M engaged, 0 with the gear trains open).
#[inline(always)]
pub(crate) fn m12<S: Lane>(k: &SlopeCoefficients<S>, sin_phi: S, cos_phi: S, rotor: S) -> S {
    S::madd(k.mrl_cos, cos_phi, S::madd(-k.mrl_sin, sin_phi, -rotor))
}

/// [M11 M12; M12 M22]⁻¹ f by Cramer's rule (one division); `m11_m22` = M11 M22.
#[inline(always)]
pub(crate) fn cramer<S: Lane>(m11: S, m22: S, m11_m22: S, m12: S, f: &[S; 2]) -> [S; 2] {
    let inv_det = S::splat(1.0) / S::madd(-m12, m12, m11_m22);
    [S::madd(m22, f[0], -(m12 * f[1])) * inv_det, S::madd(m11, f[1], -(m12 * f[0])) * inv_det]
}

/// g1(φ) of the thesis's (4.36): φ̈ per ampere of u at pitch φ, the first entry of
/// M(φ)⁻¹ (−η τ_i, η τ_i).
#[inline(always)]
pub(crate) fn pitch_input_gain<S: Lane>(k: &SlopeCoefficients<S>, phi: S) -> S {
    let (s, c) = S::sincos(phi);
    let tau = k.torque_per_amp;
    cramer(k.m11, k.m22, k.m11_m22, m12(k, s, c, k.rotor), &[-tau, tau])[0]
}

/// 1/g1(φ) ([`pitch_input_gain`]) in one division: det M over the first entry of
/// adj(M) (−η τ_i, η τ_i).
#[inline(always)]
pub(crate) fn inverse_pitch_input_gain<S: Lane>(k: &SlopeCoefficients<S>, phi: S) -> S {
    let (s, c) = S::sincos(phi);
    inverse_pitch_input_gain_at(k, s, c)
}

/// [`inverse_pitch_input_gain`] at the pitch whose sin and cos are given.
#[inline(always)]
pub(crate) fn inverse_pitch_input_gain_at<S: Lane>(k: &SlopeCoefficients<S>, sin_phi: S, cos_phi: S) -> S {
    let (tau, m12) = (k.torque_per_amp, m12(k, sin_phi, cos_phi, k.rotor));
    S::madd(-m12, m12, k.m11_m22) / S::madd(k.m22, -tau, -(m12 * tau))
}

/// [`forces_at`] with both wheels' slip-law gearhead friction `gear` (a torque on β̇ = θ̇ − φ̇,
/// as the bearing's: (+, −) on (φ, θ); none with a stick band, which [`motion`] adds) and
/// `extra(sin φ, cos φ)` added to f when it gives some (an external force on the body):
/// φ's sin/cos (`sin_cos_phi`, of x's pitch) are shared, and `None` costs nothing. Also that
/// gearhead torque.
#[inline(always)]
pub(crate) fn forces_plus<S: Lane>(
    k: &SlopeCoefficients<S>,
    gear: Gearhead<'_, S>,
    x: &[S; 4],
    u: S,
    extra: impl Fn(S, S) -> Option<[S; 2]>,
    sin_cos_phi: (S, S),
) -> (Forces<S>, S) {
    let gearhead = gear.slip_pair(x[3] - x[1]);
    let mut out = forces_at(k, x, u, sin_cos_phi);
    if !matches!(gear, Gearhead::Free) {
        out.f = [out.f[0] + gearhead, out.f[1] - gearhead];
    }
    if let Some(q) = extra(out.sin_phi, out.cos_phi) {
        out.f = [out.f[0] + q[0], out.f[1] + q[1]];
    }
    (out, gearhead)
}

/// The derivative with gearhead friction `gear` on both wheels (`Free`: the thesis's plant)
/// and the extra forces `extra`, and each wheel's gearhead friction torque: the slip
/// law's (in f already), or with a stick band what holds the wheels. A total torque F on
/// β̇ adds (F, −F) to f, so β̈ = a0 − s τ per wheel with s = −2 (r_θ − r_φ), r = M⁻¹ (1, −1).
/// `sin_cos_phi`: (sin φ, cos φ) of x's pitch.
#[inline(always)]
pub(crate) fn motion<S: Lane>(
    k: &SlopeCoefficients<S>,
    gear: Gearhead<'_, S>,
    x: &[S; 4],
    u: S,
    extra: impl Fn(S, S) -> Option<[S; 2]>,
    sin_cos_phi: (S, S),
) -> ([S; 4], S) {
    let (out, gearhead) = forces_plus(k, gear, x, u, extra, sin_cos_phi);
    let m12 = m12(k, out.sin_phi, out.cos_phi, k.rotor);
    let qdd = cramer(k.m11, k.m22, k.m11_m22, m12, &out.f);
    match gear {
        Gearhead::Stick(_) | Gearhead::Outside(..) => {
            let two = S::splat(2.0);
            let r = cramer(k.m11, k.m22, k.m11_m22, m12, &[S::splat(1.0), -S::splat(1.0)]);
            let [tau] = gear.held_torques([x[3] - x[1]], [qdd[1] - qdd[0]], [[-two * (r[1] - r[0])]]);
            let total = two * tau;
            ([x[1], qdd[0] + r[0] * total, x[3], qdd[1] + r[1] * total], tau)
        }
        _ => ([x[1], qdd[0], x[3], qdd[1]], gearhead * S::splat(0.5)),
    }
}

/// The accelerations without the rotors (both gear trains open): they add η² I_M to M11
/// and M22 and take it from M12.
#[inline(always)]
pub(crate) fn rotorless_accelerations<S: Lane>(k: &SlopeCoefficients<S>, f: &[S; 2], sin_phi: S, cos_phi: S) -> [S; 2] {
    let (m11, m22) = (k.m11 - k.rotor, k.m22 - k.rotor);
    cramer(m11, m22, m11 * m22, m12(k, sin_phi, cos_phi, S::splat(0.0)), f)
}

/// The derivative with both wheels' gear trains open (gearbox backlash): the wheels get
/// neither the motors' torque nor the gearhead friction, and lose the rotors' inertia.
/// `sin_cos_phi`: (sin φ, cos φ) of x's pitch.
#[inline(always)]
pub(crate) fn open_motion<S: Lane>(k: &SlopeCoefficients<S>, x: &[S; 4], extra: impl Fn(S, S) -> Option<[S; 2]>, sin_cos_phi: (S, S)) -> [S; 4] {
    let (out, _) = forces_plus(k, Gearhead::Free, x, S::splat(0.0), extra, sin_cos_phi);
    let qdd = rotorless_accelerations(k, &out.f, out.sin_phi, out.cos_phi);
    [x[1], qdd[0], x[3], qdd[1]]
}

/// The derivative of the thesis's plant (no gearhead friction, no external force).
#[inline(always)]
pub(crate) fn deriv<S: Lane>(k: &SlopeCoefficients<S>, x: &[S; 4], u: S) -> [S; 4] {
    deriv_at(k, x, u, S::sincos(x[0]))
}

/// [`deriv`] given (sin φ, cos φ) of x's pitch.
#[inline(always)]
pub(crate) fn deriv_at<S: Lane>(k: &SlopeCoefficients<S>, x: &[S; 4], u: S, sin_cos_phi: (S, S)) -> [S; 4] {
    let out = forces_at(k, x, u, sin_cos_phi);
    let qdd = cramer(k.m11, k.m22, k.m11_m22, m12(k, out.sin_phi, out.cos_phi, k.rotor), &out.f);
    [x[1], qdd[0], x[3], qdd[1]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rk4_step;

    fn frictionless<T: Real>() -> RobotParams<T> {
        let mut p = RobotParams::<T>::balanbot();
        p.mu_bearing = T::zero();
        p.mu_ground = T::zero();
        p
    }

    /// Relative energy drift over `n` RK4 steps from a falling start, no input.
    fn drift<T: Real>(slope: f64, dt: f64, n: usize) -> f64 {
        let model = SlopeModel::<T>::new(frictionless(), c(slope)).unwrap();
        let mut x = Vector4::new(c(0.3), c(0.5), T::zero(), c(2.0));
        let u = SVector::<T, 1>::zeros();
        let e0 = model.energy(&x);
        let mut worst = T::zero();
        for _ in 0..n {
            x = rk4_step(&model, &x, &u, c(dt));
            worst = worst.max((model.energy(&x) - e0).abs());
        }
        crate::to_f64(worst / e0.abs())
    }

    #[test]
    fn energy_is_conserved_in_f64_and_f32() {
        for slope in [0.0, 0.1] {
            assert!(drift::<f64>(slope, 1e-3, 20_000) < 1e-8, "f64 slope {slope}");
            // f32 rounding dominates: a looser, precision-appropriate bound.
            assert!(drift::<f32>(slope, 1e-3, 20_000) < 1e-3, "f32 slope {slope}");
        }
    }

    #[test]
    fn f32_and_f64_agree() {
        let m64 = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.2).unwrap();
        let m32 = SlopeModel::<f32>::new(RobotParams::balanbot(), 0.2).unwrap();
        for k in 0..50 {
            let s = k as f64 / 50.0;
            let x = Vector4::new(s - 0.5, 2.0 * s, 1.0, 3.0 - 5.0 * s);
            let u = SVector::<f64, 1>::new(0.5 - s);
            let d64 = m64.deriv(&x, &u);
            let d32 = m32.deriv(&x.map(|v| v as f32), &u.map(|v| v as f32));
            for i in 0..4 {
                let scale = d64[i].abs().max(1.0);
                assert!((d64[i] - d32[i] as f64).abs() / scale < 1e-4, "component {i}: {d64} vs {d32}");
            }
        }
    }

    #[test]
    fn equilibrium_is_steady_and_rejects_impossible_slopes() {
        let m = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.26).unwrap();
        let (x, u) = m.equilibrium(4.0).unwrap();
        let d = m.deriv(&x, &SVector::<f64, 1>::new(u));
        assert!(d[1].abs() < 1e-12 && d[3].abs() < 1e-12);
        assert!(matches!(m.equilibrium(1e5), Err(TwipError::NoEquilibrium { .. })));
        assert!(matches!(m.equilibrium(f64::NAN), Err(TwipError::InvalidParameter { .. })));
        assert!(SlopeModel::<f64>::new(RobotParams::balanbot(), 1.6).is_err());
    }

    /// The frictionless model's own path in `deriv` is `deriv_plus`'s without friction,
    /// bit for bit, on a slope and on flat ground, far from upright too.
    #[test]
    fn frictionless_deriv_is_deriv_plus_bitwise() {
        for slope in [0.0, -0.2] {
            let m = SlopeModel::<f64>::new(RobotParams::balanbot(), slope).unwrap();
            for k in 0..200 {
                let s = k as f64 / 200.0;
                let x = Vector4::new(6.0 * s - 3.0, 4.0 - 9.0 * s, s, 20.0 * s - 7.0);
                let u = 1.5 - 2.0 * s;
                let (fast, general) = (m.deriv(&x, &SVector::<f64, 1>::new(u)), m.deriv_plus(&x, u, |_, _| None));
                assert!(fast.iter().zip(general.iter()).all(|(a, b)| a.to_bits() == b.to_bits()), "{x} {u}: {fast} vs {general}");
            }
        }
    }

    #[test]
    fn mass_matrix_is_positive_definite() {
        let m = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.3).unwrap();
        for k in 0..100 {
            let mm = m.mass_matrix(k as f64 * 0.1);
            assert!(mm[(0, 0)] > 0.0 && mm.determinant() > 0.0);
        }
    }
}
