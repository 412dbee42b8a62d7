"""twip: fast, verified simulation and control of two-wheeled inverted pendulum robots.

The physics and controllers live in Rust (``twip._core``); this package re-exports them
with a numpy-friendly API. ``twip.reference`` is an independent pure-Python implementation
used to cross-check the Rust core.
"""
from twip._core import (
    ArgumentTypeError,
    BalanceBatch,
    Circle,
    ConvergenceError,
    DcMotor,
    Dlpf,
    FigureEight,
    Force,
    Friction,
    FuzzyBasis,
    FuzzyController,
    GradeFeedForward,
    Gaussian,
    Imu,
    InvalidParameterError,
    Line,
    LqrController,
    MotorDriver,
    NoEquilibriumError,
    NonFiniteError,
    NotDetectableError,
    NoStabilizingSolutionError,
    NotStabilizableError,
    OffTerrainError,
    PidTracker,
    PlanarModel,
    Push,
    Realism,
    RobotParams,
    ShapeError,
    SingularMatrixError,
    SlopeModel,
    SmcTracker,
    SpeedSchedule,
    Terrain,
    TiltEstimator,
    TrackBatch,
    Trapezoid,
    Triangle,
    TwipError,
    Waypoints,
    __version__,
    available_kernel_copies,
    c2d,
    care,
    dare,
    dlqr,
    kernel_copy,
    lqr,
    rk4_step,
)
from twip.budget import MemoryBudgetError, set_memory_budget
from twip.kernel_copies import apply_environment as _apply_kernel_copy_environment
from twip.kernel_copies import use_kernel_copy
from twip.robot_file import Robot
from twip.sim import SimResult, simulate
# Identification (scipy) loads on first use: `twip --help` and `import twip` stay quick.
_LAZY = {name: "twip.sysid" for name in ("Fit", "RunLog", "SysidMisfitWarning", "identify")}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'twip' has no attribute {name!r}")
from twip.sweep import Normal, SweepResult, Uniform, montecarlo, wilson_interval
from twip.user_sweep import ControllerFailedError
from twip.plausibility import ImplausibleRobotWarning
from twip.design import Tuning, TuningError, WorstCase, tune, worst_case

__all__ = [
    "ArgumentTypeError",
    "BalanceBatch",
    "TrackBatch",
    "Fit",
    "RunLog",
    "identify",
    "SysidMisfitWarning",
    "Circle",
    "ControllerFailedError",
    "ConvergenceError",
    "DcMotor",
    "Dlpf",
    "FigureEight",
    "Force",
    "Friction",
    "FuzzyBasis",
    "FuzzyController",
    "GradeFeedForward",
    "Gaussian",
    "Imu",
    "ImplausibleRobotWarning",
    "InvalidParameterError",
    "Line",
    "LqrController",
    "MemoryBudgetError",
    "MotorDriver",
    "NoEquilibriumError",
    "NonFiniteError",
    "NotDetectableError",
    "NoStabilizingSolutionError",
    "NotStabilizableError",
    "OffTerrainError",
    "PidTracker",
    "PlanarModel",
    "Push",
    "Realism",
    "Robot",
    "RobotParams",
    "ShapeError",
    "SingularMatrixError",
    "Normal",
    "SimResult",
    "SlopeModel",
    "SmcTracker",
    "SpeedSchedule",
    "Terrain",
    "TiltEstimator",
    "Trapezoid",
    "Triangle",
    "SweepResult",
    "Tuning",
    "TuningError",
    "TwipError",
    "Uniform",
    "Waypoints",
    "WorstCase",
    "__version__",
    "available_kernel_copies",
    "c2d",
    "care",
    "dare",
    "dlqr",
    "kernel_copy",
    "lqr",
    "montecarlo",
    "rk4_step",
    "set_memory_budget",
    "simulate",
    "tune",
    "use_kernel_copy",
    "wilson_interval",
    "worst_case",
]

_apply_kernel_copy_environment()

from twip import interop, scenarios  # noqa: E402  (twip.scenarios.get(...) after `import twip`)
