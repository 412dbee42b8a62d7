//! The 3-DOF planar model (thesis 3.29–3.48), re-derived.
//!
//! Full coordinates `q = (x, y, ψ, φ, θ_r, θ_l)`; the wheels roll without slipping, so
//! `q̇ = S(q) ν` with the quasi-velocities `ν = (φ̇, v, ω)`:
//!
//! ```text
//! ẋ = v cos ψ,  ẏ = v sin ψ,  ψ̇ = ω,  θ̇_r = (v + b ω)/R,  θ̇_l = (v − b ω)/R.
//! ```
//!
//! Per side: wheel mass m_w = M_w/2, spin inertia I_wa = I_w/2, diametral inertia I_wd,
//! rotor η² (I_M/2) on θ_side − φ. With the body COM at c_z along the body axis, the
//! Lagrange–d'Alembert equations `Sᵀ (d/dt ∂L/∂q̇ − ∂L/∂q + ∂D/∂q̇ − Q) = 0` give
//! `M(φ) ν̇ + h(φ, ν) = B u` with (k = M_b c_z² + I_xx − I_zz, s = sin φ, c = cos φ)
//!
//! ```text
//! M = [ m_φφ                 M_b c_z c − η² I_M/R   0     ]
//!     [ M_b c_z c − η² I_M/R m_vv                   0     ]
//!     [ 0                    0                      m_ωω(φ)]
//!   m_φφ = M_b c_z² + I_yy + η² I_M
//!   m_vv = M_b + M_w + (I_w + η² I_M)/R²
//!   m_ωω = I_zz + k s² + 2 I_wd + b² (M_w + (I_w + η² I_M)/R²)
//! h_φ = −M_b g c_z s − k s c ω² + μ_s φ̇ − μ_s v/R
//! h_v = −M_b c_z s (φ̇² + ω²) + (μ_s + μ_g) v/R² − μ_s φ̇/R
//! h_ω = 2 k s c φ̇ ω + M_b c_z s v ω + b² (μ_s + μ_g) ω/R²
//! B   = [[−1, −1], [1/R, 1/R], [b/R, −b/R]]
//! ```
//!
//! The yaw row decouples in `M`; the `−M_b c_z s ω²` of `h_v` and the `M_b c_z s v ω` of
//! `h_ω` come from the rolling constraint (a vakonomic derivation would miss them). With
//! ω = 0 the (φ, v) rows are the 2-DOF flat model with v = R θ̇. The thesis's printed
//! (3.38)–(3.48) carry several typos; docs/errata.md lists them (P1–P8).
use nalgebra::{Matrix3, SVector, Vector2, Vector3};

use crate::model::friction::{Friction, Gearhead};
use crate::model::lane::{fill, Lane};
use crate::model::slope::cramer;
use crate::{c, Dynamics, Real, RobotParams, TwipError};

/// State `[x, y, psi, phi, phi_dot, v, omega]`.
pub type PlanarState<T> = SVector<T, 7>;

/// The 3-DOF model on flat ground; input `[u_r, u_l]`, motor torques [N m] on the wheels.
#[derive(Clone, Copy, Debug)]
pub struct PlanarModel<T> {
    params: RobotParams<T>,
    coef: PlanarCoefficients<T>,
    /// Gearhead friction per wheel beyond `mu_bearing` (None: the thesis's model).
    friction: Option<Friction<T>>,
}

/// The coefficients of `M ν̇ + h = B u` that do not depend on the state: what a run and a
/// sweep's lanes evaluate the equations of motion with.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlanarCoefficients<S> {
    /// m_φφ = M_b c_z² + I_yy + η² I_M
    pub m_pp: S,
    /// m_vv = M_b + M_w + (I_w + η² I_M)/R²
    pub m_vv: S,
    /// m_φφ m_vv
    pub m_pp_vv: S,
    /// The constant part of m_ωω: I_zz + 2 I_wd + b² m_vv|_{M_b = 0}
    pub m_ww0: S,
    /// k = M_b c_z² + I_xx − I_zz (m_ωω = m_ωω0 + k sin²φ)
    pub k: S,
    /// 2 k
    pub two_k: S,
    /// M_b c_z
    pub mbc: S,
    /// η² I_M / R: the rotor's share of m_φv.
    pub rotor_r: S,
    /// M_b g c_z
    pub mgc: S,
    /// μ_s
    pub mu_s: S,
    /// μ_s / R
    pub mu_s_r: S,
    /// (μ_s + μ_g) / R²
    pub mu_v: S,
    /// b² (μ_s + μ_g) / R²
    pub mu_w: S,
    /// 1 / R
    pub inv_r: S,
    /// b / R
    pub b_r: S,
}

/// How many coefficients [`PlanarCoefficients`] holds.
pub(crate) const PLANAR_COEFFICIENTS: usize = 15;

impl<T: Copy> PlanarCoefficients<T> {
    /// The coefficients in declaration order (a sweep keeps one array per coefficient).
    pub(crate) fn to_array(self) -> [T; PLANAR_COEFFICIENTS] {
        [
            self.m_pp, self.m_vv, self.m_pp_vv, self.m_ww0, self.k, self.two_k, self.mbc, self.rotor_r, self.mgc,
            self.mu_s, self.mu_s_r, self.mu_v, self.mu_w, self.inv_r, self.b_r,
        ]
    }

