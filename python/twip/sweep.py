"""Monte Carlo robustness sweeps: `twip.montecarlo("flat-lqr", 10_000, perturb={...})`.

The controller of the scenario is designed once on the nominal robot; each sample runs
it on a perturbed plant (RobotParams fields, slope, initial state). The 2-DOF scenarios
(LQR, fuzzy) and the 3-DOF tracking ones (PID, sliding mode on a PlanarModel, flat or on a
terrain: its plane's "slope" and uphill "heading" are sweep axes) run alike; each family has its own metrics (`SweepResult.metric_names`). Sample i draws from
its own counter-based random stream, so a sweep gives the same numbers, bit for bit, on
any number of threads, in shards, resumed after a crash, on a Dask cluster, and when a
sample is run alone again (`SweepResult.rerun(i)`). Replayed with the full runner and its
trajectory (`SweepResult.replay(i)`), a sample is also the sweep's bit for bit, except in
sweeps on the lane kernels (kernel "lanes": LQR, and fuzzy with any sets; kernel
"realism-lanes": the same through a rig; kernel "planar-lanes": PID and sliding-mode
tracking, on flat ground or terrain; kernel "planar-realism-lanes": the same through a rig,
on flat ground or terrain), which fuse multiply-adds: there the metrics agree to ~1e-13 relative (through a
rig's quantisers, over its first seconds: see `SweepResult.replay`).

With `realism=` (a `twip.Realism`) every sample runs with the robot's real parts in the
loop. Sample i's sensor noise is the stream (sweep_noise_seed(seed), i): the
realism's own seed and stream are ignored, so a sample depends on (seed, i) alone and
another sweep seed gives other noise as well as other robots.
"""
from __future__ import annotations

import json
import time
from typing import Mapping, Optional, Sequence

import numpy as np

from twip import _core, budget, checks, user_sweep
from twip.checkpoint import Checkpoint, CheckpointWriteError, checkpoint_folder, ctrl_c_held
from twip.distributions import Normal, Uniform, finite_number, wilson_interval  # noqa: F401 (re-exported)
from twip.perturbation import PLANAR_STATE_NAMES, STATE_NAMES, family_of, kernel_for, resolve  # noqa: F401
from twip.sweep_result import StreamedSweepResult, SweepResult  # noqa: F401

_bad = _core.InvalidParameterError

DEFAULT_SHARD = 1024
#: A sweep is cut into at most this many shards: the default shard size grows to keep
#: within it, a shard_size that would make more is refused.
MAX_SHARDS = 10_000
#: A checkpointed sweep of a Python controller, whose samples are slow, is cut into shards
#: of about this many seconds' work (a Ctrl-C keeps every finished shard).
SHARD_SECONDS = 2.0
#: The layout of a checkpoint shard's columns: bumped when they change (2: the 3-DOF sweeps'
#: lifted and off_terrain columns; 3: those of a Python controller's 3-DOF sweeps).
SHARD_FORMAT = 3
#: Memory one sample of a sweep takes while it runs and when assembled: its metric
#: columns (~100 bytes), the worker's result and the concatenated copy.
BYTES_PER_SAMPLE = 320


def _scenario_of(scenario, params, options):
    from twip import scenarios

    checks.of_type("scenario", scenario, (str, scenarios.Scenario), "a scenario name or a twip.scenarios.Scenario")
    if params is not None:  # a dict of fields failed deep inside the scenario's design
        checks.of_type("params", params, _core.RobotParams, "a twip.RobotParams (from_dict(...) for a dict)")
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


def _config(sc, scenario, n, seed, perturbations, options, perturb_keys, realism=None, on_error="stop"):
    extra = {} if realism is None else {"realism": _realism_config(realism)}
    if user_sweep.is_user_controller(sc.controller):
        # What a failed sample becomes (only a Python controller fails): a checkpoint of
        # recorded failures is not another sweep's that stops at the first.
        extra["on_error"] = on_error
    return {
        "scenario": sc.name,
        "by_name": isinstance(scenario, str),
        "options": dict(options or {}),
        "params": sc.model.params.to_dict(),
        "slope": None if family_of(sc).planar else sc.model.slope,
        **_terrain_config(sc),
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
        # The layout of a shard's columns, so that a folder of an older layout is refused
        # rather than resumed with mixed shards.
        "shard_format": SHARD_FORMAT,
        # The engine that computes the samples: kernels agree to rounding, not bit for bit,
        # so a checkpoint resumes only on the kernel that began it.
        "kernel": kernel_for(sc, realism),
        **extra,
    }


