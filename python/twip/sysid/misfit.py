"""Does the fitted model explain the log? The residual check every `Fit` runs.

A model that fits leaves the measurement noise: residuals at the noise's level, as
correlated from sample to sample as the sensor's filter makes noise (white without one).
A model that lacks a part of the robot (an undeclared IMU filter, gearhead friction, the
wrong driver) leaves a slow, motion-shaped residual above the noise, and its parameters
take up what it cannot explain: a fit can converge there, with narrow intervals, far off.

The noise each signal carries is estimated from second differences (`measure.noise_level`),
scaled by what the declared sensor filter does to white noise sampled as the log samples it
(measured on a fixed white series): the smaller of the signal's estimate and the residual's.
Behind a filter the signal's own differences are mostly the robot's motion (its jerk at each
new command), not noise: the gain that undoes the filter's smoothing then read a gyro's noise
at 12x what a correct fit left (measured on rig logs of two robots), and a wrong driver's
gyro residual, 21x as correlated as noise and 3x a correct fit's, passed as 0.26x "the
noise" without a word. The residual's differences have the motion taken out; where the model
misses a slow part, that part barely moves them, so it still stands out against them.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional

import numpy as np

from twip.sysid.signals import correlation_time
from twip.sysid.measure import FILTERED, noise_floor, noise_level


class SysidMisfitWarning(UserWarning):
    """The fitted model does not explain the log: its residuals are above the noise the log
    shows, or far more correlated than noise. The fitted values may be far off."""


#: A signal misfits when its residual RMS exceeds this multiple of the noise the log shows.
LEVEL_LIMIT = 2.0
#: ... or when it is above this multiple and its residuals' correlation time is more than
#: WHITENESS_LIMIT times what the noise path gives (a slow, systematic residual).
#: (Measured on the user's robot's rig log: a wrong driver left the encoder's residual at 0.98x
#: its noise estimate and 270x as correlated; a right fit, 0.48x and 1.0x.)
CORRELATED_LEVEL = 0.75
WHITENESS_LIMIT = 4.0
#: Samples of the white series that calibrates a filter's effect on noise.
CALIBRATION_SAMPLES = 20000


def noise_path(dlpf, ratio: int):
    """(gain, correlation time) of white noise through `dlpf` (None: no filter), sampled every
    `ratio`-th filter sample: the noise's standard deviation over what `noise_level` reads
    from its second differences, and its integrated correlation time in log samples."""
    if dlpf is None:
        return 1.0, 1.0
    key = (tuple(sorted(dlpf.to_dict().items())), int(ratio))
    if key not in _CALIBRATED:
        white = np.random.default_rng(0).normal(size=CALIBRATION_SAMPLES * int(ratio))
        seen = np.asarray(dlpf.filter(white))[::int(ratio)][200:]
        _CALIBRATED[key] = (float(np.std(seen) / noise_level("", seen)), correlation_time(seen))
    return _CALIBRATED[key]


_CALIBRATED: dict = {}


def check(problem, residuals: Dict[str, np.ndarray], sigma: Optional[Dict[str, float]] = None) -> List[str]:
    """One sentence for each compared signal whose residuals (measured - predicted, NaN where
    not compared) are not the noise the log shows; [] when the model explains the log."""
    out = []
    for s, r in residuals.items():
        r = np.asarray(r, dtype=float)
        r = r[np.isfinite(r)]
        if len(r) < 20:
            continue
        y = problem.y[s]
        dlpf = problem.sensors.imu.dlpf("gyro" if s == "gyro" else "accel") \
            if (problem.sensors.imu is not None and s in FILTERED) else None
        gain, tau_noise = noise_path(dlpf, problem.grid.ratio if dlpf is not None else 1)
        if s == "enc":
            tau_noise = max(tau_noise, counting_time(y, residuals[s]))
        # Never below the signal's own floor (`noise_floor`: a billionth of its size, an encoder's
        # count): an exact log's residuals are the integrator's rounding, 1e-15 to 5e-14 against
        # second differences of 1e-15, which read as 1.5-48x "the noise" (benches/sysid.py's
        # exact states warned on four signals).
        expected = gain * max(min(noise_level(s, y), noise_level(s, r)), noise_floor(s, y))
        rms = float(np.sqrt(np.mean(r ** 2)))
        level = rms / expected if expected > 0 else math.inf
        tau = correlation_time(r) / tau_noise
        if level > LEVEL_LIMIT or (level > CORRELATED_LEVEL and tau > WHITENESS_LIMIT):
            out.append(f"{s}: residual RMS {rms:.3g} is {level:.1f}x the noise the log shows ({expected:.3g}), and "
                       f"{tau:.0f}x as correlated as that noise: the model does not explain this signal, so the "
                       f"fitted values may be far off. {ADVICE}")
    return out


def counting_time(counts: np.ndarray, residuals: np.ndarray) -> float:
    """The correlation time of an encoder's counting error, were the prediction right: the
    prediction (`counts` less the `residuals`, where compared) rounded to whole counts, less
    itself. A wheel that turns less than a count between samples holds its error from one to
    the next: a 4 kg robot's 5 ms log left its encoder at 1.0x the noise (0.292 counts, the
    rounding's own 1/sqrt(12)) and 5x as correlated as white noise, a misfit by the rule
    above, which the rounding of its own prediction explains."""
    r = np.asarray(residuals, dtype=float)
    compared = np.isfinite(r)
    predicted = np.asarray(counts, dtype=float)[compared] - r[compared]
    return correlation_time(np.round(predicted) - predicted)


#: What a misfit usually comes from.
ADVICE = ("Declare what the rig has: the IMU's filter (sensors=Sensors(imu=...), --imu-dlpf), the motor driver "
          "(driver=, the robot file's [driver]), the gearhead friction (friction=, --friction-coulomb), and the "
          "columns' units (scale=, --scale).")
