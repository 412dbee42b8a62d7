"""Monte Carlo robustness sweeps: `twip.montecarlo("flat-lqr", 10_000, perturb={...})`.

The controller of the scenario is designed once on the nominal robot; each sample runs
it on a perturbed plant (RobotParams fields, slope, initial state). The 2-DOF scenarios
(LQR, fuzzy) and the 3-DOF tracking ones (PID, sliding mode on a PlanarModel: flat, no
slope) run alike; each family has its own metrics (`SweepResult.metric_names`). Sample i draws from
its own counter-based random stream, so a sweep gives the same numbers, bit for bit, on
any number of threads, in shards, resumed after a crash, on a Dask cluster, and when a
sample is run alone again (`SweepResult.rerun(i)`). Replayed with the full runner and its
trajectory (`SweepResult.replay(i)`), a sample is also the sweep's bit for bit, except in
LQR sweeps without realism (kernel "lanes"), whose lane kernel fuses multiply-adds: there
the metrics agree to ~1e-13 relative.

With `realism=` (a `twip.Realism`) every sample runs with the robot's real parts in the
loop. Sample i's sensor noise is the Philox stream (sweep_noise_seed(seed), i): the
realism's own seed and stream are ignored, so a sample depends on (seed, i) alone and
another sweep seed gives other noise as well as other robots.
"""
from __future__ import annotations

import json
import math
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, Mapping, Optional, Sequence, Tuple

import numpy as np

from twip import _core, budget, user_sweep
from twip.checkpoint import Checkpoint
from twip.quantiles import streamed_quantiles_of

STATE_NAMES = ("phi0", "phi_dot0", "theta0", "theta_dot0")
#: SI units of the initial-state entries a sweep can perturb.
_STATE_UNITS = {"phi0": "rad", "phi_dot0": "rad/s", "theta0": "rad", "theta_dot0": "rad/s", "x0": "m", "y0": "m",
                "psi0": "rad", "v0": "m/s", "omega0": "rad/s"}
#: The initial state of a PlanarModel: [x, y, psi, phi, phi_dot, v, omega].
PLANAR_STATE_NAMES = ("x0", "y0", "psi0", "phi0", "phi_dot0", "v0", "omega0")
DEFAULT_SHARD = 1024
#: A checkpointed sweep is cut into at most this many shards by default.
MAX_SHARDS = 10_000
#: Memory one sample of a sweep takes while it runs and when assembled: its metric
#: columns (~100 bytes), the worker's result and the concatenated copy.
BYTES_PER_SAMPLE = 320


def _bad(message: str) -> Exception:
    return _core.InvalidParameterError(message)


@dataclass(frozen=True)
class Uniform:
    """Uniform on [low, high]; or nominal·(1 ± rel); or nominal ± abs."""

    low: Optional[float] = None
    high: Optional[float] = None
    rel: Optional[float] = None
    abs: Optional[float] = None

    def __post_init__(self):
        _numbers(self, ("low", "high", "rel", "abs"))

    def resolve(self, name: str, nominal: float):
        given = [self.rel is not None, self.abs is not None, self.low is not None or self.high is not None]
        if sum(given) != 1:
            raise _bad(f"{name}: Uniform takes exactly one of rel=, abs= or low=/high=")
        if self.rel is not None:
            _width(name, "rel", self.rel)
            if nominal == 0:
                raise _bad(f"{name}: rel= needs a nonzero nominal value (it is 0); use abs= or low=/high=")
            a, b = nominal * (1 - self.rel), nominal * (1 + self.rel)
            low, high = min(a, b), max(a, b)
        elif self.abs is not None:
            _width(name, "abs", self.abs)
            low, high = nominal - self.abs, nominal + self.abs
        else:
            if self.low is None or self.high is None:
                raise _bad(f"{name}: Uniform needs both low= and high=")
            low, high = _finite(name, "low", self.low), _finite(name, "high", self.high)
            if high < low:
                raise _bad(f"{name}: Uniform high = {high} < low = {low} (a negative width)")
        return ("uniform", float(low), float(high), float(low), float(high))


