"""Table 5.1's rows as the thesis measured them: each controller on its own experiment (LQR:
Figs 4.3 and 4.10, fuzzy: Figs 4.8 and 4.12), and the robots the sensitivity runs them on."""
from __future__ import annotations

import math
from typing import Optional

from twip import _core, scenarios

#: The experiment behind each Table 5.1 row: (surface, controller) -> scenario.
TABLE_5_1_RUNS = {("flat", "lqr"): "flat-lqr", ("flat", "fuzzy"): "flat-fuzzy",
                  ("slope", "lqr"): "slope-lqr", ("slope", "fuzzy"): "slope-fuzzy"}

#: What the thesis says of an experiment's run that twip's scenario does otherwise: flat-lqr
#: reverses at 1 m at once ("the reference speed was reversed", 4.2.1; twip holds 5 s there
#: to measure the stop).
PUBLISHED_OPTIONS = {("flat", "lqr"): {"hold": 0.0}}

#: The robot fitted with the GB37's no-load torque read as Coulomb friction (printed by
#: `python scripts/fit_balanbot.py --coulomb`, docs/parameters.md "The refit"): the robot that
#: goes with `Friction.gb37()`. `balanbot()`'s fitted mu_bearing already holds that torque.
COULOMB_REFIT = {
    "m_body": 0.8381, "m_wheels": 0.08014, "i_body": 4.647e-3, "i_motor": 5.186e-6, "torque_constant": 9.877e-3,
    "com_height": 0.04644, "mu_bearing": 1.338e-3, "mu_ground": 1.281e-3,
}

#: The gearhead frictions a plant can have (the thesis models only viscous friction).
FRICTIONS = ("none (thesis)", "no-load torque split", "no-load torque as Coulomb, refit robot")


def robot(friction: str):
    """(robot, gearhead friction or None) for a FRICTIONS entry: `balanbot()` without or with
    the no-load torque split beside its fitted viscous bearing, or the refit robot with all
    of it as Coulomb friction (`Friction.gb37()`)."""
    base = _core.RobotParams.balanbot()
    if friction == FRICTIONS[0]:
        return base, None
    if friction == FRICTIONS[1]:
        return base, _core.Friction.gb37_beside(base.mu_bearing / 2)
    if friction == FRICTIONS[2]:
        return base.replace(**COULOMB_REFIT), _core.Friction.gb37()
    raise _core.InvalidParameterError(f"friction = {friction!r}: must be one of {', '.join(FRICTIONS)}")


def scenario_on(name: str, friction: str = FRICTIONS[0], **options):
    """Scenario `name` with `options` on the robot of `friction` (its controller designed for
    the same robot, whose model has no gearhead friction)."""
    params, f = robot(friction)
    sc = scenarios.get(name, params=params, controller_params=params, **options)
    if f is None:
        return sc
    if isinstance(sc.model, _core.PlanarModel):
        return sc.replace(model=_core.PlanarModel(params, f, terrain=sc.model.terrain))
    return sc.replace(model=_core.SlopeModel(params, sc.model.slope, f))


def table_5_1_row(surface: str, controller: str, realism=None, friction: str = FRICTIONS[0], **options) -> dict:
    """One Table 5.1 row from its own experiment: mean |pitch error| [deg] and mean |wheel-speed
    error| [deg/s] (against the plant's own steady pitch), and with `realism` the same run
    with that robot in the loop ("_realism" keys)."""
    sc = scenario_on(TABLE_5_1_RUNS[(surface, controller)], friction,
                     **{**PUBLISHED_OPTIONS.get((surface, controller), {}), **options})
    r = sc.run()
    row = {"surface": surface, "controller": controller, "scenario": sc.name, "outcome": r.outcome,
           "pitch_error_deg": math.degrees(r.metrics["mean_abs_pitch_error"]),
           "speed_error_deg_s": math.degrees(r.metrics["mean_abs_speed_error"])}
    if realism is not None:
        real = sc.run(realism=realism)
        row.update({"outcome_realism": real.outcome,
                    "pitch_error_deg_realism": math.degrees(real.metrics["mean_abs_pitch_error"]),
                    "speed_error_deg_s_realism": math.degrees(real.metrics["mean_abs_speed_error"])})
    return row


def table_5_1_rows(realism: Optional[object] = None) -> list:
    """Every Table 5.1 row from its own experiment, with twip's defaults."""
    return [table_5_1_row(surface, controller, realism) for surface, controller in TABLE_5_1_RUNS]