    /// The entries of the wheels' rows.
    #[inline(always)]
    pub(crate) fn wheels(&self) -> WheelRows<T> {
        WheelRows { inv_r: self.inv_r, b_r: self.b_r }
    }

    /// Every coefficient through `f` (onto a sweep's lanes, say).
    pub(crate) fn map<S: Copy>(self, f: impl Fn(T) -> S) -> PlanarCoefficients<S> {
        PlanarCoefficients::from_array(self.to_array().map(f))
    }

    /// The coefficients from [`Self::to_array`]'s order.
    #[inline(always)]
    pub(crate) fn from_array(a: [T; PLANAR_COEFFICIENTS]) -> Self {
        let [m_pp, m_vv, m_pp_vv, m_ww0, k, two_k, mbc, rotor_r, mgc, mu_s, mu_s_r, mu_v, mu_w, inv_r, b_r] = a;
        Self { m_pp, m_vv, m_pp_vv, m_ww0, k, two_k, mbc, rotor_r, mgc, mu_s, mu_s_r, mu_v, mu_w, inv_r, b_r }
    }
}

impl<T: Real> PlanarModel<T> {
    /// Builds the model from validated parameters; all coefficients are computed here.
    pub fn new(params: RobotParams<T>) -> Result<Self, TwipError> {
        let p = params.validate()?;
        let r = p.wheel_radius;
        let cz = p.com_height;
        let b = p.half_track;
        let rotor = p.gear_ratio * p.gear_ratio * p.i_motor;
        let r2 = r * r;
        let wheel_line = p.m_wheels + (p.i_wheels + rotor) / r2;
        let mbc = p.m_body * cz;
        let k = mbc * cz + p.i_body_roll - p.i_body_yaw;
        let two = c::<T>(2.0);
        let (m_pp, m_vv) = (mbc * cz + p.i_body + rotor, p.m_body + wheel_line);
        let coef = PlanarCoefficients {
            m_pp,
            m_vv,
            m_pp_vv: m_pp * m_vv,
            m_ww0: p.i_body_yaw + two * p.i_wheel_diam + b * b * wheel_line,
            k,
            two_k: two * k,
            mbc,
            rotor_r: rotor / r,
            mgc: mbc * p.g,
            mu_s: p.mu_bearing,
            mu_s_r: p.mu_bearing / r,
            mu_v: (p.mu_bearing + p.mu_ground) / r2,
            mu_w: b * b * (p.mu_bearing + p.mu_ground) / r2,
            inv_r: T::one() / r,
            b_r: b / r,
        };
        Ok(Self {
            params: p,
            coef,
            friction: None,
        })
    }

    /// This model with gearhead friction on each wheel (validated); `None` turns it off.
    pub fn with_friction(self, friction: Option<Friction<T>>) -> Result<Self, TwipError> {
        let friction = friction.map(|f| f.validate()).transpose()?;
        Ok(Self { friction, ..self })
    }

    /// The gearhead friction per wheel, if any.
    pub fn friction(&self) -> Option<&Friction<T>> {
        self.friction.as_ref()
    }

    /// Each wheel's speed relative to the body, θ̇_side − φ̇ = (v ± b ω)/R − φ̇ [rad/s].
    #[inline(always)]
    pub fn wheel_speeds(&self, x: &PlanarState<T>) -> (T, T) {
        let [w_r, w_l] = wheel_speeds(&self.coef, &(*x).into());
        (w_r, w_l)
    }

    pub fn params(&self) -> &RobotParams<T> {
        &self.params
    }

    /// The coefficients of the equations of motion (a sweep's lanes evaluate them).
    pub(crate) fn coefficients(&self) -> PlanarCoefficients<T> {
        self.coef
    }

    /// The mass matrix M(φ) of `M ν̇ + h = B u`, ν = (φ̇, v, ω): symmetric positive definite.
    #[inline]
    pub fn mass_matrix(&self, phi: T) -> Matrix3<T> {
        let (s, cp) = phi.sin_cos();
        // Symmetric: its rows are its columns.
        Matrix3::from(mass(&self.coef, s, cp))
    }
}

impl<T: Real> Dynamics<T, 7, 2> for PlanarModel<T> {
    const PITCH: usize = 3;

    #[inline]
    fn deriv(&self, x: &PlanarState<T>, u: &SVector<T, 2>) -> PlanarState<T> {
        self.deriv_plus(x, u, |_, _| None)
    }

    /// ½ νᵀ M(φ) ν + M_b g c_z cos φ.
    fn energy(&self, x: &PlanarState<T>) -> T {
        self.kinetic(x) + self.coef.mgc * x[3].cos()
    }
}

impl<T: Real> PlanarModel<T> {
    /// The kinetic energy ½ νᵀ M(φ) ν.
    pub fn kinetic(&self, x: &PlanarState<T>) -> T {
        let (s, cp) = x[3].sin_cos();
        let (phi_dot, v, omega) = (x[4], x[5], x[6]);
        let (m_pv, m_ww) = (pitch_speed_mass(&self.coef, cp), yaw_mass(&self.coef, s));
        let half = c::<T>(0.5);
        half * (self.coef.m_pp * phi_dot * phi_dot + self.coef.m_vv * v * v + m_ww * omega * omega) + m_pv * phi_dot * v
    }
}

