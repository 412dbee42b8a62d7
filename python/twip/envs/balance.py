"""`twip/Balance-v0`: the 2-DOF robot on the flat or a slope, balancing and following a
wheel-speed reference (`speed_ref`). One step is one control period (default 5 ms, RK4 at
`dt` = 1 ms inside). `BalanceEnv` is one robot, `BalanceVectorEnv` N robots that one
`step` advances together in Rust; lane i of the vector env is the single env seeded with
lane i's seed."""
from __future__ import annotations

import numpy as np
from gymnasium import spaces

from twip import _core, checks
from twip.distributions import Uniform
from twip.envs.base import BatchVectorEnv, SingleEnv, made_by_gymnasium
from twip.envs.robots import Settings

#: The reward's default weights: per step alive, minus upright·φ² [rad²], minus
#: tracking·(θ̇ − θ̇_ref)² [(rad/s)²], minus effort·(action / bound)².
DEFAULT_REWARD = {"alive": 1.0, "upright": 10.0, "tracking": 0.01, "effort": 0.1}

#: The initial state's spread when `perturb` names none of its entries: φ0 uniform in ±0.1
#: rad, at rest.
DEFAULT_INIT = {"phi0": Uniform(low=-0.1, high=0.1)}


class BalanceSettings(Settings):
    """Balance-v0's keyword arguments: the common ones, `slope` [rad], `speed_ref` [rad/s]."""

    default_reward = DEFAULT_REWARD
    default_init = DEFAULT_INIT
    x0_size = 4
    action_width = 1

    def make_model(self, slope: float = 0.0, speed_ref: float = 0.0):
        self.slope = checks.real("slope", slope)
        self.speed_ref = checks.real("speed_ref", speed_ref)
        return self.model_on(self.params)

    def model_on(self, params, slope=None):
        return _core.SlopeModel(params, self.slope if slope is None else slope)

    def model_input_bound(self, per_motor_current: float) -> float:
        # The model's input is the lumped current of both motors.
        return 2.0 * per_motor_current

    @property
    def single_observation_space(self):
        return spaces.Box(-np.inf, np.inf, (4,), np.float64)

    @property
    def single_action_space(self):
        return spaces.Box(-self.action_bound, self.action_bound, (1,), np.float64)

    def batch(self, num_envs: int):
        """The native batch of `num_envs` robots."""
        return _core.BalanceBatch(self.model, self.x0, self.perturbations, num_envs, self.dt, self.substeps,
                                  self.fall_limit, realism=self.realism, threads=self.threads)

    def rewards(self, batch, actions: np.ndarray) -> np.ndarray:
        """The default terms on the true states after the step and the actions."""
        w = self.reward
        states = batch.states()
        phi, theta_dot = states[:, 0], states[:, 3]
        effort = (actions[:, 0] / self.action_bound) ** 2
        return (w["alive"] - w["upright"] * phi ** 2 - w["tracking"] * (theta_dot - self.speed_ref) ** 2
                - w["effort"] * effort)

    def step_next(self, batch, actions: np.ndarray, again: list):
        """A NEXT_STEP step of the vector env in one native call: `rewards`' numbers, bit for
        bit, made in Rust (`BatchVectorEnv._step_next`)."""
        w = self.reward
        weights = (w["alive"], w["upright"], w["tracking"], w["effort"])
        return batch.step_next(actions, again, weights, self.speed_ref, self.action_bound)


class BalanceEnv(SingleEnv):
    """One balancing robot. Keyword arguments (all optional):

    - `robot`: `twip.RobotParams` or a robot file (default: the Balanbot); `slope` [rad];
    - `realism`: a `twip.Realism`: the observation becomes the sensors' reading (tilt
      estimate, gyro rate, encoder angle and speed), the action the PWM duty [counts] when
      the rig has a motor driver, with its delay, noise, friction and backlash;
    - `perturb`: the sweep's `{name: twip.Uniform | twip.Normal}`, drawn per episode
      (default: φ0 uniform in ±0.1 rad);
    - `reward`: weights of the default terms (`DEFAULT_REWARD`);
    - `max_episode_steps` (default 2000; None: never truncated), `control_period`, `dt`
      (at most `robots.MAX_SUBSTEPS` plant steps a step), `fall_limit` [rad] (default 0.5:
      terminated beyond it), `speed_ref` [rad/s], `threads` (0, the default, or None: all cores).

    An action beyond the action space is taken (a rig saturates the duty; the effort term
    is on the action given) up to `robots.MAX_ACTION_BOUNDS` times the bound, refused beyond.
    """

    settings_class = BalanceSettings


class BalanceVectorEnv(BatchVectorEnv):
    """`num_envs` balancing robots stepped together in Rust (the keyword arguments of
    `BalanceEnv`, and `autoreset_mode`: NEXT_STEP (default), SAME_STEP or DISABLED)."""

    settings_class = BalanceSettings
    single_class = BalanceEnv


def gymnasium_balance_env(**kwargs) -> BalanceEnv:
    """`gymnasium.make`'s entry point (`base.made_by_gymnasium`)."""
    return made_by_gymnasium(BalanceEnv, **kwargs)
