"""The Gymnasium side of every twip env, over a native batch of robots: the single env
(one robot) and the vector env (N robots one `step` advances together in Rust), with the
step limit, seeding, the three autoreset modes and the dict-of-arrays infos. An env
module gives a `Settings` subclass whose `batch(n)` makes the native batch,
`observation_space`, `action_width` and `rewards(batch, actions)`."""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import gymnasium
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from twip import checks
from twip._core import InvalidParameterError
from twip.envs.robots import ClosedEnvError, check_actions, num_envs_checked, seeds_for


def render_mode_checked(render_mode):
    """None, the one render mode (Gymnasium's `make` and `make_vec` hand it to every env they
    make), or a named error: the robots render nothing."""
    if render_mode is not None:
        raise InvalidParameterError(f"render_mode = {render_mode!r}: twip's envs render nothing "
                                    "(metadata['render_modes'] is empty); use None")
    return None


def options_checked(options, known: tuple) -> Mapping:
    """`reset`'s options: a dict of the keys `known`, or None; else a named error (a key
    misspelt was ignored: `reset_masks` reset every lane)."""
    options = checks.of_type("options", {} if options is None else options, Mapping, "a dict or None")
    unknown = [k for k in options if k not in known]
    if unknown:
        takes = f"the keys it takes are {list(known)}" if known else "it takes none"
        raise InvalidParameterError(f"options: unknown key {unknown[0]!r}; {takes}")
    return options


class Episodes:
    """The batch, the step counts and the closed flag of N robots."""

    def __init__(self, settings, num_envs: int):
        self.settings = settings
        self.n = num_envs_checked(num_envs, rig=settings.realism is not None)
        self.batch = settings.batch(self.n)
        self.steps = np.zeros(self.n, dtype=np.int64)
        self.closed = False

    def check_open(self):
        if self.closed:
            raise ClosedEnvError("the env is closed: make a new one to step or reset")

    def reset(self, lanes: np.ndarray, seeds=None):
        """Starts lanes `lanes` (indices or a mask) anew: with `seeds` (one per lane; None for
        a lane whose stream goes on) episode 0 of its seed, else each lane's next episode."""
        self.check_open()
        lanes = [int(i) for i in (np.flatnonzero(lanes) if lanes.dtype == np.bool_ else lanes)]
        if seeds is None or None not in seeds:
            self.batch.reset(lanes, seeds)
        else:
            self.batch.reset([i for i, s in zip(lanes, seeds) if s is not None], [s for s in seeds if s is not None])
            self.batch.reset([i for i, s in zip(lanes, seeds) if s is None])
        self.steps[lanes] = 0

    def step(self, actions):
        """(rewards, terminated, truncated) of every robot after one step."""
        self.check_open()
        a = check_actions(actions, self.n, self.settings.action_width, self.settings.action_bound)
        terminated = self.batch.step(a)
        self.steps += 1
        rewards = self.settings.rewards(self.batch, a.reshape(self.n, -1))
        return rewards, terminated, self.truncated(terminated)

    def truncated(self, terminated: np.ndarray) -> np.ndarray:
        """The robots at the step limit that did not terminate (none without a limit)."""
        limit = self.settings.max_episode_steps
        return (self.steps >= limit) & ~terminated if limit is not None else np.zeros(self.n, dtype=np.bool_)


class SingleEnv(gymnasium.Env):
    """One robot. Subclasses set `settings_class`."""

    metadata = {"render_modes": []}
    settings_class = None

    def __init__(self, render_mode=None, **kwargs):
        self.render_mode = render_mode_checked(render_mode)
        self.settings = self.settings_class(**kwargs)
        self.observation_space = self.settings.single_observation_space
        self.action_space = self.settings.single_action_space
        self._episodes = Episodes(self.settings, 1)
        self._seeded = False

    def reset(self, *, seed=None, options=None):
        options_checked(options, ())
        super().reset(seed=seed)
        seeds = None
        if seed is not None or not self._seeded:
            seeds = seeds_for(seed, 1)
            self._seeded = True
        self._episodes.reset(np.array([0]), seeds)
        return self._obs(), self._info()

    def step(self, action):
        rewards, terminated, truncated = self._episodes.step(action)
        return self._obs(), float(rewards[0]), bool(terminated[0]), bool(truncated[0]), self._info()

    def _obs(self):
        return self._episodes.batch.observations()[0]

    def _info(self):
        return {"state": self._episodes.batch.states()[0]}

    def close(self):
        self._episodes.closed = True


def made_by_gymnasium(cls, **kwargs):
    """`cls` for `gymnasium.make`, without a step limit of its own: make keeps the argument
    `max_episode_steps` for the `TimeLimit` it wraps the env in (the registration's
    DEFAULT_MAX_EPISODE_STEPS unless told otherwise). With the env's own default under it, a
    limit asked of make above 2000 steps was cut to 2000, and None (-1) never lifted it."""
    return cls(**{"max_episode_steps": None, **kwargs})