@dataclass(frozen=True)
class Normal:
    """Normal with mean (default: nominal) and std, or std = rel·|nominal|; draws are
    clamped into [low, high]."""

    std: Optional[float] = None
    rel: Optional[float] = None
    mean: Optional[float] = None
    low: float = -math.inf
    high: float = math.inf

    def __post_init__(self):
        _numbers(self, ("std", "rel", "mean"))
        _numbers(self, ("low", "high"), optional=False)

    def resolve(self, name: str, nominal: float):
        if (self.std is None) == (self.rel is None):
            raise _bad(f"{name}: Normal takes exactly one of std= or rel=")
        mean = nominal if self.mean is None else _finite(name, "mean", self.mean)
        if self.rel is not None:
            _width(name, "rel", self.rel)
            if nominal == 0:  # std would be 0: every draw the nominal value
                raise _bad(f"{name}: rel= needs a nonzero nominal value (it is 0); use std=")
            std = self.rel * abs(nominal)
        else:
            _width(name, "std", self.std)
            std = float(self.std)
        # The bounds may be infinite (no clamp), not NaN (which would compare false).
        if math.isnan(self.low) or math.isnan(self.high):
            raise _bad(f"{name}: Normal low = {self.low}, high = {self.high}: a bound is NaN")
        if self.high < self.low:
            raise _bad(f"{name}: Normal high = {self.high} < low = {self.low}")
        return ("normal", float(mean), float(std), float(self.low), float(self.high))


def _numbers(dist, fields, optional=True) -> None:
    """Refuses, when the distribution is made, a field that is not a real number (or
    None, where `optional`)."""
    for f in fields:
        value = getattr(dist, f)
        if not (optional and value is None) and (isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))):
            raise _bad(f"{type(dist).__name__}({f}={value!r}): {f} must be a number, got {type(value).__name__}")


def _width(name, what, value):
    if not (math.isfinite(value) and value >= 0):
        raise _bad(f"{name}: {what} = {value} must be a finite number >= 0 (a negative width)")


def _finite(name, what, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise _bad(f"{name}: {what} = {value!r} must be a number") from None
    if not math.isfinite(value):
        raise _bad(f"{name}: {what} = {value} must be a finite number")
    return value


def _planar_draw(model, x0, perturbations, seed, index):
    params, x0 = _core.sweep_planar_draw(model, x0, perturbations, seed, index)
    return params, None, x0  # flat ground: no slope


@dataclass(frozen=True)
class _Family:
    """What differs between 2-DOF (SlopeModel) and 3-DOF tracking (PlanarModel) sweeps."""

    planar: bool  # flat ground (no slope to perturb)
    states: Tuple[str, ...]
    draw: Callable  # (model, x0, perturbations, seed, i) -> (params dict, slope or None, x0)
    raw: Callable  # the core's sweep of samples start..start + count


_SLOPE = _Family(False, STATE_NAMES, _core.sweep_draw, _core.sweep_raw)
_PLANAR = _Family(True, PLANAR_STATE_NAMES, _planar_draw, _core.sweep_planar_raw)


def _family(sc) -> _Family:
    return _PLANAR if isinstance(sc.model, _core.PlanarModel) else _SLOPE


def kernel_for(sc, realism=None) -> str:
    """The core's kernel for a sweep of Scenario `sc`: "python" (a user's controller),
    "realism", "planar", "planar-realism", "lanes" (LQR, vectorised) or "general"."""
    if user_sweep.is_user_controller(sc.controller):
        return "python"
    return _core.sweep_kernel(sc.controller, realism is not None)


def _target(name: str, sc):
    """(kind, index) of a perturbation name: ("param", field), ("slope", 0) or ("x0", entry)."""
    fields = list(_core.RobotParams.fields)
    family = _family(sc)
    states = family.states
    if name in fields:
        return ("param", fields.index(name))
    if name == "slope":
        if family.planar:
            raise _bad(
                f"perturbation 'slope': '{sc.name}' is a 3-DOF tracking scenario on flat ground (PlanarModel), "
                "it has no slope to perturb"
            )
        return ("slope", 0)
    if name in states:
        return ("x0", states.index(name))
    if name.startswith("x0[") and name.endswith("]") and name[3:-1].isdigit() and int(name[3:-1]) < len(states):
        return ("x0", int(name[3:-1]))
    slope = "" if family.planar else "'slope', "
    raise _bad(
        f"unknown perturbation '{name}'; perturb RobotParams fields ({', '.join(fields)}), "
        f"{slope}or initial-state entries ({', '.join(states)} or x0[0]..x0[{len(states) - 1}])"
    )


def _resolve(perturb: Mapping, scenario) -> list:
    """Perturbations as tuples for the core, in key order (the draw order)."""
    out = []
    for name, dist in (perturb or {}).items():
        kind, index = _target(name, scenario)
        if kind == "param":
            nominal = getattr(scenario.model.params, name)
        elif kind == "slope":
            nominal = scenario.model.slope
        else:
            nominal = float(scenario.x0[index])
        if not isinstance(dist, (Uniform, Normal)):
            raise _bad(f"{name}: expected twip.Uniform or twip.Normal, got {dist!r}")
        if kind == "param" and isinstance(dist, Uniform) and dist.abs is not None and dist.abs > 0.5 * abs(nominal):
            warnings.warn(f"{name}: ± {dist.abs:g} is more than half the nominal {nominal:g} (absolute, in SI units); "
                          f"for a relative spread use rel= (or ±{dist.abs:g}% on the command line)", stacklevel=3)
        out.append((kind, index) + dist.resolve(name, nominal))
    return out


def wilson_interval(successes: int, n: int, confidence: float = 0.95):
    """Wilson score interval for a binomial proportion."""
    if n <= 0:
        return (0.0, 1.0)
    from statistics import NormalDist

    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    # Clamped to hold p itself (rounding put the bound 1e-17 past p = 0 or 1).
    return (max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half)))


