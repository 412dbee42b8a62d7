"""One closed-loop run from Python, and one CARE solve: the figures of README's Speed section.

Each case is timed `--repeats` times after one warm-up call; printed: the median and the
range, in ms (µs for the CARE solve). The runs use the scenarios' own models, controllers
and references, cut to a fixed length so that the figures compare across versions.

Run:  .venv/bin/python benches/simulate.py [--repeats 21]   (after `make build`)
"""
import argparse
import statistics
import time

import numpy as np

import twip
import twip.scenarios

CASES = (  # scenario, seconds simulated
    ("flat-lqr", 10.0),
    ("flat-fuzzy", 10.0),
    ("circle-smc-fuzzy", 60.0),
)


def timed(run, repeats):
    run()  # warm-up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times), min(times), max(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=21)
    args = ap.parse_args()
    print(f"twip.simulate, dt = 1 ms, median (min-max) of {args.repeats} runs")
    for name, seconds in CASES:
        sc = twip.scenarios.get(name)
        for every, label in ((1, "full log"), (1000, "log every 1000th step")):
            def run():
                return twip.simulate(sc.model, sc.controller, sc.x0, seconds, sc.dt, reference=sc.reference,
                                     control_period=sc.control_period, record_every=every)

            med, lo, hi = timed(run, args.repeats)
            print(f"  {name:18s} {seconds:4.0f} s, {label:22s} {1e3 * med:7.2f} ms ({1e3 * lo:.2f}-{1e3 * hi:.2f})")
    # The flat LQR design problem: the model linearised at the scenario's speed.
    sc = twip.scenarios.get("flat-lqr")
    a, b = sc.model.linearize(np.zeros(4), 0.0)
    q, r = np.diag([100.0, 1.0, 1.0, 1.0]), 480.0
    med, lo, hi = timed(lambda: twip.care(a, b, q, r), args.repeats * 10)
    print(f"twip.care, 4x4 design problem: {1e6 * med:.1f} µs ({1e6 * lo:.1f}-{1e6 * hi:.1f})")


if __name__ == "__main__":
    main()
