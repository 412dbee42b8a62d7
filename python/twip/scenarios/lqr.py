"""LQR scenarios: the thesis's slope and flat simulations and experiments (4.1.1, 4.2.1)."""
from __future__ import annotations

import math

import numpy as np

from twip import _core, checks
from twip.scenarios.registry import Scenario, register, trip_time


#: The thesis's LQR weights (diag Q, R): (4.25) on the slope; on the flat, the weights the
#: flat experiment's published gains come from (4.2.1).
THESIS_WEIGHTS = ([10.0, 10.0, 1.0, 1.0], 1000.0)  # (4.25)
THESIS_FLAT_WEIGHTS = ([100.0, 1.0, 1.0, 1.0], 480.0)


def thesis_weights(slope: float):
    """(Q, R) of the thesis's LQR for a run on `slope` [rad] (flat: 0)."""
    return THESIS_WEIGHTS if slope else THESIS_FLAT_WEIGHTS


def go_and_back(distance, speed, radius, hold, settle):
    """(reference, t_final, goals) of a trip `distance` [m] out at wheel speed `speed`
    [rad/s] on wheels of `radius` [m], `hold` s there, back, and `settle` s at home."""
    settle = checks.real("settle", settle, at_least=0)  # the core would name it hold (its second leg's)
    leg = trip_time(distance, speed, radius)
    reference = _core.SpeedSchedule([(distance / radius, speed, hold), (0.0, speed, settle)])
    goals = [(leg + hold, distance), (2 * leg + hold + settle, 0.0)]
    return reference, 2 * leg + hold + settle, goals


def _lqr(ctrl_params, slope, speed, point, period):
    design_model = _core.SlopeModel(ctrl_params, slope)
    q, r = thesis_weights(slope)
    return _core.LqrController.design(design_model, speed, q, r, point=point, period=period)


@register("slope-lqr-sim")
def _slope_lqr_sim(params, ctrl_params, point="operating", period=1e-3, t_final=15.0):
    """Thesis Fig 4.2: 250 deg/s from rest at phi = 0 on a 15 deg slope."""
    slope, speed = math.radians(15), math.radians(250)
    return Scenario(
        name="slope-lqr-sim",
        description="LQR on a 15 deg slope, constant 250 deg/s from rest (thesis 4.1.1, Fig 4.2)",
        model=_core.SlopeModel(params, slope),
        controller=_lqr(ctrl_params, slope, speed, point, period),
        x0=np.zeros(4),
        reference=_core.SpeedSchedule.constant(speed),
        t_final=checks.real("t_final", t_final, above=0),  # named here, not by the core at run time
        thesis={"figure": "4.2", "pitch_settling_time": 5.0, "pitch_rate_settling_time": 2.0, "speed_settling_time": 7.0,
                "phi_s_deg": 12.5,
                "gains": [-15.2, -4.5, -0.35, -0.32]},
    )


@register("flat-lqr-sim")
def _flat_lqr_sim(params, ctrl_params, point="operating", period=1e-3, t_final=15.0):
    """Thesis Fig 4.9: 180 deg/s from rest on the flat."""
    speed = math.radians(180)
    return Scenario(
        name="flat-lqr-sim",
        description="LQR on the flat, constant 180 deg/s from rest (thesis 4.2.1, Fig 4.9)",
        model=_core.SlopeModel(params, 0.0),
        controller=_lqr(ctrl_params, 0.0, speed, point, period),
        x0=np.zeros(4),
        reference=_core.SpeedSchedule.constant(speed),
        t_final=checks.real("t_final", t_final, above=0),  # named here, not by the core at run time
        thesis={"figure": "4.9", "pitch_settling_time": 7.5, "pitch_rate_settling_time": 7.5, "speed_settling_time": 8.0,
                "phi_s_deg": 0.0,
                "gains": [-11.0, -1.7, -0.05, -0.045]},
    )


@register("slope-lqr")
def _slope_lqr(params, ctrl_params, point="operating", period=5e-3, hold=5.0, settle=5.0):
    """Thesis 4.1.1 experiment (Fig 4.3): 0.6 m up at 250 deg/s, hold 5 s, come back."""
    slope, speed, distance = math.radians(15), math.radians(250), 0.6
    plant = _core.SlopeModel(params, slope)
    x0, _ = plant.equilibrium(0.0)  # standing still, balanced on the slope
    reference, t_final, goals = go_and_back(distance, speed, params.wheel_radius, hold, settle)
    return Scenario(
        name="slope-lqr",
        description="LQR on a 15 deg slope: 0.6 m at 250 deg/s, hold 5 s, back (thesis 4.1.1, Fig 4.3)",
        model=plant,
        controller=_lqr(ctrl_params, slope, speed, point, period),
        x0=x0,
        reference=reference,
        t_final=t_final,
        thesis={"figure": "4.3", "distance": distance, "hold": hold, "goals": goals, "pitch_about_deg": 12.5},
    )


@register("flat-lqr")
def _flat_lqr(params, ctrl_params, point="operating", period=5e-3, hold=5.0, settle=5.0):
    """Thesis 4.2.1 experiment (Fig 4.10): 1 m at 180 deg/s, back to the start.

    The thesis reverses at once; we hold `hold` seconds at 1 m so that the stop can be
    measured (hold=0 gives the thesis's run)."""
    speed, distance = math.radians(180), 1.0
    reference, t_final, goals = go_and_back(distance, speed, params.wheel_radius, hold, settle)
    return Scenario(
        name="flat-lqr",
        description=(f"LQR on the flat: 1 m at 180 deg/s, hold {hold:g} s (twip's; the thesis turns at once), back "
                     "(thesis 4.2.1, Fig 4.10)"),
        model=_core.SlopeModel(params, 0.0),
        controller=_lqr(ctrl_params, 0.0, speed, point, period),
        x0=np.zeros(4),
        reference=reference,
        t_final=t_final,
        thesis={"figure": "4.10", "distance": distance, "hold": hold, "thesis_hold": 0.0, "goals": goals,
                "pitch_about_deg": 0.0},
    )
