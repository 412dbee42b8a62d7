//! What the world does to the 2-DOF robot besides gravity: pushes, a constant force on
//! the body, and a slope that changes along the path.
//!
//! A point of the body at height h on its axis (from the axle) sits at
//! `p = r θ (cos α, sin α) + h (sin φ, cos φ)` in the vertical plane, so a force
//! `F = (F_x, F_z)` (horizontal, up) there has the generalised forces
//!
//! ```text
//! Q = (∂p/∂q)ᵀ F = [ h (F_x cos φ − F_z sin φ),  r (F_x cos α + F_z sin α) ]   on (φ, θ)
//! ```
//!
//! A constant force adds `M(φ)⁻¹ Q` to the accelerations inside the dynamics. A push is
//! an impulse J: between two steps the generalised velocities jump by `M(φ)⁻¹ Q(J)`
//! (positions do not move). The slope is piecewise constant along the distance r θ;
//! crossing a change keeps (φ̇, θ̇) (the crease's own impact is neglected).
use nalgebra::{SVector, Vector2, Vector4};

use crate::error::invalid;
use crate::hardware::driver::{MotorDriver, MOTORS};
use crate::hardware::rig_plant::{RealPlant, RigGround};
use crate::model::friction::Friction;
use crate::model::lane::Lane;
use crate::model::slope::SlopeCoefficients;
use crate::{c, Dynamics, Real, RobotParams, SlopeModel, TwipError};

/// Most pushes one run holds (fixed size: no allocation, no_std).
pub const MAX_PUSHES: usize = 8;
/// Most slope changes one path holds.
pub const MAX_SLOPE_CHANGES: usize = 8;

/// A horizontal impulse on the body at time `t` [s]: `impulse` [N s] (positive pushes
/// forward) at `height` [m] up the body's axis from the axle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Push<T> {
    pub t: T,
    pub impulse: T,
    pub height: T,
}

/// A constant force on the body [N], horizontal (positive forward) and vertical
/// (positive up), at `height` [m] up the body's axis.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Force<T> {
    pub horizontal: T,
    pub vertical: T,
    pub height: T,
}

impl<T: Real> Force<T> {
    pub fn none() -> Self {
        Self { horizontal: T::zero(), vertical: T::zero(), height: T::zero() }
    }

    pub fn validate(&self) -> Result<Self, TwipError> {
        for (name, v) in [("force.horizontal", self.horizontal), ("force.vertical", self.vertical), ("force.height", self.height)] {
            if !v.is_finite() {
                return Err(invalid(name, v, "must be finite"));
            }
        }
        Ok(*self)
    }

    pub(crate) fn is_zero(&self) -> bool {
        self.horizontal == T::zero() && self.vertical == T::zero()
    }
}

/// Forces side by side on `N` lanes, one array per number: a lane's numbers read from
/// them are loads of consecutive lanes, where an array of forces cost a rig lanes' plant
/// step twelve gathers.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
impl<const N: usize> Force<[f64; N]> {
    pub(crate) fn side_by_side(each: &[Force<f64>; N]) -> Self {
        Force { horizontal: each.map(|f| f.horizontal), vertical: each.map(|f| f.vertical), height: each.map(|f| f.height) }
    }

    /// Lane `l` set to `force` (the other lanes as they are).
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn set_lane(&mut self, l: usize, force: Force<f64>) {
        (self.horizontal[l], self.vertical[l], self.height[l]) = (force.horizontal, force.vertical, force.height);
    }

    /// Lane `l`'s force, each number through `f`.
    #[inline(always)]
    pub(crate) fn lane<S>(&self, l: usize, f: impl Fn(f64) -> S) -> Force<S> {
        Force { horizontal: f(self.horizontal[l]), vertical: f(self.vertical[l]), height: f(self.height[l]) }
    }
}

// The force's law, written once over `Lane`: a run's and a sweep's lanes.
impl<S: Lane> Force<S> {
    /// The generalised force on φ at (sin φ, cos φ) (on θ it is constant on a piece).
    #[inline(always)]
    pub(crate) fn on_pitch(&self, sin_phi: S, cos_phi: S) -> S {
        self.height * (self.horizontal * cos_phi - self.vertical * sin_phi)
    }
}

