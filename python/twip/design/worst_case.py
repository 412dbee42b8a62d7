"""`twip.worst_case`: the worst robot inside the support of a scenario's perturbations.

Monte Carlo samples robots where they are likely; a worst case sits where they are not
(a corner of the box). The search scores every robot by a continuous margin, not by the
fall flag alone: a fall scores 1 plus how early it came, a run that stays up its worst
pitch excursion over the fall threshold. Its first generation is a space-filling design
(a Latin hypercube sample, and the box's corners when they are few), which SciPy's
differential evolution then refines. Every candidate robot runs with the same noise
(sweep sample 0 of `seed`), so the search is deterministic and its answer replays.
"""
from __future__ import annotations

import math
import os
import warnings
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from itertools import product
from typing import Dict, Optional

import numpy as np

from twip import _core, checks
from twip.design import uncertainty
from twip.distributions import Normal, Uniform

_bad = _core.InvalidParameterError

#: A Normal perturbation's support, for the search: mean ± this many std (within its clamps).
NORMAL_SUPPORT = 3.0
#: The box's 2^d corners join the first generation when they are at most this share of the budget.
CORNER_SHARE = 0.25
#: Robots per generation of the refinement.
POPULATION = 32
METRICS = ("margin", "time_to_fall")
#: Sweep metrics that are no badness: how a run ended, which the scores above already rank.
NOT_RANKED = ("fell", "t_end")


@dataclass
class WorstCase:
    """The worst robot found: `robot` (RobotParams), `params` (the searched quantities'
    values), `metric` (its score; larger is worse), `fell`, `evaluations`, `history` (a
    DataFrame of every robot tried; `valid` False: it could not be simulated, and scored
    -inf). `replay()` runs it again with the search's noise."""

    robot: object
    params: Dict[str, float]
    metric: float
    fell: bool
    evaluations: int
    history: object
    scenario: object = None
    realism: object = None
    seed: int = 0
    settings: dict = field(default_factory=dict)

    def _perturb(self):
        return {k: Uniform(low=v, high=v) for k, v in self.params.items()}

    def replay(self, **simulate_options):
        """The worst robot's run (a SimResult), with the noise the search gave it."""
        result = uncertainty.sweep(self.scenario, 1, self._perturb(), self.seed, self.realism, 1)
        return result.replay(0, **simulate_options)

    def confirm(self, n: int = 20, seed: Optional[int] = None):
        """The worst robot on `n` fresh noise seeds (sweep samples of another seed): a
        SweepResult whose fall rate says whether it falls on noise other than the search's."""
        n = uncertainty.positive_int("n", n)
        seed = uncertainty.held_out_seed(self.seed) if seed is None else checks.seed("seed", seed)
        return uncertainty.sweep(self.scenario, n, self._perturb(), seed, self.realism, None)


def support(perturb, sc) -> Dict[str, tuple]:
    """{name: (low, high)}: where each perturbation can put its quantity."""
    from twip.perturbation import resolve

    out = {}
    for (name, dist), tup in zip(perturb.items(), resolve(perturb, sc)):
        kind, a, b, low, high = tup[2:]
        if kind == "uniform":
            out[name] = (low, high)
        else:  # normal: mean a, std b, its draws clamped into [low, high]
            # Both ends clamped: a clamp beyond mean + 3 std puts every draw on it, not between.
            out[name] = tuple(min(max(v, low), high) for v in (a - NORMAL_SUPPORT * b, a + NORMAL_SUPPORT * b))
    return out


