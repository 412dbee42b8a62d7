"""twip.envs: Gymnasium's checker and ours on Balance-v0 (ideal plant and the rig, every
autoreset mode), parity with twip.simulate, seeding, and the named errors."""
import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import twip  # noqa: E402
from twip import envs  # noqa: E402
from twip.envs.checker import VectorEnvCheckError  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402
from gymnasium.vector import AutoresetMode  # noqa: E402

RIG = twip.Realism.thesis_like()
PERTURB = {"m_body": twip.Uniform(rel=0.1), "phi0": twip.Uniform(abs=0.15)}


@pytest.mark.parametrize("realism", [None, RIG], ids=["ideal", "rig"])
def test_gymnasium_check_env_passes_on_the_single_env(realism):
    env = gymnasium.make("twip/Balance-v0", realism=realism, perturb=PERTURB)
    check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("mode", list(AutoresetMode))
@pytest.mark.parametrize("realism", [None, RIG], ids=["ideal", "rig"])
def test_our_vector_checker_passes_in_every_autoreset_mode(realism, mode):
    env = gymnasium.make_vec("twip/Balance-v0", num_envs=21, vectorization_mode="vector_entry_point",
                             autoreset_mode=mode, realism=realism, perturb=PERTURB, max_episode_steps=40)
    assert isinstance(env, envs.BalanceVectorEnv) and env.metadata["autoreset_mode"] == mode
    envs.check_vector_env(env, seed=3, steps=120, lanes=[0, 7, 20])


def test_the_checker_catches_a_lane_that_is_not_the_single_env():
    env = envs.BalanceVectorEnv(num_envs=4, perturb=PERTURB, max_episode_steps=30)
    other = {**PERTURB, "m_body": twip.Uniform(rel=0.3)}
    with pytest.raises(VectorEnvCheckError, match="lane 0"):
        envs.check_vector_env(env, steps=60, single=lambda i: envs.BalanceEnv(perturb=other, max_episode_steps=30))


def test_the_checker_catches_a_broken_next_step_autoreset():
    class NoAutoreset(envs.BalanceVectorEnv):
        def step(self, actions):
            self._done[:] = False  # never starts a done env anew
            return super().step(actions)

    with pytest.raises(VectorEnvCheckError, match="NEXT_STEP"):
        envs.check_vector_env(NoAutoreset(num_envs=3, max_episode_steps=20), steps=60)


class _Broken(envs.BalanceVectorEnv):
    """A Balance-v0 vector env with one flaw, for the checker to find."""

    def __init__(self, flaw, **kwargs):
        super().__init__(num_envs=3, max_episode_steps=20, **kwargs)
        self.flaw = flaw

    def step(self, actions):
        obs, rewards, terminated, truncated, infos = super().step(actions)
        if self.flaw == "list infos":
            infos = [{"state": s} for s in infos["state"]]
        elif self.flaw == "float32 obs":
            obs = obs.astype(np.float32)
        elif self.flaw == "unseeded":
            obs = obs + np.random.default_rng().normal(0.0, 1e-12, obs.shape)
        elif self.flaw == "int terminated":
            terminated = terminated.astype(np.int8)
        return obs, rewards, terminated, truncated, infos


@pytest.mark.parametrize("flaw, message", [("list infos", "infos is a list"), ("float32 obs", "float32"),
                                           ("unseeded", "same seed"), ("int terminated", "terminated")])
def test_the_checker_catches_a_broken_env(flaw, message):
    with pytest.raises(VectorEnvCheckError, match=message):
        envs.check_vector_env(_Broken(flaw), steps=60)


def _lqr(model):
    gains, *_ = twip.lqr(*model.linearize(np.zeros(4), 0.0), np.diag([10.0, 10.0, 1.0, 1.0]), np.array([[100.0]]))
    return np.asarray(gains).reshape(4)


class Replay:
    """A Python controller for twip.simulate that replays the env's actions."""

    def __init__(self, actions, period):
        self.actions, self.period, self.k = list(actions), period, 0

    def update(self, t, y, ref):
        self.k += 1
        return self.actions[self.k - 1]


@pytest.mark.parametrize("realism", [None, twip.Realism.thesis_like().replace(motor=None)], ids=["ideal", "rig"])
def test_a_lane_is_twip_simulate_with_the_same_inputs(realism):
    x0 = np.array([0.05, 0.0, 0.0, 0.0])
    perturb = {"phi0": twip.Uniform(low=0.05, high=0.05)}
    venv = envs.BalanceVectorEnv(num_envs=5, realism=realism, perturb=perturb, slope=0.03)
    obs, _ = venv.reset(seed=11)
    model = twip.SlopeModel(twip.RobotParams.balanbot(), 0.03)
    k = _lqr(model)
    actions, states = [], []
    for _ in range(300):
        a = -(obs @ k)
        actions.append(a[3])
        obs, _, term, trunc, info = venv.step(a[:, None])
        assert not term.any()
        states.append(info["state"][3])
    if realism is not None:
        realism = realism.replace(seed=twip._core.sweep_noise_seed(14), stream=0)
    run = twip.simulate(model, Replay(actions, 5e-3), x0, t_final=1.5, dt=1e-3, realism=realism)
    want = run.states[5::5][:300]
    got = np.array(states)
    # Fused lanes against the runner's separate roundings, replayed open loop.
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-10)


