"""Identification that knows when it does not fit (issue 61): the residual check, the route
for logs at the loop period, one default driver, friction on the command line, and CSV
columns that are refused by name. The robot is not the Balanbot: the issue's 1.8 kg body,
0.12 m centre of mass, 40 mm wheels, 30:1 motor and 3 A driver."""
import math
import warnings

import numpy as np
import pytest

import twip
from twip import robot_file, scenarios
from twip.cli import main
from twip.sysid import LogError, RunLog, Sensors, identify

FREE = ["m_body", "com_height", "i_body", "mu_bearing"]
USER = twip.RobotParams.balanbot().replace(m_body=1.8, m_wheels=0.1, i_body=0.0135, i_wheels=2e-5, i_motor=3e-6,
                                           gear_ratio=30.0, torque_constant=0.012, wheel_radius=0.02, com_height=0.12,
                                           mu_bearing=0.008, mu_ground=0.002)
#: The issue's 3 A driver on the thesis-like bridge; its 30:1 gearbox's losses are not given, so
#: lossless (with the GB37's 0.87 the filter-declared fit below is within 1.51 %, not 0.67 %).
DRIVER = twip.MotorDriver.thesis_like().replace(current_limit=3.0, efficiency=1.0)
#: Each free parameter 20-25 % off the truth.
START = USER.replace(m_body=1.8 * 1.2, com_height=0.12 * 0.8, i_body=0.0135 * 1.25, mu_bearing=0.008 * 0.85)


def rig_log(seconds, friction=False, robot=USER, driver=DRIVER, seed=0):
    # Without the estimator's settle at rest (`Realism.settle`): these logs' excitation includes
    # the start's transient (the estimate starting from the released robot's accelerometer).
    # Settled, 8 s from 0.05 rad did not converge on USER (seeds 0 and 1); 20 s converged with
    # m_body -2.2 % (2.9 sigma). See docs/sysid.md.
    rig = twip.Realism.thesis_like(seed=seed).replace(motor=driver, settle=None)
    if not friction:
        rig = rig.replace(friction=None, backlash=None)
    sc = scenarios.get("flat-lqr", params=robot, controller_params=robot)
    run = twip.simulate(sc.model, sc.controller, [0.05, 0, 0, 0], seconds, dt=1e-3, reference=sc.reference, realism=rig)
    assert run.outcome == "completed"
    return run.to_log(), rig


def every(log, k):
    return RunLog(log.t[::k], slope=log.slope, **{n: v[::k] for n, v in log.signals().items()})


def write_csv(path, log, t=None, **changes):
    """The log's CSV with some columns changed (as a firmware might write them: RunLog refuses them)."""
    columns = {**log.signals(), **changes}
    table = np.column_stack([log.t if t is None else t, *columns.values()])
    np.savetxt(path, table, delimiter=",", header=",".join(["t", *columns]), comments="", fmt="%.17g")


def errors(fit, robot=USER):
    return {n: fit.values[n] / getattr(robot, n) - 1 for n in FREE}


