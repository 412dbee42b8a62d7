"""What every twip env shares: the keyword arguments common to Balance-v0 and Track-v0
resolved once (robot, realism, perturbations, reward weights, step limit, control period),
the checks on actions and seeds, and the error of a closed env. The robots move in Rust;
here everything is arrays over the N robots."""
from __future__ import annotations

import itertools
import types
from typing import Mapping, Optional

import numpy as np

from twip import _core, budget, checks, perturbation
from twip.robot_file import Robot

_bad = _core.InvalidParameterError

#: Steps before truncation unless told otherwise: 10 s at the default 5 ms period.
DEFAULT_MAX_EPISODE_STEPS = 2000

#: The firmware's largest PWM duty [counts]: the action bound with a motor driver.
PWM_MAX = 255.0

#: The most plant steps (RK4 steps of `dt`) one env step may take: a native step cannot be
#: interrupted, and dt = 1e-12 under the default 5 ms period was 5e9 of them (hours).
MAX_SUBSTEPS = 100_000

#: The largest |action| taken, as a multiple of the action space's bound. Beyond the bound
#: a rig saturates the duty, but the reward's effort term, (action / bound)², is on the
#: action given: past ~1e154 bounds it overflowed to a reward of -inf. A million bounds is
#: no saturation but a mistake (a unit slip, a diverged policy).
MAX_ACTION_BOUNDS = 1e6


class ClosedEnvError(_core.TwipError):
    """The env was closed: it can no longer step or reset."""


def _robot_params(robot):
    if robot is None:
        return _core.RobotParams.balanbot()
    if isinstance(robot, _core.RobotParams):
        return robot
    if isinstance(robot, Robot):
        return robot.params
    if isinstance(robot, str) or hasattr(robot, "__fspath__"):
        return Robot.from_file(robot).params
    raise _bad(f"robot: expected twip.RobotParams or a robot file path, got {robot!r}")


def motor_current_bound(driver) -> float:
    """The current [A] the driver can give one motor: the smaller of its limit and its
    stall current (battery / resistance)."""
    per_motor = driver.battery / driver.resistance
    if driver.current_limit is not None:
        per_motor = min(per_motor, driver.current_limit)
    return per_motor


