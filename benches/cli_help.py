"""How long `twip --help` takes, side by side with another copy of the package.

    python benches/cli_help.py [--other PYTHONPATH] [--runs 5]

Runs `python -m twip --help` in fresh processes, alternating this checkout's python/ and
`--other` (e.g. an older checkout's python/ folder, holding its own built twip._core), and
prints each side's median and the ratio: the machine's drift moves both sides alike.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path


def once(pythonpath: str) -> float:
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "twip", "--help"], env={**os.environ, "PYTHONPATH": pythonpath},
                   check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--other", help="PYTHONPATH of the package to compare with")
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    sides = {"this": str(Path(__file__).resolve().parents[1] / "python")}
    if args.other:
        sides["other"] = args.other
    times = {k: [] for k in sides}
    for _ in range(args.runs):
        for name, path in sides.items():
            times[name].append(once(path))
    for name, values in times.items():
        print(f"{name}: median {statistics.median(values):.3f} s of {args.runs} ({', '.join(f'{v:.2f}' for v in values)})")
    if args.other:
        print(f"this / other: {statistics.median(times['this']) / statistics.median(times['other']):.2f}")


if __name__ == "__main__":
    main()