def score(result, metric: str) -> np.ndarray:
    """Each sample's badness under `metric` (larger: worse): a fall scores 1 plus how early
    it came (as a share of the run); "margin" scores a run that stays up by its mean |pitch
    error| (a 3-DOF tracker's: mean |pitch|) over the fall limit (below 1), "time_to_fall"
    by 0, a sweep metric by its magnitude (final_position_error is signed: short of the goal
    or past it are alike) and a fall by inf. A robot that could not be simulated (invalid)
    scores -inf: never the worst."""
    m = result.metrics
    t_final = result.config["t_final"]
    fell = m["fell"]
    early = 1.0 + (t_final - m["t_end"]) / t_final
    if metric == "time_to_fall":
        s = np.where(fell, early, 0.0)
    elif metric == "margin":
        pitch = m["mean_abs_pitch_error"] if "mean_abs_pitch_error" in m else m["mean_abs_pitch"]
        s = np.where(fell, early, np.minimum(pitch / _core.DEFAULT_FALL_LIMIT, 1.0))
    else:
        s = np.where(fell, math.inf, np.abs(m[metric]))
    return np.where(m["valid"], s, -math.inf)


def worst_case(scenario, *, perturb, realism=None, metric=None, budget: int = 400, seed: int = 0,
               threads: Optional[int] = None) -> WorstCase:
    """Searches the support of `perturb` (Uniform: its interval; Normal: ± NORMAL_SUPPORT std within its clamps)
    for the robot with the worst `metric`: "margin" (default: falls first, the earlier the
    worse, then the mean pitch error), "time_to_fall", or a metric of the scenario's sweeps
    such as "peak_current" (a larger magnitude is worse; a fall worst of all). `budget` robots
    are run, each with sweep sample 0's noise of `seed`; `threads` run robots side by side (the
    answer is the same on any number). Robots that cannot be simulated (e.g. a negative mass
    within a Normal's ± NORMAL_SUPPORT std) are never the answer: a warning counts them, and
    when every robot tried was one, InvalidParameterError. Ctrl-C raises KeyboardInterrupt
    with `.partial`, the worst of the robots tried so far (None before any), its
    settings["interrupted"] True."""
    import pandas as pd  # the history is a DataFrame: needed before the search, not after it
    from scipy.optimize import differential_evolution

    budget = uncertainty.positive_int("budget", budget)
    seed = checks.seed("seed", seed)
    if realism is not None and not isinstance(realism, _core.Realism):
        raise _bad(f"realism = {realism!r}: must be a twip.Realism or None")
    checks.of_type("metric", metric, (str, type(None)), "a metric name or None")
    workers = checks.threads(threads) or os.cpu_count() or 1
    sc, perturb = uncertainty.scenario_for(scenario, None, perturb)
    if not perturb:
        raise _bad("perturb: empty; the worst case is searched over the perturbations' support")
    box = support(perturb, sc)
    names = list(box)
    lo = np.array([box[k][0] for k in names])
    hi = np.array([box[k][1] for k in names])
    metric = "margin" if metric is None else metric
    probe = uncertainty.sweep(sc, 1, perturb, seed, realism, 1)
    ranked = [k for k in probe.metric_names if k not in NOT_RANKED]
    if metric not in METRICS and metric not in ranked:
        raise _bad(f"metric = {metric!r}: one of {', '.join(METRICS)} or a sweep metric ({', '.join(ranked)})")
    # A box of one point (every low == high) holds one robot: run it once, not `budget` times.
    runs = 1 if np.array_equal(lo, hi) else budget
    rows = []
    invalid = Counter()  # why robots could not be simulated: {reason: count}

    def one(u):
        values = {k: float(v) for k, v in zip(names, lo + np.asarray(u) * (hi - lo))}
        result = uncertainty.sweep(sc, 1, {k: Uniform(low=v, high=v) for k, v in values.items()}, seed, realism, 1)
        s = score(result, metric)
        valid = bool(result.metrics["valid"][0])
        return values, float(s[0]), bool(result.metrics["fell"][0]), valid, {} if valid else result.invalid_reasons()

    def evaluate_all(func, population):
        # Robots side by side; the answers in the population's order, whatever finishes first.
        population = list(population)
        room = runs - len(rows)
        if room <= 0:
            raise _Exhausted
        population = population[:room]
        with ThreadPoolExecutor(max_workers=workers) as pool:
            answers = list(pool.map(one, population))
        out = []
        for values, s, fell, valid, reasons in answers:
            rows.append({"evaluation": len(rows), **values, "metric": s, "fell": fell, "valid": valid})
            invalid.update(reasons)
            out.append(math.inf if math.isnan(s) else -s)  # a NaN metric ranks nothing: never the worst
        if len(rows) >= runs:
            raise _Exhausted
        return out

    first = _design(len(names), runs, seed)
    settings = dict(metric=metric, budget=budget, box=box)
    try:
        differential_evolution(lambda u: 0.0, [(0.0, 1.0)] * len(names), init=first, maxiter=runs,
                               tol=0.0, atol=0.0, polish=False, **uncertainty.scipy_seed(seed), updating="deferred",
                               workers=evaluate_all, popsize=len(first))
    except _Exhausted:
        pass
    except KeyboardInterrupt as stop:  # the robots tried so far are kept: the worst of them
        stop.partial = None
        if any(row["valid"] for row in rows):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    stop.partial = _answer(pd.DataFrame(rows), invalid, names, sc, realism, seed,
                                           {**settings, "interrupted": True})
                except _bad:  # every robot so far unmeasured: no worst one yet
                    pass
        raise
    history = pd.DataFrame(rows)
    return _answer(history, invalid, names, sc, realism, seed, settings)


