"""The time base the predictions are made on.

A firmware logs at its loop period (5 ms), while its IMU samples and filters at its own
rate (1 kHz) between the logged rows, and its PWM duty is held over the period. The
predictions are then made at the IMU's samples: the log's rows, and the IMU's samples
between them, with the logged input held. The declared filter runs over all of them and
each logged row reads the register as the IMU last wrote it. A log at the IMU's rate (or
without a declared IMU) is its own grid.
"""
from __future__ import annotations

from typing import List, Optional, Sequence

import numpy as np

from twip.sysid.log import LogError

#: How far (in IMU samples) a logged interval may be from a whole number of them.
TICK_TOLERANCE = 0.25


class Grid:
    """The prediction's samples: `t` and the held input `u` on them, the shooting segments'
    starts `segments` and their `ranges` there, and `rows`, each logged row's sample."""

    def __init__(self, t: np.ndarray, u: np.ndarray, segments: Sequence[int], rate: Optional[float]):
        steps = np.diff(t)
        ticks = np.ones(len(steps), dtype=np.int64)
        if rate is not None:
            exact = steps * rate
            ticks = np.maximum(np.rint(exact), 1).astype(np.int64)
            off = np.flatnonzero(np.abs(exact - ticks) > TICK_TOLERANCE)
            if len(off):
                i = int(off[0])
                raise LogError(f"t: the interval after row {i} ({steps[i]:.6g} s, from t = {float(t[i])!r}) is "
                               f"{exact[i]:.3g} of the IMU's samples (sensors.imu.sample_rate = {rate:.6g} Hz); the "
                               "declared filter is replayed at the IMU's samples, so each logged interval must be a "
                               "whole number of them")
        #: The IMU samples in a logged interval (the most common one).
        self.ratio = int(np.bincount(ticks).argmax()) if len(ticks) else 1
        self.identity = bool(np.all(ticks == 1))
        self.rows = np.concatenate([[0], np.cumsum(ticks)])
        if self.identity:
            self.t, self.u = t, u
        else:
            # Each interval split evenly: the prediction's time is the log's own at its rows.
            fractions = np.concatenate([np.arange(k) / k for k in ticks])
            self.t = np.append(np.repeat(t[:-1], ticks) + fractions * np.repeat(steps, ticks), t[-1])
            self.u = np.append(np.repeat(u[:-1], ticks), u[-1])
        self.segments = [int(self.rows[s]) for s in segments]
        ends = [*self.segments[1:], len(self.t)]
        self.ranges: List[range] = [range(a, b) for a, b in zip(self.segments, ends)]

    def at_rows(self, signal: np.ndarray) -> np.ndarray:
        """A signal on this grid, at the logged rows."""
        return signal if self.identity else signal[..., self.rows]
