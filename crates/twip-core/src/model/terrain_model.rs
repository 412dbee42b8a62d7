//! The 3-DOF model on terrain (docs/terrain.md), derived again by Lagrange–d'Alembert in
//! the frame of the ground's local plane (scripts/derive_terrain.py does it with sympy).
//!
//! In the plane's own frame (e1 uphill, n the normal) the plane is inertial and the robot is
//! the flat robot under a tilted gravity: with φ' the pitch from the normal, χ the heading
//! in the plane from uphill and β the slope, `M(φ') ν̇' = f'` has the flat model's `M` and
//! forces, with the flat gravity torque M_b g c_z sin φ' replaced and two terms added:
//!
//! ```text
//! f'_φ: M_b g c_z (cos β sin φ' − sin β cos χ cos φ')      (the lean against the tilted vertical)
//! f'_v: − (M_b + M_w) g sin β cos χ                        (the grade's pull)
//! f'_ω: + M_b g c_z sin β sin χ sin φ'                      (a leaning body turns downhill)
//! ```
//!
//! The state keeps the flat model's `[x, y, ψ, φ, φ̇, v, ω]`: (x, y) the horizontal position
//! of the contact point under the axle's midpoint, ψ the heading of the travel direction's
//! horizontal projection, φ the pitch from the most vertical direction perpendicular to the
//! axle, φ = φ' − δ(χ) with tan δ = tan β cos χ; v the speed along the ground, ω the turn
//! rate about the ground's normal. On a plane this is exact. On curved ground the local
//! plane at (x, y) is taken as it is at each evaluation: the terms from the plane turning
//! under a moving robot (curvature × speed) are left out, and the energy balance holds to
//! them (docs/terrain.md measures it).
use nalgebra::SVector;

use crate::model::dynamics::Halt;
use crate::model::friction::Gearhead;
use crate::model::lane::Lane;
use crate::model::math::sin_cos;
use crate::model::planar::{engaged_accelerations, forces_plus, open_accelerations, PlanarCoefficients, PlanarModel, PlanarState};
use crate::model::terrain::{Local, Terrain};
use crate::{Dynamics, Real, TwipError};

/// The 3-DOF model on a [`Terrain`]; input `[u_r, u_l]`, motor torques [N m] on the wheels.
#[derive(Clone, Debug)]
pub struct TerrainModel<T> {
    flat: PlanarModel<T>,
    terrain: Terrain<T>,
}

/// The local plane's geometry seen along the heading ψ: everything the equations need.
#[derive(Clone, Copy, Debug)]
pub struct Frame<T> {
    /// cos β, β the plane's steepest slope.
    pub cos_slope: T,
    /// sin γ = sin β cos χ: the grade along the heading.
    pub sin_grade: T,
    /// sin β sin χ = −sin(roll), the roll the cross slope gives (left side up when negative).
    pub cross: T,
    /// δ, δ' = dδ/dχ and δ'' = d²δ/dχ²: φ' = φ + δ.
    pub delta: T,
    pub delta_1: T,
    pub delta_2: T,
    /// cos γ = 1/√(1 + p²): horizontal speed per speed along the ground.
    pub cos_grade: T,
    /// dψ/dχ = cos β / cos²γ.
    pub turn: T,
}

impl<S: Lane> Frame<S> {
    /// The frame from the ground's gradient (gx, gy) at heading ψ = atan2(`sin_psi`, `cos_psi`).
    /// Over [`Lane`]: a run's frame (`f64`, `f32`) and a sweep lane's ([`crate::model::lane::Fused`]:
    /// its multiply-adds and arctangent its own, so the two agree to rounding).
    #[inline(always)]
    pub fn new(gx: S, gy: S, sin_psi: S, cos_psi: S) -> Self {
        let one = S::splat(1.0);
        // p: the grade's tangent along the heading; q: across it (to the left).
        let p = gx * cos_psi + gy * sin_psi;
        let q = gy * cos_psi - gx * sin_psi;
        let w = one + p * p;
        let root_w = w.square_root();
        let cos_slope = one / (w + q * q).square_root();
        let sin_grade = p / root_w;
        let cross = -(q * cos_slope) / root_w;
        // cos²ρ = cos²β + sin²γ: the most vertical direction perpendicular to the axle.
        let c2 = cos_slope * cos_slope + sin_grade * sin_grade;
        let delta = sin_grade.arctangent_over(cos_slope);
        let delta_1 = -(cross * cos_slope) / c2;
        let delta_2 = -(sin_grade * cos_slope) * (c2 + S::splat(2.0) * cross * cross) / (c2 * c2);
        Self { cos_slope, sin_grade, cross, delta, delta_1, delta_2, cos_grade: one / root_w, turn: cos_slope * w }
    }
}

impl<T: Real> TerrainModel<T> {
    /// The flat model `flat` (its parameters and gearhead friction) on `terrain`.
    pub fn new(flat: PlanarModel<T>, terrain: Terrain<T>) -> Self {
        Self { flat, terrain }
    }

    pub fn flat(&self) -> &PlanarModel<T> {
        &self.flat
    }