@dataclass
class SweepResult:
    """Per-sample metrics (arrays of length n) and how they were made. `metric_names`:
    "fell", "t_end", then the family's metrics (those of `twip.simulate` on the model), as
    the core reports them."""

    metrics: Dict[str, np.ndarray]
    steps: int
    config: dict
    elapsed: float = 0.0
    kernel: str = ""
    metric_names: Tuple[str, ...] = ("fell", "t_end")
    _scenario: object = field(default=None, repr=False)
    _realism: object = field(default=None, repr=False)
    #: {sample index: twip.SimResult}: the decimated trajectories asked for with `traces=`.
    traces: Dict[int, object] = field(default_factory=dict, repr=False)
    #: One motor's stall current [A] given to montecarlo: summary() counts the samples above it.
    stall_current: Optional[float] = field(default=None, repr=False)

    @property
    def n(self) -> int:
        return len(self.metrics["valid"])

    def perturbation_target(self, name: str):
        """(kind, index) of a perturbation name of this sweep: ("param", field index),
        ("slope", 0) or ("x0", state index)."""
        return _target(name, self._scenario)

    @property
    def seed(self) -> int:
        return self.config["seed"]

    @property
    def realism(self):
        """The `twip.Realism` the samples ran with (None: the ideal loop)."""
        return self._realism

    @property
    def state_names(self) -> Tuple[str, ...]:
        """The names of the initial-state entries (STATE_NAMES, or PLANAR_STATE_NAMES)."""
        return _family(self._scenario).states

    @property
    def valid(self) -> np.ndarray:
        return self.metrics["valid"]

    @property
    def fall_rate(self) -> float:
        v = self.valid
        return float(np.mean(self.metrics["fell"][v])) if v.any() else float("nan")

    def fall_rate_interval(self, confidence: float = 0.95):
        v = self.valid
        return wilson_interval(int(np.sum(self.metrics["fell"][v])), int(np.sum(v)), confidence)

    def quantiles(self, name: str, q=(0.05, 0.5, 0.95)) -> np.ndarray:
        """Quantiles of a metric over valid samples that did not fall."""
        keep = self.valid & ~self.metrics["fell"]
        values = self.metrics[name][keep]
        return np.quantile(values, q) if len(values) else np.full(len(q), np.nan)

    def _invalid_indices(self, limit: int) -> np.ndarray:
        return self.metrics["index"][~self.valid][:limit]

    def invalid_reasons(self) -> Dict[str, int]:
        """{reason: count} of the samples that drew a robot no model takes (each drawn
        again and checked); at most MAX_CLASSIFIED are classified, the rest counted as
        "not classified"."""
        counts: Dict[str, int] = {}
        total = self._invalid_count()
        for i in self._invalid_indices(MAX_CLASSIFIED):
            reason = _invalid_reason(self, int(i))
            counts[reason] = counts.get(reason, 0) + 1
        if total > sum(counts.values()):
            counts["not classified"] = total - sum(counts.values())
        return counts

    def _invalid_count(self) -> int:
        return int(np.sum(~self.valid))

    def summary(self) -> dict:
        lo, hi = self.fall_rate_interval()
        out = {
            "samples": self.n,
            "invalid": self._invalid_count(),
            "invalid_reasons": self.invalid_reasons(),
            "fall_rate": self.fall_rate,
            "fall_rate_95ci": (lo, hi),
            "sample_steps_per_second": self.steps / self.elapsed if self.elapsed > 0 else float("nan"),
        }
        if self.stall_current is not None and "peak_current" in self.metric_names:
            out["over_stall_current"] = self.over_stall_current(self.stall_current)
        for name in self._summary_metrics():
            out[name] = dict(zip(("q05", "median", "q95"), map(float, self.quantiles(name))))
        return out

    def _summary_metrics(self):
        return self.metric_names[2:]

    def drawn(self, name: str, index=None) -> np.ndarray:
        """The value drawn for perturbed quantity `name` (as in `perturb=`: a RobotParams
        field, 'slope', 'phi0', 'x0[0]'...) in each sample of `index` (default: all)."""
        kind, at = self.perturbation_target(name)
        index = np.asarray(self.metrics["index"] if index is None else index, dtype=np.int64)
        sc, perturbations = self._scenario, [tuple(p) for p in self.config["perturbations"]]
        out = np.empty(len(index))
        for k, i in enumerate(index):  # the raw draw: an invalid robot has its values too
            params, slope, x0 = _family(sc).draw(sc.model, sc.x0, perturbations, self.seed, int(i))
            out[k] = slope if kind == "slope" else x0[at] if kind == "x0" else params[name]
        return out

    def table(self, part: Optional[Mapping] = None) -> Dict[str, np.ndarray]:
        """Columns for analysis, each named with its SI unit: the sample index, validity,
        the value drawn for every perturbed quantity (`m_body[kg]`), then every metric
        (`pitch_error_mean[rad]` style: `mean_abs_pitch_error[rad]`). `part`: a subset of
        `metrics` (one shard of a streamed sweep); default all."""
        from twip.plot import si_unit
        from twip.robot_file import FIELDS

        part = self.metrics if part is None else part
        out: Dict[str, np.ndarray] = {"index": np.asarray(part["index"]), "valid": np.asarray(part["valid"])}
        for name in self.config["perturb"]:
            kind, at = self.perturbation_target(name)
            unit = (FIELDS[name][0] if kind == "param" else "rad" if kind == "slope"
                    else _STATE_UNITS[self.state_names[at]])
            out[f"{name}[{unit}]"] = self.drawn(name, part["index"])
        for name in self.metric_names:
            unit = "s" if name == "t_end" else si_unit(name)
            out[f"{name}[{unit}]" if unit else name] = np.asarray(part[name])
        return out

    def to_pandas(self):
        """A DataFrame, one row per sample, columns as `table()` names them (needs pandas)."""
        import pandas as pd

        return pd.DataFrame(self.table())

    def over_stall_current(self, stall_current: float) -> int:
        """How many samples asked one motor for more than `stall_current` [A]."""
        peak = np.asarray(self.metrics.get("peak_current", []), float)
        return int(np.sum(peak > stall_current))

    def sample(self, index: int):
        """The robot, slope and initial state of sample `index` (slope None for a 3-DOF
        tracking scenario: its ground is flat)."""
        sc = self._scenario
        perturbations = [tuple(p) for p in self.config["perturbations"]]
        params, slope, x0 = _family(sc).draw(sc.model, sc.x0, perturbations, self.seed, int(index))
        return _core.RobotParams.from_dict(params), slope, x0

    def rerun(self, index: int) -> dict:
        """Runs sample `index` alone through the sweep engine again: its metrics, bit
        for bit those of the sweep (a sample does not depend on the others)."""
        if not 0 <= int(index) < self.config["n"]:
            raise _bad(f"index = {index}: this sweep has samples 0..{self.config['n'] - 1}")
        raw = _run(self._scenario, self.config, int(index), 1, 1, None, self._realism)
        return {name: raw[name][0] for name in ("valid",) + tuple(self.metric_names)}

    def replay(self, index: int, **simulate_options):
        """Runs sample `index` alone with the full runner (its trajectory included), with
        the sweep's realism and the sample's own noise stream. Its metrics are the
        sweep's bit for bit, except for LQR sweeps without realism (kernel "lanes"),
        whose lane kernel fuses multiply-adds: there they agree to ~1e-13 relative."""
        from twip.sim import simulate

        sc = self._scenario
        params, slope, x0 = self.sample(index)
        model = _core.PlanarModel(params) if slope is None else _core.SlopeModel(params, slope)
        if self._realism is not None:
            noise = self._realism.replace(seed=_core.sweep_noise_seed(self.seed), stream=int(index))
            simulate_options = {"realism": noise, **simulate_options}
        return simulate(model, sc.controller, x0, sc.t_final, sc.dt, reference=sc.reference,
                        control_period=sc.control_period, **simulate_options)

    def __repr__(self) -> str:
        s = self.summary()
        lo, hi = s["fall_rate_95ci"]
        lines = [
            f"SweepResult: {self.config['scenario']}, {s['samples']} samples ({s['invalid']} invalid), seed {self.seed}",
            *(f"  invalid: {count} {reason}" for reason, count in s["invalid_reasons"].items()),
            f"  fall rate {s['fall_rate']:.4f}  (95 % CI {lo:.4f} - {hi:.4f})",
            f"  {self.steps:,} RK4 steps in {self.elapsed:.2f} s: {s['sample_steps_per_second'] / 1e6:.1f} M sample-steps/s ({self.kernel})",
            f"  {'metric':24s} {'q05':>11s} {'median':>11s} {'q95':>11s}",
        ]
        for name in self.metric_names[2:]:
            q = s[name]
            lines.append(f"  {name:24s} {q['q05']:11.4g} {q['median']:11.4g} {q['q95']:11.4g}")
        return "\n".join(lines)


