"""The Stable-Baselines3 adapter, when SB3 is installed (not part of `make test`)."""
import numpy as np
import pytest

pytest.importorskip("gymnasium")
sb3 = pytest.importorskip("stable_baselines3")


def test_sb3_checks_and_steps_the_adapter():
    from stable_baselines3.common.vec_env.util import obs_space_info  # noqa: F401
    from twip.envs.sb3 import SB3VecEnv

    env = SB3VecEnv(8, max_episode_steps=20)
    env.seed(3)
    obs = env.reset()
    assert obs.shape == (8, 4)
    ended = 0
    for _ in range(45):
        obs, rewards, dones, infos = env.step(np.zeros((8, 1)))
        assert rewards.shape == (8,) and len(infos) == 8
        for i in np.flatnonzero(dones):
            assert infos[i]["terminal_observation"].shape == (4,)
            ended += 1
    assert ended >= 16  # every env truncated at 20 and 40 steps
    env.close()
