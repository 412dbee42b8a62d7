# Type stub of the native module twip._core (hand-written; tests/test_stub.py checks it
# against the compiled module with mypy.stubtest).
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

_ArrayLike = npt.ArrayLike
_F64 = npt.NDArray[np.float64]

__all__ = [
    "ArgumentTypeError",
    "BalanceBatch",
    "Circle",
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
    "InvalidParameterError",
    "Line",
    "LqrController",
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
    "RobotParams",
    "ShapeError",
    "SingularMatrixError",
    "SlopeModel",
    "SmcTracker",
    "Terrain",
    "SpeedSchedule",
    "TiltEstimator",
    "TrackBatch",
    "Trapezoid",
    "Triangle",
    "TwipError",
    "Waypoints",
    "__version__",
    "c2d",
    "care",
    "dare",
    "dlqr",
    "lqr",
    "rk4_step",
    "simulate_planar_raw",
    "simulate_raw",
    "sweep_draw",
    "sweep_noise_seed",
    "check_sweep_model",
    "sweep_kernel",
    "kernel_copy",
    "available_kernel_copies",
    "use_kernel_copy",
    "DEFAULT_FALL_LIMIT",
    "MAX_THREADS",
    "NORMAL_REACH",
    "ffi_record",
    "sysid_shoot",
    "ffi_firmware",
    "FFI_HEADER",
    "FFI_SOURCE_DIR",
    "controller_fingerprint",
    "sweep_planar_draw",
    "sweep_planar_raw",
    "sweep_raw",
]

__version__: str

class ArgumentTypeError(TypeError):
    """An argument of the wrong type; the message names the argument ("x: expected a real number...")."""
    def add_note(self, note: str) -> None: ...
class TwipError(ValueError):
    """Base of every twip error (a ValueError)."""
class InvalidParameterError(TwipError):
    """A named parameter has an invalid value."""
class ShapeError(TwipError):
    """An array argument has the wrong shape."""
class NonFiniteError(TwipError):
    """A state, input or matrix holds NaN or inf."""
class NoEquilibriumError(TwipError):
    """The requested operating point does not exist."""
class SingularMatrixError(TwipError):
    """A matrix that must be invertible is singular."""
class NotStabilizableError(TwipError):
    """The pair (A, B) is not stabilizable."""
class NotDetectableError(TwipError):
    """The pair (A, Q) is not detectable."""
class NoStabilizingSolutionError(TwipError):
    """The Riccati equation has no stabilising solution (Hamiltonian eigenvalues on the imaginary axis)."""
class ConvergenceError(TwipError):
    """An iterative method hit its iteration cap."""
class OffTerrainError(TwipError):
    """A point is off the terrain (outside its grid): there is no ground to extrapolate."""

@final
class RobotParams:
    """Physical parameters of one robot, SI units (see docs/parameters.md)."""
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
    def balanbot() -> RobotParams:
        """The thesis's robot (Balanbot with GB37Y3530-12V-251R motors)."""
    def replace(self, **changes: float) -> RobotParams:
        """A copy with some fields changed, validated."""
    @classmethod
    def from_file(cls, path: Any) -> RobotParams:
        """The [robot] table of a robot file (TOML; see `twip.robot_file`)."""
    def to_file(self, path: Any) -> None:
        """Writes a robot file: every field with its unit and thesis symbol in a comment."""
    def to_dict(self) -> dict[str, float]: ...
    @staticmethod
    def from_dict(d: Mapping[str, float]) -> RobotParams: ...

@final
class Friction:
    """One wheel's gearhead friction (N m, rad/s): Coulomb + viscous + Stribeck, the sign
    regularised by tanh(w / smoothing_speed); `breakaway` is the static (peak) torque.
    `stick_speed` > 0 adds a stick state: a wheel slower than it relative to the body is
    held while the torque that would move it stays below `breakaway`.
    """
    def __new__(cls, coulomb: float, breakaway: Optional[float] = None, stribeck_speed: float = 1.0,
                viscous: float = 0.0, smoothing_speed: float = 0.1, stick_speed: float = 0.0) -> Friction: ...
    @staticmethod
    def gb37() -> Friction:
        """The GB37 data sheet's no-load torque eta k_t I0 = 0.152 N m read as Coulomb
        friction; breakaway 1.25x; Stribeck speed 1 rad/s; smoothing 0.1 rad/s.
        """
    @staticmethod
    def gb37_beside(viscous_per_wheel: float) -> Friction:
        """`gb37()` beside a viscous bearing of `viscous_per_wheel` [N m s/rad]: the Coulomb
        part is what the viscous one leaves of the no-load torque at the no-load speed
        (0.0117 N m beside `RobotParams.balanbot()`'s mu_bearing / 2).
        """
    @property
    def coulomb(self) -> float: ...
    @property
    def breakaway(self) -> float: ...
    @property
    def stribeck_speed(self) -> float: ...
    @property
    def viscous(self) -> float: ...
    @property
    def smoothing_speed(self) -> float: ...
    @property
    def stick_speed(self) -> float: ...
    def with_stick(self, stick_speed: float) -> Friction:
        """This friction with a stick band of half-width `stick_speed` [rad/s]
        (0.1 rad/s suits 1 ms steps, see docs/parameters.md; 0: none).
        """
    def torque(self, w: float) -> float:
        """The slip law's torque [N m] at the wheel's speed relative to the body `w` [rad/s]
        (with a stick band, a wheel inside it is held by whatever torque that needs).
        """
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Friction:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> Friction:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class SlopeModel:
    """The 2-DOF model on a slope; state [phi, phi_dot, theta, theta_dot], input current u [A]."""
    def __new__(cls, params: RobotParams, slope: float = 0.0, friction: Optional[Friction] = None) -> SlopeModel: ...
    @property
    def friction(self) -> Optional[Friction]:
        """The gearhead friction per wheel, or None (the thesis's model)."""
    @property
    def params(self) -> RobotParams: ...
    @property
    def slope(self) -> float:
        """Slope angle alpha [rad], positive when forward travel climbs."""
    def deriv(self, x: _ArrayLike, u: Union[float, _ArrayLike]) -> _F64: ...
    def energy(self, x: _ArrayLike) -> float: ...
    def linearize(self, x0: _ArrayLike, u0: float = 0.0) -> Tuple[_F64, _F64]:
        """Exact Jacobians (A 4x4, B 4x1) at the operating point (x0, u0). With a friction's
        stick band: those of the slip law that acts outside the band, inside it too (the held
        wheels there take no input).
        """
    def linearize_thesis(self) -> Tuple[_F64, _F64, _F64]:
        """The thesis's linear model (4.6)-(4.10) on [phi, phi_dot, theta_dot]: (A 3x3, B 3x1, D 3x1)."""
    def equilibrium(self, theta_dot_ref: float, linear: bool = False) -> Tuple[_F64, float]:
        """Steady state at wheel speed theta_dot_ref: (x_s, u_s), x_s = [phi_s, 0, 0, theta_dot_ref].
        `linear=True` uses the thesis's linear model, (4.12)-(4.13).
        """
    def mass_matrix(self, phi: float) -> _F64: ...

