"""A dither on the command for identification (issue 61's 1.5 % target at 1 kHz with the sensors
declared): `twip.sysid.Dithered`. Speed steps alone left the tall robot's i_body deviation at
0.87-1.11 % at 0.1 m/s (its noise seed 4: +1.57 %); ±a third of the driver's limit, its sign drawn every
loop period, narrows it to 0.36-0.45 % over seeds 0-7 (docs/sysid.md)."""
import warnings

import numpy as np
import pytest

import twip
from twip.sysid import Dithered, Sensors, identify, speed_steps
from test_sysid_excite import FREE, ROBOTS

TALL, TALL_LIMIT = ROBOTS[1]


def fitted(amplitude, seed):
    """The tall robot's settled rig (no gearhead friction or play), 8 s of speed steps under its
    own LQR dithered by ±amplitude [A], fitted from 15-25 % off: (Fit, run)."""
    driver = twip.MotorDriver.thesis_like().replace(current_limit=TALL_LIMIT)
    rig = twip.Realism.thesis_like(seed=seed).replace(motor=driver, friction=None, backlash=None)
    sc = twip.scenarios.get("flat-lqr", params=TALL, controller_params=TALL)
    run = twip.simulate(sc.model, Dithered(sc.controller, amplitude, seed=seed), [0.05, 0, 0, 0], 8.0, dt=1e-3,
                        reference=speed_steps(TALL.wheel_radius), realism=rig)
    start = TALL.replace(m_body=TALL.m_body * 1.2, com_height=TALL.com_height * 0.8, i_body=TALL.i_body * 1.25,
                         mu_bearing=TALL.mu_bearing * 0.85)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return identify(run.to_log(), start, FREE, driver=driver, sensors=Sensors.of(rig)), run


def test_a_dither_narrows_the_tall_robots_i_body_to_within_1_5_percent():
    """Noise seed 4, the seed whose speed steps alone miss 1.5 % (i_body +1.57 %, deviation
    1.01 %): dithered by ±0.83 A, i_body -0.29 % (deviation 0.41 %), every parameter within
    0.3 %, the robot up and the driver never saturated."""
    plain, _ = fitted(0.0, 4)
    fit, run = fitted(TALL_LIMIT / 3, 4)
    assert run.outcome == "completed" and run.metrics["saturation_share"] < 0.01
    assert fit.converged and not fit.warnings, fit.summary()
    assert fit.std["i_body"] < 0.5 * plain.std["i_body"], (fit.std, plain.std)
    for n in FREE:
        assert abs(fit.values[n] / getattr(TALL, n) - 1) < 0.015, fit.summary()
    # The summary names the wide interval of the undithered log, and the run that narrows it.
    assert any(line.startswith("WIDE: i_body is known to ±") and "Dithered" in line
               for line in plain.summary().splitlines()), plain.summary()
    assert "WIDE" not in fit.summary(), fit.summary()


def test_an_lqr_dithered_by_nothing_runs_as_the_core_lqr():
    """A `twip.LqrController` is dithered through twip's Python reference of its law: with no
    dither the rig's run is the core controller's, bit for bit."""
    sc = twip.scenarios.get("flat-lqr")
    rig = twip.Realism.thesis_like(seed=1)
    core = twip.simulate(sc.model, sc.controller, [0.05, 0, 0, 0], 3.0, dt=1e-3, reference=sc.reference, realism=rig)
    wrapped = twip.simulate(sc.model, Dithered(sc.controller, 0.0), [0.05, 0, 0, 0], 3.0, dt=1e-3,
                            reference=sc.reference, realism=rig)
    np.testing.assert_array_equal(core.states, wrapped.states)
    np.testing.assert_array_equal(core.inputs, wrapped.inputs)


def test_the_dither_is_the_amplitude_with_a_drawn_sign_held_and_repeated_after_reset():
    """Each command is the controller's ± the amplitude, the sign held for `hold` updates, the
    same signs again after reset (a sweep's fresh copy, a rerun)."""
    class Zero:
        period = 0.005

        def update(self, t, y, ref):
            return 0.0

    d = Dithered(Zero(), 0.5, hold=3, seed=7)
    first = [d.update(0.0, [0.0] * 4, [0.0, 0.0]) for _ in range(30)]
    assert set(first) == {0.5, -0.5}
    assert all(first[i] == first[i - i % 3] for i in range(30))
    d.reset()
    assert [d.update(0.0, [0.0] * 4, [0.0, 0.0]) for _ in range(30)] == first
    assert d.period == 0.005


@pytest.mark.parametrize("kwargs, name", [(dict(amplitude=-0.1), "amplitude"), (dict(amplitude=float("nan")), "amplitude"),
                                          (dict(amplitude=0.1, hold=0), "hold"), (dict(amplitude=0.1, hold=1.5), "hold"),
                                          (dict(amplitude=0.1, seed=-1), "seed")])
def test_bad_dither_settings_are_refused_by_name(kwargs, name):
    sc = twip.scenarios.get("flat-lqr")
    with pytest.raises(twip.InvalidParameterError, match=name):
        Dithered(sc.controller, **kwargs)


def test_a_controller_without_a_python_law_is_refused_by_name():
    with pytest.raises(twip.InvalidParameterError, match="controller: .*Dithered wraps"):
        Dithered(twip.scenarios.get("flat-fuzzy").controller, 0.1)
