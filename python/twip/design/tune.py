"""`twip.tune`: a controller's knobs tuned over a set of uncertain robots.

Every candidate runs on the same n robots with the same sensor noise (one sweep seed for
all: common random numbers), so candidates differ by their controller alone. SciPy's
differential evolution searches the knobs on log scales, seeded, one candidate at a time:
each sweep is the same bit for bit on any number of threads, so the whole tuning is too.
The winner is then judged on held-out robots (another seed), beside the scenario's own
controller on the same robots.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from typing import Callable, Dict, Mapping, Optional

import numpy as np

from twip import _core, checks
from twip.design import knobs as knob_space
from twip.design import uncertainty
from twip.design.objective import Objective, check_constraints, failures

_bad = _core.InvalidParameterError

#: Candidates per generation of the evolution: this many per knob, within the budget.
POPULATION_PER_KNOB = 4
#: The default budget: candidate controllers evaluated (each on n robots).
DEFAULT_BUDGET = 200
#: A candidate that cannot be built (e.g. an LQR design that fails) costs this much.
UNBUILDABLE = 2.0


class TuningError(_core.TwipError):
    """No candidate kept any robot up: there is no controller to return."""


@dataclass
class Tuning:
    """A tuning's answer: the tuned `controller`, `scenario` (with it), the `knobs`, the
    held-out `validation` and the scenario's own controller's `baseline` on the same held-out
    robots (SweepResults, None when interrupted before), and the `history` of candidates."""

    controller: object
    scenario: object
    knobs: Dict[str, float]
    validation: object
    baseline: object
    history: object
    interrupted: bool = False
    settings: dict = field(default_factory=dict)

    def summary(self) -> str:
        lines = [f"{self.scenario.name}: {self.settings.get('evaluations')} candidates on "
                 f"{self.settings.get('n')} robots" + (" (interrupted: the best so far)" if self.interrupted else "")]
        lines.append("knobs: " + ", ".join(f"{k} = {v:.4g}" for k, v in self.knobs.items()))
        for label, result in (("tuned", self.validation), ("scenario's own", self.baseline)):
            if result is not None:
                lo, hi = result.fall_rate_interval()
                lines.append(f"held-out {label}: fall rate {result.fall_rate:.2%} (95 % CI {lo:.2%} – {hi:.2%}) "
                             f"over {result.n} robots")
        return "\n".join(lines)

    def save(self, path) -> None:
        """Writes the tuned knobs as a controller file (`--controller FILE`)."""
        from twip.design import controller_file

        controller_file.save(path, self)


def tune(scenario, *, perturb=None, realism=None, robot=None, knobs=None, objective=None, constraints=None,
         n: int = 256, budget: int = DEFAULT_BUDGET, seed: int = 0, validate: int = 2000, progress: bool = True,
         threads: Optional[int] = None) -> Tuning:
    """Tunes the knobs of `scenario`'s controller (twip.design.knobs) so that it holds over
    the robots of `perturb` (and of a Fit's covariance, `robot=`), through `realism`.

    objective: a callable (SweepResult on the tuning set) -> a finite number to minimise;
    default: the share of robots that fall or break a constraint, then the median pitch error,
    stop error and peak current relative to the scenario's own controller's. constraints: {metric:
    upper bound on its magnitude}; a robot whose |metric| is over a bound counts as failed. budget: candidates evaluated (each a sweep
    of n robots, seed `seed`); validate: held-out robots (another seed) for `.validation`
    and `.baseline`. Ctrl-C stops the search and validates the best so far; a second Ctrl-C
    raises KeyboardInterrupt with `.partial` (the Tuning without validation). Raises
    TuningError when every candidate failed on every robot."""
    import pandas as pd  # the history is a DataFrame: needed before the search, not after it
    from scipy.optimize import differential_evolution

    from twip.sweep import check_samples_fit

    n = uncertainty.positive_int("n", n)
    budget = uncertainty.positive_int("budget", budget)
    validate = uncertainty.positive_int("validate", validate)
    for name, count in (("n", n), ("validate", validate)):  # before the search, not when that sweep comes
        check_samples_fit(f"tune: {name} = {count:,} robots", count, f"give a smaller {name}")
    seed = checks.seed("seed", seed)
    if realism is not None and not isinstance(realism, _core.Realism):
        raise _bad(f"realism = {realism!r}: must be a twip.Realism or None")
    if objective is not None and not callable(objective):
        raise _bad(f"objective = {objective!r}: must be a callable (SweepResult) -> float, or None (the default)")
    sc, perturb = uncertainty.scenario_for(scenario, robot, perturb)
    space = knob_space.space(sc, knobs)
    run = lambda s, count, at: uncertainty.sweep(s, count, perturb, at, realism, threads)
    # Checked before the sweeps: the metric names from one robot (own's sample 0).
    constraints = check_constraints(constraints, run(sc, 1, seed).metric_names if constraints else ())

    own = run(sc, n, seed)  # the scenario's own controller on the tuning set
    goal = objective if objective is not None else Objective(constraints, reference=own)
    rows = []
    best = {"cost": math.inf, "values": None}
    bar = _bar(budget, progress)

    def cost(u) -> float:
        # The first candidate is the own controller (the first generation's first member): its
        # own values, not their log-scale round trip, nor SciPy's rescaling of it (below 0.25,
        # (u - 0.5) + 0.5 drops bits: r = 1000 in (900, 1e6) came back as 999.9999999999998).
        values = own_values if start is not None and not rows else space.values(u)
        row = {"evaluation": len(rows), **values}
        try:
            candidate = knob_space.apply(sc, values)
        except _core.TwipError as e:  # counted against the budget, like any candidate
            c = UNBUILDABLE
            rows.append({**row, "cost": c, "fall_rate": math.nan, "failed": math.nan, "error": str(e)})
        else:
            result = run(candidate, n, seed)
            try:
                c = _cost_of(goal(result))
            except (TypeError, ValueError) as e:  # SciPy would blame them on its map-like callable
                raise _Through(e) from None
            bad = failures(result, constraints)
            rows.append({**row, "cost": c, "fall_rate": result.fall_rate,
                         "failed": float(bad.mean()) if len(bad) else 1.0,
                         **{f"median_{k}": v for k, v in Objective(constraints).medians(result).items()}, "error": ""})
            if c < best["cost"]:
                best.update(cost=c, values=values, failed=rows[-1]["failed"])
        bar.update(1)
        if len(rows) >= budget:
            raise _Exhausted
        return c

    pop = max(5, min(POPULATION_PER_KNOB * len(space.names), budget))
    start = _start(space, sc)
    own_values = {k: v for k, v in space.family.read(sc.controller, sc).items() if k in space.names}
    interrupted = False
    try:
        differential_evolution(cost, [(0.0, 1.0)] * len(space.names), popsize=pop, init=_init(pop, space, start, seed),
                               maxiter=max(1, budget), tol=0.0, atol=0.0, polish=False, updating="immediate",
                               **uncertainty.scipy_seed(seed))
    except _Exhausted:
        pass
    except _Through as e:
        raise e.error from None
    except KeyboardInterrupt:
        interrupted = True
        print("tune: interrupted: validating the best candidate so far (Ctrl-C again to stop at once)",
              file=sys.stderr)
    finally:
        bar.close()
    if best["values"] is None:
        raise TuningError("tune: interrupted before any candidate finished" if interrupted else
                          "tune: no candidate controller could be built (see the knob ranges)")
    history = pd.DataFrame(rows)
    settings = dict(n=n, budget=budget, seed=seed, validate=validate, evaluations=len(rows), knobs=list(space.names),
                    ranges=[list(r) for r in space.ranges], perturb=sorted(perturb), family=space.family.name,
                    realism=_rig(realism))
    if best["failed"] >= 1.0:
        raise TuningError(f"tune: every one of {len(rows)} candidates failed on every one of the {n} robots "
                          "(fell or broke a constraint): no controller holds under this uncertainty; narrow "
                          "the perturbations or widen the knob ranges")
    tuned = knob_space.apply(sc, best["values"])
    answer = Tuning(tuned.controller, tuned, dict(best["values"]), None, None, history, interrupted, settings)
    try:
        held_out = uncertainty.held_out_seed(seed)
        answer.validation = run(tuned, validate, held_out)
        answer.baseline = run(sc, validate, held_out)
    except KeyboardInterrupt as stop:
        answer.validation = answer.baseline = None
        stop.partial = answer
        raise
    return answer


def _rig(realism) -> str:
    """The rig the tuning ran on, for the record (the controller does not depend on it; its
    held-out numbers do)."""
    if realism is None:
        return "none"
    for name, known in (("ideal", _core.Realism()), ("thesis-like", _core.Realism.thesis_like())):
        if repr(realism) == repr(known):
            return name
    return "custom"


class _Exhausted(Exception):
    """The budget of candidates is spent."""


class _Through(Exception):
    """An error of the objective's, carried through SciPy as it is."""

    def __init__(self, error: Exception):
        super().__init__(error)
        self.error = error


def _cost_of(value) -> float:
    """The objective's value: a finite real number (else float() would keep a complex's real
    part, and SciPy would misread the rest)."""
    try:
        return checks.real("objective", value)
    except (TypeError, _bad):
        raise _bad(f"objective returned {value!r} ({type(value).__name__}): must be a finite real number") from None


def _start(space, sc):
    """The scenario controller's own knob values in the unit cube, when known and in range."""
    own = space.family.read(sc.controller, sc)
    if not all(k in own for k in space.names):
        return None
    u = space.unit(own)
    return u if all(0.0 <= x <= 1.0 for x in u) else None


def _init(pop, space, start, seed):
    """The first generation: a Latin hypercube over the knobs' cube, seeded, with the
    scenario's own controller as its first member when its knobs are known."""
    from scipy.stats import qmc

    d = len(space.names)
    points = qmc.LatinHypercube(d, **uncertainty.scipy_seed(seed)).random(pop) if d else np.zeros((pop, 0))
    if start is not None:
        points[0] = start
    return points


def _bar(total, enabled):
    from twip.sweep import ProgressBar

    class _Bar(ProgressBar):
        def update(self, k):
            self.base += k
            self.update_to(0)

    bar = _Bar(0, False)
    if enabled:
        try:
            from tqdm.auto import tqdm

            bar.bar = tqdm(total=total, unit="candidates")
        except ImportError:
            pass
    return bar