@final
class Terrain:
    """A ground shape: a height z = h(x, y) [m] and its gradient. Build one with
    `Terrain.plane`, `Terrain.ramp`, `Terrain.bumps` or `Terrain.grid`.
    """
    @staticmethod
    def plane(slope: float, uphill_heading: float = 0.0) -> Terrain:
        """A plane rising at `slope` [rad, in [0, pi/2)] towards `uphill_heading` [rad from +x]."""
    @staticmethod
    def ramp(slope: float, uphill_heading: float = 0.0, start: float = 0.0, blend: float = 0.1) -> Terrain:
        """Level ground up to the line `start` [m] from the origin along `uphill_heading`, then a
        plane of `slope`; the grade rises smoothly (cubic smoothstep) over `blend` [m] past
        the line (0: a kink).
        """
    @staticmethod
    def bumps(height: float, wavelength: float) -> Terrain:
        """An egg-crate of bumps: h = (height/2) sin(2 pi x / wavelength) sin(2 pi y / wavelength),
        `height` [m] from hollow to crest, level at the origin.
        """
    @staticmethod
    def grid(x: _ArrayLike, y: _ArrayLike, z: _ArrayLike) -> Terrain:
        """A height map: `z[i, j]` [m] at (`x[i]`, `y[j]`), x and y strictly increasing (at least
        2 points each), heights finite; a C1 bicubic Hermite interpolant between the nodes.
        Off the grid there is no ground: the model raises OffTerrainError and a run ends
        with the outcome "off_terrain".
        """
    def local(self, x: float, y: float) -> Tuple[float, float, float]:
        """(height [m], dh/dx, dh/dy) at (x, y); OffTerrainError off a grid."""
    def contains(self, x: float, y: float) -> bool:
        """Whether (x, y) is on the terrain (always, except off a grid)."""
    @property
    def slope(self) -> Optional[float]:
        """The plane's slope [rad] (a plane or a ramp; None for bumps and a grid): a sweep's
        `slope` axis draws it.
        """
    @property
    def uphill_heading(self) -> Optional[float]:
        """The plane's uphill heading [rad from +x] (a plane or a ramp; None for bumps and a
        grid): a sweep's `heading` axis draws it.
        """

@final
class PlanarModel:
    """The 3-DOF planar model; state [x, y, psi, phi, phi_dot, v, omega], input [u_r, u_l] [N m]."""
    def __new__(cls, params: RobotParams, friction: Optional[Friction] = None, terrain: Optional[Terrain] = None) -> PlanarModel: ...
    @property
    def friction(self) -> Optional[Friction]:
        """The gearhead friction per wheel, or None (the thesis's model)."""
    @property
    def params(self) -> RobotParams: ...
    @property
    def terrain(self) -> Optional[Terrain]:
        """The ground (a twip.Terrain), or None: flat ground."""
    def deriv(self, x: _ArrayLike, u: _ArrayLike) -> _F64: ...
    def energy(self, x: _ArrayLike) -> float:
        """Kinetic plus potential energy [J]; on terrain the potential is from the heights of the
        body's and wheels' centres over the flat model's zero (docs/terrain.md).
        """
    def normal_forces(self, x: _ArrayLike, u: _ArrayLike) -> Tuple[float, float]:
        """Each wheel's normal force [N] (right, left) at state x under motor torques u: a run
        ends "lifted" when one goes negative. On flat ground too (a terrain-less model is
        level ground here).
        """
    def mass_matrix(self, phi: float) -> _F64:
        """The mass matrix M(phi) of M nu_dot + h = B u, with nu = (phi_dot, v, omega) (on
        terrain, in the ground plane's frame with phi the pitch from its normal).
        """

def rk4_step(model: Union[SlopeModel, PlanarModel], x: _ArrayLike, u: Union[float, _ArrayLike], dt: float) -> _F64:
    """One RK4 step of either model with the input held over the step."""
def care(A: _ArrayLike, B: _ArrayLike, Q: _ArrayLike, R: Union[float, _ArrayLike]) -> _F64:
    """Stabilising solution X of X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q = 0 (like scipy's
    `solve_continuous_are` and python-control's `care`). B may be 1-D for one input, R a scalar.
    """
def lqr(A: _ArrayLike, B: _ArrayLike, Q: _ArrayLike, R: Union[float, _ArrayLike]) -> Tuple[_F64, _F64, npt.NDArray[np.complex128]]:
    """Linear-quadratic regulator, python-control's `lqr(A, B, Q, R) -> (K, X, E)`:
    K = R⁻¹ Bᵀ X for u = −K x, X the CARE solution, E the eigenvalues of A − B K (complex).
    """
def dare(A: _ArrayLike, B: _ArrayLike, Q: _ArrayLike, R: Union[float, _ArrayLike]) -> _F64:
    """Stabilising solution X of Aᵀ X A − X − Aᵀ X B (R + Bᵀ X B)⁻¹ Bᵀ X A + Q = 0 (like scipy's
    `solve_discrete_are`: Q, R symmetric, R may be singular where the pencil allows it).
    B may be 1-D for one input, R a scalar.
    """
def dlqr(A: _ArrayLike, B: _ArrayLike, Q: _ArrayLike, R: Union[float, _ArrayLike]) -> Tuple[_F64, _F64, npt.NDArray[np.complex128]]:
    """Discrete-time LQR, python-control's `dlqr(A, B, Q, R) -> (K, S, E)`: K = (R + Bᵀ S B)⁻¹ Bᵀ S A
    for u[k] = −K x[k], S the DARE solution, E the eigenvalues of A − B K (complex).
    """
def c2d(A: _ArrayLike, B: _ArrayLike, period: float) -> Tuple[_F64, _F64]:
    """Exact zero-order-hold discretisation over `period` [s]: (Ad, Bd) with x[k+1] = Ad x[k] + Bd u[k]
    (scipy's `cont2discrete(..., method="zoh")`). B may be 1-D for one input.
    """

@final
class SpeedSchedule:
    """A wheel schedule from theta = 0: legs of (goal [rad], speed [rad/s] > 0, hold [s])."""
    def __new__(cls, legs: Sequence[Tuple[float, float, float]]) -> SpeedSchedule: ...
    @staticmethod
    def constant(speed: float) -> SpeedSchedule:
        """Constant wheel speed [rad/s] from rest, forever."""
    @staticmethod
    def go_and_return(distance: float, speed: float, wheel_radius: float, hold: float = 0.0) -> SpeedSchedule:
        """The thesis's experiment: drive `distance` [m] at wheel speed `speed` [rad/s],
        hold `hold` [s], then drive back to the start and stay there.
        """
    @property
    def legs(self) -> list[Tuple[float, float, float]]:
        """Legs as (goal, speed, hold) tuples."""
    def sample(self, t: float) -> Tuple[float, float]:
        """(theta_ref, theta_dot_ref) at time t."""

