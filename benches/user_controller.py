"""Overhead per control update of a controller written in Python, beyond its own code.

    python benches/user_controller.py [--updates 200000]

Runs the same closed loop three ways, each the median of 7 runs: the built-in LQR
controller (the runner and plant alone), a Python callable that returns 0.0, and that
callable called directly from a Python loop with the same arguments (the user's own
code). overhead = (callable run - built-in run - the callable's own cost) / updates.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import twip


def median_seconds(fn, repeat=7):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--updates", type=int, default=200_000)
    n = ap.parse_args().updates
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    from twip import scenarios
    lqr = scenarios.get("flat-lqr-sim").controller
    zero = lambda t, y, ref: 0.0  # noqa: E731
    x0, dt = [0.0, 0.0, 0.0, 0.0], 1e-3
    run = lambda c: twip.simulate(model, c, x0, n * dt, dt, control_period=dt, record_every=n)  # noqa: E731
    y, ref = np.zeros(4), np.zeros(2)

    def own_code():
        for k in range(n):
            zero(k * dt, y, ref)

    builtin = median_seconds(lambda: run(lqr))
    user = median_seconds(lambda: run(zero))
    own = median_seconds(own_code)
    print(f"{n} updates at 1 kHz, median of 7 runs")
    print(f"  built-in LQR run        {builtin * 1e3:8.1f} ms  ({builtin / n * 1e6:.3f} us per step)")
    print(f"  Python callable run     {user * 1e3:8.1f} ms  ({user / n * 1e6:.3f} us per step)")
    print(f"  the callable alone      {own * 1e3:8.1f} ms  ({own / n * 1e6:.3f} us per call)")
    print(f"  overhead per update     {(user - builtin - own) / n * 1e6:8.3f} us beyond the user's code")


if __name__ == "__main__":
    main()
