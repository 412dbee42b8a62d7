"""twip: fast, verified simulation and control of two-wheeled inverted pendulum robots.

The physics and controllers live in Rust (``twip._core``); this package re-exports them
with a numpy-friendly API. ``twip.reference`` is an independent pure-Python implementation
used to cross-check the Rust core.
"""
from twip._core import (
    ConvergenceError,
    InvalidParameterError,
    NoEquilibriumError,
    NonFiniteError,
    NotDetectableError,
    NotStabilizableError,
    PlanarModel,
    RobotParams,
    ShapeError,
    SingularMatrixError,
    SlopeModel,
    TwipError,
    __version__,
    rk4_step,
)

__all__ = [
    "ConvergenceError",
    "InvalidParameterError",
    "NoEquilibriumError",
    "NonFiniteError",
    "NotDetectableError",
    "NotStabilizableError",
    "PlanarModel",
    "RobotParams",
    "ShapeError",
    "SingularMatrixError",
    "SlopeModel",
    "TwipError",
    "__version__",
    "rk4_step",
]
