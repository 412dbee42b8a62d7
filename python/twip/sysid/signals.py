"""The log's signals as the estimator cuts and weighs them: its shooting segments, a rate
smoothed from a noisy or quantised angle, and a residual's correlation time (how many samples
one independent sample is worth), which the covariance and the misfit check both use."""
from __future__ import annotations

from typing import List

import numpy as np

from twip import checks
from twip.sysid.log import LogError

#: The fewest samples a segment may have on average.
MIN_SEGMENT_SAMPLES = 8
#: Sokal's window for a correlation time: the sum of the autocorrelation runs to the first
#: lag at least this many times the time summed so far.
CORRELATION_WINDOW = 5.0


def correlation_time(e: np.ndarray) -> float:
    """The integrated autocorrelation time 1 + 2 Σ_k ρ(k) of the series `e` (Sokal's
    window): how many samples one independent sample of it is worth (1 for white noise)."""
    e = np.asarray(e, dtype=float)
    if len(e) < 2:
        return 1.0
    e = e - np.mean(e)
    if not np.any(e):
        return 1.0
    spectrum = np.fft.rfft(e, 2 * len(e))
    acf = np.fft.irfft(spectrum * np.conj(spectrum))[:len(e)]
    times = 2.0 * np.cumsum(acf / acf[0]) - 1.0  # 1 + 2 Σ_{k=1..K} ρ(k), for each K
    reached = np.nonzero(np.arange(len(e)) >= CORRELATION_WINDOW * times)[0]
    return max(float(times[reached[0]] if len(reached) else times[-1]), 1.0)


def smooth_rate(x: np.ndarray, t: np.ndarray, window: float = 0.02) -> np.ndarray:
    """A derivative of a noisy or quantised signal: differences over about `window` seconds."""
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(window / dt / 2)))
    out = np.empty_like(x)
    for i in range(len(x)):
        a, b = max(0, i - k), min(len(x) - 1, i + k)
        out[i] = (x[b] - x[a]) / (t[b] - t[a])
    return out


def segments(t: np.ndarray, segment: float) -> List[int]:
    """The indices where the log's shooting segments of about `segment` seconds start."""
    segment = checks.real("segment", segment, above=0)
    starts, next_start = [0], t[0] + segment
    for i in range(1, len(t) - 1):
        if t[i] >= next_start:
            starts.append(i)
            next_start = t[i] + segment
    # A last segment shorter than half a segment joins the one before.
    if len(starts) > 1 and t[-1] - t[starts[-1]] < segment / 2:
        starts.pop()
    if len(starts) > 1 and len(starts) * MIN_SEGMENT_SAMPLES > len(t):
        raise LogError(f"segment = {segment!r}: {len(starts)} segments of a log of {len(t)} samples; each needs "
                       f"{MIN_SEGMENT_SAMPLES} samples on average (its start state is 4 unknowns)")
    return starts