@final
class BalanceBatch:
    """N balancing robots, each keyed (seed, episode); `twip.envs` wraps it."""
    def __new__(cls, model: SlopeModel, x0: _ArrayLike,
                perturbations: Sequence[Tuple[str, int, str, float, float, float, float]], num_envs: int, dt: float,
                substeps: int, fall_limit: float, realism: Optional[Realism] = None,
                threads: int = 0) -> BalanceBatch: ...
    @property
    def num_envs(self) -> int: ...
    @property
    def has_rig(self) -> bool: ...
    def reset(self, lanes: Sequence[int], seeds: Optional[Sequence[int]] = None) -> None:
        """Starts the next episode of each lane in `lanes`: with `seeds` (one per lane),
        episode 0 of that seed; else the lane's next episode.
        """
    def step(self, actions: _F64) -> npt.NDArray[np.bool_]:
        """One control period of every robot under `actions` (the model's inputs of
        each robot, robot after robot); returns which fell.
        """
    def step_next(self, actions: _F64, reset: Sequence[int], weights: Tuple[float, float, float, float],
                  speed_ref: float, bound: float) -> Tuple[npt.NDArray[np.bool_], _F64, _F64, _F64]:
        """One step under Gymnasium's NEXT_STEP autoreset, in one trip to the threads: every
        robot steps under `actions`, the rewards are the default terms with these weights on
        the true states after it (`twip.envs.balance.BalanceSettings.rewards`' bits), then the
        lanes `reset` (done at the last step) start their next episode. Returns which fell,
        the rewards, and the true states and observations after the restarts.
        `weights`: (alive, upright, tracking, effort).
        """
    def observations(self) -> _F64:
        """Every robot's observation (num_envs x 4)."""
    def states(self) -> _F64:
        """Every robot's true state (num_envs rows)."""
    def keys(self) -> Tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint64]]:
        """Every robot's (seed, episode) key, as two uint64 arrays."""

@final
class TrackBatch:
    """N tracking robots on one path, each keyed (seed, episode); `twip.envs` wraps it."""
    def __new__(cls, model: PlanarModel, path: Union[Circle, Line, FigureEight, Waypoints], x0: _ArrayLike,
                perturbations: Sequence[Tuple[str, int, str, float, float, float, float]], num_envs: int, dt: float,
                substeps: int, fall_limit: float, realism: Optional[Realism] = None,
                threads: int = 0) -> TrackBatch: ...
    @property
    def num_envs(self) -> int: ...
    @property
    def has_rig(self) -> bool: ...
    def reset(self, lanes: Sequence[int], seeds: Optional[Sequence[int]] = None) -> None:
        """Starts the next episode of each lane in `lanes`: with `seeds` (one per lane),
        episode 0 of that seed; else the lane's next episode.
        """
    def step(self, actions: _F64) -> npt.NDArray[np.bool_]:
        """One control period of every robot under `actions` (the model's inputs of
        each robot, robot after robot); returns which fell.
        """
    def step_next(self, actions: _F64, reset: Sequence[int], weights: Tuple[float, float, float, float, float],
                  bound: float) -> Tuple[npt.NDArray[np.bool_], _F64, _F64, _F64]:
        """One step under Gymnasium's NEXT_STEP autoreset, in one trip to the threads: every
        robot steps under `actions` (robot after robot), the rewards are `rewards`' with these
        weights, then the lanes `reset` (done at the last step) start their next episode.
        Returns which fell, the rewards, and the true states and observations after the
        restarts.
        `weights`: (alive, upright, tracking, heading, effort).
        """
    def observations(self) -> _F64:
        """Every robot's observation (num_envs x 9): path error in its frame, pitch, speeds,
        the reference's speeds.
        """
    def true_observations(self) -> _F64:
        """The observations the true states give (num_envs x 9): on the ideal plant, the
        observations.
        """
    def rewards(self, actions: _F64, alive: float, upright: float, tracking: float, heading: float, effort: float,
                bound: float) -> _F64:
        """Every robot's reward (num_envs) for the step just taken under `actions`
        (num_envs x 2): the default terms with these weights on the true observations
        (`true_observations`, made here), each action over `bound`, with the bits of the
        formula in NumPy (`twip.envs.track.TrackSettings.reward_terms`).
        """
    def states(self) -> _F64:
        """Every robot's true state (num_envs rows)."""
    def keys(self) -> Tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint64]]:
        """Every robot's (seed, episode) key, as two uint64 arrays."""

@final
class LqrController:
    """LQR with integral action on the wheel speed (thesis 4.24). A controller holds no run
    state (each run starts its integral z at zero): a pickled copy has the same gains, model,
    point and period, and `design_info` too.
    """
    def __new__(cls, model: SlopeModel, gains: _ArrayLike, point: str = "operating", period: float = 0.005) -> LqrController: ...
    @staticmethod
    def design(model: SlopeModel, theta_dot_ref: float, Q: _ArrayLike, R: float, point: str = "operating",
               period: float = 0.005, discrete: bool = False, delay: bool = False) -> LqrController:
        """Designs K̂ by LQR on the augmented system (4.17)-(4.23) at `theta_dot_ref`.
        `Q` is 4x4 (or the 4 diagonal entries), `R` a positive scalar. `discrete=True` designs
        at `period` instead (zero-order hold, the integrator as the controller runs it, dlqr);
        `delay=True` (with `discrete=True`) also models the rig's one-period command delay and
        picks the best 4 gains for it (see docs/dare.md).
        """
    @property
    def gains(self) -> _F64:
        """K̂ = [k_phi, k_phi_dot, k_theta_dot, k_z]."""
    @property
    def period(self) -> float: ...
    @property
    def point(self) -> str: ...
    @property
    def model(self) -> SlopeModel: ...
    @property
    def design_info(self) -> Optional[dict[str, Any]]:
        """The design's Â, B̂, X (P̂), poles, phi_s, u_s (None if the gains were given)."""
    def steady_state(self, theta_dot_ref: float) -> Tuple[float, float]:
        """The steady state (phi_s, u_s) the controller aims for at a reference speed."""

@final
class Trapezoid:
    """Trapezoidal membership (4.31): a <= b <= c <= d; a = b = -inf is a left shoulder,
    c = d = +inf a right one. Call it on a float or an array.
    """
    def __new__(cls, a: float, b: float, c: float, d: float) -> Trapezoid: ...
    @property
    def breakpoints(self) -> Tuple[float, float, float, float]:
        """(a, b, c, d)."""
    def eval(self, x: Any) -> Any: ...
    def __call__(self, x: Any) -> Any: ...

