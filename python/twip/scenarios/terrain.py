"""Tracking on terrain (the thesis's future work, 5.2; docs/terrain.md): the 3-DOF trackers
of 4.3 with their flat-ground gains on an incline and over bumps. These are predictions of
twip, not thesis claims: the thesis has no run on terrain."""
from __future__ import annotations

import math

import numpy as np

from twip import _core, checks
from twip.scenarios.registry import get, register

#: The trackers, as the suffix of their circle scenario (circle-pid, circle-smc, circle-smc-fuzzy).
TRACKERS = ("pid", "smc", "smc-fuzzy")


def _tracker_on(tracker, params, ctrl_params, terrain, grade_feed_forward, **options):
    """circle-`tracker` on `terrain`; `grade_feed_forward` None keeps that scenario's default
    (on for the PID and the sliding-mode tracker, off for the fuzzy adaptive one). The
    caller drops its thesis claims: none is about terrain."""
    if tracker not in TRACKERS:
        raise _core.InvalidParameterError(f"invalid tracker = {tracker!r}: expected one of {', '.join(TRACKERS)}")
    if grade_feed_forward is not None:
        checks.of_type("grade_feed_forward", grade_feed_forward, (bool, np.bool_), "a bool or None")
        options["grade_feed_forward"] = bool(grade_feed_forward)
    return get(f"circle-{tracker}", params=params, controller_params=ctrl_params, terrain=terrain, **options)


@register("incline-circle")
def _incline_circle(params, ctrl_params, tracker="pid", slope_deg=5.0, uphill_heading=0.0, laps=3,
                    grade_feed_forward=None, **options):
    """circle-`tracker` (its circle, speed and gains) on a plane of `slope_deg` [deg] rising
    towards `uphill_heading` [rad from +x]; the run starts upright at rest at the origin."""
    terrain = _core.Terrain.plane(math.radians(slope_deg), uphill_heading)
    sc = _tracker_on(tracker, params, ctrl_params, terrain, grade_feed_forward, laps=laps, **options)
    return sc.replace(name="incline-circle", thesis={},
                      description=f"{sc.description}; on a {slope_deg:g} deg incline rising towards {uphill_heading:.3g} rad "
                                  "(twip's prediction, not a thesis claim)")


@register("figure-eight-bumps")
def _figure_eight_bumps(params, ctrl_params, tracker="smc", height=0.04, wavelength=1.0, half_width=0.6, period=40.0,
                        laps=2, grade_feed_forward=None, **options):
    """circle-`tracker`'s gains on a figure-eight (twip.FigureEight(`half_width`, `period`),
    starting at the origin heading 45 deg) over twip.Terrain.bumps(`height`, `wavelength`)."""
    laps = checks.real("laps", laps, above=0)  # t_final = laps * period
    terrain = _core.Terrain.bumps(height, wavelength)
    sc = _tracker_on(tracker, params, ctrl_params, terrain, grade_feed_forward, **options)
    x0 = np.zeros(7)
    x0[2] = math.pi / 4
    return sc.replace(name="figure-eight-bumps", thesis={}, reference=_core.FigureEight(half_width, period), t_final=laps * period,
                      x0=x0,
                      description=f"{sc.description.split(',')[0]} on a figure-eight (half-width {half_width:g} m, "
                                  f"{period:g} s a lap) over bumps {height:g} m high every {wavelength:g} m "
                                  "(twip's prediction, not a thesis claim)")
