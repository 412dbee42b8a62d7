"""Each real part against its own physics: motor and driver, the MPU-6050's DLPF, the
encoder, the tilt estimators, pushes, a constant force and slope changes."""
import math

import numpy as np
import pytest
from scipy.optimize import brentq

import twip
import twip.reference.realism as rr
import twip.scenarios as scenarios

# Table 2.2 as printed in the thesis: (accel Hz, accel delay ms, gyro Hz, gyro delay ms).
TABLE_2_2 = [
    (260, 0.0, 256, 0.98),
    (184, 2.0, 188, 1.9),
    (94, 3.0, 98, 2.8),
    (44, 4.9, 42, 4.8),
    (21, 8.5, 20, 8.3),
    (10, 13.8, 10, 13.4),
    (5, 19.0, 5, 18.6),
]
ROWS = [(a, ad, "accel") for a, ad, _, _ in TABLE_2_2] + [(g, gd, "gyro") for _, _, g, gd in TABLE_2_2]


# --- motor and driver -------------------------------------------------------------------


def test_motor_stall_current_and_no_load_speed_at_12_volts(balanbot):
    """Table 2.3 at 12 V: 7 A stall, 251 rpm (+-10 %) and 350 mA with no load. The no-load
    load is the robot's bearing friction (one side's share of mu_bearing)."""
    m = twip.MotorDriver()
    stall = m.current(12.0, 0.0, balanbot)
    friction = balanbot.mu_bearing / 2
    w0 = brentq(lambda w: m.wheel_torque(12.0, w, balanbot) - friction * w, 1.0, 100.0, xtol=1e-12)
    rpm, i0 = w0 * 60 / (2 * math.pi), m.current(12.0, w0, balanbot)
    print(f"12 V: stall {stall:.4f} A (7 A), no-load {rpm:.1f} rpm (251 +-10 %), {1000 * i0:.0f} mA (350 mA)")
    assert stall == pytest.approx(7.0, rel=1e-12)
    assert abs(rpm - 251) < 0.1 * 251
    assert abs(i0 - 0.35) < 0.1 * 0.35


def test_driver_limits_and_feed_forward(balanbot):
    m = twip.MotorDriver(bridge_drop=2.0, current_limit=2.0)
    assert m.current(100.0, 0.0, balanbot) == 2.0 and m.current(-100.0, 0.0, balanbot) == -2.0
    assert m.duty(1e3, 0.0, balanbot) == 255 and m.duty(-1e3, 0.0, balanbot) == -255
    # The duty of a lumped current at a speed, applied back, gives that current within a count.
    for u, w in [(0.3, 2.0), (-0.5, -1.0), (0.05, 4.0)]:
        duty = m.duty(u, w, balanbot)
        got = 2 * m.current(duty / 255 * (m.battery - m.bridge_drop), w, balanbot)
        assert duty == round(duty) and abs(got - u) <= (m.battery - m.bridge_drop) / 255 / m.resistance
    # A flat battery the firmware does not know about gives less current than asked.
    flat = m.replace(battery=9.6, assumed_battery=11.1)
    duty = flat.duty(0.4, 0.0, balanbot)
    assert 2 * flat.current(duty / 255 * (9.6 - 2.0), 0.0, balanbot) < 0.4 * (9.6 - 2) / (11.1 - 2) + 0.03


def test_driver_evaluations_refuse_a_nan_or_infinite_input(balanbot):
    """duty(NaN) was -255 counts, current(NaN) -inf."""
    m = twip.MotorDriver.thesis_like()
    for call, name in [
        (lambda: m.duty(math.nan, 0.0, balanbot), "lumped_current"),
        (lambda: m.duty(0.1, math.nan, balanbot), "wheel_speed"),
        (lambda: m.current(math.nan, 0.0, balanbot), "voltage"),
        (lambda: m.current(1.0, math.inf, balanbot), "wheel_speed"),
        (lambda: m.wheel_torque(math.inf, 0.0, balanbot), "voltage"),
    ]:
        with pytest.raises(twip.NonFiniteError, match=rf"^{name}\[0\] = (NaN|inf)"):
            call()


# --- DLPF -------------------------------------------------------------------------------


