"""The memory budget: every buffer whose size comes from the caller (a run's log, a
sweep's metric arrays, traces, animation frames) is checked against it before it is
made, so that a request too large is a `MemoryBudgetError` naming the parameter, the
bytes needed and the way out, never an abort that takes the interpreter down.

The budget is, in order: `twip.set_memory_budget(bytes)`, the environment variable
`TWIP_MEMORY_BUDGET` (bytes, or with a suffix: "512M", "8G"), else half of the memory
the machine has available when the check runs.
"""
from __future__ import annotations

import os
from typing import Optional

from twip import _core

ENV = "TWIP_MEMORY_BUDGET"
#: The share of the available memory one request may take by default.
DEFAULT_SHARE = 0.5
#: Without /proc/meminfo or sysconf (rare), assume this much is available.
FALLBACK_AVAILABLE = 4 << 30
_SUFFIX = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}

_budget: Optional[int] = None


class MemoryBudgetError(_core.TwipError, MemoryError):
    """A request would need more memory than the budget (see `twip.set_memory_budget`)."""


def set_memory_budget(nbytes: Optional[int]) -> None:
    """Sets the memory budget [bytes] of one request; None restores the default."""
    global _budget
    if nbytes is not None and (isinstance(nbytes, bool) or not isinstance(nbytes, int) or nbytes <= 0):
        raise _core.InvalidParameterError(f"memory budget = {nbytes!r}: must be a positive integer (bytes) or None")
    _budget = nbytes


def _parse(text: str) -> int:
    t = text.strip().upper().removesuffix("B")
    scale = _SUFFIX.get(t[-1:], 1)
    try:
        value = int(float(t[:-1] if scale > 1 else t) * scale)
    except (ValueError, OverflowError):  # not a number, nan or inf
        value = 0
    if value <= 0:
        raise _core.InvalidParameterError(f"{ENV} = {text!r}: must be a positive number of bytes (e.g. 2G)")
    return value


def available_memory() -> int:
    """The memory [bytes] the machine has available now (MemAvailable on Linux)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return FALLBACK_AVAILABLE


def memory_budget() -> int:
    """The budget [bytes] a single request may use now."""
    if _budget is not None:
        return _budget
    if os.environ.get(ENV):
        return _parse(os.environ[ENV])
    return int(available_memory() * DEFAULT_SHARE)


def _human(nbytes: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(nbytes) < 1024 or unit == "PiB":
            return f"{nbytes:.0f} {unit}" if unit == "bytes" else f"{nbytes:.1f} {unit}"
        nbytes /= 1024
    return ""


def check(what: str, nbytes: float, way_out: str) -> None:
    """Raises MemoryBudgetError when `nbytes` (asked for by `what`) exceeds the budget."""
    budget = memory_budget()
    if nbytes > budget:
        raise MemoryBudgetError(
            f"{what} would need {int(nbytes):,} bytes ({_human(nbytes)}), more than the memory budget of "
            f"{budget:,} bytes ({_human(budget)}); {way_out}, or raise the budget with "
            f"twip.set_memory_budget(bytes) or {ENV}"
        )
