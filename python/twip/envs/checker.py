"""`check_vector_env`: what Gymnasium's `check_env` does for a single env, for a vector env
(Gymnasium has none): spaces and dtypes, the dict-of-arrays infos, the declared autoreset
mode's semantics, seeding (the same seed, the same bits), and that lane i is the single
env seeded with lane i's seed and driven with lane i's actions."""
from __future__ import annotations

from typing import Callable, Optional

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from twip import _core, checks

#: The most steps a check rolls out: it keeps every step's arrays, twice (10**12 grew a
#: list until memory ran out).
MAX_CHECK_STEPS = 100_000


class VectorEnvCheckError(AssertionError):
    """A vector env breaks Gymnasium's vector-env contract; the message says where."""


def _require(ok: bool, what: str):
    if not ok:
        raise VectorEnvCheckError(what)


def _count(name: str, value, low: int, high: int) -> int:
    """`value` as an int in [low, high] (numpy ints too, not a bool), or an error naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if not low <= value <= high:
        raise _core.InvalidParameterError(f"{name} = {value!r}: must be from {low} to {high}")
    return int(value)


def _check_spaces(env: VectorEnv):
    _require(isinstance(env, VectorEnv), f"not a gymnasium.vector.VectorEnv: {type(env).__name__}")
    n = env.num_envs
    _require(isinstance(n, int) and n >= 1, f"num_envs = {n!r}: must be an int >= 1")
    _require(env.observation_space == batch_space(env.single_observation_space, n),
             "observation_space is not batch_space(single_observation_space, num_envs)")
    _require(env.action_space == batch_space(env.single_action_space, n),
             "action_space is not batch_space(single_action_space, num_envs)")
    mode = env.metadata.get("autoreset_mode")
    _require(isinstance(mode, AutoresetMode), f"metadata['autoreset_mode'] = {mode!r}: must be an AutoresetMode")
    return n, mode


def _check_obs(env, obs, where):
    space = env.observation_space
    _require(isinstance(obs, np.ndarray) and obs.dtype == space.dtype and obs.shape == space.shape,
             f"{where}: observations of dtype {getattr(obs, 'dtype', type(obs))} and shape "
             f"{getattr(obs, 'shape', None)}, the space says {space.dtype} {space.shape}")
    _require(space.contains(obs), f"{where}: observations outside observation_space")


def _check_infos(infos, n, where):
    _require(isinstance(infos, dict), f"{where}: infos is a {type(infos).__name__}, not a dict")
    for key, value in infos.items():
        if key.startswith("_"):
            _require(key[1:] in infos, f"{where}: mask {key} without its key")
            continue
        mask = infos.get("_" + key)
        _require(isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == (n,),
                 f"{where}: infos[{key!r}] has no bool mask '_{key}' of shape ({n},)")
        if isinstance(value, dict):
            _check_infos(value, n, f"{where}: infos[{key!r}]")
        else:
            _require(isinstance(value, np.ndarray) and value.shape[:1] == (n,),
                     f"{where}: infos[{key!r}] is not an array of {n} rows (dict-of-arrays)")


def _rollout(env, n, mode, seed, steps):
    """Every step's (actions, obs, rewards, terminated, truncated, infos, reset mask)."""
    env.action_space.seed(seed)
    obs, infos = env.reset(seed=seed)
    _check_obs(env, obs, "reset")
    _check_infos(infos, n, "reset")
    record = {"obs0": obs, "steps": []}
    done = np.zeros(n, dtype=np.bool_)
    for k in range(steps):
        where = f"step {k}"
        reset_mask = None
        if mode == AutoresetMode.DISABLED and done.any():
            reset_mask = done.copy()
            before = obs.copy()
            obs, infos = env.reset(options={"reset_mask": reset_mask})
            _require(np.array_equal(obs[~reset_mask], before[~reset_mask]),
                     f"{where}: reset(options={{'reset_mask': ...}}) changed envs outside the mask")
        actions = env.action_space.sample()
        obs, rewards, terminated, truncated, infos = env.step(actions)
        _check_obs(env, obs, where)
        _check_infos(infos, n, where)
        for name, a in (("terminated", terminated), ("truncated", truncated)):
            _require(isinstance(a, np.ndarray) and a.dtype == np.bool_ and a.shape == (n,),
                     f"{where}: {name} must be a bool array of shape ({n},)")
        _require(isinstance(rewards, np.ndarray) and rewards.shape == (n,) and rewards.dtype.kind == "f",
                 f"{where}: rewards must be a float array of shape ({n},)")
        if mode == AutoresetMode.NEXT_STEP:
            _require(not (terminated[done] | truncated[done]).any() and not rewards[done].any(),
                     f"{where}: NEXT_STEP: an env done at the last step must start anew: reward 0, not done")
        if mode == AutoresetMode.SAME_STEP:
            now = terminated | truncated
            if now.any():
                mask = infos.get("_final_obs")
                _require(mask is not None and np.array_equal(mask, now),
                         f"{where}: SAME_STEP: infos['final_obs'] must be given for exactly the envs done")
        done = terminated | truncated
        record["steps"].append((actions, obs, rewards, terminated, truncated, infos, reset_mask))
    return record