@final
class Triangle:
    """Triangular membership with feet a, c and peak b (the trapezoid (a, b, b, c))."""
    def __new__(cls, a: float, b: float, c: float) -> Triangle: ...
    @property
    def breakpoints(self) -> Tuple[float, float, float]:
        """(a, b, c)."""
    def eval(self, x: Any) -> Any: ...
    def __call__(self, x: Any) -> Any: ...

@final
class Gaussian:
    """Gaussian membership exp(-(x - mean)^2 / (2 sigma^2)), sigma > 0."""
    def __new__(cls, mean: float, sigma: float) -> Gaussian: ...
    @property
    def mean(self) -> float: ...
    @property
    def sigma(self) -> float: ...
    def eval(self, x: Any) -> Any: ...
    def __call__(self, x: Any) -> Any: ...

@final
class FuzzyBasis:
    """The normalised fuzzy basis xi of (4.29) over a grid rule base: one rule per
    combination of one set per input, product inference, rules in row-major order (the
    last input varies fastest, as in (4.39)). xi is non-negative and sums to 1 everywhere;
    where no rule fires, each silent input's nearest set fires alone (docs/scenarios.md).
    """
    def __new__(cls, sets_per_input: Sequence[Sequence[Any]]) -> FuzzyBasis: ...
    @staticmethod
    def default() -> FuzzyBasis:
        """twip's default sets for (phi [rad], phi_dot [rad/s]), N, Z, P each, rules ordered as
        the thesis's (4.39); FuzzyController uses them unless given `sets`.
        """
    @staticmethod
    def grid(kind: str, centres: Sequence[Sequence[float]],
             widths: Optional[Sequence[Union[float, Sequence[float]]]] = None) -> FuzzyBasis:
        """A regular n x n grid over (phi [rad], phi_dot [rad/s]) for the adaptive controllers:
        `kind` "trapezoid" (core centre +- width, feet at the neighbours' core edges, the
        outer two shoulders), "triangle" (peak at the centre, feet at the neighbouring
        centres, the outer two shoulders; no widths) or "gaussian" (mean centre, sigma
        width). `centres`: per input, n strictly increasing values (n from 2 to 7);
        `widths`: per input, one value > 0 for every set or n of them.
        """
    @property
    def n_inputs(self) -> int: ...
    @property
    def n_rules(self) -> int: ...
    @property
    def sets(self) -> Any: ...
    def eval(self, x: _ArrayLike) -> _F64:
        """xi at one point x (shape (n_inputs,)) -> (n_rules,), or at many points
        (shape (N, n_inputs)) -> (N, n_rules).
        """

@final
class FuzzyController:
    """Fuzzy adaptive backstepping on the pitch + PD on the wheel position (thesis 4.56,
    errata F1-F8): u = -(1/G1)[e1 + S^T xi + k1 phi_dot + (1/2 + k2) z2] + kp e + kd e_dot
    + ki int(e), S' = z2 xi / gamma - sigma S. `model` is the controller's own model (phi_s
    and G1); `sets` the (phi, phi_dot) sets, n of each for n x n rules, n from 2 to 7
    (a 2 x n FuzzyBasis, e.g. FuzzyBasis.grid, or nested list; default twip's 3 x 3);
    `adapt=False` freezes S at `s0` (default zeros). A pickle or copy keeps these settings,
    `s0` included; the weights S adapt inside each run (from `s0`), not in the controller.
    """
    def __new__(cls, model: SlopeModel, k1: float, k2: float, kp: float, kd: float, gamma: float = ...,
                sigma: float = ..., ki: float = 0.0, adapt: bool = True, sets: Any = None, period: float = 0.005,
                s0: Optional[_ArrayLike] = None) -> FuzzyController: ...
    @staticmethod
    def thesis_slope(model: SlopeModel, gamma: float = ..., sigma: float = ..., ki: float = 0.0, adapt: bool = True,
                     sets: Any = None, period: float = 0.005, s0: Optional[_ArrayLike] = None) -> FuzzyController:
        """The thesis's slope gains k1 = 10, k2 = 13, kp = -0.01, kd = -0.09."""
    @staticmethod
    def thesis_flat(model: SlopeModel, gamma: float = ..., sigma: float = ..., ki: float = 0.0, adapt: bool = True,
                    sets: Any = None, period: float = 0.005, s0: Optional[_ArrayLike] = None) -> FuzzyController:
        """The thesis's flat gains k1 = 30, k2 = 33, kp = -0.1, kd = -0.9."""
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
    s0: list[float]
    sigma: float
    def g1(self, phi: float) -> float:
        """G1 at pitch phi: the pitch acceleration per ampere (controller's model)."""
    def steady_pitch(self, theta_dot_ref: float) -> float:
        """phi_s the controller aims for at a reference wheel speed (corrected 4.42, own model)."""
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> FuzzyController:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> FuzzyController:
        """A copy with some settings changed (validated as the constructor does)."""
    @property
    def sets(self) -> FuzzyBasis:
        """The (phi, phi_dot) sets, n of each."""

