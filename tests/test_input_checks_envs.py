"""Bad input to the Gymnasium envs, their checker, the terrain scenarios and a Python
controller's period: a named error before any work (no hang, no raw Python/numpy error,
no -inf reward, no state stored wrong)."""
from fractions import Fraction

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import twip  # noqa: E402
from twip import envs, scenarios  # noqa: E402
from twip.user_controller import own_period  # noqa: E402


@pytest.mark.parametrize("kwargs", [dict(dt=1e-12), dict(control_period=1e7), dict(dt=1e-300), dict(dt=5e-324)])
def test_a_step_of_too_many_plant_steps_is_refused_naming_dt_and_period(kwargs):
    # Each was 5e9 or more uninterruptible RK4 steps a step (or an OverflowError).
    with pytest.raises(twip.InvalidParameterError, match=r"control_period = .* over dt = .* plant steps"):
        envs.BalanceEnv(**kwargs)
    assert envs.BalanceEnv(dt=1e-7, control_period=1e-2).settings.substeps == envs.robots.MAX_SUBSTEPS


@pytest.mark.parametrize("perturb, name", [
    ({"slope": twip.Uniform(low=1.5, high=1.6)}, "slope"),
    ({"slope": twip.Normal(mean=1.0, std=0.1)}, "slope"),  # mean + 6 std > pi/2
    ({"m_body": twip.Normal(rel=0.2)}, "m_body"),  # 5 std below the mean: one reset in 3.5e6
    ({"m_body": twip.Uniform(rel=1.05)}, "m_body"),
])
def test_a_perturbation_a_draw_of_which_is_invalid_is_refused_when_made(perturb, name):
    for make in (envs.BalanceEnv, lambda **kw: envs.BalanceVectorEnv(num_envs=4, **kw)):
        with pytest.raises(twip.InvalidParameterError, match=rf"perturb\['{name}'\]: invalid {name} = .*a draw can reach it"):
            make(perturb=perturb)
    with pytest.raises(twip.InvalidParameterError, match="a draw can reach it"):
        envs.TrackEnv(perturb={"g": twip.Uniform(low=-1.0, high=9.8)})
    # Clamped into the valid range, it is taken; so is a Normal valid within 6 std (checked
    # to its 8.57 std reach, Normal(rel=0.15) on a mass was refused).
    envs.BalanceEnv(perturb={"slope": twip.Normal(mean=1.0, std=0.1, high=1.5)})
    envs.BalanceEnv(perturb={"m_body": twip.Normal(rel=0.15)})


def test_perturbations_valid_alone_but_not_together_are_refused_when_made():
    # Each alone reaches a valid robot; together a heavy rotor on a light body is refused
    # by the model (the reflected inertia check): made, 87 of 300 resets of the single env
    # failed later, each naming i_motor alone.
    together = {"i_motor": twip.Uniform(low=1.0, high=270.0), "i_body": twip.Uniform(low=1e-6, high=5e-3)}
    for name, spread in together.items():
        envs.BalanceEnv(perturb={name: spread})
    for make in (envs.BalanceEnv, envs.TrackEnv, lambda **kw: envs.BalanceVectorEnv(num_envs=2, **kw)):
        with pytest.raises(twip.InvalidParameterError,
                           match=r"perturb: 'i_motor', 'i_body' together can reach a robot the model refuses "
                                 r"\(at i_motor = 270, i_body = 1e-06, the rest nominal: invalid i_motor"):
            make(perturb={**together, "g": twip.Uniform(rel=0.1), "phi0": twip.Uniform(abs=0.1)})
    # An unclamped Normal among them is named for clamping.
    with pytest.raises(twip.InvalidParameterError, match=r"together .* clamp m_body with low=/high="):
        envs.BalanceEnv(perturb={"i_motor": twip.Uniform(low=1.0, high=270.0), "m_body": twip.Normal(rel=0.1)})
    # Narrowed so that every combination is valid, it is taken and every reset works.
    env = envs.BalanceEnv(perturb={"i_motor": twip.Uniform(low=1.0, high=100.0), "i_body": twip.Uniform(low=1e-3, high=5e-3)})
    for seed in range(50):
        env.reset(seed=seed)