#: At most this many invalid samples are drawn again to classify their reason.
MAX_CLASSIFIED = 10_000


def _invalid_reason(result, index: int) -> str:
    """Why sample `index` is invalid: the model's complaint about its robot, without the
    value (so that samples group), e.g. "m_body: must be > 0"."""
    sc = result._scenario
    perturbations = [tuple(p) for p in result.config["perturbations"]]
    try:
        params, slope, x0 = _family(sc).draw(sc.model, sc.x0, perturbations, result.seed, index)
        robot = _core.RobotParams.from_dict(params)
        _core.PlanarModel(robot) if slope is None else _core.SlopeModel(robot, slope)
        if result.realism is not None:
            _core.simulate_raw(_core.SlopeModel(robot, slope), sc.controller, x0, sc.dt, sc.dt,
                               sc.reference, realism=result.realism)
    except _core.TwipError as e:
        text = str(e)
        if text.startswith("invalid ") and " = " in text and ": " in text:
            name, rest = text[len("invalid "):].split(" = ", 1)
            return f"{name}: {rest.split(': ', 1)[1]}"
        return text
    return "the model refused the robot for a reason it did not name"


class StreamedSweepResult(SweepResult):
    """A checkpointed sweep too large for memory: its metrics stay in the shards on disk
    and every summary (fall rate, Wilson interval, quantiles, invalid samples) is read
    back from them one shard at a time. `shards()` yields the per-shard metric arrays."""

    def __init__(self, store, layout, finished, config, elapsed, kernel, sc, realism, names, steps):
        super().__init__(metrics={}, steps=steps, config=config, elapsed=elapsed, kernel=kernel,
                         metric_names=names, _scenario=sc, _realism=realism)
        self._store = store
        self._layout = [(s, c) for s, c in layout if s in finished]
        self._tally = None
        self._summary = None

    @property
    def metrics(self):
        raise budget.MemoryBudgetError(
            f"this sweep's {self.config['n']:,} samples do not fit the memory budget: their metrics stay in "
            f"the checkpoint {self._store.dir}; use summary(), quantiles(), fall_rate or shards()")

    @metrics.setter
    def metrics(self, value):  # SweepResult.__init__ sets {}: nothing is kept
        pass

    @classmethod
    def of(cls, store, layout, finished, config, elapsed, kernel, sc, realism):
        first = next(store.shards([(s, c) for s, c in layout if s in finished][:1]), None)
        names = (tuple(str(v) for v in np.asarray(first["metric_names"]).tolist()) if first is not None
                 else ("fell", "t_end"))
        out = cls(store, layout, finished, config, elapsed, kernel, sc, realism, names, 0)
        out.steps = out._counts()["steps"]
        return out

    def shards(self):
        """Per-shard metric arrays (index, valid, fell, the metrics...), in sample order."""
        return self._store.shards(self._layout)

    def over_stall_current(self, stall_current: float) -> int:
        return sum(int(np.sum(np.asarray(part["peak_current"], float) > stall_current)) for part in self.shards())

    def _counts(self) -> dict:
        if self._tally is None:
            t = dict(samples=0, valid=0, fell=0, steps=0, invalid=[])
            for part in self.shards():
                valid = part["valid"].astype(bool)
                t["samples"] += len(valid)
                t["valid"] += int(valid.sum())
                t["fell"] += int(part["fell"].astype(bool)[valid].sum())
                t["steps"] += int(part["steps"].sum())
                if len(t["invalid"]) < MAX_CLASSIFIED:
                    t["invalid"].extend(part["index"][~valid][: MAX_CLASSIFIED - len(t["invalid"])].tolist())
            self._tally = t
        return self._tally

    @property
    def n(self) -> int:
        return self._counts()["samples"]

    @property
    def valid(self):
        return self.metrics["valid"]  # refused, with the way to the summaries

    @property
    def fall_rate(self) -> float:
        t = self._counts()
        return t["fell"] / t["valid"] if t["valid"] else float("nan")

    def fall_rate_interval(self, confidence: float = 0.95):
        t = self._counts()
        return wilson_interval(t["fell"], t["valid"], confidence)

    def _invalid_count(self) -> int:
        t = self._counts()
        return t["samples"] - t["valid"]

    def _invalid_indices(self, limit: int) -> np.ndarray:
        return np.asarray(self._counts()["invalid"][:limit], dtype=np.uint64)

    def quantiles(self, name: str, q=(0.05, 0.5, 0.95)) -> np.ndarray:
        """As SweepResult.quantiles (numpy's linear interpolation), exact, read from the shards."""
        return self.quantiles_of([name], q)[name]

    def quantiles_of(self, names, q=(0.05, 0.5, 0.95)) -> Dict[str, np.ndarray]:
        """{name: quantiles(name, q)} for several metrics, in the same passes over the shards."""
        for name in names:
            if name not in self.metric_names[1:]:
                raise _bad(f"quantiles: unknown metric '{name}'; this sweep has {', '.join(self.metric_names[1:])}")

        def values():
            for part in self.shards():
                keep = part["valid"].astype(bool) & ~part["fell"].astype(bool)
                yield {name: part[name][keep].astype(float) for name in names}

        return streamed_quantiles_of(values, list(names), q)

    def _summary_metrics(self):
        return ()  # summary() takes them all in the same passes

    def summary(self) -> dict:
        if self._summary is None:  # a few passes over the shards: once
            out = super().summary()
            for name, q in self.quantiles_of(self.metric_names[2:]).items():
                out[name] = dict(zip(("q05", "median", "q95"), map(float, q)))
            self._summary = out
        return dict(self._summary)

    def to_pandas(self):
        return self.metrics  # refused: the metrics do not fit in memory


