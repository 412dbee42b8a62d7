# Type stub of the native module twip._core (hand-written; tests/test_stub.py checks it
# against the compiled module with mypy.stubtest).
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

_ArrayLike = npt.ArrayLike
_F64 = npt.NDArray[np.float64]

__all__ = [
    "Circle",
    "ConvergenceError",
    "DcMotor",
    "Dlpf",
    "FigureEight",
    "Force",
    "FuzzyBasis",
    "FuzzyController",
    "Gaussian",
    "Imu",
    "InvalidParameterError",
    "Line",
    "LqrController",
    "MotorDriver",
    "NoEquilibriumError",
    "NonFiniteError",
    "NotDetectableError",
    "NotStabilizableError",
    "PidTracker",
    "PlanarModel",
    "Push",
    "Realism",
    "RobotParams",
    "ShapeError",
    "SingularMatrixError",
    "SlopeModel",
    "SmcTracker",
    "SpeedSchedule",
    "TiltEstimator",
    "Trapezoid",
    "Triangle",
    "TwipError",
    "Waypoints",
    "__version__",
    "care",
    "lqr",
    "rk4_step",
    "simulate_planar_raw",
    "simulate_raw",
    "sweep_draw",
    "sweep_noise_seed",
    "controller_fingerprint",
    "sweep_planar_draw",
    "sweep_planar_raw",
    "sweep_raw",
]

__version__: str

class TwipError(ValueError): ...
class InvalidParameterError(TwipError): ...
class ShapeError(TwipError): ...
class NonFiniteError(TwipError): ...
class NoEquilibriumError(TwipError): ...
class SingularMatrixError(TwipError): ...
class NotStabilizableError(TwipError): ...
class NotDetectableError(TwipError): ...
class ConvergenceError(TwipError): ...

@final
class RobotParams:
    fields: list[str]
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
    def __new__(cls, **fields: float) -> RobotParams: ...
    @staticmethod
    def balanbot() -> RobotParams: ...
    def replace(self, **changes: float) -> RobotParams: ...
    def to_dict(self) -> dict[str, float]: ...
    @staticmethod
    def from_dict(d: Mapping[str, float]) -> RobotParams: ...

@final
class SlopeModel:
    def __new__(cls, params: RobotParams, slope: float = 0.0) -> SlopeModel: ...
    @property
    def params(self) -> RobotParams: ...
    @property
    def slope(self) -> float: ...
    def deriv(self, x: _ArrayLike, u: Union[float, _ArrayLike]) -> _F64: ...
    def energy(self, x: _ArrayLike) -> float: ...
    def linearize(self, x0: _ArrayLike, u0: float = 0.0) -> Tuple[_F64, _F64]: ...
    def linearize_thesis(self) -> Tuple[_F64, _F64, _F64]: ...
    def equilibrium(self, theta_dot_ref: float, linear: bool = False) -> Tuple[_F64, float]: ...
    def mass_matrix(self, phi: float) -> _F64: ...

@final
class PlanarModel:
    def __new__(cls, params: RobotParams) -> PlanarModel: ...
    @property
    def params(self) -> RobotParams: ...
    def deriv(self, x: _ArrayLike, u: _ArrayLike) -> _F64: ...
    def energy(self, x: _ArrayLike) -> float: ...
    def mass_matrix(self, phi: float) -> _F64: ...

def rk4_step(model: Union[SlopeModel, PlanarModel], x: _ArrayLike, u: Union[float, _ArrayLike], dt: float) -> _F64: ...
def care(A: _ArrayLike, B: _ArrayLike, Q: _ArrayLike, R: Union[float, _ArrayLike]) -> _F64: ...
def lqr(A: _ArrayLike, B: _ArrayLike, Q: _ArrayLike, R: Union[float, _ArrayLike]) -> Tuple[_F64, _F64, npt.NDArray[np.complex128]]: ...

@final
class SpeedSchedule:
    def __new__(cls, legs: Sequence[Tuple[float, float, float]]) -> SpeedSchedule: ...
    @staticmethod
    def constant(speed: float) -> SpeedSchedule: ...
    @staticmethod
    def go_and_return(distance: float, speed: float, wheel_radius: float, hold: float = 0.0) -> SpeedSchedule: ...
    @property
    def legs(self) -> list[Tuple[float, float, float]]: ...
    def sample(self, t: float) -> Tuple[float, float]: ...

