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


def c_float(value: float) -> str:
    """A C float literal that reads back as the same f32 (±INFINITY for infinities)."""
    v = float(np.float32(value))
    if math.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    if math.isnan(v):
        raise ValueError("a configuration value is NaN")
    text = f"{v:.9g}"
    if not any(ch in text for ch in ".en"):
        text += ".0"
    return text + "f"


def scalar(family: str, path: str, value: float, table: Dict[str, Factor], firmware: bool) -> Tuple[str, str]:
    """(C expression, comment) of the float at `path`."""
    rule = rule_for(family, path)
    if firmware and rule is not None and rule[2] in table and math.isfinite(value):
        _, unit, name = rule
        shown = value / table[name].value
        return f"{c_float(shown)} * {name}", f"{shown:.6g} {unit}"
    leaf = re.sub(r"\[\d+\]", "", path.rsplit(".", 1)[-1])
    unit = rule[0] if rule is not None else SI_UNITS.get(leaf, "")
    return c_float(value), (f"SI: {unit}" if unit else "")
