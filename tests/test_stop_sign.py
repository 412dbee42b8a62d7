"""One sign for "short of the goal", on the way out and on the way back: stop_errors, the
final_position_error metric, and the sweep kernel that computes it for many robots."""
from types import SimpleNamespace

import numpy as np

import twip
from twip import scenarios
from twip.scenarios.fuzzy import stop_errors, stop_positions


def test_stop_errors_are_positive_short_of_the_goal_on_both_legs():
    sc = scenarios.get("flat-fuzzy")
    (t_far, far), (t_home, home) = sc.thesis["goals"]
    radius = sc.model.params.wheel_radius
    t = np.array([0.0, t_far, t_home])
    for far_at, home_at, expected in ((far - 0.02, home + 0.03, [0.02, 0.03]),    # short, short
                                      (far + 0.01, home - 0.04, [-0.01, -0.04])):  # past, past
        states = np.zeros((3, 4))
        states[1, 2], states[2, 2] = far_at / radius, home_at / radius
        run = SimpleNamespace(t=t, states=states)
        assert np.allclose(stop_positions(sc, run), [far_at, home_at])
        assert np.allclose(stop_errors(sc, run), expected), (far_at, home_at)


def test_final_position_error_is_positive_behind_the_reference_on_the_way_back():
    sc = scenarios.get("flat-lqr")
    legs = sc.reference.legs
    # Out, hold, and cut half-way home: the robot lags the reference, still further out.
    out_time = legs[0][0] / legs[0][1] + legs[0][2]
    back = sc.run(t_final=out_time + 0.5 * abs(legs[1][0] - legs[0][0]) / legs[1][1])
    out = sc.run(t_final=0.5 * legs[0][0] / legs[0][1])
    for run in (out, back):
        lag = run.reference("theta")[-1] - run.states[-1, 2]
        assert run.metrics["final_position_error"] > 0, lag
    assert back.reference("theta_dot")[-1] < 0  # it was on the way back


def test_the_sweep_kernel_agrees_on_the_sign():
    sc = scenarios.get("flat-lqr")
    legs = sc.reference.legs
    t_back = legs[0][0] / legs[0][1] + legs[0][2] + 0.5 * abs(legs[1][0] - legs[0][0]) / legs[1][1]
    cut = sc.replace(t_final=t_back)
    sweep = twip.montecarlo(cut, n=4, perturb={"m_body": twip.Uniform(rel=0.05)}, seed=1, progress=False)
    assert sweep.kernel == "lanes"  # the LQR lane kernel, not the general runner
    assert np.all(sweep.metrics["final_position_error"] > 0)
    alone = cut.run()
    assert alone.metrics["final_position_error"] > 0