def quiet_identify(*args, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = identify(*args, **kwargs)
    return fit, [w for w in caught if issubclass(w.category, twip.SysidMisfitWarning)]


def test_a_fit_without_the_imus_filter_warns_and_with_it_is_quiet_and_within_1_5_percent():
    """The user's case: a 1 kHz rig log fitted without declaring the IMU's 42 Hz filter converged
    quietly, far off. Measured (8 s): undeclared, not converged at m_body +842 %, i_body +1066 %, every signal's
    residual 17-41x its noise; declared, within 0.67 % (i_body -0.67 %), residuals 0.1-1.1x."""
    log, rig = rig_log(8.0)
    blind, caught = quiet_identify(log, START, FREE, driver=DRIVER, sensors=Sensors(imu_height=rig.imu.height))
    assert blind.misfits and caught, blind.summary()
    assert "MISFIT" in blind.summary() and set(blind.misfits) <= set(blind.warnings)
    fit, caught = quiet_identify(log, START, FREE, driver=DRIVER, sensors=Sensors.of(rig))
    assert fit.converged and not fit.warnings and not caught, fit.summary()
    assert max(abs(e) for e in errors(fit).values()) < 0.015, errors(fit)


def test_a_log_at_the_loop_period_replays_the_filter_at_the_imus_rate():
    """A firmware's 5 ms log: the IMU's filter runs at 1 kHz between the logged rows, the duty
    held. It was refused ("its filter can only be replayed at its own rate"). Measured (8 s):
    within 0.24 % (i_body -0.24 %); without the filter declared: m_body +33 %,
    com_height -40 %, the gyro's residual 3.9x its noise, and a warning."""
    log, rig = rig_log(8.0)
    slow = every(log, 5)
    fit, caught = quiet_identify(slow, START, FREE, driver=DRIVER, sensors=Sensors.of(rig))
    assert fit.converged and not fit.warnings and not caught, fit.summary()
    assert max(abs(e) for e in errors(fit).values()) < 0.03, errors(fit)
    blind, caught = quiet_identify(slow, START, FREE, driver=DRIVER, sensors=Sensors(imu_height=rig.imu.height))
    assert blind.warnings and caught, blind.summary()
    # An interval that is not a whole number of the IMU's samples is refused, named.
    with pytest.raises(LogError, match=r"t: the interval after row 0 \(0.005 s, from t = 0.0\) is 2.3 of the IMU"):
        identify(slow, START, FREE, driver=DRIVER, sensors=Sensors(imu=rig.imu.replace(sample_rate=460.0)))


HEAVY = twip.RobotParams.balanbot().replace(m_body=4.0, m_wheels=0.4, i_body=0.06, i_wheels=7.2e-4, i_motor=6e-6,
                                            gear_ratio=45.0, torque_constant=0.02, wheel_radius=0.06, com_height=0.21,
                                            mu_bearing=0.025, mu_ground=0.006)


def test_an_encoder_whose_counts_hold_between_rows_is_not_a_misfit():
    """A 4 kg robot (0.21 m, 120 mm wheels, 45:1, 3.5 A driver), its 5 ms rig log with the
    sensors declared: within 0.52 %, but the encoder's residual (0.292 counts, the rounding's
    own 1/sqrt(12)) was 5x as correlated as white noise, and the Fit warned. Its wheels turn
    less than a count between some rows, so the counting error holds from row to row: the
    check now compares with the rounding of the fit's own prediction (`misfit.counting_time`).
    A wrong driver is still no quiet answer: its prediction blows up, and the error names the
    driver beside the columns' units."""
    driver = twip.MotorDriver.thesis_like().replace(current_limit=3.5)
    log, rig = rig_log(8.0, robot=HEAVY, driver=driver)
    slow = every(log, 5)
    start = HEAVY.replace(**{n: getattr(HEAVY, n) * f for n, f in
                             (("m_body", 1.2), ("com_height", 0.8), ("i_body", 1.25), ("mu_bearing", 0.85))})
    fit, caught = quiet_identify(slow, start, FREE, driver=driver, sensors=Sensors.of(rig))
    assert fit.converged and not fit.warnings and not caught, fit.summary()
    assert max(abs(e) for e in errors(fit, HEAVY).values()) < 0.03, errors(fit, HEAVY)
    with pytest.raises(LogError, match=r"check each one's unit and sign: .*the motor driver \(driver="):
        identify(slow, start, FREE, driver=twip.MotorDriver(), sensors=Sensors.of(rig))


def test_an_encoder_that_counts_only_a_creeping_wheels_staircase_is_left_out_there():
    """A robot balancing in place (an audit's robot, thesis-like rig, 700 CPR, settled, noise
    seed 9): its wheels creep about a count per segment. Compared there, the encoder's
    staircase biased mu_bearing +14.7 %, 9.0 deviations off, converged and quiet (over 19
    such fits, +5 to +22 %). Those segments' encoder rows are left out, and the fit says so."""
    r = twip.RobotParams.balanbot().replace(
        m_body=0.9224902067101121, m_wheels=0.07087306561502225, i_body=0.005774388826724214,
        i_wheels=5.375900185065631e-05, i_motor=4.176299387090223e-06, gear_ratio=39.08389287099587,
        torque_constant=0.011214087827639453, wheel_radius=0.03704723365277659, com_height=0.03701332706762869,
        mu_bearing=0.009000691769371249, mu_ground=0.001921107585622368)
    driver = twip.MotorDriver.thesis_like()
    rig = twip.Realism.thesis_like(seed=9).replace(motor=driver, friction=None, backlash=None)
    sc = scenarios.get("flat-lqr", params=r, controller_params=r)
    run = twip.simulate(sc.model, sc.controller, [0, 0, 0, 0], 8.0, dt=1e-3, reference=None, realism=rig)
    start = r.replace(m_body=r.m_body * 1.2, com_height=r.com_height * 0.8, i_body=r.i_body * 1.25,
                      mu_bearing=r.mu_bearing * 0.85)
    fit, _ = quiet_identify(run.to_log(), start, FREE, driver=driver, sensors=Sensors.of(rig))
    assert fit.converged, fit.summary()
    for n in FREE:
        assert abs(fit.values[n] - getattr(r, n)) < 3 * fit.std[n], (n, fit.summary())
    assert "NOTE: enc: left out in" in fit.summary()


def test_the_full_rig_with_friction_declared_from_the_command_line(tmp_path, capsys):
    """The full thesis-like rig (gearhead friction and backlash). Plain, the fit does not explain
    the log: exit 1 and no --out (it wrote the robot before, m_body -19 % on the Balanbot's rig).
    With the friction declared and the Coulomb level free (measured from Python): within 2.4 %
    (i_body -2.39 %, m_body -0.91 %); plain: mu_bearing +91 %, the encoder's residual 6.8x its noise."""
    log, rig = rig_log(8.0, friction=True)
    log.to_csv(tmp_path / "rig.csv")
    driver = dict(robot_file.balanbot_driver(), current_limit=3.0, efficiency=DRIVER.efficiency)
    robot_file.save(START, tmp_path / "start.toml", None, driver)
    command = ["identify", str(tmp_path / "rig.csv"), "--robot", str(tmp_path / "start.toml"), "--imu-dlpf", "42",
               "--out", str(tmp_path / "fitted.toml")]
    assert main(command + ["--free", ",".join(FREE)]) == 1
    captured = capsys.readouterr()
    assert "not writing" in captured.err and not (tmp_path / "fitted.toml").exists(), captured.out
    code = main(command + ["--free", ",".join(FREE + ["coulomb"]), "--friction", "thesis-like"])
    assert code == 0, capsys.readouterr()
    fitted = twip.Robot.from_file(tmp_path / "fitted.toml")
    for n in FREE:
        limit = 0.06 if n == "i_body" else 0.03
        assert abs(getattr(fitted.params, n) / getattr(USER, n) - 1) < limit, n
    assert fitted.driver.current_limit == 3.0 and fitted.driver.inductance == DRIVER.inductance


def test_a_fit_that_did_not_converge_writes_no_robot_unless_forced(tmp_path, capsys):
    log, rig = rig_log(2.0)
    log.to_csv(tmp_path / "rig.csv")
    out = tmp_path / "fitted.toml"
    command = ["identify", str(tmp_path / "rig.csv"), "--free", ",".join(FREE), "--imu-dlpf", "42", "--out", str(out)]
    monkey = pytest.MonkeyPatch()
    try:
        # One iteration: the fit stops short of the minimum.
        real = twip.sysid.identify
        monkey.setattr(twip.sysid, "identify", lambda *a, **k: real(*a, **{**k, "max_iter": 1}))
        assert main(command) == 1
        assert "did not converge" in capsys.readouterr().err and not out.exists()
        assert main(command + ["--force"]) == 1
        assert out.exists()
    finally:
        monkey.undo()
    # The command line's friction options are checked.
    assert main(command + ["--friction-stick", "0.1"]) == 2
    assert "--friction-stick need --friction-coulomb or --friction" in capsys.readouterr().err


def test_identify_the_rig_and_the_robot_file_agree_on_the_driver(tmp_path):
    """A Balanbot rig log fitted with `RobotParams.balanbot()` got `MotorDriver()` (no bridge
    drop) while the rig's driver has 2 V: mu_bearing +371 % with a 0.2 % standard deviation.
    Now identify's default is the rig's driver, and the fit says which it assumed; a wrong
    driver given on purpose is flagged. (On the user's robot, 8 s, `MotorDriver()` for its
    thesis-like driver: mu_bearing +442 %, the encoder's residual 270x as correlated as its
    noise; not converged.)"""
    truth = twip.RobotParams.balanbot()
    log, rig = rig_log(4.0, robot=truth, driver=twip.MotorDriver.thesis_like())
    fit, caught = quiet_identify(log, truth.replace(mu_bearing=truth.mu_bearing * 0.8), ["mu_bearing", "m_body"],
                                 sensors=Sensors.of(rig))
    assert "MotorDriver.thesis_like()" in fit.assumed["driver"] and "bridge drop 2 V" in fit.summary()
    assert not fit.warnings and abs(fit.values["mu_bearing"] / truth.mu_bearing - 1) < 0.01, fit.summary()
    wrong, caught = quiet_identify(log, truth, ["mu_bearing", "m_body"], sensors=Sensors.of(rig),
                                   driver=twip.MotorDriver())
    assert wrong.warnings and (caught or not wrong.converged), wrong.summary()
    # A robot file's [driver] table that names only the battery keeps the rig's drop, winding and
    # limit; the firmware assumes the file's battery.
    robot_file.save(truth, tmp_path / "r.toml", None, {"battery": 12.0})
    driver = twip.Robot.from_file(tmp_path / "r.toml").driver
    assert driver.to_dict() == twip.MotorDriver.thesis_like().replace(battery=12.0, assumed_battery=12.0).to_dict()


def test_csv_ambiguities_are_refused_by_name(tmp_path):
    log, _ = rig_log(1.0)
    path = tmp_path / "run.csv"
    # Gyro in deg/s without a scale: it converged, i_body +7 %.
    write_csv(path, log, gyro=np.degrees(log.gyro))
    with pytest.raises(LogError, match=r"gyro: \d+\.?\d*x the pitch rate .* in deg/s, not rad/s\? give scale="):
        RunLog.from_csv(path)
    assert np.allclose(RunLog.from_csv(path, scale={"gyro": "deg/s"}).gyro, log.gyro)
    # Both u and pwm: pwm was ignored without a word.
    path.write_text("t,u,pwm,gyro\n0,0,0,0\n0.001,0,0,0\n0.002,0,0,0\n")
    with pytest.raises(LogError, match="both u .* and pwm"):
        RunLog.from_csv(path)
    # Two headers read as one signal.
    path.write_text("t,pitch,phi,u\n0,0,0,0\n0.001,0,0,0\n")
    with pytest.raises(LogError, match="columns 'pitch' and 'phi' are both read as 'phi'"):
        RunLog.from_csv(path, columns={"pitch": "phi"})


def test_columns_in_the_wrong_unit_are_named_with_their_row(tmp_path):
    """Each of these was "x[3] = NaN is not finite"."""
    log, rig = rig_log(2.0)
    path = tmp_path / "run.csv"
    g = 9.80665
    write_csv(path, log, accel_x=log.accel_x / g, accel_z=log.accel_z / g)
    with pytest.raises(LogError, match=r"accel_x, accel_z: the median specific force is 1(\.\d+)?, not ~9.8 m/s\^2: in g\?"):
        RunLog.from_csv(path)
    write_csv(path, log, pwm=log.pwm * 10)
    with pytest.raises(LogError, match=r"pwm: row \d+ is -?\d+\.0, beyond the driver's 255 counts"):
        RunLog.from_csv(path)
    keep = (log.t < 0.8) | (log.t >= 1.8)
    write_csv(path, RunLog(log.t, **{n: v for n, v in log.signals().items()}), t=np.where(keep, log.t, np.nan))
    np.savetxt(path, np.loadtxt(path, delimiter=",", skiprows=1)[keep], delimiter=",", comments="",
               header=path.read_text().splitlines()[0], fmt="%.17g")
    with pytest.raises(LogError, match=r"t: a gap in t after row 799 .*: a dropout"):
        RunLog.from_csv(path)
    log.to_csv(path)
    reversed_enc = RunLog.from_csv(path, scale={"enc": -1})
    with pytest.raises(LogError, match="enc: the wheels turn against the input"):
        identify(reversed_enc, START, FREE, driver=DRIVER, sensors=Sensors.of(rig))


TALL = twip.RobotParams.balanbot().replace(m_body=3.0, m_wheels=0.3, i_body=0.04, i_wheels=3.75e-4, i_motor=5e-6,
                                           gear_ratio=50.0, torque_constant=0.015, wheel_radius=0.05, com_height=0.2,
                                           mu_bearing=0.02, mu_ground=0.005)


def test_a_wrong_driver_on_a_second_robot_is_not_a_quiet_answer():
    """A second robot (3 kg, 0.2 m, 100 mm wheels, 50:1, 2.5 A driver), its rig log fitted with the
    default MotorDriver() instead of its own: the fit converged quietly with mu_bearing +749 % and
    i_body +150 %, because the gyro's noise was read from the filtered signal's own second differences,
    which behind the IMU's filter are the robot's motion (12x the noise a correct fit leaves). Its
    gyro residual was 21x as correlated as noise and 3x a correct fit's. With the right driver the
    fit stays quiet and within its own intervals: on this 8 s log i_body's standard deviation is
    1.1 %, and its error ran from +0.08 % to +2.04 % over two noise seeds and two gearbox
    efficiencies (1 and 0.87), the other three parameters within 0.5 %."""
    driver = twip.MotorDriver.thesis_like().replace(current_limit=2.5)
    start = TALL.replace(m_body=3.0 * 1.2, com_height=0.2 * 0.8, i_body=0.04 * 1.25, mu_bearing=0.02 * 0.85)
    log, rig = rig_log(8.0, robot=TALL, driver=driver)
    wrong, caught = quiet_identify(log, start, FREE, driver=twip.MotorDriver(), sensors=Sensors.of(rig))
    assert max(abs(e) for e in errors(wrong, TALL).values()) > 0.05, errors(wrong, TALL)
    assert wrong.warnings and caught and any(m.startswith("gyro") for m in wrong.misfits), wrong.summary()
    fit, caught = quiet_identify(log, start, FREE, driver=driver, sensors=Sensors.of(rig))
    assert fit.converged and not fit.warnings and not caught, fit.summary()
    for name, e in errors(fit, TALL).items():
        assert abs(e) < 3 * fit.std[name] / getattr(TALL, name) and abs(e) < 0.03, (name, e, fit.summary())


def test_the_widened_covariance_is_at_least_both():
    """`spread.larger`: the least covariance as wide as the noise model's and the residuals'
    in every direction: both differences are positive semi-definite, and it is the noise
    model's where the residuals spread less, the residuals' where they spread more."""
    from twip.sysid import spread

    rng = np.random.default_rng(3)
    for _ in range(20):
        a, b = rng.normal(size=(4, 4)), rng.normal(size=(4, 4))
        model, measured = a @ a.T + 1e-3 * np.eye(4), b @ b.T + 1e-3 * np.eye(4)
        both = spread.larger(model, measured)
        for other in (model, measured):
            assert np.linalg.eigvalsh(both - other).min() > -1e-9 * np.abs(both).max()
    model = np.diag([1.0, 4.0])
    assert np.allclose(spread.larger(model, np.diag([0.5, 9.0])), np.diag([1.0, 9.0]))
    assert np.allclose(spread.ratios(model, np.diag([0.25, 16.0])), [0.5, 2.0])
    assert spread.check(["m_body", "i_body"], [0.5, 2.5])[0].startswith("i_body: the residuals spread")
    # No globals (Fit.validate's problem, no parameter free): nothing to widen.
    assert spread.larger(np.zeros((0, 0)), np.zeros((0, 0))).shape == (0, 0)


@pytest.mark.parametrize("scale", [0.1, 0.3, 1.0, 3.0])
def test_the_noise_on_a_filtered_and_rounded_column_is_calibrated_in_its_band(scale):
    """`misfit.noise_path`: noise made as the rig makes it (white, through the IMU's 42 Hz gyro
    filter, on a moving column, rounded to the gyro register's step), at 0.1-3x the rig's gyro
    noise: its standard deviation is recovered from its size in the noise's band within 5 %.
    Read from the second differences before (the noise's level times the filter's gain), the
    rounding was taken for filtered noise: 0.43x the right level on a rig's log."""
    from twip.sysid import misfit

    imu = twip.Realism.thesis_like().imu
    dlpf, step, band = imu.dlpf("gyro"), misfit.lsb(imu, "gyro"), misfit.noise_band(imu, 1)
    white = np.random.default_rng(5).normal(size=12200) * imu.gyro_noise * math.sqrt(500.0) * scale
    noise = np.asarray(dlpf.filter(white))[200:]
    moving = 0.3 * np.sin(np.linspace(0.0, 40.0, len(noise)))  # a column that crosses many steps
    rounded = np.round((noise + moving) / step) * step - moving
    deviation, _ = misfit.noise_path(dlpf, 1, step, misfit.band_size(rounded, band), moving, band)
    assert deviation == pytest.approx(np.std(rounded), rel=0.05)
    # A 5 ms log's band stays below its Nyquist frequency.
    low, high = misfit.noise_band(imu, 5)
    assert 0 < low < high <= 0.45


def test_a_right_fits_filtered_residuals_read_as_the_noise():
    """The user robot's 1 kHz rig log, sensors declared: every filtered signal's residual is
    0.8-1.25x the noise the log shows. Before the rounding of the IMU's registers was
    calibrated, the gyro's read 0.43x, so that a residual 4.6x its noise passed the 2x limit."""
    from twip.sysid import misfit

    log, rig = rig_log(8.0)
    fit, _ = quiet_identify(log, START, FREE, driver=DRIVER, sensors=Sensors.of(rig))
    levels = {s: v[2] for s, v in misfit.measured(fit._problem, fit.solution.residuals).items()}
    for s in ("gyro", "accel_x", "accel_z"):
        assert 0.8 < levels[s] < 1.25, levels
