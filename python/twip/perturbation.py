"""What a sweep may perturb: the two sweep families (2-DOF `SlopeModel`, 3-DOF tracking
`PlanarModel`), their initial-state names, the core kernel a sweep runs on, and the
resolution of `perturb={name: distribution}` into the core's draw order."""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable, Mapping, Tuple

from twip import _core, checks, user_sweep
from twip.distributions import Normal, Uniform

_bad = _core.InvalidParameterError

STATE_NAMES = ("phi0", "phi_dot0", "theta0", "theta_dot0")
#: SI units of the initial-state entries a sweep can perturb.
STATE_UNITS = {"phi0": "rad", "phi_dot0": "rad/s", "theta0": "rad", "theta_dot0": "rad/s", "x0": "m", "y0": "m",
                "psi0": "rad", "v0": "m/s", "omega0": "rad/s"}
#: The initial state of a PlanarModel: [x, y, psi, phi, phi_dot, v, omega].
PLANAR_STATE_NAMES = ("x0", "y0", "psi0", "phi0", "phi_dot0", "v0", "omega0")


def _planar_draw(model, x0, perturbations, seed, index):
    params, x0, ground = _core.sweep_planar_draw(model, x0, perturbations, seed, index)
    return params, ground, x0  # ground: None on flat ground, else (slope, heading, terrain)


def ground_value(ground, kind: str) -> float:
    """The drawn `kind` ("slope" or "heading") of a sample's ground: a 2-DOF sample's slope,
    or a 3-DOF sample's (slope, heading, terrain)."""
    if not isinstance(ground, tuple):
        return ground
    value = ground[0 if kind == "slope" else 1]
    return float("nan") if value is None else value


def ground_model(robot, ground, family):
    """The model a sample of `family` runs on: its robot on its drawn ground."""
    if not family.planar:
        return _core.SlopeModel(robot, ground)
    return _core.PlanarModel(robot, terrain=None if ground is None else ground[2])


def ground_controller(controller, ground):
    """A sweep's controller for a sample's drawn ground: a grade feed-forward feeds the
    sample's own terrain forward; any other controller as it is."""
    if ground is None or not isinstance(controller, _core.GradeFeedForward):
        return controller
    return _core.GradeFeedForward(controller.tracker, ground[2], controller.params)


@dataclass(frozen=True)
class Family:
    """What differs between 2-DOF (SlopeModel) and 3-DOF tracking (PlanarModel) sweeps."""

    planar: bool  # flat ground (no slope to perturb)
    states: Tuple[str, ...]
    draw: Callable  # (model, x0, perturbations, seed, i) -> (params dict, slope or None, x0)
    raw: Callable  # the core's sweep of samples start..start + count


SLOPE = Family(False, STATE_NAMES, _core.sweep_draw, _core.sweep_raw)
PLANAR = Family(True, PLANAR_STATE_NAMES, _planar_draw, _core.sweep_planar_raw)


def family_of(sc) -> Family:
    return PLANAR if isinstance(sc.model, _core.PlanarModel) else SLOPE


def kernel_for(sc, realism=None) -> str:
    """The core's kernel for a sweep of Scenario `sc`: "python" (a user's controller),
    "lanes" (vectorised: LQR, and fuzzy with any sets), "realism-lanes" (the same through
    any rig), "planar-lanes" (vectorised: PID and sliding-mode tracking),
    "planar-realism-lanes" (the same through any rig), "planar" (a sliding-mode tracker
    without adaptation whose own model has friction) or "planar-realism" (that tracker
    through a rig). Sweeps on terrain take the same kernels as on flat ground, with the
    grade's feed-forward or without."""
    if user_sweep.is_user_controller(sc.controller):
        return "python"
    return _core.sweep_kernel(sc.controller, realism)


def target(name: str, sc):
    """(kind, index) of a perturbation name: ("param", field), ("slope", 0), ("heading", 0) or
    ("x0", entry). A 3-DOF scenario's slope and heading are its terrain plane's."""
    checks.of_type("name", name, str, "a perturbation name (str: a RobotParams field, 'slope', 'heading' or a state name)")
    fields = list(_core.RobotParams.fields)
    family = family_of(sc)
    states = family.states
    if name in fields:
        return ("param", fields.index(name))
    if name in ("slope", "heading"):
        if family.planar:
            _plane_value(name, sc)
        elif name == "heading":
            raise _bad(f"perturbation 'heading': '{sc.name}' is a 2-DOF scenario (SlopeModel), it has no heading; "
                       "the heading axis is a 3-DOF scenario's terrain plane's uphill heading")
        return (name, 0)
    if name in states:
        return ("x0", states.index(name))
    # Spelled as the error below lists them: str.isdigit would take "x0[¹]" (and int() not).
    if name.startswith("x0[") and name.endswith("]") and name[3:-1] in [str(i) for i in range(len(states))]:
        return ("x0", int(name[3:-1]))
    slope = "'slope', 'heading' (on a terrain plane), " if family.planar else "'slope', "
    raise _bad(
        f"unknown perturbation '{name}'; perturb RobotParams fields ({', '.join(fields)}), "
        f"{slope}or initial-state entries ({', '.join(states)} or x0[0]..x0[{len(states) - 1}])"
    )


def _plane_value(name: str, sc) -> float:
    """A 3-DOF scenario's terrain plane's nominal slope or uphill heading, or an error
    naming `name` when its ground has no plane to redraw."""
    terrain = sc.model.terrain
    value = None if terrain is None else terrain.slope if name == "slope" else terrain.uphill_heading
    if value is None:
        ground = "flat ground (PlanarModel without terrain)" if terrain is None else f"{terrain!r}, which has no plane"
        raise _bad(f"perturbation '{name}': '{sc.name}' is a 3-DOF tracking scenario on {ground}; the slope and "
                   "heading axes redraw a terrain plane (terrain=twip.Terrain.plane(slope, uphill_heading) or "
                   "Terrain.ramp)")
    return value


def resolve(perturb: Mapping, scenario) -> list:
    """Perturbations as tuples for the core, in key order (the draw order)."""
    out = []
    perturb = checks.of_type("perturb", perturb or {}, Mapping, "a dict {name: twip.Uniform or twip.Normal}")
    checks.real_entries("x0", scenario.x0)  # before float() reads it (here, and a sweep's fingerprint)
    named = {}  # (kind, index) -> the first name given for it
    for name, dist in perturb.items():
        checks.of_type("perturb's keys", name, str, "parameter names (str)")
        kind, index = target(name, scenario)
        # Two names of one quantity (phi0 and x0[0]): the later draw would overwrite the
        # earlier while both are stored as drawn.
        if named.setdefault((kind, index), name) != name:
            raise _bad(f"perturb: {named[kind, index]!r} and {name!r} are the same quantity; give it once")
        if kind == "param":
            nominal = getattr(scenario.model.params, name)
        elif kind in ("slope", "heading"):
            nominal = _plane_value(kind, scenario) if family_of(scenario).planar else scenario.model.slope
        else:
            nominal = float(scenario.x0[index])
        if not isinstance(dist, (Uniform, Normal)):
            raise _bad(f"{name}: expected twip.Uniform or twip.Normal, got {dist!r}")
        if kind == "param" and isinstance(dist, Uniform) and dist.abs is not None and dist.abs > 0.5 * abs(nominal):
            warnings.warn(f"{name}: ± {dist.abs:g} is more than half the nominal {nominal:g} (absolute, in SI units); "
                          f"for a relative spread use rel= (or ±{dist.abs:g}% on the command line)", stacklevel=3)
        out.append((kind, index) + dist.resolve(name, nominal))
    return out
