//! The one integrator: classical fixed-step Runge–Kutta of order 4.
use nalgebra::SVector;

use crate::{c, Dynamics, Real};

/// One RK4 step of `dt` with the input held constant over the step (zero-order hold).
#[inline]
pub fn rk4_step<T, M, const NX: usize, const NU: usize>(
    model: &M,
    x: &SVector<T, NX>,
    u: &SVector<T, NU>,
    dt: T,
) -> SVector<T, NX>
where
    T: Real,
    M: Dynamics<T, NX, NU> + ?Sized,
{
    rk4_step_from_k1(model, x, u, dt, &model.deriv(x, u))
}

/// [`rk4_step`] given its first stage `k1` = `model.deriv(x, u)`, which a caller may
/// also need (an accelerometer reads it): the same arithmetic, one evaluation fewer.
#[inline]
pub fn rk4_step_from_k1<T, M, const NX: usize, const NU: usize>(
    model: &M,
    x: &SVector<T, NX>,
    u: &SVector<T, NU>,
    dt: T,
    k1: &SVector<T, NX>,
) -> SVector<T, NX>
where
    T: Real,
    M: Dynamics<T, NX, NU> + ?Sized,
{
    let half = dt * c::<T>(0.5);
    let k1 = *k1;
    let k2 = model.deriv(&(x + k1 * half), u);
    let k3 = model.deriv(&(x + k2 * half), u);
    let k4 = model.deriv(&(x + k3 * dt), u);
    x + (k1 + (k2 + k3) * c::<T>(2.0) + k4) * (dt / c::<T>(6.0))
}
