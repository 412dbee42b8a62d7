//! LQR with integral action on the wheel speed (thesis 4.14–4.24, 4.57–4.61).
//!
//! `u = u_s − k̂1 (x − x_s) − k̂2 z`,  `z = ∫(θ̇ − θ̇_ref) dt`,  on `x = [φ, φ̇, θ̇]`.
//! The steady state `(φ_s, u_s)` follows the reference speed and comes from the
//! controller's own model, which may differ from the plant's.
use nalgebra::SVector;

use crate::control::Controller;
use crate::control::reference::{SpeedRef, SpeedSchedule};
use crate::model::lane::Lane;
use crate::model::slope::SlopeModel;
use crate::{Real, TwipError};

/// Where the design linearises and which steady state it aims for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DesignPoint {
    /// The thesis's: linear model at φ = 0 (4.6–4.10), steady state (4.12)–(4.13).
    Thesis,
    /// Ours: linearised at the nonlinear model's true steady state (φ_s, θ̇_ref).
    OperatingPoint,
}

/// Names of [`LqrController::internals`], in order.
pub const LQR_INTERNALS: [&str; 4] = ["z", "phi_s", "u_s", "theta_dot_ref"];

/// The discrete-time LQR + integral controller.
#[derive(Clone, Copy, Debug)]
pub struct LqrController<T: Real> {
    gains: [T; 4],
    model: SlopeModel<T>,
    point: DesignPoint,
    period: T,
    z: T,
    /// (θ̇_ref, φ_s, u_s) of the last reference speed seen: speeds change rarely.
    cache: Option<(T, T, T)>,
    internals: [T; 4],
}

impl<T: Real> LqrController<T> {
    /// `gains` = [k_phi, k_phi_dot, k_theta_dot, k_z] (the thesis's K̂, u = u_s − K̂ Δx̂).
    pub fn new(gains: [T; 4], model: SlopeModel<T>, point: DesignPoint, period: T) -> Result<Self, TwipError> {
        for (i, g) in gains.iter().enumerate() {
            if !g.is_finite() {
                return Err(TwipError::NonFinite { name: "gains", index: i, value: crate::to_f64(*g) });
            }
        }
        if !(period.is_finite() && period > T::zero()) {
            return Err(TwipError::InvalidParameter {
                name: "period",
                value: crate::to_f64(period),
                reason: "must be finite and > 0",
            });
        }
        Ok(Self { gains, model, point, period, z: T::zero(), cache: None, internals: [T::zero(); 4] })
    }

    pub fn gains(&self) -> [T; 4] {
        self.gains
    }

    pub fn model(&self) -> &SlopeModel<T> {
        &self.model
    }

    pub fn point(&self) -> DesignPoint {
        self.point
    }

    /// Whether what the next update starts from (the integrator z) is finite.
    pub fn state_is_finite(&self) -> bool {
        self.z.is_finite()
    }

    pub fn with_period(mut self, period: T) -> Result<Self, TwipError> {
        self = Self::new(self.gains, self.model, self.point, period)?;
        Ok(self)
    }

    /// The steady state (φ_s, u_s) this controller aims for at a reference speed.
    pub fn steady_state(&self, theta_dot_ref: T) -> Result<(T, T), TwipError> {
        let (x, u) = match self.point {
            DesignPoint::Thesis => self.model.equilibrium_linear(theta_dot_ref)?,
            DesignPoint::OperatingPoint => self.model.equilibrium(theta_dot_ref)?,
        };
        Ok((x[0], u))
    }

    /// Fails if some speed of `schedule` (or standing still) has no steady state.
    pub fn check_reference(&self, schedule: &SpeedSchedule<T>) -> Result<(), TwipError> {
        self.steady_state(T::zero())?;
        for speed in schedule.speeds() {
            self.steady_state(speed)?;
        }
        Ok(())
    }
}

impl<T: Real> Controller<T, 4, 1> for LqrController<T> {
    type Reference = SpeedRef<T>;

    fn period(&self) -> T {
        self.period
    }

    fn reset(&mut self) {
        self.z = T::zero();
        self.cache = None;
        self.internals = [T::zero(); 4];
    }

    fn update(&mut self, _t: T, y: &SVector<T, 4>, r: &SpeedRef<T>) -> SVector<T, 1> {
        let (phi_s, u_s) = match self.cache {
            Some((speed, phi_s, u_s)) if speed == r.theta_dot => (phi_s, u_s),
            _ => {
                // Speeds were checked by `check_reference`; an unchecked impossible one
                // aims at standing straight rather than failing mid-run.
                let (phi_s, u_s) = self.steady_state(r.theta_dot).unwrap_or((T::zero(), T::zero()));
                self.cache = Some((r.theta_dot, phi_s, u_s));
                (phi_s, u_s)
            }
        };
        let (u, z) = law(&self.gains, phi_s, u_s, &[y[0], y[1], y[2], y[3]], r.theta_dot, self.z, self.period);
        self.internals = [self.z, phi_s, u_s, r.theta_dot];
        self.z = z;
        SVector::<T, 1>::new(u)
    }

