"""Fuzzy adaptive backstepping + PD scenarios (thesis 4.1.2, 4.2.1) and the comparison with
LQR of Table 5.1, nominal and with the controller's model wrong."""
from __future__ import annotations

import math
from typing import Dict, Iterable, Optional

import numpy as np

from twip import _core, checks
from twip.scenarios.lqr import go_and_back, thesis_weights
from twip.scenarios.registry import Scenario, register

SPEED = math.radians(180)

# Plant parameters scaled against the controller's model (which stays nominal).
MISMATCH_CASES: Dict[str, Dict[str, float]] = {
    "nominal": {},
    "all +20 %": dict(m_body=1.2, com_height=1.2, i_body=1.2, mu_bearing=1.2, mu_ground=1.2),
    "all -20 %": dict(m_body=0.8, com_height=0.8, i_body=0.8, mu_bearing=0.8, mu_ground=0.8),
    "top-heavy": dict(m_body=1.2, com_height=1.2, i_body=0.8, mu_bearing=0.8, mu_ground=0.8),
    "bottom-heavy": dict(m_body=0.8, com_height=0.8, i_body=1.2, mu_bearing=1.2, mu_ground=1.2),
}

# The integral gain on the position error that stops within 1 cm (ours, not the thesis's).
KI_SLOPE = -0.004
KI_FLAT = -0.004


def _fuzzy(ctrl_params, slope, period, ki, adapt, gamma, sigma, sets):
    model = _core.SlopeModel(ctrl_params, slope)
    build = _core.FuzzyController.thesis_slope if slope else _core.FuzzyController.thesis_flat
    extra = {k: v for k, v in dict(gamma=gamma, sigma=sigma, sets=sets).items() if v is not None}
    return build(model, ki=ki, adapt=adapt, period=period, **extra)


@register("slope-fuzzy-sim")
def _slope_fuzzy_sim(params, ctrl_params, ki=0.0, adapt=True, gamma=None, sigma=None, sets=None, period=1e-3,
                     t_final=15.0):
    """Thesis Fig 4.7: 180 deg/s from rest at phi = 0 on a 15 deg slope."""
    slope = math.radians(15)
    return Scenario(
        name="slope-fuzzy-sim",
        description="Fuzzy adaptive backstepping + PD on a 15 deg slope, constant 180 deg/s from rest (thesis 4.1.2, Fig 4.7)",
        model=_core.SlopeModel(params, slope),
        controller=_fuzzy(ctrl_params, slope, period, ki, adapt, gamma, sigma, sets),
        x0=np.zeros(4),
        reference=_core.SpeedSchedule.constant(SPEED),
        t_final=checks.real("t_final", t_final, above=0),  # named here, not by the core at run time
        thesis={"figure": "4.7", "pitch_settling_time": 1.5, "speed_settling_time": 5.0, "phi_s_deg": 12.5,
                "gains": [10, 13, -0.01, -0.09]},
    )


@register("flat-fuzzy-sim")
def _flat_fuzzy_sim(params, ctrl_params, ki=0.0, adapt=True, gamma=None, sigma=None, sets=None, period=1e-3,
                    t_final=15.0):
    """Thesis Fig 4.11: 180 deg/s from rest on the flat."""
    return Scenario(
        name="flat-fuzzy-sim",
        description="Fuzzy adaptive backstepping + PD on the flat, constant 180 deg/s from rest (thesis 4.2.1, Fig 4.11)",
        model=_core.SlopeModel(params, 0.0),
        controller=_fuzzy(ctrl_params, 0.0, period, ki, adapt, gamma, sigma, sets),
        x0=np.zeros(4),
        reference=_core.SpeedSchedule.constant(SPEED),
        t_final=checks.real("t_final", t_final, above=0),  # named here, not by the core at run time
        thesis={"figure": "4.11", "phi_s_deg": 0.0, "gains": [30, 33, -0.1, -0.9]},
    )


@register("slope-fuzzy")
def _slope_fuzzy(params, ctrl_params, ki=0.0, adapt=True, gamma=None, sigma=None, sets=None, period=5e-3,
                 hold=5.0, settle=5.0):
    """Thesis 4.1.2 experiment (Fig 4.8): upright (phi = 0) at rest on 15 deg, 0.75 m up at
    180 deg/s, hold, back, hold. The desired pitch is phi_s of the controller's model."""
    slope, distance = math.radians(15), 0.75
    reference, t_final, goals = go_and_back(distance, SPEED, params.wheel_radius, hold, settle)
    return Scenario(
        name="slope-fuzzy",
        description="Fuzzy adaptive backstepping + PD on a 15 deg slope: 0.75 m at 180 deg/s, hold, back (thesis 4.1.2, Fig 4.8)",
        model=_core.SlopeModel(params, slope),
        controller=_fuzzy(ctrl_params, slope, period, ki, adapt, gamma, sigma, sets),
        x0=np.zeros(4),
        reference=reference,
        t_final=t_final,
        thesis={"figure": "4.8", "distance": distance, "hold": hold, "goals": goals, "pitch_band_deg": 5.0},
    )


