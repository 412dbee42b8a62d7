"""twip.identify, RunLog, Sensors and `twip identify` on bad input: each is refused with an
error naming the parameter and its value (a TypeError for a wrong type), before any work,
never a raw numpy or Python exception, a misdiagnosis or a fit of nothing."""
import math

import numpy as np
import pytest

import twip
from twip import scenarios, sysid
from twip.cli import main
from twip.sysid import LogError, RunLog, Sensors, identify, units
from twip.sysid.problem import Problem

ROBOT = twip.RobotParams.balanbot()


@pytest.fixture(scope="module")
def log():
    """An exact 1 s flat-lqr run."""
    sc = scenarios.get("flat-lqr")
    return twip.simulate(sc.model, sc.controller, [0.05, 0, 0, 0], 1.0, dt=1e-3, reference=sc.reference).to_log()


@pytest.fixture
def csv_log(tmp_path, log):
    path = tmp_path / "run.csv"
    log.to_csv(path)
    return path


def test_a_slope_beyond_90_degrees_is_refused_by_name(log, csv_log, capsys):
    # slope=2.0 reached the estimator: "'NoneType' object is not subscriptable".
    for slope in (2.0, -math.pi / 2):
        with pytest.raises(LogError, match=rf"^slope = {slope!r} rad \(-?\d+(\.\d+)? deg\): must be within"):
            RunLog(log.t, u=log.u, phi=log.phi, theta=log.theta, slope=slope)
    assert main(["identify", str(csv_log), "--free", "m_body", "--slope", "100"]) == 2
    assert "slope = 1.745" in capsys.readouterr().err


def test_a_start_whose_prediction_is_not_finite_is_diagnosed():
    # The first evaluation's "not finite" was dropped and the search went on: a LinAlgError.
    t = np.arange(200) * 1e-3
    wild = RunLog(t, u=np.full(200, 1e100), phi=np.zeros(200), theta=np.zeros(200))
    with pytest.raises(LogError, match="the prediction from the start robot .* is not finite"):
        identify(wild, ROBOT, ["m_body"])


def test_a_free_parameter_at_the_edge_of_its_range_is_not_blamed_on_the_log(log):
    # Both were "the log's columns disagree" diagnoses (the first "theta: the wheels turn
    # against the input ... reversed encoder?"): a difference step out of the range.
    with pytest.raises(LogError, match=r"^free: 'mu_ground' starts at 0.0; .* must start > 0"):
        identify(log, ROBOT.replace(mu_ground=0.0), ["mu_ground"])
    assert identify(log, ROBOT.replace(mu_ground=0.001), ["mu_ground"]).converged
    t = np.arange(500) * 1e-3
    pwm = RunLog(t, pwm=50 * np.sin(20 * t), phi=np.zeros_like(t), theta=np.zeros_like(t))
    ideal = twip.MotorDriver.thesis_like().replace(efficiency=1.0)
    with pytest.raises(twip.InvalidParameterError, match=r"^free: invalid efficiency = 1.00001.*edge of its") as e:
        identify(pwm, ROBOT, ["efficiency"], driver=ideal)
    assert not isinstance(e.value, LogError)


@pytest.mark.parametrize("height, error, message", [
    (float("nan"), twip.InvalidParameterError, "imu_height must be finite and >= 0, got nan"),
    (1e300, twip.InvalidParameterError, r"imu_height = 1e\+300: must be at most 10 m"),
    (-5, twip.InvalidParameterError, "imu_height must be finite and >= 0, got -5"),
    ("0.1", TypeError, r"imu_height must be a real number, got '0.1' \(str\)")])
def test_an_imu_height_out_of_range_is_refused_by_name(height, error, message, csv_log, capsys):
    # nan and 1e300 were numpy's "SVD did not converge", -5 ran.
    with pytest.raises(error, match=message):
        Sensors(imu_height=height)
    if not isinstance(height, str):
        assert main(["identify", str(csv_log), "--free", "m_body", "--imu-height", str(height)]) == 2
        assert "--imu-height: imu_height" in capsys.readouterr().err
    with pytest.raises(TypeError, match=r"imu must be a twip.Imu or None, got 'x' \(str\)"):
        Sensors(imu="x")
    with pytest.raises(twip.InvalidParameterError, match="encoder_cpr must be finite and > 0, got 0"):
        Sensors(encoder_cpr=0)


