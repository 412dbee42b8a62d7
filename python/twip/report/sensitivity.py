"""How much our numbers depend on what the thesis does not publish: each claim that rests on
an unpublished choice is rerun over a plausible range of it, and its row gets
`sensitivity = {"choices": {name: [low, high]}, "low": ..., "high": ..., "holds": share}`:
the range of our number, and the share of the runs in which the thesis's conclusion holds.
The ranges, and why each is plausible, are the module's constants."""
from __future__ import annotations

import itertools
import math
from typing import Callable, Dict, List, Sequence

from twip import scenarios
from twip.report.numbers import sig

#: The go-and-back run's waits [s] at the far goal and at home (the thesis shows a hold
#: but gives no length; twip's 5 s each). 3-7 s spans what its figures could show.
WINDOWS = {"hold [s]": (3.0, 5.0, 7.0), "settle [s]": (3.0, 5.0, 7.0)}
#: The control loop's period [s]: the thesis's Arduino loop is not stated for these runs;
#: 2-10 ms spans what an Uno's loop with an MPU-6050 read takes.
PERIODS = (0.002, 0.005, 0.01)
#: The fuzzy adaptation gain Γ (unpublished): 0.005-1 spans the rates at which the weights
#: move from barely to about as fast as the PD.
GAMMAS = (0.005, 0.02, 0.1, 0.3, 1.0)
#: The weights' leakage σ (unpublished), over the range docs/scenarios.md scans.
SIGMAS = (0.01, 0.05, 0.2)
#: Gearhead friction on the plant (the thesis models only viscous friction): none, the GB37's
#: no-load torque split with the fitted viscous bearing, and all of it as Coulomb friction.
def frictions(params) -> Dict[str, object]:
    from twip import _core

    return {"none (thesis)": None, "no-load torque split": _core.Friction.gb37_beside(params.mu_bearing / 2),
            "no-load torque as Coulomb": _core.Friction.gb37()}


#: The sliding-mode trackers' λ1: twip's pitch offset (errata T8) or the thesis's (4.74).
PITCH_FORMS = {"twip's pitch offset": True, "thesis (4.74)": False}
#: The sliding-mode trackers' kinematic gains (unpublished, errata T4): each halved and
#: doubled around twip's k1 = k2 = 2, k3 = 4, with twip's pitch offset.
SMC_GAINS = {"k1": (1.0, 4.0), "k2": (1.0, 4.0), "k3": (2.0, 8.0)}


def _entry(choices: Dict[str, Sequence], values: Sequence[float], holds: Sequence[bool]) -> dict:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return {"choices": {k: [min(v), max(v)] if all(isinstance(x, (int, float)) for x in v) else list(v)
                        for k, v in choices.items()},
            "low": sig(min(finite)) if finite else None, "high": sig(max(finite)) if finite else None,
            "holds": sig(sum(holds) / len(holds)) if holds else None, "runs": len(values)}


def table_5_1(judge: Callable[[str, str, str, float], bool], quick: bool) -> Dict[str, dict]:
    """Table 5.1's rows over the hold and settle windows and the loop period, and with
    gearhead friction (at the default windows and period): {claim id: sensitivity}.
    `judge(controller, surface, metric, ours)` says whether a row's claim holds."""
    from twip import _core
    from twip.scenarios.fuzzy import compare_table

    per_row: Dict[str, List[float]] = {}
    held: Dict[str, List[bool]] = {}
    better: Dict[str, List[bool]] = {"flat": [], "slope": []}

    def record(rows) -> None:
        by = {(r["surface"], r["controller"]): r for r in rows}
        for (surface, controller), r in by.items():
            ok = r["outcome"] == "completed"
            for metric, key in (("pitch", "pitch_error_deg"), ("speed", "speed_error_deg_s")):
                cid = f"table-5.1/{controller}-{surface}/{metric}"
                per_row.setdefault(cid, []).append(r[key] if ok else float("nan"))
                held.setdefault(cid, []).append(ok and judge(controller, surface, metric, r[key]))
        for surface in better:
            lqr, fuzzy = by[(surface, "lqr")], by[(surface, "fuzzy")]
            better[surface].append(fuzzy["pitch_error_deg"] < lqr["pitch_error_deg"]
                                   and fuzzy["speed_error_deg_s"] < lqr["speed_error_deg_s"])

    choices = {**WINDOWS, "loop period [s]": PERIODS}
    grid = list(itertools.product(*choices.values()))
    for hold, settle, period in ([grid[0], grid[-1]] if quick else grid):
        record(compare_table(cases=["nominal"], controllers=("lqr", "fuzzy"), hold=hold, settle=settle, period=period))
    kinds = frictions(_core.RobotParams.balanbot())
    for friction in list(kinds.values())[1:]:
        record(compare_table(cases=["nominal"], controllers=("lqr", "fuzzy"), friction=friction))
    choices["gearhead friction"] = tuple(kinds)
    out = {cid: _entry(choices, values, held[cid]) for cid, values in per_row.items()}
    for surface, wins in better.items():
        out[f"table-5.1/fuzzy-beats-lqr-{surface}"] = _entry(choices, [float(w) for w in wins], wins)
    return out


