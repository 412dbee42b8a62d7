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


def test_sb3_check_env_passes_and_ppo_runs_on_the_adapter():
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_checker import check_env
    from stable_baselines3.common.vec_env import VecCheckNan, VecMonitor
    from twip.envs import BalanceEnv
    from twip.envs.sb3 import SB3VecEnv

    check_env(BalanceEnv(max_episode_steps=50), warn=True)
    env = VecMonitor(VecCheckNan(SB3VecEnv(4, max_episode_steps=50), raise_exception=True))
    env.seed(0)
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=128, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=512)
    assert model.num_timesteps >= 512
    # Episodes ended (falls or the 50-step limit) and were reported through the monitor.
    assert len(model.ep_info_buffer) > 0
    env.close()