def test_a_tiny_time_step_allocates_by_the_log_not_by_the_step():
    # The low-pass windows were sized 0.05 s / the median step: 373 GiB for 1e-12 s.
    n = 30
    wave = np.sin(np.arange(n) * 1.0)
    for step in (1e-12, 1e-320):  # 1e-320: 0.05 s is inf steps
        RunLog(np.arange(n) * step, u=wave, gyro=wave, phi=0.1 * np.cos(np.arange(n) * 1.0))
    # The wheels' sign check of a diagnosis (0.1 s).
    log = RunLog(np.arange(n) * 1e-12, u=wave, phi=0.1 * wave, theta=wave)
    problem = Problem(log, ROBOT, ["m_body"], None, None, 1.0, Sensors(), None, 1e-3)
    assert units.diagnosis(problem, ValueError("x")).startswith("the prediction from the start robot")


def test_free_and_sensors_of_the_wrong_type_or_empty_are_named(log, csv_log, capsys):
    with pytest.raises(TypeError, match=r"^free must be parameter names .*, got None \(NoneType\)"):
        identify(log, ROBOT, None)
    with pytest.raises(TypeError, match=r"^free\[1\] must be a parameter name, got 3 \(int\)"):
        identify(log, ROBOT, ["m_body", 3])
    with pytest.raises(TypeError, match=r"^sensors must be a twip.sysid.Sensors or None, got 'x' \(str\)"):
        identify(log, ROBOT, ["m_body"], sensors="x")
    # An empty list was a "converged" fit of nothing.
    for free in ([], ","):
        with pytest.raises(LogError, match=r"^free = \[\]: name at least one parameter"):
            identify(log, ROBOT, free)
    assert main(["identify", str(csv_log), "--free", ","]) == 2
    assert "free = []" in capsys.readouterr().err


def test_from_csv_refuses_bad_arguments_and_cells_by_name(tmp_path, csv_log):
    with pytest.raises(TypeError, match=r"^scale must be a dict .*, got \[\('u', 2\)\] \(list\)"):
        RunLog.from_csv(csv_log, scale=[("u", 2)])
    with pytest.raises(TypeError, match=r"^columns must be a dict .*, got \['t'\] \(list\)"):
        RunLog.from_csv(csv_log, columns=["t"])
    with pytest.raises(TypeError, match=r"^path must be a file path \(str or Path\), got 5 \(int\)"):
        RunLog.from_csv(5)
    path = tmp_path / "big.csv"
    path.write_text("t,u\n0,0\n1," + "1" * 200_000 + "\n")
    with pytest.raises(LogError, match=rf"^{path}: line 3: field larger than field limit"):
        RunLog.from_csv(path)
    path = tmp_path / "under.csv"
    path.write_text("t,u\n0,0\n0.001,1_0\n")
    with pytest.raises(LogError, match=r"column 'u', row 3: '1_0' is not a number"):
        RunLog.from_csv(path)
    # A spreadsheet's byte order mark was read into the first header ('\ufefft').
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbft,u,phi\n0,0,0\n0.001,1,0\n")
    assert RunLog.from_csv(path).u.tolist() == [0.0, 1.0]


def test_cli_identify_checks_its_outputs_before_the_fit(csv_log, capsys, monkeypatch):
    monkeypatch.setattr(sysid, "identify", lambda *a, **k: pytest.fail("the fit ran"))
    assert main(["identify", str(csv_log), "--free", "m_body", "--plot", str(csv_log.with_name("f.xyz"))]) == 2
    assert "--plot: figure path" in capsys.readouterr().err
    assert main(["identify", str(csv_log), "--free", "m_body", "--out", "/nonexistent/dir/f.toml"]) == 2
    err = capsys.readouterr().err
    assert "--out: output '/nonexistent/dir/f.toml': the folder /nonexistent/dir does not exist" in err
    # The log itself was overwritten by the fitted robot's TOML.
    before = csv_log.read_bytes()
    same = csv_log.parent / "." / csv_log.name
    assert main(["identify", str(csv_log), "--free", "m_body", "--out", str(same)]) == 2
    assert f"--out {same}: is the log being fitted" in capsys.readouterr().err
    assert csv_log.read_bytes() == before


