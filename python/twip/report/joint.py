"""A search over the joint box of a claim's unpublished choices: a space-filling sample
(scipy.stats.qmc) gives the share of runs in which the claim holds, with twip's default run
counted; a run at the corner a linear fit of the sample points to, either way, searches the
worst and the best case, when the sample determines the fit. Every run is kept as a `detail`
entry: its `values`, `ours`, `holds`."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from twip.report.numbers import sig


@dataclass(frozen=True)
class Span:
    """A continuous choice from `low` to `high`, twip's `default`; `log`: sampled evenly in
    its logarithm (gains and rates that span decades)."""
    low: float
    high: float
    default: float
    log: bool = False
    step: float = 0.0  # > 0: the values are whole multiples of it (a loop period of whole RK4 steps)

    def at(self, u: float) -> float:
        if self.log:
            x = math.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        else:
            x = self.low + u * (self.high - self.low)
        return float(round(x / self.step) * self.step) if self.step > 0 else float(x)

    def unit(self, x: float) -> float:
        """Where `x` lies in the range, 0 at low and 1 at high (as `at` maps)."""
        if self.log:
            return (math.log(x) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (x - self.low) / (self.high - self.low)

    def ends(self) -> Tuple[float, float]:
        return (self.low, self.high)

    def describe(self) -> list:
        return [sig(self.low), sig(self.high)]


@dataclass(frozen=True)
class Among:
    """A choice among named alternatives; the first is twip's default."""
    labels: Tuple[str, ...]

    @property
    def default(self) -> str:
        return self.labels[0]

    def at(self, u: float) -> str:
        return self.labels[min(int(u * len(self.labels)), len(self.labels) - 1)]

    def ends(self) -> Tuple[str, ...]:
        return self.labels

    def describe(self) -> list:
        return list(self.labels)


Box = Dict[str, object]  # choice name -> Span or Among
#: Our number for each claim of one run, and whether the claim holds: {claim: (number, holds)}.
Outcome = Dict[str, Tuple[Optional[float], bool]]


def sample(box: Box, n: int, seed: int) -> List[dict]:
    """twip's defaults, then `n` points of a scrambled Sobol sample of the box (n a power of 2)."""
    names = list(box)
    points = [{k: box[k].default for k in names}]
    if n > 0:
        from scipy.stats import qmc  # on use: `twip --help` imports the report's defaults only

        unit = qmc.Sobol(len(names), scramble=True, seed=seed).random(n)
        points += [{k: box[k].at(float(u)) for k, u in zip(names, row)} for row in unit]
    return points


def _key(values: dict) -> tuple:
    return tuple((k, round(v, 12) if isinstance(v, float) else v) for k, v in sorted(values.items()))


