"""Gearhead friction (Coulomb + viscous + Stribeck, tanh-regularised or with a stick band): off by
default, parity of the law and of both models with the pure-Python reference, closed-form checks,
errors."""
import dataclasses
import math

import numpy as np
import pytest

import twip
import twip.reference as ref
from twip.reference.friction import Friction as RefFriction
from conftest import rel_diff, run

FRICTIONS = {
    "coulomb": twip.Friction(0.15),
    "stribeck": twip.Friction(0.15, breakaway=0.2, stribeck_speed=0.8),
    "viscous": twip.Friction(0.0, viscous=4e-3),
    "gb37": twip.Friction.gb37(),
    "stick": twip.Friction.gb37().with_stick(0.1),
}


def rel_err(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


def test_off_by_default(balanbot):
    assert twip.SlopeModel(balanbot).friction is None
    assert twip.PlanarModel(balanbot).friction is None


def test_gb37_is_the_no_load_torque_as_coulomb():
    f = twip.Friction.gb37()
    assert f.coulomb == pytest.approx(43.7 * 9.925e-3 * 0.35, rel=1e-12)
    assert f.breakaway == pytest.approx(1.25 * f.coulomb)
    r = RefFriction.gb37()
    assert (r.coulomb, r.breakaway, r.stribeck_speed, r.viscous, r.smoothing_speed, r.stick_speed) == pytest.approx(
        (f.coulomb, f.breakaway, f.stribeck_speed, f.viscous, f.smoothing_speed, f.stick_speed), rel=1e-15
    )


@pytest.mark.parametrize("name", FRICTIONS)
def test_law_parity(name):
    f = FRICTIONS[name]
    r = RefFriction.of(f)
    for w in np.linspace(-5, 5, 101):
        assert f.torque(w) == pytest.approx(r.torque(w), rel=1e-14, abs=1e-17)


@pytest.mark.parametrize("name", FRICTIONS)
def test_slope_model_parity(balanbot, name):
    """Derivatives at random states (the reference solves the thesis's summed rows, where the
    internal friction cancels in row 2), then a 2 s open-loop RK4 run."""
    f = FRICTIONS[name]
    rng = np.random.default_rng(21)
    worst = 0.0
    for _ in range(200):
        slope = rng.uniform(-0.3, 0.3)
        x = rng.uniform([-1, -3, -5, -8], [1, 3, 5, 8])
        u = rng.uniform(-1, 1)
        a = twip.SlopeModel(balanbot, slope, friction=f).deriv(x, u)
        b = ref.SlopeModel(balanbot, slope, friction=f).deriv(x, u)
        worst = max(worst, rel_err(a, b))
    assert worst < 1e-12, worst
    x0, u, dt = [0.02, 0.0, 0.0, 0.0], 0.3, 1e-3
    a = run(twip.SlopeModel(balanbot, 0.05, friction=f), x0, u, dt, 2000)
    b = run(ref.SlopeModel(balanbot, 0.05, friction=f), x0, u, dt, 2000, step=ref.rk4_step)
    err = rel_diff(a, b)
    print(f"{name}: 2-DOF worst deriv {worst:.1e}, 2 s run {err:.1e}")
    assert err < 1e-9


@pytest.mark.parametrize("name", FRICTIONS)
def test_planar_model_parity(balanbot, name):
    """The reference builds the 3-DOF model with Kane's method and friction as a generalised force."""
    f = FRICTIONS[name]
    rng = np.random.default_rng(22)
    m, r = twip.PlanarModel(balanbot, friction=f), ref.PlanarModel(balanbot, friction=f)
    worst = 0.0
    for _ in range(200):
        x = rng.uniform([-10, -10, -7, -1.5, -5, -2, -5], [10, 10, 7, 1.5, 5, 2, 5])
        u = rng.uniform(-0.3, 0.3, 2)
        worst = max(worst, rel_err(m.deriv(x, u), r.deriv(x, u)))
    assert worst < 1e-12, worst
    x0, u, dt = [0.0, 0.0, 0.0, 0.05, 0.0, 0.0, 0.0], [0.2, 0.12], 1e-3
    a = run(m, x0, u, dt, 2000)
    b = run(r, x0, u, dt, 2000, step=ref.rk4_step)
    err = rel_diff(a, b)
    print(f"{name}: 3-DOF worst deriv {worst:.1e}, 2 s run {err:.1e}")
    assert err < 1e-9


def test_stick_band_parity_inside_the_band(balanbot):
    """States whose wheels turn inside the stick band, held or breaking away: the core and the
    reference find the same holding torques (each solves its own mass matrix)."""
    f = FRICTIONS["stick"]
    rng = np.random.default_rng(23)
    worst = 0.0
    for _ in range(200):
        slope = rng.uniform(-0.3, 0.3)
        x = rng.uniform([-0.5, -2, -5, 0], [0.5, 2, 5, 0])
        x[3] = x[1] + rng.uniform(-0.1, 0.1)
        u = rng.uniform(-0.3, 0.3)  # held below about 0.2 A, breaking away above
        a = twip.SlopeModel(balanbot, slope, friction=f).deriv(x, u)
        b = ref.SlopeModel(balanbot, slope, friction=f).deriv(x, u)
        worst = max(worst, rel_err(a, b))
    m, r = twip.PlanarModel(balanbot, friction=f), ref.PlanarModel(balanbot, friction=f)
    R, b_ = balanbot.wheel_radius, balanbot.half_track
    for _ in range(200):
        x = rng.uniform([-1, -1, -3, -0.5, -2, 0, -2], [1, 1, 3, 0.5, 2, 0, 2])
        x[5] = R * (x[4] - b_ / R * x[6] + rng.uniform(-0.1, 0.1))  # right wheel in the band
        if rng.uniform() < 0.5:
            x[6] = 0.0
            x[5] = R * (x[4] + rng.uniform(-0.1, 0.1))  # both wheels in it
        u = rng.uniform(-0.3, 0.3, 2)
        worst = max(worst, rel_err(m.deriv(x, u), r.deriv(x, u)))
    print(f"stick band: worst deriv {worst:.1e}")
    assert worst < 1e-11, worst


def test_the_wheel_that_needs_most_breaks_away_first():
    """Both held would need (1.2, -2.0) against a breakaway of 1: wheel 1 goes, and wheel 0 is
    held with 0.4 (released in index order both went, though wheel 0 could be held). The
    reference's rule, as the core's (`the_wheel_that_needs_most_breaks_away_first`)."""
    f = dataclasses.replace(RefFriction.gb37(), breakaway=1.0, stick_speed=0.1)
    S = np.array([[1.0, 0.8], [0.8, 1.0]])
    tau = f.torques([0.0, 0.0], S @ [1.2, -2.0], S)
    np.testing.assert_allclose(tau, [0.4, -1.0], atol=1e-12)


def test_a_held_robot_stays_at_rest_and_the_regularised_one_creeps(balanbot):
    """Upright at rest with each motor at 60 % of the breakaway torque for 1 s."""
    f = twip.Friction.gb37()
    u = [0.6 * f.breakaway] * 2
    held = run(twip.PlanarModel(balanbot, friction=f.with_stick(0.1)), [0.0] * 7, u, 1e-3, 1000)
    creeping = run(twip.PlanarModel(balanbot, friction=f), [0.0] * 7, u, 1e-3, 1000)
    assert np.max(np.abs(held)) < 1e-12
    assert np.max(np.abs(creeping[-1])) > 1e-3


def test_friction_changes_the_motion(balanbot):
    """Coulomb friction at the gearhead: the unpowered wheel, spun relative to the body, stops in
    finite time instead of decaying exponentially."""
    x0 = [0.0, 0.0, 0.0, 5.0]
    plain = run(twip.SlopeModel(balanbot), x0, 0.0, 1e-3, 1000)
    rough = run(twip.SlopeModel(balanbot, friction=twip.Friction.gb37()), x0, 0.0, 1e-3, 1000)
    # Falls either way; the friction drags the body along with the wheel more.
    assert not np.allclose(plain, rough)


def test_equilibrium_current_pays_the_friction(balanbot):
    speed = math.radians(180)
    f = twip.Friction.gb37()
    xs0, us0 = twip.SlopeModel(balanbot).equilibrium(speed)
    xs, us = twip.SlopeModel(balanbot, friction=f).equilibrium(speed)
    np.testing.assert_array_equal(xs, xs0)  # phi_s does not move: the friction is internal
    assert (us - us0) * balanbot.gear_ratio * balanbot.torque_constant == pytest.approx(2 * f.torque(speed), rel=1e-12)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(coulomb=-0.1), "coulomb"),
        (dict(coulomb=0.2, breakaway=0.1), "breakaway"),
        (dict(coulomb=0.1, stribeck_speed=0.0), "stribeck_speed"),
        (dict(coulomb=0.1, viscous=math.nan), "viscous"),
        (dict(coulomb=0.1, smoothing_speed=-1.0), "smoothing_speed"),
        (dict(coulomb=0.1, stick_speed=-0.1), "stick_speed"),
    ],
)
def test_bad_friction_is_named(kwargs, name):
    with pytest.raises(twip.InvalidParameterError, match=name):
        twip.Friction(**kwargs)


def test_the_law_refuses_a_nan_speed_and_gb37_beside_a_bad_bearing():
    """torque(NaN) was NaN; gb37_beside(NaN) a friction of 0 and gb37_beside(-1) one above
    the no-load torque."""
    with pytest.raises(twip.NonFiniteError, match=r"^w\[0\] = NaN"):
        twip.Friction.gb37().torque(math.nan)
    for bad in (math.nan, math.inf, -1.0):
        with pytest.raises(twip.InvalidParameterError, match="viscous_per_wheel"):
            twip.Friction.gb37_beside(bad)


def test_sweeps_refuse_friction_rather_than_drop_it(balanbot):
    model = twip.SlopeModel(balanbot, friction=twip.Friction.gb37())
    with pytest.raises(ValueError, match="friction"):
        twip._core.sweep_draw(model, [0.0, 0.0, 0.0, 0.0], [], 1, 0)
    planar = twip.PlanarModel(balanbot, friction=twip.Friction.gb37())
    with pytest.raises(ValueError, match="friction"):
        twip._core.sweep_planar_draw(planar, [0.0] * 7, [], 1, 0)
