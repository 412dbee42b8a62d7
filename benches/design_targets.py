"""The targets of controller design (docs/design.md), measured:

1. `twip.tune` on slope-lqr, thesis-like rig, ±30 % on m_body, com_height, i_body and
   mu_bearing: the held-out fall rate (target <= 2 %; the thesis's weights: ~25 %), the wall
   and CPU time (target <= 3 minutes on 2 cores) and the median stop error against the
   thesis's weights' (target: at most twice).
2. `twip.worst_case` in the ±8 % box of the same four: a falling robot within 400 runs, and
   whether it falls on fresh noise seeds; beside it, how many of 4,000 random robots fall.

    python benches/design_targets.py [--budget 200] [-n 256] [--threads 2] [--skip-tune] [--skip-worst]
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

import twip
from twip.design import knobs

FOUR = ("m_body", "com_height", "i_body", "mu_bearing")
#: The filer's hand-picked weights (issue 59): Q = diag(10, 10, 100, 10), R = 100.
HAND = dict(q_phi=10.0, q_phi_dot=10.0, q_theta_dot=100.0, q_z=10.0, r=100.0)


def box(rel):
    return {k: twip.Uniform(rel=rel) for k in FOUR}


def stop_median(result) -> float:
    m = result.metrics
    up = m["valid"] & ~m["fell"]
    return float(np.median(np.abs(m["final_position_error"][up])))


def line(label, result):
    lo, hi = result.fall_rate_interval()
    return (f"  {label:28s} fall rate {result.fall_rate:6.2%} (95 % CI {lo:.2%} – {hi:.2%}), "
            f"median stop error {100 * stop_median(result):.2f} cm, "
            f"median mean |pitch error| {np.degrees(np.median(result.metrics['mean_abs_pitch_error'])):.3f} deg")


def tune_target(args):
    rig = twip.Realism.thesis_like()
    wall, cpu = time.perf_counter(), time.process_time()
    t = twip.tune("slope-lqr", perturb=box(0.30), realism=rig, n=args.n, budget=args.budget, seed=args.seed,
                  validate=args.validate, progress=False, threads=args.threads)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(f"tune: slope-lqr, thesis-like, ±30 % on {', '.join(FOUR)}; n = {args.n}, budget = {args.budget}, "
          f"seed = {args.seed}, threads = {args.threads or os.cpu_count()}, kernel copy {twip.kernel_copy()}")
    print(f"  {t.settings['evaluations']} candidates, wall {wall:.1f} s, CPU {cpu:.1f} s (tuning and validation)")
    print("  tuned knobs: " + ", ".join(f"{k} = {v:.4g}" for k, v in t.knobs.items()))
    print(f"  held out ({args.validate} robots, seed {t.validation.seed}):")
    print(line("tuned", t.validation))
    print(line("thesis weights (scenario's)", t.baseline))
    hand = twip.montecarlo(knobs.apply(t.baseline._scenario, HAND), args.validate, perturb=box(0.30),
                           seed=t.validation.seed, realism=rig, progress=False, threads=args.threads)
    print(line("hand-picked (issue 59)", hand))
    ratio = stop_median(t.validation) / stop_median(t.baseline)
    print(f"  targets: fall rate {t.validation.fall_rate:.2%} <= 2 %: {t.validation.fall_rate <= 0.02}; "
          f"stop error {ratio:.2f} x the thesis weights' <= 2: {ratio <= 2}; wall {wall:.0f} s <= 180 s: {wall <= 180}")


def worst_target(args):
    rig = twip.Realism.thesis_like()
    wall, cpu = time.perf_counter(), time.process_time()
    w = twip.worst_case("slope-lqr", perturb=box(0.08), realism=rig, budget=400, seed=args.seed,
                        threads=args.threads)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    nominal = twip.RobotParams.balanbot().to_dict()
    print(f"worst case: slope-lqr, thesis-like, ±8 % on {', '.join(FOUR)}; budget 400, seed {args.seed}")
    print(f"  {w.evaluations} robots, wall {wall:.1f} s, CPU {cpu:.1f} s; worst metric {w.metric:.4g}, "
          f"{'falls' if w.fell else 'stays up'}")
    print("  " + ", ".join(f"{k} {w.params[k] / nominal[k] - 1:+.2%}" for k in FOUR))
    falling = w.history[w.history["fell"]]
    print(f"  first falling robot at run {int(falling['evaluation'].iloc[0]) + 1 if len(falling) else None}; "
          f"{len(falling)} of {w.evaluations} runs fell")
    check = w.confirm(50)
    print(f"  on 50 fresh noise seeds (seed {check.seed}): falls in {int(check.metrics['fell'].sum())}")
    mc = twip.montecarlo("slope-lqr", 4000, perturb=box(0.08), seed=args.seed, realism=rig, progress=False,
                         threads=args.threads)
    print(f"  beside it: {int(mc.metrics['fell'].sum())} of 4000 random robots in the box fall")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--budget", type=int, default=200)
    p.add_argument("-n", type=int, default=256)
    p.add_argument("--validate", type=int, default=2000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--skip-tune", action="store_true")
    p.add_argument("--skip-worst", action="store_true")
    args = p.parse_args()
    if not args.skip_tune:
        tune_target(args)
    if not args.skip_worst:
        worst_target(args)


if __name__ == "__main__":
    main()
