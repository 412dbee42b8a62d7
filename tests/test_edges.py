"""Edges that fail safely (issue 14): requests too large for memory are errors, not
aborts; checkpoints that cannot lie; streamed sweeps; errors that name what was given;
numbers that do not mislead. Each input the issue lists has a test here."""
import json
from decimal import Decimal
from fractions import Fraction
import math
import re
import os
import pickle
import shutil
import signal
import socket
import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pytest

import twip
import twip.sweep as tsweep
from twip import budget, quantiles, scenarios
from twip.checkpoint import LOCK, Checkpoint

SHORT = {"t_final": 0.5}
PERTURB = {"m_body": twip.Uniform(rel=0.2), "phi0": twip.Normal(std=0.05)}


def sweep(n=48, **kw):
    kw.setdefault("perturb", PERTURB)
    kw.setdefault("options", SHORT)
    kw.setdefault("seed", 3)
    return twip.montecarlo("flat-lqr-sim", n, progress=False, **kw)


def run_python(code: str, env=None, limit_gb=None):
    """Runs `code` in a fresh interpreter (optionally under an address-space limit, as a
    small machine would be); returns (exit code, stdout, stderr)."""
    prelude = "import resource; resource.setrlimit(resource.RLIMIT_AS, ({0}, {0}))\n".format(limit_gb << 30) if limit_gb else ""
    proc = subprocess.run([sys.executable, "-c", prelude + textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=120, env={**os.environ, **(env or {})})
    return proc.returncode, proc.stdout, proc.stderr


# ---------------------------------------------------------------- 1. no abort, ever

@pytest.mark.parametrize("code, expect", [
    # Each of these aborted the interpreter (exit 134 / OOM killer) before.
    ("twip.montecarlo('flat-lqr', 10**12, progress=False)", ["MemoryBudgetError", "n = 1,000,000,000,000", "checkpoint="]),
    ("scenarios.get('flat-lqr').run(t_final=1e5)", ["MemoryBudgetError", "t_final = 100000", "record_every ="]),
    ("scenarios.get('flat-lqr', params=twip.RobotParams.balanbot().replace(wheel_radius=1e-9)).run()",
     ["InvalidParameterError", "wheel_radius = 1e-09", "would take 3.18e+08 s"]),
    ("scenarios.get('flat-fuzzy', params=twip.RobotParams.balanbot().replace(wheel_radius=1e-6)).run()",
     ["InvalidParameterError", "wheel_radius = 1e-06"]),
    # A basis's rules are the product of its inputs' set counts: 256^4 aborted allocating
    # 32 GiB; 10^20 wrapped and panicked; 2^64 wrapped to none and panicked on the index.
    ("twip.FuzzyBasis([[twip.Gaussian(0, 1)] * 256] * 4).eval(np.zeros(4))",
     ["InvalidParameterError", "256 x 256 x 256 x 256 sets per input make more than 16777216 rules"]),
    ("twip.FuzzyBasis([[twip.Gaussian(0, 1)] * 2] * 64).eval(np.zeros(64))", ["InvalidParameterError", "rules"]),
    # 10 000 threads took 80 s to start; 2**64 was an OverflowError naming nothing.
    ("twip.montecarlo('flat-lqr', 3, threads=10**5, progress=False)",
     ["InvalidParameterError", "threads = 100000: must be an integer from 1 to 1024"]),
    ("twip._core.sweep_raw(*tsweep_args(), threads=10**5)", ["InvalidParameterError", "threads", "at most 1024"]),
])
def test_the_requests_that_aborted_are_clear_errors(code, expect):
    rc, out, err = run_python(f"""
        import numpy as np
        import twip
        from twip import scenarios

        def tsweep_args():
            sc = scenarios.get('flat-lqr')
            return (sc.model, sc.controller, list(sc.x0), 1.0, sc.dt, sc.reference, [], 1, 0, 4)
        try:
            {code}
        except twip.TwipError as e:
            print(type(e).__name__, e)
        """, env={budget.ENV: "1G"}, limit_gb=6)
    assert rc == 0, err[-2000:]
    for text in expect:
        assert text in out, out


def test_the_core_refuses_a_log_it_cannot_reserve_with_an_error_not_an_abort():
    # Past the budget (raised sky-high), the core's fallible reservation is what is left.
    rc, out, err = run_python("""
        import twip
        from twip import scenarios
        twip.set_memory_budget(2**62)
        sc = scenarios.get('flat-lqr-sim')
        lqr = scenarios.get('flat-lqr')
        calls = {
            "run": lambda: sc.run(t_final=1e9),
            "montecarlo": lambda: twip.montecarlo('flat-lqr-sim', 10**12, progress=False),
            # The private calls under them: refused before any sample runs (an hour's
            # work), and a replay recorded only after its room is reserved.
            "sweep_raw": lambda: twip._core.sweep_raw(lqr.model, lqr.controller, list(lqr.x0), 1.0, lqr.dt,
                                                      lqr.reference, [], 1, 0, 10**9),
            "ffi_record": lambda: twip._core.ffi_record(lqr.model, lqr.controller, [0.0] * 4, 1e9, lqr.dt,
                                                        lqr.reference),
        }
        for name, call in calls.items():
            try:
                call()
            except MemoryError as e:
                print(name, type(e).__name__, e)
        """, limit_gb=6)
    assert rc == 0, err[-2000:]
    assert "run MemoryError record_every: could not reserve" in out, out
    assert "montecarlo MemoryError n: could not reserve" in out, out
    assert "sweep_raw MemoryError n: could not reserve" in out, out
    assert "ffi_record MemoryError t_final: could not reserve" in out, out


def test_the_budget_is_settable_and_named_in_the_error(monkeypatch):
    sc = scenarios.get("flat-lqr-sim")
    twip.set_memory_budget(10_000)
    try:
        with pytest.raises(twip.MemoryBudgetError, match=r"record_every = \d+ or more") as e:
            sc.run()
        assert isinstance(e.value, MemoryError) and isinstance(e.value, twip.TwipError)
        assert "10,000 bytes" in str(e.value)
        assert len(sc.run(record_every=10**6).t) <= 3  # what the error suggested fits
    finally:
        twip.set_memory_budget(None)
    monkeypatch.setenv(budget.ENV, "2K")
    assert budget.memory_budget() == 2048
    monkeypatch.setenv(budget.ENV, "lots")
    with pytest.raises(twip.InvalidParameterError, match=budget.ENV):
        budget.memory_budget()
    for bad in (0, -5, 1.5, "1G", True):
        with pytest.raises(twip.InvalidParameterError, match="memory budget"):
            twip.set_memory_budget(bad)


def test_a_user_controllers_internals_are_counted_in_the_log_budget():
    # 2000 internals logged at every step of 20 s: 320 MB, where the guess of a built-in
    # controller's internals would have said 4 MB.
    class Wide:
        period = 0.005
        updates = 0

        def update(self, t, y, ref):
            self.updates += 1
            return 0.0

        def internals(self):
            return {f"k{i}": 0.0 for i in range(2000)}

    sc = scenarios.get("flat-lqr")
    wide = Wide()
    twip.set_memory_budget(100 << 20)
    try:
        with pytest.raises(twip.MemoryBudgetError, match=r"x 2008 columns\) .* record_every = 4 or more"):
            twip.simulate(sc.model, wide, sc.x0, 20.0)
        assert wide.updates == 0  # counted without stepping the user's controller
        assert len(twip.simulate(sc.model, wide, sc.x0, 20.0, record_every=4).internals) == 2000
    finally:
        twip.set_memory_budget(None)


def test_traces_together_are_checked_against_the_budget():
    twip.set_memory_budget(2_000_000)  # one trace of 500 rows fits, 60 do not
    try:
        with pytest.raises(twip.MemoryBudgetError, match=r"traces of 60 samples .*trace_every="):
            sweep(n=64, traces=range(60), trace_every=1)
        assert len(sweep(n=8, traces=[3], trace_every=1).traces[3].t) == 501
    finally:
        twip.set_memory_budget(None)


# ---------------------------------------------------------------- 2. sweeps of any size

def test_without_a_checkpoint_a_sweep_too_large_says_to_pass_one():
    twip.set_memory_budget(4096)
    try:
        with pytest.raises(twip.MemoryBudgetError, match="pass checkpoint=FOLDER"):
            sweep(n=1000)
    finally:
        twip.set_memory_budget(None)


def test_a_streamed_sweep_summarises_from_the_shards_as_the_in_memory_one(tmp_path):
    perturb = {**PERTURB, "com_height": twip.Uniform(abs=0.3)}  # some robots invalid
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = sweep(n=300, perturb=perturb, checkpoint=tmp_path / "a", shard_size=32)
        twip.set_memory_budget(300 * tsweep.BYTES_PER_SAMPLE - 1)  # the metrics no longer fit
        try:
            streamed = sweep(n=300, perturb=perturb, checkpoint=tmp_path / "b", shard_size=32)
            resumed = sweep(n=300, perturb=perturb, checkpoint=tmp_path / "b", shard_size=32)
        finally:
            twip.set_memory_budget(None)
    assert isinstance(streamed, tsweep.StreamedSweepResult) and not isinstance(whole, tsweep.StreamedSweepResult)
    for s in (streamed, resumed):
        assert s.n == whole.n == 300 and s.steps == whole.steps
        assert s.fall_rate == whole.fall_rate and s.fall_rate_interval() == whole.fall_rate_interval()
        for name in whole.metric_names[2:]:
            np.testing.assert_array_equal(s.quantiles(name), whole.quantiles(name), err_msg=name)
        a, b = s.summary(), whole.summary()
        assert a["invalid"] == b["invalid"] > 0 and a["invalid_reasons"] == b["invalid_reasons"]
    with pytest.raises(twip.MemoryBudgetError, match="summary"):
        streamed.metrics
    assert sum(len(p["index"]) for p in streamed.shards()) == 300
    for s in (streamed, whole):  # the same checks in memory and from the shards
        with pytest.raises(twip.InvalidParameterError, match="quantiles: unknown metric 'zz'; this sweep has t_end"):
            s.quantiles("zz")  # a KeyError in memory
        with pytest.raises(twip.InvalidParameterError, match=r"q = \(1.5,\): quantile levels must be in \[0, 1\]"):
            s.quantiles("peak_current", q=(1.5,))
        for bad in (float("nan"), -1):  # counted nothing, and every sample
            with pytest.raises(twip.InvalidParameterError, match=f"stall_current must be finite and > 0, got {bad}"):
                s.over_stall_current(bad)
    assert "300 samples" in repr(streamed)


@pytest.mark.parametrize("damage", ["missing", "flip", "truncate"])
def test_a_streamed_result_whose_shard_went_missing_or_bad_says_so(tmp_path, damage):
    """A streamed result reads its samples from the shards: one deleted or damaged after the
    sweep was skipped, with no word (missing) or a warning that it was being "recomputed"
    (it was not), and summary() counted 19 of 20 shards' samples as the whole sweep."""
    from twip.checkpoint import CheckpointReadError

    twip.set_memory_budget(80 * tsweep.BYTES_PER_SAMPLE - 1)  # the metrics no longer fit
    try:
        streamed = sweep(n=80, checkpoint=tmp_path, shard_size=16)
    finally:
        twip.set_memory_budget(None)
    assert streamed.n == 80
    path = tmp_path / "shard-000000000032.npz"
    data = path.read_bytes()
    if damage == "missing":
        path.unlink()
    else:
        path.write_bytes(_flip_a_value(data) if damage == "flip" else data[: len(data) // 2])
    why = {"missing": "is missing", "flip": "is corrupt", "truncate": "is unreadable"}[damage]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "recomputing it": nothing is recomputed here
        for read in (lambda r: r.summary(), lambda r: r.quantiles("t_end"), lambda r: list(r.shards()),
                     lambda r: r.over_stall_current(1.0)):
            with pytest.raises(CheckpointReadError, match=rf"shard-000000000032.npz \(samples 32..47\) {why}"):
                read(pickle.loads(pickle.dumps(streamed)))  # a copy, so that nothing read is cached


def test_a_full_disk_mid_sweep_names_the_file_and_keeps_what_finished(tmp_path, monkeypatch):
    """A shard write that ran out of space raised a bare "[Errno 28] No space left on device"
    (no file named) and no partial result: the samples finished in memory were lost."""
    import errno

    from twip import checkpoint

    fsync, writes = os.fsync, []

    def full_from_the_third_shard(fd):
        writes.append(fd)
        if len(writes) >= 4:  # the manifest, then shards 0 and 16; 32 finds the disk full
            raise OSError(errno.ENOSPC, "No space left on device")
        fsync(fd)

    monkeypatch.setattr(checkpoint.os, "fsync", full_from_the_third_shard)
    with pytest.raises(checkpoint.CheckpointWriteError,
                       match=r"cannot write .*shard-000000000032.npz \(No space left on device\); the shards written "
                             r"before it are kept in .*run the same sweep again to resume") as stop:
        sweep(n=64, checkpoint=tmp_path, shard_size=16)
    assert isinstance(stop.value, OSError) and stop.value.errno == errno.ENOSPC
    assert sorted(p.name for p in tmp_path.iterdir()) == [LOCK, "manifest.json", "shard-000000000000.npz",
                                                         "shard-000000000016.npz"]  # no half-written file
    partial = stop.value.partial
    assert partial.n == 48  # the shard that could not be written is in it too
    monkeypatch.undo()
    resumed, whole = sweep(n=64, checkpoint=tmp_path, shard_size=16), sweep(n=64)
    for k in whole.metrics:
        np.testing.assert_array_equal(resumed.metrics[k], whole.metrics[k], err_msg=k)
        np.testing.assert_array_equal(partial.metrics[k], whole.metrics[k][:48], err_msg=k)


def test_quantiles_agree_in_memory_and_from_the_shards_in_shape_and_when_every_sample_fell(tmp_path):
    """A scalar level gives a float either way (the shards gave a length-1 array); a sweep in
    which every sample fell gives NaN shaped as q either way (in memory a TypeError)."""
    tipped = {"phi0": twip.Uniform(low=1.5, high=1.6)}  # past the fall limit: every robot falls
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = [sweep(n=20), sweep(n=20, perturb=tipped)]
        twip.set_memory_budget(20 * tsweep.BYTES_PER_SAMPLE - 1)  # the metrics no longer fit: streamed
        try:
            results += [sweep(n=20, checkpoint=tmp_path / "a", shard_size=8),
                        sweep(n=20, perturb=tipped, checkpoint=tmp_path / "b", shard_size=8)]
        finally:
            twip.set_memory_budget(None)
    whole, fell, streamed, streamed_fell = results
    assert isinstance(streamed, tsweep.StreamedSweepResult) and fell.fall_rate == streamed_fell.fall_rate == 1.0
    for s in (whole, streamed):
        median = s.quantiles("peak_current", 0.5)
        assert np.ndim(median) == 0 and median == whole.quantiles("peak_current", (0.5,))[0]
    for s in (fell, streamed_fell):
        assert math.isnan(s.quantiles("peak_current", 0.5))
        for q in ((0.05, 0.5, 0.95), [[0.5]]):
            got = s.quantiles("peak_current", q)
            assert got.shape == np.shape(q) and np.isnan(got).all()


def test_streamed_quantiles_are_numpys_exactly():
    rng = np.random.default_rng(5)
    for data in (rng.normal(size=20_000), rng.integers(0, 3, 9_000).astype(float), np.array([2.5]),
                 np.concatenate([rng.exponential(size=5000), [np.inf] * 7, [-1e300]])):
        chunks = np.array_split(data, 13)
        q = (0.0, 0.05, 0.5, 0.95, 0.999, 1.0)
        old = quantiles._EXACT
        quantiles._EXACT = 100  # force several narrowing passes
        try:
            got = quantiles.streamed_quantiles(lambda: iter(chunks), q)
        finally:
            quantiles._EXACT = old
        with np.errstate(invalid="ignore"):  # numpy's inf - inf, as ours
            np.testing.assert_array_equal(got, np.quantile(data, q))


def test_streamed_quantiles_are_numpys_bits_from_the_nearer_end():
    """numpy interpolates from the upper value when the weight is 0.5 or more, and from the
    next rank even at a whole index (1 + inf·0: NaN): the same bits, and the same shape as q."""
    rng = np.random.default_rng(8)
    for _ in range(200):
        data = rng.normal(size=rng.integers(1, 200)) * 10 ** rng.uniform(-5, 5)
        q = rng.uniform(size=4)
        np.testing.assert_array_equal(quantiles.streamed_quantiles(lambda: iter(np.array_split(data, 3)), q),
                                      np.quantile(data, q))
    with np.errstate(invalid="ignore"):
        assert math.isnan(quantiles.streamed_quantiles(lambda: iter([np.array([0.0, 1.0, np.inf])]), 0.5))
        assert math.isnan(np.quantile([0.0, 1.0, np.inf], 0.5))
    zero = quantiles.streamed_quantiles(lambda: iter([np.array([-0.0])]), 0.0)
    assert zero == 0.0 and math.copysign(1, zero) == math.copysign(1, np.quantile([-0.0], 0.0))
    one = quantiles.streamed_quantiles(lambda: iter([np.arange(5.0)]), 0.5)
    assert one == 2.0 and np.ndim(one) == 0  # a scalar level: a float, as np.quantile's
    np.testing.assert_array_equal(quantiles.streamed_quantiles(lambda: iter([np.arange(5.0)]), [[0.5, 1.0]]),
                                  [[2.0, 4.0]])
    assert math.isnan(quantiles.streamed_quantiles(lambda: iter([]), 0.5))


def test_streamed_quantiles_of_values_wider_than_the_largest_double():
    """-1e308..1e308: the range's width overflows to inf, which sent the bins down the
    infinities' three-bin path, where every finite value shares a bin: it never narrowed."""
    data = np.r_[np.random.default_rng(0).normal(size=300), [-1e308, 1e308, 1e308]]
    q = (0.0, 0.05, 0.5, 0.99, 1.0)
    old = quantiles._EXACT
    quantiles._EXACT = 100  # force the narrowing passes
    try:
        got = quantiles.streamed_quantiles(lambda: iter(np.array_split(data, 4)), q)
    finally:
        quantiles._EXACT = old
    np.testing.assert_array_equal(got, np.quantile(data, q))


def test_streamed_quantiles_refuse_levels_outside_0_1():
    """As the sweeps' quantiles: q = -0.1 extrapolated below the minimum."""
    chunks = lambda: iter([np.arange(10.0)])  # noqa: E731
    for bad in (-0.1, [0.5, 1.5], float("nan")):
        with pytest.raises(twip.InvalidParameterError, match=r"q = .*: quantile levels must be in \[0, 1\]"):
            quantiles.streamed_quantiles(chunks, bad)
    with pytest.raises(TypeError, match="q must be quantile levels"):
        quantiles.streamed_quantiles(chunks, "median")


# ---------------------------------------------------------------- 3. checkpoints that cannot lie

HOLD_LOCK = """
import sys, time
from twip.checkpoint import Checkpoint
from twip import sweep
c = Checkpoint(sys.argv[1], {"held": True}, 8)
print("locked", flush=True)
time.sleep(60)
"""


def test_a_second_writer_is_refused_naming_the_holder(tmp_path):
    holder = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(twip.InvalidParameterError,
                           match=f"in use by another sweep: pid {holder.pid} on host {socket.gethostname()}"):
            sweep(checkpoint=tmp_path)
    finally:
        holder.kill()
        holder.wait()
    assert not list(tmp_path.glob("shard-*"))
    # Killed without releasing: its lock is stale, taken over with a warning naming it.
    with pytest.warns(UserWarning, match=f"took over the lock left by pid {holder.pid}"):
        with pytest.raises(twip.InvalidParameterError, match="different configuration"):
            sweep(checkpoint=tmp_path)  # the holder's (made-up) sweep is in the folder
    assert json.loads((tmp_path / LOCK).read_text() or "{}") == {}  # released cleanly


def test_two_sweeps_started_together_on_one_folder_never_both_run(tmp_path):
    code = """
import sys, twip
try:
    twip.montecarlo("flat-lqr-sim", 4000, seed=int(sys.argv[2]), progress=False, checkpoint=sys.argv[1],
                    shard_size=100, options={"t_final": 0.5}, threads=1)
    print("ran")
except twip.InvalidParameterError as e:
    print("refused:", e)
"""
    procs = [subprocess.Popen([sys.executable, "-c", code, str(tmp_path), str(seed)], stdout=subprocess.PIPE, text=True)
             for seed in (1, 2)]
    outs = [p.communicate(timeout=120)[0] for p in procs]
    assert sum(o.startswith("ran") for o in outs) == 1, outs
    for o in outs:  # a loser is told why: in use, or (after the winner) another configuration
        assert o.startswith("ran") or "in use by another sweep" in o or "different configuration" in o, outs
    seed = json.loads((tmp_path / "manifest.json").read_text())["manifest"]["config"]["seed"]
    again = twip.montecarlo("flat-lqr-sim", 4000, seed=seed, progress=False, checkpoint=tmp_path, shard_size=100,
                            options={"t_final": 0.5})
    fresh = twip.montecarlo("flat-lqr-sim", 4000, seed=seed, progress=False, options={"t_final": 0.5})
    np.testing.assert_array_equal(again.metrics["t_end"], fresh.metrics["t_end"])


def test_a_foreign_shard_is_named_and_recomputed(tmp_path):
    sweep(n=32, seed=1, checkpoint=tmp_path / "other", shard_size=16)
    sweep(n=32, seed=2, checkpoint=tmp_path / "mine", shard_size=16)
    shutil.copy(tmp_path / "other" / "shard-000000000016.npz", tmp_path / "mine" / "shard-000000000016.npz")
    with pytest.warns(UserWarning, match=r"shard-000000000016.npz belongs to another sweep.*recomputing"):
        resumed = sweep(n=32, seed=2, checkpoint=tmp_path / "mine", shard_size=16)
    fresh = sweep(n=32, seed=2)
    for k in fresh.metrics:
        np.testing.assert_array_equal(resumed.metrics[k], fresh.metrics[k], err_msg=k)


@pytest.mark.parametrize("damage", ["truncate", "flip", "empty"])
def test_a_corrupt_or_truncated_shard_is_named_and_recomputed(tmp_path, damage):
    sweep(n=32, checkpoint=tmp_path, shard_size=16)
    path = tmp_path / "shard-000000000000.npz"
    data = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "flip":  # same size, one byte of a stored array changed
        path.write_bytes(_flip_a_value(data))
    else:
        path.write_bytes(b"")
    with pytest.warns(UserWarning, match=r"shard-000000000000.npz is (unreadable|corrupt).*recomputing"):
        resumed = sweep(n=32, checkpoint=tmp_path, shard_size=16)
    fresh = sweep(n=32)
    np.testing.assert_array_equal(resumed.metrics["t_end"], fresh.metrics["t_end"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the recomputed shard is sound again
        sweep(n=32, checkpoint=tmp_path, shard_size=16)


def _flip_a_value(npz: bytes) -> bytes:
    """The npz with one stored float of t_end changed (stored uncompressed, so findable)."""
    import io
    import zipfile

    src = zipfile.ZipFile(io.BytesIO(npz))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            raw = src.read(item)
            if item.filename == "t_end.npy":
                raw = raw[:-8] + np.float64(123.0).tobytes()
            dst.writestr(item, raw)
    return out.getvalue()


def test_an_unwritable_folder_is_refused_before_any_work(tmp_path, monkeypatch):
    ran = []
    monkeypatch.setattr(tsweep, "run_samples", lambda *a, **k: ran.append(a))
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    with pytest.raises(twip.InvalidParameterError, match="cannot create the folder"):
        sweep(checkpoint=blocker / "sub")
    with pytest.raises(twip.InvalidParameterError, match="is not a folder"):
        sweep(checkpoint=blocker)
    real_open = os.open

    def read_only(path, flags, *args):  # as a read-only folder answers (root ignores chmod)
        if str(path).startswith(str(tmp_path / "ro")) and flags & os.O_CREAT:
            raise PermissionError(13, "Permission denied")
        return real_open(path, flags, *args)

    monkeypatch.setattr(os, "open", read_only)
    (tmp_path / "ro").mkdir()
    with pytest.raises(twip.InvalidParameterError, match="is not writable .*Permission denied"):
        sweep(checkpoint=tmp_path / "ro")
    assert ran == []


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_folder_is_refused_before_any_work(tmp_path, monkeypatch):
    ran = []
    monkeypatch.setattr(tsweep, "run_samples", lambda *a, **k: ran.append(a))
    tmp_path.chmod(0o500)
    try:
        with pytest.raises(twip.InvalidParameterError, match="not writable"):
            sweep(checkpoint=tmp_path)
    finally:
        tmp_path.chmod(0o700)
    assert ran == []


def test_by_name_and_by_scenario_object_share_one_checkpoint(tmp_path, monkeypatch):
    sweep(n=32, checkpoint=tmp_path, shard_size=16)  # by name, as the API is called
    sc = scenarios.get("flat-lqr-sim", **SHORT)  # a Scenario object, as the CLI passes it
    monkeypatch.setattr(tsweep, "run_samples", lambda *a, **k: pytest.fail("a finished shard was run again"))
    r = twip.montecarlo(sc, 32, perturb=PERTURB, seed=3, progress=False, checkpoint=tmp_path, shard_size=16)
    assert r.n == 32


# ---------------------------------------------------------------- 5. errors name what was given

def test_shape_errors_print_the_shape_received():
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    for shape in ((4, 1), (2, 2)):
        with pytest.raises(twip.ShapeError, match=rf"gains has shape \({shape[0]}, {shape[1]}\), expected \(4,\) or \(1, 4\)"):
            twip.LqrController(model, np.ones(shape))
    with pytest.raises(twip.ShapeError, match=r"gains has shape \(3,\), expected \(4,\) or \(1, 4\)"):
        twip.LqrController(model, np.ones(3))
    # python-control's K is a (1, n) row: taken as it is.
    np.testing.assert_array_equal(twip.LqrController(model, np.arange(1.0, 5.0)[None, :]).gains, [1, 2, 3, 4])
    with pytest.raises(twip.NonFiniteError, match=r"Q\[0\] = NaN"):
        twip.LqrController.design(model, 0.0, [np.nan, 1, 1, 1], 1.0)
    with pytest.raises(twip.ShapeError, match=r"Q has shape \(3,\), expected \(4,\) \(its diagonal\) or \(4, 4\)"):
        twip.LqrController.design(model, 0.0, [1, 1, 1], 1.0)


@pytest.mark.parametrize("x0, index, kind", [
    (["0", "0", "0", "0"], 0, "str"), ([0, 0, 1j, 0], 2, "complex"), ([0, 0, 0, "1.0"], 3, "str"),
    ([0, None, 0, 0], 1, "NoneType"),
])
def test_non_real_entries_are_refused_with_their_index(x0, index, kind):
    sc = scenarios.get("flat-lqr-sim")
    with pytest.raises(twip.InvalidParameterError, match=rf"x0\[{index}\] = .*not a real number \(got {kind}\)"):
        twip.simulate(sc.model, sc.controller, x0, 0.1)


@pytest.mark.parametrize("kw, message", [
    (dict(record_every=-1), "record_every = -1"), (dict(record_every=0), "record_every = 0"),
    (dict(record_every=1.5), "record_every = 1.5"), (dict(t_final="1"), "t_final = '1'"),
    (dict(control_period=0.0), "control_period must be finite and > 0, got 0.0"),  # was "invalid period = 0"
])
def test_simulate_counts_and_times_are_checked(kw, message):
    sc = scenarios.get("flat-lqr-sim")
    args = dict(t_final=0.1, **kw) if "t_final" not in kw else kw
    with pytest.raises(ValueError, match=message):
        twip.simulate(sc.model, sc.controller, np.zeros(4), **args)


@pytest.mark.parametrize("kw, message", [
    (dict(control_period="x"), r"control_period must be a real number, got 'x' \(str\)"),
    (dict(fall_limit="a"), r"fall_limit must be a pitch angle \[rad\], got 'a' \(str\)"),
    (dict(reference=twip.Circle(1.0, 1.0)), r"reference must be a twip.SpeedSchedule \(a trajectory such as twip.Circle"),
])
def test_simulate_arguments_of_the_wrong_type_are_type_errors_naming_them(kw, message):
    # Were "must be real number, not str", "could not convert string to float: 'a'" and
    # "'Circle' object is not an instance of 'SpeedSchedule'".
    sc = scenarios.get("flat-lqr-sim")
    with pytest.raises(TypeError, match=message):
        twip.simulate(sc.model, sc.controller, np.zeros(4), 0.1, **kw)


@pytest.mark.parametrize("kw, message", [
    (dict(n=-1), "n = -1"), (dict(n=0), "n = 0"), (dict(traces=[-1]), "sample index -1"),
    (dict(trace_every=-2, traces=[0]), "trace_every = -2"), (dict(shard_size=-3), "shard_size = -3"),
    (dict(threads=-1), "threads = -1"), (dict(seed=-1), "seed = -1"),
])
def test_negative_counts_are_value_errors_naming_the_argument(kw, message):
    with pytest.raises(ValueError, match=message):
        sweep(**{"n": 8, **kw})


@pytest.mark.parametrize("make, message", [
    (lambda: twip.Uniform(rel="0.2"), r"Uniform\(rel='0.2'\): rel must be a number, got str"),
    (lambda: twip.Uniform(low=[0], high=1), "low must be a number, got list"),
    (lambda: twip.Normal(std="1"), "std must be a number, got str"),
    (lambda: twip.Normal(std=1, low=None), "low must be a number, got NoneType"),
])
def test_distributions_check_their_types(make, message):
    with pytest.raises(twip.InvalidParameterError, match=message):
        make()


# ---------------------------------------------------------------- 6. honest numbers

def test_settled_metrics_are_nan_and_warned_of_when_the_run_ends_before_the_settle_time():
    sc = scenarios.get("circle-pid", laps=1)
    r = sc.run(t_final=2.0)  # the settled part starts after one lap
    assert any(re.search(r"ended at t = 2 s \(t_final = 2 s\), before settle = 36 s \(by default one lap", w)
               for w in r.warnings), r.warnings
    for name in ("mean_abs_x_error_settled", "mean_abs_y_error_settled", "max_path_error_settled"):
        assert np.isnan(r.metrics[name]), name
    assert np.isfinite(r.metrics["mean_abs_x_error"])
    assert any("before settle = 2.5 s: the _settled metrics are NaN" in w for w in sc.run(t_final=2.0, settle=2.5).warnings)
    settled = sc.run(t_final=2.0, settle=2.0)  # settled from the run's last sample on: no warning
    assert np.isfinite(settled.metrics["max_path_error_settled"]) and not settled.warnings
    # A sweep of such runs says so in its summary (and the CLI prints it), not only NaN quantiles.
    short = twip.montecarlo(sc.replace(t_final=2.0), 4, progress=False).summary()
    assert np.isnan(short["max_path_error_settled"]["median"]) and np.isfinite(short["mean_abs_x_error"]["median"])
    assert any("_settled metrics are NaN: the runs ended before their settle time" in w for w in short["warnings"])
    assert twip.montecarlo("flat-lqr", 4, progress=False).summary()["warnings"] == ()


@pytest.mark.parametrize("settle, error, message", [
    (-1, twip.InvalidParameterError, "settle must be finite and >= 0, got -1"),
    (float("nan"), twip.InvalidParameterError, "settle must be finite and >= 0, got nan"),
    ("1", TypeError, r"settle must be a real number, got '1' \(str\)"),
])
def test_a_settle_time_is_a_finite_time_from_the_start(settle, error, message):
    sc = scenarios.get("circle-pid", laps=1)
    with pytest.raises(error, match=message):
        sc.run(t_final=0.1, settle=settle)


def test_invalid_samples_are_counted_per_reason_and_absolute_spreads_warned():
    # ±20 kg on a 1.4 kg body: the percent sign forgotten.
    with pytest.warns(UserWarning, match=r"m_body: ± 20 is more than half the nominal"):
        r = twip.montecarlo("flat-lqr-sim", 200, perturb={"m_body": twip.Uniform(abs=20)}, progress=False,
                            options=SHORT)
    s = r.summary()
    assert s["invalid"] == int(np.sum(~r.valid)) > 0
    assert s["invalid_reasons"] == {"m_body: must be > 0": s["invalid"]}
    assert f"invalid: {s['invalid']} m_body: must be > 0" in repr(r)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a relative spread, or a small absolute one: no warning
        twip.montecarlo("flat-lqr-sim", 8, perturb={"m_body": twip.Uniform(abs=0.1)}, progress=False, options=SHORT)


# ---------------------------------------------------------------- 5. plot and animation arguments

def test_figure_paths_are_checked_before_a_run(tmp_path):
    from twip import plot

    with pytest.raises(twip.InvalidParameterError, match=r"'.txt' is not a figure format; use one of .*\.png"):
        plot.check_path(tmp_path / "x.txt")
    with pytest.raises(twip.InvalidParameterError, match="does not exist"):
        plot.check_path(tmp_path / "missing" / "x.png")
    plot.check_path(tmp_path / "x.svg")  # a format matplotlib writes


@pytest.mark.parametrize("kw, message", [
    (dict(path="a.png"), "must end in .gif"), (dict(fps=1e9), "fps = 1000000000.0"), (dict(fps=0), "fps = 0"),
    (dict(fps="20"), "fps = '20'"), (dict(speed=-1.0), "speed = -1.0"), (dict(size=(10**6, 10)), "size = "),
    (dict(path="missing/a.gif"), "does not exist"), (dict(max_seconds=0), "max_seconds must be finite and > 0, got 0"),
    (dict(max_seconds=float("nan")), "max_seconds must be finite and > 0, got nan"),
    (dict(max_seconds=-5), "max_seconds must be finite and > 0, got -5"),
])
def test_animation_arguments_are_checked_before_a_run(tmp_path, kw, message):
    from twip import animate

    kw = {"path": "a.gif", **kw}
    kw["path"] = tmp_path / kw["path"]
    with pytest.raises(twip.InvalidParameterError, match=message):
        animate.check_options(**kw)


def test_an_animations_max_seconds_and_slope_are_checked_before_drawing(tmp_path):
    # max_seconds = 0 was a ZeroDivisionError, -5 an IndexError, a NaN slope "cannot
    # convert float NaN to integer".
    from twip import animate

    r = scenarios.get("flat-lqr-sim").run(t_final=0.1)
    with pytest.raises(twip.InvalidParameterError, match="max_seconds must be finite and > 0, got 0"):
        animate.gif(r, tmp_path / "a.gif", max_seconds=0)
    with pytest.raises(twip.InvalidParameterError, match="slope must be finite, got nan"):
        animate.gif(r, tmp_path / "a.gif", slope=float("nan"))
    assert not (tmp_path / "a.gif").exists()


def test_an_animation_too_large_for_the_budget_is_refused_before_drawing(tmp_path):
    from twip import animate

    r = scenarios.get("flat-lqr-sim").run(t_final=2.0)
    twip.set_memory_budget(10**6)
    try:
        with pytest.raises(twip.MemoryBudgetError, match=r"animation: [0-9,]+ frames of 560x340 pixels.*lower fps"):
            animate.gif(r, tmp_path / "a.gif", fps=100, speed=0.01)
    finally:
        twip.set_memory_budget(None)
    assert not (tmp_path / "a.gif").exists()


def test_samples_past_the_last_index_are_an_error_not_an_empty_sweep():
    # start + count wrapped past 2^64 - 1 to an empty range: no samples, no error.
    sc = scenarios.get("flat-lqr")
    with pytest.raises(twip.InvalidParameterError, match="count = 10: start \\+ count passes the last sample index"):
        twip._core.sweep_raw(sc.model, sc.controller, list(sc.x0), 1.0, sc.dt, sc.reference, [], 1, 2**64 - 2, 10)


def test_interval_levels_and_sample_indices_are_checked():
    # A NaN confidence gave (0.5, 0.5); replay(99) of a 5-sample sweep ran a robot the
    # sweep never drew (rerun refused it).
    from twip.distributions import wilson_interval

    for args, message in (((5, 10, float("nan")), "confidence = nan"), ((5, 10, 1.5), "confidence = 1.5"),
                          ((-1, 10), "successes = -1: must be from 0 to n = 10")):
        with pytest.raises(twip.InvalidParameterError, match=message):
            wilson_interval(*args)
    r = twip.montecarlo("flat-lqr-sim", 5, progress=False, options=SHORT)
    with pytest.raises(twip.InvalidParameterError, match="confidence = nan"):
        r.fall_rate_interval(confidence=float("nan"))
    for bad in (99, -1, 2**70, 1.5, True):
        for call in (r.replay, r.sample, r.rerun):
            with pytest.raises(twip.InvalidParameterError, match=re.escape(f"index = {bad!r}: this sweep has samples 0..4")):
                call(bad)


# ---------------------------------------------------------------- the command line

def cli(args, capsys):
    from twip import cli as twip_cli

    try:
        code = twip_cli.main([str(a) for a in args])
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("args, message", [
    (["--plot", "{tmp}/x.txt"], "--plot: figure path .*'.txt' is not a figure format"),
    (["--plot", "{tmp}/missing/x.png"], "--plot: .*does not exist"),
    (["--animate", "{tmp}/a.gif", "--fps", "1e9"], "--animate: fps = 1000000000.0"),
    (["--animate", "{tmp}/a.png"], "--animate: .*must end in .gif"),
    (["--param", "wheel_radius=1e-9"], "wheel_radius = 1e-09 m: a 1 m leg"),
])
def test_cli_simulate_refuses_bad_outputs_before_the_run(tmp_path, capsys, args, message):
    code, out, err = cli(["simulate", "flat-lqr"] + [a.replace("{tmp}", str(tmp_path)) for a in args], capsys)
    assert code == 2 and "Traceback" not in err
    assert "outcome:" not in out  # nothing ran
    assert len(err.strip().splitlines()) == 1 and re.search(message, err), err


def test_cli_sweep_refuses_bad_outputs_before_the_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(tsweep, "run_samples", lambda *a, **k: pytest.fail("a sample ran"))
    # A second --perturb of the same quantity silently replaced the first.
    code, _, err = cli(["sweep", "flat-lqr", "-n", "5", "--perturb", "m_body=±5%", "--perturb", "m_body=±60%"], capsys)
    assert code == 2 and "--perturb m_body: given more than once" in err, err
    for args, message in ((["--plot", tmp_path / "x.txt"], "'.txt' is not a figure format"),
                          (["--csv", tmp_path / "no" / "x.csv"], "--csv: .*does not exist"),
                          (["--checkpoint", tmp_path / "f" / "g"], None)):
        (tmp_path / "f").write_text("a file where a folder should be") if message is None else None
        code, out, err = cli(["sweep", "flat-lqr-sim", "-n", "8"] + args, capsys)
        assert code == 2 and "Traceback" not in err, err
        assert re.search(message or "cannot create the folder", err), err


def test_cli_sweep_warns_of_absolute_spreads_and_counts_invalid_samples(capsys):
    code, out, err = cli(["sweep", "flat-lqr-sim", "-n", "200", "--perturb", "m_body=±20", "--option", "t_final=0.5",
                          "--quiet"], capsys)
    assert code == 0, err
    assert "twip sweep: warning: m_body: ± 20 is more than half the nominal" in err
    invalid = int(re.search(r"200 samples \((\d+) invalid\)", out).group(1))
    assert invalid > 0
    assert f"invalid: {invalid} samples, m_body: must be > 0" in out
    assert f"over the {200 - invalid} valid samples" in out


def test_cli_and_api_read_each_others_checkpoints(tmp_path, capsys, monkeypatch):
    args = ["sweep", "flat-lqr-sim", "-n", "64", "--perturb", "m_body=±20%", "--perturb", "phi0=~0.05", "--seed", "3",
            "--option", "t_final=0.5", "--quiet", "--json"]
    code, out, err = cli(args + ["--checkpoint", tmp_path / "cli"], capsys)
    assert code == 0, err
    cli_summary = json.loads(out)
    api = sweep(n=64, checkpoint=tmp_path / "api")
    with monkeypatch.context() as m:
        m.setattr(tsweep, "run_samples", lambda *a, **k: pytest.fail("a finished shard was run again"))
        from_cli = sweep(n=64, checkpoint=tmp_path / "cli")  # the API resumes the CLI's folder
        code, out, err = cli(args + ["--checkpoint", tmp_path / "api"], capsys)  # and the CLI the API's
    assert code == 0, err
    assert json.loads(out)["fall_rate_95ci"] == cli_summary["fall_rate_95ci"]
    np.testing.assert_array_equal(from_cli.metrics["t_end"], api.metrics["t_end"])


def test_cli_ctrl_c_prints_the_partial_summary_and_the_resume_command(tmp_path):
    folder = tmp_path / "ck"
    cmd = [sys.executable, "-m", "twip", "sweep", "flat-lqr-sim", "-n", "60000", "--option", "t_final=3",
           "--perturb", "m_body=±10%", "--checkpoint", str(folder), "--quiet", "--threads", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    import time

    deadline = time.monotonic() + 60
    while not list(folder.glob("shard-*.npz")):
        assert time.monotonic() < deadline and proc.poll() is None, "no shard was written"
        time.sleep(0.02)
    proc.send_signal(__import__("signal").SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert re.search(r"interrupted: the [\d,]+ samples that finished:", err), err
    assert "fall rate" in err and "resume with:" in err
    resume = err.split("resume with:")[1].strip().splitlines()[0]
    assert resume.startswith("twip sweep flat-lqr-sim -n 60000") and str(folder) in resume


class _BlowsUp:
    """Holds the input at 0 until `at`, then at 1e300 A (finite: a NaN input is an error),
    which makes the state overflow: a controller whose run diverges."""

    period = 1e-3

    def __init__(self, at):
        self.at = at

    def reset(self):
        pass

    def update(self, t, y, ref):
        return 0.0 if t < self.at else 1e300


def test_a_run_that_fell_or_diverged_never_settled():
    """Its settling times are its end, in a run, in a sweep's sample (on lanes and through a
    Python controller) and in its replay. Before, a diverged run's covered only the samples
    before it: 0 when it blew up at the first step, and a standing robot whose controller
    blew up at 0.2 s read its pitch as settled at 0."""
    sc = scenarios.get("flat-lqr-sim", t_final=1.0)
    wild = twip.LqrController(sc.model, [-1e150] * 4, point="operating", period=1e-3)
    upright = [sc.model.equilibrium(0.0)[0][0], 0.0, 0.0, 0.0]
    runs = [twip.simulate(sc.model, wild, sc.x0, 1.0, reference=sc.reference),
            twip.simulate(sc.model, _BlowsUp(0.2), upright, 1.0, reference=twip.SpeedSchedule.constant(0.0))]
    assert [r.outcome for r in runs] == ["diverged", "diverged"] and runs[1].t_end > 0.2
    sweeps = [twip.montecarlo(sc.replace(controller=wild), 4, perturb={"m_body": twip.Uniform(rel=0.1)}, progress=False),
              twip.montecarlo(sc.replace(controller=_BlowsUp(0.2), x0=upright), 2, progress=False)]
    runs += [s.replay(i) for s in sweeps for i in range(s.n)]
    for r in runs:
        assert r.fell and r.metrics["pitch_settling_time"] == r.metrics["speed_settling_time"] == r.t_end, r.metrics
    for s in sweeps:
        m = s.metrics
        assert m["fell"].all() and (m["pitch_settling_time"] == m["t_end"]).all(), m
        assert (m["speed_settling_time"] == m["t_end"]).all(), m


def test_a_diverged_run_is_a_fall_as_sweeps_count_it():
    """Gains of 1e150 blow the state up in one step: the outcome is "diverged", and `fell` said
    False while the sweep of the same robots counted every sample as fallen (so `replay(i).fell`
    disagreed with `metrics["fell"][i]`)."""
    sc = scenarios.get("flat-lqr-sim", t_final=1.0)
    wild = twip.LqrController(sc.model, [-1e150] * 4, point="operating", period=1e-3)
    r = twip.simulate(sc.model, wild, sc.x0, 1.0, reference=sc.reference)
    assert r.outcome == "diverged" and r.fell and r.t_fall == r.t_end == 0.001
    sweep = twip.montecarlo(sc.replace(controller=wild), 4, perturb={"m_body": twip.Uniform(rel=0.1)}, progress=False)
    assert sweep.metrics["fell"].all() and all(sweep.replay(i).fell for i in range(4))


def test_ctrl_c_while_the_traces_replay_keeps_every_finished_sample(monkeypatch):
    """The traces are replayed once every sample has finished; a Ctrl-C there (measured: 5 s
    of replays after a 0.35 s sweep) gave a partial result of 0 samples: the whole sweep
    was lost. Now the partial is the sweep, with the traces replayed before the Ctrl-C."""
    from twip.sweep_result import SweepResult

    replay, calls = SweepResult.replay, []

    def interrupted(self, index, **options):
        calls.append(index)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return replay(self, index, **options)

    monkeypatch.setattr(SweepResult, "replay", interrupted)
    with pytest.raises(KeyboardInterrupt) as stop:
        sweep(n=48, traces=[3, 7, 9])
    partial = stop.value.partial
    assert partial.n == 48 and list(partial.traces) == [3]
    monkeypatch.undo()
    whole = sweep(n=48)
    for k in whole.metrics:
        np.testing.assert_array_equal(partial.metrics[k], whole.metrics[k], err_msg=k)


def test_a_shard_that_finished_as_the_ctrl_c_came_is_kept(tmp_path, monkeypatch):
    """A Ctrl-C noticed as a shard's last samples finished marks the shard interrupted with
    every sample done: it was held in the partial result but never written to the checkpoint."""
    run, shards = tsweep.run_samples, []

    def ctrl_c_at_the_end_of_the_second(*args, **kwargs):
        raw = run(*args, **kwargs)
        shards.append(1)
        raw["interrupted"] = len(shards) == 2
        return raw

    monkeypatch.setattr(tsweep, "run_samples", ctrl_c_at_the_end_of_the_second)
    with pytest.raises(KeyboardInterrupt) as stop:
        sweep(n=64, checkpoint=tmp_path, shard_size=16)
    assert stop.value.partial.n == 32
    assert sorted(p.name for p in tmp_path.glob("shard-*")) == ["shard-000000000000.npz", "shard-000000000016.npz"]


def test_ctrl_c_while_a_shard_is_written_keeps_that_shard(tmp_path, monkeypatch):
    """A Ctrl-C that lands while a finished shard is written (here sent from inside the write)
    acts once the shard is kept: the file is whole and the partial result has it. Before, a
    KeyboardInterrupt inside numpy's zip writer surfaced as a ValueError with no partial
    result (seen once under two pytest workers), and one inside the write dropped the shard."""
    from twip.checkpoint import Checkpoint
    write = Checkpoint._write

    def interrupted_write(path, data):
        if path.name.startswith("shard-"):
            signal.raise_signal(signal.SIGINT)
        write(path, data)

    monkeypatch.setattr(Checkpoint, "_write", staticmethod(interrupted_write))
    sc = scenarios.get("flat-lqr-sim", t_final=0.2)
    with pytest.raises(KeyboardInterrupt) as stop:
        twip.montecarlo(sc, 64, checkpoint=tmp_path / "ck", shard_size=16, progress=False)
    assert len(list((tmp_path / "ck").glob("shard-*.npz"))) == 1
    assert stop.value.partial.n == 16 and stop.value.partial.valid.all()
    monkeypatch.undo()
    again = twip.montecarlo(sc, 64, checkpoint=tmp_path / "ck", shard_size=16, progress=False)
    assert again.n == 64


# --- float parameters: no bool, no complex ------------------------------------------------
# pyo3 read a float through __float__: a numpy complex lost its imaginary part with only a
# ComplexWarning (Circle(np.complex128(1+1j), 1) had radius 1) and a bool was 0 or 1
# (Realism(control_period=True) ran at 1 s). Every float parameter of the bindings refuses
# them; other real numbers (int, numpy's, Fraction) read as before.

NOT_REAL = [np.complex128(1 + 1j), np.complex64(1 + 1j), True, np.True_]
_P = twip.RobotParams.balanbot()
_SLOPE, _PLANAR = twip.SlopeModel(_P), twip.PlanarModel(_P)
_LQR = scenarios.get("flat-lqr-sim").controller
_PID = twip.PidTracker.table_4_1()
_STILL = twip.SpeedSchedule.constant(0.0)
_LINE = twip.Line(0.1)


def _shoot(max_step):
    t = np.linspace(0.0, 0.1, 11)
    return twip._core.sysid_shoot([_SLOPE], np.zeros((1, 1, 4)), t, np.zeros(11), np.array([0]), max_step=max_step)


# (parameter, a valid whole number for it, the call with `v` there): one or more per binding file.
FLOAT_PARAMETERS = {
    "Friction": ("coulomb", 1, lambda v: twip.Friction(v)),
    "Friction.torque": ("w", 1, lambda v: twip.Friction.gb37().torque(v)),
    "SlopeModel": ("slope", 0, lambda v: twip.SlopeModel(_P, slope=v)),
    "SlopeModel.equilibrium": ("theta_dot_ref", 1, lambda v: _SLOPE.equilibrium(v)),
    "PlanarModel.mass_matrix": ("phi", 0, lambda v: _PLANAR.mass_matrix(v)),
    "rk4_step": ("dt", 1, lambda v: twip.rk4_step(_SLOPE, np.zeros(4), 0.0, v)),
    "Terrain.plane": ("slope", 0, lambda v: twip.Terrain.plane(v)),
    "Terrain.ramp": ("blend", 1, lambda v: twip.Terrain.ramp(0.1, blend=v)),
    "BalanceBatch": ("fall_limit", 1, lambda v: twip._core.BalanceBatch(_SLOPE, np.zeros(4), [], 1, 0.005, 1, v)),
    "TrackBatch": ("dt", 1, lambda v: twip._core.TrackBatch(_PLANAR, _LINE, np.zeros(7), [], 1, v, 1, 1.0)),
    "ffi_record": ("t_final", 1, lambda v: twip._core.ffi_record(_SLOPE, _LQR, [0.0] * 4, v, 0.001, _STILL)),
    "c2d": ("period", 1, lambda v: twip.c2d(np.eye(2), np.ones((2, 1)), v)),
    "simulate_raw": ("t_final", 1, lambda v: twip._core.simulate_raw(_SLOPE, _LQR, np.zeros(4), v, 0.001, _STILL)),
    "simulate_planar_raw": ("settle", 1, lambda v: twip._core.simulate_planar_raw(
        _PLANAR, _PID, np.zeros(7), 0.01, 0.005, _LINE, settle=v)),
    "sweep_draw": ("perturbations", 0, lambda v: twip._core.sweep_draw(
        _SLOPE, np.zeros(4), [("slope", 0, "uniform", v, 0.1, 0.0, 0.1)], 0, 0)),
    "sweep_raw": ("control_period", 1, lambda v: twip._core.sweep_raw(
        _SLOPE, _LQR, np.zeros(4), 2.0, 0.005, _STILL, [], 0, 0, 1, control_period=v)),
    "sweep_planar_raw": ("t_final", 1, lambda v: twip._core.sweep_planar_raw(
        _PLANAR, _PID, np.zeros(7), v, 0.005, _LINE, [], 0, 0, 1)),
    "sysid_shoot": ("max_step", 1, _shoot),
    "Gaussian": ("mean", 0, lambda v: twip.Gaussian(v, 1.0)),
    "FuzzyController": ("ki", 0, lambda v: twip.FuzzyController.thesis_flat(_SLOPE, ki=v)),
    "FuzzyBasis.grid": ("centres", 1, lambda v: twip.FuzzyBasis.grid("triangle", [[0, v], [0, 1]])),
    "LqrController": ("period", 1, lambda v: twip.LqrController(_SLOPE, _LQR.gains, period=v)),
    "LqrController.design": ("R", 1, lambda v: twip.LqrController.design(_SLOPE, 0.0, [1, 1, 1, 1], v)),
    "SpeedSchedule": ("legs", 1, lambda v: twip.SpeedSchedule([(v, 1.0, 0.0)])),
    "SpeedSchedule.go_and_return": ("hold", 1, lambda v: twip.SpeedSchedule.go_and_return(1.0, 1.0, 0.1, hold=v)),
    "PidTracker": ("period", 1, lambda v: twip.PidTracker(_P, period=v)),
    "SmcTracker": ("guards", 1, lambda v: twip.SmcTracker(_PLANAR, guards=(v, 0.2))),
    "SmcTracker.surface_gain": ("phi", 0, lambda v: twip.SmcTracker(_PLANAR).surface_gain(v)),
    "Circle": ("radius", 1, lambda v: twip.Circle(v, 1.0)),
    "Waypoints": ("points", 1, lambda v: twip.Waypoints([(0.0, 0.0), (v, 0.0)], 0.5)),
    "Line.sample": ("t", 1, lambda v: _LINE.sample(v)),
    "DcMotor": ("supply", 12, lambda v: twip.DcMotor.gb37y3530(supply=v)),
    "DcMotor.torque": ("voltage", 1, lambda v: twip.DcMotor.gb37y3530().torque(v, 0.0)),
    "Imu": ("height", 0, lambda v: twip.Imu(height=v)),
    "Dlpf": ("bandwidth_hz", 100, lambda v: twip.Dlpf(v, 0.001)),
    "TiltEstimator.kalman": ("r_angle", 1, lambda v: twip.TiltEstimator.kalman(r_angle=v)),
    "MotorDriver": ("current_limit", 2, lambda v: twip.MotorDriver(current_limit=v)),
    "Push": ("t", 1, lambda v: twip.Push(v, 0.1)),
    "Force": ("horizontal", 1, lambda v: twip.Force(horizontal=v)),
    "Realism": ("control_period", 1, lambda v: twip.Realism(control_period=v)),
    "Realism.slope_profile": ("slope_profile", 1, lambda v: twip.Realism(slope_profile=[(v, 0.1)])),
}


@pytest.mark.filterwarnings("error")  # refused, not cast with a ComplexWarning first
@pytest.mark.parametrize("value", NOT_REAL, ids=repr)
@pytest.mark.parametrize("call", FLOAT_PARAMETERS, ids=str)
def test_a_float_parameter_refuses_a_complex_number_or_a_bool(call, value):
    arg, _, make = FLOAT_PARAMETERS[call]
    refused_naming(make, value, arg, r"^expected a real number, got the (complex value|bool) ")


def refused_naming(make, value, arg: str, message: str):
    """`make(value)` raises a TypeError whose message is "`arg`: " and then matches `message`
    and shows the value. The name was only in pyo3's note ("while processing 'x'"), which
    str(error) leaves out and Python 3.9/3.10 (no add_note) never get."""
    with pytest.raises(TypeError, match=rf"^{re.escape(arg)}: {message.lstrip('^')}") as e:
        make(value)
    assert str(value) in str(e.value)  # (1+1j), True: also inside np.complex64(1+1j), np.True_
    assert isinstance(e.value, twip.ArgumentTypeError)


def test_a_type_error_names_the_argument_in_its_message_on_every_python():
    """Constructors, methods and functions alike: the message itself names the argument,
    for a value refused by twip's own reading (a bool) and by pyo3's (a string)."""
    import pickle

    for arg, call in [
        ("height", lambda: twip.Imu(height="x")),
        ("slope", lambda: twip.SlopeModel(_P, "0.1")),
        ("radius", lambda: twip.Circle(True, 1.0)),
        ("voltage", lambda: twip.DcMotor.gb37y3530().torque(1j, 0.0)),
        ("num_envs", lambda: twip._core.BalanceBatch(_SLOPE, np.zeros(4), [], "2", 0.005, 1, 1.0)),
    ]:
        with pytest.raises(twip.ArgumentTypeError) as e:
            call()
        assert str(e.value).startswith(f"{arg}: ") and str(e.value).count(f"{arg}: ") == 1, str(e.value)
    # pyo3 names the argument by calling add_note, which Python 3.9/3.10's TypeError lacks:
    # the class's own does it there too (and once, however often it is called).
    err = twip.ArgumentTypeError("expected a real number, got the bool True")
    err.add_note("while processing 'supply'")
    err.add_note("while processing 'supply'")
    assert str(err) == "supply: expected a real number, got the bool True"
    assert pickle.loads(pickle.dumps(err)).args == err.args  # a worker's error reaches the parent


@pytest.mark.parametrize("kind", [int, np.float32, np.int64, Fraction, Decimal])
@pytest.mark.parametrize("call", FLOAT_PARAMETERS, ids=str)
def test_a_float_parameter_takes_any_other_real_number(call, kind):
    _, whole, make = FLOAT_PARAMETERS[call]
    make(kind(whole))


@pytest.mark.parametrize("value", NOT_REAL, ids=repr)
def test_settings_read_by_name_refuse_a_complex_number_or_a_bool_naming_it(value):
    """Settings given by key (a dict, replace, from_dict) are named in the message itself."""
    for name, call in [
        ("Realism.replace: control_period", lambda: twip.Realism().replace(control_period=value)),
        ("Circle.from_dict: radius", lambda: twip.Circle.from_dict({"radius": value, "speed": 1.0})),
    ]:
        with pytest.raises(TypeError, match=rf"^{re.escape(name)}: expected a real number, got the "):
            call()
    for name, call in [
        ("RobotParams field 'm_body'", lambda: _P.replace(m_body=value)),
        ("PID gain 'kp_pitch'", lambda: twip.PidTracker(_P, gains={"kp_pitch": value})),
        ("controller.period", lambda: twip._core.simulate_raw(_SLOPE, _Update(value), np.zeros(4), 0.01, 0.005, _STILL)),
    ]:
        with pytest.raises(twip.InvalidParameterError, match=rf"^{re.escape(name)}.* {re.escape(str(value))}"):
            call()


class _Update:
    def __init__(self, period):
        self.period = period

    def update(self, t, y, ref):
        return 0.0


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("value", NOT_REAL, ids=repr)
def test_a_number_or_array_argument_refuses_a_complex_number_or_a_bool(value):
    """A scalar that may also be an array (an input, a membership's x, a Python controller's
    u) is read as an array when it is no real number: its entry is named, as an array's."""
    kind = "complex" if np.iscomplexobj(value) else "bool"
    for name, call in [
        ("u", lambda: _SLOPE.deriv(np.zeros(4), value)),
        ("x", lambda: twip.Triangle(-1.0, 0.0, 1.0)(value)),
        ("x0", lambda: twip.simulate(_SLOPE, _LQR, [0.0, 0.0, value, 0.0], 0.01)),
    ]:
        with pytest.raises(twip.InvalidParameterError, match=rf"^{name}\[\d\] = .*: not a real number \(got {kind}"):
            call()
    with pytest.raises(TypeError, match=rf"controller returned u = {re.escape(str(value))} .* at t = 0"):
        twip._core.simulate_raw(_SLOPE, lambda t, y, ref: value, np.zeros(4), 0.01, 0.005, _STILL)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("value", NOT_REAL, ids=repr)
def test_python_wrappers_refuse_a_complex_or_bool_entry_before_float_reads_it(value, tmp_path):
    from twip import interop
    from twip.firmware.export import export

    kind = "complex" if np.iscomplexobj(value) else "bool"
    sc = scenarios.get("flat-lqr-sim", t_final=0.2)
    x0 = [0.0, 0.0, value, 0.0]
    for name, call in [
        ("u0", lambda: interop.jacobians(_SLOPE, np.zeros(4), [value])),
        ("x0", lambda: twip.montecarlo(sc.replace(x0=x0), 2, perturb={"theta0": twip.Normal(std=0.1)}, progress=False)),
        ("x0", lambda: export(sc.replace(x0=x0), tmp_path / "out", replay_seconds=0.1)),
    ]:
        with pytest.raises(twip.InvalidParameterError, match=rf"^{name}\[\d\] = .*: not a real number \(got {kind}"):
            call()


# --- integer parameters: no bool ----------------------------------------------------------
# pyo3 read an integer through __index__, so a bool was 0 or 1: BalanceBatch(num_envs=True)
# built one env, record_every=True kept every sample, Realism(seed=True) had seed 1. Every
# integer parameter of the bindings refuses a bool; an int or a numpy integer reads as before.

NOT_INT = [True, np.True_]
_BALANCE = twip._core.BalanceBatch(_SLOPE, np.zeros(4), [], 1, 0.005, 1, 1.0)

# (parameter, a valid value, the call with `v` there): one or more per binding file.
INT_PARAMETERS = {
    "BalanceBatch": ("num_envs", 1, lambda v: twip._core.BalanceBatch(_SLOPE, np.zeros(4), [], v, 0.005, 1, 1.0)),
    "BalanceBatch.threads": ("threads", 1, lambda v: twip._core.BalanceBatch(
        _SLOPE, np.zeros(4), [], 1, 0.005, 1, 1.0, threads=v)),
    "BalanceBatch.step_next": ("reset", 0, lambda v: _BALANCE.step_next(np.zeros(1), [v], (1.0, 1.0, 1.0, 1.0), 0.0, 1.0)),
    "TrackBatch": ("substeps", 1, lambda v: twip._core.TrackBatch(_PLANAR, _LINE, np.zeros(7), [], 1, 0.005, v, 1.0)),
    "BalanceBatch.reset": ("lanes", 0, lambda v: _BALANCE.reset([v])),
    "BalanceBatch.reset seeds": ("seeds", 3, lambda v: _BALANCE.reset([0], [v])),
    "sweep_draw": ("perturbations", 0, lambda v: twip._core.sweep_draw(
        _SLOPE, np.zeros(4), [("x0", v, "uniform", 0.0, 0.1, 0.0, 0.1)], 0, 0)),
    "sweep_raw": ("threads", 1, lambda v: twip._core.sweep_raw(
        _SLOPE, _LQR, np.zeros(4), 0.01, 0.001, _STILL, [], 0, 0, 1, threads=v)),
    "sweep_planar_raw": ("threads", 1, lambda v: twip._core.sweep_planar_raw(
        _PLANAR, _PID, np.zeros(7), 0.01, 0.005, _LINE, [], 0, 0, 1, threads=v)),
    "simulate_raw": ("record_every", 1, lambda v: twip._core.simulate_raw(
        _SLOPE, _LQR, np.zeros(4), 0.01, 0.001, _STILL, record_every=v)),
    "simulate_planar_raw": ("record_every", 1, lambda v: twip._core.simulate_planar_raw(
        _PLANAR, _PID, np.zeros(7), 0.01, 0.005, _LINE, record_every=v)),
    "Dlpf.filter": ("segments", 0, lambda v: twip.Dlpf(100, 0.001).filter(np.zeros(5), [v])),
}


@pytest.mark.parametrize("value", NOT_INT, ids=repr)
@pytest.mark.parametrize("call", INT_PARAMETERS, ids=str)
def test_an_integer_parameter_refuses_a_bool(call, value):
    arg, _, make = INT_PARAMETERS[call]
    refused_naming(make, value, arg, r"^expected an integer, got the bool ")


@pytest.mark.parametrize("kind", [int, np.int64, np.uint32])
@pytest.mark.parametrize("call", INT_PARAMETERS, ids=str)
def test_an_integer_parameter_takes_an_int_or_a_numpy_integer(call, kind):
    _, valid, make = INT_PARAMETERS[call]
    make(kind(valid))


@pytest.mark.parametrize("call", INT_PARAMETERS, ids=str)
def test_an_integer_parameter_still_refuses_a_float(call):
    _, valid, make = INT_PARAMETERS[call]
    with pytest.raises(TypeError):
        make(float(valid))


@pytest.mark.parametrize("value", NOT_INT, ids=repr)
def test_a_noise_or_sample_key_refuses_a_bool_naming_it(value):
    """Seeds, streams and sample indices (read by name, in [0, 2**64)) refuse a bool in
    their own words, as twip.montecarlo's seed does."""
    for name, call in [
        ("seed", lambda: twip.Realism(seed=value)),
        ("stream", lambda: twip.Realism().replace(stream=value)),
        ("seed", lambda: twip._core.sweep_noise_seed(value)),
        ("index", lambda: twip._core.sweep_draw(_SLOPE, np.zeros(4), [], 0, value)),
        ("count", lambda: twip._core.sweep_raw(_SLOPE, _LQR, np.zeros(4), 0.01, 0.001, _STILL, [], 0, 0, value)),
        ("start", lambda: twip._core.sweep_planar_raw(_PLANAR, _PID, np.zeros(7), 0.01, 0.005, _LINE, [], 0, value, 1)),
    ]:
        with pytest.raises(twip.InvalidParameterError, match=rf"^invalid {name} = {re.escape(repr(value))}: must be an integer"):
            call()
    assert twip.Realism(seed=np.int64(3), stream=np.uint64(2**64 - 1)).seed == 3


@pytest.mark.parametrize("value", NOT_INT, ids=repr)
def test_python_entry_points_refuse_a_bool_count_or_seed(value):
    sc = scenarios.get("flat-lqr-sim", t_final=0.2)
    for name, call in [
        ("n", lambda: twip.montecarlo(sc, value, progress=False)),
        ("seed", lambda: twip.montecarlo(sc, 2, seed=value, progress=False)),
        ("threads", lambda: twip.montecarlo(sc, 2, threads=value, progress=False)),
        ("record_every", lambda: twip.simulate(_SLOPE, _LQR, np.zeros(4), 0.01, record_every=value)),
    ]:
        with pytest.raises(twip.InvalidParameterError, match=rf"^{name} = {re.escape(repr(value))}: "):
            call()


@pytest.mark.parametrize("vector", [False, True], ids=["BalanceEnv", "BalanceVectorEnv"])
def test_an_env_refuses_a_bool_seed(vector):
    """Gymnasium's own check takes True (an int) as a seed (it was seed 1); the envs refuse it."""
    pytest.importorskip("gymnasium")
    from twip.envs import BalanceEnv, BalanceVectorEnv

    env = BalanceVectorEnv(2, max_episode_steps=5) if vector else BalanceEnv(max_episode_steps=5)
    with pytest.raises(twip.InvalidParameterError, match=r"^seed = True: must be an integer in \[0, 2\*\*64\)"):
        env.reset(seed=True)
    env.reset(seed=7)
    env.close()
