"""The distributions a sweep draws perturbations from (`Uniform`, `Normal`), each resolved
against a nominal value into the tuple the core draws with, and the Wilson interval of a
fall rate."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from twip import _core

_bad = _core.InvalidParameterError


@dataclass(frozen=True)
class Uniform:
    """Uniform on [low, high]; or nominal·(1 ± rel); or nominal ± abs."""

    low: Optional[float] = None
    high: Optional[float] = None
    rel: Optional[float] = None
    abs: Optional[float] = None

    def __post_init__(self):
        _numbers(self, ("low", "high", "rel", "abs"))

    def resolve(self, name: str, nominal: float):
        given = [self.rel is not None, self.abs is not None, self.low is not None or self.high is not None]
        if sum(given) != 1:
            raise _bad(f"{name}: Uniform takes exactly one of rel=, abs= or low=/high=")
        if self.rel is not None:
            _width(name, "rel", self.rel)
            if nominal == 0:
                raise _bad(f"{name}: rel= needs a nonzero nominal value (it is 0); use abs= or low=/high=")
            a, b = nominal * (1 - self.rel), nominal * (1 + self.rel)
            low, high = min(a, b), max(a, b)
        elif self.abs is not None:
            _width(name, "abs", self.abs)
            low, high = nominal - self.abs, nominal + self.abs
        else:
            if self.low is None or self.high is None:
                raise _bad(f"{name}: Uniform needs both low= and high=")
            low, high = finite_number(name, "low", self.low), finite_number(name, "high", self.high)
            if high < low:
                raise _bad(f"{name}: Uniform high = {high} < low = {low} (a negative width)")
        if not math.isfinite(high - low):
            raise _bad(f"{name}: Uniform low = {low}, high = {high}: the width high - low overflows "
                       "(the draws would be inf)")
        return ("uniform", float(low), float(high), float(low), float(high))


@dataclass(frozen=True)
class Normal:
    """Normal with mean (default: nominal) and std, or std = rel·|nominal|; draws are
    clamped into [low, high]."""

    std: Optional[float] = None
    rel: Optional[float] = None
    mean: Optional[float] = None
    low: float = -math.inf
    high: float = math.inf

    def __post_init__(self):
        _numbers(self, ("std", "rel", "mean"))
        _numbers(self, ("low", "high"), optional=False)

    def resolve(self, name: str, nominal: float):
        if (self.std is None) == (self.rel is None):
            raise _bad(f"{name}: Normal takes exactly one of std= or rel=")
        mean = nominal if self.mean is None else finite_number(name, "mean", self.mean)
        if self.rel is not None:
            _width(name, "rel", self.rel)
            if nominal == 0:  # std would be 0: every draw the nominal value
                raise _bad(f"{name}: rel= needs a nonzero nominal value (it is 0); use std=")
            std = self.rel * abs(nominal)
        else:
            _width(name, "std", self.std)
            std = float(self.std)
        if not math.isfinite(abs(mean) + _core.NORMAL_REACH * std):
            raise _bad(f"{name}: Normal std = {std} (mean {mean}): mean +- {_core.NORMAL_REACH:.3g} std overflows "
                       "(the draws would be inf)")
        # The bounds may be infinite (no clamp), not NaN (which would compare false).
        if math.isnan(self.low) or math.isnan(self.high):
            raise _bad(f"{name}: Normal low = {self.low}, high = {self.high}: a bound is NaN")
        if self.high < self.low:
            raise _bad(f"{name}: Normal high = {self.high} < low = {self.low}")
        return ("normal", float(mean), float(std), float(self.low), float(self.high))


def _numbers(dist, fields, optional=True) -> None:
    """Refuses, when the distribution is made, a field that is not a real number (or
    None, where `optional`)."""
    for f in fields:
        value = getattr(dist, f)
        if not (optional and value is None) and (isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))):
            raise _bad(f"{type(dist).__name__}({f}={value!r}): {f} must be a number, got {type(value).__name__}")


def _width(name, what, value):
    if not (math.isfinite(value) and value >= 0):
        raise _bad(f"{name}: {what} = {value} must be a finite number >= 0 (a negative width)")


def finite_number(name, what, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise _bad(f"{name}: {what} = {value!r} must be a number") from None
    if not math.isfinite(value):
        raise _bad(f"{name}: {what} = {value} must be a finite number")
    return value


def wilson_interval(successes: int, n: int, confidence: float = 0.95):
    """Wilson score interval for a binomial proportion: `successes` of `n` trials (integers,
    0 <= successes <= n). n = 0 (no trials: a sweep without valid samples) tells nothing
    about the proportion: (0.0, 1.0)."""
    if isinstance(confidence, bool) or not (isinstance(confidence, (int, float, np.floating)) and 0 < confidence < 1):
        raise _core.InvalidParameterError(f"confidence = {confidence!r}: must be a number in (0, 1)")
    for name, value in (("successes", successes), ("n", n)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if n < 0:
        raise _core.InvalidParameterError(f"n = {n!r}: the number of trials must be >= 0")
    if not 0 <= successes <= n:
        raise _core.InvalidParameterError(f"successes = {successes!r}: must be from 0 to n = {n!r}")
    if n == 0:
        return (0.0, 1.0)
    from statistics import NormalDist

    # From the tail: 0.5 + confidence / 2 rounds to 1.0 below the largest confidence < 1
    # (inv_cdf refuses it) and loses digits near it (4e-10 of z at 1 - 1e-9).
    z = -NormalDist().inv_cdf((1 - confidence) / 2)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    # Clamped to hold p itself (rounding put the bound 1e-17 past p = 0 or 1).
    return (max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half)))