def test_numpy_numbers_are_taken_and_bools_refused(log, csv_log):
    assert RunLog(log.t, u=log.u, phi=log.phi, slope=np.float32(0.25)).slope == float(np.float32(0.25))
    with pytest.raises(TypeError, match=r"^slope must be a real number, got True \(bool\)"):
        RunLog(log.t, u=log.u, phi=log.phi, slope=True)
    fit = identify(log, ROBOT, ["m_body"], segment=np.float32(0.25), max_step=np.float32(1e-3), max_iter=np.int64(3))
    assert fit.converged
    for kw, message in ((dict(max_iter=True), r"^max_iter must be a positive integer, got True \(bool\)"),
                        (dict(segment=True), r"^segment must be a real number, got True \(bool\)"),
                        (dict(max_step="x"), r"^max_step must be a real number, got 'x' \(str\)")):
        with pytest.raises(TypeError, match=message):
            identify(log, ROBOT, ["m_body"], **kw)
    assert np.array_equal(RunLog.from_csv(csv_log, scale={"u": np.float32(2)}).u, 2 * log.u)
    with pytest.raises(TypeError, match=r"^scale\['u'\] must be a number or a unit name .*, got True \(bool\)"):
        RunLog.from_csv(csv_log, scale={"u": True})


def test_cli_identify_reads_and_keeps_the_robot_files_sensors(tmp_path, log, capsys):
    # The file's encoder_cpr was ignored for 700 (an enc column of a 1440-count encoder
    # misfit by 216 counts RMS, exit 1), and --out dropped the [sensors] table.
    from twip import robot_file

    path = tmp_path / "enc.csv"
    RunLog(log.t, u=log.u, phi=log.phi, enc=(log.theta - log.phi) * 1440 / (2 * math.pi)).to_csv(path)
    start = tmp_path / "start.toml"
    robot_file.init(start)
    start.write_text(start.read_text().replace("encoder_cpr = 700.0", "encoder_cpr = 1440.0")
                     .replace('imu_forward = "+x"', 'imu_forward = "-x"'))
    fitted = tmp_path / "fitted.toml"
    assert main(["identify", str(path), "--robot", str(start), "--free", "m_body", "--out", str(fitted)]) == 0
    assert "MISFIT" not in capsys.readouterr().out
    assert twip.Robot.from_file(fitted).sensors == twip.Robot.from_file(start).sensors
    # A flag still overrides the file.
    assert main(["identify", str(path), "--robot", str(start), "--free", "m_body", "--encoder-cpr", "700"]) == 1
    assert "MISFIT: enc" in capsys.readouterr().out


def test_from_csv_holds_the_numbers_only_within_the_budget(tmp_path):
    # The rows were read whole as text first (a 318 MB log took 1.77 GB, 5.6x), unchecked.
    path, small = tmp_path / "log.csv", tmp_path / "small.csv"
    path.write_text("t,u,phi,note\n" + "".join(f"{i},1,0,a\n" for i in range(70_000)))
    small.write_text("t,u,phi,note\n0,0,0,a\n0.001,1,0,b\n0.002,1,0,c\n")
    twip.set_memory_budget(1 << 20)
    try:
        with pytest.raises(twip.MemoryBudgetError, match=r"RunLog.from_csv\(.*log.csv'\) would need 6,291,456 bytes"):
            RunLog.from_csv(path, scale={"t": "ms"})
        assert RunLog.from_csv(small).phi.tolist() == [0.0, 0.0, 0.0]  # a small log is not held to it
    finally:
        twip.set_memory_budget(None)
    assert len(RunLog.from_csv(path, scale={"t": "ms"})) == 70_000
    # A file without line breaks is refused at its first long line, not held whole.
    path.write_text("t,u\n" + "0," * 600_000 + "\n")
    with pytest.raises(LogError, match=r"log.csv: line 2 is longer than 1,048,576 characters"):
        RunLog.from_csv(path)