def _scenario_of(scenario, params, options):
    from twip import scenarios

    if isinstance(scenario, str):
        return scenarios.get(scenario, params=params, **(options or {}))
    if params is not None or options:
        raise _bad("params= and options= go with a scenario name, not a Scenario object")
    return scenario


def _realism_config(r) -> dict:
    """A Realism as plain JSON values (for the checkpoint fingerprint and Dask workers),
    without seed and stream, which a sweep replaces."""
    c = json.loads(r.to_json())
    del c["seed"], c["stream"]
    return c


def _realism_from_config(c: dict):
    """The Realism `_realism_config` describes (seed and stream 0)."""
    return _core.Realism.from_json(json.dumps(c))


def _config(sc, scenario, n, seed, perturbations, options, perturb_keys, realism=None):
    extra = {} if realism is None else {"realism": _realism_config(realism)}
    return {
        "scenario": sc.name,
        "by_name": isinstance(scenario, str),
        "options": dict(options or {}),
        "params": sc.model.params.to_dict(),
        "slope": None if _family(sc).planar else sc.model.slope,
        "x0": [float(v) for v in sc.x0],
        "t_final": sc.t_final,
        "dt": sc.dt,
        "control_period": sc.control_period,
        "reference": repr(sc.reference),
        # The whole controller (gains, period, fuzzy sets, its model...), not its short repr.
        "controller": (user_sweep.fingerprint(sc.controller) if user_sweep.is_user_controller(sc.controller)
                       else _core.controller_fingerprint(sc.controller)),
        "perturb": list(perturb_keys),
        "perturbations": [list(p) for p in perturbations],
        "seed": int(seed),
        "n": int(n),
        "twip": _core.__version__,
        **extra,
    }


