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

import functools
import hashlib
import inspect
import io
import marshal
import math
import multiprocessing
import os
import pickle
import signal
import sys
import traceback
import types
from pathlib import Path

import numpy as np

from twip import _core, sim, user_controller
from twip.checkpoint import ctrl_c_held

#: What a chunk of samples runs with in a forked worker: set before the pool starts.
_JOB: dict = {}


#: twip's own controller classes; anything else is a controller written in Python.
_BUILTIN = tuple(getattr(_core, n) for n in ("LqrController", "FuzzyController", "PidTracker", "SmcTracker", "GradeFeedForward"))


def is_user_controller(controller) -> bool:
    """A controller written in Python: not one of twip's controller classes."""
    return not isinstance(controller, _BUILTIN)


def controller_bytes(controller) -> bytes:
    """The controller pickled, and loaded back once, or a clear error before any sample runs."""
    try:
        data = pickle.dumps(controller)
    except Exception as e:  # pickle raises several kinds
        raise _core.InvalidParameterError(
            f"controller {controller!r} cannot be pickled ({type(e).__name__}: {e}); a sweep runs a fresh copy per "
            "sample in worker processes: define its class at module level and keep no open files, locks or lambdas in it"
        ) from None
    try:  # a __setstate__ that raises surfaced as its bare exception, naming no sweep
        pickle.loads(data)
    except Exception as e:  # noqa: BLE001 (the controller's own code may raise anything)
        raise _core.InvalidParameterError(
            f"controller {controller!r} is pickled but its copy cannot be loaded ({type(e).__name__}: {e}); a sweep "
            "runs a fresh copy per sample, unpickled in worker processes: its __setstate__ (or __reduce__) must "
            "rebuild it"
        ) from None
    return data


def fingerprint(controller) -> str:
    """What a checkpoint records of a Python controller: its class, its pickled state and
    its code (a pickle holds only the state: a checkpoint resumed after `update` was edited
    once returned the old law's shards)."""
    named = controller if isinstance(controller, types.FunctionType) else type(controller)
    kind = f"{named.__module__}.{named.__qualname__}"
    controller_bytes(controller)  # the clear errors of one that does not pickle
    digest = hashlib.sha256(_canonical(controller))
    digest.update(_code_behind(controller))
    return f"python:{kind}:{digest.hexdigest()}"


def _code_behind(controller) -> bytes:
    """The code a controller runs: a plain function's own (it pickles by name alone: its
    body was in no fingerprint, and a checkpoint resumed after an edit mixed the two laws'
    shards), a partial's or a bound method's function, else its class's."""
    if isinstance(controller, functools.partial):
        return _code_behind(controller.func)
    if isinstance(controller, types.MethodType):
        return _code_behind(controller.__func__) + _code_of(type(controller.__self__))
    if isinstance(controller, types.FunctionType):
        try:
            return Path(inspect.getsourcefile(sys.modules[controller.__module__])).read_bytes()
        except (KeyError, TypeError, OSError):
            return marshal.dumps(_placeless(controller.__code__))
    return _code_of(type(controller))


class _Canonical(pickle.Pickler):
    """A pickler whose sets come out sorted: a set of strings pickles in its hash order, which
    each process draws anew (PYTHONHASHSEED), so a checkpoint was refused on resume ("differs
    in: controller") for a controller that had not changed. Else the bytes of pickle.dumps.
    (persistent_id sees every object; reducer_override skips sets.) For hashing only."""

    def persistent_id(self, obj):
        if type(obj) in (set, frozenset):
            return type(obj).__name__, sorted(_canonical(x) for x in obj)
        return None


def _canonical(obj) -> bytes:
    """`obj` pickled with its sets sorted (what a fingerprint hashes)."""
    out = io.BytesIO()
    _Canonical(out, protocol=pickle.DEFAULT_PROTOCOL).dump(obj)
    return out.getvalue()


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
                    out.update(name.encode() + marshal.dumps(_placeless(code)))
    return out.digest()


def _placeless(code: types.CodeType) -> types.CodeType:
    """`code` without the file and line it was compiled at: a notebook compiles each cell
    under a file name of its session (/tmp/ipykernel_<pid>/...), so the same class's code
    differed in a new session and its checkpoint was refused on resume."""
    consts = tuple(_placeless(c) if isinstance(c, types.CodeType) else c for c in code.co_consts)
    return code.replace(co_filename="", co_firstlineno=1, co_consts=consts)


#: How a sweep treats a sample whose controller raised or returned a bad `u`.
ON_ERROR = ("stop", "record")
#: Samples per chunk handed to a worker at most: a Ctrl-C loses the chunks under way, and a
#: sample of a Python controller (thousands of calls) outweighs a chunk's round trip.
MAX_CHUNK = 1