def ramp_lag(f, n=20000, period=1e-3):
    """Steady lag [s] of a unit ramp through the filter: its DC group delay."""
    t = np.arange(n) * period
    y = f.filter(t)
    return t[-1] - y[-1]


def test_filters_take_any_real_array_like_and_refuse_nan():
    """Lists and int arrays were a TypeError, NaN samples NaN out, and dt = 0 was reported
    as 'dt = inf'."""
    dlpf = twip.Dlpf(42.0, 0.0048)
    expected = dlpf.filter(np.array([1.0, 2.0, 3.0]))
    for x in ([1, 2, 3], np.array([1, 2, 3]), np.array([1, 2, 3], np.float32), (1.0, 2.0, 3.0)):
        np.testing.assert_array_equal(dlpf.filter(x), expected)
    with pytest.raises(twip.NonFiniteError, match=r"^x\[1\] = NaN"):
        dlpf.filter([0.0, math.nan])
    with pytest.raises(twip.ShapeError, match=r"x has shape \(2, 2\), expected a 1-D array"):
        dlpf.filter(np.zeros((2, 2)))
    tilt = twip.TiltEstimator.kalman()
    phi, rate = tilt.filter(np.full(3, 0.5), np.full(3, 9.8), np.array([0.0, 0.1, 0.2]), 1e-3)
    phi2, rate2 = tilt.filter([0.5] * 3, np.full(3, 9.8), [0, 0.1, 0.2], 1e-3)
    np.testing.assert_array_equal(phi2, phi)
    np.testing.assert_array_equal(rate2, rate)
    for i, name in enumerate(("accel_x", "accel_z", "gyro")):
        args = [[0.0, 0.0], [9.8, 9.8], [0.0, 0.0]]
        args[i] = [0.0, math.nan]
        with pytest.raises(twip.NonFiniteError, match=rf"^{name}\[1\] = NaN"):
            tilt.filter(*args, 1e-3)
    for dt, shown in ((0.0, "0"), (-1e-3, "-0.001"), (math.nan, "NaN"), (math.inf, "inf")):
        with pytest.raises(twip.InvalidParameterError, match=rf"invalid dt = {shown}: must be finite and > 0"):
            tilt.filter([0.0], [9.8], [0.0], dt)


def test_a_filter_over_segments_filters_each_from_its_own_start():
    """With `segments`, each segment is the filter of its own samples alone, from the steady
    state of its first (identification's shooting segments): the same bits as one call per
    segment. Bad starts are refused by name."""
    dlpf = twip.Dlpf.mpu6050(42, "gyro")
    x = np.sin(np.arange(500) * 0.05) + 0.3 * (np.arange(500) >= 200)
    starts = [0, 130, 200, 499]
    ends = [*starts[1:], len(x)]
    expected = np.concatenate([dlpf.filter(x[a:b]) for a, b in zip(starts, ends)])
    np.testing.assert_array_equal(dlpf.filter(x, starts), expected)
    np.testing.assert_array_equal(dlpf.filter(x, [0]), dlpf.filter(x))
    # Not the whole run's filter: each segment forgot what came before it.
    assert not np.array_equal(expected, dlpf.filter(x))
    for bad, shown in (([], "none given"), ([5, 10], "the first is 5, not 0"),
                       ([0, 10, 10], r"segments\[2\] = 10 after 10"), ([0, 500], r"segments\[1\] = 500 after 0 in a series of 500")):
        with pytest.raises(twip.InvalidParameterError, match=rf"^segments: {shown}"):
            dlpf.filter(x, bad)


