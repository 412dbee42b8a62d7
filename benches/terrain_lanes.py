"""A terrain sweep's speed and bits, to compare two builds (issue 64: the planar lanes on
terrain against the general runner they replaced), and a flat sweep's bits (which the lanes on
terrain must not change):

    python benches/terrain_lanes.py [N] [--realism] [--seconds S]

runs incline-circle's PID with the grade's feed-forward, S (default 10) s per sample, over N
(default 64) planes drawn per sample (slope uniform 0-10 deg, uphill heading any, body mass
+-20 %, seed 0) on one thread, then circle-pid on flat ground (N samples, S s). With
--realism both sweeps run through the thesis-like 3-DOF rig (issue 64: the rig's lanes on
terrain against the general runner they replaced; the flat rig's lanes must keep their bits).
Prints the kernel copy, each sweep's kernel, time and a digest of every metric's bits. Run it
with each build's Python (one after the other, twice, on a quiet machine) and divide the
times."""
import argparse
import hashlib
import math
import time

import numpy as np

import twip


def digest(r) -> str:
    h = hashlib.sha256()
    for k in sorted(r.metrics):
        h.update(k.encode())
        h.update(np.ascontiguousarray(r.metrics[k]).tobytes())
    return h.hexdigest()[:16]


def timed(sc, n, perturb, realism):
    start = time.perf_counter()
    r = twip.montecarlo(sc, n, perturb=perturb, seed=0, threads=1, progress=False, realism=realism)
    return r, time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("n", nargs="?", type=int, default=64, help="samples per sweep")
    parser.add_argument("--realism", action="store_true", help="through the thesis-like 3-DOF rig")
    parser.add_argument("--seconds", type=float, default=10.0, help="seconds per sample")
    args = parser.parse_args()
    n, t = args.n, args.seconds
    realism = twip.Realism.thesis_like() if args.realism else None
    print(f"kernel copy {twip.kernel_copy()}; {'thesis-like rig' if realism else 'ideal'}")
    incline = twip.scenarios.get("incline-circle", tracker="pid").replace(t_final=t)
    axes = {"m_body": twip.Uniform(rel=0.2), "slope": twip.Uniform(low=0.0, high=math.radians(10)),
            "heading": twip.Uniform(low=-math.pi, high=math.pi)}
    flat = twip.scenarios.get("circle-pid").replace(t_final=t)
    for name, sc, perturb in (("terrain", incline, axes), ("flat", flat, {"m_body": twip.Uniform(rel=0.2)})):
        r, secs = timed(sc, n, perturb, realism)
        print(f"{name}: {n} samples x {t:g} s on {r.kernel}: {secs:.2f} s; fall rate {r.fall_rate:.3f}; digest {digest(r)}")


if __name__ == "__main__":
    main()