/// The generalised forces of `(F_x, F_z)` at `height` on the body (module docs).
#[inline]
pub fn generalised_force<T: Real>(phi: T, slope: T, radius: T, fx: T, fz: T, height: T) -> Vector2<T> {
    let (sin_phi, cos_phi) = phi.sin_cos();
    let (sin_a, cos_a) = slope.sin_cos();
    Vector2::new(height * (fx * cos_phi - fz * sin_phi), radius * (fx * cos_a + fz * sin_a))
}

/// `M(φ)⁻¹ q` for the 2×2 mass matrix of `model`.
#[inline]
/// The jump of (φ̇, θ̇) an impulse gives (module docs).
pub fn impulse_response<T: Real>(model: &SlopeModel<T>, x: &Vector4<T>, impulse: T, height: T) -> Vector2<T> {
    let radius = model.params().wheel_radius;
    let q = generalised_force(x[0], model.slope(), radius, impulse, T::zero(), height);
    model.solve_mass(x[0], &q)
}

/// The ground's slope by distance along the path: `base` from the start, then each
/// `(distance [m], slope [rad])` from that distance on (distances strictly increasing).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlopeProfile<T> {
    base: T,
    starts: [T; MAX_SLOPE_CHANGES],
    slopes: [T; MAX_SLOPE_CHANGES],
    count: usize,
}

impl<T: Real> SlopeProfile<T> {
    /// The same slope everywhere.
    pub fn constant(slope: T) -> Self {
        Self { base: slope, starts: [T::zero(); MAX_SLOPE_CHANGES], slopes: [T::zero(); MAX_SLOPE_CHANGES], count: 0 }
    }

    pub fn new(base: T, changes: &[(T, T)]) -> Result<Self, TwipError> {
        if changes.len() > MAX_SLOPE_CHANGES {
            return Err(invalid("slope_profile", c::<T>(changes.len() as f64), "too many slope changes (at most 8)"));
        }
        let mut p = Self::constant(base);
        for (i, &(at, slope)) in changes.iter().enumerate() {
            if !at.is_finite() || (i > 0 && at <= changes[i - 1].0) {
                return Err(invalid("slope_profile.distance", at, "must be finite and strictly increasing"));
            }
            if !slope.is_finite() || slope.abs() >= T::frac_pi_2() {
                return Err(invalid("slope_profile.slope", slope, "must be finite and within (-pi/2, pi/2) rad"));
            }
            p.starts[i] = at;
            p.slopes[i] = slope;
        }
        p.count = changes.len();
        Ok(p)
    }

    /// The changes as (distance, slope).
    pub fn changes(&self) -> impl Iterator<Item = (T, T)> + '_ {
        self.starts[..self.count].iter().copied().zip(self.slopes[..self.count].iter().copied())
    }

    pub fn base(&self) -> T {
        self.base
    }

    /// The same changes from another starting slope (the plant's own).
    pub fn with_base(mut self, base: T) -> Self {
        self.base = base;
        self
    }

    /// Which piece holds `distance`: 0 for the base, i + 1 after change i.
    #[inline]
    pub fn segment(&self, distance: T) -> usize {
        let mut i = self.count;
        while i > 0 && distance < self.starts[i - 1] {
            i -= 1;
        }
        i
    }

    /// The slope at `distance` along the path [rad].
    #[inline]
    pub fn slope_at(&self, distance: T) -> T {
        match self.segment(distance) {
            0 => self.base,
            i => self.slopes[i - 1],
        }
    }
}

/// Pushes in time order, applied once each.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pushes<T> {
    list: [Push<T>; MAX_PUSHES],
    count: usize,
    next: usize,
}

impl<T: Real> Pushes<T> {
    pub fn none() -> Self {
        let zero = Push { t: T::zero(), impulse: T::zero(), height: T::zero() };
        Self { list: [zero; MAX_PUSHES], count: 0, next: 0 }
    }

