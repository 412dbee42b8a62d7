"""Two builds of twip side by side: each family's sweep speed, new against old, and whether
their metrics have the same bits.

A change to the lane kernels is judged against the build before it on the same machine in
the same minutes, because this project's VMs drift by more than most changes gain. So each
round runs the old build and then the new (the next round the other way round), each in a
fresh process that imports its own copy of the package, one thread, timed by CPU time; a
row's ratio is old CPU time / new (above 1: the new build is faster). Each child hashes
every metric of its sweep: a row's bits are the same when every run of both builds gave one
hash.

A build is a folder holding a `twip` package with its compiled `_core` (for example a copy of
`python/twip` made before the change: `cp -r python/twip /tmp/old/`).

Run:  .venv/bin/python benches/pair_builds.py OLD_DIR NEW_DIR [--rounds 6] [--kernel-copy avx2]
          [--rows lqr fuzzy ...] [--no-settle] [--instructions] [--samples N]
`--instructions` counts instead of timing: each build's row once under valgrind's callgrind
(installed apart: Debian's `valgrind`), the instructions run in twip's compiled `_core` per
sample-step, without the warm-up sweep. A count moves by under 0.1 % from run to run, so it
tells a change of a few per cent that the VM's noise hides; it is not the time (stalls,
divisions and masked stores cost more than an add). `--samples N` shortens the rows (about
1-3 min a count for 16 samples of a rig row): keep N a multiple of 16, the lanes' block, or
idle lanes are counted.
`--no-settle` runs the rigs without `Realism.thesis_like()`'s settled start (`settle=0.0`), the
work a build from before it (0.1.9) did; a build whose `Realism` has no `settle` runs as it is.
Rows are benches/families.py's workloads, sized to about 0.8 s of one thread on AVX-512.
"""
import argparse
import hashlib
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
# label: (index into families.families(), samples)
ROWS = {
    "lqr": (0, 8192), "fuzzy": (1, 4096), "fuzzy-gauss": (2, 4096), "lqr-rig": (3, 1024),
    "fuzzy-rig": (4, 1024), "lqr-rig-nofric": (5, 2048), "lqr-rig-push": (6, 1024),
    "lqr-rig-slopes": (7, 1024), "lqr-rig-slip": (8, 1024), "fuzzy-gauss-rig": (9, 1024),
    "circle-pid": (10, 384), "circle-smc": (11, 256), "circle-pid-rig": (12, 64), "circle-smc-rig": (13, 64),
}


def child(row, copy, settle, warm=True, samples=None):
    """In a fresh process: one sweep of `row` on one thread (after a small one to warm up, if
    `warm`); prints the package's file, the CPU seconds, the sample-steps, the kernel copy and
    the metrics' hash."""
    import numpy as np
    import twip
    sys.path.insert(0, HERE)
    import families

    if copy != "widest":
        twip.use_kernel_copy(copy)
    i, n = ROWS[row]
    n = samples or n
    _, sc, realism, _ = families.families()[i]
    if settle == "no-settle" and realism is not None and hasattr(realism, "settle"):
        realism = realism.replace(settle=0.0)
    kw = dict(perturb=families.PERTURB, seed=1, progress=False, threads=1, realism=realism)
    if warm:
        twip.montecarlo(sc, 16, **kw)  # the first call loads and sets up
    start = time.process_time()
    r = twip.montecarlo(sc, n, **kw)
    cpu = time.process_time() - start
    digest = hashlib.sha256(b"".join(k.encode() + np.ascontiguousarray(r.metrics[k]).tobytes() for k in sorted(r.metrics)))
    print(twip.__file__, cpu, r.steps, twip.kernel_copy(), digest.hexdigest()[:16])


def run(build, row, copy, settle, samples):
    """(cpu seconds, sample-steps, kernel copy, hash) of `row` in a child importing `build`;
    `settle`: "settle" as the rows are, or "no-settle"; `samples`: the sweep's size (0: the row's)."""
    env = dict(os.environ, PYTHONPATH=build)
    out = subprocess.run([sys.executable, __file__, "--child", row, copy, settle, "warm", str(samples)], env=env, capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"{row} with {build}:\n{out.stderr}")
    cpu, steps, kernel_copy, digest = child_said(out.stdout, build, row)
    return float(cpu), int(steps), kernel_copy, digest


def child_said(stdout, build, row):
    """A child's (cpu seconds, sample-steps, kernel copy, hash), once it is sure the child ran
    `build`'s package."""
    path, cpu, steps, kernel_copy, digest = stdout.split()
    if not path.startswith(os.path.abspath(build)):
        raise SystemExit(f"{row}: the child imported {path}, not the build in {build}")
    return cpu, steps, kernel_copy, digest


