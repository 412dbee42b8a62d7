"""Firmware units: the conversions `twip export` writes next to each value, so that a
configuration reads in what the firmware measures and drives (degrees, encoder counts per
loop period, PWM counts, milliseconds) while the C library computes in SI.

Every converted value is written as `FIRMWARE_VALUE * TWIP_FACTOR`, where the factor
turns one firmware unit into SI; the factors are macros of the exported `twip_config.h`,
each with its derivation.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Dict, Optional, Tuple

import numpy as np


@dataclass(frozen=True)
class Factor:
    """A macro `name` = `value` SI units per firmware unit, derived as `how`."""

    name: str
    value: float
    how: str


def factors(encoder_cpr: float, period: float, nm_per_pwm: Optional[float],
            tracker: Optional[Tuple[float, str]] = None) -> Dict[str, Factor]:
    """The conversion macros for an encoder of `encoder_cpr` counts per wheel turn, a loop
    of `period` [s] and a motor whose stall torque is `nm_per_pwm` [N m] per PWM count;
    `tracker` is (N m per PWM count, derivation) of the motor the sliding-mode gains are
    counted on, which may not be the feed-forward driver's."""
    counts_per_rad = encoder_cpr / (2 * math.pi)
    out = [
        Factor("TWIP_RAD_PER_DEG", math.pi / 180, "pi / 180"),
        Factor("TWIP_DEG_PER_RAD", 180 / math.pi, "180 / pi"),
        Factor("TWIP_S_PER_MS", 1e-3, "1 ms = 0.001 s"),
        Factor("TWIP_COUNTS_PER_RAD", counts_per_rad, f"{encoder_cpr:g} counts per wheel turn / (2 pi)"),
        Factor("TWIP_CPP_PER_RAD_S", counts_per_rad * period,
               f"encoder counts per {period * 1e3:g} ms loop at 1 rad/s = TWIP_COUNTS_PER_RAD * {period:g} s"),
    ]
    if nm_per_pwm is not None:
        out.append(Factor("TWIP_NM_PER_PWM", nm_per_pwm,
                          "stall torque of one PWM count at the wheel: gear_ratio k_t (supply / pwm_max) / R"))
    if tracker is not None:
        out.append(Factor("TWIP_TRACKER_NM_PER_PWM", *tracker))
    return {f.name: f for f in out}


#: (path pattern, families, SI unit, firmware unit, factor macro): the values written in
#: firmware units.
RULES: Tuple[Tuple[str, Tuple[str, ...], str, str, str], ...] = (
    (r"period", ("lqr", "fuzzy", "pid", "smc"), "s", "ms", "TWIP_S_PER_MS"),
    (r"slope", ("lqr", "fuzzy"), "rad", "deg", "TWIP_RAD_PER_DEG"),
    (r"gains\[0\]", ("lqr",), "A/rad", "A per deg of pitch", "TWIP_DEG_PER_RAD"),
    (r"gains\[1\]", ("lqr",), "A s/rad", "A per deg/s of pitch rate", "TWIP_DEG_PER_RAD"),
    (r"gains\[2\]", ("lqr",), "A s/rad", "A per encoder count per loop", "TWIP_CPP_PER_RAD_S"),
    (r"gains\[3\]", ("lqr",), "A/rad", "A per encoder count of integrated speed error", "TWIP_COUNTS_PER_RAD"),
    (r"sets\[0\]\[\d\]\.p\[\d\]", ("fuzzy",), "rad", "deg of pitch", "TWIP_RAD_PER_DEG"),
    (r"sets\[1\]\[\d\]\.p\[\d\]", ("fuzzy",), "rad/s", "deg/s of pitch rate", "TWIP_RAD_PER_DEG"),
    (r"(yaw|pitch)_sets\[0\]\[\d\]\.p\[\d\]", ("smc",), "rad", "deg of pitch", "TWIP_RAD_PER_DEG"),
    (r"pitch_sets\[1\]\[\d\]\.p\[\d\]", ("smc",), "rad/s", "deg/s of pitch rate", "TWIP_RAD_PER_DEG"),
    (r"yaw_sets\[1\]\[\d\]\.p\[\d\]", ("smc",), "rad/s", "deg/s of yaw rate", "TWIP_RAD_PER_DEG"),
    # Counted on the tracker's own motor (thesis: k_s3 = -2 counts at 11.1 V).
    (r"k_s3|k_s4|g_y4", ("smc",), "N m", "PWM counts of the tracker's motor", "TWIP_TRACKER_NM_PER_PWM"),
)