@final
class LqrController:
    def __new__(cls, model: SlopeModel, gains: _ArrayLike, point: str = "operating", period: float = 0.005) -> LqrController: ...
    @staticmethod
    def design(model: SlopeModel, theta_dot_ref: float, Q: _ArrayLike, R: float, point: str = "operating",
               period: float = 0.005) -> LqrController: ...
    @property
    def gains(self) -> _F64: ...
    @property
    def period(self) -> float: ...
    @property
    def point(self) -> str: ...
    @property
    def model(self) -> SlopeModel: ...
    @property
    def design_info(self) -> Optional[dict[str, Any]]: ...
    def steady_state(self, theta_dot_ref: float) -> Tuple[float, float]: ...

@final
class Trapezoid:
    def __new__(cls, a: float, b: float, c: float, d: float) -> Trapezoid: ...
    @property
    def breakpoints(self) -> Tuple[float, float, float, float]: ...
    def eval(self, x: Any) -> Any: ...
    def __call__(self, x: Any) -> Any: ...

@final
class Triangle:
    def __new__(cls, a: float, b: float, c: float) -> Triangle: ...
    @property
    def breakpoints(self) -> Tuple[float, float, float]: ...
    def eval(self, x: Any) -> Any: ...
    def __call__(self, x: Any) -> Any: ...

@final
class Gaussian:
    def __new__(cls, mean: float, sigma: float) -> Gaussian: ...
    @property
    def mean(self) -> float: ...
    @property
    def sigma(self) -> float: ...
    def eval(self, x: Any) -> Any: ...
    def __call__(self, x: Any) -> Any: ...

@final
class FuzzyBasis:
    def __new__(cls, sets_per_input: Sequence[Sequence[Any]]) -> FuzzyBasis: ...
    @staticmethod
    def default() -> FuzzyBasis: ...
    @property
    def n_inputs(self) -> int: ...
    @property
    def n_rules(self) -> int: ...
    @property
    def sets(self) -> Any: ...
    def eval(self, x: _ArrayLike) -> _F64: ...

@final
class FuzzyController:
    def __new__(cls, model: SlopeModel, k1: float, k2: float, kp: float, kd: float, gamma: float = ...,
                sigma: float = ..., ki: float = 0.0, adapt: bool = True, sets: Any = None, period: float = 0.005,
                s0: Optional[_ArrayLike] = None) -> FuzzyController: ...
    @staticmethod
    def thesis_slope(model: SlopeModel, gamma: float = ..., sigma: float = ..., ki: float = 0.0, adapt: bool = True,
                     sets: Any = None, period: float = 0.005, s0: Optional[_ArrayLike] = None) -> FuzzyController: ...
    @staticmethod
    def thesis_flat(model: SlopeModel, gamma: float = ..., sigma: float = ..., ki: float = 0.0, adapt: bool = True,
                    sets: Any = None, period: float = 0.005, s0: Optional[_ArrayLike] = None) -> FuzzyController: ...
    adapt: bool
    basis: FuzzyBasis
    gamma: float
    internal_names: list[str]
    k1: float
    k2: float
    kd: float
    ki: float
    kp: float
    model: SlopeModel
    period: float
    s0: _F64
    sigma: float
    def g1(self, phi: float) -> float: ...
    def steady_pitch(self, theta_dot_ref: float) -> float: ...

@final
class Circle:
    def __new__(cls, radius: float, speed: float, centre: Optional[Tuple[float, float]] = None,
                direction: Any = None, phase: Optional[float] = None) -> Circle: ...
    centre: Tuple[float, float]
    direction: float
    period: float
    phase: float
    radius: float
    speed: float
    def sample(self, t: float) -> dict[str, float]: ...
    def distance(self, x: float, y: float) -> float: ...

@final
class Line:
    def __new__(cls, speed: float, heading: float = 0.0, start: Tuple[float, float] = ...) -> Line: ...
    heading: float
    speed: float
    start: Tuple[float, float]
    def sample(self, t: float) -> dict[str, float]: ...
    def distance(self, x: float, y: float) -> float: ...

@final
class FigureEight:
    def __new__(cls, half_width: float, period: float, centre: Tuple[float, float] = ...) -> FigureEight: ...
    centre: Tuple[float, float]
    half_width: float
    period: float
    def sample(self, t: float) -> dict[str, float]: ...
    def distance(self, x: float, y: float) -> float: ...

@final
class Waypoints:
    def __new__(cls, points: Sequence[Tuple[float, float]], speed: float, corner_radius: float = 0.0) -> Waypoints: ...
    corner_radius: float
    duration: float
    length: float
    points: list[Tuple[float, float]]
    speed: float
    def sample(self, t: float) -> dict[str, float]: ...
    def distance(self, x: float, y: float) -> float: ...

