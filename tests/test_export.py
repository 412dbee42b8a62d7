"""twip export and twip-ffi: the tuned controller of each family, exported, built with the
host's cc against the static library, and its recorded closed-loop run replayed through
the C ABI within 1e-5 relative (`make check`); the f32 run against the f64 one; the
configuration in firmware units and in SI."""
import re
import shutil
import subprocess

import numpy as np
import pytest

import twip
from twip import _core, scenarios
from twip.cli import main
from twip.firmware import export, header
from twip.firmware.export import FAMILIES, REPLAY_TOLERANCE

needs_tools = pytest.mark.skipif(not (shutil.which("cargo") and shutil.which("cc") and shutil.which("make")),
                                 reason="needs cargo, cc and make")
#: One scenario per family: LQR, fuzzy, PID, sliding mode with its fuzzy estimates.
ONE_PER_FAMILY = {"lqr": "flat-lqr", "fuzzy": "slope-fuzzy", "pid": "circle-pid", "smc": "circle-smc-fuzzy"}


def _check(folder) -> str:
    done = subprocess.run(["make", "-s", "-C", str(folder), "check"], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def _relative(output: str) -> float:
    return float(re.search(r", ([0-9.e+-]+) of the largest command", output).group(1))


@needs_tools
@pytest.mark.parametrize("family", sorted(ONE_PER_FAMILY))
def test_export_builds_and_replays_within_tolerance(family, tmp_path):
    summary = export(ONE_PER_FAMILY[family], tmp_path, replay_seconds=10.0)
    assert summary["family"] == family and summary["updates"] == 2000
    out = _check(tmp_path)
    assert out.startswith(f"{family}: 2000 updates replayed")
    assert _relative(out) <= REPLAY_TOLERANCE
    assert (tmp_path / "example").exists()


@needs_tools
def test_cli_export_then_make_check(tmp_path, capsys):
    assert main(["export", "flat-lqr", "--out", str(tmp_path / "fw")]) == 0
    assert "make -C" in capsys.readouterr().err
    assert _relative(_check(tmp_path / "fw")) <= REPLAY_TOLERANCE


@needs_tools
def test_the_check_fails_on_a_wrong_gain(tmp_path):
    export("flat-lqr", tmp_path, replay_seconds=2.0)
    config = tmp_path / "twip_config.c"
    text = config.read_text()
    gain = re.search(r"\.gains = \{\n\s+(-?[0-9.e-]+)f", text).group(1)
    config.write_text(text.replace(gain + "f", f"{float(gain) * 1.001!r}f", 1))
    done = subprocess.run(["make", "-s", "-C", str(tmp_path), "check"], capture_output=True, text=True, timeout=900)
    assert done.returncode != 0 and "updates replayed" in done.stdout


def test_firmware_units_write_each_conversion_beside_its_value(tmp_path):
    export("flat-lqr", tmp_path, replay_seconds=1.0)
    c = (tmp_path / "twip_config.c").read_text()
    h = (tmp_path / "twip_config.h").read_text()
    # 5 * f32(1 ms) is an ulp off f32(5 ms): written in SI, to be the library's f32.
    assert ".period = 0.005f,  /* SI: s (= 5 ms) */" in c
    assert "* TWIP_DEG_PER_RAD,  /*" in c and "A per deg of pitch" in c
    assert "A per encoder count per loop" in c
    cpr = float(re.search(r"#define TWIP_COUNTS_PER_RAD ([0-9.e+-]+)f", h).group(1)) * 2 * np.pi
    assert cpr == pytest.approx(twip.Realism.thesis_like().encoder_cpr, rel=1e-6)
    # The firmware value times its factor is the SI gain.
    sc = scenarios.get("flat-lqr")
    shown = float(re.search(r"\.gains = \{\n\s+(-?[0-9.e-]+)f \* TWIP_DEG_PER_RAD", c).group(1))
    assert shown * 180 / np.pi == pytest.approx(sc.controller.gains[0], rel=1e-6)


def test_the_sliding_mode_gains_are_counted_on_the_trackers_own_motor(tmp_path):
    # Thesis and errata T7: k_s3 = -2 PWM counts of the tracker's motor (11.1 V), not of the
    # feed-forward driver's (9.1 V here), which would show -2.44.
    export("circle-smc-fuzzy", tmp_path, replay_seconds=1.0)
    c = (tmp_path / "twip_config.c").read_text()
    h = (tmp_path / "twip_config.h").read_text()
    for name, counts in (("k_s3", -2), ("k_s4", -1), ("g_y4", 1)):
        line = re.search(rf"\.{name} = (-?[0-9.]+)f \* TWIP_TRACKER_NM_PER_PWM,  /\* (.*) \*/", c)
        assert line and line.group(1) == f"{counts:.1f}", name  # was -1.99999988
        assert line.group(2) == f"{counts} PWM counts of the tracker's motor", name
    own = _core.DcMotor.gb37y3530().torque_per_count()
    shown = float(re.search(r"#define TWIP_TRACKER_NM_PER_PWM ([0-9.e+-]+)f", h).group(1))
    assert shown == pytest.approx(own, rel=1e-6) and "11.1 V" in h


def _c_values(section: str, macros: dict) -> list:
    """The values of a C initialiser as the compiler forms them: an int, a float literal, or
    a literal times a float macro (an f32 product)."""
    out = []
    item = r"^\s*(?:\.\w+ = )?(-?INFINITY|-?[0-9][0-9.e+-]*f?)(?: \* (TWIP_\w+))?,"
    for lit, macro in re.findall(item, section, re.M):
        if not lit.endswith("f") and "INFINITY" not in lit:
            out.append(int(lit))
            continue
        x = np.float32(float(lit.rstrip("f").replace("INFINITY", "inf")))
        out.append(x * macros[macro] if macro else x)
    return out


def _flat(value) -> list:
    if isinstance(value, dict):
        return [v for item in value.values() for v in _flat(item)]
    if isinstance(value, list):
        return [v for item in value for v in _flat(item)]
    return [value]


@pytest.mark.parametrize("name", sorted(ONE_PER_FAMILY.values()))
def test_each_value_of_the_configuration_is_the_f32_the_rust_side_has(name, tmp_path):
    # k_s3 was written -1.99999988f * TWIP_TRACKER_NM_PER_PWM: its factor came from the
    # f32-rounded motor and f32(value) / factor was rounded to f32 again, an ulp off -2.
    export(name, tmp_path, replay_seconds=0.1)
    c = (tmp_path / "twip_config.c").read_text()
    h = (tmp_path / "twip_config.h").read_text()
    macros = {m: np.float32(float(v)) for m, v in re.findall(r"^#define (TWIP_\w+) (-?[0-9][0-9.e+-]*)f\b", h, re.M)}
    section = c[c.index("twip_controller_config = {"):]
    written = _c_values(section[:section.index("\n};")], macros)
    sc = scenarios.get(name)
    rec = _core.ffi_record(sc.model, sc.controller, [float(v) for v in sc.x0], 0.01, sc.dt, sc.reference)
    fam = FAMILIES[rec["family"]]
    wanted = _flat(header.decode(header.structs(), fam.config, rec["config"]))
    assert len(written) == len(wanted)
    for k, (w, v) in enumerate(zip(written, wanted)):
        assert np.asarray(w).tobytes() == np.asarray(v, dtype=type(w)).tobytes(), (k, w, v)


def test_float_literals_are_the_fewest_digits_that_read_back():
    from twip.firmware.units import c_float, in_unit

    assert [c_float(v) for v in (-2.0, 0.1, 5.0, 1e-5, 0.0, float("inf"))] == \
        ["-2.0f", "0.1f", "5.0f", "1e-05f", "0.0f", "INFINITY"]
    rng = np.random.default_rng(7)
    for v in (rng.standard_normal(2000) * 10.0 ** rng.integers(-8, 8, 2000)).astype(np.float32):
        assert np.float32(float(c_float(v)[:-1])) == v
    # -2 counts of 0.0110129 N m: exactly -2.0 (in f32 too); 5 ms is no f32 multiple of
    # f32(1 ms) in few digits (4.9999995 is), so it is left to SI.
    torque = twip.DcMotor.gb37y3530().torque_per_count()
    assert in_unit(-2 * torque, torque) == -2.0 and in_unit(0.005, 1e-3) is None


def test_si_units_write_plain_si(tmp_path):
    export("flat-lqr", tmp_path, units_="si", replay_seconds=1.0)
    c = (tmp_path / "twip_config.c").read_text()
    assert "* TWIP_" not in c and "/* SI: A/rad */" in c


@needs_tools
@pytest.mark.parametrize("units_", ["si", "firmware"])
def test_the_c_abi_answers_the_recorded_commands_bit_for_bit(units_, tmp_path):
    # The C ABI runs the same f32 code as the recording on the same f32 configuration, in
    # firmware units too: each `X * TWIP_FACTOR` is the recording's f32 (k_s3 was an ulp off).
    export("circle-smc-fuzzy", tmp_path, units_=units_, replay_seconds=5.0)
    assert _relative(_check(tmp_path)) == 0.0


@pytest.mark.parametrize("name", ["flat-lqr", "slope-fuzzy", "circle-pid", "circle-smc-fuzzy"])
def test_f32_run_follows_the_f64_run(name):
    """The f32 controller on the f32 plant (what the robot runs) against twip.simulate's
    f64 run, over 20 s at every controller update. Measured (notes): commands within
    1.2e-4 of their largest value, states within 1e-3 of their range, in every family."""
    sc = scenarios.get(name)
    seconds = min(sc.t_final, 20.0)
    rec = _core.ffi_record(sc.model, sc.controller, [float(v) for v in sc.x0], seconds, sc.dt, sc.reference)
    run = sc.run(t_final=seconds)
    at = np.rint(rec["t"].astype(float) / sc.dt).astype(int)
    states, inputs = run.states[at], run.inputs[at]
    span = np.maximum(np.abs(states).max(axis=0), 1e-9)
    assert np.max(np.abs(states - rec["y"]) / span) < 2e-3
    assert np.max(np.abs(inputs - rec["u"])) / np.abs(inputs).max() < 5e-4


def test_header_layout_matches_the_decoded_structs():
    layout = header.structs()
    for fam in FAMILIES.values():
        assert fam.config in layout and fam.state in layout and fam.reference in layout
    assert [f.name for f in layout["TwipRobot"]] == list(twip.RobotParams.fields)
    assert header.macros()["TWIP_OK"] == 0
    rec = _core.ffi_record(scenarios.get("flat-lqr").model, scenarios.get("flat-lqr").controller, [0.0] * 4,
                           0.01, 1e-3, twip.SpeedSchedule.constant(0.0))
    assert header.decode(layout, "TwipLqrConfig", rec["config"])["period"] == pytest.approx(0.005)
    with pytest.raises(ValueError, match="bytes"):
        header.decode(layout, "TwipLqrConfig", rec["config"][:-4])


def test_bad_arguments_are_named(tmp_path):
    with pytest.raises(twip.InvalidParameterError, match="units"):
        export("flat-lqr", tmp_path, units_="imperial")
    with pytest.raises(twip.InvalidParameterError, match="replay_seconds"):
        export("flat-lqr", tmp_path, replay_seconds=-1.0)
    with pytest.raises(TypeError, match="twip export takes"):
        _core.ffi_record(twip.SlopeModel(twip.RobotParams.balanbot(), 0.0), lambda t, y, r: 0.0, [0.0] * 4, 1.0,
                         1e-3, twip.SpeedSchedule.constant(0.0))
    (tmp_path / "file").write_text("")
    assert main(["export", "flat-lqr", "--out", str(tmp_path / "file")]) == 2
    with pytest.raises(twip.InvalidParameterError, match=r"out = '.*file': cannot create the folder \(File exists\)"):
        export("flat-lqr", tmp_path / "file")  # was a bare FileExistsError
    # Both were AttributeErrors ('str' object has no attribute 'params').
    with pytest.raises(TypeError, match=r"robot must be a twip.Robot \(from a robot file\) or None .*got 'x' \(str\)"):
        export("flat-lqr", tmp_path, robot="x")
    with pytest.raises(TypeError, match=r"scenario must be a scenario name or a twip.scenarios.Scenario, got 5 \(int\)"):
        export(5, tmp_path)
    # Raw OSErrors before: a name too long to read, a folder where a file goes; and a replay
    # shorter than a step was named t_final at the 32-bit build's rounding.
    with pytest.raises(twip.InvalidParameterError, match=r"out = '.*': cannot be read as a folder \(File name too long\)"):
        export("flat-lqr", tmp_path / ("x" * 300))
    (tmp_path / "held").mkdir()
    (tmp_path / "held" / "twip.h").mkdir()
    with pytest.raises(twip.InvalidParameterError, match=r"out = '.*held': cannot write twip.h \(Is a directory\)"):
        export("flat-lqr", tmp_path / "held", replay_seconds=0.1, force=True)
    with pytest.raises(twip.InvalidParameterError, match=r"replay_seconds = 1e-300: shorter than one step \(dt = 0.001 s\)"):
        export("flat-lqr", tmp_path / "new", replay_seconds=1e-300)


def test_a_replay_too_long_for_the_memory_budget_is_refused_before_it_is_recorded(tmp_path):
    long_run = scenarios.get("flat-lqr").replace(t_final=3e5)
    twip.set_memory_budget(200 << 20)
    try:
        with pytest.raises(twip.MemoryBudgetError, match=r"replay of 300000 s \(60,000,001 controller updates\).*"
                                                         r"shorter replay_seconds"):
            export(long_run, tmp_path, replay_seconds=3e5)
        assert not tmp_path.joinpath("replay_data.c").exists()
        assert export(long_run, tmp_path, replay_seconds=2.0)["updates"] == 400  # a short replay still fits
    finally:
        twip.set_memory_budget(None)


def test_an_install_without_sources_says_how_to_point_at_them(tmp_path, capsys, monkeypatch):
    # A wheel from PyPI carries no Rust sources: the export still writes everything and says
    # how to give a checkout, and the Makefile takes it as TWIP_SRC.
    monkeypatch.setenv("TWIP_SRC", str(tmp_path / "nowhere"))
    assert main(["export", "flat-lqr", "--out", str(tmp_path / "fw"), "--replay-seconds", "0.1"]) == 0
    err = capsys.readouterr().err
    assert "has no twip-ffi Cargo.toml" in err and "TWIP_SRC=" in err
    makefile = (tmp_path / "fw" / "Makefile").read_text()
    assert f"TWIP_SRC ?= {tmp_path / 'nowhere'}" in makefile
    monkeypatch.delenv("TWIP_SRC")
    summary = export("flat-lqr", tmp_path / "fw2", replay_seconds=0.1)
    assert summary["source_found"], summary["source"]


def _loop_period_macro(folder) -> float:
    h = (folder / "twip_config.h").read_text()
    return float(re.search(r"#define TWIP_LOOP_PERIOD_S ([0-9.e+-]+)f", h).group(1))


@needs_tools
def test_the_export_runs_at_the_scenarios_control_period(tmp_path):
    # Scenario.control_period is the loop period simulate runs: it was ignored, and the
    # export recorded and wrote the controller's own 5 ms while the simulation ran 10 ms.
    sc = scenarios.get("flat-lqr").replace(control_period=0.01)
    summary = export(sc, tmp_path, replay_seconds=2.0)
    assert summary["updates"] == 200
    assert _loop_period_macro(tmp_path) == pytest.approx(0.01)
    assert ".period = 0.01f,  /* SI: s (= 10 ms) */" in (tmp_path / "twip_config.c").read_text()
    assert _relative(_check(tmp_path)) <= REPLAY_TOLERANCE
    # The recording is the simulation's loop: an update every 10 ms, the same commands as
    # the f64 run within f32's rounding.
    rec = _core.ffi_record(sc.model, sc.controller, [float(v) for v in sc.x0], 2.0, sc.dt, sc.reference,
                           control_period=sc.control_period)
    np.testing.assert_allclose(np.diff(rec["t"].astype(float)), 0.01, atol=1e-6)
    run = sc.run(t_final=2.0)
    at = np.rint(rec["t"].astype(float) / sc.dt).astype(int)
    assert np.max(np.abs(run.inputs[at] - rec["u"])) / np.abs(run.inputs).max() < 5e-4
    # Without control_period, the controller's own period, as before.
    export("flat-lqr", tmp_path / "own", replay_seconds=0.5)
    assert _loop_period_macro(tmp_path / "own") == pytest.approx(0.005)


def _custom_robot(tmp_path) -> "twip.Robot":
    """A robot file whose motor and driver are not the Balanbot's (the audit's)."""
    from twip import robot_file

    path = tmp_path / "custom.toml"
    robot_file.init(path)
    text = path.read_text()
    for key, value in dict(gear_ratio=30.0, torque_constant=0.0135, battery=7.4, bridge_drop=0.5, stall_current=5.0,
                           rated_voltage=6.0, no_load_rpm=300.0, no_load_current=0.2).items():
        text = re.sub(rf"^{key} = [^#\n]*", f"{key} = {value!r}  ", text, flags=re.M)
    path.write_text(text)
    return twip.Robot.from_file(path)


def _motors(folder) -> list:
    """Every motor of the exported twip_config.c (SI units): resistance, gear ratio, supply."""
    c = (folder / "twip_config.c").read_text()
    found = re.findall(r"\.motor = \{\s*\.resistance = ([0-9.e+-]+)f.*?\.gear_ratio = ([0-9.e+-]+)f.*?"
                       r"\.supply = ([0-9.e+-]+)f", c, re.S)
    return [tuple(float(np.float32(v)) for v in m) for m in found]  # as the C compiler reads them


@pytest.mark.parametrize("name", ["circle-pid", "circle-smc-fuzzy"])
def test_a_robot_files_motor_is_the_trackers_and_the_pwm_feed_forwards(name, tmp_path):
    # The trackers kept the Balanbot's GB37 (1.71 ohm, 43.7:1, 11.1 V) for their torque
    # limits and PWM conversion while twip_pwm_config drove the file's motor.
    robot = _custom_robot(tmp_path)
    export(name, tmp_path / "fw", robot=robot, units_="si", replay_seconds=0.5)
    tracker, pwm = _motors(tmp_path / "fw")
    motor, driver = robot.motor, robot.driver
    f32 = lambda v: float(np.float32(v))  # noqa: E731
    assert tracker == (f32(motor.resistance), 30.0, f32(driver.battery))
    # The feed-forward assumes the battery less the bridge's drop (docs/firmware.md).
    assert pwm == (f32(motor.resistance), 30.0, f32(driver.battery - driver.bridge_drop))
    # The CLI's --robot does the same, and so does its simulate.
    assert main(["export", name, "--robot", str(tmp_path / "custom.toml"), "--out", str(tmp_path / "cli"),
                 "--units", "si", "--replay-seconds", "0.5"]) == 0
    assert _motors(tmp_path / "cli") == [tracker, pwm]
    from twip.cli.args import get_scenario

    simulated = get_scenario(name, params=robot.params, robot_file=str(tmp_path / "custom.toml"))
    assert _tracker_motor_dict(simulated.controller) == motor.to_dict()


@pytest.mark.parametrize("name", ["circle-pid", "circle-smc-fuzzy"])
def test_by_default_the_tracker_and_the_feed_forward_are_the_simulations_two_motors(name, tmp_path):
    # As export's docstring and docs/firmware.md say (the docstring said "one motor
    # throughout" for the default too): the thesis's GB37 at 11.1 V in the tracker, the
    # thesis-like driver's 11.1 - 2.0 V in the feed-forward, as `twip simulate` runs them.
    export(name, tmp_path, units_="si", replay_seconds=0.5)
    tracker, pwm = _motors(tmp_path)
    f32 = lambda v: float(np.float32(v))  # noqa: E731
    gb37, driver = twip.DcMotor.gb37y3530(), twip.Realism.thesis_like().motor
    assert tracker == (f32(gb37.resistance), f32(gb37.gear_ratio), f32(11.1))
    assert pwm[2] == f32(driver.assumed_battery - driver.bridge_drop) == f32(9.1)
    assert "two motors" in export.__doc__ and "one motor throughout" in export.__doc__


def _tracker_motor_dict(controller) -> dict:
    return (controller.motor if isinstance(controller, twip.PidTracker) else controller.to_dict()["motor"]).to_dict()


def test_a_scenario_built_for_another_motor_than_the_robot_files_is_refused(tmp_path):
    robot = _custom_robot(tmp_path)
    balanbot_motor = scenarios.get("circle-pid", params=robot.params)
    with pytest.raises(twip.InvalidParameterError, match=r"robot: the scenario's tracker assumes DcMotor\(resistance=1.71"):
        export(balanbot_motor, tmp_path / "fw", robot=robot, replay_seconds=0.5)
    same = scenarios.get("circle-pid", params=robot.params, **scenarios.robot_options("circle-pid", robot))
    assert export(same, tmp_path / "fw", robot=robot, replay_seconds=0.5)["family"] == "pid"
    # The Balanbot's own file changes nothing: its data sheet is the GB37's.
    from twip import robot_file

    robot_file.init(tmp_path / "balanbot.toml")
    balanbot = twip.Robot.from_file(tmp_path / "balanbot.toml")
    assert balanbot.controller_motor().to_dict() == twip.DcMotor.gb37y3530().to_dict()


def test_values_out_of_f32_or_of_the_loop_are_named_with_the_value_given(tmp_path):
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    huge_gain = scenarios.get("flat-lqr").replace(controller=twip.LqrController(model, [-1e39, -1.7, -0.05, -0.045]))
    with pytest.raises(twip.InvalidParameterError, match=r"invalid gains\[0\] = -1e39: does not fit in f32"):
        export(huge_gain, tmp_path, replay_seconds=1.0)  # was "gains[0] = -inf is not finite"
    tiny_period = scenarios.get("flat-lqr").replace(
        controller=twip.LqrController(model, [-11, -1.7, -0.05, -0.045], period=1e-50))
    with pytest.raises(twip.InvalidParameterError,
                       match=r"controller.period = 1e-50 s: .* at least the scenario's dt = 0.001 s"):
        export(tiny_period, tmp_path, replay_seconds=1.0)  # was a MemoryBudgetError for 1e47 updates
    with pytest.raises(twip.InvalidParameterError, match=r"control_period = 0.0005 s: .*dt = 0.001 s"):
        export(scenarios.get("flat-lqr").replace(control_period=5e-4), tmp_path, replay_seconds=1.0)
    # A robot's value prints as the user wrote it, not in 301 digits.
    with pytest.raises(twip.InvalidParameterError, match=r"^invalid m_body = 1e\+?300: "):
        twip.RobotParams.balanbot().replace(m_body=1e300)
    assert not (tmp_path / "replay_data.c").exists()