    pub fn terrain(&self) -> &Terrain<T> {
        &self.terrain
    }

    /// The ground under the state's contact point (clamped onto a grid: see [`Halt`]).
    #[inline(always)]
    fn ground(&self, x: &PlanarState<T>) -> Local<T> {
        self.terrain.local_clamped(x[0], x[1])
    }

    /// The local plane's frame at state `x`.
    pub fn frame(&self, x: &PlanarState<T>) -> Frame<T> {
        frame_of(&self.terrain, x)
    }

    /// ν̇' = (φ̈', v̇, ω̇) in the plane's frame, each wheel's gearhead torque and the frame.
    #[inline(always)]
    fn accelerations(&self, x: &PlanarState<T>, u: &SVector<T, 2>) -> ([T; 3], [T; 2], Frame<T>, [T; 7]) {
        self.geared_accelerations(x, u, [true, true], |_, _| None)
    }

    /// [`Self::accelerations`] with the gear trains of the wheels not `engaged` open (the
    /// 3-DOF rig's backlash: as `PlanarModel::deriv_geared`) and `extra` generalised forces
    /// on (φ', v) at (sin φ', cos φ') (a force on the body, in the plane's frame). All
    /// engaged and no extra force is [`Self::accelerations`], bit for bit.
    #[inline(always)]
    pub(crate) fn geared_accelerations(
        &self,
        x: &PlanarState<T>,
        u: &SVector<T, 2>,
        engaged: [bool; 2],
        extra: impl Fn(T, T) -> Option<[T; 2]>,
    ) -> ([T; 3], [T; 2], Frame<T>, [T; 7]) {
        let f = self.frame(x);
        let xp = in_plane(x, &f);
        let p = self.flat.params();
        let weight = (p.m_body + p.m_wheels) * p.g;
        let gear = Gearhead::of(self.flat.friction());
        let open = (engaged != [true, true]).then(|| (engaged, self.flat.rotor_per_wheel()));
        let (nu, tau) = geared_in_frame(&self.flat.coefficients(), weight, gear, &f, &xp, [u[0], u[1]], open, extra);
        (nu, tau, f, xp)
    }

    /// The derivative with the gear trains of the wheels not `engaged` open and `extra`
    /// forces on the body ([`Self::geared_accelerations`]), and each wheel's gearhead
    /// torque: the 3-DOF rig's plant on terrain.
    #[inline(always)]
    pub(crate) fn deriv_geared(
        &self,
        x: &PlanarState<T>,
        u: &SVector<T, 2>,
        engaged: [bool; 2],
        extra: impl Fn(T, T) -> Option<[T; 2]>,
    ) -> (PlanarState<T>, [T; 2]) {
        let (nu, tau, f, _) = self.geared_accelerations(x, u, engaged, extra);
        (motion(x, &nu, &f), tau)
    }

    /// Each wheel's speed relative to the body, θ̇_side − φ̇' = (v ± b ω)/R − φ̇' [rad/s]:
    /// the body's pitch rate about the axle is φ̇' = φ̇ + δ' ω (what the motors and the
    /// encoders turn by).
    pub fn wheel_speeds(&self, x: &PlanarState<T>) -> (T, T) {
        self.flat.wheel_speeds(&PlanarState::from(in_plane(x, &self.frame(x))))
    }

    /// φ̈' = φ̈ + δ' ω̇ + δ'' ω² from the state `x` and its derivative `d` in frame `f`.
    #[inline(always)]
    pub(crate) fn pitch_acceleration(x: &PlanarState<T>, d: &PlanarState<T>, f: &Frame<T>) -> T {
        pitch_acceleration_of(&(*x).into(), &(*d).into(), f)
    }

    /// Each wheel's normal force [N] with the gear trains `engaged` and `extra` forces on
    /// the body (the rig's plant: its accelerations; the forces' own weight on the ground is
    /// not counted).
    pub(crate) fn normal_forces_geared(&self, x: &PlanarState<T>, u: &SVector<T, 2>, engaged: [bool; 2], extra: impl Fn(T, T) -> Option<[T; 2]>) -> [T; 2] {
        let (nu, _, f, xp) = self.geared_accelerations(x, u, engaged, extra);
        normal_forces(self.flat.params(), &f, &xp, &nu)
    }

    /// `change` applied to the state in the plane's frame (a jump of the velocities ν' =
    /// (φ̇', v, ω): an impulse, an impact), written back to `x` (φ̇ = φ̇' − δ' ω).
    pub(crate) fn jump_in_plane<R>(&self, x: &mut PlanarState<T>, change: impl FnOnce(&mut PlanarState<T>) -> R) -> R {
        let f = self.frame(x);
        let mut xp = PlanarState::from(in_plane(x, &f));
        let out = change(&mut xp);
        x[4] = xp[4] - f.delta_1 * xp[6];
        x[5] = xp[5];
        x[6] = xp[6];
        out
    }