impl<T: Real> PlanarModel<T> {
    /// ν̇ = M(φ)⁻¹ q: the accelerations generalised forces `q` on (φ, v, ω) give at `phi`.
    pub fn solve_mass(&self, phi: T, q: &Vector3<T>) -> Vector3<T> {
        let (s, cp) = phi.sin_cos();
        Vector3::from(accelerations(&self.coef, &[q[0], q[1], q[2]], s, cp))
    }

    /// `deriv` with extra generalised forces `extra(sin φ, cos φ)` on (φ, v) (a force on
    /// the body). `|_, _| None` is `deriv`, bit for bit.
    #[inline(always)]
    pub(crate) fn deriv_plus(
        &self,
        x: &PlanarState<T>,
        u: &SVector<T, 2>,
        extra: impl Fn(T, T) -> Option<Vector2<T>>,
    ) -> PlanarState<T> {
        self.deriv_geared(x, u, [true, true], extra).0
    }

    /// Each wheel's gearhead friction torque [N m] at state `x` under motor torques `u`
    /// (0 without friction): the slip law, or with a stick band whatever holds a wheel.
    pub fn gearhead_torques_at(&self, x: &PlanarState<T>, u: &SVector<T, 2>) -> [T; 2] {
        self.deriv_geared(x, u, [true, true], |_, _| None).1
    }

    /// One wheel's rotor inertia at the wheel, η² I_M / 2 [kg m²].
    pub fn rotor_per_wheel(&self) -> T {
        self.coef.rotor_r * self.params.wheel_radius / c::<T>(2.0)
    }

    /// The mass matrix with the rotors of the wheels not `engaged` taken off (their gear
    /// trains open): M − Σ J r rᵀ over those wheels.
    pub fn geared_mass_matrix(&self, phi: T, engaged: [bool; 2]) -> Matrix3<T> {
        let (s, cp) = phi.sin_cos();
        Matrix3::from(reduced_mass(&self.coef, s, cp, open_rotors(engaged, self.rotor_per_wheel())))
    }

    /// The plastic impact of an open train's rotor, turning at `rotor_speed`, on its
    /// wheel's flank (gearbox backlash): one impulse P along the wheel's row r, with the
    /// trains `engaged` as before it (this wheel's open), leaves rotor and wheel at one
    /// speed. Updates the velocities in `x`; returns that speed.
    pub fn engage(&self, x: &mut PlanarState<T>, wheel: usize, rotor_speed: T, engaged: [bool; 2]) -> T {
        let inertia = self.rotor_per_wheel();
        let (s, cp) = crate::model::math::sin_cos(x[3]);
        let reduced = Adjugate::of(reduced_mass(&self.coef, s, cp, open_rotors(engaged, inertia)));
        let r = wheel_rows(&self.coef)[wheel];
        let response = reduced.solve(&r);
        let impulse = (rotor_speed - dot(&r, &[x[4], x[5], x[6]])) / (dot(&r, &response) + T::one() / inertia);
        for k in 0..3 {
            x[4 + k] += response[k] * impulse;
        }
        rotor_speed - impulse / inertia
    }

    /// The derivative with the gear trains of the wheels not `engaged` open (gearbox
    /// backlash, `hardware::backlash`): such a wheel gets neither its motor's torque nor
    /// its gearhead friction, and its rotor's inertia leaves it (the rotor turns on its
    /// own). Also each wheel's gearhead friction torque. All engaged is `deriv_plus`.
    // Always inlined: it is the 3-DOF rig's derivative under backlash, at every RK4 stage.
    #[inline(always)]
    pub fn deriv_geared(
        &self,
        x: &PlanarState<T>,
        u: &SVector<T, 2>,
        engaged: [bool; 2],
        extra: impl Fn(T, T) -> Option<Vector2<T>>,
    ) -> (PlanarState<T>, [T; 2]) {
        let gear = Gearhead::of(self.friction.as_ref());
        let extra = |s: T, cp: T| extra(s, cp).map(|q| [q[0], q[1]]);
        let (d, tau) = if engaged == [true, true] {
            engaged_motion(&self.coef, gear, &(*x).into(), [u[0], u[1]], extra)
        } else {
            open_motion(&self.coef, gear, &(*x).into(), [u[0], u[1]], engaged, self.rotor_per_wheel(), extra)
        };
        (PlanarState::from(d), tau)
    }
}

// The equations of motion, written once over `Lane`: a run evaluates them in `T`, a
// sweep's lanes in `Fused` (multiply-adds fused). Each `madd` is the `a * b + c` the
// scalar code had, so a run's bits did not change when they were written this way.

/// The generalised forces f = B u − h on ν = (φ̇, v, ω) under the wheels' net torques
/// `u_r`, `u_l`; and sin φ, cos φ.
#[inline(always)]
pub(crate) fn forces<S: Lane>(k: &PlanarCoefficients<S>, x: &[S; 7], u_r: S, u_l: S) -> ([S; 3], S, S) {
    forces_at(k, x, u_r, u_l, S::sincos(x[3]))
}

