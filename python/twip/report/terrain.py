"""`twip reproduce`'s future-work rows: the trackers on terrain (docs/terrain.md). Every row
is a prediction of twip, not a thesis claim (the thesis has no run on terrain)."""
from __future__ import annotations

import math
from typing import List

from twip import scenarios
from twip.report.numbers import dec
from twip.scenarios.terrain import TRACKERS

#: The scenarios of twip.scenarios.terrain: run here, not among the thesis's.
TERRAIN_SCENARIOS = ("incline-circle", "figure-eight-bumps")
BASIS = "prediction of twip (thesis 5.2's future work; not a thesis claim)"
#: The inclines [deg] and the uphill headings [rad from +x] the circles run at (each circle
#: starts heading +x, so every heading also meets the grade at every angle along the lap).
SLOPES_DEG = (5.0, 10.0)
HEADINGS = (0.0, math.pi / 2, math.pi, 3 * math.pi / 2)
#: Whether a tracker holds the path: its settled path error under this [m].
HOLDS_BELOW = 0.05
#: The uphill heading [rad] whose circles (and the figure-eight) also run through the
#: thesis-like rig (`twip.Realism.thesis_like()`); the other headings on the ideal plant only.
RIG_HEADING = 0.0


def _holds(r) -> bool:
    return r.outcome == "completed" and r.metrics["max_path_error_settled"] < HOLDS_BELOW


def _row(name: str, tracker: str, where: str, feed_forward: bool, r, rig=None) -> dict:
    """A row from the ideal plant's run `r` and the thesis-like rig's `rig` (None: not run)."""
    m = r.metrics
    path = m["max_path_error_settled"]
    row = {"id": f"future-work/{name}/{tracker}/{where}{'' if feed_forward else '/no-feed-forward'}",
           "basis": BASIS, "scenario": name, "tracker": tracker, "terrain": where, "grade_feed_forward": feed_forward,
           "outcome": r.outcome, "path_settled_cm": dec(100 * path, 2),
           "x_cm": dec(100 * m["mean_abs_x_error"], 2), "y_cm": dec(100 * m["mean_abs_y_error"], 2),
           "holds": _holds(r), "rig_outcome": None, "rig_path_settled_cm": None, "rig_holds": None}
    if rig is not None:
        row.update(rig_outcome=rig.outcome, rig_path_settled_cm=dec(100 * rig.metrics["max_path_error_settled"], 2),
                   rig_holds=_holds(rig))
    return row


def cases(quick: bool = False) -> List[tuple]:
    """(scenario, tracker, label, options) for every future-work row: each tracker with its
    default feed-forward, and the fuzzy adaptive one also with it (does it absorb the grade?)."""
    out = []
    slopes = SLOPES_DEG[-1:] if quick else SLOPES_DEG
    headings = HEADINGS[:2] if quick else HEADINGS
    for tracker in TRACKERS:
        for ff in ((None, True) if tracker == "smc-fuzzy" else (None,)):
            for slope in slopes:
                for heading in headings:
                    opts = {"tracker": tracker, "slope_deg": slope, "uphill_heading": heading}
                    if ff is not None:
                        opts["grade_feed_forward"] = ff
                    out.append(("incline-circle", tracker, f"{slope:g}deg-uphill-{math.degrees(heading):g}deg", opts))
            opts = {"tracker": tracker, **({} if ff is None else {"grade_feed_forward": ff})}
            out.append(("figure-eight-bumps", tracker, "bumps", opts))
    return out


def terrain_rows(quick: bool = False) -> List[dict]:
    """The trackers on the inclines and over the bumps, on the ideal plant, and with the
    thesis-like rig at the uphill heading `RIG_HEADING` and over the bumps."""
    from twip import Realism

    rows = []
    for name, tracker, where, opts in cases(quick):
        sc = scenarios.get(name, **opts, **({"laps": 2} if quick else {}))
        feed_forward = type(sc.controller).__name__ == "GradeFeedForward"
        on_rig = opts.get("uphill_heading", RIG_HEADING) == RIG_HEADING
        rig = sc.run(record_every=1000, realism=Realism.thesis_like()) if on_rig else None
        rows.append(_row(name, tracker, where, feed_forward, sc.run(record_every=1000), rig))
    return rows


def markdown(rows: List[dict]) -> List[str]:
    """report.md's future-work section, from report.json's "future_work" rows."""
    from twip.report.markdown import md_table
    from twip.report.numbers import fix

    def rig(r):
        if r.get("rig_outcome") is None:
            return ["", "", ""]
        return [r["rig_outcome"], fix(r["rig_path_settled_cm"], 2), "yes" if r["rig_holds"] else "no"]

    table = [[f"`{r['scenario']}`", r["tracker"], r["terrain"], "yes" if r["grade_feed_forward"] else "no", r["outcome"],
              fix(r["path_settled_cm"], 2), f"{fix(r['x_cm'], 2)} / {fix(r['y_cm'], 2)}", "yes" if r["holds"] else "no",
              *rig(r)]
             for r in rows]
    return ["", "## Future work: tracking on terrain (predictions of twip, not thesis claims)", "",
            "The thesis's trackers with their flat-ground gains on inclines (uphill towards the heading given, from +x) "
            "and on a figure-eight over bumps (`twip.scenarios.terrain`, docs/terrain.md), on the ideal plant and, "
            f"at the uphill heading {math.degrees(RIG_HEADING):g} deg and over the bumps, through the thesis-like rig "
            "(`twip.Realism.thesis_like()`: sensors, driver, delay, gearhead friction and backlash on the terrain). "
            "*Holds*: the run completed with its largest path error after the "
            f"first lap under {100 * HOLDS_BELOW:g} cm.", "",
            md_table(["scenario", "tracker", "terrain", "grade feed-forward", "outcome", "max path error after lap 1 [cm]",
                       "mean abs x / y [cm]", "holds", "rig: outcome", "rig: max path error after lap 1 [cm]",
                       "rig: holds"], table)]