def test_reset_takes_a_seed_per_lane_as_gymnasiums_sync_vector_env_does():
    # A list of seeds (None: that lane's stream goes on) raised gymnasium.error.Error.
    kw = dict(max_episode_steps=30, perturb=PERTURB)
    vec = envs.BalanceVectorEnv(num_envs=4, **kw)
    sync = gymnasium.vector.SyncVectorEnv([lambda: envs.BalanceEnv(**kw) for _ in range(4)])
    rng = np.random.default_rng(0)
    for seed in (5, [7, None, 2, None], (1, 2, 3, 4), [None, None, 0, 2**64 - 1]):
        obs, _ = vec.reset(seed=seed)
        assert np.array_equal(obs, sync.reset(seed=list(seed) if isinstance(seed, tuple) else seed)[0])
        for _ in range(40):
            a = rng.uniform(-4.0, 4.0, (4, 1))
            for got, want in zip(vec.step(a)[:4], sync.step(a)[:4]):
                assert np.array_equal(got, want)
    assert np.array_equal(vec.reset(seed=np.array([1, 2, 3, 4]))[0], vec.reset(seed=[1, 2, 3, 4])[0])
    with pytest.raises(twip.InvalidParameterError, match=r"seed: a list of 3 seeds for 4 envs"):
        vec.reset(seed=[1, 2, 3])
    with pytest.raises(twip.InvalidParameterError, match=r"seed\[1\] = -1"):
        vec.reset(seed=[1, -1, 3, 4])
    with pytest.raises(twip.InvalidParameterError, match=r"the last lane's seed, seed \+ 3, passes 2\*\*64 - 1"):
        vec.reset(seed=2**64 - 2)


def _same_outputs(got, want, where):
    if isinstance(want, tuple):
        assert len(got) == len(want), where
        for i, (x, y) in enumerate(zip(got, want)):
            _same_outputs(x, y, f"{where}[{i}]")
    elif isinstance(want, dict):
        assert sorted(got) == sorted(want), where
        for key in want:
            _same_outputs(got[key], want[key], f"{where}[{key!r}]")
    elif isinstance(want, np.ndarray) and want.dtype == object:
        assert [x is None for x in got] == [x is None for x in want], where
        for x, y in zip(got, want):
            if y is not None:
                _same_outputs(x, y, where)
    else:
        assert got.dtype == np.asarray(want).dtype and np.array_equal(got, want), where


@pytest.mark.parametrize("mode", list(AutoresetMode))
@pytest.mark.parametrize("vector, single", [(envs.BalanceVectorEnv, envs.BalanceEnv), (envs.TrackVectorEnv, envs.TrackEnv)],
                         ids=["balance", "track"])
def test_the_vector_env_is_gymnasiums_sync_vector_env_of_the_single_env(vector, single, mode):
    """Every output, infos included, bit for bit, through falls, time limits and resets by
    mask. The infos' rows under a False mask were the states (final_info of the envs not
    done, a masked reset's envs not reset), where Gymnasium gives zeros."""
    kw = dict(max_episode_steps=50, perturb={"m_body": twip.Uniform(rel=0.1), "phi0": twip.Uniform(abs=0.1)})
    n = 4
    vec = vector(num_envs=n, autoreset_mode=mode, **kw)
    sync = gymnasium.vector.SyncVectorEnv([lambda: single(**kw) for _ in range(n)], autoreset_mode=mode)
    high = vec.single_action_space.high
    rng = np.random.default_rng(2)
    _same_outputs(vec.reset(seed=4), sync.reset(seed=4), "reset")
    done, ends = np.zeros(n, dtype=bool), 0
    for k in range(130):
        if mode == AutoresetMode.DISABLED and done.any():
            _same_outputs(vec.reset(options={"reset_mask": done.copy()}), sync.reset(options={"reset_mask": done.copy()}),
                          f"reset by mask before step {k}")
        a = rng.uniform(-0.5, 0.5, (n, len(high))) * high
        a[0] = high  # pushed over: terminations; the others mostly reach the limit
        got, want = vec.step(a), sync.step(a)
        _same_outputs(got, want, f"step {k}")
        done = got[2] | got[3]
        ends += done.sum()
    assert ends >= 6