class Settings:
    """The resolved keyword arguments every env takes. A subclass names its model
    (`make_model`), its initial state's length and default spread (`x0_size`,
    `default_init`), its reward terms (`default_reward`) and its input bound without a
    driver (`model_input_bound`)."""

    default_reward: Mapping[str, float] = {}
    default_init: Mapping[str, object] = {}
    x0_size = 4

    def __init__(self, robot=None, realism=None, perturb: Optional[Mapping] = None, reward: Optional[Mapping] = None,
                 max_episode_steps: Optional[int] = DEFAULT_MAX_EPISODE_STEPS, control_period: Optional[float] = None,
                 dt: float = 1e-3, fall_limit: float = 0.5, threads: int = 0, **own):
        self.params = _robot_params(robot)
        self.model = self.make_model(**own)
        if realism is not None and not isinstance(realism, _core.Realism):
            raise _bad(f"realism: expected twip.Realism or None, got {realism!r}")
        self.realism = realism
        self.dt = checks.real("dt", dt, above=0.0)
        period = control_period if control_period is not None else (
            realism.control_period if realism is not None and realism.control_period is not None else 5e-3)
        period = checks.real("control_period", period, above=0.0)
        plant_steps = period / self.dt  # inf for a subnormal dt: refused below, not rounded
        if not plant_steps <= MAX_SUBSTEPS + 0.5:
            raise _bad(f"control_period = {period} over dt = {self.dt} is {plant_steps:.3g} plant steps a step: "
                       f"at most {MAX_SUBSTEPS} (raise dt or lower control_period)")
        substeps = round(plant_steps)
        if substeps < 1 or abs(substeps * self.dt - period) > 1e-9 * period:
            raise _bad(f"control_period = {period}: must be a whole number (>= 1) of plant steps dt = {self.dt}")
        self.period, self.substeps = period, substeps
        self.fall_limit = checks.real("fall_limit", fall_limit, above=0.0)
        steps = max_episode_steps
        if steps is not None and (isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1):
            raise _bad(f"max_episode_steps = {max_episode_steps!r}: must be an int >= 1 or None")
        # A numpy integer too (as num_envs), kept as a Python int.
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.reward = dict(self.default_reward)
        weights = checks.of_type("reward", {} if reward is None else reward, Mapping, "a dict {term: weight} or None")
        for name, w in weights.items():
            if name not in self.default_reward:
                raise _bad(f"reward: unknown term {name!r}; the terms are {sorted(self.default_reward)}")
            self.reward[name] = checks.real(f"reward[{name!r}]", w)
        self.x0 = self.nominal_x0()
        scenario = types.SimpleNamespace(model=self.model, x0=self.x0, name=type(self).__name__)
        self.perturbations = perturbation.resolve(perturb or {}, scenario)
        if not any(kind == "x0" for kind, *_ in self.perturbations):
            self.perturbations += perturbation.resolve(self.default_init, scenario)
        self.check_draws()
        # All cores: 0 for the envs (their default, the core's word), None for checks.threads.
        zero = isinstance(threads, (int, np.integer)) and not isinstance(threads, bool) and threads == 0
        self.threads = checks.threads(None if zero else threads) or 0
        self.kwargs = dict(robot=robot, realism=realism, perturb=perturb, reward=reward,
                           max_episode_steps=max_episode_steps, control_period=control_period, dt=dt,
                           fall_limit=fall_limit, threads=threads, **own)
        driven = realism is not None and realism.motor is not None
        # With a driver in the rig the action is the firmware's duty; else the model's input.
        self.action_bound = PWM_MAX if driven else self.model_input_bound(
            motor_current_bound(_core.MotorDriver.thesis_like()))

    def make_model(self, **own):
        raise NotImplementedError

    def model_on(self, params, slope: Optional[float] = None):
        """The env's model of robot `params` (on `slope`, None: the nominal one): what a
        reset makes of a draw."""
        raise NotImplementedError

    def check_draws(self):
        """Refuses a perturbation one of whose draws the model refuses, here rather than at
        some later reset (each batch's autoreset would raise it again): each end of its reach,
        the other quantities nominal; then every corner of the perturbations' joint reach, since
        a draw combines them and the model checks fields against each other (the rotor's
        reflected inertia against the rest of the robot's: each alone valid, together not).
        Those checks are monotone in each field, so a combination they refuse is refused at a
        corner. An initial-state entry takes any (finite) value."""
        fields = list(_core.RobotParams.fields)
        ends, normal = {}, set()
        for kind, index, *spread in self.perturbations:
            if kind == "x0":
                continue
            name = fields[index] if kind == "param" else kind
            ends[name] = reach(*spread)
            if spread[0] == "normal":
                normal.add(name)
            for end in ends[name]:
                error = self.refusal({name: end})
                if error is not None:
                    raise _bad(f"perturb[{name!r}]: {error}: a draw can reach it{_clamp_hint([name], normal)}")
        if len(ends) >= 2:
            key = (type(self), tuple(self.params.to_dict().items()), getattr(self, "slope", None),
                   tuple(self.perturbations))
            if key not in _COMBINATIONS_TAKEN:
                self.check_corners(ends, normal)
                if len(_COMBINATIONS_TAKEN) >= 1024:
                    _COMBINATIONS_TAKEN.clear()
                _COMBINATIONS_TAKEN.add(key)

    def check_corners(self, ends: Mapping[str, tuple], normal: set):
        """Every corner of the joint reach `ends` ({name: (low end, high end)}), walked in Gray
        code order (one quantity changes from corner to corner: 2**17 corners take ~0.3 s)."""
        names = list(ends)
        corner = [0] * len(names)
        values = {n: ends[n][0] for n in names}
        params, slope, flipped = self.params, values.get("slope"), {n: v for n, v in values.items() if n != "slope"}
        for i in range(1, 2 ** len(names) + 1):
            try:  # `replace` checks the fields too: the first refusal ends the walk
                params = params.replace(**flipped)
                self.model_on(params, slope)
            except _core.TwipError:
                self.refuse_corner(values, normal)
            if i == 2 ** len(names):
                return
            j = (i & -i).bit_length() - 1  # the bit Gray code flips
            corner[j] ^= 1
            name = names[j]
            values[name] = ends[name][corner[j]]
            slope, flipped = (values[name], {}) if name == "slope" else (slope, {name: values[name]})

    def refuse_corner(self, values: Mapping[str, float], normal: set):
        """The named error for a corner the model refuses, naming the perturbations it
        needs (each put back to nominal in turn, and left so when still refused)."""
        values = dict(values)
        for name in list(values):
            fewer = {k: v for k, v in values.items() if k != name}
            if self.refusal(fewer) is not None:
                values = fewer
        at = ", ".join(f"{k} = {v:g}" for k, v in values.items())
        raise _bad(f"perturb: {', '.join(repr(k) for k in values)} together can reach a robot the model refuses "
                   f"(at {at}, the rest nominal: {self.refusal(values)}), though each alone is valid: narrow their "
                   f"ranges{_clamp_hint(list(values), normal)}")

    def refusal(self, values: Mapping[str, float]) -> Optional[str]:
        """The model's error for the nominal robot and slope but `values` ({field or 'slope':
        value}), or None when it takes them."""
        fields = {k: v for k, v in values.items() if k != "slope"}
        try:
            self.model_on(self.params.replace(**fields) if fields else self.params, values.get("slope"))
        except _core.TwipError as e:
            return str(e)
        return None

    def model_input_bound(self, per_motor_current: float) -> float:
        raise NotImplementedError

    def nominal_x0(self) -> np.ndarray:
        """The initial state the perturbations spread (default: upright at rest)."""
        return np.zeros(self.x0_size)


