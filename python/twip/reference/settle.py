"""A firmware's start, as twip-core's hardware/settle.rs: before the run the robot stands
still at its initial pitch while the loop reads a fresh copy of the IMU (on its own noise
stream) through the tilt estimator. Only the estimator and the time of its last read carry
over into the run."""
from __future__ import annotations

import math

from twip.reference.rng import Sfc64

#: The settle's noise key beside the run's: (seed ^ this, stream).
SETTLE_SEED = 0x5E771E0000000000


def settle(tilt, imu, phi, g, seconds, dt, period, seed, stream):
    """Feeds `tilt` the fresh IMU `imu` (a reference Mpu6050) at rest at pitch `phi` for
    whole loop periods covering `seconds`; returns the last read's time (-period)."""
    rng = Sfc64(seed ^ SETTLE_SEED, stream)
    per_update = max(round(period / dt), 1)
    reads = max(math.ceil(seconds / period), 1)
    fx, fz = -g * math.sin(phi), g * math.cos(phi)
    next_sample, half_step = 0.0, dt * 0.5

    def sample(t):
        nonlocal next_sample
        if t + half_step >= next_sample:
            imu.sample(fx, fz, 0.0, rng)
            next_sample += imu.period

    sample(0.0)
    last = None
    for k in range(reads * per_update):
        t = dt * k
        if k % per_update == 0:
            ax, az, gyro = imu.reading
            tilt.update(math.atan2(-ax, az), gyro, 0.0 if last is None else t - last)
            last = t
        sample(t)
    return -(dt * per_update)