def _run(sc, config, start, count, threads, progress, realism=None):
    family = _family(sc)
    if user_sweep.is_user_controller(sc.controller):  # worker processes, not threads
        return user_sweep.run(sc, family, config, start, count, threads, progress, realism)
    return family.raw(sc.model, sc.controller, sc.x0, sc.t_final, sc.dt, sc.reference,
                      [tuple(p) for p in config["perturbations"]], config["seed"], start, count,
                      control_period=sc.control_period, threads=threads, progress=progress, realism=realism)


def _run_shard_by_name(config, start, count, threads):
    """A Dask task: rebuilds the scenario (and realism) on the worker and runs one shard."""
    from twip import scenarios

    params = _core.RobotParams.from_dict(config["params"])
    sc = scenarios.get(config["scenario"], params=params, **config["options"])
    realism = _realism_from_config(config["realism"]) if "realism" in config else None
    raw = _run(sc, config, start, count, threads, None, realism)
    return {k: (np.asarray(v) if not isinstance(v, (str, bool)) else v) for k, v in raw.items()}


class _Bar:
    """tqdm when installed and wanted, else nothing."""

    def __init__(self, total, enabled):
        self.bar = None
        if enabled:
            try:
                from tqdm.auto import tqdm

                self.bar = tqdm(total=total, unit="samples", smoothing=0.1)
            except ImportError:
                pass
        self.base = 0

    def update_to(self, done):
        if self.bar is not None:
            self.bar.n = self.base + done
            self.bar.refresh()

    def close(self):
        if self.bar is not None:
            self.bar.close()


