"""What a sweep returns: `SweepResult` (per-sample metrics in memory) and
`StreamedSweepResult` (a checkpointed sweep too large for memory, summarised shard by
shard), with the ways back to one sample (`sample`, `drawn`, `rerun`, `replay`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, Mapping, Optional, Tuple

import numpy as np

from twip import _core, budget, checks
from twip.distributions import wilson_interval
from twip.perturbation import STATE_UNITS, family_of, ground_controller, ground_model, ground_value, target
from twip.quantiles import levels, no_values, streamed_quantiles_of

_bad = _core.InvalidParameterError


@dataclass
class SweepResult:
    """Per-sample metrics (arrays of length n) and how they were made. `metric_names`:
    "fell", "t_end", then the family's metrics (those of `twip.simulate` on the model), as
    the core reports them. It pickles (a process pool may return it, joblib may cache it)
    with its scenario and realism, so `replay` and `rerun` work on the copy (loaded by the
    twip that made it: another refuses them, as its draws and runs may differ)."""

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
    #: {sample index: message} of the samples whose Python controller raised or returned a
    #: `u` that is not finite (montecarlo(on_error="record")); each is counted invalid.
    errors: Dict[int, str] = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        return len(self.metrics["valid"])

    def perturbation_target(self, name: str):
        """(kind, index) of a perturbation name of this sweep: ("param", field index),
        ("slope", 0) or ("x0", state index)."""
        return target(name, self._scenario)

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
        return family_of(self._scenario).states

    @property
    def valid(self) -> np.ndarray:
        return self.metrics["valid"]

    @property
    def fall_rate(self) -> float:
        v = self.valid
        return float(np.mean(self.metrics["fell"][v])) if v.any() else float("nan")

    @property
    def lift_rate(self) -> float:
        """The share of valid samples whose run ended "lifted" (a wheel's normal force went
        negative, on terrain: counted in `fall_rate` too); NaN without valid samples or in
        a sweep that does not tell (2-DOF)."""
        v = self.valid
        lifted = self.metrics.get("lifted")
        return float(np.mean(lifted[v] == 1.0)) if lifted is not None and v.any() else float("nan")

    def fall_rate_interval(self, confidence: float = 0.95):
        v = self.valid
        return wilson_interval(int(np.sum(self.metrics["fell"][v])), int(np.sum(v)), confidence)

    def quantiles(self, name: str, q=(0.05, 0.5, 0.95)) -> np.ndarray:
        """Quantiles of a metric over valid samples that did not fall (np.quantile's, shaped as
        q: a float for a scalar q); NaN when every sample fell."""
        check_quantiles(self, [name], q)
        keep = self.valid & ~self.metrics["fell"]
        values = self.metrics[name][keep]
        return np.quantile(values, q) if len(values) else no_values(np.shape(q))

    def _invalid_indices(self, limit: int) -> np.ndarray:
        return self.metrics["index"][~self.valid][:limit]

    def invalid_reasons(self) -> Dict[str, int]:
        """{reason: count} of the samples that drew a robot no model takes (each drawn
        again and checked); at most MAX_CLASSIFIED are classified, the rest counted as
        "not classified"."""
        counts: Dict[str, int] = {}
        total = self._invalid_count()
        for i in self._invalid_indices(MAX_CLASSIFIED):
            reason = invalid_reason(self, int(i))
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
        out["warnings"] = unsettled_warnings(out, self.metric_names[2:])
        return out

    def _summary_metrics(self):
        return self.metric_names[2:]

    def drawn(self, name: str, index=None) -> np.ndarray:
        """The value drawn for perturbed quantity `name` (as in `perturb=`: a RobotParams
        field, 'slope', 'phi0', 'x0[0]'...) in each sample of `index` (a list of sample indices;
        default: all)."""
        kind, at = self.perturbation_target(name)
        try:  # each a sample of this sweep, as sample() takes it
            index = [self._index(i) for i in (self.metrics["index"] if index is None else index)]
        except TypeError:  # not iterable
            raise TypeError(f"index must be a list of sample indices (or None: all), got {index!r} "
                            f"({type(index).__name__})") from None
        sc, perturbations = self._scenario, [tuple(p) for p in self.config["perturbations"]]
        out = np.empty(len(index))
        for k, i in enumerate(index):  # the raw draw: an invalid robot has its values too
            params, ground, x0 = family_of(sc).draw(sc.model, sc.x0, perturbations, self.seed, i)
            out[k] = (ground_value(ground, kind) if kind in ("slope", "heading") else x0[at] if kind == "x0"
                      else params[name])
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
            unit = (FIELDS[name][0] if kind == "param" else "rad" if kind in ("slope", "heading")
                    else STATE_UNITS[self.state_names[at]])
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
        stall_current = checks.real("stall_current", stall_current, above=0)
        peak = np.asarray(self.metrics.get("peak_command", self.metrics.get("peak_current", [])), float)
        return int(np.sum(peak > stall_current))

    def sample(self, index: int):
        """The robot, ground and initial state of sample `index`: the ground is a 2-DOF
        sample's slope; a 3-DOF sample's None on flat ground, else (slope, heading, terrain)
        drawn (slope and heading None on a terrain without a plane)."""
        sc = self._scenario
        perturbations = [tuple(p) for p in self.config["perturbations"]]
        params, slope, x0 = family_of(sc).draw(sc.model, sc.x0, perturbations, self.seed, self._index(index))
        return _core.RobotParams.from_dict(params), slope, x0

    def _index(self, index) -> int:
        """`index` as a sample of this sweep, else an error naming it and the range; and an
        error for a sweep another twip made (a result pickled or checkpointed then), whose
        draws and runs this twip need not give bit for bit: every way back to a sample
        (`sample`, `drawn`, `rerun`, `replay`) passes here."""
        made_by = self.config.get("twip")
        if made_by is not None and made_by != _core.__version__:
            raise _bad(f"this sweep was made by twip {made_by}, and this is twip {_core.__version__}, whose draws and "
                       "runs may differ: its samples cannot be drawn or run again here; use twip "
                       f"{made_by}, or run the sweep again")
        n = self.config["n"]
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= int(index) < n:
            raise _bad(f"index = {index!r}: this sweep has samples 0..{n - 1}")
        return int(index)

    def rerun(self, index: int) -> dict:
        """Runs sample `index` alone through the sweep engine again: its metrics, bit
        for bit those of the sweep (a sample does not depend on the others)."""
        index = self._index(index)
        from twip.sweep import run_samples  # the sweep imports this module

        raw = run_samples(self._scenario, self.config, int(index), 1, 1, None, self._realism)
        return {name: raw[name][0] for name in ("valid",) + tuple(self.metric_names)}

    def replay(self, index: int, **simulate_options):
        """Runs sample `index` alone with the full runner (its trajectory included), with
        the sweep's realism and the sample's own noise stream. Its metrics are the
        sweep's bit for bit, except on the lane kernels ("lanes", "realism-lanes",
        "planar-lanes" and "planar-realism-lanes"), which fuse multiply-adds: there they agree to ~1e-13 relative,
        and through the rig's quantisers (IMU registers, encoder counts, duty counts) the
        two roundings drift apart at the open-loop pendulum's rate (~1e-8 after 3 s).
        `rerun(index)` gives the sweep's bits on every kernel."""
        from twip.sim import simulate

        sc = self._scenario
        params, ground, x0 = self.sample(index)
        model = ground_model(params, ground, family_of(sc))
        if self._realism is not None:
            noise = self._realism.replace(seed=_core.sweep_noise_seed(self.seed), stream=int(index))
            simulate_options = {"realism": noise, **simulate_options}
        return simulate(model, ground_controller(sc.controller, ground), x0, sc.t_final, sc.dt, reference=sc.reference,
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


def unsettled_warnings(summary: dict, names) -> tuple:
    """A warning when a tracking sweep's _settled metrics are NaN while the others are not:
    its runs ended before their settle time (the one-run case: `twip.sim.unsettled_warnings`)."""
    settled = [n for n in names if n.endswith("_settled")]
    others = [n for n in names if n not in settled]
    if not settled or not all(np.isnan(summary[n]["median"]) for n in settled) or \
            all(np.isnan(summary[n]["median"]) for n in others):
        return ()
    return ("the _settled metrics are NaN: the runs ended before their settle time (by default one lap of the "
            "path); sweep a longer run (the scenario's t_final) to have them",)


#: At most this many invalid samples are drawn again to classify their reason.
MAX_CLASSIFIED = 10_000


def check_quantiles(result, names, q) -> None:
    """Refuses a name that is not one of `result`'s metrics and a level `q` outside [0, 1]."""
    for name in names:
        if name not in result.metric_names[1:]:
            raise _bad(f"quantiles: unknown metric {name!r}; this sweep has {', '.join(result.metric_names[1:])}")
    levels(q)


def invalid_reason(result, index: int) -> str:
    """Why sample `index` is invalid: its controller's failure (`SweepResult.errors`), or the
    model's complaint about its robot, without the value (so that samples group), e.g.
    "m_body: must be > 0"."""
    if index in result.errors:
        from twip.user_sweep import failure_reason

        return failure_reason(result.errors[index])
    sc = result._scenario
    perturbations = [tuple(p) for p in result.config["perturbations"]]
    try:
        params, slope, x0 = family_of(sc).draw(sc.model, sc.x0, perturbations, result.seed, index)
        robot = _core.RobotParams.from_dict(params)
        ground_model(robot, slope, family_of(sc))
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
        stall_current = checks.real("stall_current", stall_current, above=0)
        asked = lambda part: part["peak_command"] if "peak_command" in part else part["peak_current"]  # noqa: E731
        return sum(int(np.sum(np.asarray(asked(part), float) > stall_current)) for part in self.shards())

    def _counts(self) -> dict:
        if self._tally is None:
            t = dict(samples=0, valid=0, fell=0, steps=0, invalid=[], errors={})
            for part in self.shards():
                if "controller_error" in part:
                    t["errors"].update((int(i), str(m)) for i, m in zip(part["index"], part["controller_error"]) if m)
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
    def errors(self):
        return self._counts()["errors"]

    @errors.setter
    def errors(self, value):  # SweepResult.__init__ sets {}: they are read from the shards
        pass

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
        check_quantiles(self, names, q)

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
            out["warnings"] = unsettled_warnings(out, self.metric_names[2:])
            self._summary = out
        return dict(self._summary)

    def to_pandas(self):
        return self.metrics  # refused: the metrics do not fit in memory
