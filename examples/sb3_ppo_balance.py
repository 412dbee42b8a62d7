"""A short PPO run of Stable-Baselines3 on the SB3 adapter (Balance-v0, ideal plant), after
SB3's own `check_env` on the single env; needs stable-baselines3 (and so torch).

    python examples/sb3_ppo_balance.py [total_timesteps]

Prints the mean return of 32 deterministic episodes before and after training."""
import sys
import time
import stable_baselines3, torch
from stable_baselines3 import PPO
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.vec_env import VecCheckNan, VecMonitor
from stable_baselines3.common.evaluation import evaluate_policy
from twip.envs import BalanceEnv
from twip.envs.sb3 import SB3VecEnv

print("stable-baselines3", stable_baselines3.__version__, "torch", torch.__version__)
check_env(BalanceEnv(max_episode_steps=200), warn=True)
print("SB3 check_env(BalanceEnv): passed")
torch.set_num_threads(1)
env = VecMonitor(VecCheckNan(SB3VecEnv(16, max_episode_steps=200), raise_exception=True))
env.seed(0)
model = PPO("MlpPolicy", env, n_steps=256, batch_size=512, seed=0, verbose=0, device="cpu")
before = evaluate_policy(model, env, n_eval_episodes=32, deterministic=True)
t = time.perf_counter()
model.learn(total_timesteps=int(sys.argv[1]) if len(sys.argv) > 1 else 8192)
dt = time.perf_counter() - t
after = evaluate_policy(model, env, n_eval_episodes=32, deterministic=True)
print(f"PPO: {model.num_timesteps} steps in {dt:.1f} s; mean return over 32 episodes (of at most 200): "
      f"before {before[0]:.1f} +- {before[1]:.1f}, after {after[0]:.1f} +- {after[1]:.1f}")
