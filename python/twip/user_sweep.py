"""Sweeps of a scenario whose controller is written in Python (`sc.replace(controller=obj)`).

A Python controller needs the GIL at every update, so the samples run in worker
processes instead of the core's threads: the shard is cut into chunks, each worker runs
its chunk through `twip.simulate` (the same runner and metrics as any run), and the
chunks are put back in index order. Each sample gets a fresh copy of the controller
(unpickled from the bytes checked before any work) reset by `simulate`, and draws its
robot from its own stream (`_core.sweep_draw`), so a sample's metrics depend on
(seed, index) alone: the same on any number of workers, in shards and after a resume.
"""
from __future__ import annotations

import hashlib
import inspect
import marshal
import math
import multiprocessing
import os
import pickle
import sys
from pathlib import Path

import numpy as np

from twip import _core

#: What a chunk of samples runs with in a forked worker: set before the pool starts.
_JOB: dict = {}


#: twip's own controller classes; anything else is a controller written in Python.
_BUILTIN = tuple(getattr(_core, n) for n in ("LqrController", "FuzzyController", "PidTracker", "SmcTracker"))


def is_user_controller(controller) -> bool:
    """A controller written in Python: not one of twip's controller classes."""
    return not isinstance(controller, _BUILTIN)


def controller_bytes(controller) -> bytes:
    """The controller pickled, or a clear error before any sample runs."""
    try:
        return pickle.dumps(controller)
    except Exception as e:  # pickle raises several kinds
        raise _core.InvalidParameterError(
            f"controller {controller!r} cannot be pickled ({type(e).__name__}: {e}); a sweep runs a fresh copy per "
            "sample in worker processes: define its class at module level and keep no open files, locks or lambdas in it"
        ) from None


def fingerprint(controller) -> str:
    """What a checkpoint records of a Python controller: its class, its pickled state and
    its code (a pickle holds only the state: a checkpoint resumed after `update` was edited
    once returned the old law's shards)."""
    kind = f"{type(controller).__module__}.{type(controller).__qualname__}"
    digest = hashlib.sha256(controller_bytes(controller))
    digest.update(_code_of(type(controller)))
    return f"python:{kind}:{digest.hexdigest()}"


def _code_of(cls) -> bytes:
    """The code behind a class: the source file of each module its classes (but object)
    come from, whole, since their methods may call the module's functions and read its
    globals; for a class without a source file, its functions' bytecode."""
    out = hashlib.sha256()
    for klass in cls.__mro__:
        if klass is object:
            continue
        try:
            out.update(Path(inspect.getsourcefile(sys.modules[klass.__module__])).read_bytes())
        except (KeyError, TypeError, OSError):
            for name, member in sorted(vars(klass).items()):
                code = getattr(getattr(member, "__func__", member), "__code__", None)
                if code is not None:
                    out.update(name.encode() + marshal.dumps(code))
    return out.digest()


def _sample(index: int) -> dict:
    """Sample `index`: its robot drawn from its own stream, then one run."""
    from twip.sim import simulate

    job = _JOB
    sc, family = job["scenario"], job["family"]
    params, slope, x0 = family.draw(sc.model, sc.x0, job["perturbations"], job["seed"], index)
    try:
        robot = _core.RobotParams.from_dict(params)
        model = _core.PlanarModel(robot) if family.planar else _core.SlopeModel(robot, slope)
    except _core.TwipError:
        return {"valid": False}
    options = {}
    if job["realism"] is not None:
        options["realism"] = job["realism"].replace(seed=_core.sweep_noise_seed(job["seed"]), stream=index)
    try:
        r = simulate(model, pickle.loads(job["controller"]), x0, sc.t_final, sc.dt, reference=sc.reference,
                     control_period=sc.control_period, record_every=max(1, int(round(sc.t_final / sc.dt))),
                     **options)
    except _core.TwipError:
        return {"valid": False}
    t_end = r.t_end if r.t_end is not None else r.steps * sc.dt
    return {"valid": True, "fell": r.outcome in ("fell", "diverged"), "t_end": t_end, "steps": r.steps, **r.metrics}


def _chunk(bounds) -> list:
    start, stop = bounds
    return [_sample(i) for i in range(start, stop)]


def run(sc, family, config, start, count, workers, progress, realism=None) -> dict:
    """Samples start..start + count as the core's sweep functions lay them out (index,
    done, valid, fell, steps, the metrics, metric_names, kernel, interrupted)."""
    _JOB.update(scenario=sc, family=family, perturbations=[tuple(p) for p in config["perturbations"]],
                seed=config["seed"], controller=controller_bytes(sc.controller), realism=realism)
    names = _metric_names(sc)
    workers = max(1, min(workers or os.cpu_count() or 1, count))
    size = max(1, min(64, math.ceil(count / (4 * workers))))
    chunks = [(s, min(s + size, start + count)) for s in range(start, start + count, size)]
    results: dict = {}
    interrupted = False
    try:
        if workers == 1 or "fork" not in multiprocessing.get_all_start_methods():
            for c in chunks:
                results[c[0]] = _chunk(c)
                if progress:
                    progress(sum(len(v) for v in results.values()))
        else:
            from concurrent.futures import ProcessPoolExecutor, as_completed

            with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
                futures = {pool.submit(_chunk, c): c[0] for c in chunks}
                try:
                    for future in as_completed(futures):
                        results[futures[future]] = future.result()
                        if progress:
                            progress(sum(len(v) for v in results.values()))
                except KeyboardInterrupt:
                    for f in futures:
                        f.cancel()
                    raise
    except KeyboardInterrupt:
        interrupted = True
    finally:
        _JOB.clear()
    return _layout(start, count, results, interrupted, names)


def _metric_names(sc) -> list:
    """The family's metrics, as `simulate` reports them, from a one-step run of the
    nominal robot (so that a shard whose samples all failed or were interrupted has them)."""
    from twip.sim import simulate

    one = simulate(sc.model, pickle.loads(_JOB["controller"]), sc.x0, sc.dt, sc.dt, reference=sc.reference,
                   control_period=sc.control_period)
    return ["t_end"] + list(one.metrics)


def _layout(start, count, results, interrupted, names) -> dict:
    rows = [None] * count
    for c0, samples in results.items():
        rows[c0 - start:c0 - start + len(samples)] = samples
    done = np.array([r is not None for r in rows])
    out = {
        "index": np.arange(start, start + count, dtype=np.uint64),
        "done": done,
        "valid": np.array([bool(r and r["valid"]) for r in rows]),
        "fell": np.array([bool(r and r.get("fell", False)) for r in rows]),
        "steps": np.array([r.get("steps", 0) if r else 0 for r in rows], dtype=np.uint64),
        "metric_names": ["fell"] + names,
        "kernel": "python",
        "interrupted": interrupted,
    }
    for name in names:
        out[name] = np.array([float(r[name]) if r and r["valid"] else math.nan for r in rows])
    return out