def test_from_csv_skips_blank_lines_and_names_another_separator(tmp_path):
    # An editor's trailing blank lines were "column 't', row 5: '(missing)' is not a number".
    path = tmp_path / "log.csv"
    path.write_text("t,u,phi\n0,0,0\n0.001,1,0\n\n0.002,1,0\n\n   \n")
    assert RunLog.from_csv(path).t.tolist() == [0.0, 0.001, 0.002]
    path.write_text("t,u,phi\n0,0,0\n0.001,,0\n")
    with pytest.raises(LogError, match=r"column 'u', row 3: '' is not a number"):
        RunLog.from_csv(path)
    # A spreadsheet's export with decimal commas was told to map a column to 't'.
    path.write_text("t;u;phi\n0;0;0\n0,001;1;0\n")
    with pytest.raises(LogError, match=r"the header 't;u;phi' is one column: the file is separated by ';'"):
        RunLog.from_csv(path)


def test_cli_identify_out_keeps_a_fitted_resistance(tmp_path):
    # The robot file had no place for the driver's resistance: --out wrote the sheet's
    # 1.714 ohm beside "wrote", exit 0, for a fitted 2.2 ohm.
    from twip import robot_file

    base = twip.Realism.thesis_like().replace(friction=None, backlash=None)
    truth = base.motor.replace(inductance=0.0, current_limit=None, resistance=2.2)
    sc = scenarios.get("flat-lqr")
    run = twip.simulate(sc.model, sc.controller, [0.05, 0, 0, 0], 2.0, reference=sc.reference,
                        realism=base.replace(motor=truth))
    path, start, fitted = tmp_path / "pwm.csv", tmp_path / "start.toml", tmp_path / "fitted.toml"
    run.to_log().to_csv(path)
    robot_file.init(start)
    start.write_text(start.read_text().replace("inductance = 0.001", "inductance = 0.0")
                     .replace("current_limit = 2.0", "current_limit = 0.0"))
    assert main(["identify", str(path), "--robot", str(start), "--free", "resistance", "--imu-dlpf", "42",
                 "--out", str(fitted)]) == 0
    assert twip.Robot.from_file(fitted).driver.resistance == pytest.approx(2.2, rel=1e-3)  # measured: 2.20009
    # Without the key, the [motor] sheet's, as before.
    assert twip.Robot.from_file(start).driver.resistance == pytest.approx(12 / 7, rel=1e-12)


def test_from_csv_names_a_column_named_like_a_signal_that_it_leaves_out(tmp_path, capsys):
    # "Gyro (rad/s)" was dropped without a word (RunLog.ignored, printed nowhere), and a
    # "t [s]" header was told to map "..." to 't'.
    path = tmp_path / "log.csv"
    path.write_text("t,u,phi,Gyro (rad/s),PWM,note\n0,0,0,0,0,a\n0.001,1,0,0.5,0,b\n0.002,1,0,0.5,0,c\n")
    with pytest.warns(UserWarning, match=r"column 'Gyro \(rad/s\)' is not read: .* give columns=\{'Gyro \(rad/s\)': "
                                         r"'gyro'\} \(--column 'Gyro \(rad/s\)=gyro'\)") as seen:
        log = RunLog.from_csv(path)
    assert len(seen) == 1 and log.ignored == ("Gyro (rad/s)", "PWM", "note")  # PWM: u is the input
    assert RunLog.from_csv(path, columns={"Gyro (rad/s)": "gyro"}).gyro.tolist() == [0.0, 0.5, 0.5]
    path.write_text("t [s],u,phi\n0,0,0\n0.001,1,0\n")
    with pytest.raises(LogError, match=r"map one with columns=\{'t \[s\]': 't'\} \(--column 't \[s\]=t'\)"):
        RunLog.from_csv(path)


def test_t_in_microseconds_is_named_and_read(tmp_path):
    # An Arduino's micros() (1000 per 1 ms sample) was told "in milliseconds? scale t=ms",
    # which left it 1000x off, refused again as an interval of 1 s.
    t = np.arange(100) * 1e-3
    z = np.zeros_like(t)
    with pytest.raises(LogError, match=r"^t: the median interval is 1000 s .*in microseconds\? .*scale=\{'t': 'us'\} "
                                       r"\(--scale t=us\)"):
        RunLog(t * 1e6, u=z, phi=z)
    path = tmp_path / "micros.csv"
    path.write_text("t,u,phi\n" + "".join(f"{1000 * i},0,0\n" for i in range(100)))
    assert np.array_equal(RunLog.from_csv(path, scale={"t": "us"}).t, np.arange(100) * 1000 * 1e-6)