    /// Any order; sorted by time here.
    pub fn new(pushes: &[Push<T>]) -> Result<Self, TwipError> {
        if pushes.len() > MAX_PUSHES {
            return Err(invalid("pushes", c::<T>(pushes.len() as f64), "too many pushes (at most 8)"));
        }
        let mut s = Self::none();
        for p in pushes {
            if !(p.t.is_finite() && p.t >= T::zero()) {
                return Err(invalid("push.t", p.t, "must be finite and >= 0"));
            }
            if !p.impulse.is_finite() {
                return Err(invalid("push.impulse", p.impulse, "must be finite"));
            }
            if !p.height.is_finite() {
                return Err(invalid("push.height", p.height, "must be finite"));
            }
            // Insertion keeps equal times in the given order.
            let mut i = s.count;
            while i > 0 && s.list[i - 1].t > p.t {
                s.list[i] = s.list[i - 1];
                i -= 1;
            }
            s.list[i] = *p;
            s.count += 1;
        }
        Ok(s)
    }

    pub fn as_slice(&self) -> &[Push<T>] {
        &self.list[..self.count]
    }

    /// All pushes pending again (for a new run).
    pub fn rewind(&mut self) {
        self.next = 0;
    }

    /// The pushes not yet applied whose time is nearest the sample at `t` (step `dt`).
    #[inline]
    pub(crate) fn due(&mut self, t: T, dt: T) -> Option<Push<T>> {
        let p = *self.list[..self.count].get(self.next)?;
        if p.t >= t + dt * c::<T>(0.5) {
            return None;
        }
        self.next += 1;
        Some(p)
    }
}

/// One piece of the ground: its model, and the force's constant part on it.
#[derive(Clone, Copy, Debug)]
struct Piece<T: Real> {
    model: SlopeModel<T>,
    /// The force's generalised force on θ (constant on a piece).
    q_theta: T,
}

impl<T: Real> Piece<T> {
    fn new(model: SlopeModel<T>, force: &Force<T>) -> Self {
        let (sin_slope, cos_slope) = model.slope().sin_cos();
        let q_theta = model.params().wheel_radius * (force.horizontal * cos_slope + force.vertical * sin_slope);
        Self { model, q_theta }
    }

    /// `SlopeModel::deriv` with the force's generalised forces added to f before
    /// solving `M q̈ = f`. A zero force gives the model's numbers bit for bit
    /// (`force_path_matches_the_model`).
    #[inline(always)]
    fn deriv_with_force(&self, x: &Vector4<T>, u: T, force: &Force<T>) -> Vector4<T> {
        self.model.deriv_plus(x, u, |sin_phi, cos_phi| self.force_at(force, sin_phi, cos_phi))
    }

    /// The force's generalised forces on (φ, θ) at (sin φ, cos φ).
    #[inline(always)]
    fn force_at(&self, force: &Force<T>, sin_phi: T, cos_phi: T) -> Option<Vector2<T>> {
        Some(Vector2::new(force.on_pitch(sin_phi, cos_phi), self.q_theta))
    }

    /// `SlopeModel::deriv_geared` with the force (None: none).
    #[inline(always)]
    fn deriv_geared(&self, x: &Vector4<T>, u: T, engaged: bool, force: Option<&Force<T>>) -> (Vector4<T>, T) {
        self.model.deriv_geared(x, u, engaged, |s, cp| force.and_then(|f| self.force_at(f, s, cp)))
    }
}

/// The 2-DOF model on a slope profile: one model per slope, each with the constant part of
/// the force on the body. The ground of the 2-DOF rig's plant, [`SlopePlant`].
#[derive(Clone, Copy, Debug)]
pub struct Slopes<T: Real> {
    /// One piece per slope of the profile.
    pieces: [Piece<T>; MAX_SLOPE_CHANGES + 1],
    profile: SlopeProfile<T>,
    radius: T,
}

impl<T: Real> Slopes<T> {
    pub fn new(params: RobotParams<T>, profile: SlopeProfile<T>, force: &Force<T>) -> Result<Self, TwipError> {
        let base = Piece::new(SlopeModel::new(params, profile.base())?, force);
        let mut pieces = [base; MAX_SLOPE_CHANGES + 1];
        for (i, (_, slope)) in profile.changes().enumerate() {
            pieces[i + 1] = Piece::new(SlopeModel::new(params, slope)?, force);
        }
        Ok(Self { pieces, profile, radius: params.wheel_radius })
    }

