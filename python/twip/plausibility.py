"""Units sanity for a robot's parameters: a warning when a length, mass or inertia is far
outside what a tabletop two-wheeled robot has, the sign of a value entered in another unit
(com_height = 120: millimetres, in a file of metres). The model takes any positive value,
so such a robot runs and "completes"; the warning says which value and what it likely is.
"""
from __future__ import annotations

import math
import warnings
from typing import Dict, List, Tuple


class ImplausibleRobotWarning(UserWarning):
    """A RobotParams value outside the range of a tabletop robot (likely another unit)."""


#: (low, high) of a tabletop robot, SI: the Balanbot's values are well inside, a value
#: entered in mm, g or g cm^2 is outside.
LENGTHS: Dict[str, Tuple[float, float]] = {
    "wheel_radius": (0.005, 0.5),
    "com_height": (0.005, 2.0),
    "half_track": (0.005, 1.0),
}
MASSES: Dict[str, Tuple[float, float]] = {"m_body": (0.01, 50.0), "m_wheels": (0.001, 20.0)}
#: Each inertia's radius of gyration sqrt(I / m) [m] against the mass it belongs to.
INERTIAS: Dict[str, str] = {
    "i_body": "m_body", "i_body_roll": "m_body", "i_body_yaw": "m_body",
    "i_wheels": "m_wheels", "i_wheel_diam": "m_wheels",
}
GYRATION = (0.001, 2.0)


def implausible(params) -> List[str]:
    """What is implausible in `params` (a RobotParams), one sentence per value."""
    p = params.to_dict()
    out = []
    for table, unit, hint in ((LENGTHS, "m", "millimetres or centimetres?"), (MASSES, "kg", "grams?")):
        for name, (low, high) in table.items():
            if not low <= p[name] <= high:
                out.append(f"{name} = {p[name]!r} {unit} is outside {low:g}..{high:g} {unit} ({hint})")
    for name, mass in INERTIAS.items():
        if p[name] > 0 and p[mass] > 0:
            radius = math.sqrt(p[name] / p[mass])
            low, high = GYRATION
            if not low <= radius <= high:
                out.append(f"{name} = {p[name]!r} kg m^2 gives a radius of gyration of {radius:.3g} m with "
                           f"{mass} = {p[mass]!r} kg, outside {low:g}..{high:g} m (g cm^2 or kg mm^2?)")
    return out


def warn_if_implausible(params, where: str = "robot", stacklevel: int = 3) -> None:
    """Warns (ImplausibleRobotWarning) when `params` is implausible for a tabletop robot."""
    found = implausible(params)
    if found:
        warnings.warn(f"{where}: implausible for a tabletop robot (SI units: m, kg, kg m^2): " + "; ".join(found),
                      ImplausibleRobotWarning, stacklevel=stacklevel)
