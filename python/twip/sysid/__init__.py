"""System identification: fit a robot's parameters from a logged run (`twip.identify`).

`RunLog` holds the logged signals; `identify` fits the free parameters by multiple
shooting (`twip.sysid.estimator`) and returns a `Fit` with the fitted robot, its
uncertainty and a diagnosis of what the log could not determine. docs/sysid.md explains
what to log and how the estimator works.
"""
from __future__ import annotations

import math
import warnings
from typing import Optional, Sequence

import numpy as np

from twip import _core, checks
from twip.sysid import closed_loop
from twip.sysid.estimator import Estimator, Problem
from twip.sysid.dither import Dithered
from twip.sysid.excite import speed_steps
from twip.sysid.fit import Fit, Undetermined
from twip.sysid.log import SIGNALS, LogError, RunLog
from twip.sysid.measure import Sensors
from twip.sysid.misfit import SysidMisfitWarning

__all__ = ["Dithered", "Fit", "LogError", "RunLog", "SIGNALS", "Sensors", "SysidMisfitWarning", "Undetermined", "identify", "speed_steps"]


def identify(log: RunLog, robot, free: Sequence[str], controller=None, *, method: str = "shooting",
             reference=None, segment: float = 0.25, driver=None, friction=None, sensors: Optional[Sensors] = None,
             signals: Optional[Sequence[str]] = None, weights: Optional[dict] = None, max_iter: int = 50,
             max_step: float = 1e-3, backlash: Optional[float] = None) -> Fit:
    """Fits the `free` parameters of `robot` (a RobotParams or a `twip.Robot` from a robot
    file) to `log` by minimising the weighted prediction error of its signals.

    - `free`: RobotParams field names, "slope", with a pwm log (no u column) the
      driver's battery, bridge_drop, resistance, efficiency, and with `friction=` its
      "coulomb" level (the breakaway torque keeps its ratio to it).
    - `segment` [s]: the multiple-shooting segment length; each segment's start state is
      an unknown. Shorter segments suit a plant that diverges fast open-loop.
    - `driver`: the MotorDriver behind a pwm log, with its winding's inductance and current
      limit (default: the robot file's, else `MotorDriver.thesis_like()`, the rig's;
      `Fit.assumed` says which); `friction`: a twip.Friction on the model.
    - `backlash` [rad]: each gear train's free play at the wheel, as the rig takes it
      (`Realism(backlash=)`, e.g. `Realism.thesis_like().backlash`; None: none). Declared, not
      fitted: the predictions carry the rotors through the play as the simulator does (the
      encoder counts the motor shaft), and the fitted robot's parameters stay its own.
    - `sensors`: encoder counts per turn and IMU height, for enc and accel columns.
    - `max_step` [s]: sample intervals longer than this are split into equal RK4 steps; for a
      log of a twip run, its `dt` (the default is `twip.simulate`'s), so that the prediction
      takes the simulator's steps (with winding inductance the current moves within each step).
    - `signals`: which logged outputs to compare (default all present); `weights`: their
      noise standard deviations (default estimated from the data, then from the fit).
    - `method`: "shooting" (the prediction error by multiple shooting, the default) or
      "closed-loop": the simulation error of `controller` (the robot's own) driving the
      candidate robot from the log's first state, with `reference` (a SpeedSchedule,
      default standing still); `controller` alone also adds `Fit.closed_loop_rms`, the
      fitted robot's closed-loop simulation error.
    """
    checks.of_type("log", log, RunLog, "a twip.RunLog")
    params = getattr(robot, "params", robot)
    if not isinstance(params, _core.RobotParams):
        raise LogError(f"robot: {type(robot).__name__} is not a RobotParams or a twip.Robot")
    checks.of_type("driver", driver, (_core.MotorDriver, type(None)), "a twip.MotorDriver or None")
    checks.of_type("friction", friction, (_core.Friction, type(None)), "a twip.Friction or None")
    if backlash is not None:
        backlash = checks.real("backlash", backlash, at_least=0.0) or None
    assumed = None
    if driver is None:
        driver = getattr(robot, "driver", None)
        assumed = "the robot file's [driver]" if driver is not None else DEFAULT_DRIVER_NAME
        driver = driver or default_driver()
    if isinstance(free, str):
        free = [f.strip() for f in free.split(",") if f.strip()]
    checks.of_type("free", free, (list, tuple), "parameter names (a list, or a string 'a,b')")
    for i, name in enumerate(free):
        checks.of_type(f"free[{i}]", name, str, "a parameter name")
    if not free:  # here, not in Problem: `Fit.validate` holds every parameter
        raise LogError("free = []: name at least one parameter to fit")
    checks.of_type("sensors", sensors, (Sensors, type(None)), "a twip.sysid.Sensors or None")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)):
        raise TypeError(f"max_iter must be a positive integer, got {max_iter!r} ({type(max_iter).__name__})")
    if not max_iter > 0:
        raise LogError(f"max_iter = {max_iter!r}: must be a positive integer")
    max_iter = int(max_iter)
    if method not in ("shooting", "closed-loop"):
        raise LogError(f"method = {method!r}: must be 'shooting' or 'closed-loop'")
    if method == "closed-loop" and controller is None:
        raise LogError("method = 'closed-loop' needs controller= (the robot's own controller)")
    if method == "closed-loop":
        segment = log.t[-1] - log.t[0] + 1.0  # one segment: the closed loop is not restarted
    problem = Problem(log, params, list(free), driver, friction, segment, sensors or Sensors(), signals, max_step,
                      backlash)
    if method == "closed-loop":
        fit = Fit(problem, closed_loop.run(problem, controller, reference, max_iter))
    else:
        estimator = Estimator(problem, weights, max_iter)
        solution = estimator.run()
        fit = Fit(problem, solution,
                  lambda delta: estimator.evaluate(np.concatenate([delta, solution.biases]), solution.starts)[0])
        if controller is not None:
            fit.closed_loop_rms = closed_loop.error(problem, fit, controller, reference)
    if problem.driven:
        d = driver.to_dict()
        fit.assumed["driver"] = (f"{assumed or 'driver='}: battery {d['battery']:g} V, bridge drop {d['bridge_drop']:g} V, "
                                 f"resistance {d['resistance']:.4g} ohm, inductance {d['inductance']:g} H, current "
                                 f"limit {d['current_limit'] or 'none'}" + (" A" if d['current_limit'] else ""))
    if backlash is not None:
        fit.assumed["backlash"] = f"{backlash:.4g} rad ({math.degrees(backlash):.3g} deg) of gear play, declared"
    for w in fit.misfits:
        warnings.warn(w, SysidMisfitWarning, stacklevel=2)
    return fit


#: The motor driver a pwm log is fitted with when neither driver= nor the robot file gives
#: one: the thesis-like rig's, as `Realism.thesis_like()` and a robot file's [driver] table start from.
DEFAULT_DRIVER_NAME = "MotorDriver.thesis_like() (the rig's; no driver= and no robot file [driver])"


def default_driver():
    return _core.MotorDriver.thesis_like()