@pytest.mark.parametrize("make", [envs.BalanceVectorEnv, envs.TrackVectorEnv])
def test_num_envs_is_checked_against_the_memory_budget_before_the_batch_is_made(make):
    # Unchecked, a million robots through the rig (~14 kB each) aborted the interpreter
    # under a 3 GB limit ("memory allocation of 81792 bytes failed"); 2**24, which the core
    # takes, is 230 GB.
    twip.set_memory_budget(1 << 20)
    try:
        with pytest.raises(twip.MemoryBudgetError, match=r"num_envs = 100 robots \(through a rig, ~16 KiB each\)"):
            make(num_envs=100, realism=twip.Realism.thesis_like())
        make(num_envs=100)  # 200 KiB on the ideal plant
        with pytest.raises(twip.MemoryBudgetError, match=r"num_envs = 1,000 robots \(ideal plant"):
            make(num_envs=1000)
    finally:
        twip.set_memory_budget(None)
    with pytest.raises(twip.InvalidParameterError, match=r"num_envs = 16777217: at most 16777216"):
        make(num_envs=2 ** 24 + 1)


@pytest.mark.parametrize("steps", [0, -5, 1.5, "10", True, np.int64(0)])
def test_max_episode_steps_must_be_an_int_of_at_least_one(steps):
    with pytest.raises(twip.InvalidParameterError, match=r"max_episode_steps = .*: must be an int >= 1 or None"):
        envs.BalanceEnv(max_episode_steps=steps)


def test_max_episode_steps_may_be_a_numpy_integer_as_num_envs_may():
    # np.int64(3) was refused as "max_episode_steps = np.int64(3): must be an int >= 1".
    env = envs.BalanceVectorEnv(num_envs=np.int64(2), max_episode_steps=np.int64(3))
    assert env.settings.max_episode_steps == 3 and type(env.settings.max_episode_steps) is int
    env.reset(seed=0)
    assert [env.step(np.zeros((2, 1)))[3].tolist() for _ in range(3)] == [[False, False], [False, False], [True, True]]


def test_a_refused_step_moves_no_step_count():
    v = envs.BalanceVectorEnv(num_envs=2)
    v.reset(seed=0)
    v.step(np.zeros((2, 1)))
    v.settings.step_next = lambda *a: (_ for _ in ()).throw(twip.InvalidParameterError("refused"))
    for _ in range(3):
        with pytest.raises(twip.InvalidParameterError):
            v.step(np.zeros((2, 1)))
    assert v._episodes.steps.tolist() == [1, 1]


@pytest.mark.parametrize("make, width", [(envs.BalanceVectorEnv, 1), (envs.TrackVectorEnv, 2)])
def test_a_huge_action_is_refused_not_a_minus_inf_reward(make, width):
    for realism in (None, twip.Realism.thesis_like()):
        e = make(num_envs=2, realism=realism)
        e.reset(seed=0)
        with pytest.raises(twip.InvalidParameterError, match=r"action\[0\] = 1e\+200: beyond 1e\+06 times the action bound"):
            e.step(np.full((2, width), 1e200))
        assert e._episodes.steps.tolist() == [0, 0]
        # Beyond the bound (saturated through a rig), a finite reward.
        _, rewards, *_ = e.step(np.full((2, width), 1e3 * e.settings.action_bound))
        assert np.all(np.isfinite(rewards))
    single = envs.BalanceEnv()
    single.reset(seed=0)
    with pytest.raises(twip.InvalidParameterError, match=r"action\[0\] = -1e\+200"):
        single.step(np.array([-1e200]))


@pytest.mark.parametrize("threads", [-1, 10**30, 1025, "2", 2.5, True])
def test_threads_must_be_an_int_up_to_max_threads(threads):
    with pytest.raises(twip.InvalidParameterError, match=rf"threads = {threads!r}: must be an integer from 1 to"):
        envs.BalanceVectorEnv(num_envs=2, threads=threads)
    for all_cores in (0, None):
        assert envs.BalanceVectorEnv(num_envs=2, threads=all_cores).settings.threads == 0
    assert envs.BalanceVectorEnv(num_envs=2, threads=np.int64(2)).settings.threads == 2


