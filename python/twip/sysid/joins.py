"""Segments joined, or their continuity released, where it cannot be met.

Each segment's end must meet the next one's start. Where the prediction jumps just before a
boundary (an impact in the gear play, or the gearhead friction's stick band switching within a
plant step), the end is not a smooth function of the unknowns: the linearised gap closes, the
run's does not, and the search stops "not converged" with one boundary open. Shooting's
boundaries are the estimator's choice, not the log's: the two segments there become one,
whose prediction carries through the jump, and the search goes on. Where the joined
segment's end jumps in turn (a stretch of impacts), the boundaries are released instead: the
later segment's start is free of the earlier one's end, a constraint less, and the rows of
both segments still count.
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

#: The most boundaries one fit joins (or releases).
MAX_JOINS = 3


def stuck_boundary(gaps: Optional[np.ndarray], starts: np.ndarray, tolerance: float) -> Optional[int]:
    """The segment (its index) whose start the one before misses most, each state's gap in units of
    that state's size (at least 1) among the segments' `starts`, if that is beyond `tolerance`
    (the start states' difference step); None if every gap is within it."""
    if gaps is None or not len(gaps) or not np.all(np.isfinite(gaps)):
        return None
    size = np.abs(gaps) / np.maximum(1.0, np.abs(starts).max(axis=0))
    worst = int(np.argmax(size.max(axis=1)))
    return worst + 1 if size[worst].max() >= tolerance else None


def passed(times: Sequence[float], released: bool) -> str:
    """What a message says of the boundaries joined (or `released`) at `times` [s]."""
    if not times:
        return ""
    what = "continuity released" if released else "segments joined"
    return f"; {what} at t = " + ", ".join(f"{t:.3f}" for t in times) + " s, where the prediction jumps"