def test_seeds_give_the_same_bits_on_any_thread_count():
    def rollout(threads):
        env = envs.BalanceVectorEnv(num_envs=50, realism=RIG, perturb=PERTURB, threads=threads, max_episode_steps=30)
        env.action_space.seed(5)
        out = [env.reset(seed=9)[0]]
        for _ in range(60):
            out.append(env.step(env.action_space.sample())[0])
        return np.array(out)

    assert np.array_equal(rollout(1), rollout(2))


def test_bad_input_gets_named_errors_and_changes_nothing():
    env = envs.BalanceVectorEnv(num_envs=3)
    obs, _ = env.reset(seed=0)
    with pytest.raises(twip.ShapeError, match="action"):
        env.step(np.zeros((2, 1)))
    with pytest.raises(twip.ShapeError, match="dtype"):
        env.step(np.array([["a"], ["b"], ["c"]]))
    with pytest.raises(twip.NonFiniteError, match=r"action\[1\]"):
        env.step(np.array([[0.0], [np.nan], [0.0]]))
    with pytest.raises(twip.InvalidParameterError, match="num_envs"):
        envs.BalanceVectorEnv(num_envs=0)
    with pytest.raises(twip.InvalidParameterError, match="reset_mask"):
        env.reset(options={"reset_mask": np.ones(2, dtype=bool)})
    env.close()
    with pytest.raises(envs.ClosedEnvError):
        env.step(np.zeros((3, 1)))
    single = envs.BalanceEnv()
    single.reset(seed=0)
    single.close()
    with pytest.raises(envs.ClosedEnvError):
        single.step(np.zeros(1))


def test_a_rejected_action_leaves_the_state_as_it_was():
    env = envs.BalanceVectorEnv(num_envs=3)
    env.reset(seed=0)
    before = env._episodes.batch.states()
    with pytest.raises(twip.NonFiniteError):
        env.step(np.array([[0.0], [np.inf], [0.0]]))
    assert np.array_equal(env._episodes.batch.states(), before)


def test_falls_terminate_and_the_step_limit_truncates():
    env = envs.BalanceEnv(max_episode_steps=10, perturb={"phi0": twip.Uniform(low=0.0, high=0.0)})
    env.reset(seed=0)
    for k in range(10):
        _, _, term, trunc, _ = env.step(np.zeros(1))
        assert not term and trunc == (k == 9)
    env = envs.BalanceEnv(perturb={"phi0": twip.Uniform(low=0.3, high=0.3)})
    env.reset(seed=0)
    for _ in range(400):
        obs, _, term, trunc, info = env.step(np.zeros(1))
        if term:
            break
    assert term and not trunc and abs(info["state"][0]) > 0.5


def test_registered_through_the_module_entry_point():
    env = gymnasium.make("twip.envs:twip/Balance-v0")
    assert isinstance(env.unwrapped, envs.BalanceEnv)


def test_render_mode_none_is_taken_and_any_other_refused_by_name():
    # render_mode=None, which RL tools pass to make(), was a TypeError from make_model().
    for env in (gymnasium.make("twip/Balance-v0", render_mode=None), gymnasium.make("twip/Track-v0", render_mode=None),
                gymnasium.make_vec("twip/Balance-v0", num_envs=2, vectorization_mode="vector_entry_point", render_mode=None),
                gymnasium.make_vec("twip/Track-v0", num_envs=2, vectorization_mode="sync", render_mode=None)):
        assert env.render_mode is None
        env.reset(seed=0)
    for make in (envs.BalanceEnv, envs.TrackEnv, envs.BalanceVectorEnv, envs.TrackVectorEnv):
        with pytest.raises(twip.InvalidParameterError, match=r"render_mode = 'human': twip's envs render nothing"):
            make(render_mode="human")


@pytest.mark.parametrize("env_id", ["twip/Balance-v0", "twip/Track-v0"])
def test_gymnasium_makes_step_limit_is_the_one_asked_for(env_id):
    """gymnasium.make keeps max_episode_steps for its TimeLimit: the env's own default of
    2000 under it cut a limit of 2500 to 2000, and -1 (no limit) still truncated at 2000."""
    upright = {"phi0": twip.Uniform(low=0.0, high=0.0)}  # at rest upright: never falls

    def truncated_at(**kw):
        env = gymnasium.make(env_id, perturb=upright, **kw)
        env.reset(seed=0)
        zero = np.zeros(env.action_space.shape)
        for k in range(1, 2601):
            _, _, term, trunc, _ = env.step(zero)
            assert not term
            if trunc:
                return k
        return None

    assert truncated_at(max_episode_steps=2500) == 2500
    assert truncated_at(max_episode_steps=-1) is None
    assert truncated_at() == envs.DEFAULT_MAX_EPISODE_STEPS == gymnasium.spec(env_id).max_episode_steps
    assert truncated_at(max_episode_steps=30) == 30
    # The vector env takes it as its own keyword, the registration's by default.
    assert gymnasium.make_vec(env_id, num_envs=2).settings.max_episode_steps == 2000
    assert gymnasium.make_vec(env_id, num_envs=2, max_episode_steps=None).settings.max_episode_steps is None