@final
class Circle:
    """Constant speed round a circle. `direction` +1 (or "ccw") turns left, -1 ("cw") right.
    By default it starts at the origin heading along +x, centre (0, direction * radius).
    """
    def __new__(cls, radius: float, speed: float, centre: Optional[Tuple[float, float]] = None,
                direction: Any = None, phase: Optional[float] = None) -> Circle: ...
    centre: Tuple[float, float]
    direction: float
    period: float
    phase: float
    radius: float
    speed: float
    def sample(self, t: float) -> dict[str, float]:
        """The reference at time t: dict of x, y, psi, v, omega, v_dot, omega_dot (SI)."""
    def distance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the circle [m]."""
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Circle:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> Circle:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class Line:
    """A straight line from `start` along `heading` [rad] at constant `speed`."""
    def __new__(cls, speed: float, heading: float = 0.0, start: Tuple[float, float] = ...) -> Line: ...
    heading: float
    speed: float
    start: Tuple[float, float]
    def sample(self, t: float) -> dict[str, float]: ...
    def distance(self, x: float, y: float) -> float: ...
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Line:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> Line:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class FigureEight:
    """The lemniscate of Gerono x = a sin(Wt), y = (a/2) sin(2Wt), W = 2 pi/period, about
    `centre` (right lobe clockwise, left lobe counter-clockwise).
    """
    def __new__(cls, half_width: float, period: float, centre: Tuple[float, float] = ...) -> FigureEight: ...
    centre: Tuple[float, float]
    half_width: float
    period: float
    def sample(self, t: float) -> dict[str, float]: ...
    def distance(self, x: float, y: float) -> float: ...
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> FigureEight:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> FigureEight:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class Waypoints:
    """Straight legs through `points` (2 to 16 (x, y) pairs) at constant `speed`, inner corners
    rounded by arcs of `corner_radius` (0: sharp; smaller where a leg is short, sharp at a
    near-reversal). The reference stops at the last point.
    """
    def __new__(cls, points: Sequence[Tuple[float, float]], speed: float, corner_radius: float = 0.0) -> Waypoints: ...
    corner_radius: float
    duration: float
    length: float
    points: list[Tuple[float, float]]
    speed: float
    def sample(self, t: float) -> dict[str, float]: ...
    def distance(self, x: float, y: float) -> float: ...
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Waypoints:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> Waypoints:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class DcMotor:
    """A brushed DC gear motor on PWM, quasi-static: i = (V - k_e eta w)/R, wheel torque
    eta k_t i, w the wheel's speed relative to the body [rad/s]. SI units.
    """
    def __new__(cls, resistance: float, k_t: float, gear_ratio: float, friction: float = 0.0, supply: float = 11.1,
                pwm_max: float = 255.0) -> DcMotor: ...
    @staticmethod
    def gb37y3530(supply: float = 11.1) -> DcMotor:
        """The thesis's GB37Y3530-12V-251R (Table 2.3) on a `supply` V battery (3 x 3.7 V)."""
    @staticmethod
    def from_data_sheet(rated_voltage: float, no_load_rpm: float, no_load_current: float, stall_current: float,
                        gear_ratio: float, supply: float = 11.1) -> DcMotor:
        """R = V/I_stall, k_t = k_e = (V - I_0 R)/w_0, friction = k_t I_0/w_0 (at the motor shaft)."""
    friction: float
    gear_ratio: float
    k_t: float
    pwm_max: float
    resistance: float
    supply: float
    def current(self, voltage: float, relative_speed: float) -> float: ...
    def friction_at_wheel(self) -> float:
        """eta^2 x friction [N m s/rad]."""
    def no_load_speed(self) -> float:
        """Wheel speed with no load at full supply [rad/s]."""
    def pwm_voltage(self, pwm: float) -> float: ...
    def torque(self, voltage: float, relative_speed: float) -> float:
        """Wheel torque [N m] at terminal `voltage` and relative wheel speed [rad/s]."""
    def torque_from_pwm(self, pwm: float, relative_speed: float) -> float: ...
    def torque_limits(self, relative_speed: float) -> Tuple[float, float]:
        """(full reverse, full forward) torque at `relative_speed`."""
    def torque_per_count(self) -> float:
        """Stall torque of one PWM count [N m]."""
    def voltage_for_torque(self, torque: float, relative_speed: float) -> float: ...
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> DcMotor:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> DcMotor:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class PidTracker:
    """The PID tracker (4.64-4.70) in the Arduino's units: outputs PWM counts, turned into
    wheel torques by `motor` at the measured wheel speeds. `gains` (dict, over Table 4.1's)
    and `units` ("arduino", "si" or a dict of pitch, speed, heading, integral_step).
    A tracker holds no run state (each run starts its integrators at zero), so a pickled
    copy is the same tracker. The heading error is wrapped to [−π, π) (docs/errata.md T2).
    """
    def __new__(cls, params: RobotParams, gains: Any = None, units: Any = None, motor: Optional[DcMotor] = None,
                period: float = 0.005) -> PidTracker: ...
    @staticmethod
    def table_4_1(params: Optional[RobotParams] = None, motor: Optional[DcMotor] = None,
                  period: float = 0.005) -> PidTracker:
        """Table 4.1's gains as published, in twip's reading of the Arduino's units."""
    gains: Any
    motor: DcMotor
    period: float
    units: Any

@final
class GradeFeedForward:
    """`tracker` (a twip.PidTracker or SmcTracker designed on flat ground) with the grade's
    feed-forward on `terrain`: at each update the local plane under the robot gives the rest
    pitch and wheel torques of a robot with `params` standing there facing its heading; the
    tracker sees its pitch from that rest pitch and the torques are added to its output
    (held within its motor's torques). Run it with twip.simulate like the tracker itself.
    """
    def __new__(cls, tracker: Any, terrain: Terrain, params: RobotParams) -> GradeFeedForward: ...
    @property
    def params(self) -> RobotParams:
        """The robot whose rest on the grade it feeds forward."""
    @property
    def period(self) -> float:
        """The tracker's update period [s]."""
    @property
    def terrain(self) -> Terrain:
        """The terrain whose grade it feeds forward."""
    @property
    def tracker(self) -> Any:
        """The tracker it wraps."""

@final
class SmcTracker:
    """The sliding-mode backstepping tracker (4.71-4.98) or, with `fuzzy=True`, its fuzzy
    adaptive form (4.99-4.121). `gains` (dict, SI) override the published ones, whose
    torque gains (k_s3, k_s4, g_y4) are read in `torque_unit`; `boundary_layer` is the
    width of sat(S/w) for (S_eta, S1), one number for both, 0 for sgn; `pitch` is
    "backward" (the reading under which the published r1, r2 work) or "forward". A pickle
    or copy keeps these settings; the fuzzy weights adapt inside each run (from zeros), not
    in the tracker. The heading error ψ_r − ψ is wrapped to [−π, π) (docs/errata.md T2).
    Logged internals: `lambda1` = −k_φ (φ − φ_s) in twip's pitch sign (the "backward" reading
    turns r1, not λ1), `d` = r1 g21 + r2 g22 (the surface's input gain, not (4.82)'s 1 + k3 e1).
    `yaw_sets` (over phi, omega) and `pitch_sets` (over phi, phi_dot) are the fuzzy estimates'
    n x n grids, the same n from 2 to 7 (a FuzzyBasis, e.g. FuzzyBasis.grid; default twip's 3 x 3).
    """
    def __new__(cls, model: PlanarModel, fuzzy: bool = False, boundary_layer: Any = None, gains: Any = None,
                torque_unit: Any = None, pitch: str = "backward", guards: Any = ..., gamma: Any = ...,
                leakage: float = 0.0, pitch_offset: bool = True, motor: Optional[DcMotor] = None,
                motor_limits: bool = True, period: float = 0.005, yaw_sets: Any = None,
                pitch_sets: Any = None) -> SmcTracker: ...
    @staticmethod
    def thesis_gains(torque_unit: Any = None) -> Any:
        """The published gains (4.3.2) and twip's k1, k2, k3, k_phi, as a dict in SI with the
        torque gains read in `torque_unit` ("pwm": one PWM count of the GB37Y3530 at 11.1 V).
        """
    boundary_layer: Any
    fuzzy: bool
    gains: Any
    model: PlanarModel
    period: float
    pitch: str
    weights: Any
    def input_gains(self, phi: float) -> Any:
        """(g21, g22, g23) of (4.72) for the controller's model at pitch phi."""
    def steady_pitch(self, v: float, omega: float) -> float:
        """The controller model's steady pitch driving at speed v [m/s] turning at omega [rad/s]."""
    def surface_gain(self, phi: float) -> float:
        """r1 g21 + r2 g22 at pitch phi, r1 on the controller's pitch: (4.113) needs it < 0."""
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> SmcTracker:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> SmcTracker:
        """A copy with some settings changed (validated as the constructor does)."""
    @property
    def torque_unit(self) -> str:
        """The unit the stored gains are in: "si", always (gains read in "pwm" are converted
        when the tracker is built; `gains` holds them in N m).
        """
    @property
    def guards(self) -> Tuple[float, float]:
        """Guards delta of (4.82) for (e3, d)."""
    @property
    def gamma(self) -> Tuple[float, float]:
        """Adaptation gains (gamma1, gamma2) of the fuzzy form."""
    @property
    def leakage(self) -> float: ...
    @property
    def pitch_offset(self) -> bool: ...
    @property
    def motor(self) -> Optional[DcMotor]: ...
    @property
    def motor_limits(self) -> bool: ...
    @property
    def yaw_sets(self) -> FuzzyBasis:
        """The yaw estimate's sets over (phi, omega)."""
    @property
    def pitch_sets(self) -> FuzzyBasis:
        """The pitch estimate's sets over (phi, phi_dot)."""