    /// Nothing but `model`: the same numbers as `model` itself.
    pub fn plain(model: &SlopeModel<T>) -> Self {
        Self {
            pieces: [Piece::new(*model, &Force::none()); MAX_SLOPE_CHANGES + 1],
            profile: SlopeProfile::constant(model.slope()),
            radius: model.params().wheel_radius,
        }
    }

    /// The same ground with gearhead friction on every piece (validated).
    pub fn with_friction(mut self, friction: Option<Friction<T>>) -> Result<Self, TwipError> {
        for piece in self.pieces.iter_mut() {
            piece.model = piece.model.with_friction(friction)?;
        }
        Ok(self)
    }

    /// Where the ground's slope changes along the path [m] (`SlopeProfile::changes`).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub(crate) fn slope_changes(&self) -> impl Iterator<Item = T> + '_ {
        self.profile.changes().map(|(at, _)| at)
    }

    /// Piece `i`'s coefficients (0: the base slope; then one per change) and the force's
    /// generalised force on θ on it.
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub(crate) fn piece_terms(&self, i: usize) -> (SlopeCoefficients<T>, T) {
        (self.pieces[i].model.coefficients(), self.pieces[i].q_theta)
    }

    #[inline(always)]
    fn piece(&self, x: &Vector4<T>) -> &Piece<T> {
        &self.pieces[self.piece_index(x)]
    }

    /// Which piece of the ground is under the robot at state `x`.
    #[inline(always)]
    fn piece_index(&self, x: &Vector4<T>) -> usize {
        self.profile.segment(x[2] * self.radius)
    }

    /// The model of the ground under the robot at state `x`.
    #[inline]
    pub fn model_at(&self, x: &Vector4<T>) -> &SlopeModel<T> {
        &self.piece(x).model
    }

    /// The lumped current's wheel torque per ampere (every piece is the same robot's).
    #[inline(always)]
    fn torque_per_amp(&self) -> T {
        self.pieces[0].model.params().torque_per_amp()
    }

    /// The lumped pair's flank contact torque τ_i u − 2 τ_f − J β̈: the current `u`, the
    /// gearhead torque per wheel `friction`, the rotor inertia `j` and β̈ = θ̈ − φ̈.
    #[inline(always)]
    pub(crate) fn lumped_contact(&self, u: T, friction: T, j: T, beta_ddot: T) -> T {
        self.torque_per_amp() * u - c::<T>(2.0) * friction - j * beta_ddot
    }
}

impl<T: Real> RigGround<T, 4, 1> for Slopes<T> {
    const PITCH: usize = 0;

    #[inline(always)]
    fn wheel_speeds(&self, x: &Vector4<T>) -> [T; 1] {
        [x[3] - x[1]]
    }

    #[inline(always)]
    fn deriv(&self, x: &Vector4<T>, u: &SVector<T, 1>, engaged: Option<[bool; 1]>, force: Option<&Force<T>>) -> Vector4<T> {
        let piece = self.piece(x);
        match (engaged, force) {
            (Some([engaged]), _) => piece.deriv_geared(x, u[0], engaged, force).0,
            (None, Some(f)) => piece.deriv_with_force(x, u[0], f),
            (None, None) => piece.model.deriv(x, u),
        }
    }

    #[inline(always)]
    fn deriv_geared(&self, x: &Vector4<T>, u: &SVector<T, 1>, engaged: [bool; 1], force: Option<&Force<T>>) -> (Vector4<T>, [T; 1]) {
        let (d, friction) = self.piece(x).deriv_geared(x, u[0], engaged[0], force);
        (d, [friction])
    }

    /// τ_i u − 2 τ_f − J β̈ for the lumped pair (the friction is per wheel).
    #[inline(always)]
    fn contact(&self, _: &Vector4<T>, d: &Vector4<T>, u: &SVector<T, 1>, friction: [T; 1], j: T) -> [T; 1] {
        [self.lumped_contact(u[0], friction[0], j, d[3] - d[1])]
    }