def search(box: Box, evaluate: Callable[[dict], Outcome], claims: Sequence[str], n: int, seed: int = 0,
           extremes: bool = True) -> Dict[str, dict]:
    """{claim: sensitivity entry} over the joint `box`: `evaluate(values)` runs one point and
    gives each claim's (number, holds) (number None: the run fell; NaN: it diverged; either
    way it has no number, and the claim does not hold in it whatever `evaluate` says). The
    share that holds is over the default and the `n` sampled points. With `extremes`, each
    claim's worst and best case is searched at the corner a linear fit of the sample points to
    (`_corner`: each range at the end the fit's slope favours, each alternative the one with
    the lowest or highest fitted effect), when the runs with a number determine the fit;
    otherwise `not_searched` says why. The low and the high are over every run that has a
    number; `fell` counts the runs without one (each marked in `detail`), which they leave out."""
    cache: Dict[tuple, Outcome] = {}
    runs: List[Tuple[dict, Outcome, str]] = []

    def run(values: dict, kind: str) -> Outcome:
        key = _key(values)
        if key not in cache:
            cache[key] = {k: (x, bool(ok) and _finite(x)) for k, (x, ok) in evaluate(values).items()}
            runs.append((values, cache[key], kind))
        return cache[key]

    points = sample(box, n, seed)
    sampled = [run(values, "default" if i == 0 else "sample") for i, values in enumerate(points)]
    share = {k: sum(out[k][1] for out in sampled) / len(sampled) for k in claims}
    unsearched: Dict[str, str] = {}
    if extremes:
        for k in claims:
            numbered = [(v, o[k][0]) for v, o in zip(points, sampled) if _finite(o[k][0])]
            for sign in (1.0, -1.0):
                corner, why = _corner(box, numbered, sign)
                if corner is not None:
                    run(corner, "search")
                else:
                    unsearched[k] = why
    out = {}
    for k in claims:
        numbers = [o[k][0] for _, o, _ in runs if _finite(o[k][0])]
        out[k] = {"choices": {name: choice.describe() for name, choice in box.items()},
                  "low": _ours(min(numbers)) if numbers else None, "high": _ours(max(numbers)) if numbers else None,
                  "holds": sig(share[k]), "runs": len(sampled), "searched": len(runs) - len(sampled),
                  "fell": sum(not _finite(o[k][0]) for _, o, _ in runs),
                  "detail": [{"values": {n_: (sig(v) if isinstance(v, float) else v) for n_, v in values.items()},
                              "ours": _ours(o[k][0]), "holds": o[k][1], "run": kind, "fell": not _finite(o[k][0])}
                             for values, o, kind in runs]}
        if k in unsearched:
            out[k]["not_searched"] = unsearched[k]
    return out


def _corner(box: Box, points: List[Tuple[dict, float]], sign: float) -> Tuple[Optional[dict], str]:
    """(the corner of `box` where a linear fit (numpy.linalg.lstsq) of the sampled `points`
    (values, number) is lowest (`sign` 1) or highest (-1), ""): each range at the end its
    slope favours, each alternative the sampled one with the lowest (highest) fitted effect
    (one 0/1 term per sampled alternative but the default, so the ranges' slopes are not
    confounded with them). A number linear in each range's `unit` plus an effect per
    alternative is fitted exactly, and the corners are its exact low and high, when the points
    determine the fit: at least as many as its terms, of full rank. Otherwise (None, why):
    fewer points leave a family of fits, and lstsq's minimum-norm one would point to an
    arbitrary corner."""
    spans = [k for k, c in box.items() if isinstance(c, Span)]
    levels = [(k, label) for k, c in box.items() if isinstance(c, Among) for label in c.labels[1:]
              if any(values[k] == label for values, _ in points)]  # an unseen one has no column to fit
    a = np.array([[1.0] + [box[k].unit(values[k]) for k in spans] + [float(values[k] == label) for k, label in levels]
                  for values, _ in points]).reshape(len(points), 1 + len(spans) + len(levels))
    terms = a.shape[1]
    if len(points) < terms or np.linalg.matrix_rank(a) < terms:
        return None, (f"{len(points)} run{'s' if len(points) != 1 else ''} with a number for a linear fit of {terms} "
                      f"terms{'' if len(points) < terms else ' that they do not determine'}")
    y = np.array([float(number) for _, number in points])
    coef = dict(zip(spans + levels, np.linalg.lstsq(a, y, rcond=None)[0][1:]))
    corner = {}
    for k, choice in box.items():
        if isinstance(choice, Span):
            corner[k] = choice.low if sign * coef[k] > 0 else choice.high
        else:
            seen = [label for label in choice.labels if any(v[k] == label for v, _ in points)]
            corner[k] = min(seen, key=lambda label: sign * coef.get((k, label), 0.0))
    return corner, ""


def _finite(x) -> bool:
    """A number to compare (a yes/no conclusion counts as 0/1); None or NaN: the run fell."""
    return x is not None and math.isfinite(float(x))


def _ours(x):
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    return sig(float(x)) if _finite(x) else None
