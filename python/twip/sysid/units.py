"""Plausibility of a log's columns: the mistakes that otherwise reach the estimator as a
prediction that blows up, or as a fit that converges somewhere wrong. Each check names the
column, the row and the likely unit."""
from __future__ import annotations

import math
from typing import Dict, Optional

import numpy as np

#: A duty's full scale [counts] (the L298's 8-bit PWM, `MotorDriver`).
DUTY_MAX = 255.0
#: A sample interval this many times the median one is a dropout, not a sampling rate.
DROPOUT_STEPS = 10.0
#: Median |specific force| below which accelerometer columns are in g, not m/s^2.
G_LIKE = 3.0
#: The gyro against the rate of the pitch the log shows otherwise: a ratio near 180/pi
#: (within this factor) is a gyro in deg/s. Wide: the accelerometer's pitch carries the wheels'
#: acceleration too (measured on rig logs of a 40 mm-wheeled robot: 0.45-2.6 for a gyro in rad/s).
DEG_RATIO_BAND = 5.0
#: A median interval of t at least this long [s] is t in milliseconds: a balancing robot is
#: logged every few ms (a 12 s log in ms was refused as "12000 segments", naming no unit).
MS_STEP = 0.5


def problems(t: np.ndarray, columns: Dict[str, np.ndarray]) -> Optional[str]:
    """The first implausible thing about the log, as a sentence, or None."""
    steps = np.diff(t)
    if len(steps) > 2:
        typical = float(np.median(steps))
        if typical >= MS_STEP:
            # A median of 500 or more is microseconds (Arduino's micros()): "ms" left it 1000x off.
            unit, name = ("microseconds", "us") if typical >= 1000 * MS_STEP else ("milliseconds", "ms")
            return (f"t: the median interval is {typical:.4g} s (t = {float(t[0])!r}, {float(t[1])!r}, "
                    f"{float(t[2])!r}, ...): in {unit}? a balancing robot is logged every few ms; give "
                    f"scale={{'t': '{name}'}} (--scale t={name})")
        gaps = np.flatnonzero(steps > DROPOUT_STEPS * typical)
        if len(gaps):
            i = int(gaps[0])
            return (f"t: a gap in t after row {i} (t = {float(t[i])!r} then {float(t[i + 1])!r}: {steps[i]:.3g} s, "
                    f"{steps[i] / typical:.0f}x the median interval {typical:.3g} s): a dropout; fit the pieces "
                    "on either side (RunLog.slice) or log without it")
    if "u" in columns and "pwm" in columns:
        return ("the log has both u (a current [A]) and pwm (a duty [counts]): the input is one of them; drop the "
                "other or map it to another name (columns=, --column)")
    pwm = columns.get("pwm")
    if pwm is not None:
        over = np.flatnonzero(np.abs(pwm) > DUTY_MAX)
        if len(over):
            i = int(over[0])
            return (f"pwm: row {i} is {float(pwm[i])!r}, beyond the driver's {DUTY_MAX:g} counts (max |pwm| "
                    f"{float(np.max(np.abs(pwm))):.4g}): a duty in other units (x{float(np.max(np.abs(pwm))) / DUTY_MAX:.2g} "
                    "the full scale?); give scale={'pwm': 255 / your full scale} (--scale pwm=...)")
    accel = [columns[k] for k in ("accel_x", "accel_z") if k in columns]
    if accel:
        norm = np.sqrt(sum(a ** 2 for a in accel))
        if "accel_z" in columns and float(np.median(norm)) < G_LIKE:
            name = "accel_z" if "accel_x" not in columns else "accel_x, accel_z"
            return (f"{name}: the median specific force is {float(np.median(norm)):.3g}, not ~9.8 m/s^2: in g? "
                    "give scale={'accel_x': 'g', 'accel_z': 'g'} (--scale accel_x=g --scale accel_z=g)")
    gyro = columns.get("gyro")
    if gyro is not None and len(t) > 20:
        ratio = _gyro_over_pitch_rate(t, columns)
        if ratio is not None and abs(math.log(ratio / math.degrees(1.0))) < math.log(DEG_RATIO_BAND):
            peak = int(np.argmax(np.abs(gyro)))
            return (f"gyro: {ratio:.3g}x the pitch rate the log's {'phi' if 'phi' in columns else 'accelerometer'} "
                    f"shows (row {peak} reads {float(gyro[peak]):.4g}): in deg/s, not rad/s? give "
                    "scale={'gyro': 'deg/s'} (--scale gyro=deg/s)")
    return None