    /// Each wheel's normal force [N] (right, left) at state `x` under motor torques `u`, by
    /// Newton–Euler on the whole robot about the contact midpoint (docs/terrain.md).
    pub fn normal_forces(&self, x: &PlanarState<T>, u: &SVector<T, 2>) -> [T; 2] {
        let (nu, _, f, xp) = self.accelerations(x, u);
        normal_forces(self.flat.params(), &f, &xp, &nu)
    }

    /// Each wheel's gearhead friction torque [N m] at state `x` under motor torques `u`.
    pub fn gearhead_torques_at(&self, x: &PlanarState<T>, u: &SVector<T, 2>) -> [T; 2] {
        self.accelerations(x, u).1
    }

    /// The equilibrium at rest on a plane facing `heading`, upright in the sense of
    /// standing still: the pitch φ_s and the wheel torques (u_r, u_l) that hold it, or
    /// NoEquilibrium when gravity on the body cannot balance the grade.
    pub fn rest(&self, x: T, y: T, heading: T) -> Result<(T, [T; 2]), TwipError> {
        let g = self.terrain.local(x, y).ok_or(TwipError::InvalidParameter { name: "x", value: crate::to_f64(x), reason: "is off the terrain" })?;
        let (s, co) = heading.sin_cos();
        let f = Frame::new(g.gx, g.gy, s, co);
        let k = RestTerms::of(self.flat.params());
        let (drive, sin_phi) = rest_drive(&k, &f);
        if sin_phi.abs() >= T::one() {
            return Err(TwipError::NoEquilibrium { reason: "the grade exceeds what gravity on the body can balance (sin phi_s)", value: crate::to_f64(sin_phi) });
        }
        let phi = sin_phi.asin();
        Ok((phi, rest_torques(&k, &f, drive, (phi + f.delta).sin())))
    }
}

/// What the rest on a grade needs of a robot: R (M_b + M_w) g, M_b g c_z, R and b.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RestTerms<S> {
    pub drive_per_grade: S,
    pub mgc: S,
    pub radius: S,
    pub half_track: S,
}

impl<T: Real> RestTerms<T> {
    pub(crate) fn of(p: &crate::RobotParams<T>) -> Self {
        Self { drive_per_grade: p.wheel_radius * (p.m_body + p.m_wheels) * p.g, mgc: p.m_body * p.g * p.com_height, radius: p.wheel_radius, half_track: p.half_track }
    }

    /// In another number type (a sweep's lanes).
    #[cfg(feature = "std")]
    pub(crate) fn map<S>(&self, f: impl Fn(T) -> S) -> RestTerms<S> {
        RestTerms { drive_per_grade: f(self.drive_per_grade), mgc: f(self.mgc), radius: f(self.radius), half_track: f(self.half_track) }
    }
}

/// The rest on the plane of frame `f`, over [`Lane`] (a run's and a sweep lane's, one
/// source): the wheels' summed torque and sin φ_s. v̇ = φ̈ = 0: u_r + u_l = R (M_b + M_w) g sin γ
/// (the grade), and the pitch row M_b g c_z (cos β sin φ' − sin γ cos φ') = u_r + u_l, i.e.
/// M_b g c_z cos ρ sin φ = u_r + u_l. A rest exists where |sin φ_s| < 1.
#[inline(always)]
pub(crate) fn rest_drive<S: Lane>(k: &RestTerms<S>, f: &Frame<S>) -> (S, S) {
    let drive = k.drive_per_grade * f.sin_grade;
    let cos_roll = (f.cos_slope * f.cos_slope + f.sin_grade * f.sin_grade).square_root();
    (drive, drive / (k.mgc * cos_roll))
}

/// The wheel torques (u_r, u_l) of the rest of summed torque `drive`, `sin_lean` = sin(φ_s + δ):
/// the yaw row, the lean's turn −M_b g c_z sin β sin χ sin φ' = b (u_r − u_l)/R.
#[inline(always)]
pub(crate) fn rest_torques<S: Lane>(k: &RestTerms<S>, f: &Frame<S>, drive: S, sin_lean: S) -> [S; 2] {
    let yaw = -(k.mgc * f.cross * sin_lean) * k.radius / k.half_track;
    let half = S::splat(0.5);
    [half * (drive + yaw), half * (drive - yaw)]
}

/// The frame of `terrain`'s local plane at state `x` (clamped onto a grid).
#[inline(always)]
pub(crate) fn frame_of<T: Real>(terrain: &Terrain<T>, x: &PlanarState<T>) -> Frame<T> {
    let g = terrain.local_clamped(x[0], x[1]);
    let (s, co) = sin_cos(x[2]);
    Frame::new(g.gx, g.gy, s, co)
}

/// The state in the plane's frame `f`: φ → φ' = φ + δ, φ̇ → φ̇' = φ̇ + δ' ω.
#[inline(always)]
pub(crate) fn in_plane<T: Real>(x: &PlanarState<T>, f: &Frame<T>) -> [T; 7] {
    plane_state(&core::array::from_fn(|i| x[i]), f)
}

