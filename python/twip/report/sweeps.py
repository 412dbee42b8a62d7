"""The report's Monte Carlo runs: robustness sweeps of every experiment scenario and the
fall-rate maps over the initial pitch and pitch rate."""
from __future__ import annotations

import math
import time
from typing import Any, Dict, List

import numpy as np

import twip
from twip.plot import METRIC_UNITS, size_label
from twip.report.numbers import dec, sig
from twip.scenarios import is_planar
from twip.sweep import kernel_for

#: Robustness sweeps: every parameter a builder can get wrong, ±20 % (frictions ±50 %).
SWEEP_PERTURB = {"m_body": ("±20%", 0.2), "com_height": ("±20%", 0.2), "i_body": ("±20%", 0.2),
                 "mu_bearing": ("±50%", 0.5), "mu_ground": ("±50%", 0.5)}

#: Metrics a sweep reports (and draws) as their size: the stop's error either side of the goal.
SIZES = ("final_position_error",)

#: What a robustness sweep reports, per model.
_SWEEP_KEYS = {True: ("mean_abs_x_error_settled", "mean_abs_y_error_settled", "max_path_error_settled"),
               False: ("mean_abs_pitch_error", "mean_abs_speed_error", "final_position_error")}


def sweep_perturb(planar: bool) -> Dict[str, Any]:
    out: Dict[str, Any] = {k: twip.Uniform(rel=v) for k, (_, v) in SWEEP_PERTURB.items()}
    if not planar:
        out["phi0"] = twip.Normal(std=math.radians(2.0))
    return out


def sweep_perturb_text(planar: bool) -> str:
    text = ", ".join(f"{k} {s}" for k, (s, _) in SWEEP_PERTURB.items())
    return text + ("" if planar else ", φ(0) + N(0, 2°)")


def _interval_pct(res) -> List[float]:
    lo, hi = res.fall_rate_interval()
    return [dec(100 * lo, 1), dec(100 * hi, 1)]


def _metric_summary(res, key: str) -> dict:
    """Median and 95th percentile of one metric over the samples that did not fall."""
    keep = res.metrics["valid"] & ~res.metrics["fell"]
    label, scale, unit = METRIC_UNITS[key]
    v = np.asarray(res.metrics[key], float)[keep]
    if key in SIZES:
        v, label = np.abs(v), size_label(key)
    v = v[np.isfinite(v)]
    q = np.quantile(v, (0.5, 0.95)) if len(v) else np.full(2, np.nan)
    return {"label": label, "unit": unit, "median": sig(q[0] * scale, 3), "q95": sig(q[1] * scale, 3)}


def robustness_sweeps(runs: dict, quick: bool, steps, figures, family, quick_options) -> List[dict]:
    """One sweep per experiment scenario (the `-sim` ones are left to the fall maps)."""
    from twip import plot

    rows = []
    for name, (sc, _) in runs.items():
        if name.endswith("-sim"):
            continue
        planar = is_planar(sc)
        lanes = kernel_for(sc) == "lanes"  # the fast LQR kernel affords more samples
        n = (6 if quick else 40) if planar else ((64 if lanes else 24) if quick else (2000 if lanes else 300))
        t0 = time.perf_counter()
        options = {**quick_options(name, quick), **({"laps": 2} if planar else {})}
        try:
            res = twip.montecarlo(name, n, perturb=sweep_perturb(planar), seed=1, progress=False, options=options)
        except Exception as e:
            steps.done(f"sweep {name}: FAILED ({e})", time.perf_counter() - t0)
            continue
        keys = _SWEEP_KEYS[planar]
        rows.append({"scenario": name, "controller": family(sc), "samples": res.n,
                     "perturbation": sweep_perturb_text(planar), "fall_rate_pct": dec(100 * res.fall_rate, 1),
                     "fall_rate_95ci_pct": _interval_pct(res), "metrics": {k: _metric_summary(res, k) for k in keys}})
        title = (f"Robustness of {name} ({family(sc)}): {res.n} robots drawn with {sweep_perturb_text(planar)}; "
                 "the controller is designed for the nominal robot")
        figures.add(f"sweep_{name}.png", f"robustness sweep of {name}: histograms over {res.n} perturbed robots",
                    lambda p, res=res, keys=keys, title=title: plot.sweep(res, metrics=list(keys), path=p, title=title,
                                                                                       sizes=SIZES))
        steps.done(f"sweep {name}: {res.n} samples, fall rate {res.fall_rate:.1%}", time.perf_counter() - t0)
    return rows


def fall_maps(runs: dict, quick: bool, steps, figures, family) -> List[dict]:
    """Which starts each controller on the slope catches: initial pitch and rate drawn uniformly."""
    from twip import plot

    rows, results = [], []
    for name, (sc, _) in runs.items():
        if is_planar(sc) or not name.endswith("-sim") or not getattr(sc.model, "slope", 0.0):
            continue
        lanes = kernel_for(sc) == "lanes"
        n = (300 if lanes else 150) if quick else (4000 if lanes else 2000)
        t0 = time.perf_counter()
        perturb = {"phi0": twip.Uniform(low=-1.0, high=1.0), "phi_dot0": twip.Uniform(low=-20.0, high=20.0)}
        try:
            res = twip.montecarlo(name, n, perturb=perturb, seed=2, progress=False, options={"t_final": 4.0})
        except Exception as e:
            steps.done(f"fall map {name}: FAILED ({e})", time.perf_counter() - t0)
            continue
        rows.append({"scenario": name, "controller": family(sc), "samples": res.n,
                     "perturbation": "φ(0) uniform ±57.3°, φ̇(0) uniform ±1146°/s, 4 s",
                     "fall_rate_pct": dec(100 * res.fall_rate, 1), "fall_rate_95ci_pct": _interval_pct(res)})
        results.append(res)
        steps.done(f"fall map {name}: {res.n} starts, fall rate {res.fall_rate:.1%}", time.perf_counter() - t0)
    if results:
        figures.add("fall_maps.png", "fall rate over the initial pitch and pitch rate, per controller, on the 15° slope",
                    lambda p, rs=results: plot.fall_maps(
                        rs, "phi0", "phi_dot0", bins=(8, 8) if quick else (14, 14), path=p,
                        title="Which starts each controller catches (15° slope, ideal actuator: no current limit)"))
    return rows