class ControllerFailedError(_core.TwipError):
    """A sweep's sample whose Python controller raised (or returned a `u` that is not
    finite): `.index` names the sample, `.message` the controller's exception."""

    def __init__(self, index: int, message: str):
        super().__init__(f"sample {index}: the controller failed ({message}); pass on_error='record' to record "
                         "such samples as invalid and go on (SweepResult.errors), or replay it with "
                         f"result.rerun({index})")
        self.index, self.message = index, message


def failure_reason(message: str) -> str:
    """The reason a failed sample is counted invalid under (the exception's type: the
    messages name times and values, so that samples group)."""
    return f"the controller failed: {message.split(':', 1)[0]}"


#: How a 3-DOF run on terrain can end besides a fall, each a column of its sweep as in the
#: built-in trackers' (1 when the run ended so, counted as fallen too).
_HALTS = ("lifted", "off_terrain")


def _sample(index: int) -> dict:
    """Sample `index`: its robot drawn from its own stream, then one run."""
    from twip.perturbation import ground_model  # (it imports this module)
    from twip.sim import simulate

    job = _JOB
    sc, family = job["scenario"], job["family"]
    params, ground, x0 = family.draw(sc.model, sc.x0, job["perturbations"], job["seed"], index)
    try:
        robot = _core.RobotParams.from_dict(params)
        model = ground_model(robot, ground, family)
    except _core.TwipError:
        return {"valid": False}
    options = {}
    if job["realism"] is not None:
        options["realism"] = job["realism"].replace(seed=_core.sweep_noise_seed(job["seed"]), stream=index)
    try:
        r = simulate(model, pickle.loads(job["controller"]), x0, sc.t_final, sc.dt, reference=sc.reference,
                     control_period=sc.control_period, record_every=max(1, int(round(sc.t_final / sc.dt))),
                     **options)
    except Exception as e:  # noqa: BLE001 (a controller may raise anything)
        message = user_controller.failure(e, sim.__file__, "run")
        if message is not None:
            if job["on_error"] == "stop":
                raise ControllerFailedError(index, message) from None
            return {"valid": False, "error": message}
        if isinstance(e, _core.TwipError):
            return {"valid": False}
        raise
    t_end = r.t_end if r.t_end is not None else r.steps * sc.dt
    ended = {name: float(r.outcome == name) for name in _HALTS} if family.planar else {}
    return {"valid": True, "fell": r.outcome in ("fell", "diverged", *_HALTS), "t_end": t_end, "steps": r.steps, **r.metrics, **ended}


def _chunk(bounds) -> list:
    start, stop = bounds
    return [_sample(i) for i in range(start, stop)]


def _worker(conn, parent_ends) -> None:
    """A worker process: runs the chunks it is sent until told to stop (None) or its
    parent is gone. It ignores Ctrl-C: the parent, which a terminal's Ctrl-C reaches too,
    ends it, so that no worker is caught between a pipe's reads. It closes the parent's
    ends of the pipes it inherited from the fork: holding its own pipe's other end, it never
    saw the parent die, and lived on as an orphan holding the parent's stdout."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for end in parent_ends:
        end.close()
    while True:
        try:
            bounds = conn.recv()
        except (EOFError, OSError):
            return
        if bounds is None:
            return
        try:
            reply = ("done", bounds[0], _chunk(bounds))
        except ControllerFailedError as e:
            reply = ("failed", e.index, e.message)
        except BaseException as e:  # noqa: BLE001 (sent to the parent, which raises it)
            reply = ("error", bounds[0], f"{type(e).__name__}: {e}\n{traceback.format_exc()}")
        try:
            conn.send(reply)
        except (BrokenPipeError, OSError):
            return


class _Pool:
    """Worker processes, each on a pipe of its own (no lock shared between processes:
    killing one mid-chunk cannot leave another waiting). Leaving the block kills any that
    are still running: a chunk under way is lost, every finished one was already kept."""

    def __init__(self, workers: int):
        context = multiprocessing.get_context("fork")
        self.procs, self.conns = [], []
        try:
            # A Ctrl-C that lands in the fork's own handlers (logging's lock release) is
            # printed as "Exception ignored" and lost, and the sweep ran on: hold it until
            # the workers are started, then let it stop the sweep.
            with ctrl_c_held():
                for _ in range(workers):
                    parent, child = context.Pipe()
                    self.conns.append(parent)
                    proc = context.Process(target=_worker, args=(child, self.conns), daemon=True)
                    proc.start()
                    child.close()
                    self.procs.append(proc)
        except BaseException:
            self.__exit__()
            raise

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        with ctrl_c_held():  # a second Ctrl-C waits the few milliseconds this takes
            for proc in self.procs:
                if proc.is_alive():
                    proc.kill()
            for proc in self.procs:
                proc.join(timeout=5)
            for conn in self.conns:
                conn.close()

    def run(self, chunks, keep) -> None:
        """Runs `chunks` on the workers, each result handed to `keep(start, samples)` as it
        finishes."""
        from multiprocessing.connection import wait

        todo = list(reversed(chunks))
        busy = {}  # each worker's pipe: the chunk it runs
        for conn in self.conns:
            if todo:
                busy[conn] = todo.pop()
                conn.send(busy[conn])
        while busy:
            for conn in wait(list(busy)):
                try:
                    kind, start, payload = conn.recv()
                except EOFError:
                    raise RuntimeError(self._ended(conn, busy[conn])) from None
                if kind == "failed":
                    raise ControllerFailedError(start, payload)
                if kind == "error":
                    raise RuntimeError(f"a sweep worker failed on the chunk at sample {start}: {payload}")
                keep(start, payload)
                if todo:
                    busy[conn] = todo.pop()
                    conn.send(busy[conn])
                else:
                    del busy[conn]

    def _ended(self, conn, bounds) -> str:
        """Why a worker's pipe closed mid-chunk, naming the samples it ran (it named none)."""
        proc = self.procs[self.conns.index(conn)]
        proc.join(timeout=5)
        code = proc.exitcode
        how = (f"killed by signal {-code} ({signal.Signals(-code).name})" if code is not None and code < 0
               and -code in signal.valid_signals() else f"exit code {code}")
        start, stop = bounds
        which = f"sample {start}" if stop - start == 1 else f"samples {start} to {stop - 1}"
        return (f"{which}: the sweep's worker process ended without a reply ({how}): the controller's code ended it "
                "(os._exit, a crash in an extension module) or it was killed (out of memory?); the samples finished "
                "in shards before it are kept with checkpoint=")


