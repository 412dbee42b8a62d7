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
    sc.run(t_final=1e5, record_every=10**9)   # 1e8 steps: minutes of work
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(0)
print("finished", flush=True)
"""


def test_sigint_stops_a_long_simulation_within_a_second():
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
    print(f"stopped {waited * 1e3:.0f} ms after SIGINT")
    assert out.strip() == "interrupted"
    assert waited < 1.0


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