    #[inline(always)]
    fn motor_torques(&self, u: &SVector<T, 1>) -> [T; 1] {
        [self.torque_per_amp() * u[0]]
    }

    #[inline(always)]
    fn input_of(&self, torques: [T; 1]) -> SVector<T, 1> {
        SVector::<T, 1>::new(torques[0] / self.torque_per_amp())
    }

    #[inline(always)]
    fn impact(&self, x: &mut Vector4<T>, _: usize, rotor_speed: T, _: [bool; 1]) {
        self.model_at(x).engage(x, rotor_speed);
    }

    // Rare, and kept out of line: inlined, its sin/cos got hoisted into every step.
    #[cold]
    #[inline(never)]
    fn push(&self, x: &mut Vector4<T>, p: &Push<T>) {
        let dv = impulse_response(self.model_at(x), x, p.impulse, p.height);
        x[1] += dv[0];
        x[3] += dv[1];
    }

    /// Every piece is the same robot with the same friction.
    #[inline(always)]
    fn friction(&self) -> Option<&Friction<T>> {
        self.pieces[0].model.friction()
    }

    /// The lumped pair's rotors, two trains.
    fn rotors(&self) -> (T, T) {
        (self.pieces[0].model.rotor_inertia(), c(2.0))
    }

    /// 2 ε: both motors' current, lumped.
    fn input_per_amp(&self, driver: &MotorDriver<T>, _: &RobotParams<T>) -> T {
        c::<T>(MOTORS) * driver.efficiency
    }

    /// The lumped current (the input's units).
    #[inline(always)]
    fn logged_currents(&self, u: &SVector<T, 1>, windings: Option<(SVector<T, 1>, T)>) -> SVector<T, 1> {
        windings.map_or(*u, |(amps, per_amp)| amps * per_amp)
    }

    /// The lumped pair's offset, for each wheel.
    #[inline(always)]
    fn shafts([offset]: [T; 1]) -> [T; 2] {
        [offset, offset]
    }

    /// Energy of the piece under the robot (the profile's height is not tracked).
    fn energy(&self, x: &Vector4<T>) -> T {
        self.model_at(x).energy(x)
    }
}

/// The 2-DOF rig's plant: the slope model on its profile with the rig's parts
/// ([`RealPlant`]). Input: the lumped current, as `SlopeModel`, or the duty with a driver.
pub type SlopePlant<T> = RealPlant<T, Slopes<T>, 4, 1>;

impl<T: Real> SlopePlant<T> {
    /// The 2-DOF model on `profile` with the constant `force` on the body and `pushes`.
    pub fn disturbed(params: RobotParams<T>, profile: SlopeProfile<T>, force: Force<T>, pushes: Pushes<T>) -> Result<Self, TwipError> {
        let force = force.validate()?;
        Self::new(Slopes::new(params, profile, &force)?, force, pushes)
    }

    /// Nothing but `model`: the same numbers as `model` itself.
    pub fn plain(model: &SlopeModel<T>) -> Self {
        Self::new(Slopes::plain(model), Force::none(), Pushes::none()).expect("no force is a valid force")
    }

    /// The same plant with gearhead friction on every piece of the ground (validated).
    pub fn with_friction(self, friction: Option<Friction<T>>) -> Result<Self, TwipError> {
        let ground = self.ground().with_friction(friction)?;
        Ok(self.with_ground(ground))
    }

    /// The model of the ground under the robot at state `x`.
    #[inline]
    pub fn model_at(&self, x: &Vector4<T>) -> &SlopeModel<T> {
        self.ground().model_at(x)
    }

