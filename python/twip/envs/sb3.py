"""Stable-Baselines3's `VecEnv` API over the native vector env (needs stable-baselines3).

SB3 resets an env in the step that ends it and hands the last observation over in that
env's info as "terminal_observation": Gymnasium's SAME_STEP autoreset, which this adapter
runs. The robots move in Rust; SB3's info format is a list of one dict per env."""
from __future__ import annotations

from typing import Any, List, Optional, Sequence

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from twip.envs.balance import BalanceVectorEnv


class SB3VecEnv(VecEnv):
    """`num_envs` Balance-v0 robots as an SB3 `VecEnv` (the keyword arguments of
    `BalanceEnv`)."""

    def __init__(self, num_envs: int, **kwargs):
        self.env = BalanceVectorEnv(num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
        super().__init__(num_envs, self.env.single_observation_space, self.env.single_action_space)
        self._seed: Optional[int] = None
        self._actions = None

    def reset(self):
        obs, _ = self.env.reset(seed=self._seed)
        self._seed = None
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, 1)

    def step_wait(self):
        obs, rewards, terminated, truncated, infos = self.env.step(self._actions)
        dones = terminated | truncated
        out: List[dict] = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(dones):
            out[i] = {"terminal_observation": infos["final_obs"][i], "TimeLimit.truncated": bool(truncated[i])}
        return obs, rewards.astype(np.float32), dones, out

    def seed(self, seed: Optional[int] = None) -> Sequence[Optional[int]]:
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def close(self) -> None:
        self.env.close()

    def get_attr(self, attr_name: str, indices=None) -> List[Any]:
        # SB3 asks every env for its render mode; the robots have none to render.
        value = None if attr_name == "render_mode" else getattr(self.env.settings, attr_name)
        return [value] * len(self._get_indices(indices))

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        raise AttributeError(f"{attr_name}: the robots' settings are fixed when the env is made")

    def env_method(self, method_name: str, *args, indices=None, **kwargs) -> List[Any]:
        raise AttributeError(f"{method_name}: the native vector env has no per-env objects to call")

    def env_is_wrapped(self, wrapper_class, indices=None) -> List[bool]:
        return [False] * len(self._get_indices(indices))
