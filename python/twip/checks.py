"""Checks of a caller's arguments, shared by the package's modules: a value of the wrong
type is a TypeError, a number out of range a `twip.InvalidParameterError` (a ValueError),
each naming the parameter and the value it got."""
from __future__ import annotations

import math
import sys
from typing import Optional

import numpy as np

from twip import _core


#: The types a real number may come as (a bool is an int too: `real` refuses it).
REAL = (int, float, np.integer, np.floating)
#: The highest IMU above the axle a robot file or a sysid Sensors takes [m]: a balancing
#: robot's is well below it, and far beyond it the accelerometer's predictions overflow
#: (1e300 m: an SVD of NaNs).
MAX_IMU_HEIGHT = 10.0


def of_type(name: str, value, types, what: str):
    """`value` when it is an instance of `types`; else a TypeError: "`name` must be
    `what`, got `value` (its type)"."""
    if not isinstance(value, types):
        raise TypeError(f"{name} must be {what}, got {value!r} ({type(value).__name__})")
    return value


#: The most characters a robot or controller file may have: a few kB of TOML. A larger one
#: (a log passed by mistake, /dev/zero) is refused before it is held whole.
MAX_TEXT_FILE = 1 << 20


def read_text_file(path) -> Optional[str]:
    """The text of a small UTF-8 file, or None when it has more than MAX_TEXT_FILE characters
    (OSError and UnicodeDecodeError as open and read raise them)."""
    with open(path, encoding="utf-8") as f:
        text = f.read(MAX_TEXT_FILE + 1)
    return text if len(text) <= MAX_TEXT_FILE else None


def finite_number(value) -> Optional[float]:
    """A value read from a file as a finite float, or None: a bool, a string, an array, nan,
    inf, or an integer beyond any float (10**400: float() raises OverflowError)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def shown(value) -> str:
    """`value` for a message: a huge integer by its size, not its hundreds of digits, and a
    long array or table by its start (a 200,000-number array made a 1 MB message)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**20:
        try:
            return f"an integer of {len(str(abs(value)))} digits"
        except ValueError:  # beyond Python's int-to-str limit, which str() enforces
            return f"an integer of more than {sys.get_int_max_str_digits()} digits"
    text = repr(value)
    if len(text) > 80 and isinstance(value, (list, dict, str)):
        return f"{text[:60]}... (a {type(value).__name__} of {len(value):,} items)"
    return text


def real(name: str, value, above: Optional[float] = None, at_least: Optional[float] = None) -> float:
    """`value` as a float when it is a finite real number (not a bool), > `above` and
    >= `at_least` where given."""
    if isinstance(value, bool) or not isinstance(value, REAL):
        raise TypeError(f"{name} must be a real number, got {value!r} ({type(value).__name__})")
    try:
        number = float(value)
    except OverflowError:  # an int beyond any float (10**400)
        number = math.inf
    if not (math.isfinite(number) and (above is None or number > above) and (at_least is None or number >= at_least)):
        bound = f" and > {above:g}" if above is not None else f" and >= {at_least:g}" if at_least is not None else ""
        raise _core.InvalidParameterError(f"{name} must be finite{bound}, got {value!r}")
    return number


def real_entries(name: str, value, error=_core.InvalidParameterError):
    """`value` unless it holds a complex number or a bool (a numpy array or scalar, or an
    entry of a list): numpy's cast to float would keep only a complex's real part, with
    nothing but a warning, and read a bool as 0 or 1. The error names the first such entry
    (of complex numbers, the first off the real axis; the first entry when none is)."""
    try:
        entries = np.asarray(value)
    except ValueError:  # ragged rows: the cast to float names them
        return value
    if entries.dtype.kind == "c":
        entries = entries.ravel()
        off = np.flatnonzero(entries.imag != 0)
        i = int(off[0]) if len(off) else 0
        raise error(f"{name}[{i}] = {complex(entries[i])!r}: not a real number (got complex)")
    # A bool among numbers (a list: [True, 0.5] reads as floats) or a bool array.
    if entries.dtype.kind in "bO" or not hasattr(value, "dtype"):
        for i, entry in enumerate(np.asarray(value, dtype=object).ravel()):
            if isinstance(entry, (bool, np.bool_)):
                raise error(f"{name}[{i}] = {entry!r}: not a real number (got bool)")
    return value


def vector(name: str, value, n: int) -> np.ndarray:
    """`value` as n finite floats (any array-like of n real numbers, flattened): else a
    TypeError (not numbers), an InvalidParameterError (complex or bool), a ShapeError or a
    NonFiniteError, each naming the parameter."""
    real_entries(name, value)
    try:
        v = np.asarray(value, dtype=float).ravel()
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be numbers, got {value!r} ({type(value).__name__})") from None
    if v.shape != (n,):
        raise _core.ShapeError(f"{name} has shape {np.shape(value)}, expected ({n},)")
    if not np.all(np.isfinite(v)):
        raise _core.NonFiniteError(f"{name} = {v.tolist()}: every entry must be finite")
    return v


def seed(name: str, value) -> int:
    """`value` as a seed (or a stream, a sample index): an integer in [0, 2**64) (a numpy
    integer too; not a bool, which Python and the bindings would read as 0 or 1)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value < 2**64:
        raise _core.InvalidParameterError(f"{name} = {value!r}: must be an integer in [0, 2**64)")
    return int(value)


def threads(value) -> Optional[int]:
    """`value` as a thread count: None (all cores) or an integer from 1 to MAX_THREADS
    (a numpy integer too; not a bool)."""
    if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer))
                              or not 1 <= value <= _core.MAX_THREADS):
        raise _core.InvalidParameterError(
            f"threads = {value!r}: must be an integer from 1 to {_core.MAX_THREADS}, or None (all cores)")
    return None if value is None else int(value)