@final
class Dlpf:
    """A Table 2.2 low-pass: a second-order section solved from (bandwidth, delay), plus a
    pure delay where the section cannot reach the delay (see docs/parameters.md).
    """
    def __new__(cls, bandwidth_hz: float, delay: float, sample_rate: float = 1000.0) -> Dlpf: ...
    @staticmethod
    def mpu6050(dlpf_hz: float, sensor: str = "gyro", sample_rate: float = 1000.0) -> Dlpf:
        """The MPU-6050's filter for the row whose bandwidth is `dlpf_hz`, for the "accel"
        or "gyro" column.
        """
    @staticmethod
    def table() -> Any:
        """Table 2.2 as (accel_hz, accel_delay [s], gyro_hz, gyro_delay [s]) per DLPF_CFG."""
    bandwidth_hz: float
    delay: float
    natural_frequency: float
    pure_delay: float
    sample_rate: float
    zeta: float
    def filter(self, x: _ArrayLike, segments: Optional[Sequence[int]] = None) -> _F64:
        """Filters `x` (samples at the sample rate), starting in the steady state of x[0]. With
        `segments` (each segment's first sample: 0 first, increasing), each segment is
        filtered on its own, from the steady state of its own first sample.
        """
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Dlpf:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> Dlpf:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class Imu:
    """The MPU-6050 of the Balance Shield: DLPF (Table 2.2), noise, bias, ranges, LSB.
    SI units; the ranges as the data sheet's settings (deg/s, g). Defaults: the data
    sheet's noise densities, no bias, DLPF 44/42 Hz, +-250 deg/s, +-2 g, 1 kHz.
    """
    def __new__(cls, *, dlpf_hz: float = 42.0, height: float = 0.12, gyro_noise: float = ..., accel_noise: float = ...,
                gyro_bias: float = 0.0, gyro_bias_walk: float = 0.0, accel_bias: Any = ..., gyro_range_dps: float = 250.0,
                accel_range_g: float = 2.0, quantise: bool = True, sample_rate: float = 1000.0) -> Imu: ...
    @staticmethod
    def data_sheet() -> Imu:
        """The data sheet's sensor (the defaults)."""
    @staticmethod
    def thesis_like() -> Imu:
        """The data sheet's sensor with the residual errors of a start-up calibration:
        gyro bias 0.1 deg/s drifting 0.005 deg/s/sqrt(s), accelerometer x bias 5 mg.
        """
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
    def dlpf(self, sensor: str = "gyro") -> Dlpf:
        """The filter of one sensor ("accel" or "gyro") as set up here."""
    def replace(self, **changes: Any) -> Imu:
        """A copy with some settings changed (validated as the constructor does)."""
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Imu:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""

@final
class TiltEstimator:
    """How the firmware estimates the pitch from the IMU: `complementary(time_constant)` or
    `kalman(q_angle, q_bias, r_angle)` (angle and gyro bias).
    """
    @staticmethod
    def complementary(time_constant: float = 1.0) -> TiltEstimator:
        """phi <- a (phi + T omega) + (1 - a) phi_acc, a = tau / (tau + T); tau [s]."""
    @staticmethod
    def kalman(q_angle: float = 1e-3, q_bias: float = 1e-6, r_angle: float = 0.2) -> TiltEstimator:
        """Kalman filter on (angle, gyro bias): q_angle [rad^2/s], q_bias [rad^2/s^3],
        r_angle [rad^2] (the accelerometer tilt's variance while driving).
        """
    kind: str
    parameters: Any
    def filter(self, accel_x: _ArrayLike, accel_z: _ArrayLike, gyro: _ArrayLike, dt: float) -> Any:
        """Runs the estimator over IMU readings taken every `dt` [s]: specific force along
        the sensor's x and z [m/s^2] and pitch rate [rad/s]. Returns (phi_hat, phi_dot_hat).
        """

@final
class MotorDriver:
    """Battery, L298P bridge and the two GB37Y3530 motors (per motor). Defaults: the data
    sheet's motor (R = 12 V / 7 A) on 3 x 3.7 V, no bridge drop, no inductance, a lossless
    gearbox and no current limit; `assumed_battery` (default: `battery`) is what the
    firmware's feed-forward believes.
    """
    def __new__(cls, *, battery: float = 11.1, bridge_drop: float = 0.0, resistance: float = ..., inductance: float = 0.0,
                efficiency: float = 1.0, current_limit: Optional[float] = None,
                assumed_battery: Optional[float] = None) -> MotorDriver: ...
    @staticmethod
    def data_sheet() -> MotorDriver:
        """The defaults: the data sheet's motor on the 11.1 V battery, nothing else."""
    @staticmethod
    def thesis_like() -> MotorDriver:
        """The L298P's 2 V drop and 2 A DC rating, an assumed 1 mH winding, and the GB37
        gearbox's efficiency from its data sheet (docs/parameters.md).
        """
    assumed_battery: Optional[float]
    battery: float
    bridge_drop: float
    current_limit: Optional[float]
    efficiency: float
    inductance: float
    resistance: float
    def current(self, voltage: float, wheel_speed: float, params: Optional[RobotParams] = None) -> float:
        """Steady winding current of one motor [A] at terminal `voltage` and relative wheel
        speed theta_dot - phi_dot [rad/s] (the robot's torque constant and gear ratio).
        """
    def duty(self, lumped_current: float, wheel_speed: float, params: Optional[RobotParams] = None) -> float:
        """The firmware's duty [counts] for a lumped (both motors) current at a measured
        relative wheel speed: R i + back-EMF, rounded and saturated at +-255.
        """
    def replace(self, **changes: Any) -> MotorDriver:
        """A copy with some settings changed (validated as the constructor does)."""
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    def wheel_torque(self, voltage: float, wheel_speed: float, params: Optional[RobotParams] = None) -> float:
        """Torque of one motor on its wheel [N m] at `voltage` and relative wheel speed."""
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> MotorDriver:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""