/// [`TerrainModel::pitch_acceleration`] over [`Lane`] (a run's and a sweep lane's).
#[inline(always)]
pub(crate) fn pitch_acceleration_of<S: Lane>(x: &[S; 7], d: &[S; 7], f: &Frame<S>) -> S {
    d[4] + f.delta_1 * d[6] + f.delta_2 * x[6] * x[6]
}

/// [`in_plane`] over [`Lane`].
#[inline(always)]
pub(crate) fn plane_state<S: Lane>(x: &[S; 7], f: &Frame<S>) -> [S; 7] {
    [x[0], x[1], x[2], x[3] + f.delta, f.delta_1 * x[6] + x[4], x[5], x[6]]
}

/// The state's derivative from ν̇' = (φ̈', v̇, ω̇) in frame `f`.
#[inline(always)]
fn motion<T: Real>(x: &PlanarState<T>, nu: &[T; 3], f: &Frame<T>) -> PlanarState<T> {
    PlanarState::from(motion_of(&core::array::from_fn(|i| x[i]), nu, f))
}

/// [`motion`] over [`Lane`].
#[inline(always)]
pub(crate) fn motion_of<S: Lane>(x: &[S; 7], nu: &[S; 3], f: &Frame<S>) -> [S; 7] {
    let (s, co) = S::sincos(x[2]);
    let (v, omega) = (x[5], x[6]);
    let speed = v * f.cos_grade;
    // φ = φ' − δ(χ), χ̇ = ω: φ̈ = φ̈' − δ' ω̇ − δ'' ω².
    let phi_dd = nu[0] - f.delta_1 * nu[2] - f.delta_2 * omega * omega;
    [speed * co, speed * s, omega * f.turn, x[4], phi_dd, nu[1], nu[2]]
}

/// The forces on ν' = (φ̇', v, ω) on the plane of frame `f` at the plane-frame state `xp`:
/// the flat model's (with `extra`), its gravity torque M_b g c_z sin φ' become
/// M_b g c_z (cos β sin φ' − sin γ cos φ') (the difference added: exactly zero on level
/// ground), the grade's pull on v and the lean's yaw torque; with sin φ' and cos φ'.
/// `weight` = (M_b + M_w) g.
#[inline(always)]
fn tilted_forces<S: Lane>(k: &PlanarCoefficients<S>, weight: S, f: &Frame<S>, xp: &[S; 7], u_r: S, u_l: S, extra: impl Fn(S, S) -> Option<[S; 2]>) -> ([S; 3], S, S) {
    let ([f_p, f_v, f_w], s, cp) = forces_plus(k, xp, u_r, u_l, extra);
    let lean = (f.cos_slope - S::splat(1.0)) * s - f.sin_grade * cp;
    ([k.mgc * lean + f_p, f_v - weight * f.sin_grade, k.mgc * f.cross * s + f_w], s, cp)
}

/// The terrain model's derivative at `x` under wheel torques `u` on the ground of gradient
/// (`gx`, `gy`) under the contact point, over [`Lane`]: a run's ([`TerrainModel::deriv`])
/// and a sweep lane's, one source. Gear trains engaged with `gear`'s friction, no force on
/// the body; `k`: the flat model's coefficients, `weight` = (M_b + M_w) g.
#[inline(always)]
pub(crate) fn deriv_on_ground<S: Lane>(k: &PlanarCoefficients<S>, weight: S, gear: Gearhead<'_, S>, x: &[S; 7], u: [S; 2], gx: S, gy: S) -> [S; 7] {
    let (nu, f, _) = accelerations_on_ground(k, weight, gear, x, u, gx, gy);
    motion_of(x, &nu, &f)
}

/// ν̇' = (φ̈', v̇, ω̇) at `x` on the ground of gradient (`gx`, `gy`), with the frame and the
/// plane-frame state: [`deriv_on_ground`]'s and [`normal_forces_on_ground`]'s.
#[inline(always)]
fn accelerations_on_ground<S: Lane>(k: &PlanarCoefficients<S>, weight: S, gear: Gearhead<'_, S>, x: &[S; 7], u: [S; 2], gx: S, gy: S) -> ([S; 3], Frame<S>, [S; 7]) {
    let (s, co) = S::sincos(x[2]);
    let f = Frame::new(gx, gy, s, co);
    let xp = plane_state(x, &f);
    let (nu, _) = geared_in_frame(k, weight, gear, &f, &xp, u, None, |_, _| None);
    (nu, f, xp)
}

/// ν̇' = (φ̈', v̇, ω̇) and each wheel's gearhead torque on the plane of frame `f` at the
/// plane-frame state `xp`, under the wheels' motor torques `u`, over [`Lane`]: a run's
/// ([`TerrainModel::geared_accelerations`]) and a sweep lane's (the 3-DOF rig's lanes on
/// terrain), one source. `open`: the gear trains' engagement and the rotor per wheel when
/// some train may be open (None: both engaged); `extra`: generalised forces on (φ', v) at
/// (sin φ', cos φ') (a force on the body).
#[inline(always)]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn geared_in_frame<S: Lane>(
    k: &PlanarCoefficients<S>,
    weight: S,
    gear: Gearhead<'_, S>,
    f: &Frame<S>,
    xp: &[S; 7],
    u: [S; 2],
    open: Option<([S::Mask; 2], S)>,
    extra: impl Fn(S, S) -> Option<[S; 2]>,
) -> ([S; 3], [S; 2]) {
    let forces_at = |u_r: S, u_l: S| tilted_forces(k, weight, f, xp, u_r, u_l, &extra);
    match open {
        None => engaged_accelerations(k, gear, xp, u, forces_at),
        Some((engaged, rotor)) => open_accelerations(k, gear, xp, u, engaged, rotor, forces_at),
    }
}

