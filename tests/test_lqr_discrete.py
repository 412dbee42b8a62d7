"""LqrController.design(discrete=True[, delay=True]): the design at the controller period,
checked against python-control's dlqr on the same discrete model, its continuous limit, and
the delay-aware gains' optimality on the delayed model."""
import math

import numpy as np
import pytest
import scipy.linalg as sl

import twip
from twip.scenarios.lqr import THESIS_WEIGHTS

SPEED = math.radians(250)
Q, R = THESIS_WEIGHTS


@pytest.fixture
def model(balanbot):
    return twip.SlopeModel(balanbot, math.radians(15))


def _discrete_model(model, period, point="operating"):
    """(4.19)'s plant part held over one period, and the integrator as the controller runs it
    (forward Euler: z[k+1] = z[k] + T (theta_dot[k] - ref))."""
    info = twip.LqrController.design(model, SPEED, Q, R, point=point).design_info
    phi, gamma = twip.c2d(info["A"][:3, :3], info["B"][:3], period)
    a = np.zeros((4, 4))
    a[:3, :3], a[3, 2], a[3, 3] = phi, period, 1.0
    return a, np.vstack([gamma, [[0.0]]])


@pytest.mark.parametrize("point", ["thesis", "operating"])
@pytest.mark.parametrize("period", [1e-3, 5e-3, 20e-3])
def test_discrete_design_is_dlqr_of_the_held_model(model, point, period):
    control = pytest.importorskip("control")
    ctrl = twip.LqrController.design(model, SPEED, Q, R, point=point, period=period, discrete=True)
    a, b = _discrete_model(model, period, point)
    k, s, e = control.dlqr(a, b, np.diag(Q), R)
    np.testing.assert_allclose(ctrl.gains, k[0], rtol=1e-9)
    info = ctrl.design_info
    np.testing.assert_allclose(info["A"], a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(info["X"], s, rtol=1e-9)
    assert info["discrete"] and not info["delay"] and np.abs(info["poles"]).max() < 1
    assert ctrl.period == period


def test_the_discrete_design_tends_to_the_continuous_one(model):
    continuous = twip.LqrController.design(model, SPEED, Q, R).gains
    gaps = [np.abs(twip.LqrController.design(model, SPEED, Q, R, period=t, discrete=True).gains / continuous - 1).max()
            for t in (1e-2, 1e-3, 1e-4)]
    assert gaps[2] < 1e-3 and gaps[2] < gaps[1] < gaps[0], gaps


def _delayed_cost(a, b, k):
    """tr P of the delayed loop on [x, v], v[k+1] = u[k] = -K x[k] (the design's cost), or inf."""
    f = np.zeros((5, 5))
    f[:4, :4], f[:4, 4:] = a, b
    f[4, :4] = -k
    if np.abs(np.linalg.eigvals(f)).max() >= 1:
        return math.inf
    stage = np.zeros((5, 5))
    stage[:4, :4] = np.diag(Q) + R * np.outer(k, k)
    return np.trace(sl.solve_discrete_lyapunov(f.T, stage))


def test_delay_gains_are_the_best_four_on_the_delayed_model(model):
    period = 5e-3
    plain = twip.LqrController.design(model, SPEED, Q, R, period=period, discrete=True)
    delayed = twip.LqrController.design(model, SPEED, Q, R, period=period, discrete=True, delay=True)
    a, b = _discrete_model(model, period)
    best = _delayed_cost(a, b, delayed.gains)
    assert best < _delayed_cost(a, b, plain.gains)
    # A stationary point: no relative nudge of any gain lowers the cost.
    for i in range(4):
        for step in (1e-4, -1e-4):
            nudged = delayed.gains.copy()
            nudged[i] *= 1 + step
            assert _delayed_cost(a, b, nudged) >= best * (1 - 1e-12)
    info = delayed.design_info
    assert info["delay"] and info["X"].shape == (5, 5) and len(info["poles"]) == 5
    assert np.abs(info["poles"]).max() < 1
    np.testing.assert_allclose(np.trace(info["X"]), best, rtol=1e-9)


def test_delay_needs_discrete(model):
    with pytest.raises(twip.InvalidParameterError, match="discrete"):
        twip.LqrController.design(model, SPEED, Q, R, delay=True)
    with pytest.raises(twip.InvalidParameterError, match="period"):
        twip.LqrController.design(model, SPEED, Q, R, period=0.0, discrete=True)


def test_the_default_is_still_the_thesis_continuous_design(model):
    default = twip.LqrController.design(model, SPEED, Q, R)
    assert not default.design_info["discrete"]
    np.testing.assert_array_equal(default.gains, twip.LqrController.design(model, SPEED, Q, R, discrete=False).gains)
