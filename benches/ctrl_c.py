"""How long after a Ctrl-C (SIGINT) each kind of long run stops: a long simulation, a sweep
on the core's threads and a sweep of a controller written in Python (worker processes),
each checkpointed sweep stopped once its first shard is on disk. The tests check that
each stops and keeps what finished; this measures how fast (issue 61: within 0.5 s).

    python benches/ctrl_c.py [--rounds 5]

Prints the median and the worst of the rounds, in milliseconds, for each kind; the time is
from the signal to the process's own "interrupted" line."""
from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TESTS = str(Path(__file__).resolve().parent.parent / "tests")

RUN = """
import twip
print("started", flush=True)
try:
    twip.scenarios.get("flat-lqr-sim").run(t_final=1e5, record_every=10**9)
except KeyboardInterrupt:
    import time
    print("interrupted", time.time(), flush=True)
"""

SWEEP = """
import sys, time, twip
sys.path.insert(0, {tests!r})
from test_user_controller import PythonLqr
sc = twip.scenarios.get("flat-lqr-sim")
if {python}:
    sc = sc.replace(controller=PythonLqr(sc.model, sc.controller.gains, sc.controller.period))
print("started", flush=True)
try:
    twip.montecarlo(sc, {n}, perturb={{"m_body": twip.Uniform(rel=0.2)}}, progress=False, threads=2,
                    checkpoint={folder!r}, shard_size={shard})
except KeyboardInterrupt:
    print("interrupted", time.time(), flush=True)
"""


def stop_after(script: str, folder: Path | None) -> float:
    """Seconds from SIGINT to the run's "interrupted" line, sent once the run is under way
    (a checkpointed sweep: once its first shard is on disk)."""
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "started"
        deadline = time.monotonic() + 120
        while folder is not None and not list(folder.glob("shard-*.npz")):
            if time.monotonic() > deadline or proc.poll() is not None:
                raise RuntimeError("no shard was written")
            time.sleep(0.02)
        time.sleep(0.3)
        sent = time.time()
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=120)
    finally:
        proc.kill()
    if not out.startswith("interrupted"):
        raise RuntimeError(f"the run did not stop on SIGINT: {out!r}")
    return float(out.split()[1]) - sent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    import twip

    kinds = {"simulation (scalar runner)": lambda d: (RUN, None)}
    kinds["sweep, core threads (4e6 samples, shards of 20k)"] = lambda d: (SWEEP.format(
        tests=TESTS, python=False, n=4_000_000, folder=str(d), shard=20_000), d)
    kinds["sweep, Python controller (1e4 samples, shards by time)"] = lambda d: (SWEEP.format(
        tests=TESTS, python=True, n=10_000, folder=str(d), shard=None), d)
    print(f"twip {twip.__version__}, kernel copy {twip.kernel_copy()}, {os.cpu_count()} CPUs, {args.rounds} rounds")
    for kind, make in kinds.items():
        waits = []
        for _ in range(args.rounds):
            with tempfile.TemporaryDirectory() as tmp:
                script, folder = make(Path(tmp) / "ck")
                waits.append(stop_after(script, folder))
        print(f"{kind:58s} median {statistics.median(waits) * 1e3:6.0f} ms, worst {max(waits) * 1e3:6.0f} ms")


if __name__ == "__main__":
    main()
