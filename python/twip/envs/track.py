"""`twip/Track-v0`: the 3-DOF robot (`twip.PlanarModel`) balancing while it follows a path
(`path=`: a twip.Circle, Line, FigureEight or Waypoints; default the thesis's circle of
Fig 4.14), each episode from the path's start at time 0. The observation holds the path
error in the robot's frame; the action is the two wheel commands. `TrackEnv` is one
robot, `TrackVectorEnv` N robots that one `step` advances together in Rust."""
from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from twip import _core
from twip.distributions import Uniform
from twip.envs.base import BatchVectorEnv, SingleEnv, made_by_gymnasium
from twip.envs.robots import Settings

#: The observation's entries: the reference's position ahead of the robot and to its
#: left [m] and its heading minus the robot's [rad], then pitch [rad], pitch rate [rad/s],
#: forward speed [m/s], yaw rate [rad/s], and the reference's speed and yaw rate.
OBSERVATION_NAMES = ("e_along", "e_lateral", "e_psi", "phi", "phi_dot", "v", "omega", "v_ref", "omega_ref")

#: The reward's default weights: per step alive, minus upright·φ² [rad²], minus
#: tracking·(e_along² + e_lateral²) [m²], minus heading·e_psi² [rad²], minus
#: effort·mean((action / bound)²).
DEFAULT_REWARD = {"alive": 1.0, "upright": 10.0, "tracking": 10.0, "heading": 1.0, "effort": 0.1}

#: The initial state's spread when `perturb` names none of its entries: φ0 uniform in
#: ±0.05 rad, on the path's start, at rest.
DEFAULT_INIT = {"phi0": Uniform(low=-0.05, high=0.05)}


def default_path(params):
    """The thesis's circle (Fig 4.14): radius 0.6 m at a wheel speed of 180 deg/s."""
    return _core.Circle(0.6, math.radians(180.0) * params.wheel_radius)


_PATHS = (_core.Circle, _core.Line, _core.FigureEight, _core.Waypoints)


class TrackSettings(Settings):
    """Track-v0's keyword arguments: the common ones and `path`."""

    default_reward = DEFAULT_REWARD
    default_init = DEFAULT_INIT
    x0_size = 7
    action_width = 2

    def make_model(self, path=None):
        self.path = default_path(self.params) if path is None else path
        if not isinstance(self.path, _PATHS):
            raise _core.InvalidParameterError(
                f"path: expected a twip.Circle, Line, FigureEight or Waypoints, got {path!r}")
        return self.model_on(self.params)

    def model_on(self, params, slope=None):
        return _core.PlanarModel(params)  # flat: `perturb` has no slope here

    def nominal_x0(self) -> np.ndarray:
        """On the path's start, along it, upright and at rest."""
        r = self.path.sample(0.0)
        return np.array([r["x"], r["y"], r["psi"], 0.0, 0.0, 0.0, 0.0])

    def model_input_bound(self, per_motor_current: float) -> float:
        # The model's inputs are the two wheels' motor torques [N m].
        return per_motor_current * self.params.torque_constant * self.params.gear_ratio

    @property
    def single_observation_space(self):
        return spaces.Box(-np.inf, np.inf, (len(OBSERVATION_NAMES),), np.float64)

    @property
    def single_action_space(self):
        return spaces.Box(-self.action_bound, self.action_bound, (2,), np.float64)

    def batch(self, num_envs: int):
        """The native batch of `num_envs` robots."""
        return _core.TrackBatch(self.model, self.path, self.x0, self.perturbations, num_envs, self.dt,
                                self.substeps, self.fall_limit, realism=self.realism, threads=self.threads)

    def rewards(self, batch, actions: np.ndarray) -> np.ndarray:
        """The default terms on the true path error and pitch after the step, and the actions
        (`reward_terms`' numbers, made in Rust in one pass: the NumPy columns cost a sixth of
        a step of 4096 robots)."""
        w = self.reward
        return batch.rewards(actions, w["alive"], w["upright"], w["tracking"], w["heading"], w["effort"],
                             self.action_bound)

    def step_next(self, batch, actions: np.ndarray, again: list):
        """A NEXT_STEP step of the vector env in one native call (`BatchVectorEnv._step_next`)."""
        w = self.reward
        weights = (w["alive"], w["upright"], w["tracking"], w["heading"], w["effort"])
        return batch.step_next(actions, again, weights, self.action_bound)

    def reward_terms(self, observations: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """The rewards as NumPy evaluates the formula on true observations and actions: what
        `rewards` gives, bit for bit (tests/test_envs_track.py)."""
        w, o = self.reward, observations
        effort = np.mean((actions / self.action_bound) ** 2, axis=1)
        return (w["alive"] - w["upright"] * o[:, 3] ** 2 - w["tracking"] * (o[:, 0] ** 2 + o[:, 1] ** 2)
                - w["heading"] * o[:, 2] ** 2 - w["effort"] * effort)


class TrackEnv(SingleEnv):
    """One robot following a path. Keyword arguments (all optional): those of
    `twip.envs.BalanceEnv` but `slope` and `speed_ref` (the planar model is flat), and
    `path`. Through a rig (`realism=`) the observation is built from the sensors' reading
    (dead-reckoned position, encoder heading, tilt estimate, gyros) and the action is the
    two PWM duties [counts] when the rig has a motor driver; else the action is the two
    wheels' motor torques [N m], right then left."""

    settings_class = TrackSettings


class TrackVectorEnv(BatchVectorEnv):
    """`num_envs` tracking robots stepped together in Rust (the keyword arguments of
    `TrackEnv`, and `autoreset_mode`)."""

    settings_class = TrackSettings
    single_class = TrackEnv


def gymnasium_track_env(**kwargs) -> TrackEnv:
    """`gymnasium.make`'s entry point (`base.made_by_gymnasium`)."""
    return made_by_gymnasium(TrackEnv, **kwargs)
