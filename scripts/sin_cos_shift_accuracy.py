"""How near the sweeps' shifted sin/cos (`math::sin_cos_plus`) is to sin/cos of φ + d.

An RK4 stage's pitch is the step's first pitch φ moved by d = k h. The lanes take the later
stages' sin/cos from the first's by the sum formulas (sin d and cos d − 1 by Taylor's first
four and three terms), where before they took sin/cos of the rounded sum fl(φ + d). This script emulates
the Rust arithmetic in Python (each multiply-add rounded once, by exact fractions) and
measures both against 120-bit sin/cos of the exact φ + d, in ulp of the true value:

    .venv/bin/python scripts/sin_cos_shift_accuracy.py [--n 20000]

It also measures the sum formulas with the small terms added to sin φ one at a time (two
roundings at the result's scale), the order first tried, and with cos d − 1's fourth term,
d⁸/8!, which the lanes took until the twenty-eighth session.
"""
from __future__ import annotations

import argparse
import math
import random
from fractions import Fraction

import mpmath

# Taylor's terms, as math::SIN[..3] and math::COS[..3] (and COS[3], the term dropped).
SIN = [-1 / 6, 1 / 120, -1 / 5040]
COS = [-0.5, 1 / 24, -1 / 720, 1 / 40320]
SHIFT_LIMIT = 1 / 32


def fma(a: float, b: float, c: float) -> float:
    """a·b + c rounded once."""
    return float(Fraction(a) * Fraction(b) + Fraction(c))


def shifted(s: float, c: float, d: float, one_by_one: bool = False, cos_terms: int = 3) -> tuple[float, float]:
    """`sin_cos_plus((s, c), d)`, operation for operation (cos_terms = 4: with d⁸/8!)."""
    d2 = d * d
    sin_d = fma(d * d2, fma(d2, fma(d2, SIN[2], SIN[1]), SIN[0]), d)
    inner = fma(d2, COS[3], COS[2]) if cos_terms == 4 else COS[2]
    cos_d_1 = d2 * fma(d2, fma(d2, inner, COS[1]), COS[0])
    if one_by_one:
        return fma(c, sin_d, fma(s, cos_d_1, s)), fma(-s, sin_d, fma(c, cos_d_1, c))
    return s + fma(c, sin_d, s * cos_d_1), c + fma(-s, sin_d, c * cos_d_1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20000, help="random (φ, d) pairs")
    args = parser.parse_args()
    mpmath.mp.prec = 120
    rng = random.Random(1)
    ways = {
        "shifted (sin_cos_plus)": lambda x, d: shifted(math.sin(x), math.cos(x), d),
        "shifted, terms added one by one": lambda x, d: shifted(math.sin(x), math.cos(x), d, True),
        "shifted, cos d − 1 to d⁸/8!": lambda x, d: shifted(math.sin(x), math.cos(x), d, cos_terms=4),
        "libm's sin/cos of fl(φ + d)": lambda x, d: (math.sin(x + d), math.cos(x + d)),
    }
    errors = {name: [] for name in ways}
    for _ in range(args.n):
        x, d = rng.uniform(-3.0, 3.0), rng.uniform(-SHIFT_LIMIT, SHIFT_LIMIT)
        exact = mpmath.mpf(x) + mpmath.mpf(d)
        truth = (mpmath.sin(exact), mpmath.cos(exact))
        for name, way in ways.items():
            for got, want in zip(way(x, d), truth):
                ulp = math.ulp(max(abs(float(want)), 1e-300))
                errors[name].append(float(abs(mpmath.mpf(got) - want)) / ulp)
    print(f"{args.n} pairs, φ in ±3, |d| ≤ 1/32; error in ulp of the true sin/cos of φ + d")
    for name, e in errors.items():
        e.sort()
        print(f"{name:34s} mean {sum(e) / len(e):.3f}  median {e[len(e) // 2]:.3f}  99th percentile {e[int(0.99 * len(e))]:.2f}")


if __name__ == "__main__":
    main()