#: SI units of the values left in SI, for the comment beside them.
SI_UNITS = {
    "m_body": "kg", "m_wheels": "kg", "i_body": "kg m^2", "i_wheels": "kg m^2", "i_motor": "kg m^2",
    "torque_constant": "N m/A", "wheel_radius": "m", "com_height": "m", "mu_bearing": "N m s/rad",
    "mu_ground": "N m s/rad", "half_track": "m", "i_body_roll": "kg m^2", "i_body_yaw": "kg m^2",
    "i_wheel_diam": "kg m^2", "g": "m/s^2", "resistance": "ohm", "k_t": "N m/A", "friction": "N m s/rad",
    "supply": "V", "pwm_max": "counts", "coulomb": "N m", "breakaway": "N m", "stribeck_speed": "rad/s",
    "viscous": "N m s/rad", "smoothing_speed": "rad/s", "stick_speed": "rad/s", "k1": "1/s", "k2": "1/s", "k3": "1/s",
    "width_eta": "rad/s", "wheel_radius_pid": "m", "time_constant": "s", "command_per_amp": "command/A",
}


def rule_for(family: str, path: str):
    for pattern, families, si, unit, factor in RULES:
        if family in families and re.fullmatch(pattern, path):
            return si, unit, factor
    return None


def _digits(v: np.float32) -> str:
    """The fewest decimal digits that read back as the f32 `v` (numpy's Dragon4), as the
    compiler reads a literal: 2.0, 0.1, 1e-05."""
    a = abs(float(v))
    if a == 0 or 1e-4 <= a < 1e16:
        return np.format_float_positional(v, unique=True, trim="0")
    return np.format_float_scientific(v, unique=True, trim="-")


def c_float(value: float) -> str:
    """A C float literal that reads back as the same f32 (±INFINITY for infinities), in the
    fewest digits that do (a 2 is `2.0f`, not `2.00000000f`)."""
    with np.errstate(over="ignore"):
        v = np.float32(value)
    if np.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    if np.isnan(v):
        raise ValueError("a configuration value is NaN")
    return _digits(v) + "f"


def _significant(text: str) -> int:
    """The significant digits of a literal of `_digits`: 3 of -0.00125, 1 of 5.0."""
    mantissa = text.lstrip("-").split("e")[0].replace(".", "").lstrip("0").rstrip("0")
    return max(len(mantissa), 1)


#: A firmware value of at most this many significant digits reads as chosen (5 ms, -2
#: counts, 0.3 deg): it is written as such, or in SI, never as the 4.9999995 next to it.
ROUND_DIGITS = 6


def in_unit(value: float, factor: float) -> Optional[np.float32]:
    """The f32 `s` whose C expression `s * FACTOR` (both f32: the literal and the macro
    `c_float(factor)`) is the f32 of `value` bit for bit, in the fewest digits that do:
    -2 counts is `-2.0f`, not the -1.99999988 that f32(value) / factor rounds to. None when
    no f32 near the quotient hits it, or when only one longer than a round firmware value
    does (5 ms: 5 * f32(0.001) is an ulp off f32(0.005), and 4.9999995 would read as a
    mistake); the value is then written in SI. The product of two f32 is exact in f64, so
    its rounding to f32 is C's float multiply."""
    v, f = np.float32(value), np.float32(factor)
    if v == 0:
        return v  # 0 (or -0) times any factor is itself
    guess = np.float32(float(v) / float(f))
    if not (np.isfinite(guess) and guess != 0):
        return None
    near, up, down = [guess], guess, guess
    for _ in range(4):  # the quotient's rounding is within an ulp or two of an exact one
        up, down = np.nextafter(up, np.float32(np.inf)), np.nextafter(down, np.float32(-np.inf))
        near += [up, down]
    product = {float(s): np.float32(float(s) * float(f)) for s in near}
    ulp = float(np.spacing(abs(v)))
    natural = min((_significant(_digits(s)) for s in near if abs(float(product[float(s)]) - float(v)) <= ulp),
                  default=None)
    exact = sorted((s for s in near if product[float(s)] == v), key=lambda s: _significant(_digits(s)))
    if not exact:
        return None
    best = exact[0]
    if natural is not None and natural <= ROUND_DIGITS and _significant(_digits(best)) > natural:
        return None
    return best


def scalar(family: str, path: str, value: float, table: Dict[str, Factor], firmware: bool) -> Tuple[str, str]:
    """(C expression, comment) of the float at `path`."""
    rule = rule_for(family, path)
    if firmware and rule is not None and rule[2] in table and math.isfinite(value):
        _, unit, name = rule
        shown = in_unit(value, table[name].value)
        if shown is not None:
            return f"{_digits(shown)}f * {name}", f"{float(shown):.6g} {unit}"
        # No natural f32 times the factor is this value: SI, so that the library gets the f32
        # the Rust side has, the firmware value beside it.
        return c_float(value), f"SI: {rule[0]} (= {value / table[name].value:.6g} {unit})"
    leaf = re.sub(r"\[\d+\]", "", path.rsplit(".", 1)[-1])
    unit = rule[0] if rule is not None else SI_UNITS.get(leaf, "")
    return c_float(value), (f"SI: {unit}" if unit else "")
