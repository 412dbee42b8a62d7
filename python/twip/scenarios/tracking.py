"""Trajectory tracking scenarios on the 3-DOF model (thesis 4.3) and the Table 5.2 comparison.

Every run starts upright and at rest at the origin, heading along +x, on the circle's start
point; the trackers update every 5 ms (an Arduino loop), RK4 at 1 ms.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from twip import _core, checks
from twip.scenarios.registry import Scenario, get, register

#: Table 5.2: mean |x - x_r|, |y - y_r| [m].
THESIS_TABLE_5_2 = {"pid": (0.072, 0.076), "smc": (0.027, 0.030)}
#: Where each row of Table 5.2 comes from: the thesis does not say. Its only PID run is the
#: experiment of 4.3.1; its sliding-mode tracker has a simulation (Figs 4.16/4.18) and an
#: experiment (Figs 4.19/4.20), and 5.1 does not say which the row measures.
TABLE_5_2_SOURCE = {"pid": "thesis: experiment, its only PID run",
                    "smc": "thesis: simulation or experiment, not stated"}

#: The fields a model mismatch scales (the wheel, gearing and gravity are known exactly).
MISMATCH_FIELDS = ("m_body", "m_wheels", "i_body", "i_wheels", "i_motor", "com_height", "mu_bearing", "mu_ground",
                   "half_track", "i_body_roll", "i_body_yaw", "i_wheel_diam")


def _circle(radius, speed, laps):
    laps = checks.real("laps", laps, above=0)  # else its error would name t_final, laps * a lap
    circle = _core.Circle(radius, speed)
    return circle, laps * circle.period


def _on(terrain, tracker, ctrl_params, grade_feed_forward):
    """`tracker`, with the grade's feed-forward of `terrain` when there is one and it is asked."""
    if terrain is None or not grade_feed_forward:
        return tracker
    return _core.GradeFeedForward(tracker, terrain, ctrl_params)


@register("circle-pid")
def _circle_pid(params, ctrl_params, laps=3, period=0.005, supply=None, motor=None, terrain=None,
                grade_feed_forward=True):
    """Fig 4.14: the circle of radius 0.6 m at a wheel speed of 180 deg/s (36 s a lap), Table 4.1.
    `motor` (a twip.DcMotor) turns the PID's PWM counts into torques; default the GB37Y3530 at
    `supply` [V] (default 11.1). `terrain` (a twip.Terrain) puts the plant on it; the tracker
    keeps its flat-ground gains, with the grade's feed-forward (twip.GradeFeedForward) unless
    `grade_feed_forward=False` (docs/terrain.md)."""
    speed = math.radians(180.0) * params.wheel_radius
    circle, t_final = _circle(0.6, speed, laps)
    if motor is not None and supply is not None:
        raise _core.InvalidParameterError(f"supply = {supply!r}: give the motor's supply in motor, not both")
    motor = motor if motor is not None else _core.DcMotor.gb37y3530(11.1 if supply is None else supply)
    return Scenario(
        name="circle-pid",
        description="PID tracker, Table 4.1's gains in the Arduino's units, r = 0.6 m at 180 deg/s (thesis 4.3.1, Fig 4.14)",
        model=_core.PlanarModel(params, terrain=terrain),
        controller=_on(terrain, _core.PidTracker.table_4_1(ctrl_params, motor=motor, period=period), ctrl_params,
                       grade_feed_forward),
        x0=np.zeros(7),
        reference=circle,
        t_final=t_final,
        thesis={"figure": "4.14", "lap_s": 36.0, "pitch_within_deg": 5.0, "table_5_2": THESIS_TABLE_5_2["pid"]},
    )