/// [`forces`] given the pitch's (sin φ, cos φ).
#[inline(always)]
pub(crate) fn forces_at<S: Lane>(k: &PlanarCoefficients<S>, x: &[S; 7], u_r: S, u_l: S, (s, cp): (S, S)) -> ([S; 3], S, S) {
    let (phi_dot, v, omega) = (x[4], x[5], x[6]);
    let (u_sum, u_diff) = (u_r + u_l, u_r - u_l);
    let w2 = omega * omega;
    let sc = s * cp;
    // M_b g c_z s + k s c ω² − μ_s φ̇ + μ_s v/R − (u_r + u_l)
    let f_p = S::madd(k.mu_s_r, v, S::madd(-k.mu_s, phi_dot, S::madd(k.mgc, s, k.k * sc * w2))) - u_sum;
    // M_b c_z s (φ̇² + ω²) − (μ_s + μ_g) v/R² + μ_s φ̇/R + (u_r + u_l)/R
    let centripetal = k.mbc * s * S::madd(phi_dot, phi_dot, w2);
    let f_v = S::madd(k.inv_r, u_sum, S::madd(k.mu_s_r, phi_dot, S::madd(-k.mu_v, v, centripetal)));
    // b (u_r − u_l)/R − (2 k s c φ̇ + M_b c_z s v + b² (μ_s + μ_g)/R²) ω
    let damping = S::madd(k.two_k * sc, phi_dot, k.mbc * s * v) + k.mu_w;
    let f_w = S::madd(-damping, omega, k.b_r * u_diff);
    ([f_p, f_v, f_w], s, cp)
}

/// ν̇ = M(φ)⁻¹ f at sin φ, cos φ: the (φ, v) block by Cramer's rule (the slope model's,
/// one division), the yaw row diagonal.
#[inline(always)]
pub(crate) fn accelerations<S: Lane>(k: &PlanarCoefficients<S>, f: &[S; 3], s: S, cp: S) -> [S; 3] {
    let [phi_dd, v_dot] = cramer(k.m_pp, k.m_vv, k.m_pp_vv, pitch_speed_mass(k, cp), &[f[0], f[1]]);
    [phi_dd, v_dot, f[2] / yaw_mass(k, s)]
}

/// M₁₂ = M₂₁ of the mass matrix at cos φ: the pitch–speed coupling M_b c_z cos φ less the
/// rotors' η² I_M / R.
#[inline(always)]
fn pitch_speed_mass<S: Lane>(k: &PlanarCoefficients<S>, cp: S) -> S {
    S::madd(k.mbc, cp, -k.rotor_r)
}

/// M₃₃ of the mass matrix at sin φ: the yaw inertia.
#[inline(always)]
fn yaw_mass<S: Lane>(k: &PlanarCoefficients<S>, s: S) -> S {
    S::madd(k.k * s, s, k.m_ww0)
}

/// The mass matrix M(φ) at sin φ, cos φ, by rows.
#[inline(always)]
fn mass<S: Lane>(k: &PlanarCoefficients<S>, s: S, cp: S) -> [[S; 3]; 3] {
    let (zero, m_pv) = (S::splat(0.0), pitch_speed_mass(k, cp));
    [[k.m_pp, m_pv, zero], [m_pv, k.m_vv, zero], [zero, zero, yaw_mass(k, s)]]
}

/// M' = M − Σ J r rᵀ at sin φ, cos φ: the mass matrix less each open train's rotor, `off`
/// per wheel its rotor's inertia J when its train is open, zero when engaged.
#[inline(always)]
fn reduced_mass<S: Lane>(k: &PlanarCoefficients<S>, s: S, cp: S, off: [S; 2]) -> [[S; 3]; 3] {
    let mut m = mass(k, s, cp);
    for (r, off) in wheel_rows(k).iter().zip(off) {
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] = m[a][b] - off * r[a] * r[b];
            }
        }
    }
    m
}

/// Each wheel's rotor inertia `j` where its train is open (not `engaged`), else zero: what
/// [`reduced_mass`] takes off.
#[inline(always)]
fn open_rotors<S: Lane>(engaged: [S::Mask; 2], j: S) -> [S; 2] {
    engaged.map(|on| S::select(on, S::splat(0.0), j))
}