#: How far from its mean an unclamped Normal perturbation is checked when an env is made
#: [std]. Its draws can reach the core's NORMAL_REACH (8.57 std), but past 6 std goes one
#: draw in 5e8: checking to 8.57 refused Normal(rel=0.15) on a mass, a common randomisation.
#: A rarer draw the model refuses fails its own reset, by name.
CHECKED_REACH = 6.0


#: The settings' perturbations whose joint reach the model took (`Settings.check_corners`):
#: the vector envs of Gymnasium's SyncVectorEnv make the same settings over and over.
_COMBINATIONS_TAKEN: set = set()


def _clamp_hint(names, normal) -> str:
    clamped = [n for n in names if n in normal]
    return (f" (checked {CHECKED_REACH:g} std from a Normal's mean: clamp {', '.join(clamped)} with low=/high=)"
            if clamped else "")


def reach(spread: str, a: float, b: float, low: float, high: float):
    """The smallest and largest value a resolved distribution is checked at: a uniform's
    ends (a, b), a normal's mean a -+ CHECKED_REACH std b clamped into [low, high]."""
    if spread == "uniform":
        return a, b
    return min(max(a - CHECKED_REACH * b, low), high), min(max(a + CHECKED_REACH * b, low), high)


#: The most robots a native batch holds (the core's `envs::MAX_ENVS`).
MAX_ENVS = 1 << 24

#: The memory one robot of a batch takes [bytes], with room: measured (peak RSS over a
#: batch of thousands, made and reset) 1.3 kB on the ideal plant and 12.9-13.8 kB through
#: the thesis-like rig (its IMUs' state and drawn-ahead noise).
ROBOT_BYTES = {"ideal": 2 << 10, "rig": 16 << 10}


def num_envs_checked(num_envs, rig: bool = False) -> int:
    """`num_envs` as an int, or a named error: not an int from 1 to MAX_ENVS, or its robots
    would need more than the memory budget (checked before the batch is made: past it the
    allocation aborted the interpreter; 2**24 robots through a rig are 230 GB)."""
    if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
        raise _bad(f"num_envs = {num_envs!r}: must be an int >= 1")
    n = int(num_envs)
    if n > MAX_ENVS:
        raise _bad(f"num_envs = {n}: at most {MAX_ENVS} robots in a batch")
    kind = "rig" if rig else "ideal"
    budget.check(f"num_envs = {n:,} robots ({'through a rig' if rig else 'ideal plant'}, "
                 f"~{ROBOT_BYTES[kind] >> 10} KiB each)", n * ROBOT_BYTES[kind], "lower num_envs")
    return n


def check_actions(actions, n: int, width: int, bound: float) -> np.ndarray:
    """The actions as float64 (n * width,), robot after robot, or a named error: wrong
    shape or dtype, NaN, beyond MAX_ACTION_BOUNDS times `bound`. A single env (n = 1) takes
    shape (width,)."""
    try:
        a = np.asarray(actions)
    except ValueError:  # ragged: rows of different lengths
        raise _core.ShapeError(f"action: rows of different lengths, expected shape "
                               f"{(width,) if n == 1 else (n, width)}") from None
    if a.dtype.kind not in "fiu":
        raise _core.ShapeError(f"action: expected a float array, got dtype {a.dtype}")
    want = (width,) if n == 1 else (n, width)
    if a.shape != want and not (n == 1 and a.shape == (1, width)):
        raise _core.ShapeError(f"action has shape {a.shape}, expected {want}")
    a = np.ascontiguousarray(a, dtype=np.float64).reshape(n * width)
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.argmax(bad))
        raise _core.NonFiniteError(f"action[{i}] = {a[i]}: every action must be finite")
    big = np.abs(a) > MAX_ACTION_BOUNDS * bound
    if big.any():
        i = int(np.argmax(big))
        raise _bad(f"action[{i}] = {a[i]:g}: beyond {MAX_ACTION_BOUNDS:g} times the action bound {bound:g}")
    return a


def seeds_for(seed, n: int) -> list:
    """Gymnasium's convention: None draws fresh seeds, an int seeds lane i with seed + i, a
    list (tuple, array) one per lane, where None is a lane whose stream goes on."""
    if seed is None:
        base = int(np.random.SeedSequence().generate_state(1, np.uint64)[0]) >> 1
        return [base + i for i in range(n)]
    if isinstance(seed, (list, tuple, np.ndarray)):
        if len(seed) != n:
            raise _bad(f"seed: a list of {len(seed)} seeds for {n} envs")
        return [None if s is None else checks.seed(f"seed[{i}]", s) for i, s in enumerate(seed)]
    first = checks.seed("seed", seed)
    if first + n - 1 >= 2 ** 64:  # lane i's seed is seed + i
        raise _bad(f"seed = {first}: the last lane's seed, seed + {n - 1}, passes 2**64 - 1")
    return [first + i for i in range(n)]