def _smc(params, ctrl_params, fuzzy, laps, period, boundary_layer, pitch_offset, motor, terrain, grade_feed_forward,
         **options):
    circle, t_final = _circle(0.45, math.pi / 30, laps)
    if motor is not None:  # else SmcTracker's default, the GB37Y3530 at 11.1 V
        options["motor"] = motor
    name = "circle-smc-fuzzy" if fuzzy else "circle-smc"
    what = "fuzzy adaptive sliding mode" if fuzzy else "sliding-mode backstepping"
    tracker = _core.SmcTracker(_core.PlanarModel(ctrl_params), fuzzy=fuzzy, boundary_layer=boundary_layer,
                               pitch_offset=pitch_offset, period=period, **options)
    return Scenario(
        name=name,
        description=(f"{what} tracker: the published switching and yaw gains with twip's k1-k3, k_phi"
                     f"{', Gamma' if fuzzy else ''} and lambda1 aimed at phi_s (errata T4, T8), r = 0.45 m at pi/30 m/s, "
                     "pi/13.5 rad/s (thesis 4.3.2, Fig 4.16)"),
        model=_core.PlanarModel(params, terrain=terrain),
        controller=_on(terrain, tracker, ctrl_params, grade_feed_forward),
        x0=np.zeros(7),
        reference=circle,
        t_final=t_final,
        thesis={"figure": "4.16", "omega_r": math.pi / 13.5, "table_5_2": THESIS_TABLE_5_2["smc"],
                # the experiment of Figs 4.19/4.20, with the fuzzy tracker: "the inclined angle is maintained
                # around 0, and the speed is controlled to be about 0.1 m/s"
                **({"pitch_about_deg": 0.0, "speed_about": 0.1} if fuzzy else {})},
    )


@register("circle-smc")
def _circle_smc(params, ctrl_params, laps=3, period=0.005, boundary_layer=None, pitch_offset=True, motor=None,
                terrain=None, grade_feed_forward=True, **options):
    """4.3.2 with the controller's own model for f2 (4.89, 4.97). `motor` (a twip.DcMotor)
    limits the torques and reads the published gains in its PWM counts. `terrain` (a
    twip.Terrain) puts the plant on it; the tracker keeps its flat-ground model, with the
    grade's feed-forward unless `grade_feed_forward=False`."""
    return _smc(params, ctrl_params, False, laps, period, boundary_layer, pitch_offset, motor, terrain,
                grade_feed_forward, **options)


#: The fuzzy-sets study's 5 x 5 Gaussian grids (docs/fuzzy_sets.md): centres phi (rad) and
#: omega, phi_dot (rad/s), sigma half the spacing.
_PHI5 = [-0.3, -0.15, 0.0, 0.15, 0.3]
SMC_GRIDS = {
    "gaussian-5x5": lambda: (_core.FuzzyBasis.grid("gaussian", [_PHI5, [-1.0, -0.5, 0.0, 0.5, 1.0]], [0.075, 0.25]),
                             _core.FuzzyBasis.grid("gaussian", [_PHI5, [-2.0, -1.0, 0.0, 1.0, 2.0]], [0.075, 0.5])),
}


def _smc_grids(sets) -> dict:
    """The SmcTracker options of `sets`: None (the thesis's 3 x 3 trapezoids), a name of
    SMC_GRIDS (what the command line can give) or a pair (yaw_sets, pitch_sets)."""
    if sets is None:
        return {}
    if isinstance(sets, str):
        if sets not in SMC_GRIDS:
            raise _core.InvalidParameterError(f"sets = {sets!r}: not a grid name; the names are {sorted(SMC_GRIDS)} "
                                              "(or give a pair (yaw_sets, pitch_sets) of twip.FuzzyBasis grids)")
        sets = SMC_GRIDS[sets]()
    try:
        yaw, pitch = sets
    except (TypeError, ValueError):
        raise _core.InvalidParameterError(f"sets = {sets!r}: expected a grid name {sorted(SMC_GRIDS)} or a pair "
                                          "(yaw_sets, pitch_sets)") from None
    return {"yaw_sets": yaw, "pitch_sets": pitch}


@register("circle-smc-fuzzy")
def _circle_smc_fuzzy(params, ctrl_params, laps=3, period=0.005, boundary_layer=None, pitch_offset=True, motor=None,
                      terrain=None, grade_feed_forward=False, sets=None, **options):
    """4.3.2 with fuzzy estimates of f23 and of the (phi, v) equivalent control (4.99-4.121).
    `terrain` (a twip.Terrain) puts the plant on it; by default without the grade's
    feed-forward: the fuzzy estimate is left to absorb the grade (docs/terrain.md measures it).
    `sets`: the estimates' grids, a pair (yaw_sets, pitch_sets) or a name of SMC_GRIDS
    ("gaussian-5x5": the fuzzy-sets study's; `twip export circle-smc-fuzzy --option
    sets=gaussian-5x5`); default the thesis's 3 x 3 trapezoids."""
    grids = _smc_grids(sets)
    if grids and ({"yaw_sets", "pitch_sets"} & set(options)):
        raise _core.InvalidParameterError("sets: give the grids in sets or in yaw_sets/pitch_sets, not both")
    return _smc(params, ctrl_params, True, laps, period, boundary_layer, pitch_offset, motor, terrain,
                grade_feed_forward, **options, **grids)


