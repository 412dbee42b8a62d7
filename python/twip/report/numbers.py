"""How the report rounds and prints numbers: report.md is written from report.json, so a
number must print as the value that report.json holds."""
from __future__ import annotations

import math

import numpy as np

def jsonable(x):
    """NaN and infinities become null (JSON has neither); numpy scalars become floats."""
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    return x


def sig(x, digits: int = 4):
    """x rounded to `digits` significant digits (what report.md prints, what report.json holds)."""
    if x is None:
        return None
    if isinstance(x, (list, tuple, np.ndarray)):
        return [sig(v, digits) for v in x]
    if isinstance(x, (bool, np.bool_, str)):
        return x if not isinstance(x, np.bool_) else bool(x)
    x = float(x)
    if not math.isfinite(x) or x == 0:
        return x if math.isfinite(x) else None
    return float(f"{x:.{digits}g}")


def dec(x, decimals: int):
    """x rounded to a number of decimals (tables with a fixed precision per column)."""
    if x is None or not math.isfinite(float(x)):
        return None
    return round(float(x), decimals) + 0.0


def fix(x, decimals: int) -> str:
    """A table cell with a fixed number of decimals (the value is already rounded to them)."""
    return "—" if x is None else f"{x:.{decimals}f}"


def fmt(x) -> str:
    """The report.md text of a sig value: reads back as the same number."""
    if x is None:
        return "—"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, str):
        return x
    if isinstance(x, (list, tuple)):
        if len(x) == 2:
            return f"{fmt(x[0])} / {fmt(x[1])}"
        return "[" + ", ".join(fmt(v) for v in x) + "]"
    return f"{x:.6g}"