@register("flat-fuzzy")
def _flat_fuzzy(params, ctrl_params, ki=0.0, adapt=True, gamma=None, sigma=None, sets=None, period=5e-3,
                hold=5.0, settle=5.0):
    """Thesis 4.2.2 experiment (Fig 4.12): 1 m at 180 deg/s, hold, back, hold."""
    distance = 1.0
    reference, t_final, goals = go_and_back(distance, SPEED, params.wheel_radius, hold, settle)
    return Scenario(
        name="flat-fuzzy",
        description="Fuzzy adaptive backstepping + PD on the flat: 1 m at 180 deg/s, hold, back (thesis 4.2.2, Fig 4.12)",
        model=_core.SlopeModel(params, 0.0),
        controller=_fuzzy(ctrl_params, 0.0, period, ki, adapt, gamma, sigma, sets),
        x0=np.zeros(4),
        reference=reference,
        t_final=t_final,
        thesis={"figure": "4.12", "distance": distance, "hold": hold, "goals": goals, "pitch_band_deg": 5.0},
    )


def shoulders(inner: float, outer: float) -> list:
    """N, Z, P over one input: two shoulders and a trapezoid (a triangle when inner = 0)."""
    inf = math.inf
    return [_core.Trapezoid(-inf, -inf, -outer, -inner), _core.Trapezoid(-outer, -inner, inner, outer),
            _core.Trapezoid(inner, outer, inf, inf)]


#: Plausible fuzzy sets for Figs 4.4/4.5, which the thesis draws without numbers:
#: (φ core, φ foot, φ̇ core, φ̇ foot) [rad, rad/s] of `shoulders` (docs/scenarios.md).
SET_CHOICES = {
    "0.1/0.3, 0.5/2 (default)": (0.1, 0.3, 0.5, 2.0),
    "triangles 0/0.3, 0/2": (0.0, 0.3, 0.0, 2.0),
    "narrow 0.05/0.15, 0.25/1": (0.05, 0.15, 0.25, 1.0),
    "wide 0.2/0.6, 1/4": (0.2, 0.6, 1.0, 4.0),
    "triangles 0/0.5, 0/5": (0.0, 0.5, 0.0, 5.0),
}


def sets_of(choice: str) -> list:
    """The sets of SET_CHOICES[choice], as `scenarios.get(..., sets=)` takes them."""
    phi_in, phi_out, rate_in, rate_out = SET_CHOICES[choice]
    return [shoulders(phi_in, phi_out), shoulders(rate_in, rate_out)]


def stop_positions(scenario: Scenario, result) -> np.ndarray:
    """Where the robot is [m] at the end of each hold."""
    radius = scenario.model.params.wheel_radius
    at = [min(np.searchsorted(result.t, t_goal - 1e-9), len(result.t) - 1) for t_goal, _ in scenario.thesis["goals"]]
    return result.states[at, 2] * radius


def stop_errors(scenario: Scenario, result) -> np.ndarray:
    """How far short of each goal the robot stops [m], along the leg that leads there: positive
    short of it, negative past it, on the way out and on the way back alike."""
    out, previous = [], 0.0  # every run starts at 0
    for (_, goal), position in zip(scenario.thesis["goals"], stop_positions(scenario, result)):
        direction = 1.0 if goal >= previous else -1.0
        out.append(direction * (goal - position))
        previous = goal
    return np.array(out)


def mismatched(params, case: str):
    """`params` with the plant-side changes of MISMATCH_CASES[case]."""
    base = params.to_dict()
    return params.replace(**{k: base[k] * f for k, f in MISMATCH_CASES[case].items()})


def _lqr_like(scenario: Scenario, ctrl_params, period):
    """The thesis's LQR (Q, R of 4.25 on the slope, 4.2.1 on the flat) for the same run."""
    slope = scenario.model.slope
    q, r = thesis_weights(slope)
    return _core.LqrController.design(_core.SlopeModel(ctrl_params, slope), SPEED, q, r, period=period)