def mismatched(params, factor: float):
    """`params` with every mass, inertia, length and friction of MISMATCH_FIELDS times `factor`."""
    return params.replace(**{k: getattr(params, k) * factor for k in MISMATCH_FIELDS})


def compare(params=None, mismatch: float = 0.2, laps: int = 3, dt: float = 1e-3, realism=None,
            pitch_offset: bool = True, smc_gains: Optional[dict] = None, friction=None, period: float = 0.005,
            trackers=("circle-pid", "circle-smc", "circle-smc-fuzzy")) -> list:
    """Table 5.2's analogue: mean |x - x_r|, |y - y_r| of each tracker on its circle, with the
    plant as the controllers assume it and with every MISMATCH_FIELDS entry of the plant
    +mismatch and -mismatch off (the controllers keep the nominal robot). One dict per run;
    the "_settled" errors leave out the first lap. With `realism` (a `twip.Realism`, e.g.
    `Realism.thesis_like()`) each case also runs on those parts: "realism_outcome",
    "x_realism" and "y_realism". `pitch_offset=False` gives the sliding-mode trackers the
    thesis's λ1 of (4.74) instead of twip's pitch offset (errata T8); `smc_gains` overrides
    some of their gains (SmcTracker's `gains`); `friction` (a twip.Friction) puts gearhead
    friction on the plants; `period` [s] is every tracker's loop period; `trackers`: which of the
    three to run."""
    nominal = params if params is not None else _core.RobotParams.balanbot()
    rows = []
    cases = [("nominal", 1.0), (f"+{mismatch:.0%}", 1.0 + mismatch), (f"-{mismatch:.0%}", 1.0 - mismatch)]
    for label, factor in cases:
        plant = mismatched(nominal, factor)
        for name in trackers:
            options = {} if name == "circle-pid" else {"pitch_offset": pitch_offset, "gains": smc_gains}
            sc = get(name, params=plant, controller_params=nominal, laps=laps, period=period, **options)
            if friction is not None:
                sc = sc.replace(model=_core.PlanarModel(plant, friction, terrain=sc.model.terrain))
            r = sc.run(dt=dt, record_every=1000)
            m = r.metrics
            rows.append({
                "controller": name, "plant": label, "outcome": r.outcome,
                "x": m["mean_abs_x_error"], "y": m["mean_abs_y_error"],
                "x_settled": m["mean_abs_x_error_settled"], "y_settled": m["mean_abs_y_error_settled"],
                "path_settled": m["max_path_error_settled"], "pitch_deg": math.degrees(m["mean_abs_pitch"]),
                "peak_torque": m["peak_abs_torque"],
            })
            if realism is not None:
                real = sc.run(dt=dt, record_every=1000, realism=realism)
                rows[-1].update({"realism_outcome": real.outcome, "x_realism": real.metrics["mean_abs_x_error"],
                                 "y_realism": real.metrics["mean_abs_y_error"]})
    return rows


def thesis_cm(controller: str) -> str:
    """THESIS_TABLE_5_2's "x / y" [cm] for a tracker scenario (both sliding-mode ones: "smc")."""
    x, y = THESIS_TABLE_5_2["pid" if controller == "circle-pid" else "smc"]
    return f"{100 * x:.1f} / {100 * y:.1f}"


def format_table(rows) -> str:
    """A markdown table of `compare`'s rows, in cm, with the thesis's Table 5.2 beside."""
    out = ["| tracker | plant | mean abs x / y [cm] | after lap 1 [cm] | max path error after lap 1 [cm] | thesis [cm] |",
           "|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| `{r['controller']}` | {r['plant']} | {100 * r['x']:.2f} / {100 * r['y']:.2f} | "
                   f"{100 * r['x_settled']:.2f} / {100 * r['y_settled']:.2f} | {100 * r['path_settled']:.2f} | "
                   f"{thesis_cm(r['controller'])} |")
    return "\n".join(out)