def _terrain_config(sc) -> dict:
    """A 3-DOF scenario's terrain for the checkpoint fingerprint (none on flat ground): its
    constructor call, a grid's heights by their hash."""
    terrain = getattr(sc.model, "terrain", None)
    if terrain is None:
        return {}
    import hashlib
    import pickle

    return {"terrain": repr(terrain), "terrain_sha256": hashlib.sha256(pickle.dumps(terrain)).hexdigest()}


def run_samples(sc, config, start, count, threads, progress, realism=None, on_error="stop"):
    family = family_of(sc)
    if user_sweep.is_user_controller(sc.controller):  # worker processes, not threads
        return user_sweep.run(sc, family, config, start, count, threads, progress, realism, on_error)
    return family.raw(sc.model, sc.controller, sc.x0, sc.t_final, sc.dt, sc.reference,
                      [tuple(p) for p in config["perturbations"]], config["seed"], start, count,
                      control_period=sc.control_period, threads=threads, progress=progress, realism=realism)


def run_shard_by_name(config, start, count, threads):
    """A Dask task: rebuilds the scenario (and realism) on the worker and runs one shard,
    once the worker's sweep is the client's (a worker of another twip, or whose scenario
    comes out otherwise, would mix its own numbers into the result)."""
    from twip import scenarios
    from twip.checkpoint import HOW_GIVEN

    params = _core.RobotParams.from_dict(config["params"])
    sc = scenarios.get(config["scenario"], params=params, **config["options"])
    realism = _realism_from_config(config["realism"]) if "realism" in config else None
    mine = _config(sc, config["scenario"], config["n"], config["seed"], config["perturbations"], config["options"],
                   config["perturb"], realism)
    as_json = lambda v: json.dumps(v, sort_keys=True, default=repr)  # noqa: E731 (the client's config may be JSON's)
    differ = [k for k in {**mine, **config} if k not in HOW_GIVEN and as_json(mine.get(k)) != as_json(config.get(k))]
    if differ:
        import socket

        raise _bad(f"sweep worker on {socket.gethostname()} (twip {_core.__version__}) rebuilt another sweep than the "
                   f"client's (twip {config.get('twip')}): they differ in {', '.join(differ)}; run the same twip "
                   "on the client and the workers")
    raw = run_samples(sc, config, start, count, threads, None, realism)
    return {k: (np.asarray(v) if not isinstance(v, (str, bool)) else v) for k, v in raw.items()}


