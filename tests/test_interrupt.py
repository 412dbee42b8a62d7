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
