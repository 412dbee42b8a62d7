//! The closed-loop runner: RK4 on the plant, the controller's input held between its
//! updates (zero-order hold), fall and divergence detection, and observers that
//! accumulate metrics or a decimated log while it runs. Nothing here allocates.
use nalgebra::SVector;

use crate::control::{Controller, Reference};
use crate::{c, rk4_step, Dynamics, Real, TwipError};

/// Step size, duration and fall limit of one run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig<T> {
    /// Plant integration step [s].
    pub dt: T,
    /// Duration [s].
    pub t_final: T,
    /// The robot has fallen when |pitch| exceeds this [rad].
    pub fall_limit: T,
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome<T> {
    Completed,
    /// |pitch| passed the fall limit at `t`.
    Fell { t: T },
    /// The state or the input stopped being finite at `t`.
    Diverged { t: T },
}

impl<T: Real> SimConfig<T> {
    /// Number of plant steps and plant steps per controller update; checks that the
    /// control period is a whole number of steps.
    pub fn steps(&self, control_period: T) -> Result<(usize, usize), TwipError> {
        let bad = |name, v: T, reason| {
            Err(TwipError::InvalidParameter { name, value: crate::to_f64(v), reason })
        };
        if !(self.dt.is_finite() && self.dt > T::zero()) {
            return bad("dt", self.dt, "must be finite and > 0");
        }
        if !(self.t_final.is_finite() && self.t_final > T::zero()) {
            return bad("t_final", self.t_final, "must be finite and > 0");
        }
        if !(self.fall_limit > T::zero()) {
            return bad("fall_limit", self.fall_limit, "must be > 0");
        }
        if !(control_period.is_finite() && control_period > T::zero()) {
            return bad("control_period", control_period, "must be finite and > 0");
        }
        let ratio = control_period / self.dt;
        let per_update = ratio.round();
        if per_update < T::one() || (ratio - per_update).abs() > c::<T>(1e-6) * ratio {
            return bad("control_period", control_period, "must be a whole multiple of dt");
        }
        let n = (self.t_final / self.dt).round();
        if crate::to_f64(n) > 1e12 {
            return bad("t_final", self.t_final, "needs more than 1e12 steps of dt");
        }
        Ok(((crate::to_f64(n) as usize).max(1), crate::to_f64(per_update) as usize))
    }
}

/// Sees every sample of a run: the time, the state, the input held over the next step,
/// the reference and the controller's internals.
pub trait Observer<T: Real, const NX: usize, const NU: usize, S> {
    fn observe(&mut self, t: T, x: &SVector<T, NX>, u: &SVector<T, NU>, r: &S, internals: &[T]);
}

impl<T: Real, const NX: usize, const NU: usize, S> Observer<T, NX, NU, S> for () {
    fn observe(&mut self, _: T, _: &SVector<T, NX>, _: &SVector<T, NU>, _: &S, _: &[T]) {}
}

impl<T, A, B, const NX: usize, const NU: usize, S> Observer<T, NX, NU, S> for (A, B)
where
    T: Real,
    A: Observer<T, NX, NU, S>,
    B: Observer<T, NX, NU, S>,
{
    fn observe(&mut self, t: T, x: &SVector<T, NX>, u: &SVector<T, NU>, r: &S, internals: &[T]) {
        self.0.observe(t, x, u, r, internals);
        self.1.observe(t, x, u, r, internals);
    }
}

/// Runs `controller` on `plant` from `x0`. Returns how the run ended and the number of
/// plant steps taken. The observer sees samples 0..=steps (the last one after the end).
pub fn simulate<T, P, C, R, O, const NX: usize, const NU: usize>(
    plant: &P,
    controller: &mut C,
    reference: &R,
    x0: &SVector<T, NX>,
    config: &SimConfig<T>,
    observer: &mut O,
) -> Result<(Outcome<T>, usize), TwipError>
where
    T: Real,
    P: Dynamics<T, NX, NU>,
    R: Reference<T>,
    C: Controller<T, NX, NU, Reference = R::Sample>,
    O: Observer<T, NX, NU, R::Sample>,
{
    let (n, per_update) = config.steps(controller.period())?;
    for (index, value) in x0.iter().enumerate() {
        if !value.is_finite() {
            return Err(TwipError::NonFinite { name: "x0", index, value: crate::to_f64(*value) });
        }
    }
    let dt = config.dt;
    let mut x = *x0;
    let mut u = SVector::<T, NU>::zeros();
    for k in 0..n {
        let t = dt * c::<T>(k as f64);
        let r = reference.sample(t);
        if k % per_update == 0 {
            u = controller.update(t, &x, &r);
            if u.iter().any(|v| !v.is_finite()) {
                return Ok((Outcome::Diverged { t }, k));
            }
        }
        observer.observe(t, &x, &u, &r, controller.internals());
        x = rk4_step(plant, &x, &u, dt);
        let t_next = dt * c::<T>((k + 1) as f64);
        if x.iter().any(|v| !v.is_finite()) {
            return Ok((Outcome::Diverged { t: t_next }, k + 1));
        }
        if x[P::PITCH].abs() > config.fall_limit {
            observer.observe(t_next, &x, &u, &reference.sample(t_next), controller.internals());
            return Ok((Outcome::Fell { t: t_next }, k + 1));
        }
    }
    let t_end = dt * c::<T>(n as f64);
    observer.observe(t_end, &x, &u, &reference.sample(t_end), controller.internals());
    Ok((Outcome::Completed, n))
}
