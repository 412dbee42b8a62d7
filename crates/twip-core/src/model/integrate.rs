//! The one integrator: classical fixed-step Runge–Kutta of order 4.
use nalgebra::SVector;

use crate::model::lane::{fill, Lane};
use crate::{Dynamics, Real};

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
// Always inlined, with the observer's `observe`: in the runner's loop, calls of the two
// cost the 2-DOF general runner 13-16% (examples/sweep_throughput scalar, fuzzy-scalar).
#[inline(always)]
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
    SVector::from(rk4(&Held { model, u }, &(*x).into(), &(*k1).into(), dt))
}

/// RK4's stages by where in the step they fall: at its start (k1), halfway (k2, k3) or at
/// its end (k4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Start,
    Half,
    End,
}

/// A vector field ẋ = f(x), as [`rk4`] steps it (a model with its input held).
pub trait Field<S, const N: usize> {
    /// The field at the step's start (RK4's first stage).
    fn at(&self, x: &[S; N]) -> [S; N];

    /// The field at a later stage: the same function of the state, but for a plant whose
    /// input moves within the step (an inductive winding's current).
    #[inline(always)]
    fn at_stage(&self, x: &[S; N], _stage: Stage) -> [S; N] {
        self.at(x)
    }

    /// The field at RK4's later `stage` x + k h, from the step's start `x`: by default at
    /// that state. A field may reuse what it computed at `x` (the sweeps' 2-DOF plants: the
    /// pitch's sin/cos, shifted by k₀ h).
    #[inline(always)]
    fn at_offset(&self, x: &[S; N], k: &[S; N], h: S, stage: Stage) -> [S; N]
    where
        S: Lane,
    {
        self.at_stage(&stage_state(x, k, h), stage)
    }
}

/// RK4's stage state x + k h. (Its closure and `rk4`'s `inline(always)`: on a sweep's 16-lane
/// `Wide`, the compiler left them out of line, baseline code whose every multiply-add called
/// the software fma; `benches/kernel_calls.py` checks the kernels for such calls.)
#[inline(always)]
pub fn stage_state<S: Lane, const N: usize>(x: &[S; N], k: &[S; N], h: S) -> [S; N] {
    fill(#[inline(always)] |i| S::madd(k[i], h, x[i]))
}

/// A model with its input held over a step.
struct Held<'a, M: ?Sized, U> {
    model: &'a M,
    u: &'a U,
}

impl<T, M, const NX: usize, const NU: usize> Field<T, NX> for Held<'_, M, SVector<T, NU>>
where
    T: Real,
    M: Dynamics<T, NX, NU> + ?Sized,
{
    // Always inlined, as is `rk4`: a call per stage would cost more than the model.
    #[inline(always)]
    fn at(&self, x: &[T; NX]) -> [T; NX] {
        self.model.deriv(&SVector::from(*x), self.u).into()
    }

    #[inline(always)]
    fn at_stage(&self, x: &[T; NX], stage: Stage) -> [T; NX] {
        self.model.deriv_at_stage(&SVector::from(*x), self.u, stage).into()
    }
}

/// One RK4 step of the field `f` (a model with its input held) from `x` given `k1` = f(x),
/// written once over [`Lane`] for a run and for a sweep's lanes.
#[inline(always)]
pub fn rk4<S: Lane, const N: usize>(f: &impl Field<S, N>, x: &[S; N], k1: &[S; N], dt: S) -> [S; N] {
    let half = dt * S::splat(0.5);
    let k2 = f.at_offset(x, k1, half, Stage::Half);
    let k3 = f.at_offset(x, &k2, half, Stage::Half);
    let k4 = f.at_offset(x, &k3, dt, Stage::End);
    let sixth = dt / S::splat(6.0);
    fill(#[inline(always)] |i| S::madd(S::madd(k2[i] + k3[i], S::splat(2.0), k1[i] + k4[i]), sixth, x[i]))
}
