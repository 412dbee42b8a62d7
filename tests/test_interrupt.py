"""Ctrl-C stops a long simulation promptly with KeyboardInterrupt."""
import signal
import subprocess
import sys
import time

SCRIPT = r"""
import sys, twip, twip.scenarios as s
sc = s.get("flat-lqr-sim")
print("ready", flush=True)
try:
    sc.run(t_final=1e6, record_every=10**9)   # 1e9 steps: minutes of work
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(0)
print("finished", flush=True)
"""


def test_sigint_stops_a_long_simulation_long_before_its_end():
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(0.5)
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=10)
        waited = time.monotonic() - sent
    finally:
        proc.kill()
    # How fast is measured by benches/ctrl_c.py (a time bound here fails on a loaded machine);
    # the 10 s above is far short of the run's minutes of work.
    print(f"stopped {waited * 1e3:.0f} ms after SIGINT")
    assert out.strip() == "interrupted"


SWEEP = r"""
import sys, time, twip
sys.path.insert(0, {tests!r})
from test_user_controller import PythonLqr
sc = twip.scenarios.get("flat-lqr-sim")
mine = sc.replace(controller=PythonLqr(sc.model, sc.controller.gains, sc.controller.period))
print("started", flush=True)
try:
    twip.montecarlo(mine, 10**4, perturb={{"m_body": twip.Uniform(rel=0.2)}}, progress=False, threads=2,
                    checkpoint={folder!r})
except KeyboardInterrupt as stop:
    print("interrupted", stop.partial.n, time.time(), flush=True)
"""


def _sweep_in_its_own_group(tmp_path):
    """A Python-controller sweep in a session of its own (its workers share its process
    group, as a terminal's Ctrl-C reaches them all), once its first shard is on disk."""
    import os

    folder = tmp_path / "ck"
    script = SWEEP.format(tests=os.path.dirname(os.path.abspath(__file__)), folder=str(folder))
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, start_new_session=True)
    assert proc.stdout.readline().strip() == "started"
    deadline = time.monotonic() + 120  # shards are sized to a few seconds' work
    while not list(folder.glob("shard-*.npz")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    assert list(folder.glob("shard-*.npz")), "no shard finished: shards are not sized by time"
    return proc, folder


def _group_is_gone(pgid):
    import os

    for _ in range(100):
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    return False


def test_ctrl_c_stops_a_python_controller_sweep_and_keeps_its_finished_shards(tmp_path):
    import os

    proc, folder = _sweep_in_its_own_group(tmp_path)
    try:
        time.sleep(0.5)
        sent = time.time()
        os.killpg(proc.pid, signal.SIGINT)  # the parent and its workers, as a terminal does
        out, _ = proc.communicate(timeout=60)  # a hang fails here
    finally:
        proc.kill()
    assert out.startswith("interrupted"), out
    print(f"the sweep stopped {(float(out.split()[2]) - sent) * 1e3:.0f} ms after SIGINT")
    kept = int(out.split()[1])
    assert kept > 0 and len(list(folder.glob("shard-*.npz"))) >= 1
    assert _group_is_gone(proc.pid), "a worker process outlived the sweep"


def test_a_second_ctrl_c_never_hangs_a_python_controller_sweep(tmp_path):
    import os

    proc, _ = _sweep_in_its_own_group(tmp_path)
    try:
        os.killpg(proc.pid, signal.SIGINT)
        time.sleep(0.3)
        try:
            os.killpg(proc.pid, signal.SIGINT)
        except ProcessLookupError:
            pass  # already gone
        proc.communicate(timeout=60)  # a hang fails here
    finally:
        proc.kill()
    assert _group_is_gone(proc.pid), "a worker process outlived the sweep"


FORKED = r"""
import os, signal
fired = []

def ctrl_c_once():  # a Ctrl-C that lands while a worker is being forked
    if not fired:
        fired.append(1)
        signal.raise_signal(signal.SIGINT)

os.register_at_fork(after_in_parent=ctrl_c_once)  # first: the fork's other handlers run after it
import sys, twip
sys.path.insert(0, {tests!r})
from test_user_controller import PythonLqr
sc = twip.scenarios.get("flat-lqr-sim")
mine = sc.replace(controller=PythonLqr(sc.model, sc.controller.gains, sc.controller.period))
try:
    r = twip.montecarlo(mine, 40, perturb={{"m_body": twip.Uniform(rel=0.2)}}, progress=False, threads=2)
    print("finished", r.n, flush=True)
except KeyboardInterrupt as stop:
    print("interrupted", stop.partial.n, flush=True)
"""


def test_a_ctrl_c_while_the_workers_are_forked_stops_the_sweep():
    """A Ctrl-C inside the fork's own handlers (logging's lock release) was printed as
    "Exception ignored" and lost: the sweep ran on to the end (on CI, past the test's minute)."""
    import os

    script = FORKED.format(tests=os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert out.stdout.startswith("interrupted"), (out.stdout, out.stderr[-2000:])
    assert "Exception ignored" not in out.stderr, out.stderr[-2000:]


def test_the_workers_end_when_their_parent_is_killed(tmp_path):
    """A worker held its own pipe's parent end (inherited at the fork), so it never saw a
    killed parent go and lived on, holding the parent's stdout open."""
    proc, _ = _sweep_in_its_own_group(tmp_path)
    import os

    proc.kill()  # the parent alone: no Ctrl-C, no clean-up of its own
    proc.wait(timeout=60)
    proc.stdout.close()
    gone = _group_is_gone(proc.pid)
    if not gone:
        os.killpg(proc.pid, signal.SIGKILL)  # leave no orphans behind a failure
    assert gone, "a worker process outlived its killed parent"


def test_a_ctrl_c_before_the_first_shard_carries_an_empty_partial(tmp_path, monkeypatch):
    """KeyboardInterrupt always carries `.partial`: also when it lands while the checkpoint
    folder is being set up, before any sample ran."""
    import pytest
    import twip
    import twip.sweep

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(twip.sweep, "Checkpoint", interrupted)
    with pytest.raises(KeyboardInterrupt) as stop:
        twip.montecarlo("flat-lqr-sim", 8, perturb={"m_body": twip.Uniform(rel=0.2)}, progress=False,
                        checkpoint=tmp_path / "ck")
    assert stop.value.partial.n == 0
    assert stop.value.partial.summary()["samples"] == 0