/// Each wheel's normal force (right, left) at `x` under `u` on the ground of gradient
/// (`gx`, `gy`), over [`Lane`]: a sweep lane's "lifted" test, as [`TerrainModel::normal_forces`]
/// (gear trains engaged, `gear`'s friction; its sine and cosine of φ' the lanes' own).
#[cfg(feature = "std")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn normal_forces_on_ground<S: Lane>(k: &PlanarCoefficients<S>, weight: S, gear: Gearhead<'_, S>, contact: &Contact<S>, x: &[S; 7], u: [S; 2], gx: S, gy: S) -> [S; 2] {
    let (nu, f, xp) = accelerations_on_ground(k, weight, gear, x, u, gx, gy);
    normal_forces_of(contact, &f, &xp, &nu, S::sincos(xp[3]))
}

/// N_r, N_l from the plane-frame state `xp` = [.., φ', φ̇', v, ω] and ν̇' (docs/terrain.md):
/// N_r + N_l = (M_b + M_w) g cos β − M_b c_z (sin φ' φ̈' + cos φ' φ̇'²), and
/// b (N_l − N_r) = g sin β sin χ H − (H + I_w/R) v ω − ω φ̇' (k cos 2φ' + I_yy + M_b c_z² + 2 M_b R c_z cos φ')
///                 − ω̇ sin φ' (k cos φ' + M_b R c_z),  H = M_b (R + c_z cos φ') + M_w R.
fn normal_forces<T: Real>(p: &crate::RobotParams<T>, f: &Frame<T>, xp: &[T; 7], nu: &[T; 3]) -> [T; 2] {
    normal_forces_of(&Contact::of(p), f, xp, nu, xp[3].sin_cos())
}

/// The robot's numbers the normal forces take: R, c_z, M_b, M_w, g, k = M_b c_z² + I_xx − I_zz,
/// I_w, I_yy and b.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Contact<S> {
    r: S,
    l: S,
    mb: S,
    mw: S,
    g: S,
    k: S,
    i_wheels: S,
    i_body: S,
    half_track: S,
}

impl<T: Real> Contact<T> {
    pub(crate) fn of(p: &crate::RobotParams<T>) -> Self {
        let (r, l, mb) = (p.wheel_radius, p.com_height, p.m_body);
        let k = mb * l * l + p.i_body_roll - p.i_body_yaw;
        Self { r, l, mb, mw: p.m_wheels, g: p.g, k, i_wheels: p.i_wheels, i_body: p.i_body, half_track: p.half_track }
    }

    /// In another number type (a sweep's lanes).
    #[cfg(feature = "std")]
    pub(crate) fn map<S>(&self, f: impl Fn(T) -> S) -> Contact<S> {
        Contact { r: f(self.r), l: f(self.l), mb: f(self.mb), mw: f(self.mw), g: f(self.g), k: f(self.k), i_wheels: f(self.i_wheels), i_body: f(self.i_body), half_track: f(self.half_track) }
    }
}

/// [`normal_forces`] over [`Lane`], given (sin φ', cos φ') (a run's libm's, a lane's own).
#[inline(always)]
pub(crate) fn normal_forces_of<S: Lane>(p: &Contact<S>, f: &Frame<S>, xp: &[S; 7], nu: &[S; 3], (s, cp): (S, S)) -> [S; 2] {
    let (phi_dot, v, omega) = (xp[4], xp[5], xp[6]);
    let (r, l, mb, k) = (p.r, p.l, p.mb, p.k);
    let sum = (mb + p.mw) * p.g * f.cos_slope - mb * l * (s * nu[0] + cp * phi_dot * phi_dot);
    let h = mb * (r + l * cp) + p.mw * r;
    let cos_2 = cp * cp - s * s;
    let moment = p.g * f.cross * h
        - (h + p.i_wheels / r) * v * omega
        - omega * phi_dot * (k * cos_2 + p.i_body + mb * l * l + S::splat(2.0) * mb * r * l * cp)
        - nu[2] * s * (k * cp + mb * r * l);
    let diff = moment / p.half_track;
    let half = S::splat(0.5);
    [half * (sum - diff), half * (sum + diff)]
}

impl<T: Real> Dynamics<T, 7, 2> for TerrainModel<T> {
    const PITCH: usize = 3;

