"""twip.envs Track-v0: Gymnasium's checker and ours (ideal plant and the rig, every
autoreset mode), parity with twip.simulate on a PlanarModel, seeding, the observation's
path error and the named errors."""
import math

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import twip  # noqa: E402
from twip import envs  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402
from gymnasium.vector import AutoresetMode  # noqa: E402

RIG = twip.Realism.thesis_like()
PERTURB = {"m_body": twip.Uniform(rel=0.1), "phi0": twip.Uniform(abs=0.05), "y0": twip.Uniform(abs=0.02)}


@pytest.mark.parametrize("realism", [None, RIG], ids=["ideal", "rig"])
def test_gymnasium_check_env_passes_on_the_single_env(realism):
    env = gymnasium.make("twip/Track-v0", realism=realism, perturb=PERTURB)
    check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("mode", list(AutoresetMode))
@pytest.mark.parametrize("realism", [None, RIG], ids=["ideal", "rig"])
def test_our_vector_checker_passes_in_every_autoreset_mode(realism, mode):
    env = gymnasium.make_vec("twip/Track-v0", num_envs=21, vectorization_mode="vector_entry_point",
                             autoreset_mode=mode, realism=realism, perturb=PERTURB, max_episode_steps=40)
    assert isinstance(env, envs.TrackVectorEnv) and env.metadata["autoreset_mode"] == mode
    envs.check_vector_env(env, seed=3, steps=120, lanes=[0, 7, 20])


def test_spaces_are_the_path_error_and_the_two_wheel_commands():
    env = envs.TrackVectorEnv(num_envs=3)
    assert env.single_observation_space.shape == (9,) and env.single_observation_space.dtype == np.float64
    assert env.single_action_space.shape == (2,) and env.single_action_space.dtype == np.float64
    p = twip.RobotParams.balanbot()
    driver = twip.MotorDriver.thesis_like()
    per_motor = min(driver.battery / driver.resistance, driver.current_limit or np.inf)
    assert env.single_action_space.high[0] == pytest.approx(per_motor * p.torque_constant * p.gear_ratio)
    driven = envs.TrackVectorEnv(num_envs=3, realism=RIG)
    assert driven.single_action_space.high.tolist() == [255.0, 255.0]
    obs, _ = env.reset(seed=0)
    # Each episode starts on the path's start, along it: the error is φ0's alone.
    np.testing.assert_allclose(obs[:, :3], 0.0, atol=1e-12)
    circle = twip.Circle(0.6, math.radians(180.0) * p.wheel_radius)
    np.testing.assert_allclose(obs[:, 7], circle.sample(0.0)["v"])


def test_standing_still_the_path_runs_ahead():
    """Held upright at the start (no pitch, no torque), the robot stays while the
    reference moves along the circle: the error is the reference's position seen from
    the robot (heading +x at the origin)."""
    env = envs.TrackEnv(perturb={"phi0": twip.Uniform(low=0.0, high=0.0)})
    env.reset(seed=0)
    for _ in range(200):
        obs, *_ = env.step(np.zeros(2))
    r = env.settings.path.sample(200 * 5e-3)
    np.testing.assert_allclose(obs[:3], [r["x"], r["y"], r["psi"]], atol=1e-12)


class Replay:
    def __init__(self, actions, period):
        self.actions, self.period, self.k = list(actions), period, 0

    def update(self, t, y, ref):
        self.k += 1
        return self.actions[self.k - 1]


@pytest.mark.parametrize("realism", [None, twip.Realism.thesis_like().replace(motor=None)], ids=["ideal", "rig"])
def test_a_lane_is_twip_simulate_with_the_same_inputs(realism):
    perturb = {"phi0": twip.Uniform(low=0.01, high=0.01)}
    venv = envs.TrackVectorEnv(num_envs=4, realism=realism, perturb=perturb)
    venv.reset(seed=20)
    rng = np.random.default_rng(1)
    actions, states = [], []
    for _ in range(100):
        a = rng.uniform(-0.05, 0.05, size=(4, 2))
        actions.append(a[2])
        _, _, term, trunc, info = venv.step(a)
        assert not term.any()
        states.append(info["state"][2])
    if realism is not None:
        realism = realism.replace(seed=twip._core.sweep_noise_seed(22), stream=0)
    model = twip.PlanarModel(twip.RobotParams.balanbot())
    x0 = venv.settings.x0.copy()  # the path's start (the circle's x there is 0.6 cos(-pi/2))
    x0[3] = 0.01
    run = twip.simulate(model, Replay(actions, 5e-3), x0, t_final=0.5, dt=1e-3, reference=venv.settings.path,
                        realism=realism)
    want, got = run.states[5::5][:100], np.array(states)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-10)