class BatchVectorEnv(VectorEnv):
    """`num_envs` robots stepped together in Rust; `autoreset_mode`: NEXT_STEP (default),
    SAME_STEP or DISABLED. Subclasses set `settings_class` and `single_class`."""

    settings_class = None
    single_class = None

    def __init__(self, num_envs: int = 1, autoreset_mode=AutoresetMode.NEXT_STEP, render_mode=None, **kwargs):
        self.render_mode = render_mode_checked(render_mode)
        self.settings = self.settings_class(**kwargs)
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise InvalidParameterError(f"autoreset_mode = {autoreset_mode!r}: must be one of {[m.value for m in AutoresetMode]}") from None
        self._episodes = Episodes(self.settings, num_envs)
        self.num_envs = self._episodes.n
        self.metadata = {"autoreset_mode": mode, "render_modes": []}
        self.single_observation_space = self.settings.single_observation_space
        self.single_action_space = self.settings.single_action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._done = np.zeros(self.num_envs, dtype=np.bool_)
        self._seeded = False

    def single_env(self):
        """A single env with this one's settings (lane i: seed it with lane i's seed)."""
        return self.single_class(**self.settings.kwargs)

    def reset(self, *, seed=None, options=None):
        options = options_checked(options, ("reset_mask",))
        # Gymnasium's VectorEnv seeds its own np_random from an int only; a list seeds lanes.
        super().reset(seed=None if isinstance(seed, (list, tuple, np.ndarray)) else seed)
        self._episodes.check_open()
        mask = np.ones(self.num_envs, dtype=np.bool_)
        if "reset_mask" in options:
            mask = options["reset_mask"]
            if not (isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == (self.num_envs,)):
                shape = getattr(mask, "shape", None)
                raise InvalidParameterError(f"options['reset_mask']: expected a bool array of shape ({self.num_envs},), got "
                           f"{type(mask).__name__} of shape {shape}")
        seeds = None
        if seed is not None or not self._seeded:
            lane_seeds = seeds_for(seed, self.num_envs)
            if not self._seeded:  # a lane not started yet has no stream to go on: a fresh seed
                lane_seeds = [f if s is None else s for s, f in zip(lane_seeds, seeds_for(None, self.num_envs))]
            seeds = [s for s, m in zip(lane_seeds, mask) if m]
            self._seeded = True
        self._episodes.reset(mask, seeds)
        self._done[mask] = False
        return self._episodes.batch.observations(), self._info(mask)

    def step(self, actions):
        mode = self.metadata["autoreset_mode"]
        if mode == AutoresetMode.NEXT_STEP:
            return self._step_next(actions)
        if mode == AutoresetMode.DISABLED and self._done.any():
            raise InvalidParameterError(f"autoreset_mode DISABLED: envs {np.flatnonzero(self._done).tolist()} are done; "
                       "reset them first with reset(options={'reset_mask': ...})")
        rewards, terminated, truncated = self._episodes.step(actions)
        infos = self._info()
        done = terminated | truncated
        obs = self._episodes.batch.observations()
        if mode == AutoresetMode.SAME_STEP and done.any():
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(done):
                final_obs[i] = obs[i].copy()
            infos["final_obs"], infos["_final_obs"] = final_obs, done.copy()
            # The envs not done have no final info: zeros under a False mask, as Gymnasium's.
            final = {"state": np.where(done[:, None], infos["state"], 0.0), "_state": done.copy()}
            infos["final_info"], infos["_final_info"] = final, done.copy()
            self._episodes.reset(done)
            obs = self._episodes.batch.observations()
            infos["state"] = self._episodes.batch.states()
            done = np.zeros(self.num_envs, dtype=np.bool_)
        self._done = done
        return obs, rewards, terminated, truncated, infos

    def _step_next(self, actions):
        """A NEXT_STEP step as `step`'s general path takes it (step, rewards, the envs done at
        the last step started anew, states, observations), made by the batch in one trip to
        its threads: each native call was a trip of its own (~10-15 us of CPU each)."""
        episodes = self._episodes
        episodes.check_open()
        a = check_actions(actions, self.num_envs, self.settings.action_width, self.settings.action_bound)
        again = np.flatnonzero(self._done)
        terminated, rewards, states, obs = self.settings.step_next(episodes.batch, a, again.tolist())
        episodes.steps += 1  # after the native step: a refused step moves nothing
        truncated = episodes.truncated(terminated)
        if again.size:
            # The envs done at the last step started anew instead of stepping.
            episodes.steps[again] = 0
            rewards[again] = 0.0
            terminated[again] = False
            truncated[again] = False
        self._done = terminated | truncated
        return obs, rewards, terminated, truncated, {"state": states, "_state": np.ones(self.num_envs, dtype=np.bool_)}

    def _info(self, lanes=None):
        """The infos of every env, or (a reset's) of the envs `lanes` (a mask): the others'
        rows zeros under a False mask, as Gymnasium's vector envs give them."""
        states = self._episodes.batch.states()
        if lanes is None or lanes.all():
            return {"state": states, "_state": np.ones(self.num_envs, dtype=np.bool_)}
        states[~lanes] = 0.0
        return {"state": states, "_state": lanes.copy()}

    def close_extras(self, **kwargs):
        self._episodes.closed = True
