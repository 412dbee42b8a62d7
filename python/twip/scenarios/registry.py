"""The scenario registry: the `Scenario` record, `register` for the modules that define
scenarios, and lookup by name (`get`, `names`, `options`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, Optional

import numpy as np

from twip import _core
from twip.sim import SimResult, simulate


#: A scenario whose reference would take longer than this [s] is refused before it runs
#: (a wheel radius off by orders of magnitude makes a 1 m trip last years).
MAX_TRIP_SECONDS = 3600.0


def trip_time(distance: float, speed: float, wheel_radius: float) -> float:
    """The time [s] to drive `distance` [m] at wheel speed `speed` [rad/s] on wheels of
    `wheel_radius` [m]; refused when longer than MAX_TRIP_SECONDS."""
    leg = distance / (speed * wheel_radius)
    if not leg <= MAX_TRIP_SECONDS:
        raise _core.InvalidParameterError(
            f"wheel_radius = {wheel_radius:g} m: a {distance:g} m leg at {math.degrees(speed):g} deg/s would take "
            f"{leg:.3g} s (more than {MAX_TRIP_SECONDS:g} s); check wheel_radius (metres) or the trip's distance"
        )
    return leg


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    model: object
    controller: object
    x0: np.ndarray
    reference: object
    t_final: float
    dt: float = 1e-3
    control_period: Optional[float] = None
    thesis: dict = field(default_factory=dict)

    def run(self, realism=None, **overrides) -> SimResult:
        """Simulates the scenario; `realism` (a `twip.Realism`) and keyword overrides go
        to `twip.simulate`."""
        kw = dict(
            realism=realism,
            model=self.model,
            controller=self.controller,
            x0=self.x0,
            t_final=self.t_final,
            dt=self.dt,
            reference=self.reference,
            control_period=self.control_period,
        )
        kw.update(overrides)
        return simulate(**kw)

    def replace(self, **changes) -> "Scenario":
        return replace(self, **changes)


_REGISTRY: Dict[str, Callable[..., Scenario]] = {}


def register(name: str):
    def wrap(factory):
        _REGISTRY[name] = factory
        return factory

    return wrap


def names() -> list:
    """All scenario names."""
    return sorted(_REGISTRY)


def options(name: str) -> Dict[str, object]:
    """The keyword options of scenario `name` with their defaults (a factory that takes
    further keywords has the key "**" mapped to None)."""
    import inspect

    if name not in _REGISTRY:
        raise KeyError(f"unknown scenario {name!r}; known: {', '.join(names())}")
    params = list(inspect.signature(_REGISTRY[name]).parameters.values())[2:]
    out: Dict[str, object] = {p.name: p.default for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    if any(p.kind == p.VAR_KEYWORD for p in params):
        out["**"] = None
    return out


def is_planar(sc) -> bool:
    """Whether scenario `sc` runs the 3-DOF planar model (a tracking scenario)."""
    from twip import _core

    return isinstance(sc.model, _core.PlanarModel)


def get(name: str, params=None, controller_params=None, **options) -> Scenario:
    """The scenario `name` for robot `params` (default: RobotParams.balanbot())."""
    if name not in _REGISTRY:
        raise _core.InvalidParameterError(f"unknown scenario '{name}'; known: {', '.join(names())}")
    _check_options(name, options)
    params = params if params is not None else _core.RobotParams.balanbot()
    return _REGISTRY[name](params, controller_params or params, **options)


def robot_options(name: str, robot) -> Dict[str, object]:
    """The options that build scenario `name` for robot file `robot` (a twip.Robot or None):
    {"motor": robot.controller_motor()} for a scenario that takes a motor (the trackers)
    when the file describes one, so that the tracker and the robot's driver are one motor."""
    motor = robot.controller_motor() if robot is not None else None
    return {"motor": motor} if motor is not None and "motor" in options(name) else {}


def _check_options(name: str, given) -> None:
    """Refuses an option that scenario `name` does not take, naming the ones it does."""
    known = options(name)
    for key in given:
        if key not in known and "**" not in known:
            raise TypeError(f"scenario '{name}' has no option {key!r}; its options: {', '.join(known) or 'none'}")
