"""Exports that are safe to flash: a folder holding files is not overwritten without
--force, an empty --out never means the current folder, the example firmware kills its
motors past a tilt cut-off, keeps time in integer ticks and drives direction and duty
pins, and the robot file's [sensors] reach the export and the rig."""
import re
import shutil
import subprocess
import warnings
from pathlib import Path

import pytest

import twip
from twip import robot_file
from twip.cli import main
from twip.firmware import export


def test_a_folder_that_holds_files_is_not_overwritten_without_force(tmp_path):
    export("flat-lqr", tmp_path, replay_seconds=0.1)
    example = tmp_path / "example.c"
    example.write_text("/* my edits */")
    with pytest.raises(twip.InvalidParameterError, match=r"the folder is not empty .*example.c.*force=True"):
        export("flat-lqr", tmp_path, replay_seconds=0.1)
    assert example.read_text() == "/* my edits */"
    assert main(["export", "flat-lqr", "--out", str(tmp_path), "--replay-seconds", "0.1"]) == 2
    assert example.read_text() == "/* my edits */"
    assert main(["export", "flat-lqr", "--out", str(tmp_path), "--replay-seconds", "0.1", "--force"]) == 0
    assert "TILT_CUTOFF_RAD" in example.read_text()


def test_an_empty_out_is_never_the_current_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["export", "flat-lqr", "--out", "", "--replay-seconds", "0.1"]) == 2
    assert "--out ''" in capsys.readouterr().err
    with pytest.raises(twip.InvalidParameterError, match=r"out = '': give the folder to write"):
        export("flat-lqr", "", replay_seconds=0.1)
    assert list(tmp_path.iterdir()) == []


def test_the_example_kills_the_motors_keeps_integer_ticks_and_drives_direction_pins(tmp_path):
    export("flat-lqr", tmp_path, replay_seconds=0.1)
    c = (tmp_path / "example.c").read_text()
    assert re.search(r"fabsf\(phi\) < TILT_CUTOFF_RAD", c) and "motors_off();" in c
    assert "static uint32_t ticks;" in c and "float t;" not in c and "t += " not in c
    assert "set_motor(int motor, int forward, uint16_t duty)" in c
    halt = re.search(r"static void halt\(TwipStatus status\) \{(.*?)\n\}", c, re.S).group(1)
    assert "printf" not in halt and "motors_off()" in halt
    h = (tmp_path / "twip_config.h").read_text()
    assert "#define TWIP_PWM_MAX 255" in h and "#define TWIP_IMU_FORWARD 0" in h


