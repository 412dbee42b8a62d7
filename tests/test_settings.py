"""Settings classes declared once in the bindings: every field round-trips through
to_dict/from_dict and replace, Realism through JSON, and decisions come from the core."""
import json
import math

import numpy as np
import pytest

import twip
from twip import _core


def _planar():
    return twip.PlanarModel(twip.RobotParams.balanbot())


SETTINGS = {
    "Imu": lambda: twip.Imu(dlpf_hz=98.0, gyro_bias=0.01, accel_bias=(0.1, -0.2), quantise=False),
    "Dlpf": lambda: twip.Dlpf(30.0, 0.004, sample_rate=500.0),
    "MotorDriver": lambda: twip.MotorDriver(battery=12.0, current_limit=3.0),
    "Push": lambda: twip.Push(1.5, 0.3, height=0.2),
    "Force": lambda: twip.Force(horizontal=0.5, vertical=-1.0),
    "Friction": lambda: twip.Friction(0.01, breakaway=0.02, viscous=1e-3),
    "Circle": lambda: twip.Circle(0.5, 0.2, direction="cw"),
    "Line": lambda: twip.Line(0.3, heading=0.4, start=(1.0, 2.0)),
    "FigureEight": lambda: twip.FigureEight(1.0, 30.0, centre=(0.5, 0.0)),
    "Waypoints": lambda: twip.Waypoints([(0, 0), (1, 0), (1, 1)], 0.2, corner_radius=0.1),
    "DcMotor": lambda: twip.DcMotor.gb37y3530(supply=12.0),
    "FuzzyController": lambda: twip.FuzzyController.thesis_flat(
        twip.SlopeModel(twip.RobotParams.balanbot(), 0.0), gamma=0.5, s0=np.arange(9.0)),
    "SmcTracker": lambda: twip.SmcTracker(_planar(), fuzzy=True, boundary_layer=(0.03, 0.04), leakage=0.1),
    "Realism": lambda: twip.Realism.thesis_like(seed=3).replace(
        pushes=[(1.0, 0.4)], force=twip.Force(1.0), slope_profile=[(2.0, 0.1)], friction=twip.Friction.gb37()),
}


#: A positive float field of each class that may be doubled (and must refuse NaN).
CHANGE = {"Imu": "height", "Dlpf": "delay", "MotorDriver": "battery", "Push": "impulse",
          "Force": "horizontal", "Friction": "coulomb", "Circle": "radius", "Line": "speed",
          "FigureEight": "half_width", "Waypoints": "speed", "DcMotor": "resistance",
          "FuzzyController": "k1", "SmcTracker": "period", "Realism": "control_period"}


def _plain(v):
    """Comparable values: settings objects as their dicts, arrays as lists."""
    if hasattr(v, "to_dict"):
        return {k: _plain(x) for k, x in v.to_dict().items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x) for x in v]
    if hasattr(v, "kind") and hasattr(v, "parameters"):
        return (v.kind, v.parameters)
    if isinstance(v, (twip.SlopeModel, twip.PlanarModel)):
        return (v.params.to_dict(), getattr(v, "slope", None), _plain(v.friction))
    if isinstance(v, twip.FuzzyBasis):
        return repr(v)
    return v


@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_every_field_round_trips_through_to_dict(name):
    x = SETTINGS[name]()
    d = x.to_dict()
    y = type(x).from_dict(d)
    assert _plain(y) == _plain(x)
    for k, v in d.items():  # each field has its getter, equal to the dict's value
        assert _plain(getattr(x, k)) == _plain(v)
    assert repr(x).startswith(f"{name}(")


@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_replace_changes_one_field_and_validates(name):
    x = SETTINGS[name]()
    d = x.to_dict()
    key = CHANGE[name]
    y = x.replace(**{key: d[key] * 2})
    assert getattr(y, key) == pytest.approx(d[key] * 2)
    assert {k: _plain(v) for k, v in y.to_dict().items() if k != key} == \
        {k: _plain(v) for k, v in d.items() if k != key}
    with pytest.raises((ValueError, TypeError)):
        x.replace(**{key: float("nan")})
    with pytest.raises(TypeError):
        x.replace(no_such_field=1.0)


@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_a_field_of_the_wrong_type_is_named(name):
    """pyo3 names the argument only in a note that str(error) leaves out: the message was
    "must be real number, not str"."""
    x = SETTINGS[name]()
    key = CHANGE[name]
    with pytest.raises(TypeError, match=rf"^{name}\.from_dict: {key}: must be real number, not str"):
        type(x).from_dict({**x.to_dict(), key: "x"})
    with pytest.raises(TypeError, match=rf"^{name}\.replace: {key}: must be real number, not str"):
        x.replace(**{key: "x"})


