"""Gymnasium environments on twip's engine (needs the `gym` extra: `pip install twip[gym]`).

Importing this module registers `twip/Balance-v0` and `twip/Track-v0` (`gymnasium.make`,
and `gymnasium.make_vec(..., vectorization_mode="vector_entry_point")` for the native
vector envs, whose `step` advances every robot in Rust).
`gymnasium.make("twip.envs:twip/Balance-v0")` imports it first. `check_vector_env`
checks any Gymnasium vector env."""
from __future__ import annotations

import gymnasium

from twip.envs.balance import DEFAULT_INIT, DEFAULT_REWARD, BalanceEnv, BalanceVectorEnv
from twip.envs.checker import VectorEnvCheckError, check_vector_env
from twip.envs.robots import DEFAULT_MAX_EPISODE_STEPS, ClosedEnvError
from twip.envs.track import TrackEnv, TrackVectorEnv

__all__ = [
    "BalanceEnv",
    "BalanceVectorEnv",
    "ClosedEnvError",
    "DEFAULT_INIT",
    "DEFAULT_MAX_EPISODE_STEPS",
    "DEFAULT_REWARD",
    "TrackEnv",
    "TrackVectorEnv",
    "VectorEnvCheckError",
    "check_vector_env",
    "register_envs",
]

#: id -> (entry point, vector entry point).
ENVS = {
    "twip/Balance-v0": ("twip.envs.balance:gymnasium_balance_env", "twip.envs.balance:BalanceVectorEnv"),
    "twip/Track-v0": ("twip.envs.track:gymnasium_track_env", "twip.envs.track:TrackVectorEnv"),
}


def register_envs() -> None:
    """Registers twip's envs with Gymnasium (once; also Gymnasium's entry point), with their
    step limit: `gymnasium.make` keeps `max_episode_steps` for its `TimeLimit` (the
    registration's, or its own argument: -1 for none), and `make_vec` hands it to the
    vector env."""
    for env_id, (entry, vector_entry) in ENVS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(env_id, entry_point=entry, vector_entry_point=vector_entry,
                               max_episode_steps=DEFAULT_MAX_EPISODE_STEPS)


register_envs()
