"""A linear policy trained on an env, as a controller `twip.simulate` and `twip.montecarlo`
take (a Python object with `update(t, y, ref)` and `period`)."""
from __future__ import annotations

import numpy as np

from twip import _core, checks


class LinearPolicy:
    """action = gains · observation, each control period.

    On an env whose rig has a motor driver the action is the firmware's duty [counts];
    `twip.simulate` through that rig hands the controller's lumped current to the
    firmware's current → duty mapping (`MotorDriver.duty`, with the robot `params`), so the
    controller returns the current that this mapping turns into the policy's duty
    (bisection: the mapping is monotone, rounded to whole counts)."""

    def __init__(self, gains, period: float = 5e-3, realism=None, params=None):
        self.gains = checks.vector("gains", gains, 4)
        self.period = checks.real("period", period, above=0.0)
        self.driver = realism.motor if realism is not None else None
        self.params = params if params is not None else _core.RobotParams.balanbot()

    def action(self, y) -> float:
        return float(self.gains @ np.asarray(y, dtype=np.float64))

    def update(self, t, y, ref):
        a = self.action(y)
        if self.driver is None:
            return a
        duty = float(np.clip(np.round(a), -255.0, 255.0))
        return self._current_for(duty, float(y[3] - y[1]))

    def _current_for(self, duty: float, speed: float) -> float:
        """The smallest lumped current the firmware maps to `duty` at `speed`."""
        lo, hi = -1e3, 1e3
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if self.driver.duty(mid, speed, self.params) < duty:
                lo = mid
            else:
                hi = mid
        return hi
