"""Peak memory (RSS) of a checkpointed, streamed Monte Carlo sweep against its size n.

Each n runs in a fresh interpreter: `twip.montecarlo("flat-lqr-sim", n, checkpoint=...)`
with a short run per sample (`--t-final`), under a memory budget (`--budget`) below
which the metrics stay on disk; then `summary()` (fall rate, Wilson interval, quantiles)
is read back from the shards. Printed per n: the peak RSS of that interpreter, the time,
and the slope of RSS against n between the smallest and the largest n (bytes per sample;
~0 means the memory does not grow with the sweep).

Run:  .venv/bin/python benches/sweep_memory.py [--n 100000 1000000 10000000] [--budget 256M] [--shard-size S]
(after `make build`; the largest n takes minutes on 2 cores and ~75 bytes of disk per sample).
The memory of a streamed sweep is that of one shard, whatever n: `--shard-size 100000` (the
default shard of n = 10**9) over n = 10**6..10**8 shows what a 10**9 sweep needs.
"""
import argparse
import json
import subprocess
import sys
import tempfile
import time

CHILD = """
import json, resource, sys, time
import twip
n, t_final, folder = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
shard = int(sys.argv[4]) if sys.argv[4] != "default" else None
start = time.perf_counter()
r = twip.montecarlo("flat-lqr-sim", n, perturb={"m_body": twip.Uniform(rel=0.2), "phi0": twip.Normal(std=0.05)},
                    seed=1, progress=False, checkpoint=folder, options={"t_final": t_final},
                    shard_size=shard)
ran = time.perf_counter() - start
s = r.summary()
print(json.dumps({"n": r.n, "streamed": type(r).__name__, "fall_rate": s["fall_rate"],
                  "median_pitch_error": s["mean_abs_pitch_error"]["median"], "run_s": ran,
                  "summary_s": time.perf_counter() - start - ran,
                  "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[100_000, 1_000_000, 10_000_000])
    ap.add_argument("--budget", default="256M", help="TWIP_MEMORY_BUDGET for the sweeps (default 256M)")
    ap.add_argument("--t-final", type=float, default=0.01, help="seconds simulated per sample (default 0.01)")
    ap.add_argument("--shard-size", type=int, default=None,
                    help="samples per shard (default: the sweep's own, 1024 up to 10**7 samples, then n / 10**4)")
    args = ap.parse_args()
    rows = []
    for n in args.n:
        with tempfile.TemporaryDirectory() as folder:
            shard = str(args.shard_size) if args.shard_size else "default"
            out = subprocess.run([sys.executable, "-c", CHILD, str(n), str(args.t_final), folder, shard], check=True,
                                 capture_output=True, text=True, env={**__import__("os").environ,
                                                                      "TWIP_MEMORY_BUDGET": args.budget})
        row = json.loads(out.stdout)
        rows.append(row)
        print(f"n = {n:>12,}  {row['streamed']:20s} peak RSS {row['peak_rss_mib']:8.1f} MiB  "
              f"run {row['run_s']:7.1f} s  summary {row['summary_s']:6.1f} s  fall rate {row['fall_rate']:.4f}",
              flush=True)
    if len(rows) >= 2:
        a, b = rows[0], rows[-1]
        slope = (b["peak_rss_mib"] - a["peak_rss_mib"]) * 2**20 / (b["n"] - a["n"])
        print(f"slope of peak RSS vs n: {slope:.4f} bytes per sample "
              f"(an in-memory sweep keeps ~{320} bytes per sample)")


if __name__ == "__main__":
    main()