class ProgressBar:
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
    on_error: str = "stop",
) -> SweepResult:
    """Runs `n` samples of `scenario` (a name from `twip.scenarios.names()`, or a Scenario).

    perturb: {"m_body": twip.Uniform(rel=0.2), "slope": twip.Uniform(low=0, high=0.2),
              "phi0": twip.Normal(std=0.02), ...}; drawn in key order, per sample. The
              initial state of a 3-DOF tracking scenario is PLANAR_STATE_NAMES; on a terrain
              plane its "slope" and uphill "heading" [rad] are drawn per sample too (the
              model's and a GradeFeedForward's plane; docs/terrain.md).
    threads: worker threads (default: all cores). checkpoint: a folder; the sweep is
    written there in shards and a re-run with the same arguments resumes. client: a
    dask.distributed.Client; shards run as Dask tasks (needs a scenario name).
    realism: a `twip.Realism`: sensors, estimator, motor drivers, loop period and
    delay, disturbances in every run (2-DOF and 3-DOF tracking scenarios). Sample i's noise is stream i of a key
    made from `seed`; the realism's own seed and stream are ignored.
    traces: a few sample indices whose trajectories to keep, logged every `trace_every`
    steps, in `SweepResult.traces` (each replayed alone with the full runner, see replay).
    Ctrl-C stops within a fraction of a second: finished shards stay in the checkpoint,
    and the KeyboardInterrupt carries `.partial`, a SweepResult of what finished. A shard
    that cannot be written (a full disk) raises `twip.checkpoint.CheckpointWriteError`
    (an OSError naming the file), which carries `.partial` too.
    Memory: when n samples' metrics do not fit the memory budget (`twip.set_memory_budget`),
    a sweep needs `checkpoint=`; it then keeps them on disk and returns a
    StreamedSweepResult, whose summaries are read back shard by shard.
    on_error: what a sample whose Python controller raised (or returned a `u` that is not
    finite) does: "stop" (the default) raises `ControllerFailedError` naming the sample;
    "record" counts it invalid, under the exception's type in `summary()["invalid_reasons"]`,
    keeps its message in `SweepResult.errors` {index: message} and goes on. A checkpointed
    sweep of a Python controller is cut into shards of about SHARD_SECONDS of work.
    """
    if not isinstance(on_error, str) or on_error not in user_sweep.ON_ERROR:  # an array's `in` is ambiguous
        raise _bad(f"on_error = {on_error!r}: must be one of {', '.join(map(repr, user_sweep.ON_ERROR))}")
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n <= 0:
        raise _bad(f"n = {n!r}: the number of samples must be a positive integer")
    checks.seed("seed", seed)
    threads = checks.threads(threads)
    if checkpoint is not None:  # before a shard size is read from it or the folder is made
        checkpoint = checkpoint_folder(checkpoint)
    if client is not None:  # dask only when a client is given (an executor has .submit too, but no Dask)
        from dask.distributed import Client

        if not isinstance(client, Client):
            raise TypeError(f"client must be a dask.distributed.Client, got {client!r} ({type(client).__name__})")
    if client is not None and not isinstance(scenario, str):
        raise _bad("client= (Dask) needs a scenario name, so that workers can rebuild it")
    traces = _trace_indices(traces, n, trace_every)
    if realism is not None and not isinstance(realism, _core.Realism):
        raise _bad(f"realism = {realism!r}: must be a twip.Realism or None")
    sc = _scenario_of(scenario, params, options)
    _core.check_sweep_model(sc.model)  # before a checkpoint folder is touched
    if traces:  # each replay checks its own log; together they must fit too
        from twip.sim import log_shape_guess

        rows, columns = log_shape_guess(sc.model, sc.t_final, sc.dt, trace_every, realism)
        budget.check(f"montecarlo: traces of {len(traces)} samples ({rows:,.0f} rows x {columns} columns each)",
                     len(traces) * rows * columns * 8, "keep fewer traces= or log them sparser with trace_every=")
    perturbations = resolve(perturb or {}, sc)
    config = _config(sc, scenario, n, seed, perturbations, options, (perturb or {}).keys(), realism, on_error)
    if stall_current is not None:  # summary() counts the samples that asked more of a motor
        stall_current = checks.real("stall_current", stall_current, above=0)
    store = None
    try:
        if shard_size is None and checkpoint is not None and user_sweep.is_user_controller(sc.controller):
            shard = _timed_shard(sc, config, n, checkpoint, threads, realism)
        elif shard_size is None:
            # Checkpointed sweeps keep at most MAX_SHARDS files (n = 10**9: shards of 10**5).
            shard = max(DEFAULT_SHARD, -(-n // MAX_SHARDS)) if (checkpoint or client) else n
        elif isinstance(shard_size, bool) or not isinstance(shard_size, (int, np.integer)) or shard_size <= 0:
            raise _bad(f"shard_size = {shard_size!r}: must be a positive integer")
        else:
            shard = int(shard_size)
        if -(-n // shard) > MAX_SHARDS:  # before the shards' layout is built
            raise _bad(f"n = {n:,} samples in shards of shard_size = {shard:,} make {-(-n // shard):,} shards, "
                       f"more than MAX_SHARDS = {MAX_SHARDS:,}; pass shard_size >= {-(-n // MAX_SHARDS):,}")
        # Memory: all the metrics when they fit the budget, else (with a checkpoint) a
        # shard at a time, the summaries read back from the shards.
        in_memory = fits_in_memory(n)
        if checkpoint is None:
            check_samples_fit(f"montecarlo: n = {n:,} samples", n, "pass checkpoint=FOLDER to stream the sweep to disk in shards")
        else:
            # Without shard_size the shard is as small as MAX_SHARDS allows: only a smaller n helps.
            check_samples_fit(f"montecarlo: a shard of {shard:,} samples", shard,
                              "pass a smaller shard_size" if shard_size is not None
                              else f"sweep fewer samples (n = {n:,} is cut into at most {MAX_SHARDS:,} shards)")
        store = Checkpoint(checkpoint, config, shard) if checkpoint is not None else None
        result = _sweep(sc, config, n, shard, store, in_memory, client, threads, progress, realism, traces, trace_every,
                        on_error)
        result.stall_current = stall_current
        return result
    except (KeyboardInterrupt, CheckpointWriteError) as stop:
        if getattr(stop, "partial", None) is None:  # stopped before the first shard began
            stop.partial = _assemble({}, config, 0.0, kernel_for(sc, realism), sc, complete=False, realism=realism)
        stop.partial.stall_current = stall_current
        raise
    finally:
        if store is not None:
            store.close()


def _timed_shard(sc, config, n, checkpoint, threads, realism) -> int:
    """The shard size of a checkpointed sweep of a Python controller: the folder's own, when
    it holds this sweep (a resume), else about SHARD_SECONDS of work on all the workers,
    timed on one run of the nominal robot."""
    import os

    resumed = Checkpoint.shard_size_of(checkpoint, config)
    if resumed is not None:
        return resumed
    workers = threads or os.cpu_count() or 1
    seconds = max(user_sweep.time_one_run(sc, realism), 1e-6)
    return max(1, min(DEFAULT_SHARD, int(SHARD_SECONDS * workers / seconds)), -(-n // MAX_SHARDS))


def check_samples_fit(what: str, n: int, hint: str) -> None:
    """Refuses `what`, n samples' metrics held at once, when they exceed the memory budget."""
    budget.check(what, n * BYTES_PER_SAMPLE, hint)


def fits_in_memory(n: int) -> bool:
    """Whether the metrics of an n-sample sweep fit the memory budget (else a sweep
    needs checkpoint= and returns a StreamedSweepResult)."""
    return n * BYTES_PER_SAMPLE <= budget.memory_budget()


def _sweep(sc, config, n, shard, store, in_memory, client, threads, progress, realism, traces, trace_every,
           on_error="stop"):
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
    bar = ProgressBar(n, progress)
    bar.base = sum(c for s, c in layout if s in finished)
    started = time.perf_counter()
    kernel = kernel_for(sc, realism)
    held = in_memory or store is None  # the metrics held in memory, not read back from the shards

    def keep(s, raw):
        with ctrl_c_held():  # a finished shard is kept whole, then a Ctrl-C acts
            if held:  # first: in the partial result even when its write fails
                parts[s] = raw
            if store is not None:
                store.save(s, raw)
            finished.add(s)

    try:
        if client is not None:
            futures = {client.submit(run_shard_by_name, config, s, c, threads or 1, pure=False): s for s, c in todo}
            from dask.distributed import as_completed

            for future in as_completed(futures):
                raw = future.result()
                keep(futures[future], raw)
                bar.base += len(raw["index"])
                bar.update_to(0)
        else:
            for s, c in todo:
                raw = run_samples(sc, config, s, c, threads or 0, bar.update_to if progress else None, realism, on_error)
                if raw["interrupted"]:
                    if np.all(raw["done"]):  # the Ctrl-C came as the shard finished: kept as any other
                        keep(s, raw)
                    else:
                        parts[s] = raw
                    raise KeyboardInterrupt
                keep(s, raw)
                bar.base += c
    except (KeyboardInterrupt, CheckpointWriteError) as stop:  # either way, what finished is given back
        elapsed = time.perf_counter() - started
        stop.partial = (_assemble(parts, config, elapsed, kernel, sc, complete=False, realism=realism)
                        if held else
                        StreamedSweepResult.of(store, layout, finished, config, elapsed, kernel, sc, realism))
        raise
    finally:
        bar.close()
    elapsed = time.perf_counter() - started
    if not held:
        return StreamedSweepResult.of(store, layout, finished, config, elapsed, kernel, sc, realism)
    result = _assemble(parts, config, elapsed, kernel, sc, complete=True, realism=realism)
    try:
        for i in traces:
            result.traces[i] = result.replay(i, record_every=trace_every)
    except KeyboardInterrupt as stop:  # every sample finished: they are the partial result, not nothing
        stop.partial = result
        raise
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
    errors = {int(i): str(m) for k in keys if "controller_error" in parts[k]
              for i, m in zip(parts[k]["index"], parts[k]["controller_error"]) if m}
    return SweepResult(metrics=metrics, steps=steps, config=config, elapsed=elapsed, kernel=kernel,
                       metric_names=names, _scenario=sc, _realism=realism, errors=errors)