@final
class DcMotor:
    def __new__(cls, resistance: float, k_t: float, gear_ratio: float, friction: float = 0.0, supply: float = 11.1,
                pwm_max: float = 255.0) -> DcMotor: ...
    @staticmethod
    def gb37y3530(supply: float = 11.1) -> DcMotor: ...
    @staticmethod
    def from_data_sheet(rated_voltage: float, no_load_rpm: float, no_load_current: float, stall_current: float,
                        gear_ratio: float, supply: float = 11.1) -> DcMotor: ...
    friction: float
    gear_ratio: float
    k_t: float
    pwm_max: float
    resistance: float
    supply: float
    def current(self, voltage: float, relative_speed: float) -> float: ...
    def friction_at_wheel(self) -> float: ...
    def no_load_speed(self) -> float: ...
    def pwm_voltage(self, pwm: float) -> float: ...
    def torque(self, voltage: float, relative_speed: float) -> float: ...
    def torque_from_pwm(self, pwm: float, relative_speed: float) -> float: ...
    def torque_limits(self, relative_speed: float) -> Tuple[float, float]: ...
    def torque_per_count(self) -> float: ...
    def voltage_for_torque(self, torque: float, relative_speed: float) -> float: ...

@final
class PidTracker:
    def __new__(cls, params: RobotParams, gains: Any = None, units: Any = None, motor: Optional[DcMotor] = None,
                period: float = 0.005) -> PidTracker: ...
    @staticmethod
    def table_4_1(params: Optional[RobotParams] = None, motor: Optional[DcMotor] = None,
                  period: float = 0.005) -> PidTracker: ...
    gains: Any
    motor: DcMotor
    period: float
    units: Any

@final
class SmcTracker:
    def __new__(cls, model: PlanarModel, fuzzy: bool = False, boundary_layer: Any = None, gains: Any = None,
                torque_unit: Any = None, pitch: str = "backward", guards: Any = ..., gamma: Any = ...,
                leakage: float = 0.0, pitch_offset: bool = True, motor: Optional[DcMotor] = None,
                motor_limits: bool = True, period: float = 0.005) -> SmcTracker: ...
    @staticmethod
    def thesis_gains(torque_unit: Any = None) -> Any: ...
    boundary_layer: Any
    fuzzy: bool
    gains: Any
    model: PlanarModel
    period: float
    pitch: str
    weights: Any
    def input_gains(self, phi: float) -> Any: ...
    def steady_pitch(self, v: float, omega: float) -> float: ...
    def surface_gain(self, phi: float) -> float: ...

@final
class Dlpf:
    def __new__(cls, bandwidth_hz: float, delay: float, sample_rate: float = 1000.0) -> Dlpf: ...
    @staticmethod
    def mpu6050(dlpf_hz: float, sensor: str = "gyro", sample_rate: float = 1000.0) -> Dlpf: ...
    @staticmethod
    def table() -> Any: ...
    bandwidth_hz: float
    delay: float
    natural_frequency: float
    pure_delay: float
    sample_rate: float
    zeta: float
    def filter(self, x: _ArrayLike) -> _F64: ...

@final
class Imu:
    def __new__(cls, *, dlpf_hz: float = 42.0, height: float = 0.12, gyro_noise: float = ..., accel_noise: float = ...,
                gyro_bias: float = 0.0, gyro_bias_walk: float = 0.0, accel_bias: Any = ..., gyro_range_dps: float = 250.0,
                accel_range_g: float = 2.0, quantise: bool = True, sample_rate: float = 1000.0) -> Imu: ...
    @staticmethod
    def data_sheet() -> Imu: ...
    @staticmethod
    def thesis_like() -> Imu: ...
    accel_bias: Any
    accel_noise: float
    accel_range_g: float
    dlpf_cfg: int
    dlpf_hz: float
    gyro_bias: float
    gyro_bias_walk: float
    gyro_noise: float
    gyro_range_dps: float
    height: float
    quantise: bool
    sample_rate: float
    def dlpf(self, sensor: str = "gyro") -> Dlpf: ...
    def replace(self, **changes: Any) -> Imu: ...
    def to_dict(self) -> dict[str, Any]: ...

@final
class TiltEstimator:
    @staticmethod
    def complementary(time_constant: float = 1.0) -> TiltEstimator: ...
    @staticmethod
    def kalman(q_angle: float = 1e-3, q_bias: float = 1e-6, r_angle: float = 0.2) -> TiltEstimator: ...
    kind: str
    parameters: Any
    def filter(self, accel_x: _ArrayLike, accel_z: _ArrayLike, gyro: _ArrayLike, dt: float) -> Any: ...