def _gyro_over_pitch_rate(t, columns) -> Optional[float]:
    """The gyro's integral over the pitch's change, by least squares over the log (both with
    their means and trends removed: a bias and a slow drift do not count), or None without
    a pitch to compare with or without pitch motion."""
    if "phi" in columns:
        pitch = columns["phi"]
    elif "accel_x" in columns and "accel_z" in columns:
        pitch = np.arctan2(columns["accel_x"], columns["accel_z"])
    else:
        return None
    steps = np.diff(t)
    angle = np.concatenate([[0.0], np.cumsum(0.5 * (columns["gyro"][1:] + columns["gyro"][:-1]) * steps)])
    # Low-passed over ~50 ms: the accelerometer's pitch carries the wheels' acceleration too.
    kernel = _moving_average(t, 0.05)
    a, p = (np.convolve(x, kernel, "valid") for x in (angle, pitch))
    basis = np.vstack([np.ones(len(a)), np.linspace(-1, 1, len(a))]).T
    a = a - basis @ np.linalg.lstsq(basis, a, rcond=None)[0]
    p = p - basis @ np.linalg.lstsq(basis, p, rcond=None)[0]
    if not float(p @ p) > 0 or np.sqrt(np.mean(p ** 2)) < 1e-3:
        return None
    return abs(float(a @ p) / float(p @ p))


def diagnosis(problem, error: Exception) -> str:
    """Why the prediction from the log's own start states blew up, naming the column, the
    row and the likely unit where the log shows it; else the columns to check."""
    log = problem.log
    sign = _reversed_wheel(problem)
    if sign:
        return sign
    checks = ", ".join(f"{name} [{unit}]" for name, unit in CHECKED.items() if getattr(log, name) is not None)
    # A pwm log through a driver other than the rig's blows up as a wrong unit does (a 4 kg
    # robot's 5 ms log through MotorDriver()'s, tests/test_sysid_misfit.py).
    model = (" the motor driver (driver=, the robot file's [driver]) and" if problem.driven else "")
    return (f"the prediction from the start robot and the log's own start states is not finite ({error}): the "
            f"log's columns disagree with the model; check each one's unit and sign: {checks}; and that the "
            f"model is the rig's:{model} the gearhead friction (friction=, --friction-coulomb)")


#: What each column must be in, for the diagnosis.
CHECKED = {"u": "A, lumped current, positive drives forward", "pwm": "counts, +-255, positive drives forward",
           "phi": "rad, positive pitching forward", "gyro": "rad/s, the pitch rate",
           "accel_x": "m/s^2", "accel_z": "m/s^2, +9.8 upright", "theta": "rad, positive forward",
           "enc": "counts, rising as the wheels roll forward under the body"}


def _reversed_wheel(problem) -> Optional[str]:
    """An encoder or wheel column whose sign disagrees with the input: a driven wheel's steady
    speed relative to the body follows the duty (its back-EMF), so the two correlate positively
    over the log, low-passed."""
    log = problem.log
    if log.enc is not None:
        name, rel = "enc", log.enc.astype(float)
    elif log.theta is not None and log.phi is not None:
        name, rel = "theta", log.theta - log.phi
    else:
        return None
    kernel = _moving_average(log.t, 0.1)
    speed = np.convolve(np.gradient(rel, log.t), kernel, "same")
    drive = np.convolve(problem.input, kernel, "same")
    if not (np.std(speed) > 0 and np.std(drive) > 0):
        return None
    corr = float(np.corrcoef(speed, drive)[0, 1])
    if corr > -0.3:
        return None
    row = int(np.argmax(np.abs(speed) * (np.sign(speed) != np.sign(drive))))
    return (f"{name}: the wheels turn against the input (correlation {corr:.2f} between the low-passed "
            f"{'duty' if problem.driven else 'current'} and the wheels' speed relative to the body; row {row}: "
            f"{'pwm' if problem.driven else 'u'} {float(problem.input[row]):.4g}, {name} speed {float(speed[row]):.4g}/s): "
            f"a negative scale or a reversed encoder? {name} must rise as the wheels roll forward")


def _moving_average(t: np.ndarray, seconds: float) -> np.ndarray:
    """The kernel of a moving average over about `seconds` of samples at t's median
    interval; never longer than the log (a tiny interval would size it by the data)."""
    samples = seconds / float(np.median(np.diff(t)))  # inf for a subnormal interval
    k = len(t) if samples >= len(t) else max(1, int(round(samples)))
    return np.ones(k) / k
