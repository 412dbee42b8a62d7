"""Env-steps per second of twip's native vector envs (Balance-v0, and Track-v0) at N robots,
on the ideal plant and through the thesis-like rig, beside Gymnasium's own NumPy
`CartPoleVectorEnv`, measured in one run, alternating, so that the ratios hold on a loaded
machine.

    python benches/envs.py [--num-envs 4096] [--threads 2] [--steps 200] [--rounds 5]

Each step is `env.step` through Gymnasium's API (NEXT_STEP autoreset, rewards, infos) with
a fixed action batch; twip's step is one 5 ms control period, five RK4 steps of 1 ms.
Prints the median env-steps/s of each and the ratios, and which kernel copy ran."""
from __future__ import annotations

import argparse
import time

import numpy as np
from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv

import twip
from twip import envs


def rate(env, actions, steps: int) -> float:
    env.reset(seed=0)
    start = time.perf_counter()
    for _ in range(steps):
        env.step(actions)
    return env.num_envs * steps / (time.perf_counter() - start)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--num-envs", type=int, default=4096)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    n = args.num_envs
    # A small stabilising-free action: the robots fall and start anew now and then.
    benches = {
        "twip Balance-v0 ideal": (envs.BalanceVectorEnv(n, threads=args.threads), np.zeros((n, 1))),
        "twip Balance-v0 rig": (envs.BalanceVectorEnv(n, realism=twip.Realism.thesis_like(), threads=args.threads),
                     np.zeros((n, 1))),
        "twip Track-v0 ideal": (envs.TrackVectorEnv(n, threads=args.threads), np.zeros((n, 2))),
        "twip Track-v0 rig": (envs.TrackVectorEnv(n, realism=twip.Realism.thesis_like(), threads=args.threads),
                              np.zeros((n, 2))),
        "gymnasium CartPoleVectorEnv": (CartPoleVectorEnv(num_envs=n), np.ones(n, dtype=np.int64)),
    }
    rates = {name: [] for name in benches}
    for _ in range(args.rounds):
        for name, (env, actions) in benches.items():
            rates[name].append(rate(env, actions, args.steps))
    median = {name: float(np.median(r)) for name, r in rates.items()}
    print(f"N = {n}, {args.threads} threads (CartPole: one NumPy thread), kernel copy {twip.kernel_copy()}, "
          f"{args.rounds} alternating rounds of {args.steps} steps, median:")
    cartpole = median["gymnasium CartPoleVectorEnv"]
    for name, r in median.items():
        print(f"  {name:30s} {r / 1e6:7.2f} M env-steps/s   {r / cartpole:5.2f}x CartPole")


if __name__ == "__main__":
    main()