@pytest.mark.skipif(not shutil.which("cc"), reason="needs a C compiler")
@pytest.mark.parametrize("name, defines", [("flat-lqr", []), ("flat-lqr", ["-DDITHER_AMPS=0.8f"]), ("circle-pid", [])])
def test_the_example_compiles_warning_free(name, defines, tmp_path):
    """As it comes, and with the identification dither on (docs/sysid.md)."""
    export(name, tmp_path, replay_seconds=0.1)
    done = subprocess.run(["cc", "-fsyntax-only", "-std=c11", "-Wall", "-Wextra", "-Werror", "-DTWIP_HOST_MAIN",
                           *defines, "example.c", "twip_config.c"], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def _robot_with(tmp_path, sensors: str) -> "twip.Robot":
    path = tmp_path / "mine.toml"
    robot_file.init(path)
    text = path.read_text()
    text = text[:text.index("[sensors]")] + sensors
    path.write_text(text)
    return twip.Robot.from_file(path)


def _cpp_factor(folder) -> float:
    h = (folder / "twip_config.h").read_text()
    return float(re.search(r"#define TWIP_COUNTS_PER_RAD ([0-9.e+-]+)f", h).group(1))


def test_the_sensors_table_sets_the_exports_units_and_axes_and_the_rigs_encoder(tmp_path):
    import math

    robot = _robot_with(tmp_path, '[sensors]\nencoder_cpr = 1320\nimu_height = 0.05\nimu_forward = "-y"\n'
                                  'imu_up = "+x"\nimu_pitch = "+z"\n')
    assert robot.sensors.encoder_cpr == 1320 and robot.sensors.imu_height == 0.05
    realism = robot.realism()
    assert realism.encoder_cpr == 1320 and realism.imu.height == 0.05
    export("flat-lqr", tmp_path / "fw", robot=robot, replay_seconds=0.1)
    assert _cpp_factor(tmp_path / "fw") == pytest.approx(1320 / (2 * math.pi), rel=1e-6)
    assert "twip_encoder_cpr = 1320.0f" in (tmp_path / "fw" / "twip_config.c").read_text()
    h = (tmp_path / "fw" / "twip_config.h").read_text()
    assert "#define TWIP_IMU_FORWARD 1" in h and "#define TWIP_IMU_FORWARD_SIGN -1.0f" in h
    assert "#define TWIP_IMU_UP 0" in h and "#define TWIP_IMU_PITCH 2" in h


def test_a_robot_file_without_sensors_says_what_the_export_assumes(tmp_path):
    robot = _robot_with(tmp_path, "")
    assert robot.sensors is None
    with pytest.warns(UserWarning, match=r"no \[sensors\] table: the firmware-unit gains assume .* \(700 counts"):
        export("flat-lqr", tmp_path / "fw", robot=robot, replay_seconds=0.1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # SI units depend on no encoder
        export("flat-lqr", tmp_path / "si", robot=robot, units_="si", replay_seconds=0.1)


@pytest.mark.parametrize("sensors, message", [
    ('encoder_cpr = -700', r"\[sensors\] encoder_cpr: -700: counts per wheel turn must be > 0"),
    ('imu_up = "z"', r"\[sensors\] imu_up: 'z' is not an axis"),
    ('imu_forward = "+z"', r"three different axes"),
    ('cpr = 700', r"\[sensors\] cpr: unknown key"),
    ('imu_height = "12cm"', r"\[sensors\] imu_height: '12cm' is not a finite number"),
])
def test_bad_sensors_are_named_with_their_line(tmp_path, sensors, message):
    with pytest.raises(robot_file.RobotFileError, match=message):
        _robot_with(tmp_path, f"[sensors]\n{sensors}\n")


@pytest.mark.skipif(not shutil.which("cc"), reason="needs a C compiler")
def test_the_examples_drive_stops_a_motor_on_a_nan_duty(tmp_path):
    # drive() clamped |NaN| to TWIP_PWM_MAX and read NaN >= 0 as reverse: full reverse power.
    example = (Path(export.__globals__["__file__"]).parent / "templates" / "example.c").read_text()
    drive = re.search(r"static void drive\(int motor, float duty\) \{.*?\n\}", example, re.S).group(0)
    (tmp_path / "drive.c").write_text(f"""#include <math.h>
#include <stdint.h>
#include <stdio.h>
#define TWIP_PWM_MAX 255
static int pins[2][2];
static void set_motor(int motor, int forward, uint16_t duty) {{ pins[motor][0] = forward; pins[motor][1] = duty; }}
{drive}
int main(void) {{
    float duties[] = {{NAN, -NAN, INFINITY, -INFINITY, -300.0f, 100.7f, -3.0f, 0.0f}};
    for (int i = 0; i < 8; ++i) {{
        drive(1, duties[i]);
        printf("%d %d\\n", pins[1][0], pins[1][1]);
    }}
    return 0;
}}
""")
    subprocess.run(["cc", "-std=c11", "-Wall", "-Werror", "-o", "drive", "drive.c", "-lm"], cwd=tmp_path, check=True)
    done = subprocess.run(["./drive"], cwd=tmp_path, capture_output=True, text=True, check=True)
    assert done.stdout.split("\n")[:8] == ["1 0", "1 0", "1 255", "0 255", "0 255", "1 100", "0 3", "1 0"]