def test_realism_json_names_a_field_of_the_wrong_type():
    text = twip.Realism.thesis_like().to_json()
    for change, where in [
        (lambda d: d["imu"].update(dlpf_hz="x"), "imu: dlpf_hz: must be real number"),
        (lambda d: d["motor"].update(battery=[1]), "motor: battery: must be real number"),
        (lambda d: d.update(encoder_cpr="700"), "encoder_cpr: must be real number"),
        (lambda d: d.update(delay="yes"), "delay: 'str' object"),
        (lambda d: d.update(estimator="kalman"), "estimator: 'str' object"),
        (lambda d: d.update(pushes=[{"t": "1", "impulse": 0.1}]), "pushes: t: must be real number"),
    ]:
        d = json.loads(text)
        change(d)
        with pytest.raises(TypeError, match=rf"^Realism\.from_json: {where}"):
            twip.Realism.from_json(json.dumps(d))


def test_realism_json_round_trip_keeps_every_part():
    r = SETTINGS["Realism"]().replace(estimator=twip.TiltEstimator.kalman(2e-3, 3e-6, 0.1), stream=7)
    text = r.to_json()
    back = twip.Realism.from_json(text)
    assert back.to_json() == text
    assert json.loads(text)["estimator"] == {"kind": "kalman", "q_angle": 2e-3, "q_bias": 3e-6, "r_angle": 0.1}
    assert back.pushes[0].impulse == 0.4 and back.friction == twip.Friction.gb37() and back.stream == 7
    assert twip.Realism.from_json(twip.Realism().to_json()).is_ideal
    with pytest.raises(ValueError, match="JSON"):
        twip.Realism.from_json("[1, 2]")
    # The kind named the estimator class's attribute: "bogus" was an AttributeError,
    # "__class__" a TypeError.
    for kind in ("bogus", "__class__", "filter"):
        bad = json.dumps({**json.loads(text), "estimator": {"kind": kind}})
        with pytest.raises(twip.InvalidParameterError, match=f'kind = "{kind}": must be "complementary" or "kalman"'):
            twip.Realism.from_json(bad)


def test_realism_json_runs_the_same_robot():
    sc = twip.scenarios.get("flat-lqr-sim", t_final=1.0)
    r = twip.Realism.thesis_like(seed=5)
    a = sc.run(realism=r)
    b = sc.run(realism=twip.Realism.from_json(r.to_json()))
    assert np.array_equal(a.states, b.states)


def test_kernel_and_fall_limit_come_from_the_core():
    assert _core.DEFAULT_FALL_LIMIT == pytest.approx(math.radians(60))
    lqr = twip.scenarios.get("flat-lqr-sim")
    assert twip.sweep.kernel_for(lqr) == "lanes"
    assert twip.sweep.kernel_for(lqr, twip.Realism.thesis_like()) == "realism-lanes"
    # Every rig runs on lanes for a law the lanes have: pushes, a force, slope changes.
    assert twip.sweep.kernel_for(lqr, twip.Realism(pushes=[(1.0, 0.3)])) == "realism-lanes"
    assert twip.sweep.kernel_for(lqr, twip.Realism(force=twip.Force(horizontal=0.5))) == "realism-lanes"
    assert twip.sweep.kernel_for(lqr, twip.Realism(slope_profile=[(0.2, 0.05)])) == "realism-lanes"
    assert twip.sweep.kernel_for(twip.scenarios.get("flat-fuzzy-sim")) == "lanes"
    # Fuzzy sets of any kind: Gaussians too.
    gaussian = [[twip.Gaussian(-0.3, 0.15), twip.Triangle(-0.3, 0.0, 0.3), twip.Gaussian(0.3, 0.15)]] * 2
    gaussian = twip.scenarios.get("flat-fuzzy-sim", sets=gaussian, t_final=0.2)
    assert twip.sweep.kernel_for(gaussian) == "lanes"
    assert twip.sweep.kernel_for(gaussian, twip.Realism.thesis_like()) == "realism-lanes"
    assert twip.sweep.kernel_for(twip.scenarios.get("circle-pid")) == "planar-lanes"
    assert twip.sweep.kernel_for(twip.scenarios.get("circle-smc-fuzzy")) == "planar-lanes"
    assert twip.sweep.kernel_for(twip.scenarios.get("circle-pid"), twip.Realism.thesis_like()) == "planar-realism-lanes"
    own_friction = twip.scenarios.get("circle-smc")
    own_friction = own_friction.replace(controller=twip.SmcTracker(twip.PlanarModel(own_friction.model.params, twip.Friction.gb37())))
    assert twip.sweep.kernel_for(own_friction) == "planar"
    assert twip.sweep.kernel_for(own_friction, twip.Realism.thesis_like()) == "planar-realism"
    with pytest.raises(TypeError):
        _core.sweep_kernel(object())
    # The sweep reports the kernel it ran, the one kernel_for names.
    res = twip.montecarlo(gaussian, n=2, seed=1)
    assert res.kernel == "lanes"


def test_metric_names_are_the_same_in_runs_and_sweeps():
    run = twip.scenarios.get("flat-lqr-sim", t_final=0.5).run()
    sweep = twip.montecarlo("flat-lqr-sim", n=2, seed=1, options={"t_final": 0.5})
    assert set(run.metrics) <= set(sweep.metric_names) | {"peak_abs_input"}
    planar = twip.scenarios.get("circle-pid").run(t_final=0.5)
    assert {"mean_abs_x_error", "max_path_error_settled", "peak_current", "peak_torque", "settle"} <= set(planar.metrics)
