"""The closed-loop runner's Python face: `simulate` and its `SimResult`."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from twip import _core


@dataclass(frozen=True)
class SimResult:
    """One closed-loop run. Arrays have one row per logged sample (SI units, radians)."""

    t: np.ndarray
    states: np.ndarray
    inputs: np.ndarray
    references: np.ndarray
    reference_names: tuple
    internals: dict
    outcome: str
    t_end: Optional[float]
    steps: int
    metrics: dict = field(default_factory=dict)
    # With `realism`: per sample, what the controller last read (2-DOF: phi_hat,
    # phi_dot_hat, theta_hat, theta_dot_hat; 3-DOF: x_hat ... omega_hat), the plant's input
    # ("drive", "drive_r"/"drive_l": PWM counts with a motor driver, else the command) and
    # the motor current ("motor_current" lumped, or "current_r"/"current_l", A).
    signals: dict = field(default_factory=dict)

    @property
    def measurements(self) -> Optional[np.ndarray]:
        """What the controller read per sample, beside `states` (same columns)."""
        if not self.signals:
            return None
        names = [n for n in self.signals if n.endswith("_hat")]
        return np.column_stack([self.signals[n] for n in names])

    @property
    def fell(self) -> bool:
        """True when |pitch| passed the fall limit."""
        return self.outcome == "fell"

    @property
    def t_fall(self) -> Optional[float]:
        return self.t_end if self.fell else None

    def reference(self, name: str) -> np.ndarray:
        return self.references[:, self.reference_names.index(name)]


def simulate(
    model,
    controller,
    x0,
    t_final: float,
    dt: float = 1e-3,
    reference=None,
    control_period: Optional[float] = None,
    fall_limit: float = math.radians(60.0),
    record_every: int = 1,
    settle: Optional[float] = None,
    realism=None,
) -> SimResult:
    """Runs `controller` on `model` from `x0` for `t_final` seconds.

    The plant is integrated with RK4 at `dt`; the controller updates every
    `control_period` (default: its own period, which must be a multiple of `dt`) and
    its input is held in between. The run ends early, cleanly, when |pitch| exceeds
    `fall_limit` (default 60 degrees). `record_every` keeps one sample in k in the log;
    metrics always use every step.

    A `PlanarModel` needs a trajectory as `reference` (twip.Circle, Line, FigureEight or
    Waypoints); its "_settled" metrics start at `settle` [s] (default: one lap of a
    circle or figure-eight, else 0).

    `realism` (a `twip.Realism`) puts the robot's real parts in the loop: sensors and
    estimator, motor driver, loop period and delay, disturbances; on a PlanarModel each
    wheel has its motor and encoder and the gyro's z axis gives the yaw rate.
    `inputs` stay the controller's command (current or wheel torques); `signals` and
    `measurements` hold the rest.
    """
    if isinstance(model, _core.PlanarModel):
        if reference is None:
            raise _core.InvalidParameterError(
                "reference is required for a PlanarModel: a twip.Circle, Line, FigureEight or Waypoints")
        raw = _core.simulate_planar_raw(
            model, controller, x0, float(t_final), float(dt), reference,
            control_period=control_period, fall_limit=float(fall_limit), record_every=int(record_every),
            settle=None if settle is None else float(settle), realism=realism,
        )
    else:
        if settle is not None:  # the settled metrics are the tracking ones
            raise _core.InvalidParameterError("settle: only a PlanarModel (3-DOF tracking) takes settle")
        if reference is None:
            reference = _core.SpeedSchedule.constant(0.0)
        raw = _core.simulate_raw(
            model, controller, x0, float(t_final), float(dt), reference,
            control_period=control_period, fall_limit=float(fall_limit), record_every=int(record_every),
            realism=realism,
        )
    names = raw["internal_names"]
    internals = {n: raw["internals"][:, i] for i, n in enumerate(names)}
    return SimResult(
        t=raw["t"],
        states=raw["states"],
        inputs=raw["inputs"],
        references=raw["references"],
        reference_names=tuple(raw["reference_names"]),
        internals=internals,
        outcome=raw["outcome"],
        t_end=raw["t_end"],
        steps=raw["steps"],
        metrics=dict(raw["metrics"]),
        signals={} if raw.get("signals") is None else {
            n: raw["signals"][:, i] for i, n in enumerate(raw["signal_names"])},
    )