def count(build, row, copy, settle, samples):
    """(instructions in twip's `_core` per sample-step, kernel copy, hash) of `row` in a child
    importing `build`, run once under callgrind without the warm-up sweep."""
    with tempfile.TemporaryDirectory() as tmp:
        out_file = os.path.join(tmp, "callgrind.out")
        env = dict(os.environ, PYTHONPATH=build)
        cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out_file}", sys.executable, __file__, "--child", row, copy, settle, "cold", str(samples)]
        try:
            out = subprocess.run(cmd, env=env, capture_output=True, text=True)
        except FileNotFoundError:
            raise SystemExit("--instructions needs valgrind (Debian: apt install valgrind)")
        if out.returncode:
            raise SystemExit(f"{row} with {build} under callgrind:\n{out.stderr[-2000:]}")
        _, steps, kernel_copy, digest = child_said(out.stdout, build, row)
        table = subprocess.run(["callgrind_annotate", "--threshold=100", out_file], capture_output=True, text=True, check=True).stdout
    n = ours(table, build)
    if not n:
        raise SystemExit(f"{row}: callgrind counted no instructions in {build}'s twip/_core")
    return n / int(steps), kernel_copy, digest


def ours(table, build):
    """The instructions `callgrind_annotate`'s `table` gives the functions of `build`'s `_core`
    (other packages have a `_core` too: scipy's)."""
    # The object's path as the build was named or with its links resolved.
    cores = tuple(os.path.join(f(build), "twip", "_core.") for f in (os.path.abspath, os.path.realpath))
    total = 0
    for line in table.splitlines():
        # A function's line: "1,234 (12.3%)  file:function [object]".
        if line.strip()[:1].isdigit() and line.rstrip().endswith("]") and line.rsplit("[", 1)[-1].startswith(cores):
            total += int(line.split()[0].replace(",", ""))
    return total


def settle_of(a):
    """The children's word for the rigs' settled start: "settle" as the rows are, or "no-settle"."""
    return "no-settle" if a.no_settle else "settle"


def count_rows(a, builds):
    """Each row's instructions per sample-step in both builds, once each (`--instructions`)."""
    print("instructions in twip's _core per sample-step (callgrind; one thread; no warm-up); new/old; same bits")
    for row in a.rows:
        got = {b: count(builds[b], row, a.kernel_copy, settle_of(a), a.samples) for b in builds}
        (old, kernel_copy, h_old), (new, _, h_new) = got["old"], got["new"]
        print(f"{row:16s} {kernel_copy} old {old:8.1f} new {new:8.1f}  {new / old:.3f}  {'same bits' if h_old == h_new else 'BITS DIFFER'}", flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("old")
    p.add_argument("new")
    p.add_argument("--rounds", type=int, default=6)
    p.add_argument("--kernel-copy", default="widest", help="avx512, avx2, baseline (builds with every copy: `make build KERNEL_COPIES=all`), "
                   "or widest (the CPU's)")
    p.add_argument("--rows", nargs="+", default=list(ROWS), choices=list(ROWS))
    p.add_argument("--no-settle", action="store_true", help="the rigs without the settled start (settle=0.0)")
    p.add_argument("--instructions", action="store_true", help="count instructions under callgrind instead of timing")
    p.add_argument("--samples", type=int, default=0, help="each row's sweep size (default: the row's own)")
    a = p.parse_args()
    if a.rounds < 1:
        p.error(f"--rounds must be at least 1, got {a.rounds}")
    if a.samples < 0:
        p.error(f"--samples must be at least 1 (or 0: the rows' own), got {a.samples}")
    builds = {"old": a.old, "new": a.new}
    if a.instructions:
        return count_rows(a, builds)
    speed = {row: {"old": [], "new": [], "ratio": []} for row in a.rows}
    hashes = {(row, b): set() for row in a.rows for b in builds}
    for k in range(a.rounds):
        for j, row in enumerate(a.rows):
            order = ["old", "new"] if (k + j) % 2 == 0 else ["new", "old"]
            cpu = {}
            for b in order:
                cpu[b], steps, kernel_copy, digest = run(builds[b], row, a.kernel_copy, settle_of(a), a.samples)
                hashes[(row, b)].add(digest)
                speed[row][b].append(steps / cpu[b] / 1e6)
            speed[row]["ratio"].append(cpu["old"] / cpu["new"])
            print(f"round {k} {row:16s} {kernel_copy} old {cpu['old']:.3f} s new {cpu['new']:.3f} s new/old speed {cpu['old'] / cpu['new']:.3f}", flush=True)
    print(f"\nkernel copy {kernel_copy}; M sample-steps/s (CPU time, one thread), medians; new/old speed: median [range]; same bits")
    for row in a.rows:
        s = speed[row]
        same = len(hashes[(row, "old")]) == 1 and hashes[(row, "old")] == hashes[(row, "new")]
        print(f"{row:16s} old {statistics.median(s['old']):7.2f} new {statistics.median(s['new']):7.2f}  "
              f"{statistics.median(s['ratio']):.3f} [{min(s['ratio']):.3f}-{max(s['ratio']):.3f}]  {'same bits' if same else 'BITS DIFFER'}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[3], sys.argv[4], warm=sys.argv[5] == "warm", samples=int(sys.argv[6]) or None)
    else:
        main()