@final
class MotorDriver:
    def __new__(cls, *, battery: float = 11.1, bridge_drop: float = 0.0, resistance: float = ..., inductance: float = 0.0,
                efficiency: float = 1.0, current_limit: Optional[float] = None,
                assumed_battery: Optional[float] = None) -> MotorDriver: ...
    @staticmethod
    def data_sheet() -> MotorDriver: ...
    @staticmethod
    def thesis_like() -> MotorDriver: ...
    assumed_battery: Optional[float]
    battery: float
    bridge_drop: float
    current_limit: Optional[float]
    efficiency: float
    inductance: float
    resistance: float
    def current(self, voltage: float, wheel_speed: float, params: Optional[RobotParams] = None) -> float: ...
    def duty(self, lumped_current: float, wheel_speed: float, params: Optional[RobotParams] = None) -> float: ...
    def replace(self, **changes: Any) -> MotorDriver: ...
    def to_dict(self) -> dict[str, Any]: ...
    def wheel_torque(self, voltage: float, wheel_speed: float, params: Optional[RobotParams] = None) -> float: ...

@final
class Push:
    def __new__(cls, t: float, impulse: float, height: Optional[float] = None) -> Push: ...
    height: Optional[float]
    impulse: float
    t: float

@final
class Force:
    def __new__(cls, horizontal: float = 0.0, vertical: float = 0.0, height: Optional[float] = None) -> Force: ...
    height: Optional[float]
    horizontal: float
    vertical: float

@final
class Realism:
    def __new__(cls, *, imu: Optional[Imu] = None, estimator: Any = None, encoder_cpr: Optional[float] = None,
                motor: Optional[MotorDriver] = None, delay: bool = False, control_period: Optional[float] = None,
                pushes: Optional[Sequence[Push]] = None, force: Optional[Force] = None, slope_profile: Any = None,
                seed: Optional[int] = None, stream: Optional[int] = None) -> Realism: ...
    @staticmethod
    def ideal() -> Realism: ...
    @staticmethod
    def thesis_like(*, seed: int = 0, stream: int = 0) -> Realism: ...
    control_period: Optional[float]
    delay: bool
    encoder_cpr: Optional[float]
    estimator: Any
    force: Optional[Force]
    imu: Optional[Imu]
    is_ideal: bool
    motor: Optional[MotorDriver]
    pushes: list[Push]
    seed: int
    slope_profile: Any
    stream: int
    def replace(self, **changes: Any) -> Realism: ...
    def to_dict(self) -> dict[str, Any]: ...

def simulate_raw(model: SlopeModel, controller: Any, x0: _ArrayLike, t_final: float, dt: float, reference: SpeedSchedule,
                 control_period: Optional[float] = None, fall_limit: Optional[float] = None, record_every: int = 1,
                 realism: Optional[Realism] = None) -> dict[str, Any]: ...
def simulate_planar_raw(model: PlanarModel, controller: Any, x0: _ArrayLike, t_final: float, dt: float, reference: Any,
                        control_period: Optional[float] = None, fall_limit: Optional[float] = None,
                        record_every: int = 1, settle: Optional[float] = None) -> dict[str, Any]: ...
def sweep_raw(model: SlopeModel, controller: Any, x0: _ArrayLike, t_final: float, dt: float, reference: SpeedSchedule,
              perturbations: Sequence[Tuple[str, int, str, float, float, float, float]], seed: int, start: int,
              count: int, control_period: Optional[float] = None, fall_limit: Optional[float] = None, threads: int = 0,
              progress: Optional[Callable[[int], Any]] = None, realism: Optional[Realism] = None) -> dict[str, Any]: ...
def sweep_noise_seed(seed: int) -> int: ...
def controller_fingerprint(controller: Any) -> str: ...
def sweep_draw(model: SlopeModel, x0: _ArrayLike, perturbations: Sequence[Tuple[str, int, str, float, float, float, float]],
               seed: int, index: int) -> Tuple[dict[str, float], float, _F64]: ...
def sweep_planar_raw(model: PlanarModel, controller: Any, x0: _ArrayLike, t_final: float, dt: float, reference: Any,
                     perturbations: Sequence[Tuple[str, int, str, float, float, float, float]], seed: int, start: int,
                     count: int, control_period: Optional[float] = None, fall_limit: Optional[float] = None,
                     settle: Optional[float] = None, threads: int = 0,
                     progress: Optional[Callable[[int], Any]] = None) -> dict[str, Any]: ...
def sweep_planar_draw(model: PlanarModel, x0: _ArrayLike,
                      perturbations: Sequence[Tuple[str, int, str, float, float, float, float]], seed: int,
                      index: int) -> Tuple[dict[str, float], _F64]: ...
