"""Robot files (TOML): round trip, units in comments, errors that name file, key and line,
and the CLI's --robot and `twip robot init`."""
from __future__ import annotations

import numpy as np
import pytest

import twip
from twip import robot_file
from twip.cli import main


def test_round_trip_keeps_every_field_to_the_bit(tmp_path):
    path = tmp_path / "r.toml"
    robot = twip.RobotParams.balanbot().replace(m_body=1.234567890123, wheel_radius=0.0412, g=9.80665)
    robot.to_file(path)
    back = twip.RobotParams.from_file(path)
    assert back.to_dict() == robot.to_dict()
    text = path.read_text()
    for name, (unit, symbol, _) in robot_file.FIELDS.items():
        line = next(l for l in text.splitlines() if l.startswith(f"{name} ="))
        assert f"[{unit}]" in line and f"({symbol})" in line


def test_a_driver_round_trips_to_the_bit_without_a_current_limit_too(tmp_path):
    # A driver's current_limit None (no limit) was left out of the file, which read it back
    # as the thesis-like 2 A; the resistance was left out as no key of [driver].
    path = tmp_path / "r.toml"
    for driver in (twip.MotorDriver.thesis_like().replace(current_limit=None, resistance=2.345678901234567),
                   twip.MotorDriver.thesis_like().replace(current_limit=1.5, battery=12.6, assumed_battery=12.6,
                                                           efficiency=0.9)):
        robot_file.save(twip.RobotParams.balanbot(), path, driver=driver.to_dict())
        assert twip.Robot.from_file(path).driver.to_dict() == driver.to_dict()


def test_init_writes_the_balanbot_with_its_motor_and_driver(tmp_path):
    path = tmp_path / "robot.toml"
    assert main(["robot", "init", str(path)]) == 0
    robot = twip.Robot.from_file(path)
    assert robot.params.to_dict() == twip.RobotParams.balanbot().to_dict()
    assert robot.stall_current == 7.0
    assert robot.driver.to_dict() == twip.MotorDriver.thesis_like().to_dict()
    assert robot.realism().to_dict()["motor"].to_dict() == twip.Realism.thesis_like().to_dict()["motor"].to_dict()
    assert main(["robot", "init", str(path)]) == 2  # no silent overwrite


def _write(tmp_path, edit):
    path = tmp_path / "r.toml"
    robot_file.init(path)
    path.write_text(edit(path.read_text()))
    return path


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace("m_body =", "m_bdy ="), r"r.toml:4: \[robot\] m_bdy: unknown key"),
    (lambda t: t.replace("com_height = 0.04943", "com_height = \"tall\""), r"r.toml:\d+: \[robot\] com_height: 'tall' is not a finite number"),
    (lambda t: t.replace("g = 9.81", ""), r"\[robot\]: missing g"),
    (lambda t: t.replace("m_body = 0.8301", "m_body = -1.0"), r"r.toml:4: \[robot\] m_body: .*m_body"),
    (lambda t: t.replace("stall_current = 7.0", "stall_current = 7.0\nstal = 1"), r"\[motor\] stal: unknown key"),
    (lambda t: t.replace("[driver]", "[drivr]"), r"\[drivr\]: unknown table"),
    (lambda t: t.replace("m_body = 0.8301", "m_body = = 1"), r"not valid TOML"),
    # The motor's data sheet is read at the battery voltage: a battery of 0 was blamed on [motor].
    (lambda t: t.replace("battery = 11.1", "battery = 0"), r"r.toml:28: \[driver\] battery: invalid supply = 0"),
    # "... below the battery voltage" was blamed on battery, the key named in it first.
    (lambda t: t.replace("bridge_drop = 2.0", "bridge_drop = 20.0"), r"r.toml:29: \[driver\] bridge_drop: invalid bridge_drop"),
    # An integer beyond any float was a bare OverflowError (ValueError past 4300 digits).
    (lambda t: t.replace("m_body = 0.8301", "m_body = " + "9" * 400), r"r.toml:4: \[robot\] m_body: an integer of 400 digits"),
    (lambda t: t.replace("encoder_cpr = 700.0", "encoder_cpr = " + "9" * 400), r"r.toml:35: \[sensors\] encoder_cpr: an integer"),
    (lambda t: t.replace("m_body = 0.8301", "m_body = " + "9" * 5000), r"r.toml: not a robot file: .*4300 digits"),
    # A quoted or dotted key was placed at line 0.
    (lambda t: t.replace("m_body = 0.8301", '"m_body" = -1.0'), r"r.toml:4: \[robot\] m_body: invalid m_body"),
    (lambda t: t.replace("m_body = 0.8301", "m_body = 0.8301\nextra.x = 1"), r"r.toml:5: \[robot\] extra: unknown key"),
])
def test_errors_name_the_file_the_key_and_the_line(tmp_path, edit, message):
    with pytest.raises(twip.InvalidParameterError, match=message):
        twip.Robot.from_file(_write(tmp_path, edit))