def test_a_linear_policy_runs_through_twip_simulate_as_on_the_env():
    """LinearPolicy hands twip.simulate the current the firmware turns into the policy's
    duty: through the rig with its driver, the run is the env's lane to rounding."""
    from twip.envs.policy import LinearPolicy

    gains = np.array([6000.0, 110.0, 300.0, -10.0])
    env = envs.BalanceEnv(realism=RIG, perturb={"phi0": twip.Uniform(low=0.08, high=0.08)}, max_episode_steps=None)
    obs, _ = env.reset(seed=7)
    states = []
    for _ in range(200):
        obs, _, term, _, info = env.step(np.array([np.clip(gains @ obs, -255.0, 255.0)]))
        assert not term
        states.append(info["state"])
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    policy = LinearPolicy(gains, period=5e-3, realism=RIG, params=model.params)
    run = twip.simulate(model, policy, np.array([0.08, 0.0, 0.0, 0.0]), t_final=1.0, dt=1e-3,
                        realism=RIG.replace(seed=twip._core.sweep_noise_seed(7), stream=0))
    np.testing.assert_allclose(np.array(states), run.states[5::5][:200], rtol=0, atol=1e-10)


@pytest.mark.parametrize("kwargs, error, message", [
    ({"gains": [1.0, 2.0, 3.0]}, twip.ShapeError, r"^gains has shape \(3,\), expected \(4,\)$"),
    ({"gains": [1.0, np.nan, 3.0, 4.0]}, twip.NonFiniteError, r"^gains = \[1.0, nan, 3.0, 4.0\]"),
    ({"gains": np.array([1.0, 2.0, 3.0, 4.0 + 1.0j])}, twip.InvalidParameterError,
     r"^gains\[3\] = \(4\+1j\): not a real number \(got complex\)$"),
    ({"gains": "abcd"}, TypeError, r"^gains must be numbers, got 'abcd' \(str\)$"),
    ({"gains": [1.0, 2.0, 3.0, 4.0], "period": 0.0}, twip.InvalidParameterError, r"^period must be finite and > 0, got 0.0$"),
    ({"gains": [1.0, 2.0, 3.0, 4.0], "period": "5 ms"}, TypeError, r"^period must be a real number, got '5 ms' \(str\)$"),
])
def test_a_linear_policys_bad_gains_or_period_are_refused_by_name(kwargs, error, message):
    from twip.envs.policy import LinearPolicy

    with pytest.raises(error, match=message):
        LinearPolicy(**kwargs)


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint8)


@pytest.mark.parametrize("cls", [envs.BalanceVectorEnv, envs.TrackVectorEnv], ids=["balance", "track"])
@pytest.mark.parametrize("realism", [None, RIG], ids=["ideal", "rig"])
def test_next_step_in_one_native_call_is_the_calls_one_by_one(cls, realism):
    """NEXT_STEP's one native call (`step_next`: step, rewards, the restarts, states and
    observations in one trip to the threads) gives the bits of the native calls one by
    one, with falls, a few lanes started anew and (ideal plant) more than 512 at once."""
    n = 40 if realism is not None else 1100
    odd = {"alive": 0.3, "upright": 7.1, "tracking": 0.33, "effort": 0.37}
    if cls is envs.TrackVectorEnv:
        odd["heading"] = 0.7
    # Leaning far at the start: robots fall within the steps.
    lean = {"phi0": twip.Uniform(abs=0.45)}
    one, many = (cls(num_envs=n, realism=realism, reward=odd, perturb=lean, threads=2) for _ in range(2))
    one.reset(seed=5)
    many.reset(seed=5)
    settings = one.settings
    rng = np.random.default_rng(7)
    falls = 0
    for k in range(40):
        a = rng.uniform(-0.2, 1.2, size=(n, settings.action_width)) * one.single_action_space.high
        again = list(range(0, n, 2)) if k == 20 and realism is None else rng.choice(n, size=3, replace=False).tolist()
        again.sort()
        fell, rewards, states, obs = settings.step_next(one._episodes.batch, a.ravel(), again)
        batch = many._episodes.batch
        want_fell = batch.step(a.ravel())
        want_rewards = settings.rewards(batch, a)
        batch.reset(again)
        for got, want in [(fell, want_fell), (rewards, want_rewards), (states, batch.states()), (obs, batch.observations())]:
            assert got.dtype == want.dtype and got.shape == want.shape
            assert np.array_equal(_bits(got), _bits(want)), k
        falls += fell.sum()
    assert falls > 0
