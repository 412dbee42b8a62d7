"""The `twip` command line. `twip demo` runs every thesis scenario and prints a summary."""
from __future__ import annotations

import argparse
import math
import sys
import time

import twip
from twip import scenarios


def _demo(args) -> int:
    print(f"twip {twip.__version__}: the thesis's scenarios on RobotParams.balanbot()\n")
    header = f"{'scenario':16s} {'design':10s} {'outcome':10s} {'|pitch err|':>12s} {'|speed err|':>12s} " \
             f"{'pitch settle':>13s} {'speed settle':>13s} {'final pos err':>14s} {'run time':>9s}"
    print(header)
    print("-" * len(header))
    for name in scenarios.names():
        for point in ("thesis", "operating"):
            sc = scenarios.get(name, point=point)
            start = time.perf_counter()
            r = sc.run()
            elapsed = time.perf_counter() - start
            m = r.metrics
            print(
                f"{name:16s} {point:10s} {r.outcome:10s} {math.degrees(m['mean_abs_pitch_error']):10.3f} ° "
                f"{math.degrees(m['mean_abs_speed_error']):8.2f} °/s {m['pitch_settling_time']:11.2f} s "
                f"{m['speed_settling_time']:11.2f} s {100 * m['final_position_error']:11.2f} cm {1e3 * elapsed:7.2f} ms"
            )
    print("\nSettling times are the last time outside a 2 % band (see docs/scenarios.md).")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="twip", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("demo", help="run every thesis scenario and print a summary",
                   description="Run every thesis scenario (both LQR design points) and print their metrics.")
    args = parser.parse_args(argv)
    try:
        return {"demo": _demo}[args.command](args)
    except twip.TwipError as e:
        print(f"twip: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
