"""Augmented random search (Mania et al. 2018, ARS V1-t) in NumPy trains a linear balancing
policy on twip/Balance-v0's vector env with the thesis-like rig on (sensor readings in,
PWM duty out, delay, noise, friction, backlash, robots drawn per episode), then runs the
policy through `twip.simulate` and a `twip.montecarlo` sweep like any controller.

    python examples/ars_balance.py [--iterations 40] [--threads 2] [--sweep 200]

docs/envs.md records its time and the policy's fall rate.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import gymnasium

import twip
from twip import envs  # noqa: F401  (registers twip/Balance-v0)
from twip.envs.policy import LinearPolicy
from twip.scenarios.registry import Scenario

REALISM = twip.Realism.thesis_like()
PERTURB = {"m_body": twip.Uniform(rel=0.1), "com_height": twip.Uniform(rel=0.1), "phi0": twip.Uniform(abs=0.1)}
EPISODE_STEPS = 400  # 2 s at the rig's 5 ms loop
#: The policy learns in scaled units: duty = 255 · M · (observation / OBS_SCALE), so that the
#: exploration noise is alike in every direction.
OBS_SCALE = np.array([0.1, 1.0, 1.0, 10.0])  # [rad, rad/s, rad, rad/s]
DUTY = 255.0


def returns(env, gains: np.ndarray, seed: int) -> np.ndarray:
    """Each lane's return over its first episode, lane i driven by gains[i]."""
    obs, _ = env.reset(seed=seed)
    total = np.zeros(env.num_envs)
    alive = np.ones(env.num_envs, dtype=bool)
    for _ in range(EPISODE_STEPS):
        actions = np.einsum("ij,ij->i", gains, obs)[:, None]
        obs, reward, terminated, truncated, _ = env.step(np.clip(actions, -DUTY, DUTY))
        total += np.where(alive, reward, 0.0)
        alive &= ~(terminated | truncated)
        if not alive.any():
            break
    return total


def train(iterations: int, directions: int, top: int, step: float, noise: float, threads: int, seed: int):
    env = gymnasium.make_vec("twip/Balance-v0", num_envs=2 * directions, vectorization_mode="vector_entry_point",
                             realism=REALISM, perturb=PERTURB, max_episode_steps=EPISODE_STEPS, threads=threads)
    rng = np.random.default_rng(seed)
    theta = np.zeros(4)
    history = []
    for it in range(iterations):
        deltas = rng.standard_normal((directions, 4))
        gains = np.concatenate([theta + noise * deltas, theta - noise * deltas]) * (DUTY / OBS_SCALE)
        r = returns(env, gains, seed=seed + 1000 * it)
        plus, minus = r[:directions], r[directions:]
        best = np.argsort(np.maximum(plus, minus))[-top:]
        sigma = np.concatenate([plus[best], minus[best]]).std() + 1e-8
        theta = theta + step / (top * sigma) * ((plus[best] - minus[best]) @ deltas[best])
        history.append(float(np.mean(r)))
        print(f"iteration {it:3d}: mean return {history[-1]:7.1f} of {EPISODE_STEPS}")
    env.close()
    return theta * DUTY / OBS_SCALE, history


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iterations", type=int, default=40)
    ap.add_argument("--directions", type=int, default=32)
    ap.add_argument("--top", type=int, default=16)
    ap.add_argument("--step", type=float, default=0.3)
    ap.add_argument("--noise", type=float, default=0.5)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sweep", type=int, default=200, help="Monte Carlo samples")
    args = ap.parse_args()
    start = time.perf_counter()
    theta, _ = train(args.iterations, args.directions, args.top, args.step, args.noise, args.threads, args.seed)
    trained = time.perf_counter() - start
    print(f"trained in {trained:.1f} s: duty = {np.array2string(theta, precision=2)} . [phi, phi_dot, theta, theta_dot]")

    model = twip.SlopeModel(twip.RobotParams.balanbot())
    policy = LinearPolicy(theta, period=5e-3, realism=REALISM, params=model.params)
    run = twip.simulate(model, policy, np.array([0.08, 0.0, 0.0, 0.0]), t_final=10.0, dt=1e-3, realism=REALISM)
    print(f"twip.simulate, 10 s through the rig from phi0 = 0.08 rad: outcome {run.outcome}, "
          f"max |phi| after 1 s = {np.abs(run.states[1000:, 0]).max():.4f} rad")

    scenario = Scenario(name="ars-balance", description="the ARS policy balancing", model=model, controller=policy,
                        x0=np.zeros(4), reference=twip.SpeedSchedule.constant(0.0), t_final=5.0)
    sweep = twip.montecarlo(scenario, args.sweep, perturb=PERTURB, seed=1, realism=REALISM)
    print(f"twip.montecarlo, {args.sweep} robots x 5 s through the rig: fall rate {sweep.fall_rate:.3f}")


if __name__ == "__main__":
    main()
