"""A run that excites identification (issue 61's 1.5 % target at 1 kHz with the sensors
declared): `twip.sysid.speed_steps`, short trips whose starts, turns and stops pitch the body.
On the thesis-like rig as it starts (the estimator settled at rest), flat-lqr's own reference
left i_body's standard deviation at 1.1-1.5 % (docs/sysid.md); with the trips, 0.2-1.0 % on
three robots. The trips turn back at once: with 0.3 s holds at their ends (the default
before) the tall robot's noise seed 1 gave i_body +1.93 %."""
import warnings

import pytest

import twip
from twip.sysid import Sensors, identify, speed_steps

FREE = ["m_body", "com_height", "i_body", "mu_bearing"]
BASE = twip.RobotParams.balanbot()
#: The issue's robot (1.8 kg, 0.12 m, 40 mm wheels, 30:1, 3 A) and a taller one (3 kg, 0.2 m,
#: 100 mm wheels, 50:1, 2.5 A), each with the thesis-like driver's other values.
ROBOTS = [
    (BASE.replace(m_body=1.8, m_wheels=0.1, i_body=0.0135, i_wheels=2e-5, i_motor=3e-6, gear_ratio=30.0,
                  torque_constant=0.012, wheel_radius=0.02, com_height=0.12, mu_bearing=0.008, mu_ground=0.002), 3.0),
    (BASE.replace(m_body=3.0, m_wheels=0.3, i_body=0.04, i_wheels=3.75e-4, i_motor=5e-6, gear_ratio=50.0,
                  torque_constant=0.015, wheel_radius=0.05, com_height=0.2, mu_bearing=0.02, mu_ground=0.005), 2.5),
    # A third of our own: 1.2 kg, 0.08 m, 66 mm wheels, 34:1, 2 A.
    (BASE.replace(m_body=1.2, m_wheels=0.08, i_body=0.006, i_wheels=1e-5, i_motor=2e-6, gear_ratio=34.0,
                  torque_constant=0.01, wheel_radius=0.033, com_height=0.08, mu_bearing=0.005, mu_ground=0.002), 2.0),
]


@pytest.mark.parametrize("robot, limit, seed", [(*ROBOTS[0], 0), (*ROBOTS[1], 1), (*ROBOTS[2], 3)],
                         ids=["user-seed0", "tall-seed1", "mid-seed3"])
def test_speed_steps_identify_a_settled_rig_log_within_1_5_percent(robot, limit, seed):
    """8 s of the rig (settled at rest, then four trips of 0.08 m at 0.1 m/s, turned at once),
    from 15-25 % off. Measured over noise seeds 0-3 (benches/sysid.py --excitation): every
    parameter within 0.45 % (tall), 0.25 % (user), 0.19 % (mid). The tall robot's seed 1 with
    0.3 s holds at the trips' ends (the default before): i_body +1.93 % (std 0.92 %). Not every
    seed holds on the tall robot: seed 4 gives i_body +1.57 % (docs/sysid.md)."""
    driver = twip.MotorDriver.thesis_like().replace(current_limit=limit)
    rig = twip.Realism.thesis_like(seed=seed).replace(motor=driver, friction=None, backlash=None)
    assert rig.settle > 0
    sc = twip.scenarios.get("flat-lqr", params=robot, controller_params=robot)
    run = twip.simulate(sc.model, sc.controller, [0.05, 0, 0, 0], 8.0, dt=1e-3,
                        reference=speed_steps(robot.wheel_radius), realism=rig)
    assert run.outcome == "completed"
    start = robot.replace(m_body=robot.m_body * 1.2, com_height=robot.com_height * 0.8, i_body=robot.i_body * 1.25,
                          mu_bearing=robot.mu_bearing * 0.85)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = identify(run.to_log(), start, FREE, driver=driver, sensors=Sensors.of(rig))
    assert fit.converged and not fit.warnings and not caught, fit.summary()
    for name in FREE:
        error = fit.values[name] / getattr(robot, name) - 1
        assert abs(error) < 0.015 and abs(error) < 3 * fit.std[name] / getattr(robot, name) + 1e-4, (name, error)
    assert fit.std["i_body"] / robot.i_body < 0.01, fit.summary()


def test_speed_steps_are_checked():
    legs = speed_steps(0.02, speed=0.1, distance=0.08, hold=0.3, trips=2).legs
    assert [v for leg in legs for v in leg] == pytest.approx([4.0, 5.0, 0.3, 0.0, 5.0, 0.3] * 2)
    for bad in (dict(wheel_radius=0.0), dict(speed=-1.0), dict(distance=float("nan")), dict(trips=5), dict(trips=1.5)):
        kwargs = dict(wheel_radius=0.02, **bad) if "wheel_radius" not in bad else bad
        with pytest.raises(twip.InvalidParameterError, match=next(iter(bad))):
            speed_steps(**kwargs)