/// a · b in three dimensions.
#[inline(always)]
fn dot<S: Lane>(a: &[S; 3], b: &[S; 3]) -> S {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A symmetric 3 × 3 matrix's inverse as its adjugate over its determinant: the reduced
/// mass matrix M' is positive definite and well conditioned, so this needs no pivoting
/// and no branch (the same code on lanes).
struct Adjugate<S> {
    adj: [[S; 3]; 3],
    inv_det: S,
}

impl<S: Lane> Adjugate<S> {
    #[inline(always)]
    fn of(m: [[S; 3]; 3]) -> Self {
        let [[a, b, c], [_, d, e], [_, _, ff]] = m;
        let adj = [[d * ff - e * e, c * e - b * ff, b * e - c * d], [c * e - b * ff, a * ff - c * c, b * c - a * e], [b * e - c * d, b * c - a * e, a * d - b * b]];
        let inv_det = S::splat(1.0) / (a * adj[0][0] + b * adj[0][1] + c * adj[0][2]);
        Self { adj, inv_det }
    }

    /// M⁻¹ v.
    #[inline(always)]
    fn solve(&self, v: &[S; 3]) -> [S; 3] {
        fill(|i| dot(&self.adj[i], v) * self.inv_det)
    }
}

/// Each wheel's relative-speed row r, w = r · ν with ν = (φ̇, v, ω): (−1, 1/R, ±b/R).
#[inline(always)]
fn wheel_rows<S: Lane>(k: &PlanarCoefficients<S>) -> [[S; 3]; 2] {
    [[-S::splat(1.0), k.inv_r, k.b_r], [-S::splat(1.0), k.inv_r, -k.b_r]]
}

/// The state derivative from the accelerations ν̇ = (φ̈, v̇, ω̇).
#[inline(always)]
pub(crate) fn kinematics<S: Lane>(x: &[S; 7], nu_dot: [S; 3]) -> [S; 7] {
    kinematics_at(x, nu_dot, S::sincos(x[2]))
}

/// [`kinematics`] given the heading's (sin ψ, cos ψ).
#[inline(always)]
pub(crate) fn kinematics_at<S: Lane>(x: &[S; 7], nu_dot: [S; 3], (sin_psi, cos_psi): (S, S)) -> [S; 7] {
    let v = x[5];
    [v * cos_psi, v * sin_psi, x[6], x[4], nu_dot[0], nu_dot[1], nu_dot[2]]
}

/// The derivative of the thesis's plant (no gearhead friction, no external force).
#[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
#[inline(always)]
pub(crate) fn deriv<S: Lane>(k: &PlanarCoefficients<S>, x: &[S; 7], u: [S; 2]) -> [S; 7] {
    deriv_at(k, x, u, S::sincos(x[3]), S::sincos(x[2]))
}

/// [`deriv`] given the pitch's (sin φ, cos φ) and the heading's (sin ψ, cos ψ).
#[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
#[inline(always)]
pub(crate) fn deriv_at<S: Lane>(k: &PlanarCoefficients<S>, x: &[S; 7], u: [S; 2], pitch: (S, S), heading: (S, S)) -> [S; 7] {
    let (f, s, cp) = forces_at(k, x, u[0], u[1], pitch);
    kinematics_at(x, accelerations(k, &f, s, cp), heading)
}

/// The derivative with the gear trains of the wheels not `engaged` open
/// (`PlanarModel::deriv_geared`'s other case; a sweep's lanes evaluate it too): such a
/// wheel gets neither its motor's torque (of `u`) nor its gearhead friction, and its
/// rotor's inertia `rotor` leaves it; with one wheel engaged, its friction acts against the
/// reduced mass matrix M' (solved by its adjugate). Also each wheel's gearhead torque.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn open_motion<S: Lane>(
    k: &PlanarCoefficients<S>,
    gear: Gearhead<'_, S>,
    x: &[S; 7],
    u: [S; 2],
    engaged: [S::Mask; 2],
    rotor: S,
    extra: impl Fn(S, S) -> Option<[S; 2]>,
) -> ([S; 7], [S; 2]) {
    let (nu_dot, tau) = open_accelerations(k, gear, x, u, engaged, rotor, |u_r, u_l| forces_plus(k, x, u_r, u_l, &extra));
    (kinematics(x, nu_dot), tau)
}

/// ν̇ with the gear trains of the wheels not `engaged` open ([`open_motion`]'s), the
/// generalised forces at net wheel torques (u_r, u_l) given by `forces_at` (with sin φ,
/// cos φ), as [`engaged_accelerations`] takes them; and each wheel's gearhead torque.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn open_accelerations<S: Lane>(
    k: &PlanarCoefficients<S>,
    gear: Gearhead<'_, S>,
    x: &[S; 7],
    u: [S; 2],
    engaged: [S::Mask; 2],
    rotor: S,
    forces_at: impl Fn(S, S) -> ([S; 3], S, S),
) -> ([S; 3], [S; 2]) {
    let zero = S::splat(0.0);
    let (f, s, cp) = forces_at(S::select(engaged[0], u[0], zero), S::select(engaged[1], u[1], zero));
    let rows = wheel_rows(k);
    let reduced = Adjugate::of(reduced_mass(k, s, cp, open_rotors(engaged, rotor)));
    let mut nu_dot = reduced.solve(&f);
    let mut tau = [zero; 2];
    if let Gearhead::Slip(fr) | Gearhead::Stick(fr) | Gearhead::Outside(fr, _) = gear {
        // One wheel engaged (the other's train open): its friction against M'.
        let right = engaged[0];
        let row: [S; 3] = fill(|i| S::select(right, rows[0][i], rows[1][i]));
        let response = reduced.solve(&row);
        let [w_r, w_l] = wheel_speeds(k, x);
        let w = S::select(right, w_r, w_l);
        let (a0, sr) = (dot(&row, &nu_dot), dot(&row, &response));
        let one = (engaged[0] & !engaged[1]) | (!engaged[0] & engaged[1]);
        let t = if matches!(gear, Gearhead::Slip(_)) { fr.torque(w) } else { gear.held_torques([w], [a0], [[sr]])[0] };
        let t = S::select(one, t, zero);
        for i in 0..3 {
            nu_dot[i] = nu_dot[i] - response[i] * t;
        }
        tau = [S::select(right, t, zero), S::select(right, zero, t)];
    }
    (nu_dot, tau)
}