def run(sc, family, config, start, count, workers, progress, realism=None, on_error="stop") -> dict:
    """Samples start..start + count as the core's sweep functions lay them out (index,
    done, valid, fell, steps, the metrics, metric_names, kernel, interrupted), and
    `controller_error` (the controller's exception per sample, "" for none)."""
    _JOB.update(scenario=sc, family=family, perturbations=[tuple(p) for p in config["perturbations"]],
                seed=config["seed"], controller=controller_bytes(sc.controller), realism=realism, on_error=on_error)
    names = _metric_names(sc, realism)
    workers = max(1, min(workers or os.cpu_count() or 1, count))
    size = max(1, min(MAX_CHUNK, math.ceil(count / (4 * workers))))
    chunks = [(s, min(s + size, start + count)) for s in range(start, start + count, size)]
    results: dict = {}
    interrupted = False

    def keep(c0, samples):
        results[c0] = samples
        if progress:
            progress(sum(len(v) for v in results.values()))

    try:
        if workers == 1 or "fork" not in multiprocessing.get_all_start_methods():
            for c in chunks:
                keep(c[0], _chunk(c))
        else:
            with _Pool(workers) as pool:
                pool.run(chunks, keep)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        _JOB.clear()
    return _layout(start, count, results, interrupted, names)


def time_one_run(sc, realism=None) -> float:
    """Seconds one run of the nominal robot takes (what sizes a sweep's shards by time)."""
    import time

    from twip.sim import simulate

    options = {} if realism is None else {"realism": realism}
    # A copy, as every sample runs: the user's own object, run here, kept the state this run
    # left (a controller without reset()), and the samples pickled after it started from it.
    controller = pickle.loads(controller_bytes(sc.controller))
    started = time.perf_counter()
    try:
        simulate(sc.model, controller, sc.x0, sc.t_final, sc.dt, reference=sc.reference,
                 control_period=sc.control_period, record_every=max(1, int(round(sc.t_final / sc.dt))), **options)
    except Exception:  # noqa: BLE001 (the sweep itself reports a failing controller)
        pass
    return time.perf_counter() - started


def _metric_names(sc, realism) -> list:
    """The family's metrics, as `simulate` reports them, from a short run of the nominal
    robot (so that a shard whose samples all failed or were interrupted has them). It runs
    through the realism, so that a controller the rig refuses (its period) is refused
    before any sample."""
    from twip.perturbation import family_of  # (it imports this module)
    from twip.sim import simulate

    options = {} if realism is None else {"realism": realism}
    one = simulate(sc.model, pickle.loads(_JOB["controller"]), sc.x0, sc.dt, sc.dt, reference=sc.reference,
                   control_period=sc.control_period, **options)
    return ["t_end"] + list(one.metrics) + (list(_HALTS) if family_of(sc).planar else [])


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
        "controller_error": np.array([(r or {}).get("error", "") for r in rows], dtype=str),
        "kernel": "python",
        "interrupted": interrupted,
    }
    for name in names:
        out[name] = np.array([float(r[name]) if r and r["valid"] else math.nan for r in rows])
    return out
