"""Sweep throughput of every controller family, both cores, side by side in one run.

Each family's scenario swept over perturbed robots (m_body ±20 %, com_height ±10 %,
i_body ±20 %), 10 s per sample (the 3-DOF circles: their three laps, 108 s) at dt = 1 ms.
`--repeats` rounds, each running every family once in turn, so that the machine's drift
moves a round's numbers alike; printed: M sample-steps per second (median over the rounds)
and the ratio to the LQR lane kernel in the same round (median, and its range over the
rounds), which the issue's targets are stated against (fuzzy >= 0.5x; 3-DOF trackers and
the 2-DOF realism rig >= 0.3x).

Run:  .venv/bin/python benches/families.py [--scale 1.0] [--repeats 3] [--kernel-copy avx2]
"""
import argparse
import math
import os
import statistics
import time

import twip

PERTURB = {"m_body": twip.Uniform(rel=0.2), "com_height": twip.Uniform(rel=0.1), "i_body": twip.Uniform(rel=0.2)}
GAUSSIAN_SETS = [[twip.Gaussian(-0.3, 0.15), twip.Triangle(-0.3, 0.0, 0.3), twip.Gaussian(0.3, 0.15)],
                 [twip.Trapezoid(-math.inf, -math.inf, -2, -0.5), twip.Triangle(-2, 0, 2),
                  twip.Trapezoid(0.5, 2, math.inf, math.inf)]]


def families():
    """(label, scenario, realism, samples at scale 1): each about a second on two cores."""
    get = twip.scenarios.get
    thesis_like = twip.Realism.thesis_like()
    return [
        ("LQR, lanes", get("flat-lqr-sim", t_final=10.0), None, 16384),
        ("fuzzy, lanes", get("flat-fuzzy-sim", t_final=10.0), None, 8192),
        ("fuzzy, Gaussian sets, lanes", get("flat-fuzzy-sim", t_final=10.0, sets=GAUSSIAN_SETS), None, 8192),
        ("LQR with realism (thesis-like rig)", get("flat-lqr-sim", t_final=10.0), thesis_like, 4096),
        ("fuzzy with realism (thesis-like rig)", get("flat-fuzzy-sim", t_final=10.0), thesis_like, 4096),
        # The rig the issue's goal was set on: thesis_like() before the gearheads' friction
        # (2ad982d) and play (e34a4c0) joined it.
        ("LQR, thesis-like rig, no gearhead friction or play", get("flat-lqr-sim", t_final=10.0),
         thesis_like.replace(friction=None, backlash=None), 4096),
        ("LQR, thesis-like rig and a push", get("flat-lqr-sim", t_final=10.0), thesis_like.replace(pushes=[(5.0, 0.2)]), 4096),
        ("LQR, thesis-like rig, slope changes", get("flat-lqr-sim", t_final=10.0),
         thesis_like.replace(slope_profile=[(0.3, 0.02), (0.6, -0.02)]), 4096),
        ("LQR, thesis-like rig, slip friction (no stick band)", get("flat-lqr-sim", t_final=10.0),
         thesis_like.replace(friction=thesis_like.friction.replace(stick_speed=0.0)), 4096),
        ("fuzzy, Gaussian sets, thesis-like rig", get("flat-fuzzy-sim", t_final=10.0, sets=GAUSSIAN_SETS), thesis_like, 4096),
        ("circle-pid (3-DOF, three laps)", get("circle-pid"), None, 1024),
        ("circle-smc-fuzzy (3-DOF, three laps)", get("circle-smc-fuzzy"), None, 512),
        ("circle-pid with realism", get("circle-pid"), thesis_like, 768),
        ("circle-smc-fuzzy with realism", get("circle-smc-fuzzy"), thesis_like, 512),
    ]


def rate(sc, realism, n):
    start = time.perf_counter()
    r = twip.montecarlo(sc, n, perturb=PERTURB, seed=1, progress=False, threads=os.cpu_count(), realism=realism)
    return r.steps / (time.perf_counter() - start) / 1e6, r.kernel


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scale", type=float, default=1.0, help="multiplies every family's sample count")
    ap.add_argument("--repeats", type=int, default=3, help="rounds (each runs every family once); medians count")
    ap.add_argument("--kernel-copy", choices=["avx512", "avx2", "baseline"], default=None,
                    help="run this copy of twip's lane kernels (default: the widest this CPU has; baseline needs a "
                         "wheel with every copy, `make build KERNEL_COPIES=all`)")
    args = ap.parse_args()
    twip.use_kernel_copy(args.kernel_copy)
    cases = [(label, sc, realism, max(16, round(n * args.scale))) for label, sc, realism, n in families()]
    for _, sc, realism, _ in cases:
        rate(sc, realism, 16)  # warm-up
    rounds = [[rate(sc, realism, n) for _, sc, realism, n in cases] for _ in range(args.repeats)]
    print(f"{os.cpu_count()} cores, twip's {twip.kernel_copy()} lane kernels")
    print(f"{'family':52s} {'kernel':21s} {'M sample-steps/s':>17s} {'x LQR lanes':>12s} {'range':>12s}")
    for j, (label, *_) in enumerate(cases):
        speeds = [r[j][0] for r in rounds]
        ratios = [r[j][0] / r[0][0] for r in rounds]
        span = f"{min(ratios):.2f}-{max(ratios):.2f}"
        print(f"{label:52s} {rounds[0][j][1]:21s} {statistics.median(speeds):17.1f} {statistics.median(ratios):12.2f} {span:>12s}")


if __name__ == "__main__":
    main()