@final
class Push:
    """A horizontal push on the body: `impulse` [N s] (positive forward) at time `t` [s],
    `height` [m] up the body's axis from the axle (default: the centre of mass).
    """
    def __new__(cls, t: float, impulse: float, height: Optional[float] = None) -> Push: ...
    height: Optional[float]
    impulse: float
    t: float
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Push:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> Push:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class Force:
    """A constant force on the body [N]: `horizontal` (positive forward), `vertical`
    (positive up), at `height` [m] up the body's axis (default: the centre of mass).
    """
    def __new__(cls, horizontal: float = 0.0, vertical: float = 0.0, height: Optional[float] = None) -> Force: ...
    height: Optional[float]
    horizontal: float
    vertical: float
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Force:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def replace(self, **changes: Any) -> Force:
        """A copy with some settings changed (validated as the constructor does)."""

@final
class Realism:
    """Which real parts of the robot are in the loop, for `twip.simulate(..., realism=...)`.
    Every part is optional; `Realism()` is the ideal loop.

    - `imu`: a `twip.Imu` (the MPU-6050) read through `estimator` ("complementary",
      "kalman" or a `twip.TiltEstimator`) for phi and phi_dot; None: the true ones.
    - `encoder_cpr`: encoder counts per wheel turn (700; 2797 with 4x decoding) for theta
      and theta_dot; None: the true ones.
    - `motor`: a `twip.MotorDriver`; the controller's current becomes a PWM duty. None:
      the plant gets the current.
    - `delay`: apply each command one control period late.
    - `control_period`: the firmware's loop period [s] (None: the controller's own;
      `simulate(control_period=...)` wins over it).
    - `pushes`: `twip.Push` or (t, impulse[, height]) tuples; `force`: a `twip.Force`;
      `slope_profile`: (distance [m], slope [rad]) changes along the path.
    - `friction`: a `twip.Friction` per wheel on the plant (None: the model's own);
      `backlash`: each gear train's free play at the wheel [rad] (None: none).
    - `settle`: seconds the robot stands still at its initial pitch before the run while
      the firmware's loop reads the IMU through the estimator (None or 0: the estimator
      starts at the run's first read, while the robot free-rolls).
    - `seed`, `stream`: the noise's key (its SFC64 stream); a run is bitwise repeatable.
    """
    def __new__(cls, *, imu: Optional[Imu] = None, estimator: Any = None, encoder_cpr: Optional[float] = None,
                motor: Optional[MotorDriver] = None, delay: bool = False, control_period: Optional[float] = None,
                pushes: Optional[Sequence[Push]] = None, force: Optional[Force] = None, slope_profile: Any = None,
                friction: Optional[Friction] = None, backlash: Optional[float] = None, seed: Optional[int] = None,
                stream: Optional[int] = None, settle: Optional[float] = None) -> Realism: ...
    @staticmethod
    def ideal() -> Realism:
        """Every part ideal (the same run as without realism, through the realism runner)."""
    @staticmethod
    def thesis_like(*, seed: int = 0, stream: int = 0) -> Realism:
        """The thesis's robot as built: a 5 ms loop applying its command one period late,
        the MPU-6050 at DLPF 42 Hz with data-sheet noise and calibrated residual biases, a
        complementary filter, 700 CPR encoders, the L298P on 11.1 V, and the GB37 gearheads:
        their friction (the no-load torque split beside the Balanbot's viscous bearing, with
        a stick band; `replace(friction=None)` leaves the model's own) and 1 degree of
        backlash (`replace(backlash=None)`: none). The estimator settles for 2 s at rest
        before the motors run (`replace(settle=None)`: it starts at the run's first read).
        docs/parameters.md.
        """
    backlash: Optional[float]
    control_period: Optional[float]
    delay: bool
    encoder_cpr: Optional[float]
    estimator: Any
    force: Optional[Force]
    friction: Optional[Friction]
    imu: Optional[Imu]
    is_ideal: bool
    motor: Optional[MotorDriver]
    pushes: list[Push]
    seed: int
    settle: Optional[float]
    slope_profile: Any
    stream: int
    def replace(self, **changes: Any) -> Realism:
        """A copy with some settings changed (validated as the constructor does)."""
    def to_dict(self) -> dict[str, Any]:
        """The settings as the constructor's keyword arguments:
        `type(x).from_dict(x.to_dict()) == x`.
        """
    @classmethod
    def from_dict(cls, settings: Mapping[str, Any]) -> Realism:
        """The settings `to_dict()` gave (missing keys take the constructor's defaults)."""
    def to_json(self) -> str:
        """The settings as JSON text: every part as its `to_dict()`, the estimator as
        {"kind", ...its parameters}. `Realism.from_json` reads it back.
        """
    @staticmethod
    def from_json(text: str) -> Realism:
        """The Realism that `to_json` wrote."""

def simulate_raw(model: SlopeModel, controller: Any, x0: _ArrayLike, t_final: float, dt: float, reference: SpeedSchedule,
                 control_period: Optional[float] = None, fall_limit: Optional[float] = None, record_every: int = 1,
                 realism: Optional[Realism] = None) -> dict[str, Any]:
    """Runs the closed loop; returns a dict that `twip.simulate` wraps into a SimResult.
    With `realism` (a `twip.Realism`) the loop runs through `simulate_rig` and the log
    gains the `signals` (what the controller read, the plant's input, the motor current).
    """
def simulate_planar_raw(model: PlanarModel, controller: Any, x0: _ArrayLike, t_final: float, dt: float, reference: Any,
                        control_period: Optional[float] = None, fall_limit: Optional[float] = None,
                        record_every: int = 1, settle: Optional[float] = None,
                        realism: Optional[Realism] = None) -> dict[str, Any]:
    """Runs a tracker on the 3-DOF model; returns a dict that `twip.simulate` wraps into a
    SimResult. `settle` [s] starts the "_settled" metrics (default: one lap of a circle or
    figure-eight, else 0).
    """