@pytest.mark.parametrize("reward", [[("alive", 1.0)], "alive", 0])
def test_reward_must_be_a_mapping(reward):
    with pytest.raises(TypeError, match=r"reward must be a dict .*got"):
        envs.BalanceEnv(reward=reward)
    assert envs.BalanceEnv(reward=None).settings.reward == envs.balance.DEFAULT_REWARD


def test_a_ragged_action_is_a_shape_error():
    e = envs.BalanceVectorEnv(num_envs=2)
    e.reset(seed=0)
    with pytest.raises(twip.ShapeError, match=r"action: rows of different lengths, expected shape \(2, 1\)"):
        e.step([[1.0], [2.0, 3.0]])


@pytest.mark.parametrize("options", ["reset_mask", ["x"]])
@pytest.mark.parametrize("make", [lambda: envs.BalanceVectorEnv(num_envs=2), envs.BalanceEnv, envs.TrackEnv])
def test_reset_options_must_be_a_dict(options, make):
    # The single envs ignored any options, a str or a list too.
    e = make()
    with pytest.raises(TypeError, match="options must be a dict or None"):
        e.reset(options=options)


def test_an_unknown_reset_option_is_refused_by_name():
    # Ignored: a misspelt reset_mask reset every lane.
    vec = envs.BalanceVectorEnv(num_envs=3)
    vec.reset(seed=0)
    with pytest.raises(twip.InvalidParameterError, match=r"options: unknown key 'reset_masks'; the keys it takes are \['reset_mask'\]"):
        vec.reset(options={"reset_masks": np.array([True, False, False])})
    for single in (envs.BalanceEnv(), envs.TrackEnv()):
        with pytest.raises(twip.InvalidParameterError, match=r"options: unknown key 'reset_mask'; it takes none"):
            single.reset(options={"reset_mask": np.array([True])})
        single.reset(options={})
        single.reset(options=None)


@pytest.mark.parametrize("laps, error", [(-2, twip.InvalidParameterError), (0, twip.InvalidParameterError),
                                         (float("nan"), twip.InvalidParameterError), ("2", TypeError)])
def test_figure_eight_bumps_laps_is_checked(laps, error):
    with pytest.raises(error, match="laps"):
        scenarios.get("figure-eight-bumps", laps=laps)


@pytest.mark.parametrize("name", ["incline-circle", "figure-eight-bumps"])
@pytest.mark.parametrize("value", ["yes", 2])
def test_grade_feed_forward_must_be_a_bool(name, value):
    with pytest.raises(TypeError, match="grade_feed_forward must be a bool"):
        scenarios.get(name, grade_feed_forward=value)


@pytest.mark.parametrize("kwargs, error", [(dict(steps=10**12), twip.InvalidParameterError),
                                           (dict(steps="10"), TypeError), (dict(steps=-1), twip.InvalidParameterError),
                                           (dict(lanes=[5]), twip.InvalidParameterError),
                                           (dict(lanes=[-1]), twip.InvalidParameterError),
                                           (dict(lanes=[0.5]), TypeError), (dict(lanes=1), TypeError)])
def test_check_vector_env_checks_steps_and_lanes_before_any_step(kwargs, error):
    e = envs.BalanceVectorEnv(num_envs=2)
    name = next(iter(kwargs))
    with pytest.raises(error, match=name):
        envs.check_vector_env(e, **kwargs)


class _Controller:
    def __init__(self, period):
        self.period = period

    def update(self, t, y, ref):
        return 0.0


@pytest.mark.parametrize("period, seconds", [(np.float32(0.25), 0.25), (np.int64(1), 1.0), (Fraction(1, 200), 0.005)])
def test_a_controller_period_may_be_any_real_number(period, seconds):
    assert own_period(_Controller(period)) == seconds


@pytest.mark.parametrize("period", [True, 1j, "5ms", float("nan"), np.float32("inf"), 10**400, 0, -0.005])
def test_a_controller_period_that_is_no_positive_real_is_refused(period):
    with pytest.raises(twip.InvalidParameterError, match="controller.period"):
        own_period(_Controller(period))
