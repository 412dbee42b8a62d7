"""The fuzzy-sets study of docs/fuzzy_sets.md: the thesis's 3 x 3 trapezoids against a 5 x 5
Gaussian grid in the fuzzy adaptive backstepping + PD controller (the Table 5.1 analogue, the
report's robustness sweeps and fall map) and in the sliding-mode tracker's fuzzy estimates
(the Table 5.2 analogue).

    python scripts/fuzzy_sets_study.py [samples]     # samples per sweep, default 2000

Prints markdown tables; every run is the report's own (same scenarios, perturbation box,
seeds), only `sets` changes.
"""
from __future__ import annotations

import sys
import time

import twip
from twip.report.sweeps import sweep_perturb, sweep_perturb_text
from twip.scenarios.fuzzy import compare_table

#: The 5 x 5 Gaussian grid: centres spanning the thesis's sets' transitions (φ ±0.3 rad,
#: φ̇ ±2 rad/s), σ half the spacing.
GAUSSIAN_5X5 = twip.FuzzyBasis.grid("gaussian", [[-0.3, -0.15, 0.0, 0.15, 0.3], [-2.0, -1.0, 0.0, 1.0, 2.0]],
                                    [0.075, 0.5])
BASES = {"3x3 trapezoids (thesis)": None, "5x5 Gaussians": GAUSSIAN_5X5}
#: The tracker's yaw estimate's grid over (φ, ω): ω ±1 rad/s, where its 3 x 3 sets change.
YAW_5X5 = twip.FuzzyBasis.grid("gaussian", [[-0.3, -0.15, 0.0, 0.15, 0.3], [-1.0, -0.5, 0.0, 0.5, 1.0]],
                               [0.075, 0.25])


def table_5_1() -> None:
    print("## Table 5.1 analogue: mean |pitch error| [deg], mean |speed error| [deg/s], stops [cm]\n")
    print("| surface | plant | controller | basis | outcome | pitch | speed | stop far | stop home |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = {label: compare_table(controllers=("fuzzy", "fuzzy+ki"), sets=sets) for label, sets in BASES.items()}
    for k in range(len(rows["3x3 trapezoids (thesis)"])):
        for label in BASES:
            r = rows[label][k]
            print(f"| {r['surface']} | {r['case']} | {r['controller']} | {label} | {r['outcome']} | "
                  f"{r['pitch_error_deg']:.3f} | {r['speed_error_deg_s']:.2f} | {r['stop_far_cm']:.2f} | "
                  f"{r['stop_home_cm']:.2f} |")


def table_5_2() -> None:
    from twip.scenarios.tracking import mismatched
    print("\n## Table 5.2 analogue: circle-smc-fuzzy, 3 laps, mean |x - x_r|, |y - y_r| [cm] (after lap 1)\n")
    print("| plant | basis | outcome | x | y | x settled | y settled |")
    print("|---|---|---|---|---|---|---|")
    nominal = twip.RobotParams.balanbot()
    for label, factor in (("nominal", 1.0), ("+20%", 1.2), ("-20%", 0.8)):
        sc = twip.scenarios.get("circle-smc-fuzzy", params=mismatched(nominal, factor), controller_params=nominal, laps=3)
        for basis, ctrl in (("3x3 trapezoids (thesis)", sc.controller),
                            ("5x5 Gaussians", sc.controller.replace(yaw_sets=YAW_5X5, pitch_sets=GAUSSIAN_5X5))):
            m = sc.replace(controller=ctrl).run(record_every=1000)
            r = m.metrics
            print(f"| {label} | {basis} | {m.outcome} | {100 * r['mean_abs_x_error']:.2f} | {100 * r['mean_abs_y_error']:.2f} | "
                  f"{100 * r['mean_abs_x_error_settled']:.3f} | {100 * r['mean_abs_y_error_settled']:.3f} |")


def sweeps(n: int) -> None:
    print(f"\n## Robustness: {n} robots per row, {sweep_perturb_text(False)}, seed 1 (the report's box)\n")
    print("| scenario | basis | fall rate | 95 % interval | median mean |pitch error| [deg] | wall [s] |")
    print("|---|---|---|---|---|---|")
    for name in ("slope-fuzzy", "flat-fuzzy"):
        for label, sets in BASES.items():
            sc = twip.scenarios.get(name, **({} if sets is None else {"sets": sets}))
            t0 = time.perf_counter()
            res = twip.montecarlo(sc, n, perturb=sweep_perturb(False), seed=1, progress=False)
            wall = time.perf_counter() - t0
            lo, hi = res.fall_rate_interval()
            keep = res.metrics["valid"] & ~res.metrics["fell"]
            pitch = float(__import__("numpy").median(res.metrics["mean_abs_pitch_error"][keep])) * 57.29577951308232
            print(f"| {name} | {label} | {100 * res.fall_rate:.1f} % | {100 * lo:.1f} to {100 * hi:.1f} % | "
                  f"{pitch:.3f} | {wall:.1f} |")
    print(f"\n## Fall map: slope-fuzzy-sim, φ(0) uniform ±1 rad, φ̇(0) uniform ±20 rad/s, 4 s, {n} starts, seed 2\n")
    print("| basis | fall rate | 95 % interval | wall [s] |")
    print("|---|---|---|---|")
    perturb = {"phi0": twip.Uniform(low=-1.0, high=1.0), "phi_dot0": twip.Uniform(low=-20.0, high=20.0)}
    for label, sets in BASES.items():
        sc = twip.scenarios.get("slope-fuzzy-sim", t_final=4.0, **({} if sets is None else {"sets": sets}))
        t0 = time.perf_counter()
        res = twip.montecarlo(sc, n, perturb=perturb, seed=2, progress=False)
        wall = time.perf_counter() - t0
        lo, hi = res.fall_rate_interval()
        print(f"| {label} | {100 * res.fall_rate:.1f} % | {100 * lo:.1f} to {100 * hi:.1f} % | {wall:.1f} |")


if __name__ == "__main__":
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    print(f"twip.kernel_copy() = {twip.kernel_copy()}\n")
    table_5_1()
    table_5_2()
    sweeps(n)
