"""Units sanity: a length, mass or inertia far outside a tabletop robot's is named in a
warning (com_height = 120, millimetres in a file of metres, ran and "completed"), and the
CLI prints the thesis's claims only for the thesis's robot."""
import re
import warnings

import pytest

import twip
from twip import robot_file
from twip.cli import main
from twip.plausibility import implausible


def _file(tmp_path, **changes):
    path = tmp_path / "mine.toml"
    robot_file.save(twip.RobotParams.balanbot().replace(**changes), path)
    return path


def test_the_thesis_robot_is_plausible():
    assert implausible(twip.RobotParams.balanbot()) == []


@pytest.mark.parametrize("changes, named", [
    (dict(com_height=120.0), "com_height = 120.0 m"),          # millimetres
    (dict(wheel_radius=34.0), "wheel_radius = 34.0 m"),
    (dict(m_body=1800.0), "m_body = 1800.0 kg"),               # grams
    (dict(i_body=108.0), "i_body = 108.0 kg m^2"),             # kg m^2 x 1000
    (dict(i_wheels=1e-12), "i_wheels = 1e-12 kg m^2"),
])
def test_an_implausible_value_is_named_by_the_file_the_run_and_the_cli(tmp_path, capsys, changes, named):
    path = _file(tmp_path, **changes)
    with pytest.warns(twip.ImplausibleRobotWarning, match=re.escape(named)):
        robot = twip.Robot.from_file(path)
    sc = twip.scenarios.get("flat-lqr-sim", params=robot.params, t_final=0.5)
    r = sc.run()
    assert any(named in w for w in r.warnings), r.warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", twip.ImplausibleRobotWarning)
        main(["simulate", "flat-lqr-sim", "--robot", str(path), "--t-final", "0.5"])
    assert named in capsys.readouterr().err


def test_a_plausible_run_has_no_such_warning():
    r = twip.scenarios.get("flat-lqr-sim", t_final=0.5).run()
    assert not any("implausible" in w for w in r.warnings)


def test_the_cli_prints_the_thesis_claims_only_for_the_thesis_robot(tmp_path, capsys):
    assert main(["simulate", "flat-lqr"]) == 0
    assert "the thesis's claims" in capsys.readouterr().out
    balanbot = tmp_path / "balanbot.toml"
    robot_file.init(balanbot)
    assert main(["simulate", "flat-lqr", "--robot", str(balanbot)]) == 0
    assert "the thesis's claims" in capsys.readouterr().out  # the same robot, from a file
    mine = _file(tmp_path, m_body=1.8, com_height=0.12, wheel_radius=0.02, gear_ratio=30.0)
    assert main(["simulate", "flat-lqr", "--robot", str(mine)]) == 0
    assert "the thesis's claims" not in capsys.readouterr().out


def test_a_command_beyond_the_driver_is_named():
    # 1e12 A ran without a word; the ideal loop's driver is MotorDriver() (11.1 V / 1.71 ohm).
    plant = twip.SlopeModel(twip.RobotParams.balanbot())
    r = twip.simulate(plant, lambda t, y, ref: 1e12, [0.0] * 4, 0.01)
    assert any("beyond the 6.48 A its driver can give" in w for w in r.warnings), r.warnings
    sc = twip.scenarios.get("flat-lqr")
    assert not any("its driver" in w for w in sc.run(t_final=2.0).warnings)
    # Through a rig, its driver's limit (the thesis-like L298: 2 A).
    driver = twip.Realism.thesis_like().motor
    assert driver.current_limit == 2.0
    r = twip.simulate(plant, lambda t, y, ref: 10.0, [0.0] * 4, 0.05, realism=twip.Realism.thesis_like())
    assert any("beyond the 2 A its driver can give" in w and "2 A limit" in w for w in r.warnings), r.warnings
