"""Exact quantiles of data too large for memory, read in chunks: `streamed_quantiles`
gives what np.quantile would on all the values together (linear interpolation), with
memory bounded by a chunk. A streamed sweep's summaries use it over its shards."""
from __future__ import annotations

import math
from typing import Callable, Dict

import numpy as np

from twip import _core

#: A value range is narrowed until at most this many values remain, then sorted.
_EXACT = 1 << 16
_BINS = 1024


def levels(q) -> np.ndarray:
    """`q` as quantile levels: floats in [0, 1], of any shape; else a TypeError or a
    twip.InvalidParameterError naming q."""
    try:
        out = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"q must be quantile levels (numbers in [0, 1]), got {q!r}") from None
    if not np.all((out >= 0) & (out <= 1)):
        raise _core.InvalidParameterError(f"q = {q!r}: quantile levels must be in [0, 1]")
    return out


def no_values(shape):
    """The quantiles of no values at levels of `shape`: NaN (a float for a scalar level)."""
    return np.full(shape, np.nan)[()]


def streamed_quantiles(chunks: Callable, q) -> np.ndarray:
    """np.quantile(all values, q) over the arrays that `chunks()` yields again on every
    call (see `streamed_quantiles_of`)."""
    return streamed_quantiles_of(lambda: ({"v": v} for v in chunks()), ["v"], q)["v"]


def streamed_quantiles_of(chunks: Callable, names, q) -> Dict[str, np.ndarray]:
    """{name: np.quantile(all values of column name, q)} (linear interpolation, the same bits;
    shaped as q, a float for a scalar q; NaN without values) over the dicts of arrays that
    `chunks()` yields again on every call: exact, with memory bounded by a chunk. Each order
    statistic is found by narrowing a value range with histograms, all columns in the same
    passes, until few enough values remain to sort."""
    q = levels(q)
    shape, q = q.shape, q.ravel()
    count = dict.fromkeys(names, 0)
    lo, hi = dict.fromkeys(names, math.inf), dict.fromkeys(names, -math.inf)
    nan = set()
    for chunk in chunks():
        for name in names:
            v = chunk[name]
            if len(v) and name not in nan:
                if np.isnan(v).any():
                    nan.add(name)  # as np.quantile: NaN
                    continue
                count[name] += len(v)
                lo[name], hi[name] = min(lo[name], float(v.min())), max(hi[name], float(v.max()))
    out = {name: no_values(shape) for name in names}
    # Per (column, rank): the range [lo, hi] that holds it, values below lo, values inside.
    state, value = {}, {}
    for name in names:
        if name not in nan and count[name]:
            for p in q * (count[name] - 1):
                for r in _ranks(p, count[name])[:2]:
                    state[name, r] = dict(lo=lo[name], hi=hi[name], below=0, inside=count[name])
    while len(value) < len(state):
        for key, s in state.items():
            if key not in value and s["lo"] == s["hi"]:
                value[key] = s["lo"]
        open_ = [key for key in state if key not in value]
        if not open_:
            break
        gather = {key: [] for key in open_ if state[key]["inside"] <= _EXACT}
        hist = {key: (np.zeros(_BINS, np.int64), np.full(_BINS, np.inf), np.full(_BINS, -np.inf))
                for key in open_ if key not in gather}
        for chunk in chunks():
            for key in open_:
                v = chunk[key[0]]
                a, b = state[key]["lo"], state[key]["hi"]
                inside = v[(v >= a) & (v <= b)]
                if key in gather:
                    gather[key].append(inside)
                    continue
                counts, mins, maxs = hist[key]
                if math.isfinite(b - a):
                    k = np.clip(((inside - a) / (b - a) * _BINS).astype(np.int64), 0, _BINS - 1)
                elif math.isfinite(a) and math.isfinite(b):  # b - a overflows (-1e308..1e308): in halves
                    k = np.clip(((inside / 2 - a / 2) / (b / 2 - a / 2) * _BINS).astype(np.int64), 0, _BINS - 1)
                else:  # infinities at an end: -inf, the finite values, +inf (monotone too)
                    k = np.where(inside == -math.inf, 0, np.where(inside == math.inf, 2, 1))
                counts += np.bincount(k, minlength=_BINS)
                np.minimum.at(mins, k, inside)
                np.maximum.at(maxs, k, inside)
        for key, parts in gather.items():
            value[key] = float(np.sort(np.concatenate(parts))[key[1] - state[key]["below"]])
        for key, (counts, mins, maxs) in hist.items():
            cum = np.cumsum(counts)
            below = state[key]["below"]
            k = int(np.searchsorted(cum, key[1] - below, side="right"))
            state[key] = dict(lo=float(mins[k]), hi=float(maxs[k]), below=below + (int(cum[k - 1]) if k else 0),
                              inside=int(counts[k]))
    for name in names:
        if name not in nan and count[name]:
            ranks = [_ranks(p, count[name]) for p in q * (count[name] - 1)]
            out[name] = np.array([_lerp(value[name, a], value[name, b], t) for a, b, t in ranks]).reshape(shape)[()]
    return out


def _ranks(p: float, count: int):
    """(rank, next rank, weight) np.quantile interpolates with at virtual index `p`, as numpy's
    _get_indexes and _get_gamma: floor(p) and the next; at or beyond the last both the last
    (numpy's index -1, which its weight p + 1 keeps: it decides the sign of a zero)."""
    if p >= count - 1:
        return count - 1, count - 1, p + 1
    return math.floor(p), math.floor(p) + 1, p - math.floor(p)


def _lerp(a: float, b: float, t: float) -> float:
    """numpy's _lerp, for its bits: from the nearer end (b − (b − a)(1 − t) from t = 0.5)."""
    diff = b - a
    return b - diff * (1 - t) if t >= 0.5 else a + diff * t