def goals(quick: bool) -> Dict[str, dict]:
    """The go-and-back experiments' stops over the hold and settle windows: each row's number is
    the largest distance of a stop from its goal [m]; the claim holds when both are within 2 cm."""
    from twip.scenarios.fuzzy import stop_positions

    grid = list(itertools.product(*WINDOWS.values()))
    if quick:
        grid = [grid[0], grid[-1]]
    out = {}
    for name in ("slope-lqr", "slope-fuzzy", "flat-lqr", "flat-fuzzy"):
        values, held = [], []
        for hold, settle in grid:
            sc = scenarios.get(name, hold=hold, settle=settle)
            r = sc.run()
            off = max(abs(p - g) for p, (_, g) in zip(stop_positions(sc, r), sc.thesis["goals"]))
            values.append(off)
            held.append(r.outcome == "completed" and off <= 0.02)
        entry = _entry(WINDOWS, values, held)
        entry["measure"] = "largest |stop − goal| [m]"
        out[f"{name}/goals"] = entry
    return out


def fuzzy_settling(judge: Callable[[str, float], bool], quick: bool) -> Dict[str, dict]:
    """slope-fuzzy-sim's settling claims over the adaptation gain Γ and leakage σ, and over
    the fuzzy sets of Figs 4.4/4.5 (scenarios.fuzzy.SET_CHOICES, at the default Γ, σ)."""
    from twip.scenarios.fuzzy import SET_CHOICES, sets_of

    gammas, sigmas = ((GAMMAS[0], GAMMAS[-1]), (SIGMAS[1],)) if quick else (GAMMAS, SIGMAS)
    options = {"t_final": 6.0} if quick else {}
    runs = [dict(gamma=g, sigma=s) for g, s in itertools.product(gammas, sigmas)]
    runs += [dict(sets=sets_of(label)) for label in (list(SET_CHOICES)[:2] if quick else SET_CHOICES)]
    values = {"pitch_settling_time": [], "speed_settling_time": []}
    for run in runs:
        r = scenarios.get("slope-fuzzy-sim", **run, **options).run()
        for key in values:
            values[key].append(float(r.metrics[key]))
    choices = {"gamma": gammas, "sigma": sigmas, "sets": tuple(SET_CHOICES)}
    return {f"slope-fuzzy-sim/{key}": _entry(choices, v, [judge(key, x) for x in v]) for key, v in values.items()}


def smc_versus_pid(ratio_of: Callable[[list], float], laps: int) -> Dict[str, dict]:
    """Table 5.2's conclusion under both forms of the sliding-mode trackers' λ1, over their
    unpublished gains k1, k2, k3 (one at a time), and with gearhead friction on the plants."""
    from twip.scenarios import tracking

    by_form = {label: ratio_of(tracking.compare(laps=laps, pitch_offset=form)) for label, form in PITCH_FORMS.items()}
    by_gain = [ratio_of(tracking.compare(laps=laps, smc_gains={name: value}))
               for name, values in SMC_GAINS.items() for value in values]
    from twip import _core

    kinds = frictions(_core.RobotParams.balanbot())
    by_friction = [ratio_of(tracking.compare(laps=laps, friction=f)) for f in list(kinds.values())[1:]]
    ratios = [*by_form.values(), *by_gain, *by_friction]
    entry = _entry({"λ1": tuple(PITCH_FORMS), **SMC_GAINS, "gearhead friction": tuple(kinds)}, ratios,
                   [r >= 2.0 for r in ratios])
    entry["by_choice"] = {label: sig(r) for label, r in by_form.items()}
    return {"table-5.2/smc-beats-pid": entry}