def _same(a, b) -> bool:
    return np.array_equal(np.asarray(a), np.asarray(b))


def _check_lane(record, mode, lane, single, seed):
    """Lane `lane` of the rollout replayed on the single env."""
    obs, _ = single.reset(seed=seed + lane)
    _require(_same(obs, record["obs0"][lane]), f"lane {lane}: reset differs from the single env seeded {seed + lane}")
    done = False
    for k, (actions, v_obs, v_rew, v_term, v_trunc, infos, reset_mask) in enumerate(record["steps"]):
        where = f"lane {lane}, step {k}"
        if mode == AutoresetMode.DISABLED and reset_mask is not None and reset_mask[lane]:
            single.reset()
            done = False
        if mode == AutoresetMode.NEXT_STEP and done:
            obs, rew, term, trunc = single.reset()[0], 0.0, False, False
        else:
            obs, rew, term, trunc, _ = single.step(actions[lane])
        if mode == AutoresetMode.SAME_STEP and (term or trunc):
            _require(_same(infos["final_obs"][lane], obs), f"{where}: final_obs differs from the single env's")
            obs = single.reset()[0]
        _require(_same(obs, v_obs[lane]), f"{where}: observation differs from the single env's")
        _require(_same(rew, v_rew[lane]) and term == v_term[lane] and trunc == v_trunc[lane],
                 f"{where}: reward/terminated/truncated differ from the single env's")
        done = term or trunc


def check_vector_env(env: VectorEnv, *, seed: int = 0, steps: int = 300,
                     single: Optional[Callable[[int], object]] = None, lanes=None) -> None:
    """Checks `env` against Gymnasium's vector-env contract; raises `VectorEnvCheckError`
    (a bad `steps`, at most MAX_CHECK_STEPS, or `lanes` is a TypeError or an
    InvalidParameterError naming it, before any step).

    Two rollouts of `steps` random actions (the action space seeded with `seed`) must give
    the same bits. `single(i)` makes the single env for lane i (default: `env.single_env()`
    when the env has it); lanes `lanes` (default: the first and last) are replayed on it
    and must agree bit for bit, through every autoreset. Leaves `env` reset."""
    n, mode = _check_spaces(env)
    steps = _count("steps", steps, 1, MAX_CHECK_STEPS)
    if lanes is not None:
        checks.of_type("lanes", lanes, (list, tuple, range, np.ndarray), "a list of lane indices or None")
        lanes = [_count(f"lanes[{i}]", lane, 0, n - 1) for i, lane in enumerate(lanes)]
    first = _rollout(env, n, mode, seed, steps)
    again = _rollout(env, n, mode, seed, steps)
    for k, (a, b) in enumerate(zip(first["steps"], again["steps"])):
        _require(all(_same(x, y) for x, y in zip(a[1:5], b[1:5])), f"step {k}: the same seed gave different results")
    if not any(s[3].any() or s[4].any() for s in first["steps"]):
        raise VectorEnvCheckError(f"no env ended in {steps} random steps: autoreset was not exercised (raise steps)")
    if single is None and hasattr(env, "single_env"):
        single = lambda i: env.single_env()  # noqa: E731
    if single is not None:
        for lane in (lanes if lanes is not None else sorted({0, n - 1})):
            one = single(lane)
            try:
                _check_lane(first, mode, lane, one, seed)
            finally:
                one.close()
    env.reset(seed=seed)