@pytest.mark.parametrize("realism", [None, RIG], ids=["ideal", "rig"])
def test_the_native_rewards_are_the_numpy_formulas_bits(realism):
    """The rewards made in Rust are the formula's in NumPy column by column, bit for bit,
    with falls and odd weights (the bits a vector env's rewards had)."""
    env = envs.TrackVectorEnv(num_envs=40, realism=realism, perturb=PERTURB, max_episode_steps=25,
                              reward={"alive": 0.3, "upright": 7.1, "tracking": 3.3, "heading": 0.7, "effort": 0.37})
    env.reset(seed=2)
    rng = np.random.default_rng(3)
    batch, settings = env._episodes.batch, env.settings
    falls = 0
    for _ in range(60):
        a = rng.uniform(-0.2, 1.2, size=(40, 2)) * env.single_action_space.high  # pushed: falls
        fell = batch.step(a.ravel())
        rewards = settings.rewards(batch, a)
        want = settings.reward_terms(batch.true_observations(), a)
        assert np.array_equal(rewards.view(np.uint64), want.view(np.uint64))
        falls += fell.sum()
        batch.reset(np.flatnonzero(fell).tolist())
    assert falls > 0


@pytest.mark.parametrize("reset", [[3, 17, 39], list(range(0, 1200, 2))], ids=["few", "many"])
def test_the_observations_kept_from_the_rewards_are_made_anew_for_the_lanes_reset(reset):
    """On the ideal plant the rewards' true observations are handed out by `observations`;
    a reset in between makes the rows of the lanes it starts anew (a few one by one, many
    all again): the same bits as observations made from scratch, each array its own."""
    env = envs.TrackVectorEnv(num_envs=1200, perturb=PERTURB)
    env.reset(seed=4)
    batch, settings = env._episodes.batch, env.settings
    rng = np.random.default_rng(8)
    for k in range(30):
        a = rng.uniform(-1, 1, size=(1200, 2)) * env.single_action_space.high
        batch.step(a.ravel())
        settings.rewards(batch, a)
        if k % 3 == 0:
            batch.reset(reset)
        kept, made = batch.observations(), batch.observations()
        assert kept is not made
        assert np.array_equal(kept.view(np.uint64), made.view(np.uint64)), k
        assert np.array_equal(made.view(np.uint64), batch.true_observations().view(np.uint64)), k


def test_seeds_give_the_same_bits_on_any_thread_count():
    def rollout(threads):
        env = envs.TrackVectorEnv(num_envs=50, realism=RIG, perturb=PERTURB, threads=threads, max_episode_steps=30)
        env.action_space.seed(5)
        out = [env.reset(seed=9)[0]]
        for _ in range(60):
            out.append(env.step(env.action_space.sample())[0])
        return np.array(out)

    assert np.array_equal(rollout(1), rollout(2))


def test_each_episode_draws_anew():
    env = envs.TrackVectorEnv(num_envs=2, perturb=PERTURB, max_episode_steps=5)
    first, _ = env.reset(seed=4)
    for _ in range(6):  # the 5th step truncates, the 6th starts episode 1 (NEXT_STEP)
        obs, *_ = env.step(np.zeros((2, 2)))
    seeds, episodes = env._episodes.batch.keys()
    assert seeds.tolist() == [4, 5] and episodes.tolist() == [1, 1]
    assert not np.array_equal(obs[:, 3], first[:, 3])  # φ0 redrawn
    env.reset(seed=4)
    assert np.array_equal(env._episodes.batch.observations(), first)


def test_bad_input_gets_named_errors_and_changes_nothing():
    env = envs.TrackVectorEnv(num_envs=3)
    env.reset(seed=0)
    before = env._episodes.batch.states()
    with pytest.raises(twip.ShapeError, match="action"):
        env.step(np.zeros((3, 1)))
    with pytest.raises(twip.NonFiniteError, match=r"action\[3\]"):
        env.step(np.array([[0.0, 0.0], [0.0, np.nan], [0.0, 0.0]]))
    assert np.array_equal(env._episodes.batch.states(), before)
    with pytest.raises(twip.InvalidParameterError, match="num_envs"):
        envs.TrackVectorEnv(num_envs=0)
    with pytest.raises(twip.InvalidParameterError, match="path"):
        envs.TrackEnv(path="circle")
    with pytest.raises(twip.InvalidParameterError, match="slope"):
        envs.TrackEnv(perturb={"slope": twip.Uniform(abs=0.1)})
    with pytest.raises(twip.InvalidParameterError, match="reset_mask"):
        env.reset(options={"reset_mask": np.ones(4, dtype=bool)})
    env.close()
    with pytest.raises(envs.ClosedEnvError):
        env.step(np.zeros((3, 2)))