/// Each wheel's speed relative to the body, θ̇_side − φ̇ = (v ± b ω)/R − φ̇ [rad/s].
#[inline(always)]
pub(crate) fn wheel_speeds<S: Lane>(k: &PlanarCoefficients<S>, x: &[S; 7]) -> [S; 2] {
    k.wheels().speeds(x)
}

/// The wheels' rows' entries 1/R and b/R: what turns ν into the wheels' speeds relative to
/// the body (the encoders' sensors keep these alone).
#[derive(Clone, Copy, Debug)]
pub(crate) struct WheelRows<S> {
    pub(crate) inv_r: S,
    pub(crate) b_r: S,
}

impl<S: Lane> WheelRows<S> {
    /// Each wheel's speed relative to the body at state `x`, (v ± b ω)/R − φ̇ [rad/s].
    #[inline(always)]
    pub(crate) fn speeds(&self, x: &[S; 7]) -> [S; 2] {
        self.of(&[x[4], x[5], x[6]])
    }

    /// r · ν for each wheel's row r: its speed relative to the body from ν = (φ̇, v, ω), or
    /// its acceleration from ν̇.
    #[inline(always)]
    pub(crate) fn of(&self, nu: &[S; 3]) -> [S; 2] {
        let turn = self.b_r * nu[2];
        let roll = self.inv_r * nu[1] - nu[0];
        [roll + turn, roll - turn]
    }
}

/// [`forces`] with `extra(sin φ, cos φ)` added on (φ, v) when it gives some (a force on
/// the body): `None` costs nothing.
#[inline(always)]
pub(crate) fn forces_plus<S: Lane>(k: &PlanarCoefficients<S>, x: &[S; 7], u_r: S, u_l: S, extra: impl Fn(S, S) -> Option<[S; 2]>) -> ([S; 3], S, S) {
    let ([f_p, f_v, f_w], s, cp) = forces(k, x, u_r, u_l);
    let (f_p, f_v) = match extra(s, cp) {
        Some(q) => (f_p + q[0], f_v + q[1]),
        None => (f_p, f_v),
    };
    ([f_p, f_v, f_w], s, cp)
}

/// The derivative with both gear trains engaged (`PlanarModel::deriv_geared`'s common
/// case; a sweep's lanes evaluate it too) under the wheels' motor torques `u`, with
/// gearhead friction `gear` and `extra` forces on (φ, v); and each wheel's gearhead
/// torque ([`engaged_accelerations`] on flat ground).
#[inline(always)]
pub(crate) fn engaged_motion<S: Lane>(
    k: &PlanarCoefficients<S>,
    gear: Gearhead<'_, S>,
    x: &[S; 7],
    u: [S; 2],
    extra: impl Fn(S, S) -> Option<[S; 2]>,
) -> ([S; 7], [S; 2]) {
    let (nu_dot, tau) = engaged_accelerations(k, gear, x, u, |u_r, u_l| forces_plus(k, x, u_r, u_l, &extra));
    (kinematics(x, nu_dot), tau)
}

