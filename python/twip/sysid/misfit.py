"""Does the fitted model explain the log? The residual check every `Fit` runs.

A model that fits leaves the measurement noise: residuals at the noise's level, as
correlated from sample to sample as the sensor's filter makes noise (white without one).
A model that lacks a part of the robot (an undeclared IMU filter, gearhead friction, the
wrong driver) leaves a slow, motion-shaped residual above the noise, and its parameters
take up what it cannot explain: a fit can converge there, with narrow intervals, far off.

The noise an unfiltered signal carries is estimated from its second differences
(`measure.noise_level`); a filtered one's from its size in the noise's band (`noise_band`:
above the model's slow errors, below the filter's corner), calibrated by making noise as the
rig makes it: white, through the declared filter, rounded to the IMU register's step on the
fit's own prediction (`noise_path`). Each from the smaller of the signal's estimate and the
residual's: the signal's own differences are mostly the robot's motion (its jerk at each new
command), not noise, so that a wrong driver's gyro residual, 21x as correlated as noise and 3x a
correct fit's, once passed as 0.26x "the noise". The residual's have the motion taken out; where
the model misses a slow part, that part barely moves them, so it still stands out against them.
A model that misses sudden events (impacts in gear play not declared) leaves spikes instead:
heavy tails (kurtosis), whatever their level.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Tuple

import numpy as np

from twip.sysid.log import UNIT_NAMES
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
#: ... or when it is above CORRELATED_LEVEL and its residuals' kurtosis exceeds this (3 for the
#: sensors' Gaussian noise, filtered or not): spikes, where the robot had sudden events the model
#: lacks. Measured on the gyro (benches/sysid.py's robots, noise seeds 0-7 or 0-11): with the full
#: rig's gear play not declared, the mid robot's 25-33 (its fits were quiet, their largest errors
#: 3.7-5.4 %), the tall robot's 14-40; with the play declared, 2.8-15.3 (the mid robot's seeds 3-6
#: 10-15, within 0.64 %), but 68-177 on the tall robot's seeds 2 and 4, whose model's impacts miss
#: the log's (a 5 ms log of seed 2 was quiet at i_body +3.8 %); logs without friction and play
#: 2.7-3.3 (the encoder's rounding, uniform, 1.8: not checked).
TAIL_LIMIT = 20.0
#: The band a filtered column's noise is measured in, in its filter's corner frequency.
NOISE_BAND = (0.25, 1.0)
#: Log samples a calibration's white series settles for (left out); halvings of the search for its scale.
CALIBRATION_SETTLING = 200
CALIBRATION_HALVINGS = 40
#: Steps of a 16-bit IMU register from zero to its full scale.
REGISTER_HALF_RANGE = 32768.0


def noise_path(dlpf, ratio: int, step: float, seen: float, predicted: np.ndarray,
               band: Tuple[float, float]) -> Tuple[float, float]:
    """(standard deviation, correlation time in log samples) of the noise on a column filtered by
    `dlpf` whose size in the noise's `band` (`band_size`) is `seen`, were that noise made as the
    rig makes it: white, through the filter, every `ratio`-th filter sample logged, added to the
    fit's `predicted` column and rounded to the register's `step` (0: not rounded). Calibrated
    on a fixed white series, scaled until its size in the band is `seen`. The band is where the
    filtered noise is most of a residual: above the model's slow errors, below the filter's
    corner, where the register's rounding (white) is a small part. Read from the second
    differences before, as the noise's level times the filter's gain: the rounding was most of
    them (the user robot's 1 kHz gyro, 42 Hz, rounded to 7.6e-3 deg/s), a right fit's residual
    read 0.43x "the noise" (0.94x unrounded), and a fit with the gear play left out, 4x a right
    fit's, passed at 1.8x."""
    white = np.random.default_rng(0).normal(size=(len(predicted) + CALIBRATION_SETTLING) * int(ratio))
    unit = np.asarray(dlpf.filter(white))[::int(ratio)][CALIBRATION_SETTLING:]
    unit_size = max(band_size(unit, band), 1e-300)

    def made(scale: float) -> np.ndarray:
        noisy = scale * unit
        return np.round((noisy + predicted) / step) * step - predicted if step > 0 else noisy

    if step > 0:  # the size grows with the scale
        low, high = 0.0, 4 * max(seen, step) / unit_size
        for _ in range(CALIBRATION_HALVINGS):
            mid = 0.5 * (low + high)
            low, high = (mid, high) if band_size(made(mid), band) < seen else (low, mid)
        noise = made(0.5 * (low + high))
    else:
        noise = made(seen / unit_size)
    return float(np.std(noise)), correlation_time(noise)


def noise_band(imu, ratio: int) -> Tuple[float, float]:
    """The band a filtered column's noise is measured in, in cycles per log sample: NOISE_BAND
    of the IMU filter's corner, within 0.45 of the log's rate (its Nyquist's 0.9)."""
    rate = imu.sample_rate / ratio
    low, high = (min(f * imu.dlpf_hz, 0.45 * rate) for f in NOISE_BAND)
    return min(low, 0.5 * high) / rate, high / rate


def band_size(x: np.ndarray, band: Tuple[float, float]) -> float:
    """The RMS of `x`'s part in `band` (cycles per sample, by its discrete Fourier transform)."""
    x = np.asarray(x, dtype=float)
    if len(x) < 2:
        return 0.0
    spectrum = np.fft.rfft(x - np.mean(x))
    f = np.fft.rfftfreq(len(x))
    inside = (f >= band[0]) & (f <= band[1])
    return float(np.sqrt(2.0 * np.sum(np.abs(spectrum[inside]) ** 2)) / len(x))


def check(problem, residuals: Dict[str, np.ndarray], sigma: Optional[Dict[str, float]] = None) -> List[str]:
    """One sentence for each compared signal whose residuals (measured - predicted, NaN where
    not compared) are not the noise the log shows; [] when the model explains the log."""
    out = []
    for s, (rms, expected, level, tau, tails) in measured(problem, residuals).items():
        if level > LEVEL_LIMIT or (level > CORRELATED_LEVEL and tau > WHITENESS_LIMIT):
            out.append(f"{s}: residual RMS {rms:.3g} is {level:.1f}x the noise the log shows ({expected:.3g}), and "
                       f"{tau:.0f}x as correlated as that noise: the model does not explain this signal, so the "
                       f"fitted values may be far off. {ADVICE}")
        elif level > CORRELATED_LEVEL and tails > TAIL_LIMIT and s != "enc":
            events = ("impacts in the gear play at other times than the model's" if problem.backlash is not None
                      else "impacts in gear play that is not declared (backlash=, --backlash)")
            out.append(f"{s}: the residuals come in spikes (kurtosis {tails:.0f}, against 3 for the sensor's noise), "
                       f"at {level:.1f}x the noise the log shows: the robot had sudden events the model does not "
                       f"have, such as {events}, so the fitted values may be off. {ADVICE}")
    return out


def measured(problem, residuals: Dict[str, np.ndarray]) -> Dict[str, Tuple[float, float, float, float, float]]:
    """For each compared signal with enough rows: its residuals' RMS, the noise the log shows,
    their ratio (the level), how many times as correlated as that noise the residuals are, and
    their kurtosis (3 for Gaussian noise, filtered or not)."""
    out = {}
    imu = problem.sensors.imu
    for s, r in residuals.items():
        compared = np.isfinite(np.asarray(r, dtype=float))
        r = np.asarray(r, dtype=float)[compared]
        if len(r) < 20:
            continue
        y = problem.y[s]
        # Never below the signal's own floor (`noise_floor`: a billionth of its size, an encoder's
        # count): an exact log's residuals are the integrator's rounding, 1e-15 to 5e-14 against
        # second differences of 1e-15, which read as 1.5-48x "the noise" (benches/sysid.py's
        # exact states warned on four signals).
        if imu is not None and s in FILTERED:
            band = noise_band(imu, problem.grid.ratio)
            seen = min(band_size(y, band), band_size(r, band))
            expected, tau_noise = noise_path(imu.dlpf("gyro" if s == "gyro" else "accel"), problem.grid.ratio,
                                             lsb(imu, s), seen, np.asarray(y, dtype=float)[compared] - r, band)
            expected = max(expected, noise_floor(s, y))
        else:
            expected, tau_noise = max(min(noise_level(s, y), noise_level(s, r)), noise_floor(s, y)), 1.0
        if s == "enc":
            tau_noise = max(tau_noise, counting_time(y, residuals[s]))
        rms = float(np.sqrt(np.mean(r ** 2)))
        centred = r - np.mean(r)
        spread = float(np.mean(centred ** 2))
        tails = float(np.mean(centred ** 4)) / spread ** 2 if spread > 0 else 0.0
        out[s] = (rms, expected, rms / expected if expected > 0 else math.inf, correlation_time(r) / tau_noise, tails)
    return out


def lsb(imu, signal: str) -> float:
    """The step of an IMU column's 16-bit register (0 when the IMU does not round): the gyro's in
    rad/s, the accelerometer's in m/s^2, as the rig rounds them."""
    if not imu.quantise:
        return 0.0
    full = math.radians(imu.gyro_range_dps) if signal == "gyro" else imu.accel_range_g * UNIT_NAMES["g"]
    return full / REGISTER_HALF_RANGE


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
