"""Robot parameters for the reference models (same fields and units as twip.RobotParams)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

from twip.reference.real import real

# Fields that may be zero (a direct drive has no rotor; friction may be absent).
_NON_NEGATIVE = {"i_motor", "mu_bearing", "mu_ground"}


@dataclass(frozen=True)
class RobotParams:
    m_body: float
    m_wheels: float
    i_body: float
    i_wheels: float
    i_motor: float
    gear_ratio: float
    torque_constant: float
    wheel_radius: float
    com_height: float
    mu_bearing: float
    mu_ground: float
    half_track: float
    i_body_roll: float
    i_body_yaw: float
    i_wheel_diam: float
    g: float

    def __post_init__(self) -> None:
        for f in fields(self):
            value = real(f.name, getattr(self, f.name))
            object.__setattr__(self, f.name, value)
            if not math.isfinite(value):
                raise ValueError(f"invalid {f.name} = {value}: must be finite")
            if f.name in _NON_NEGATIVE:
                if value < 0:
                    raise ValueError(f"invalid {f.name} = {value}: must be >= 0")
            elif value <= 0:
                raise ValueError(f"invalid {f.name} = {value}: must be > 0")

    @classmethod
    def from_dict(cls, d: dict) -> "RobotParams":
        return cls(**{f.name: d[f.name] for f in fields(cls)})

    @classmethod
    def of(cls, p) -> "RobotParams":
        """Converts any object with the fields (e.g. a twip.RobotParams)."""
        return cls(**{f.name: getattr(p, f.name) for f in fields(cls)})

    def to_dict(self) -> dict:
        return asdict(self)

    def replace(self, **changes) -> "RobotParams":
        return replace(self, **changes)