    #[inline]
    fn deriv(&self, x: &PlanarState<T>, u: &SVector<T, 2>) -> PlanarState<T> {
        let g = self.ground(x);
        let p = self.flat.params();
        let weight = (p.m_body + p.m_wheels) * p.g;
        let gear = Gearhead::of(self.flat.friction());
        PlanarState::from(deriv_on_ground(&self.flat.coefficients(), weight, gear, &core::array::from_fn(|i| x[i]), [u[0], u[1]], g.gx, g.gy))
    }

    /// ½ ν'ᵀ M(φ') ν' + M_b g c_z (cos β cos φ' + sin γ sin φ') + (M_b + M_w) g (h + R (cos β − 1)):
    /// heights from the flat model's zero (the axle at R over level ground at h = 0).
    fn energy(&self, x: &PlanarState<T>) -> T {
        let f = self.frame(x);
        let xp = in_plane(x, &f);
        let p = self.flat.params();
        // As the flat model's energy evaluates its cos φ.
        let (s, cp) = (xp[3].sin(), xp[3].cos());
        let body = self.flat.coefficients().mgc * (f.cos_slope * cp + f.sin_grade * s);
        let lift = self.ground(x).height + p.wheel_radius * (f.cos_slope - T::one());
        self.flat.kinetic(&PlanarState::from(xp)) + body + (p.m_body + p.m_wheels) * p.g * lift
    }

    /// Off a grid, or a wheel's normal force below zero.
    #[inline]
    fn halted(&self, x: &PlanarState<T>, u: &SVector<T, 2>) -> Option<Halt> {
        if !self.terrain.contains(x[0], x[1]) {
            return Some(Halt::OffTerrain);
        }
        let [n_r, n_l] = self.normal_forces(x, u);
        (n_r < T::zero() || n_l < T::zero()).then_some(Halt::Lifted)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::{rk4_step, RobotParams, SlopeModel};
    use nalgebra::Vector4;

    fn model(terrain: Terrain<f64>) -> TerrainModel<f64> {
        TerrainModel::new(PlanarModel::new(RobotParams::balanbot()).unwrap(), terrain)
    }

    /// A sweep lane's frame ([`Fused`]: fused multiply-adds, the polynomial arctangent) is a
    /// run's to rounding: every field within 4 ulp of its size (relative; 1e-300 absolute)
    /// over gradients up to 80° and any heading, and level ground gives the run's exact zeros.
    #[cfg(feature = "std")]
    #[test]
    fn a_lanes_frame_is_a_runs_to_rounding() {
        use crate::model::lane::Fused;
        let fields = |f: Frame<f64>| [f.cos_slope, f.sin_grade, f.cross, f.delta, f.delta_1, f.delta_2, f.cos_grade, f.turn];
        let (mut worst, mut seed) = (0.0f64, 11u64);
        let mut next = |lo: f64, hi: f64| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
        };
        for k in 0..20_000 {
            let (slope, uphill, psi) = (next(0.0, 1.4), next(-4.0, 4.0), next(-4.0, 4.0));
            let (gx, gy) = (slope.tan() * uphill.cos(), slope.tan() * uphill.sin());
            let (s, c) = psi.sin_cos();
            let run = fields(Frame::new(gx, gy, s, c));
            let f = Frame::new(Fused(gx), Fused(gy), Fused(s), Fused(c));
            let lane = fields(Frame { cos_slope: f.cos_slope.0, sin_grade: f.sin_grade.0, cross: f.cross.0, delta: f.delta.0, delta_1: f.delta_1.0, delta_2: f.delta_2.0, cos_grade: f.cos_grade.0, turn: f.turn.0 });
            for (i, (a, b)) in run.iter().zip(lane).enumerate() {
                let e = (a - b).abs() / (a.abs().max(1e-300) * f64::EPSILON);
                assert!(e <= 4.0, "field {i} at {k}: {a:e} vs {b:e}");
                worst = worst.max(e);
            }
        }
        std::println!("lane frame against the run's: worst {worst} ulp of the field's size");
        let level = Frame::new(Fused(0.0), Fused(0.0), Fused(0.3f64.sin()), Fused(0.3f64.cos()));
        let run = Frame::new(0.0, 0.0, 0.3f64.sin(), 0.3f64.cos());
        assert_eq!((level.delta.0, level.delta_1.0, level.delta_2.0, level.cos_slope.0), (run.delta, run.delta_1, run.delta_2, run.cos_slope));
        assert_eq!((run.delta, run.cos_slope), (0.0, 1.0));
    }

