"""Property-based tests over the public Python API (hypothesis): thousands of generated
inputs, good and bad. The property everywhere: a call either returns finite numbers or
raises a clear Python error (a twip.TwipError, TypeError or ValueError, whose message is
not empty); never a panic (pyo3's PanicException is no Exception), an abort, a hang or a
silent NaN. Sizes are kept small so that the whole file runs in well under a minute."""
import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import twip
from twip import scenarios

CLEAR = (twip.TwipError, TypeError, ValueError)
FAST = settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SLOW = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
FIELDS = list(twip.RobotParams.fields)
BALANBOT = twip.RobotParams.balanbot()

# Anything a user might pass where a number is expected.
anything = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**20, 10**20), st.text(max_size=4), st.none(),
    st.complex_numbers(max_magnitude=1e3), st.booleans(), st.lists(st.floats(-10, 10), max_size=3),
)
finite = st.floats(-1e6, 1e6, allow_nan=False)
small = st.floats(-3, 3, allow_nan=False)
# Arrays of any shape and content, and well-formed state vectors.
arrays = st.one_of(
    st.lists(anything, max_size=8),
    st.lists(st.lists(st.floats(allow_nan=True), min_size=1, max_size=5), min_size=1, max_size=5),
    st.builds(np.zeros, st.tuples(st.integers(0, 5), st.integers(0, 5))),
    anything,
)
states4 = st.lists(small, min_size=4, max_size=4)


