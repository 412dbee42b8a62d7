"""A random binary dither on a controller's command: what tells the body's own inertia apart.

Speed steps (`speed_steps`) pitch the body slowly, and each shooting segment's free start state
takes up most of what a slow motion says of `i_body`: on the tall robot of benches/sysid.py
(3 kg, 0.2 m, 2.5 A driver) i_body's standard deviation stayed 0.79-1.15 % at 0.1, 0.12 and 0.14
m/s steps, and its white-noise part hardly moved (noise seed 0: 0.27 % and 0.26 % at 0.1 and 0.14 m/s). What
the pitch's response measures an inertia by is the command's quick changes. A firmware adds a
dither of ±`amplitude` to its command, the sign drawn anew every `hold` loop periods, and logs
the command it sent. With a third of the driver's current limit beside 0.1 m/s speed steps,
i_body's deviation fell to 0.36-0.45 % (tall), 0.21-0.27 % (1.8 kg) and 0.11-0.14 % (1.2 kg)
over noise seeds 0-7 (docs/sysid.md).
"""
from __future__ import annotations

import numpy as np

from twip import _core, checks


class Dithered:
    """`controller` (an object with `update(t, y, ref)` and `period`, or a `twip.LqrController`,
    whose law runs here as twip's Python reference of it) with ±`amplitude` [A] added to its
    command, the sign drawn every `hold` updates from a generator seeded by `seed`. Run it as the
    controller of the logged run (`twip.simulate`, with realism as on the robot); the log's `u`
    is the dithered command. Keep the amplitude within what the driver gives beside the
    balancing: a third of its current limit kept three robots of ours up, their drivers
    saturated in at most 0.4 % of the loop periods (docs/sysid.md)."""

    def __init__(self, controller, amplitude: float, hold: int = 1, seed: int = 0):
        self.amplitude = checks.real("amplitude", amplitude, at_least=0)
        if isinstance(hold, bool) or not isinstance(hold, int) or hold < 1:
            raise _core.InvalidParameterError(f"hold must be a positive integer (loop periods), got {hold!r}")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise _core.InvalidParameterError(f"seed must be a non-negative integer, got {seed!r}")
        self.inner, self.hold, self.seed = law_of(controller), hold, seed
        self.period = self.inner.period
        self.reset()

    def reset(self):
        if hasattr(self.inner, "reset"):
            self.inner.reset()
        self._random = np.random.default_rng(self.seed)
        self._updates, self._sign = 0, 1.0

    def update(self, t, y, ref):
        if self._updates % self.hold == 0:
            self._sign = 1.0 if self._random.random() < 0.5 else -1.0
        self._updates += 1
        return self.inner.update(t, y, ref) + self._sign * self.amplitude


def law_of(controller):
    """The controller whose `update` the dither wraps: the object itself, or for a
    `twip.LqrController` (a law in the core, with no Python `update`) the reference's law."""
    if isinstance(controller, _core.LqrController):
        from twip.reference.control import LqrController
        from twip.reference.slope import SlopeModel

        model = controller.model
        return LqrController(SlopeModel(model.params, model.slope, getattr(model, "friction", None)),
                             controller.gains, point=controller.point, period=controller.period)
    if not (hasattr(controller, "update") and hasattr(controller, "period")):
        raise _core.InvalidParameterError(
            f"controller: {type(controller).__name__} has no update(t, y, ref) and period; Dithered wraps a "
            "controller written in Python or a twip.LqrController")
    return controller