def _answer(history, invalid, names, sc, realism, seed, settings) -> WorstCase:
    """The worst robot of `history` (the robots tried, in order)."""
    if invalid:
        count = len(history) - int(history["valid"].sum())
        why = "; ".join(f"{reason} ({k})" for reason, k in invalid.items())
        if count == len(history):
            raise _bad(f"perturb: none of the {count} robots tried could be simulated ({why}); "
                       "keep the perturbations within what a robot can be")
        warnings.warn(f"worst_case: {count} of the {len(history)} robots tried could not be simulated ({why}); "
                      "they are left out of the search", stacklevel=3)
    metric = settings["metric"]
    scores = history["metric"].to_numpy()
    unmeasured = np.isnan(scores)  # e.g. a settled error on runs too short to settle
    if unmeasured.any():
        if unmeasured[history["valid"].to_numpy()].all():
            raise _bad(f"metric = {metric!r}: NaN on every one of the {int(history['valid'].sum())} robots tried "
                       "(these runs do not measure it); choose another metric or a longer run")
        warnings.warn(f"worst_case: metric {metric!r} is NaN on {int(unmeasured.sum())} of the {len(history)} "
                      "robots tried; they are left out of the search", stacklevel=3)
        scores = np.where(unmeasured, -math.inf, scores)
    worst = int(np.argmax(scores))  # the first of equals: deterministic
    params = {k: float(history[k].iloc[worst]) for k in names}
    robot = _robot_of(sc, params)
    return WorstCase(robot, params, float(history["metric"].iloc[worst]), bool(history["fell"].iloc[worst]),
                     len(history), history, sc, realism, seed, settings)


class _Exhausted(Exception):
    """The budget of robots is spent."""


def _design(d: int, budget: int, seed: int) -> np.ndarray:
    """The first generation: the box's corners (when 2^d is at most CORNER_SHARE of the
    budget) and a Latin hypercube sample, POPULATION at least, within the budget."""
    from scipy.stats import qmc

    corners = np.array(list(product((0.0, 1.0), repeat=d))) if 2**d <= CORNER_SHARE * budget else np.zeros((0, d))
    size = max(POPULATION, len(corners) + 8)
    size = min(size, budget) if budget >= 5 else 5
    spread = qmc.LatinHypercube(d, **uncertainty.scipy_seed(seed)).random(max(size - len(corners), 0))
    return np.vstack([corners, spread])[:size]


def _robot_of(sc, params: Dict[str, float]):
    fields = set(_core.RobotParams.fields)
    return sc.model.params.replace(**{k: v for k, v in params.items() if k in fields})