/// ν̇ with both gear trains engaged under the wheels' motor torques `u` and gearhead
/// friction `gear`, the generalised forces at net wheel torques (u_r, u_l) given by
/// `forces_at` (with sin φ, cos φ); and each wheel's gearhead torque. With a stick band:
/// the accelerations without it, less each held or slipping wheel's torque times its
/// response (as `slope::motion` does), so the forces are evaluated once. `x` gives the
/// wheels' speeds relative to the body.
#[inline(always)]
pub(crate) fn engaged_accelerations<S: Lane>(
    k: &PlanarCoefficients<S>,
    gear: Gearhead<'_, S>,
    x: &[S; 7],
    u: [S; 2],
    forces_at: impl Fn(S, S) -> ([S; 3], S, S),
) -> ([S; 3], [S; 2]) {
    let [w_r, w_l] = wheel_speeds(k, x);
    let driven = |u_r: S, u_l: S| {
        let (f, s, cp) = forces_at(u_r, u_l);
        accelerations(k, &f, s, cp)
    };
    match gear {
        Gearhead::Free => return (driven(u[0], u[1]), [S::splat(0.0); 2]),
        Gearhead::Slip(f) => {
            let tau = [f.torque(w_r), f.torque(w_l)];
            return (driven(u[0] - tau[0], u[1] - tau[1]), tau);
        }
        Gearhead::Stick(_) | Gearhead::Outside(..) => {}
    }
    // A torque on one wheel acts on (φ, v) as (−1, 1/R) and on the yaw as ±b/R: the
    // response to it is `shared` on (φ, v) and ±`turn` on the yaw.
    let (q, sin_phi, cos_phi) = forces_at(u[0], u[1]);
    let free = accelerations(k, &q, sin_phi, cos_phi);
    let [a_r, a_l] = k.wheels().of(&free);
    let shared = accelerations(k, &[-S::splat(1.0), k.inv_r, S::splat(0.0)], sin_phi, cos_phi);
    // `shared` does not yaw: both wheels' rows see the same.
    let [common, _] = k.wheels().of(&shared);
    let turn = k.b_r / yaw_mass(k, sin_phi);
    let yaw = k.b_r * turn;
    // ẇ = a0 − S τ: friction takes its torque off the motor's.
    let s = [[common + yaw, common - yaw], [common - yaw, common + yaw]];
    let tau = gear.held_torques([w_r, w_l], [a_r, a_l], s);
    let (both, apart) = (tau[0] + tau[1], tau[0] - tau[1]);
    ([free[0] - both * shared[0], free[1] - both * shared[1], free[2] - apart * turn], tau)
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::rk4_step;

    fn frictionless<T: Real>() -> RobotParams<T> {
        let mut p = RobotParams::<T>::balanbot();
        p.mu_bearing = T::zero();
        p.mu_ground = T::zero();
        p
    }

    /// A small deterministic generator (no dependencies): uniform in [lo, hi).
    struct Lcg(u64);
    impl Lcg {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
        }
    }

    #[test]
    fn f32_and_f64_derivatives_agree() {
        let m64 = PlanarModel::<f64>::new(RobotParams::balanbot()).unwrap();
        let m32 = PlanarModel::<f32>::new(RobotParams::balanbot()).unwrap();
        let mut rng = Lcg(7);
        for _ in 0..1000 {
            let x: [f64; 7] = core::array::from_fn(|_| rng.uniform(-1.5, 1.5));
            let u = [rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2)];
            let d64 = m64.deriv(&PlanarState::from(x), &SVector::from(u));
            let d32 = m32.deriv(
                &PlanarState::from(x.map(|v| v as f32)),
                &SVector::from(u.map(|v| v as f32)),
            );
            let scale = d64.amax().max(1.0);
            for i in 0..7 {
                let err = (d32[i] as f64 - d64[i]).abs() / scale;
                assert!(
                    err < 1e-4,
                    "component {i}: f32 {} vs f64 {} (rel {err:e})",
                    d32[i],
                    d64[i]
                );
            }
        }
    }

    #[test]
    fn mass_matrix_is_symmetric_positive_definite() {
        let mut p = RobotParams::<f64>::balanbot();
        // Also a body whose yaw inertia exceeds roll + M_b c_z² (k < 0).
        for yaw in [p.i_body_yaw, 10.0 * p.i_body_yaw] {
            p.i_body_yaw = yaw;
            let m = PlanarModel::new(p).unwrap();
            for i in 0..=64 {
                let phi = -core::f64::consts::PI + i as f64 * core::f64::consts::PI / 32.0;
                let mm = m.mass_matrix(phi);
                assert_eq!(mm, mm.transpose());
                assert!(
                    mm.cholesky().is_some(),
                    "not positive definite at phi = {phi}"
                );
                assert_eq!(mm[(0, 2)], 0.0);
                assert_eq!(mm[(1, 2)], 0.0);
            }
        }
    }

    #[test]
    fn energy_matches_mass_matrix() {
        let m = PlanarModel::<f64>::new(RobotParams::balanbot()).unwrap();
        let x = PlanarState::from([0.1, -0.2, 0.3, 0.4, -0.5, 0.6, 0.7]);
        let nu = nalgebra::Vector3::new(x[4], x[5], x[6]);
        let p = m.params();
        let expected = 0.5 * (nu.transpose() * m.mass_matrix(x[3]) * nu)[0]
            + p.m_body * p.g * p.com_height * x[3].cos();
        assert!((m.energy(&x) - expected).abs() < 1e-14);
    }

    fn energy_drift<T: Real>(dt: f64, steps: usize) -> f64 {
        let m = PlanarModel::<T>::new(frictionless()).unwrap();
        let mut x = PlanarState::<T>::from([0.0, 0.0, 0.0, 0.3, 0.5, 0.4, 2.0].map(c::<T>));
        let u = SVector::<T, 2>::zeros();
        let e0 = crate::to_f64(m.energy(&x));
        let mut worst: f64 = 0.0;
        let mut max_phi: f64 = 0.0;
        for _ in 0..steps {
            x = rk4_step(&m, &x, &u, c::<T>(dt));
            worst = worst.max((crate::to_f64(m.energy(&x)) - e0).abs() / e0.abs());
            max_phi = max_phi.max(crate::to_f64(x[3]).abs());
        }
        assert!(
            max_phi > core::f64::consts::PI,
            "the body should swing through the bottom"
        );
        worst
    }

    #[test]
    fn energy_is_conserved_f64() {
        let drift = energy_drift::<f64>(1e-3, 20_000);
        let drift_half = energy_drift::<f64>(0.5e-3, 40_000);
        std::println!(
            "f64 energy drift over 20 s: {drift:.2e} at dt = 1 ms, {drift_half:.2e} at 0.5 ms"
        );
        assert!(drift < 1e-7, "drift {drift:e}");
        assert!(
            drift_half < drift / 10.0,
            "drift {drift:e} -> {drift_half:e} when halving dt"
        );
    }

    #[test]
    fn energy_is_roughly_conserved_f32() {
        let drift = energy_drift::<f32>(1e-3, 20_000);
        std::println!("f32 energy drift over 20 s at dt = 1 ms: {drift:.2e}");
        assert!(drift < 1e-3, "drift {drift:e}");
    }

    #[test]
    fn friction_dissipates() {
        let m = PlanarModel::<f64>::new(RobotParams::balanbot()).unwrap();
        let mut x = PlanarState::from([0.0, 0.0, 0.0, 0.3, 0.5, 0.4, 2.0]);
        let u = SVector::<f64, 2>::zeros();
        let mut e = m.energy(&x);
        for _ in 0..5000 {
            x = rk4_step(&m, &x, &u, 1e-3);
            let e_next = m.energy(&x);
            assert!(e_next <= e + 1e-12);
            e = e_next;
        }
    }

    #[test]
    fn no_yaw_reduces_to_the_flat_slope_model() {
        let p = RobotParams::<f64>::balanbot();
        let planar = PlanarModel::new(p).unwrap();
        let slope = crate::SlopeModel::new(p, 0.0).unwrap();
        let r = p.wheel_radius;
        let x = PlanarState::from([0.0, 0.0, 0.0, 0.4, -0.7, 0.3, 0.0]);
        let current = 0.8;
        let torque = p.torque_per_amp() * current / 2.0;
        let d = planar.deriv(&x, &SVector::from([torque, torque]));
        let ds = slope.deriv(
            &nalgebra::Vector4::new(x[3], x[4], 0.0, x[5] / r),
            &SVector::from([current]),
        );
        assert!((d[4] - ds[1]).abs() < 1e-12 * ds[1].abs().max(1.0));
        assert!((d[5] - r * ds[3]).abs() < 1e-12 * (r * ds[3]).abs().max(1.0));
        assert_eq!(d[6], 0.0);
    }

    /// The open-train derivative (`open_motion`, M'⁻¹ by the adjugate) against nalgebra's
    /// Cholesky solve of `geared_mass_matrix` without friction, and on `Fused` lanes against
    /// the run's (`deriv_geared`) to rounding, friction torques too: for either wheel open or
    /// both, without friction, with the slip law and with a stick band (states inside and
    /// outside it), under a body force.
    #[cfg(feature = "std")] // the lanes' number type
    #[test]
    fn open_motion_solves_the_reduced_mass_matrix_and_lanes_agree() {
        use crate::model::lane::Fused;
        let gb37 = Friction::gb37();
        let mut rng = Lcg(11);
        let (mut worst_solve, mut worst_lanes, mut in_band) = (0.0f64, 0.0f64, 0);
        for friction in [None, Some(gb37), Some(gb37.with_stick(0.5))] {
            let m = PlanarModel::new(RobotParams::balanbot()).unwrap().with_friction(friction).unwrap();
            let (k, rotor) = (m.coefficients().map(Fused), Fused(m.rotor_per_wheel()));
            let fused = friction.map(|f| f.map(Fused));
            for engaged in [[false, true], [true, false], [false, false]] {
                for n in 0..200 {
                    // Every other state slow enough for the wheels to sit in the stick band.
                    let scale = if n % 2 == 0 { 1.0 } else { 5e-3 };
                    let x: [f64; 7] = core::array::from_fn(|i| rng.uniform(-1.5, 1.5) * if i >= 4 { scale } else { 1.0 });
                    let u = [rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)];
                    let q = [rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2)];
                    let (d, tau) = m.deriv_geared(&PlanarState::from(x), &SVector::from(u), engaged, |_, _| Some(Vector2::from(q)));
                    if friction.is_none() {
                        // M' ν̇ = f, f the forces with the open wheels' torques left out.
                        let on = |i: usize| if engaged[i] { u[i] } else { 0.0 };
                        let (f, _, _) = forces_plus(&m.coefficients(), &x, on(0), on(1), |_, _| Some(q));
                        let chol = m.geared_mass_matrix(x[3], engaged).cholesky().unwrap();
                        let want = chol.solve(&Vector3::from(f));
                        for i in 0..3 {
                            worst_solve = worst_solve.max((d[4 + i] - want[i]).abs() / want[i].abs().max(1.0));
                        }
                    }
                    let gear = Gearhead::of(fused.as_ref());
                    let w = m.wheel_speeds(&PlanarState::from(x));
                    let engaged_w = if engaged[0] { w.0 } else { w.1 };
                    in_band += (matches!(gear, Gearhead::Stick(_)) && engaged != [false, false] && engaged_w.abs() < 0.5) as usize;
                    let (dl, tl) = open_motion(&k, gear, &x.map(Fused), u.map(Fused), engaged, rotor, |_, _| Some(q.map(Fused)));
                    for (a, b) in dl.iter().map(|v| v.0).zip(d.iter()).chain(tl.iter().map(|v| v.0).zip(tau.iter())) {
                        worst_lanes = worst_lanes.max((a - b).abs() / b.abs().max(1.0));
                    }
                }
            }
        }
        std::println!("open trains: adjugate against Cholesky {worst_solve:e}, lanes against the run {worst_lanes:e} (relative, or absolute below 1); {in_band} held in the stick band");
        assert!(worst_solve < 1e-13, "{worst_solve:e}");
        assert!(worst_lanes < 1e-13 && worst_lanes > 0.0, "{worst_lanes:e}");
        assert!(in_band > 50, "the engaged wheel inside the stick band only {in_band} times");
    }

    #[test]
    fn right_torque_turns_left() {
        let m = PlanarModel::<f64>::new(RobotParams::balanbot()).unwrap();
        let d = m.deriv(&PlanarState::zeros(), &SVector::from([0.1, -0.1]));
        assert!(d[6] > 0.0);
        assert!(d[4].abs() < 1e-15 && d[5].abs() < 1e-15);
    }
}