    /// The derivative over `Lane` ([`deriv_on_ground`], a run's) is the model's accelerations
    /// in the plane's frame taken back to the state (`deriv_geared`, the rig's path), bit for
    /// bit in `f64` with and without gearhead friction, and a sweep lane's ([`Fused`], no
    /// friction) agrees with it to rounding, on a plane, a ramp, bumps and a grid, at random
    /// states.
    #[cfg(feature = "std")]
    #[test]
    fn the_lanes_derivative_is_the_models() {
        use crate::model::lane::Fused;
        let xs: std::vec::Vec<f64> = (0..6).map(|i| -1.5 + 0.6 * i as f64).collect();
        let z: std::vec::Vec<f64> = xs.iter().flat_map(|x| xs.iter().map(move |y| 0.1 * (1.1 * x).sin() * (0.7 * y).cos())).collect();
        let grid = Terrain::Grid(alloc::sync::Arc::new(crate::model::terrain::Grid::new(xs.clone(), xs, &z).unwrap()));
        let terrains = [Terrain::plane(0.3, 0.8).unwrap(), Terrain::ramp(0.2, -0.5, -0.2, 0.3).unwrap(), Terrain::bumps(0.05, 0.9).unwrap(), grid];
        let gb37 = crate::model::friction::Friction::gb37();
        let mut worst = 0.0f64;
        for t in terrains {
            for friction in [None, Some(gb37), Some(gb37.with_stick(0.5))] {
                let m = TerrainModel::new(PlanarModel::new(RobotParams::balanbot()).unwrap().with_friction(friction).unwrap(), t.clone());
                for (x, u) in states().take(200) {
                    let want = m.deriv_geared(&x, &u, [true, true], |_, _| None).0;
                    assert_eq!(m.deriv(&x, &u).map(f64::to_bits), want.map(f64::to_bits), "{t:?} {friction:?} {x:?}");
                    if friction.is_some() {
                        continue;
                    }
                    let k = m.flat().coefficients();
                    let p = m.flat().params();
                    let g = t.local_clamped(x[0], x[1]);
                    let kf = PlanarCoefficients::from_array(k.to_array().map(Fused));
                    let a: [f64; 7] = core::array::from_fn(|i| x[i]);
                    let weight = Fused((p.m_body + p.m_wheels) * p.g);
                    let lane = deriv_on_ground(&kf, weight, Gearhead::of(None), &a.map(Fused), [Fused(u[0]), Fused(u[1])], Fused(g.gx), Fused(g.gy));
                    let scale = want.amax().max(1e-300);
                    for i in 0..7 {
                        worst = worst.max((lane[i].0 - want[i]).abs() / scale);
                    }
                }
            }
        }
        std::println!("a lane's terrain derivative against the model's: worst {worst:e} of the largest entry");
        assert!(worst < 1e-13 && worst > 0.0, "{worst:e}");
    }