    fn internals(&self) -> &[T] {
        &self.internals
    }

    fn internal_names(&self) -> &'static [&'static str] {
        &LQR_INTERNALS
    }
}

/// The control law, written once over [`Lane`] (a run's and a sweep lane's): the input
/// for measurement `y` with steady state (φ_s, u_s), and the integrator's next value.
/// Forward Euler, as a microcontroller would: z holds the error up to this update.
#[inline(always)]
pub(crate) fn law<S: Lane>(k: &[S; 4], phi_s: S, u_s: S, y: &[S; 4], theta_dot_ref: S, z: S, period: S) -> (S, S) {
    let speed_error = y[3] - theta_dot_ref;
    let u = u_s - (k[0] * (y[0] - phi_s) + k[1] * y[1] + k[2] * speed_error) - k[3] * z;
    (u, z + speed_error * period)
}

/// The augmented design problem (4.17)–(4.23) and its solution.
#[cfg(feature = "alloc")]
#[derive(Clone, Debug, PartialEq)]
pub struct LqrDesign<T: Real> {
    /// K̂ = [k_phi, k_phi_dot, k_theta_dot, k_z].
    pub gains: [T; 4],
    /// Â and B̂ of (4.19) on Δx̂ = [Δφ, Δφ̇, Δθ̇, z].
    pub a: nalgebra::Matrix4<T>,
    pub b: nalgebra::Vector4<T>,
    /// P̂ of (4.23).
    pub x: nalgebra::DMatrix<T>,
    /// Eigenvalues of Â − B̂ K̂.
    pub poles: alloc::vec::Vec<nalgebra::Complex<T>>,
    /// The steady state designed for.
    pub phi_s: T,
    pub u_s: T,
}

/// The plant's linear model on `[φ, φ̇, θ̇]` where `point` says, and the steady state
/// `(φ_s, u_s)` at `theta_dot_ref`: what both designs, continuous and discrete, start from.
#[cfg(feature = "alloc")]
#[allow(clippy::type_complexity)]
pub(crate) fn linear_model<T: Real>(
    model: &SlopeModel<T>,
    theta_dot_ref: T,
    point: DesignPoint,
) -> Result<(nalgebra::Matrix3<T>, nalgebra::Vector3<T>, T, T), TwipError> {
    use nalgebra::{Matrix3, Vector3};
    Ok(match point {
        DesignPoint::Thesis => {
            let lin = model.linearize_thesis();
            let (x_s, u_s) = model.equilibrium_linear(theta_dot_ref)?;
            (lin.a, lin.b, x_s[0], u_s)
        }
        DesignPoint::OperatingPoint => {
            let (x_s, u_s) = model.equilibrium(theta_dot_ref)?;
            let (a4, b4) = model.linearize(&x_s, u_s);
            // Drop θ: nothing depends on it.
            let keep = [0usize, 1, 3];
            (Matrix3::from_fn(|i, j| a4[(keep[i], keep[j])]), Vector3::from_fn(|i, _| b4[keep[i]]), x_s[0], u_s)
        }
    })
}

/// Designs K̂ for `model` at the reference speed `theta_dot_ref` with weights Q̂ (4×4)
/// and R̂ (scalar), linearised where `point` says.
#[cfg(feature = "alloc")]
pub fn design<T: Real>(
    model: &SlopeModel<T>,
    theta_dot_ref: T,
    q: &nalgebra::Matrix4<T>,
    r: T,
    point: DesignPoint,
) -> Result<LqrDesign<T>, TwipError> {
    use nalgebra::{DMatrix, Matrix4, Vector4};
    let (a3, b3, phi_s, u_s) = linear_model(model, theta_dot_ref, point)?;
    // (4.19): the integrator state z integrates θ̇ − θ̇_ref (C = [0 0 1]).
    let mut a = Matrix4::<T>::zeros();
    a.fixed_view_mut::<3, 3>(0, 0).copy_from(&a3);
    a[(3, 2)] = T::one();
    let b = Vector4::new(b3[0], b3[1], b3[2], T::zero());
    let solved = crate::control::care::lqr(
        &DMatrix::from_fn(4, 4, |i, j| a[(i, j)]),
        &DMatrix::from_fn(4, 1, |i, _| b[i]),
        &DMatrix::from_fn(4, 4, |i, j| q[(i, j)]),
        &DMatrix::from_element(1, 1, r),
    )?;
    let k = &solved.k;
    Ok(LqrDesign {
        gains: [k[(0, 0)], k[(0, 1)], k[(0, 2)], k[(0, 3)]],
        a,
        b,
        x: solved.x,
        poles: solved.poles,
        phi_s,
        u_s,
    })
}
