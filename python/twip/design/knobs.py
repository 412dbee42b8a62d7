"""The tunable knobs of each controller family, declared once: name, unit, default range.

A knob is searched on a log scale between `low` and `high` (magnitudes; a knob whose value
is negative keeps its sign). Where the range is absolute (the LQR weights) it is given; where
a controller's own value sets the scale (the gains of the fuzzy, PID and sliding-mode
controllers, whose units differ from robot to robot), the range is `span` decades either
side of the scenario controller's value. `apply(controller, values)` builds the controller
with those knob values; everything else (its model, period, sets, motor...) is kept.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Dict, Mapping, Optional, Tuple

from twip import _core, checks

_bad = _core.InvalidParameterError


@dataclass(frozen=True)
class Knob:
    """One tunable number: `low`..`high` (absolute, on a log scale) or, when they are None,
    `span` decades either side of the controller's own value; `most` caps the magnitude
    (a limit of the controller itself, e.g. the fuzzy leakage's sigma·period < 1)."""

    name: str
    unit: str
    what: str
    low: Optional[float] = None
    high: Optional[float] = None
    span: float = 1.0
    most: Optional[Callable[[object], float]] = None
    #: A weight of a cost (an LQR's Q and R): never negative. The design takes a negative Q
    #: weight (an indefinite Q) and returns gains; refused here by the knob's name.
    weight: bool = False

    def range_for(self, value: float, controller) -> Tuple[float, float]:
        """(low, high) [knob units] of the default range for a controller whose value is `value`."""
        if self.low is not None:
            return self.low, self.high
        if value == 0 or not math.isfinite(value):
            raise _bad(f"knob '{self.name}': the controller's value is {value!r}, so it sets no scale; "
                       f"give the range: knobs={{'{self.name}': (low, high)}}")
        a, b = value / 10**self.span, value * 10**self.span
        low, high = min(a, b), max(a, b)
        if self.most is not None:
            cap = self.most(controller)
            low, high = (max(low, -cap), high) if value < 0 else (low, min(high, cap))
        return low, high


@dataclass(frozen=True)
class Family:
    """A controller family's knobs and how to read and set them."""

    name: str
    controller: type
    knobs: Tuple[Knob, ...]
    read: Callable[[object, object], Dict[str, float]]  # (controller, scenario) -> the controller's own values
    build: Callable[[object, Dict[str, float], object], object]  # (controller, values, scenario) -> controller

    def knob(self, name: str) -> Knob:
        for k in self.knobs:
            if k.name == name:
                return k
        raise _bad(f"unknown knob '{name}' for the {self.name} controller; its knobs: "
                   + ", ".join(k.name for k in self.knobs))


# --- LQR: Q's diagonal and R, redesigned at the scenario's speed ---------------------------

def lqr_design(controller, speed: float, q, r: float):
    """The one place an LQR is designed from knob values: `LqrController.design` on the
    controller's own model, point and period at wheel speed `speed` [rad/s], and the way
    the controller itself was designed (its design_info's `discrete` and `delay`): a tuned
    discrete, delay-aware design stays one."""
    info = controller.design_info or {}
    return _core.LqrController.design(controller.model, speed, list(q), float(r), point=controller.point,
                                      period=controller.period, discrete=bool(info.get("discrete", False)),
                                      delay=bool(info.get("delay", False)))


def design_speed(scenario) -> float:
    """The wheel speed [rad/s] the scenario's LQR was designed at (its design_info), else
    its schedule's fastest leg."""
    info = scenario.controller.design_info
    if info is not None:
        return float(info["theta_dot_ref"])
    return float(max(abs(leg[1]) for leg in scenario.reference.legs))


def _lqr_build(controller, values, scenario):
    q = [values[n] for n in LQR_Q]
    return lqr_design(controller, design_speed(scenario), q, values["r"])


def _lqr_read(controller, scenario) -> Dict[str, float]:
    """A designed LqrController keeps its gains, not the weights they came from: the
    thesis's weights when they give its gains (every registered LQR scenario's), else none."""
    from twip.scenarios.lqr import thesis_weights

    q, r = thesis_weights(controller.model.slope)
    try:
        same = (lqr_design(controller, design_speed(scenario), q, r).gains == controller.gains).all()
    except _core.TwipError:
        same = False
    return dict(zip(LQR_Q + ("r",), [*q, r])) if same else {}


LQR = Family("lqr", _core.LqrController, (
    Knob("q_phi", "1/rad^2", "Q weight on the pitch error", 1e-2, 1e4, weight=True),
    Knob("q_phi_dot", "s^2/rad^2", "Q weight on the pitch rate", 1e-2, 1e4, weight=True),
    Knob("q_theta_dot", "s^2/rad^2", "Q weight on the wheel-speed error", 1e-2, 1e4, weight=True),
    Knob("q_z", "1/rad^2", "Q weight on the integral of the wheel-speed error (position)", 1e-2, 1e4, weight=True),
    Knob("r", "1/A^2", "R, the weight on the current command", 1e-1, 1e5, weight=True),
), _lqr_read, _lqr_build)
#: The knobs of Q's diagonal, in the state order [phi, phi_dot, theta_dot error, z].
LQR_Q = tuple(k.name for k in LQR.knobs if k.name.startswith("q_"))


# --- fuzzy adaptive backstepping + PD ---------------------------------------------------

def _fuzzy_read(controller, scenario) -> Dict[str, float]:
    return {k.name: float(getattr(controller, k.name)) for k in FUZZY.knobs}


def _fuzzy_build(controller, values, scenario):
    return controller.replace(**values)


FUZZY = Family("fuzzy", _core.FuzzyController, (
    Knob("k1", "1/s", "backstepping gain on the pitch error"),
    Knob("k2", "1/s", "backstepping gain on z2"),
    Knob("kp", "A/rad", "PD gain on the wheel-position error"),
    Knob("kd", "A s/rad", "PD gain on the wheel-speed error"),
    Knob("gamma", "1", "adaptation gain Γ (S' = z2 ξ / Γ - σ S)"),
    # Forward-Euler leakage needs sigma * period < 1: at most half that.
    Knob("sigma", "1/s", "adaptation leakage σ", most=lambda c: 0.5 / c.period),
), _fuzzy_read, _fuzzy_build)


# --- PID tracker: each loop's gains, in the tracker's units -----------------------------

def _pid_read(controller, scenario) -> Dict[str, float]:
    return {k.name: float(controller.gains[k.name]) for k in PID.knobs}


def _pid_build(controller, values, scenario):
    # PidTracker keeps its robot only in its pickle: rebuilt from those arguments.
    cls, (params, gains, units, motor, period) = controller.__reduce__()[:2]
    return cls(params, {**dict(gains), **values}, units, motor, period)


PID = Family("pid", _core.PidTracker, (
    Knob("kp_pitch", "tracker units", "pitch loop P"),
    Knob("kd_pitch", "tracker units", "pitch loop D"),
    Knob("kp_speed", "tracker units", "speed loop P"),
    Knob("ki_speed", "tracker units", "speed loop I"),
    Knob("kp_yaw", "tracker units", "heading loop P"),
    Knob("ki_yaw", "tracker units", "heading loop I"),
    Knob("kd_yaw", "tracker units", "heading loop D"),
), _pid_read, _pid_build)


# --- sliding-mode tracker: k1, k2, k3, k_phi --------------------------------------------

def _smc_read(controller, scenario) -> Dict[str, float]:
    return {k.name: float(controller.gains[k.name]) for k in SMC.knobs}


def _smc_build(controller, values, scenario):
    return controller.replace(gains={**dict(controller.gains), **values})


SMC = Family("smc", _core.SmcTracker, (
    Knob("k1", "1/s", "along-track error gain (4.81)"),
    Knob("k2", "1/s", "heading error gain (4.82)"),
    Knob("k3", "1/m", "cross-track gain (4.82)"),
    Knob("k_phi", "1/s", "pitch gain of the surface S1"),
), _smc_read, _smc_build)


FAMILIES = (LQR, FUZZY, PID, SMC)


def family_of(controller) -> Family:
    """The knob family of a controller; a controller of no family is refused."""
    for f in FAMILIES:
        if isinstance(controller, f.controller):
            return f
    raise _bad(f"controller {type(controller).__name__}: has no tunable knobs (tunable: "
               + ", ".join(f.controller.__name__ for f in FAMILIES) + ")")


@dataclass(frozen=True)
class Space:
    """The knobs being tuned, each with its range, in order: maps a point of the unit cube
    to knob values (log scale, sign kept) and back."""

    family: Family
    names: Tuple[str, ...]
    ranges: Tuple[Tuple[float, float], ...]

    def values(self, u) -> Dict[str, float]:
        out = {}
        for name, (low, high), x in zip(self.names, self.ranges, u):
            sign = -1.0 if high < 0 else 1.0
            a, b = sorted((abs(low), abs(high)))
            out[name] = sign * math.exp(math.log(a) + float(x) * (math.log(b) - math.log(a)))
        return out

    def unit(self, values: Mapping[str, float]):
        out = []
        for name, (low, high) in zip(self.names, self.ranges):
            a, b = sorted((abs(low), abs(high)))
            out.append(0.5 if a == b else (math.log(abs(values[name])) - math.log(a)) / (math.log(b) - math.log(a)))
        return out


def space(scenario, knobs=None) -> Space:
    """The knob space of `scenario`'s controller: every knob of its family with its default
    range (knobs=None), the named ones (a list of names), or the named ones with ranges
    ({name: (low, high)} or {name: None} for the default range)."""
    controller = scenario.controller
    fam = family_of(controller)
    own = fam.read(controller, scenario)
    if knobs is None:
        knobs = {k.name: None for k in fam.knobs}
    elif isinstance(knobs, (list, tuple)):
        for name in knobs:  # before the dict: a list as a name is not hashable
            checks.of_type("knobs: a knob name", name, str, "a string")
        knobs = {name: None for name in knobs}
    elif not isinstance(knobs, Mapping):
        raise _bad(f"knobs = {knobs!r}: must be None, a list of knob names or a dict {{name: (low, high) or None}}")
    if not knobs:
        raise _bad("knobs: no knob to tune (give at least one, or None for all)")
    names, ranges = [], []
    for name, given in knobs.items():
        knob = fam.knob(name)
        low, high = knob.range_for(own.get(name, 0.0), controller) if given is None else _range(knob, given)
        names.append(name)
        ranges.append((low, high))
    return Space(fam, tuple(names), tuple(ranges))


def _range(knob, given) -> Tuple[float, float]:
    # A string is a sequence too ("19": 1 to 9): refused with the other non-pairs. Each end
    # is a real number, not cast (a complex's real part).
    name = knob.name
    if isinstance(given, (str, bytes)) or not hasattr(given, "__len__") or len(given) != 2:
        raise TypeError(f"knob '{name}': range must be two numbers (low, high), got {given!r}")
    low, high = (checks.real(f"knob '{name}': range's {end}", v) for end, v in zip(("low", "high"), given))
    if low == 0 or high == 0 or (low < 0) != (high < 0):
        raise _bad(f"knob '{name}': range ({low:g}, {high:g}) is searched on a log scale, so both ends need "
                   "the same sign and neither may be 0")
    if high < low:
        raise _bad(f"knob '{name}': range ({low:g}, {high:g}) is inverted (high < low)")
    if knob.weight and low < 0:
        raise _bad(f"knob '{name}': range ({low:g}, {high:g}) is negative; it is a weight of the cost, > 0")
    return low, high


def apply(scenario, values: Mapping[str, float]):
    """`scenario` with its controller built from knob values (the others keep the
    controller's own values; an LQR needs all five weights)."""
    checks.of_type("values", values, Mapping, "a dict {knob name: value}")
    controller = scenario.controller
    fam = family_of(controller)
    for name in values:
        fam.knob(name)
    given = {k: checks.real(f"knob '{k}'", v) for k, v in values.items()}
    for k, v in given.items():
        if v < 0 and fam.knob(k).weight:
            raise _bad(f"knob '{k}' = {v:g}: a weight of the {fam.name} cost must be >= 0")
    full = {**fam.read(controller, scenario), **given}
    missing = [k.name for k in fam.knobs if k.name not in full]
    if missing:
        raise _bad(f"the {fam.name} controller's own values of {', '.join(missing)} are not known (its gains "
                   "were not designed from the thesis's weights): tune or give every knob")
    return scenario.replace(controller=fam.build(controller, full, scenario))
