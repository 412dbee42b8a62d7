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
) -> SimResult:
    """Runs `controller` on `model` from `x0` for `t_final` seconds.

    The plant is integrated with RK4 at `dt`; the controller updates every
    `control_period` (default: its own period, which must be a multiple of `dt`) and
    its input is held in between. The run ends early, cleanly, when |pitch| exceeds
    `fall_limit` (default 60 degrees). `record_every` keeps one sample in k in the log;
    metrics always use every step.
    """
    if reference is None:
        reference = _core.SpeedSchedule.constant(0.0)
    raw = _core.simulate_raw(
        model, controller, x0, float(t_final), float(dt), reference,
        control_period=control_period, fall_limit=float(fall_limit), record_every=int(record_every),
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
    )