    /// Applies the pushes due at the sample `t` (step `dt`) to the velocities in `x`.
    #[cfg(test)]
    pub(crate) fn kick(&mut self, t: T, dt: T, x: &mut Vector4<T>) {
        self.ground_start(t, dt, x);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rk4_step;

    fn model() -> SlopeModel<f64> {
        SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap()
    }

    #[test]
    fn a_short_strong_force_is_the_push() {
        // The same impulse spread over a tiny time gives the same velocity jump.
        let m = model();
        let x0 = Vector4::new(0.05, 0.1, 0.0, 1.0);
        let (j, h, dt) = (0.05, 0.12, 1e-6);
        let force = Force { horizontal: j / dt, vertical: 0.0, height: h };
        let pushed = SlopePlant::disturbed(*m.params(), SlopeProfile::constant(0.1), force, Pushes::none()).unwrap();
        let u = SVector::<f64, 1>::new(0.2);
        let by_force = rk4_step(&pushed, &x0, &u, dt);
        let dv = impulse_response(&m, &x0, j, h);
        let drift = rk4_step(&m, &x0, &u, dt) - x0;
        assert!((by_force[1] - x0[1] - drift[1] - dv[0]).abs() < 1e-4 * dv[0].abs());
        assert!((by_force[3] - x0[3] - drift[3] - dv[1]).abs() < 1e-4 * dv[1].abs());
    }

    #[test]
    fn a_push_conserves_the_generalised_momentum_it_adds() {
        // M Δq̇ = Q(J): the kinetic energy grows by Δq̇ᵀ M q̇ + ½ Δq̇ᵀ M Δq̇ = Q·(q̇ + ½ Δq̇).
        let m = model();
        let x = Vector4::new(0.1, -0.3, 2.0, 4.0);
        let (j, h) = (0.2, 0.1);
        let mut d = SlopePlant::disturbed(*m.params(), SlopeProfile::constant(0.1), Force::none(),
                                   Pushes::new(&[Push { t: 1.0, impulse: j, height: h }]).unwrap()).unwrap();
        let mut y = x;
        d.kick(0.9, 1e-3, &mut y);
        assert_eq!(y, x, "not due yet");
        d.kick(1.0, 1e-3, &mut y);
        let q = generalised_force(x[0], 0.1, m.params().wheel_radius, j, 0.0, h);
        let dq = Vector2::new(y[1] - x[1], y[3] - x[3]);
        let mm = m.mass_matrix(x[0]);
        assert!(((mm * dq) - q).norm() < 1e-12);
        let mut z = y;
        d.kick(2.0, 1e-3, &mut z);
        assert_eq!(z, y, "applied once");
    }

    #[test]
    fn slope_profile_picks_the_piece_by_distance() {
        let p = SlopeProfile::new(0.0, &[(0.5, 0.2), (1.0, -0.1)]).unwrap();
        assert_eq!(p.slope_at(-1.0), 0.0);
        assert_eq!(p.slope_at(0.49), 0.0);
        assert_eq!(p.slope_at(0.5), 0.2);
        assert_eq!(p.slope_at(3.0), -0.1);
        assert!(SlopeProfile::new(0.0, &[(0.5, 0.2), (0.5, 0.1)]).is_err());
        assert!(SlopeProfile::<f64>::new(0.0, &[(0.5, 2.0)]).is_err());
        let params = RobotParams::balanbot();
        let d = SlopePlant::disturbed(params, p, Force::none(), Pushes::none()).unwrap();
        let x = Vector4::new(0.0, 0.0, 0.7 / params.wheel_radius, 0.0);
        let u = SVector::<f64, 1>::zeros();
        assert_eq!(d.deriv(&x, &u), SlopeModel::new(params, 0.2).unwrap().deriv(&x, &u));
    }

    #[test]
    fn force_path_matches_the_model() {
        let m = model();
        let piece = Piece::new(m, &Force::none());
        for k in 0..20 {
            let s = k as f64 / 20.0;
            let x = Vector4::new(s - 0.5, 2.0 * s, 1.0, 3.0 - 5.0 * s);
            let u = 0.5 - s;
            assert_eq!(piece.deriv_with_force(&x, u, &Force::none()), m.deriv(&x, &SVector::<f64, 1>::new(u)));
        }
    }

    #[test]
    fn plain_is_the_model_itself() {
        let m = model();
        let d = SlopePlant::plain(&m);
        let x = Vector4::new(0.2, 0.1, 3.0, -1.0);
        let u = SVector::<f64, 1>::new(0.4);
        assert_eq!(d.deriv(&x, &u), m.deriv(&x, &u));
    }
}
