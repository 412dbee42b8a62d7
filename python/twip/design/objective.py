"""What a tuning minimises: the share of robots that fail (fall, or break a constraint),
then a secondary cost that can never outweigh one more failure."""
from __future__ import annotations

import math
from typing import Mapping, Optional

import numpy as np

from twip import _core, checks

_bad = _core.InvalidParameterError

#: The secondary cost's parts: the median over the robots that stayed up of each (its
#: magnitude), relative to the scenario's own controller's on the tuning set: pitch error,
#: stop error (where the run ends against its goal) and peak current.
SECONDARY = ("mean_abs_pitch_error", "final_position_error", "peak_current")


def check_constraints(constraints: Optional[Mapping], names) -> dict:
    """{metric: upper bound on its magnitude}, each a metric of the sweep and a finite real
    number >= 0 (below 0 every robot would break it)."""
    checks.of_type("constraints", constraints, (Mapping, type(None)), "a dict {metric: upper bound} or None")
    out = {}
    for name, bound in (constraints or {}).items():
        if name not in names:
            raise _bad(f"constraints: unknown metric '{name}'; the sweep's metrics: {', '.join(names)}")
        out[name] = checks.real(f"constraints: the bound of {name}", bound, at_least=0.0)
    return out


def failures(result, constraints: Mapping[str, float]) -> np.ndarray:
    """Per valid sample: fell, or broke a constraint (its metric's magnitude above the bound: a
    signed metric such as final_position_error is off either way; NaN breaks it)."""
    m = result.metrics
    valid = m["valid"]
    bad = m["fell"].copy()
    for name, bound in constraints.items():
        bad |= ~(np.abs(m[name]) <= bound)
    return bad[valid]


class Objective:
    """The default objective: failures / n, plus (1/n)·s/(1 + s), where s is the mean over
    SECONDARY of the median (robots that stayed up) relative to `reference`'s median. One
    robot more that fails costs more than any secondary gain."""

    def __init__(self, constraints: Mapping[str, float], reference=None, secondary=SECONDARY):
        self.constraints = dict(constraints)
        self.secondary = tuple(secondary)
        self.scales = {}
        if reference is not None:
            self.scales = {k: v for k, v in self.medians(reference).items() if math.isfinite(v) and v > 0}

    def medians(self, result) -> dict:
        m = result.metrics
        up = m["valid"] & ~m["fell"]
        return {k: float(np.median(np.abs(m[k][up]))) if up.any() and k in m else math.nan for k in self.secondary}

    def __call__(self, result) -> float:
        bad = failures(result, self.constraints)
        n = max(len(bad), 1)
        parts = [v / self.scales[k] for k, v in self.medians(result).items() if k in self.scales]
        s = float(np.mean(parts)) if parts and all(math.isfinite(p) for p in parts) else math.inf
        squash = 1.0 if not math.isfinite(s) else s / (1.0 + s)
        return float(bad.sum()) / n + squash / n
