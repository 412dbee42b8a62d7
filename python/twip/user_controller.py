"""What twip checks of a controller written in Python (an object with `update(t, y, ref)`
and `period`, or a plain callable) around the core's runner: that its own period is the
loop's, and whether an exception out of a run is the controller's failure or the model's."""
from __future__ import annotations

import math
import numbers
from pathlib import Path
from typing import Optional

from twip import _core

#: Periods within this relative difference are one period (a sum of float steps).
SAME_PERIOD = 1e-9


def own_period(controller) -> Optional[float]:
    """The controller object's own `period` [s], checked: None when it has none (a plain
    callable, or an object whose loop period is given)."""
    if not hasattr(controller, "update") or not hasattr(controller, "period"):
        return None
    period = controller.period
    # Any real number (np.float32, np.int64, Fraction): numbers.Real, not a bool.
    real = isinstance(period, numbers.Real) and not isinstance(period, bool)
    try:
        seconds = float(period) if real else math.nan
    except OverflowError:  # an int beyond any float (10**400)
        seconds = math.inf
    if not (math.isfinite(seconds) and seconds > 0):
        raise _core.InvalidParameterError(f"controller.period = {period!r}: must be a positive, finite number of "
                                          "seconds (the loop period the controller is written for)")
    return seconds


def check_period(controller, control_period: Optional[float], realism) -> None:
    """Refuses a Python controller whose own `period` is not the loop's: `control_period=`,
    else the realism's loop period. The runner calls it at the loop's period, so a controller
    that integrates or differentiates with its own would be silently wrong (a rig at 5 ms ran
    controllers with periods 0.02, 0.1, 0, -0.005, NaN and "5ms" alike)."""
    own = own_period(controller)
    if control_period is not None:
        loop, source = control_period, "control_period="
    elif realism is not None and realism.control_period is not None:
        loop, source = realism.control_period, "the realism's control_period"
    else:
        return
    if own is not None and abs(own - loop) > SAME_PERIOD * loop:
        raise _core.InvalidParameterError(
            f"controller.period = {own!r} s, but the loop runs every {loop!r} s ({source}): set controller.period "
            f"= {loop!r}, or run the loop at the controller's period")


def failure(error: BaseException, runner_file: str, runner_name: str) -> Optional[str]:
    """The message of `error` when it is the controller's failure (raised in its code, or
    the core's complaint about what it returned: "controller returned u = [NaN] ..."), None
    when the model refused the robot. `runner_file`/`runner_name`: the Python frame that
    called the core, below which any frame is the controller's."""
    tb = error.__traceback__
    last = None
    while tb is not None:
        last, tb = tb, tb.tb_next
    from_core = last is not None and (Path(last.tb_frame.f_code.co_filename) == Path(runner_file)
                                      and last.tb_frame.f_code.co_name == runner_name)
    if not from_core or not isinstance(error, _core.TwipError) or str(error).startswith("controller"):
        return f"{type(error).__name__}: {error}"
    return None
