//! How either runner (2-DOF, 3-DOF) drives its run with a controller: a Python controller
//! with the GIL, called back at every update, or a twip controller without it. The two
//! runners differ only in their run's settings (`Run`).
use pyo3::prelude::*;
use twip_core::control::Controller;
use twip_core::sim::log::LogRow;
use twip_core::TwipError;

use crate::control::user_controller::UserController;
use crate::errors::PyTwipError;

/// One closed-loop run's settings for a model of NX states and NU inputs.
pub(crate) trait Run<const NX: usize, const NU: usize>: Sync {
    type Reference: LogRow<f64> + Copy;
    type Output: Send;

    fn run<C>(&self, ctrl: &mut C, should_stop: impl FnMut() -> bool) -> Result<Self::Output, TwipError>
    where
        C: Controller<f64, NX, NU, Reference = Self::Reference>;
}

/// What a run gives back: the controller's internals' names and the run's output.
pub(crate) type Driven<O> = (&'static [&'static str], O);

/// A controller written in Python (`controller`), run every `period` [s] (None: its own, or
/// `dt` for a plain callable) on a `model`. Its first exception ends the run and is raised.
pub(crate) fn run_user<R, const NX: usize, const NU: usize>(
    run: &R,
    controller: &Bound<'_, PyAny>,
    period: Option<f64>,
    dt: f64,
    model: &str,
) -> PyResult<Driven<R::Output>>
where
    R: Run<NX, NU>,
{
    let mut ctrl = UserController::<R::Reference, NX, NU>::new(controller, period, dt, model)?;
    let failed = ctrl.failed.clone();
    let mut interrupt = None;
    let out = run.run(&mut ctrl, || failed.get() || crate::interrupt::requested(&mut interrupt));
    if let Some(err) = ctrl.take_error().or(interrupt) {
        return Err(err);
    }
    Ok((ctrl.internal_names(), out.map_err(PyTwipError)?))
}

/// A twip controller's run, without the GIL; Ctrl-C ends it.
pub(crate) fn run_native<R, C, const NX: usize, const NU: usize>(py: Python<'_>, run: &R, mut ctrl: C) -> PyResult<Driven<R::Output>>
where
    R: Run<NX, NU>,
    C: Controller<f64, NX, NU, Reference = R::Reference> + Send,
{
    let (out, interrupt) = py.detach(|| {
        let mut interrupt = None;
        let out = run.run(&mut ctrl, || crate::interrupt::requested(&mut interrupt));
        (out, interrupt)
    });
    if let Some(err) = interrupt {
        return Err(err);
    }
    Ok((ctrl.internal_names(), out.map_err(PyTwipError)?))
}