def gain_at(f, hz, period=1e-3, cycles=60):
    n = int(cycles / (hz * period))
    t = np.arange(n) * period
    y = f.filter(np.sin(2 * np.pi * hz * t))
    tail = y[n // 2:]
    return 0.5 * (tail.max() - tail.min())


@pytest.mark.parametrize("hz,delay_ms,sensor", ROWS)
def test_dlpf_reproduces_table_2_2(hz, delay_ms, sensor):
    f = twip.Dlpf.mpu6050(hz, sensor)
    lag_ms = 1000 * ramp_lag(f)
    print(f"{sensor} {hz:>3} Hz: delay {lag_ms:.3f} ms (table {delay_ms} ms), zeta {f.zeta:.3f}, "
          f"f_n {f.natural_frequency / (2 * np.pi):.1f} Hz, pure {1000 * f.pure_delay:.3f} ms")
    if delay_ms == 0:
        assert abs(lag_ms) < 1e-9, "the 260 Hz accelerometer row passes samples through"
        return
    assert abs(lag_ms - delay_ms) <= 0.1 * delay_ms
    # The bandwidth is the -3 dB point of the discrete filter.
    assert gain_at(f, hz) == pytest.approx(math.sqrt(0.5), rel=0.02)
    # The reference builds the same filter from the same equations.
    r = rr.Dlpf.mpu6050(rr.dlpf_config(hz), sensor, 1e-3)
    x = np.sin(np.arange(3000) * 0.01) + 0.01 * np.arange(3000)
    r.prime(x[0])
    expected = np.array([r.filter(v) for v in x])
    np.testing.assert_allclose(f.filter(x), expected, rtol=1e-12, atol=1e-12)


def test_imu_gyro_reaches_the_controller_with_the_dlpf_delay():
    """End to end through a run: phi_dot_hat (complementary filter: the gyro itself) is phi_dot
    about 4.8 ms (DLPF 42 Hz) plus 1 ms (the register's age at a read) late."""
    sc = scenarios.get("flat-lqr-sim")
    imu = twip.Imu(gyro_noise=0.0, accel_noise=0.0, quantise=False)
    r = sc.run(realism=twip.Realism(imu=imu), t_final=3.0)
    true, seen = r.states[:, 1], r.signals["phi_dot_hat"]
    lags = np.arange(0, 12)
    errs = [np.sum((seen[20:] - true[20 - k:len(true) - k]) ** 2) for k in lags]
    best = lags[int(np.argmin(errs))]
    print(f"gyro reaches the controller {best} ms late (DLPF 4.8 ms + 1 ms register age)")
    assert best in (5, 6)


def test_gyro_noise_matches_the_data_sheets_total_rms():
    """Data sheet: 0.005 deg/s/sqrt(Hz) gives a total RMS noise of 0.05 deg/s at DLPF_CFG = 2
    (98 Hz). Measured on a robot standing still, quantisation off."""
    sc = scenarios.get("flat-lqr-sim")
    imu = twip.Imu(dlpf_hz=98, quantise=False)
    r = sc.run(realism=twip.Realism(imu=imu), reference=twip.SpeedSchedule.constant(0.0), t_final=20.0)
    every = round(sc.controller.period / sc.dt)
    err = (r.signals["phi_dot_hat"] - r.states[:, 1])[1000::every]
    rms = math.degrees(np.sqrt(np.mean(err**2)))
    print(f"gyro noise at DLPF 98 Hz: {rms:.4f} deg/s rms (data sheet 0.05)")
    assert rms == pytest.approx(0.05, rel=0.15)


# --- encoder ----------------------------------------------------------------------------


@pytest.mark.parametrize("cpr", [700, 2797])
def test_encoder_speed_error_is_bounded_by_one_count_per_period(cpr):
    sc = scenarios.get("flat-lqr")
    period = sc.controller.period
    r = sc.run(realism=twip.Realism(encoder_cpr=cpr), t_final=10.0)
    k = np.arange(0, len(r.t) - 1, round(period / sc.dt))  # the controller's updates
    beta = r.states[k, 2] - r.states[k, 0]
    mean_speed = np.diff(beta) / period
    measured = (r.signals["theta_dot_hat"] - r.signals["phi_dot_hat"])[k][1:]
    count = 2 * math.pi / cpr
    worst = np.max(np.abs(measured - mean_speed))
    print(f"{cpr} CPR: worst speed error {worst:.4f} rad/s, one count per period {count / period:.4f} rad/s")
    assert worst < count / period
    angle_error = r.signals["theta_hat"][k] - r.states[k, 2]
    assert np.all((angle_error <= 1e-12) & (angle_error > -count))


# --- tilt estimators --------------------------------------------------------------------


@pytest.mark.parametrize("estimator", [twip.TiltEstimator.complementary(), twip.TiltEstimator.kalman()])
def test_estimators_converge_on_a_static_tilt(estimator):
    """Held at 5.7 deg with a 0.5 deg/s gyro bias, starting from a level estimate: the
    complementary filter settles tau * bias off, the Kalman filter on the tilt."""
    g, tilt, bias, dt, n = 9.81, 0.1, math.radians(0.5), 0.005, 24_000
    ax, az = np.full(n, -g * math.sin(tilt)), np.full(n, g * math.cos(tilt))
    ax[0], az[0] = 0.0, g
    phi, rate = estimator.filter(ax, az, np.full(n, bias), dt)
    if estimator.kind == "complementary":
        target = tilt + estimator.parameters["time_constant"] * bias
    else:
        target = tilt
        assert abs(rate[-1]) < 0.05 * bias, "the bias is learnt"
    print(f"{estimator!r}: final {math.degrees(phi[-1]):.4f} deg, expected {math.degrees(target):.4f} deg")
    assert abs(phi[-1] - target) < 1e-4


# --- disturbances -----------------------------------------------------------------------


def test_a_push_changes_the_velocities_by_m_inverse_q(balanbot):
    """The push is applied after the sample at t: compare the next sample with and without."""
    sc = scenarios.get("flat-lqr-sim")
    t_push, j, h = 1.0, 0.05, 0.1
    plain = sc.run(realism=twip.Realism(), t_final=1.5)
    pushed = sc.run(realism=twip.Realism(pushes=[twip.Push(t_push, j, h)]), t_final=1.5)
    k = round(t_push / sc.dt)
    assert np.array_equal(plain.states[: k + 1], pushed.states[: k + 1])
    x = plain.states[k]
    q = np.array([h * j * math.cos(x[0]), balanbot.wheel_radius * j])
    expected = np.linalg.solve(rr.mass_matrix(balanbot, 0.0, x[0]), q)
    got = (pushed.states[k + 1] - plain.states[k + 1])[[1, 3]]
    print(f"push {j} N s at {h} m: jump {got} vs M^-1 Q {expected}")
    np.testing.assert_allclose(got, expected, rtol=0.03)


def test_a_constant_force_tilts_the_robot_against_it(balanbot):
    """At constant speed on the flat, summing both equations of motion:
    M_b g l sin(phi) - mu_g theta_dot + (h cos(phi) + r) F = 0."""
    sc = scenarios.get("flat-lqr-sim")
    f, h = 0.2, 0.1
    r = sc.run(realism=twip.Realism(force=twip.Force(horizontal=f, height=h)), t_final=25.0)
    assert r.outcome == "completed"
    p = balanbot
    speed = sc.reference.sample(0.0)[1]
    mgl = p.m_body * p.g * p.com_height
    phi = brentq(lambda a: mgl * math.sin(a) - p.mu_ground * speed + (h * math.cos(a) + p.wheel_radius) * f, -1, 1)
    tail = r.t > r.t[-1] - 2.0
    print(f"force {f} N at {h} m: pitch {math.degrees(r.states[tail, 0].mean()):.3f} deg, "
          f"predicted {math.degrees(phi):.3f} deg")
    assert r.states[tail, 0].mean() == pytest.approx(phi, abs=math.radians(0.05))


def test_a_slope_change_moves_the_steady_pitch(balanbot):
    sc = scenarios.get("flat-lqr-sim")
    slope = math.radians(5)
    r = sc.run(realism=twip.Realism(slope_profile=[(0.3, slope)]), t_final=25.0)
    assert r.outcome == "completed"
    speed = sc.reference.sample(0.0)[1]
    phi_s = twip.SlopeModel(balanbot, slope).equilibrium(speed)[0][0]
    tail = r.t > r.t[-1] - 2.0
    crossed = r.t[np.argmax(r.states[:, 2] * balanbot.wheel_radius >= 0.3)]
    print(f"slope 5 deg from 0.3 m (crossed at {crossed:.2f} s): pitch {math.degrees(r.states[tail, 0].mean()):.3f} deg, "
          f"steady state {math.degrees(phi_s):.3f} deg")
    assert r.states[tail, 0].mean() == pytest.approx(phi_s, abs=math.radians(0.1))