def sweep_raw(model: SlopeModel, controller: Any, x0: _ArrayLike, t_final: float, dt: float, reference: SpeedSchedule,
              perturbations: Sequence[Tuple[str, int, str, float, float, float, float]], seed: int, start: int,
              count: int, control_period: Optional[float] = None, threads: int = 0,
              progress: Optional[Callable[[int], Any]] = None, realism: Optional[Realism] = None) -> dict[str, Any]:
    """Runs samples `start..start + count`; returns their metrics as arrays. With `realism`
    (a `twip.Realism`) each runs through the rig; its seed and stream are replaced by the
    sweep's (see `sweep_noise_seed`).
    """
def check_sweep_model(model: SlopeModel | PlanarModel) -> None:
    """Refuses a model a sweep cannot carry (one with gearhead friction), before the sweep
    touches anything (`montecarlo` asks before its checkpoint folder).
    """
def sweep_noise_seed(seed: int) -> int:
    """The sensor-noise key of a sweep with `seed` (sample i replays with
    `realism.replace(seed=sweep_noise_seed(seed), stream=i)`).
    """
def kernel_copy() -> str:
    """Which copy of the sweeps' lane kernels runs: "avx512" (x86-64 with AVX-512 and FMA),
    "avx2" (AVX2 and FMA) or "baseline"; the widest this CPU has, unless `use_kernel_copy`
    chose a narrower one. Every copy gives the same numbers, at its own speed: name it
    beside any throughput you quote.
    """
def available_kernel_copies() -> list[str]:
    """The copies of the lane kernels this process can run, widest first: those this CPU has
    instructions for and this build holds (a wheel `make` built on a CPU with AVX2 and FMA
    holds no "baseline" copy; one for any x86-64 CPU does).
    """
def use_kernel_copy(name: str | None) -> str:
    """Makes this process's sweeps run the lane kernels' copy `name` ("avx512", "avx2" or
    "baseline"; None: the widest this CPU has), to measure what a CPU without the wider
    instructions gets. The numbers are the same on every copy. Returns the copy that now
    runs. A copy this CPU has no instructions for, or this build does not hold
    (`available_kernel_copies`), is refused (`InvalidParameterError`). `import twip` applies the
    environment variable `TWIP_KERNEL_COPY` this way.
    """
def sweep_kernel(controller: Any, realism: Realism | None = None) -> str:
    """The core's kernel for a sweep of `controller` (a built-in 2-DOF or 3-DOF controller),
    with `realism` (a `twip.Realism`) or without (None): "lanes", "realism-lanes",
    "planar-lanes", "planar-realism-lanes", "planar" or "planar-realism".
    """

DEFAULT_FALL_LIMIT: float
MAX_THREADS: int
NORMAL_REACH: float
def ffi_record(
    model: Any, controller: Any, x0: Sequence[float], t_final: float, dt: float, reference: Any,
    control_period: Optional[float] = None,
) -> dict[str, Any]:
    """`ffi_record(model, controller, x0, t_final, dt, reference, control_period=None)`: the
    controller's C configuration and a closed-loop run of its `f32` build (as `twip_X_init`
    makes it) on the `f32` plant, every update recorded: {"family", "config" (bytes of the C
    struct), "t", "y", "reference", "u", "outcome"}. With `control_period` [s] the controller
    runs at that period, as `simulate(..., control_period=)` runs it, and its configuration
    says so.
    """
def sysid_shoot(
    models: Sequence[SlopeModel], starts: _ArrayLike, t: _ArrayLike, u: _ArrayLike, segments: _ArrayLike,
    max_step: float = 1e-3, drivers: Optional[Sequence[MotorDriver]] = None, backlash: Optional[float] = None,
) -> Tuple[_F64, _F64, _F64, _F64]:
    """Predicts the log for each of `models` (K SlopeModels) from its own start states
    `starts` [K, segments, 4]: returns (states, rates), each [K, n, 4], and each segment's
    state carried on to the next segment's first sample, [K, segments, 4] (NaN for the
    last). `u[i]` is held over
    [t_i, t_i+1): the lumped current [A], or with `drivers` (one MotorDriver per model) the
    PWM duty [counts]. A driver with inductance carries its winding's current along each
    segment, and each RK4 stage feels it within the step, as `simulate` does (from the
    steady current of the duty held before the segment's first sample); without, the
    current is algebraic. The fourth array, [K, n, 2], is what the sensors see besides the
    state: the motor shafts' offset from the wheels (the encoder counts the shaft) and the
    pitch rate the IMU samples. With `backlash` (each gear train's play at the wheel [rad])
    the models' gear trains have play, as the rig's (`Realism(backlash=)`): the first run
    carries each segment's play on from the previous segment's end and records its impacts
    and openings, step by step; the others start each segment from the first run's play and
    replay its events (a finite difference holds the impacts' schedule; `run_all`).
    """
def ffi_firmware(realism: Realism, params: RobotParams) -> dict[str, Any]:
    """`ffi_firmware(realism, params)`: the C configurations of the firmware pieces the
    realism describes: {"tilt": bytes of TwipTiltConfig, "pwm_lumped" and "pwm_wheel": bytes
    of TwipPwmConfig (for a lumped current and for one wheel's torque), "encoder_cpr"}.
    """
FFI_HEADER: str
FFI_SOURCE_DIR: str
def controller_fingerprint(controller: Any) -> str:
    """Everything a controller is (gains, model, period, fuzzy sets, initial weights, ...),
    as text: what a sweep's checkpoint fingerprints, so that any change is noticed.
    """
def sweep_draw(model: SlopeModel, x0: _ArrayLike, perturbations: Sequence[Tuple[str, int, str, float, float, float, float]],
               seed: int, index: int) -> Tuple[dict[str, float], float, _F64]:
    """The robot, slope and initial state of sample `index` (to replay it alone)."""
def sweep_planar_raw(model: PlanarModel, controller: Any, x0: _ArrayLike, t_final: float, dt: float, reference: Any,
                     perturbations: Sequence[Tuple[str, int, str, float, float, float, float]], seed: int, start: int,
                     count: int, control_period: Optional[float] = None, threads: int = 0,
                     progress: Optional[Callable[[int], Any]] = None,
                     realism: Optional[Realism] = None) -> dict[str, Any]:
    """Runs samples `start..start + count` of a tracker on perturbed planar robots along
    `reference`; returns their metrics as arrays ("_settled" ones after one lap of a
    closed path, else from the start: `simulate_planar_raw`'s default).
    """
def sweep_planar_draw(model: PlanarModel, x0: _ArrayLike,
                      perturbations: Sequence[Tuple[str, int, str, float, float, float, float]], seed: int,
                      index: int) -> Tuple[dict[str, float], _F64, Optional[Tuple[Optional[float], Optional[float], Terrain]]]:
    """The robot, initial state and ground of sample `index` (to replay it alone): the ground
    None on flat ground, else (slope, heading, terrain) drawn (slope and heading None on a
    terrain without a plane).
    """
