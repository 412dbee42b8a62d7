"""Pure-Python (numpy) reference of twip's models, integrator and controllers.

Written independently of the Rust core (not generated from it, never calling it), so
that agreement between the two is evidence that both are right. Slow by design: it is
for parity tests and for reading, not for production runs.
"""
from twip.reference.params import RobotParams
from twip.reference.integrate import rk4_step
from twip.reference.slope import SlopeModel
from twip.reference.planar import PlanarModel
from twip.reference.control import LqrController, SpeedSchedule, lqr_design, simulate
from twip.reference.fuzzy import FuzzyBasis, FuzzyController, Gaussian, GridBasis, Trapezoid, Triangle
from twip.reference.tracking import (Circle, DcMotor, FigureEight, Line, PidTracker, SmcTracker, TrackSample,
                                     Waypoints, simulate_planar, surface_zero_dynamics, tracking_errors)

__all__ = [
    "Circle",
    "DcMotor",
    "FigureEight",
    "Line",
    "PidTracker",
    "SmcTracker",
    "TrackSample",
    "Waypoints",
    "simulate_planar",
    "surface_zero_dynamics",
    "tracking_errors",
    "FuzzyBasis",
    "FuzzyController",
    "Gaussian",
    "GridBasis",
    "Trapezoid",
    "Triangle",
    "LqrController",
    "PlanarModel",
    "RobotParams",
    "SlopeModel",
    "SpeedSchedule",
    "lqr_design",
    "rk4_step",
    "simulate",
]
