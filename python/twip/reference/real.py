"""A real number as the bindings read one (crates/twip-py/src/convert.rs, `Real`), so that
the reference refuses what the Rust side refuses, with its wording: a bool and a complex
number (Python's or numpy's) read by float() as 0/1 or their real part, and what float()
parses but the bindings do not read at all (a string: "1.5"). An int, a float, a numpy
real, a Fraction or a Decimal read as float() reads them."""
from __future__ import annotations

import operator

import numpy as np


def real(name: str, value) -> float:
    """`value` as a float, or a TypeError that starts with `name` (as the bindings' do)."""
    if isinstance(value, float):  # np.float64 too
        return value
    kind = getattr(getattr(value, "dtype", None), "kind", None)
    if isinstance(value, (bool, np.bool_)) or kind == "b":
        raise TypeError(f"{name}: expected a real number, got the bool {value!r}")
    if isinstance(value, complex) or kind == "c":
        raise TypeError(f"{name}: expected a real number, got the complex value {value!r}")
    if hasattr(type(value), "__float__"):
        return float(value)
    if hasattr(type(value), "__index__"):
        return float(operator.index(value))
    raise TypeError(f"{name}: must be real number, not {type(value).__name__}")


def reals(name: str, values) -> list:
    """Each entry of a sequence as `real`, the entry named `name[i]`."""
    return [real(f"{name}[{i}]", v) for i, v in enumerate(values)]