def clear(call):
    """Runs `call`; returns its value, or None when it raised a clear error."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return call()
    except CLEAR as e:
        assert str(e), f"{type(e).__name__} without a message"
        return None


def all_finite(*arrays) -> bool:
    return all(np.all(np.isfinite(np.asarray(a, dtype=float))) for a in arrays)


robots = st.fixed_dictionaries({}, optional={f: st.one_of(anything, st.floats(1e-4, 10)) for f in FIELDS})
plausible = st.fixed_dictionaries({f: st.floats(0.5, 2.0) for f in FIELDS if f != "g"}).map(
    lambda scale: BALANBOT.replace(**{f: getattr(BALANBOT, f) * s for f, s in scale.items()}))


@FAST
@given(robots)
def test_robot_params_take_any_fields_and_either_build_or_name_the_problem(fields):
    p = clear(lambda: BALANBOT.replace(**fields))
    if p is not None:
        assert all_finite(list(p.to_dict().values()))
        assert twip.RobotParams.from_dict(p.to_dict()).to_dict() == p.to_dict()


@FAST
@given(plausible, arrays, st.one_of(anything, small), st.one_of(anything, st.floats(-0.5, 0.5)))
def test_slope_model_derivatives_are_finite_or_refused(params, x, u, slope):
    model = clear(lambda: twip.SlopeModel(params, slope))
    if model is None:
        return
    dx = clear(lambda: model.deriv(x, u))
    if dx is not None:
        assert dx.shape == (4,) and all_finite(dx)
    x1 = clear(lambda: twip.rk4_step(model, x, u, 1e-3))
    if x1 is not None:
        assert all_finite(x1)


@FAST
@given(plausible, st.lists(small, min_size=7, max_size=7), st.lists(small, min_size=2, max_size=2), arrays)
def test_planar_model_derivatives_are_finite_or_refused(params, x, u, junk):
    model = twip.PlanarModel(params)
    assert all_finite(model.deriv(x, u), model.energy(x))
    clear(lambda: model.deriv(junk, u))
    clear(lambda: model.deriv(x, junk))


@FAST
@given(plausible, st.one_of(arrays, st.lists(st.floats(-100, 100), min_size=4, max_size=4)),
       st.one_of(anything, st.floats(1e-4, 0.1)))
def test_lqr_controllers_from_any_gains(params, gains, period):
    model = twip.SlopeModel(params)
    c = clear(lambda: twip.LqrController(model, gains, period=period))
    if c is not None:
        assert all_finite(c.gains) and c.period > 0


@SLOW
@given(plausible, st.one_of(arrays, st.lists(st.floats(0, 100), min_size=4, max_size=4)),
       st.one_of(anything, st.floats(1e-3, 1e4)), st.one_of(anything, st.floats(-5, 5)))
def test_lqr_design_from_any_weights(params, Q, R, speed):
    model = twip.SlopeModel(params)
    c = clear(lambda: twip.LqrController.design(model, speed, Q, R))
    if c is not None:
        assert all_finite(c.gains)


@FAST
@given(st.lists(st.tuples(anything, anything, anything), max_size=3),
       st.lists(st.tuples(st.floats(-10, 10), st.floats(0.01, 10), st.floats(0, 5)), min_size=1, max_size=3),
       st.floats(-100, 100))
def test_speed_schedules_from_any_legs(junk, legs, t):
    clear(lambda: twip.SpeedSchedule(junk))
    s = clear(lambda: twip.SpeedSchedule(legs))
    if s is not None:
        assert all_finite(s.sample(t))


@FAST
@given(st.one_of(anything, st.floats(-1, 1)), st.one_of(anything, st.floats(-1, 1)),
       st.one_of(anything, st.floats(-1, 1)), st.one_of(anything, st.floats(-1, 1)), st.floats(-2, 2))
def test_fuzzy_sets_from_any_breakpoints(a, b, c, d, x):
    t = clear(lambda: twip.Trapezoid(a, b, c, d))
    if t is not None:
        assert 0.0 <= t(x) <= 1.0
    g = clear(lambda: twip.Gaussian(a, b))
    if g is not None:
        assert 0.0 <= g(x) <= 1.0


@FAST
@given(st.dictionaries(st.sampled_from(["low", "high", "rel", "abs"]), anything, max_size=3),
       st.dictionaries(st.sampled_from(["std", "rel", "mean", "low", "high"]), anything, max_size=3),
       st.floats(-10, 10))
def test_distributions_from_any_fields(uniform, normal, nominal):
    for dist in (clear(lambda: twip.Uniform(**uniform)), clear(lambda: twip.Normal(**normal))):
        if dist is not None:
            spec = clear(lambda: dist.resolve("m_body", nominal))
            if spec is not None:
                kind, a, b, low, high = spec
                assert kind in ("uniform", "normal") and not (math.isnan(a) or math.isnan(b))


LQR = scenarios.get("flat-lqr-sim")


@SLOW
@given(st.one_of(arrays, states4), st.one_of(anything, st.floats(0.0, 0.3)), st.one_of(anything, st.floats(1e-4, 0.01)),
       st.one_of(anything, st.integers(-3, 50)))
def test_simulate_from_any_arguments(x0, t_final, dt, record_every):
    r = clear(lambda: twip.simulate(LQR.model, LQR.controller, x0, t_final, dt, record_every=record_every))
    if r is not None:
        assert r.outcome in ("completed", "fell", "diverged")
        assert len(r.t) >= 1 and all_finite(r.t, r.states, r.inputs)


@SLOW
@given(states4, st.floats(1e-3, 0.3), st.sampled_from([1e-3, 5e-4, 2.5e-4, 1e-4]), st.integers(1, 50))
def test_simulate_from_well_formed_arguments_always_runs(x0, t_final, dt, record_every):
    r = twip.simulate(LQR.model, LQR.controller, x0, t_final, dt, record_every=record_every)
    assert r.outcome in ("completed", "fell", "diverged")
    assert len(r.t) >= 1 and all_finite(r.t, r.states, r.inputs)
    assert r.outcome != "completed" or all_finite(list(r.metrics.values()))


@SLOW
@given(st.integers(1, 40), st.integers(0, 2**64 - 1), st.sampled_from([None, 1, 2]),
       st.one_of(st.none(), st.integers(10, 40)), st.floats(0, 0.5), st.floats(0, 0.2))
def test_montecarlo_from_well_formed_arguments_always_runs(n, seed, threads, shard_size, rel, std):
    r = twip.montecarlo("flat-lqr-sim", n, perturb={"m_body": twip.Uniform(rel=rel), "phi0": twip.Normal(std=std)},
                        seed=seed, threads=threads, shard_size=shard_size, progress=False, options={"t_final": 0.05})
    assert r.n == n and r.valid.all()
    assert 0.0 <= r.fall_rate <= 1.0
    lo, hi = r.fall_rate_interval()
    assert 0.0 <= lo <= r.fall_rate <= hi <= 1.0
    assert all_finite(r.metrics["t_end"])


@SLOW
@given(st.one_of(anything, st.integers(-5, 40)), st.one_of(anything, st.integers(-2, 2**64)),
       st.one_of(st.none(), anything, st.integers(-1, 3)), st.one_of(st.none(), anything, st.integers(-4, 20)),
       st.dictionaries(st.sampled_from(["m_body", "phi0", "slope", "nope", "x0[9]"]),
                       st.one_of(anything, st.builds(twip.Uniform, rel=st.floats(0, 0.5)),
                                 st.builds(twip.Normal, std=st.floats(0, 0.1))), max_size=2))
def test_montecarlo_from_any_arguments(n, seed, threads, shard_size, perturb):
    r = clear(lambda: twip.montecarlo("flat-lqr-sim", n, perturb=perturb, seed=seed, threads=threads,
                                      shard_size=shard_size, progress=False, options={"t_final": 0.05}))
    if r is not None:
        assert r.n == n and 0.0 <= r.fall_rate <= 1.0 or math.isnan(r.fall_rate)
        assert not np.isnan(r.metrics["t_end"][r.valid]).any()


@FAST
@given(st.one_of(anything, st.integers(-10, 10**15)))
def test_memory_budget_takes_a_byte_count_or_refuses(nbytes):
    try:
        clear(lambda: twip.set_memory_budget(nbytes))
    finally:
        twip.set_memory_budget(None)