def montecarlo(
    scenario,
    n: int,
    perturb: Optional[Mapping] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    progress: bool = True,
    checkpoint=None,
    client=None,
    shard_size: Optional[int] = None,
    params=None,
    options: Optional[Mapping] = None,
    realism=None,
    traces: Optional[Sequence[int]] = None,
    trace_every: int = 10,
    stall_current: Optional[float] = None,
) -> SweepResult:
    """Runs `n` samples of `scenario` (a name from `twip.scenarios.names()`, or a Scenario).

    perturb: {"m_body": twip.Uniform(rel=0.2), "slope": twip.Uniform(low=0, high=0.2),
              "phi0": twip.Normal(std=0.02), ...}; drawn in key order, per sample. The
              initial state of a 3-DOF tracking scenario is PLANAR_STATE_NAMES (no slope).
    threads: worker threads (default: all cores). checkpoint: a folder; the sweep is
    written there in shards and a re-run with the same arguments resumes. client: a
    dask.distributed.Client; shards run as Dask tasks (needs a scenario name).
    realism: a `twip.Realism`: sensors, estimator, motor drivers, loop period and
    delay, disturbances in every run (2-DOF and 3-DOF tracking scenarios). Sample i's noise is stream i of a key
    made from `seed`; the realism's own seed and stream are ignored.
    traces: a few sample indices whose trajectories to keep, logged every `trace_every`
    steps, in `SweepResult.traces` (each replayed alone with the full runner, see replay).
    Ctrl-C stops within a fraction of a second: finished shards stay in the checkpoint,
    and the KeyboardInterrupt carries `.partial`, a SweepResult of what finished.
    Memory: when n samples' metrics do not fit the memory budget (`twip.set_memory_budget`),
    a sweep needs `checkpoint=`; it then keeps them on disk and returns a
    StreamedSweepResult, whose summaries are read back shard by shard.
    """
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n <= 0:
        raise _bad(f"n = {n!r}: the number of samples must be a positive integer")
    if not isinstance(seed, (int, np.integer)) or seed < 0 or seed >= 2**64:
        raise _bad(f"seed = {seed!r}: must be an integer in [0, 2**64)")
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise _bad(f"threads = {threads!r}: must be a positive integer or None (all cores)")
    if client is not None and not isinstance(scenario, str):
        raise _bad("client= (Dask) needs a scenario name, so that workers can rebuild it")
    traces = _trace_indices(traces, n, trace_every)
    if realism is not None and not isinstance(realism, _core.Realism):
        raise _bad(f"realism = {realism!r}: must be a twip.Realism or None")
    sc = _scenario_of(scenario, params, options)
    if traces:  # each replay checks its own log; together they must fit too
        from twip.sim import log_shape_guess

        rows, columns = log_shape_guess(sc.model, sc.t_final, sc.dt, trace_every, realism)
        budget.check(f"montecarlo: traces of {len(traces)} samples ({rows:,.0f} rows x {columns} columns each)",
                     len(traces) * rows * columns * 8, "keep fewer traces= or log them sparser with trace_every=")
    perturbations = _resolve(perturb or {}, sc)
    config = _config(sc, scenario, n, seed, perturbations, options, (perturb or {}).keys(), realism)
    if stall_current is not None:  # summary() counts the samples that asked more of a motor
        stall_current = _finite("stall_current", "the stall current [A]", stall_current)
        if stall_current <= 0:
            raise _bad(f"stall_current = {stall_current}: must be > 0 [A]")
    if shard_size is None:
        # Checkpointed sweeps keep at most MAX_SHARDS files (n = 10**9: shards of 10**5).
        shard = max(DEFAULT_SHARD, -(-n // MAX_SHARDS)) if (checkpoint or client) else n
    elif isinstance(shard_size, bool) or not isinstance(shard_size, (int, np.integer)) or shard_size <= 0:
        raise _bad(f"shard_size = {shard_size!r}: must be a positive integer")
    else:
        shard = int(shard_size)
    # Memory: all the metrics when they fit the budget, else (with a checkpoint) a
    # shard at a time, the summaries read back from the shards.
    in_memory = fits_in_memory(n)
    if checkpoint is None:
        budget.check(f"montecarlo: n = {n:,} samples", n * BYTES_PER_SAMPLE,
                     "pass checkpoint=FOLDER to stream the sweep to disk in shards")
    else:
        budget.check(f"montecarlo: a shard of shard_size = {shard:,} samples", shard * BYTES_PER_SAMPLE,
                     "pass a smaller shard_size")
    store = Checkpoint(checkpoint, config, shard) if checkpoint is not None else None
    try:
        result = _sweep(sc, config, n, shard, store, in_memory, client, threads, progress, realism, traces, trace_every)
        result.stall_current = stall_current
        return result
    except KeyboardInterrupt as stop:
        if getattr(stop, "partial", None) is not None:
            stop.partial.stall_current = stall_current
        raise
    finally:
        if store is not None:
            store.close()


def fits_in_memory(n: int) -> bool:
    """Whether the metrics of an n-sample sweep fit the memory budget (else a sweep
    needs checkpoint= and returns a StreamedSweepResult)."""
    return n * BYTES_PER_SAMPLE <= budget.memory_budget()


def _sweep(sc, config, n, shard, store, in_memory, client, threads, progress, realism, traces, trace_every):
    layout = [(s, min(shard, n - s)) for s in range(0, n, shard)]
    parts = {}
    finished = set()
    if store is not None:  # verified one shard at a time; kept only when in memory
        for s, c in layout:
            raw = store.read(s, c)
            if raw is not None:
                finished.add(s)
                if in_memory:
                    parts[s] = raw
    todo = [(s, c) for s, c in layout if s not in finished]
    bar = _Bar(n, progress)
    bar.base = sum(c for s, c in layout if s in finished)
    started = time.perf_counter()
    kernel = kernel_for(sc, realism)

    def keep(s, raw):
        if store is not None:
            store.save(s, raw)
        finished.add(s)
        if in_memory or store is None:
            parts[s] = raw

    try:
        if client is not None:
            futures = {client.submit(_run_shard_by_name, config, s, c, threads or 1, pure=False): s for s, c in todo}
            from dask.distributed import as_completed

            for future in as_completed(futures):
                raw = future.result()
                keep(futures[future], raw)
                bar.base += len(raw["index"])
                bar.update_to(0)
        else:
            for s, c in todo:
                raw = _run(sc, config, s, c, threads or 0, bar.update_to if progress else None, realism)
                if raw["interrupted"]:
                    parts[s] = raw
                    raise KeyboardInterrupt
                keep(s, raw)
                bar.base += c
    except KeyboardInterrupt as stop:
        elapsed = time.perf_counter() - started
        stop.partial = (_assemble(parts, config, elapsed, kernel, sc, complete=False, realism=realism)
                        if in_memory or store is None else
                        StreamedSweepResult.of(store, layout, finished, config, elapsed, kernel, sc, realism))
        raise
    finally:
        bar.close()
    elapsed = time.perf_counter() - started
    if not (in_memory or store is None):
        return StreamedSweepResult.of(store, layout, finished, config, elapsed, kernel, sc, realism)
    result = _assemble(parts, config, elapsed, kernel, sc, complete=True, realism=realism)
    result.traces = {i: result.replay(i, record_every=trace_every) for i in traces}
    return result


MAX_TRACES = 100


def _trace_indices(traces, n, every) -> list:
    """The sample indices of `traces=`, checked: distinct, in range, a few."""
    if traces is None:
        return []
    if isinstance(traces, (int, np.integer)):
        traces = [traces]
    out = []
    for i in traces:
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < n:
            raise _bad(f"traces: sample index {i!r} is not in 0..{n - 1}")
        out.append(int(i))
    if len(set(out)) > MAX_TRACES:
        raise _bad(f"traces: {len(set(out))} samples; a sweep keeps at most {MAX_TRACES} trajectories "
                   "(metrics are kept for every sample)")
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise _bad(f"trace_every = {every!r}: must be an integer >= 1 (log every that many steps)")
    return sorted(set(out))


def _assemble(parts, config, elapsed, kernel, sc, complete, realism=None):
    keys = sorted(parts)
    cat = lambda name: np.concatenate([np.asarray(parts[k][name]) for k in keys]) if keys else np.array([])
    done = cat("done").astype(bool) if keys else np.zeros(0, bool)
    if complete and (len(done) != config["n"] or not done.all()):
        raise RuntimeError("internal error: a sweep finished with missing samples")
    # The core names its metrics in every shard; before any shard, only the common ones.
    names = tuple(str(n) for n in np.asarray(parts[keys[0]]["metric_names"]).tolist()) if keys else ("fell", "t_end")
    metrics = {"index": cat("index").astype(np.uint64), "valid": cat("valid").astype(bool)}
    for name in names:
        metrics[name] = cat(name).astype(bool) if name == "fell" else cat(name).astype(float)
    if not complete:
        metrics = {k: v[done] for k, v in metrics.items()}
    steps = int(np.sum(cat("steps"))) if keys else 0
    return SweepResult(metrics=metrics, steps=steps, config=config, elapsed=elapsed, kernel=kernel,
                       metric_names=names, _scenario=sc, _realism=realism)
