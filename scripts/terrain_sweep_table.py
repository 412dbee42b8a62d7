"""docs/terrain.md's sweep table: each tracker's incline circle (3 laps) over drawn planes,
the slope uniform in [0, SLOPE_DEG] and the uphill heading uniform over the circle, the
robot's body mass ±20 %: the fall rate (with its 95 % interval), the lift rate and the
settled path error's median over the samples that completed.

    python scripts/terrain_sweep_table.py [n] [slope_deg] [--realism]
"""
import math
import sys

import numpy as np

import twip

ROWS = (("pid", None), ("smc", None), ("smc-fuzzy", False), ("smc-fuzzy", True))


def main(n: int = 64, slope_deg: float = 10.0, realism=None) -> None:
    perturb = {"slope": twip.Uniform(low=0.0, high=math.radians(slope_deg)),
               "heading": twip.Uniform(low=-math.pi, high=math.pi),
               "m_body": twip.Uniform(rel=0.2)}
    rig = "thesis-like rig" if realism is not None else "ideal plant"
    print(f"n = {n}, slope U(0, {slope_deg:g} deg), heading U(-pi, pi), m_body ±20 %, {rig}, "
          f"kernel copy {twip.kernel_copy()}")
    print("| tracker | fall rate (95 % CI) | lift rate | median settled path error of those that completed |")
    print("|---|---|---|---|")
    for tracker, feed_forward in ROWS:
        options = {"tracker": tracker}
        if feed_forward is not None:
            options["grade_feed_forward"] = feed_forward
        r = twip.montecarlo("incline-circle", n, perturb=perturb, options=options, seed=0, progress=False,
                            realism=realism)
        lo, hi = r.fall_rate_interval()
        keep = r.valid & ~r.metrics["fell"]
        path = np.median(r.metrics["max_path_error_settled"][keep]) if keep.any() else float("nan")
        ff = {None: "", True: " + feed-forward", False: ", no feed-forward"}[feed_forward]
        default_ff = {"pid": " + feed-forward", "smc": " + feed-forward"}.get(tracker, "")
        print(f"| {tracker}{ff or default_ff} | {r.fall_rate:.3f} ({lo:.3f}-{hi:.3f}) | {r.lift_rate:.3f} | "
              f"{100 * path:.2f} cm |")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(int(args[0]) if args else 64, float(args[1]) if len(args) > 1 else 10.0,
         twip.Realism.thesis_like() if "--realism" in sys.argv else None)
