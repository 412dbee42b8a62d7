"""What each logged signal is, as a function of the predicted state and its rate: the
measurement model of the estimator, and the noise level of a signal estimated from itself."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from twip import _core, checks

#: The signals the estimator compares with predictions (the inputs u and pwm drive them).
OUTPUTS = ("phi", "phi_dot", "theta", "theta_dot", "gyro", "enc", "accel_x", "accel_z")


#: Signals that carry an unknown constant offset (estimated beside the parameters).
BIASED = ("gyro", "accel_x")


@dataclass(frozen=True)
class Sensors:
    """What turns states into raw readings: the encoder's counts per wheel turn, the IMU's
    height above the axle [m], and the IMU (a `twip.Imu`) whose low-pass filter (DLPF)
    smoothed and delayed the gyro and accelerometer columns, if any: the predictions then
    pass through the same filter, at the IMU's samples (a slower log's rows are whole numbers of them)."""

    encoder_cpr: float = 700.0
    imu_height: float = 0.12
    imu: Optional[object] = None

    def __post_init__(self):
        object.__setattr__(self, "encoder_cpr", checks.real("encoder_cpr", self.encoder_cpr, above=0))
        height = checks.real("imu_height", self.imu_height, at_least=0)
        if height > checks.MAX_IMU_HEIGHT:
            raise _core.InvalidParameterError(f"imu_height = {self.imu_height!r}: must be at most "
                                              f"{checks.MAX_IMU_HEIGHT:g} m (the IMU's height above the axle)")
        object.__setattr__(self, "imu_height", height)
        checks.of_type("imu", self.imu, (_core.Imu, type(None)), "a twip.Imu or None")

    @classmethod
    def of(cls, realism) -> "Sensors":
        """The sensors of a `twip.Realism` (its encoder and IMU)."""
        imu = realism.imu
        return cls(encoder_cpr=realism.encoder_cpr or 700.0, imu_height=imu.height if imu else 0.12, imu=imu)


FILTERED = ("gyro", "accel_x", "accel_z")


def predict(name: str, states: np.ndarray, rates: np.ndarray, radius: float, g: float, slope: float,
            sensors: Sensors, segments: Sequence[range], sensed: Optional[np.ndarray] = None) -> np.ndarray:
    """Signal `name` over states [n, 4] and their rates (as `_core.sysid_shoot` gives), without
    any sensor offset. `sensed` [n, 2] (sysid_shoot's too): the motor shafts' offset from the
    wheels, which the encoder counts (gear play), and the pitch rate the IMU samples (after
    an impact in the play, which jumps it); None: no play. Through an IMU's filter, each
    shooting segment is filtered on its own, from the steady state of its first value, so
    that it depends on its own start state only; the estimator leaves out the rows where
    that start has not yet been forgotten."""
    if sensed is not None and (name == "enc" or name in FILTERED):
        states = states.copy()
        if name == "enc":
            states[..., 2] = states[..., 2] + sensed[..., 0]
        else:
            states[..., 1] = sensed[..., 1]
    raw = _unfiltered(name, states, rates, radius, g, slope, sensors)
    if sensors.imu is None or name not in FILTERED:
        return raw
    dlpf = sensors.imu.dlpf("gyro" if name == "gyro" else "accel")
    starts = [r.start for r in segments]
    filtered = dlpf.filter(raw, starts)
    # A log row holds the register as last sampled: one IMU sample before the row's state
    # (within its segment: a segment's first row holds its own first sample).
    out = np.empty_like(filtered)
    out[1:] = filtered[:-1]
    out[starts] = filtered[starts]
    return out


def settling_samples(sensors: Sensors, name: str) -> int:
    """Samples after a segment's start left out of the comparison of a filtered signal: until
    the filter's start from a steady state has decayed below a thousandth (ten filter
    delays; measured on the MPU-6050's 42 Hz gyro row: 1e-3 of the start's error after 50
    samples at 1 kHz), and the register's sample."""
    if sensors.imu is None or name not in FILTERED:
        return 0
    return _filter_delays(sensors, name, SETTLING_DELAYS) + 1


#: Filter delays after a segment's start that a filtered signal is not compared over.
SETTLING_DELAYS = 10
#: Filter delays after an impact in the gear play that a filtered signal is not compared over
#: (benches/sysid.py --accuracy, mid robot, friction and play declared, seed 0: with 3, i_body
#: +13 %, not converged; with 5, within 0.52 %).
IMPACT_DELAYS = 5


def impact_samples(sensors: Sensors, name: str) -> int:
    """IMU samples after an impact's sample that a filtered signal is not compared over
    (`IMPACT_DELAYS` filter delays): its one jumped sample has faded through the filter."""
    if sensors.imu is None or name not in FILTERED:
        return 0
    return _filter_delays(sensors, name, IMPACT_DELAYS)


def _filter_delays(sensors: Sensors, name: str, delays: float) -> int:
    """IMU samples in `delays` delays of filtered signal `name`'s filter, rounded up."""
    dlpf = sensors.imu.dlpf("gyro" if name == "gyro" else "accel")
    return int(math.ceil(delays * dlpf.delay * dlpf.sample_rate))


def _unfiltered(name, states, rates, radius, g, slope, sensors) -> np.ndarray:
    phi, phi_dot, theta = states[..., 0], states[..., 1], states[..., 2]
    if name in ("phi", "phi_dot", "theta", "theta_dot"):
        return states[..., ("phi", "phi_dot", "theta", "theta_dot").index(name)]
    if name == "gyro":
        return phi_dot
    if name == "enc":
        return (theta - phi) * (sensors.encoder_cpr / (2 * math.pi))
    # The specific force at the IMU, as hardware::imu::specific_force computes it.
    wheel = radius * rates[..., 3]
    pitch = phi + slope
    if name == "accel_x":
        return wheel * np.cos(pitch) + sensors.imu_height * rates[..., 1] - g * np.sin(phi)
    if name == "accel_z":
        return wheel * np.sin(pitch) - sensors.imu_height * phi_dot**2 + g * np.cos(phi)
    raise KeyError(name)


def noise_level(name: str, y: np.ndarray) -> float:
    """The standard deviation of white noise on `y`, from its second differences (robust:
    the median absolute deviation). A smooth signal sampled fast has second differences far
    below its noise. Encoder counts are at least quantised: one count's rounding, 1/sqrt(12)."""
    d2 = np.diff(y, 2)
    sigma = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6) if len(d2) else 0.0
    return max(sigma, noise_floor(name, y))


def noise_floor(name: str, y: np.ndarray) -> float:
    """The least noise a weight assumes: one count's rounding for the encoder, else a
    billionth of the signal's size (exact data would otherwise weigh by rounding error)."""
    return 1 / math.sqrt(12) if name == "enc" else 1e-9 * max(float(np.max(np.abs(y))), 1e-6)