CONTROLLERS = ("lqr", "fuzzy", "fuzzy-fixed", "fuzzy+ki")


def compare_table(params=None, cases: Optional[Iterable[str]] = None,
                  controllers: Iterable[str] = ("lqr", "fuzzy", "fuzzy-fixed"), period: float = 5e-3,
                  realism=None, hold: float = 5.0, settle: float = 5.0, friction=None, sets=None) -> list:
    """Table 5.1 analogue: mean |pitch error| and |wheel-speed error| of each controller on the
    slope-fuzzy and flat-fuzzy runs (same schedule, start and plant for every controller).

    The controller's model is always `params` (default balanbot); the plant is changed per
    case of MISMATCH_CASES. Controllers: "lqr" (thesis weights, operating-point design),
    "fuzzy" (thesis gains, adaptation on), "fuzzy-fixed" (adaptation off: S stays 0),
    "fuzzy+ki" (with KI_SLOPE / KI_FLAT). Errors are against the plant's own steady pitch.
    With `realism` (a twip.Realism) each nominal row also carries the same run with that
    robot in the loop: `outcome_realism`, `pitch_error_deg_realism`, `speed_error_deg_s_realism`.
    `hold` and `settle` [s] are the go-and-back run's waits at the far goal and at home (the
    thesis does not give them; twip's 5 s each). `friction` (a twip.Friction) puts gearhead
    friction on the plant (the controllers' models keep none). `sets` (a twip.FuzzyBasis, e.g. an
    n x n FuzzyBasis.grid) replaces the fuzzy controllers' 3 x 3 sets. Returns one dict per
    (surface, case, controller)."""
    from twip.scenarios.registry import get

    params = params if params is not None else _core.RobotParams.balanbot()
    rows = []
    for surface, name, ki in (("flat", "flat-fuzzy", KI_FLAT), ("slope", "slope-fuzzy", KI_SLOPE)):
        for case in cases if cases is not None else MISMATCH_CASES:
            plant = mismatched(params, case)
            for which in controllers:
                if which not in CONTROLLERS:
                    raise _core.InvalidParameterError(f"unknown controller '{which}'; known: {', '.join(CONTROLLERS)}")
                options = {"fuzzy-fixed": dict(adapt=False), "fuzzy+ki": dict(ki=ki)}.get(which, {})
                if sets is not None and which != "lqr":
                    options = {**options, "sets": sets}
                sc = get(name, params=plant, controller_params=params, period=period, hold=hold, settle=settle,
                         **options)
                if which == "lqr":
                    sc = sc.replace(controller=_lqr_like(sc, params, period))
                if friction is not None:
                    sc = sc.replace(model=_core.SlopeModel(plant, sc.model.slope, friction))
                r = sc.run()
                m = r.metrics
                stops = stop_errors(sc, r)
                rows.append({
                    "surface": surface,
                    "case": case,
                    "controller": which,
                    "outcome": r.outcome,
                    "pitch_error_deg": math.degrees(m["mean_abs_pitch_error"]),
                    "speed_error_deg_s": math.degrees(m["mean_abs_speed_error"]),
                    "stop_far_cm": 100 * stops[0],
                    "stop_home_cm": 100 * stops[1],
                })
                if realism is not None and case == "nominal":
                    real = sc.run(realism=realism)
                    rows[-1].update({
                        "outcome_realism": real.outcome,
                        "pitch_error_deg_realism": math.degrees(real.metrics["mean_abs_pitch_error"]),
                        "speed_error_deg_s_realism": math.degrees(real.metrics["mean_abs_speed_error"]),
                    })
    return rows


def format_table(rows: list) -> str:
    """Markdown: one line per (surface, case), pitch / speed error per controller."""
    controllers = list(dict.fromkeys(r["controller"] for r in rows))
    head = "| surface | plant | " + " | ".join(f"{c}: pitch [deg], speed [deg/s]" for c in controllers) + " |"
    lines = [head, "|" + "---|" * (2 + len(controllers))]
    keys = list(dict.fromkeys((r["surface"], r["case"]) for r in rows))
    for surface, case in keys:
        cells = []
        for c in controllers:
            r = next(r for r in rows if (r["surface"], r["case"], r["controller"]) == (surface, case, c))
            fell = "" if r["outcome"] == "completed" else f" ({r['outcome']})"
            cells.append(f"{r['pitch_error_deg']:.3f}, {r['speed_error_deg_s']:.1f}{fell}")
        lines.append(f"| {surface} | {case} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