    fn states() -> impl Iterator<Item = (PlanarState<f64>, SVector<f64, 2>)> {
        let mut seed = 3u64;
        let mut next = move |lo: f64, hi: f64| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
        };
        (0..300).map(move |_| {
            let x: [f64; 7] = core::array::from_fn(|_| next(-1.5, 1.5));
            (PlanarState::from(x), SVector::from([next(-0.3, 0.3), next(-0.3, 0.3)]))
        })
    }

    /// Level ground (a plane of zero slope, at any heading) is the flat model bit for bit,
    /// with and without gearhead friction (slip law and stick band).
    #[test]
    fn level_ground_is_the_flat_model_bitwise() {
        let gb37 = crate::model::friction::Friction::gb37();
        for friction in [None, Some(gb37), Some(gb37.with_stick(0.5))] {
            let flat = PlanarModel::new(RobotParams::balanbot()).unwrap().with_friction(friction).unwrap();
            for heading in [0.0, 1.0, -2.5] {
                let m = TerrainModel::new(flat, Terrain::plane(0.0, heading).unwrap());
                for (x, u) in states() {
                    assert_eq!(m.deriv(&x, &u), flat.deriv(&x, &u), "{friction:?} at {x}");
                    assert_eq!(m.gearhead_torques_at(&x, &u), flat.gearhead_torques_at(&x, &u));
                    assert_eq!(m.energy(&x), flat.energy(&x));
                }
            }
        }
    }

    /// Facing straight uphill (any uphill heading), the (φ, v) rows are the 2-DOF slope
    /// model with v = R θ̇, its rest pitch and equilibrium torque included.
    #[test]
    fn facing_uphill_is_the_slope_model() {
        let p = RobotParams::<f64>::balanbot();
        for (slope, heading) in [(0.26, 0.0), (0.1, 2.0), (0.4, -1.0)] {
            let m = model(Terrain::plane(slope, heading).unwrap());
            let two = SlopeModel::new(p, slope).unwrap();
            let r = p.wheel_radius;
            for (x, _) in states() {
                let x = PlanarState::from([x[0], x[1], heading, x[3], x[4], x[5], 0.0]);
                let current = x[0] * 0.5;
                let torque = p.torque_per_amp() * current / 2.0;
                let d = m.deriv(&x, &SVector::from([torque, torque]));
                let ds = two.deriv(&Vector4::new(x[3], x[4], 0.0, x[5] / r), &SVector::from([current]));
                assert!((d[4] - ds[1]).abs() < 1e-12 * ds[1].abs().max(1.0), "{} vs {}", d[4], ds[1]);
                assert!((d[5] - r * ds[3]).abs() < 1e-12 * (r * ds[3]).abs().max(1.0));
                assert!(d[6].abs() < 1e-15 && d[2].abs() < 1e-15);
                // Along the ground at v: horizontally v cos α.
                assert!((d[0].hypot(d[1]) - x[5].abs() * slope.cos()).abs() < 1e-14);
            }
            let (xs, us) = two.equilibrium(0.0).unwrap();
            let (phi, [u_r, u_l]) = m.rest(0.3, -0.2, heading).unwrap();
            let torque = p.torque_per_amp() * us / 2.0;
            assert!((phi - xs[0]).abs() < 1e-14, "rest pitch {phi} vs {}", xs[0]);
            assert!((u_r - torque).abs() < 1e-14 && (u_l - torque).abs() < 1e-14, "{u_r} {u_l} vs {torque}");
        }
    }

    /// Across the slope, at rest and upright, nothing moves: every acceleration is zero.
    #[test]
    fn across_the_slope_at_rest_upright_stays() {
        for slope in [0.1, 0.5, 1.2] {
            for uphill in [0.0, 0.8] {
                let m = model(Terrain::plane(slope, uphill).unwrap());
                for side in [-1.0, 1.0] {
                    let x = PlanarState::from([0.2, 0.1, uphill + side * core::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0, 0.0]);
                    let d = m.deriv(&x, &SVector::zeros());
                    assert!(d.amax() < 1e-13, "slope {slope}: {d}");
                    let [n_r, n_l] = m.normal_forces(&x, &SVector::zeros());
                    // The downhill wheel carries more: the left one facing 90° left of uphill.
                    assert!(side * (n_l - n_r) > 0.0, "{n_r} {n_l}");
                }
            }
        }
    }

    /// dE/dt = input power − dissipation on planes, at any heading, turning and pitching:
    /// the energy's rate by central differences along the motion against u·(wheel speeds)
    /// less the viscous losses.
    #[test]
    fn energy_balance_on_planes() {
        let p = RobotParams::<f64>::balanbot();
        for terrain in [Terrain::plane(0.3, 0.4).unwrap(), Terrain::plane(1.0, -2.0).unwrap()] {
            let m = model(terrain);
            for (x, u) in states().take(100) {
                let d = m.deriv(&x, &u);
                let h = 1e-6;
                let rate = (m.energy(&(x + d * h)) - m.energy(&(x - d * h))) / (2.0 * h);
                let f = m.frame(&x);
                let phi_dot_p = x[4] + f.delta_1 * x[6];
                let (v, w) = (x[5], x[6]);
                let spin = [(v + p.half_track * w) / p.wheel_radius, (v - p.half_track * w) / p.wheel_radius];
                let rel = [spin[0] - phi_dot_p, spin[1] - phi_dot_p];
                let power = u[0] * rel[0] + u[1] * rel[1];
                let loss = 0.5 * p.mu_bearing * (rel[0] * rel[0] + rel[1] * rel[1]) + 0.5 * p.mu_ground * (spin[0] * spin[0] + spin[1] * spin[1]);
                let scale = power.abs() + loss + d.amax();
                assert!((rate - (power - loss)).abs() < 1e-6 * scale, "{rate} vs {}", power - loss);
            }
        }
    }

    /// Without friction or input, RK4 keeps the energy on a plane as on flat ground.
    #[test]
    fn energy_is_conserved_on_a_plane() {
        let mut p = RobotParams::<f64>::balanbot();
        p.mu_bearing = 0.0;
        p.mu_ground = 0.0;
        let m = TerrainModel::new(PlanarModel::new(p).unwrap(), Terrain::plane(0.2, 1.0).unwrap());
        let mut x = PlanarState::from([0.0, 0.0, 0.3, 0.3, 0.5, 0.4, 2.0]);
        let e0 = m.energy(&x);
        let mut worst: f64 = 0.0;
        for _ in 0..20_000 {
            x = rk4_step(&m, &x, &SVector::zeros(), 1e-3);
            worst = worst.max((m.energy(&x) - e0).abs());
        }
        std::println!("energy drift over 20 s on a 0.2 rad plane: {worst:e} J of {e0} J");
        assert!(worst < 1e-7 * e0.abs().max(1.0), "{worst}");
    }

    /// Turning hard across a steep plane lifts the uphill wheel; a slow turn does not.
    #[test]
    fn a_hard_turn_lifts_a_wheel() {
        let m = model(Terrain::plane(0.5, 0.0).unwrap());
        let across = core::f64::consts::FRAC_PI_2;
        let slow = PlanarState::from([0.0, 0.0, across, 0.0, 0.0, 0.1, 0.1]);
        assert!(m.halted(&slow, &SVector::zeros()).is_none());
        // Heading +y with uphill +x: the uphill wheel is the right one; turning right
        // (ω < 0) at speed throws the load onto the left, downhill wheel.
        let hard = PlanarState::from([0.0, 0.0, across, 0.0, 0.0, 1.5, -8.0]);
        let [n_r, n_l] = m.normal_forces(&hard, &SVector::zeros());
        assert!(n_r < 0.0 && n_l > 0.0, "{n_r} {n_l}");
        assert_eq!(m.halted(&hard, &SVector::zeros()), Some(Halt::Lifted));
    }
}