def test_a_data_sheet_of_another_motor_is_not_passed_over_in_silence(tmp_path, recwarn):
    """The runs take [robot]'s torque_constant; the sheet sets the winding's resistance only.
    A sheet whose torque constant differs (here 100 rpm at no load: 2.5x the Balanbot's) was
    read with no word; the Balanbot's own sheet agrees to 0.05 % and stays quiet."""
    twip.Robot.from_file(_write(tmp_path, lambda t: t))
    assert not [w for w in recwarn if "torque_constant" in str(w.message)]
    with pytest.warns(UserWarning, match=r"torque_constant = 0.00992 N m/A, but the \[motor\] data sheet gives 0.0249"):
        robot = twip.Robot.from_file(_write(tmp_path, lambda t: t.replace("no_load_rpm = 251.0", "no_load_rpm = 100.0")))
    assert robot.params.torque_constant == 0.00992


def test_a_file_that_is_not_text_is_named(tmp_path):
    # It was a UnicodeDecodeError naming no file (a traceback on the command line).
    path = tmp_path / "bin.toml"
    path.write_bytes(b"\xff\xfe\x00bin")
    for read in (twip.Robot.from_file, twip.RobotParams.from_file):
        with pytest.raises(twip.InvalidParameterError, match=r"bin.toml: not a text file \(byte 0 is not UTF-8"):
            read(path)
    with pytest.raises(twip.InvalidParameterError, match=r"bin.toml'?: not a text file \(byte 0 is not UTF-8"):
        twip.RunLog.from_csv(path)


@pytest.mark.parametrize("forward, up, pitch, expected", [("+x", "+z", "-y", "+y"), ("-y", "+x", "+z", "-z"),
                                                         ("+y", "+z", "+x", "-x")])
def test_a_pitch_axis_against_up_and_forward_is_named(tmp_path, recwarn, forward, up, pitch, expected):
    # A pitch axis of the wrong sign for its forward and up axes was taken as given: on a
    # right-handed IMU, leaning forward is a positive rate about up x forward, and the
    # export's tilt filter ran its gyro against its accelerometer.
    def axes(f, u, p):
        return lambda t: (t.replace('imu_forward = "+x"', f'imu_forward = "{f}"').replace('imu_up = "+z"', f'imu_up = "{u}"')
                          .replace('imu_pitch = "+y"', f'imu_pitch = "{p}"'))

    with pytest.warns(twip.ImplausibleRobotWarning, match=rf'r.toml:39: \[sensors\] imu_pitch = "\{pitch}", but .* '
                                                          rf'about up x forward, "\{expected}"'):
        twip.Robot.from_file(_write(tmp_path, axes(forward, up, pitch)))
    recwarn.clear()
    assert twip.Robot.from_file(_write(tmp_path, axes(forward, up, expected))).sensors.imu_pitch == expected
    assert not [w for w in recwarn if "imu_pitch" in str(w.message)]


def test_a_file_too_large_for_a_robot_file_is_refused_before_it_is_held(tmp_path, capsys):
    # /dev/zero was read until a MemoryError; a log passed by mistake was held whole.
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * (1 << 20) + "\n")
    for path in (big, "/dev/zero"):
        with pytest.raises(twip.InvalidParameterError, match=r"more than 1,048,576 characters; a robot file is"):
            twip.Robot.from_file(path)
    assert main(["simulate", "flat-lqr", "--robot", "/dev/zero"]) == 2
    assert "more than 1,048,576 characters" in capsys.readouterr().err
    # A long array is named by its start: its whole repr made a 1 MB message.
    with pytest.raises(twip.InvalidParameterError, match=r"m_body: \[1.0, 1.0, .*\.\.\. \(a list of 200,000 items\) is not") as e:
        twip.Robot.from_file(_write(tmp_path, lambda t: t.replace("m_body = 0.8301", "m_body = [" + "1.0," * 200_000 + "]")))
    assert len(str(e.value)) < 300


def test_the_cli_runs_your_robot_and_its_driver(tmp_path, capsys):
    path = tmp_path / "heavy.toml"
    twip.RobotParams.balanbot().replace(m_body=1.2).to_file(path)
    assert main(["simulate", "flat-lqr-sim", "--robot", str(path), "--json"]) == 0
    import json

    mine = json.loads(capsys.readouterr().out)
    ours = twip.scenarios.get("flat-lqr-sim", params=twip.RobotParams.balanbot().replace(m_body=1.2)).run()
    assert mine["metrics"]["mean_abs_pitch_error"] == pytest.approx(ours.metrics["mean_abs_pitch_error"], rel=1e-12)
    # A driver with a lower current limit in the file changes the thesis-like run.
    weak = _write(tmp_path, lambda t: t.replace("current_limit = 2.0", "current_limit = 0.3"))
    assert main(["simulate", "flat-lqr", "--robot", str(weak), "--realism", "thesis-like", "--json"]) == 0
    limited = json.loads(capsys.readouterr().out)
    assert main(["simulate", "flat-lqr", "--realism", "thesis-like", "--json"]) == 0
    default = json.loads(capsys.readouterr().out)
    assert limited["metrics"]["mean_abs_pitch_error"] != default["metrics"]["mean_abs_pitch_error"]
    assert main(["sweep", "flat-lqr-sim", "-n", "4", "--robot", str(path), "--quiet", "--json"]) == 0
    assert main(["simulate", "flat-lqr", "--robot", str(tmp_path / "missing.toml")]) == 2
