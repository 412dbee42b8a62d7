"""twip: fast, verified simulation and control of two-wheeled inverted pendulum robots.

The physics and controllers live in Rust (``twip._core``); this package re-exports them
with a numpy-friendly API. ``twip.reference`` is an independent pure-Python implementation
used to cross-check the Rust core.
"""
from twip._core import (
    ConvergenceError,
    InvalidParameterError,
    LqrController,
    NoEquilibriumError,
    NonFiniteError,
    NotDetectableError,
    NotStabilizableError,
    PlanarModel,
    RobotParams,
    ShapeError,
    SingularMatrixError,
    SlopeModel,
    SpeedSchedule,
    TwipError,
    __version__,
    care,
    lqr,
    rk4_step,
)
from twip.sim import SimResult, simulate

__all__ = [
    "ConvergenceError",
    "InvalidParameterError",
    "LqrController",
    "NoEquilibriumError",
    "NonFiniteError",
    "NotDetectableError",
    "NotStabilizableError",
    "PlanarModel",
    "RobotParams",
    "ShapeError",
    "SingularMatrixError",
    "SimResult",
    "SlopeModel",
    "SpeedSchedule",
    "TwipError",
    "__version__",
    "care",
    "lqr",
    "rk4_step",
    "simulate",
]
