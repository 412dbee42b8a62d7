"""The real robot in the loop: the thesis's scenarios on thesis-like hardware, settings
under which they fall, determinism of the noise, parity with twip.reference, and errors."""
import math

import numpy as np
import pytest

import twip
import twip.reference as ref
import twip.reference.realism as rr
import twip.scenarios as scenarios
from twip.scenarios.fuzzy import stop_errors
from conftest import rel_diff

LQR = ["slope-lqr", "flat-lqr", "slope-lqr-sim", "flat-lqr-sim"]
FUZZY = ["slope-fuzzy", "flat-fuzzy", "slope-fuzzy-sim", "flat-fuzzy-sim"]


def stop_errors_cm(sc, r):
    """twip.scenarios.fuzzy.stop_errors in cm, rounded for printing; None for a scenario without goals."""
    return np.round(100 * stop_errors(sc, r), 2) if "goals" in sc.thesis else None


def summary(sc, r):
    m = r.metrics
    return (f"{r.outcome}, pitch error {math.degrees(m['mean_abs_pitch_error']):.3f} deg, speed error "
            f"{m['mean_abs_speed_error']:.3f} rad/s, peak {m['peak_abs_input']:.2f} A, stops {stop_errors_cm(sc, r)} cm")


@pytest.mark.parametrize("name", LQR + FUZZY[:1])
def test_ideal_realism_is_the_plain_run_bit_for_bit(name):
    sc = scenarios.get(name)
    plain, ideal = sc.run(), sc.run(realism=twip.Realism.ideal())
    assert np.array_equal(plain.states, ideal.states)
    assert np.array_equal(plain.inputs, ideal.inputs)
    assert plain.metrics == ideal.metrics
    for k, v in plain.internals.items():
        assert np.array_equal(v, ideal.internals[k])
    assert plain.signals == {} and plain.measurements is None
    # What the controller read is the truth at its updates, held in between.
    every = round(sc.controller.period / sc.dt)
    np.testing.assert_array_equal(ideal.measurements[:-1:every], plain.states[:-1:every])


@pytest.mark.parametrize("estimator", ["complementary", "kalman"])
@pytest.mark.parametrize("name", LQR + FUZZY)
def test_thesis_like_hardware_keeps_the_robot_up(name, estimator):
    """5 ms loop applying its command a period late, DLPF 42 Hz, data-sheet noise, biases,
    700 CPR encoders, PWM through the L298P: every scenario still balances."""
    sc = scenarios.get(name)
    realism = twip.Realism.thesis_like().replace(estimator=estimator)
    r = sc.run(realism=realism)
    ideal = sc.run()
    print(f"{name} ideal: {summary(sc, ideal)}\n{name} thesis-like ({estimator}): {summary(sc, r)}")
    assert r.outcome == "completed"
    assert np.all(np.abs(r.states[:, 0]) < math.radians(30))


@pytest.mark.parametrize("name", LQR + FUZZY)
def test_a_5_hz_dlpf_makes_them_fall(name):
    sc = scenarios.get(name)
    thesis = twip.Realism.thesis_like()
    r = sc.run(realism=thesis.replace(imu=thesis.imu.replace(dlpf_hz=5)))
    print(f"{name}, DLPF 5 Hz (19 ms): {r.outcome} at {r.t_fall} s")
    assert r.fell


def test_a_25_ms_loop_drops_the_robot_off_the_slope():
    """A 20 ms loop holds it once the estimator has settled at rest (`Realism.settle`);
    without the settle the start's wrong estimate drops it (at 2.31 s)."""
    sc = scenarios.get("slope-lqr-sim")
    rig = twip.Realism.thesis_like()
    ok = sc.run(realism=rig)
    held = sc.run(realism=rig.replace(control_period=0.02))
    unsettled = sc.run(realism=rig.replace(control_period=0.02, settle=None))
    slow = sc.run(realism=rig.replace(control_period=0.025))
    print(f"slope-lqr-sim: 5 ms {ok.outcome}, 20 ms {held.outcome} ({unsettled.outcome} at {unsettled.t_fall} s "
          f"without the settle), 25 ms {slow.outcome} at {slow.t_fall} s")
    assert ok.outcome == held.outcome == "completed" and unsettled.fell and slow.fell


@pytest.mark.parametrize("option", [
    dict(imu=twip.Imu()), dict(encoder_cpr=700), dict(motor=twip.MotorDriver()), dict(delay=True),
    dict(control_period=0.01), dict(pushes=[(1.0, 0.02)]), dict(force=twip.Force(0.05)),
    dict(slope_profile=[(0.05, 0.02)]),
])
def test_every_option_changes_the_run(option):
    sc = scenarios.get("flat-lqr-sim")
    plain = sc.run(t_final=3.0)
    r = sc.run(realism=twip.Realism(**option), t_final=3.0)
    assert r.outcome == "completed"
    assert not np.array_equal(plain.states, r.states)


def test_noise_is_bitwise_repeatable_and_streams_differ():
    sc = scenarios.get("flat-lqr")
    base = twip.Realism.thesis_like(seed=7, stream=0)
    a, b = sc.run(realism=base), sc.run(realism=base)
    assert np.array_equal(a.states, b.states) and np.array_equal(a.measurements, b.measurements)
    assert a.metrics == b.metrics
    for other in (base.replace(stream=1), base.replace(seed=8)):
        c = sc.run(realism=other)
        assert not np.array_equal(a.measurements[:, 1], c.measurements[:, 1]), "different noise"
        assert c.outcome == "completed"
    # Without noise, biases or quantisation the stream does not matter.
    quiet = twip.Realism(imu=twip.Imu(gyro_noise=0.0, accel_noise=0.0, quantise=False))
    assert np.array_equal(sc.run(realism=quiet).states, sc.run(realism=quiet.replace(stream=3)).states)


def test_measurements_are_logged_beside_the_truth():
    sc = scenarios.get("flat-lqr")
    r = sc.run(realism=twip.Realism.thesis_like(), record_every=5)
    assert set(r.signals) == {"phi_hat", "phi_dot_hat", "theta_hat", "theta_dot_hat", "drive", "motor_current",
                              "gyro", "accel_x", "accel_z", "enc"}
    assert r.measurements.shape == r.states.shape
    # The raw readings: the encoder's counter of the motor shaft relative to the body, the
    # gyro's register (noise, bias and the DLPF's lag of a few ms) and gravity on the
    # accelerometer. Without backlash the shaft is the wheels (times the gear ratio); with the
    # thesis-like 1 degree of play it is up to half of it (0.97 counts) off them, either way.
    phi, phi_dot, theta = r.states[:, 0], r.states[:, 1], r.states[:, 2]
    wheels = np.floor((theta - phi) * 700 / (2 * math.pi))
    assert np.max(np.abs(r.signals["enc"] - wheels)) <= 1 and np.any(r.signals["enc"] != wheels)
    tight = sc.run(realism=twip.Realism.thesis_like().replace(backlash=None), record_every=5)
    phi, theta = tight.states[:, 0], tight.states[:, 2]
    assert np.array_equal(tight.signals["enc"], np.floor((theta - phi) * 700 / (2 * math.pi)))
    assert np.median(np.abs(r.signals["gyro"] - phi_dot)) < math.radians(2.0)
    assert np.all(np.abs(r.signals["accel_z"] - 9.81) < 0.5)
    ideal = sc.run(realism=twip.Realism(), record_every=5)
    assert np.all(np.isnan(ideal.signals["gyro"])) and np.all(np.isnan(ideal.signals["enc"]))
    # The estimate follows the truth to a fraction of a degree; the duty is whole counts.
    assert np.max(np.abs(r.measurements[:, 0] - r.states[:, 0])) < math.radians(1.0)
    assert np.all(r.signals["drive"] == np.round(r.signals["drive"])) and np.max(np.abs(r.signals["drive"])) <= 255
    # inputs stay the controller's current. The motors' current follows it on average, with
    # the error of the back-EMF feed-forward from the encoder's speed (a count per period).
    jitter = {}
    for cpr in (None, 2797, 700):
        run = sc.run(realism=twip.Realism.thesis_like().replace(encoder_cpr=cpr))
        jitter[cpr] = np.mean(np.abs(run.signals["motor_current"] - run.inputs[:, 0]))
    print("mean |motor current - command| [A] by encoder CPR:", {k: round(v, 3) for k, v in jitter.items()})
    assert jitter[None] < 0.02 < jitter[2797] < jitter[700]


def everything_on(estimator):
    return twip.Realism.thesis_like(seed=3, stream=5).replace(
        estimator=estimator,
        pushes=[twip.Push(0.4, 0.03, 0.1), (1.2, -0.02)],
        force=twip.Force(horizontal=0.05, vertical=-0.2, height=0.1),
        slope_profile=[(0.01, math.radians(13)), (0.05, math.radians(16))],
    )


@pytest.mark.parametrize("estimator", ["complementary", "kalman"])
def test_parity_with_the_reference_every_option_on(balanbot, estimator):
    """The same run in twip.reference (numpy, the same Philox noise) to 1e-9 relative.

    Kept to 2 s: the quantised sensors and PWM hide differences of an ulp from the
    controller, so two implementations drift apart at the open-loop rate of the pendulum
    (about e^(6.7 t)) until a reading rounds differently; by 2 s an ulp has grown to ~1e-10."""
    sc = scenarios.get("slope-lqr-sim")
    realism = everything_on(estimator)
    t_final = 2.0
    r = sc.run(realism=realism, t_final=t_final)
    model = ref.SlopeModel(balanbot, sc.model.slope)
    ctrl = ref.LqrController(model, sc.controller.gains, point=sc.controller.point, period=sc.controller.period)
    run = rr.simulate(model, ctrl, sc.x0, t_final, sc.dt, ref.SpeedSchedule(sc.reference.legs),
                      rr.Realism.from_twip(realism, balanbot))
    assert r.outcome == run.outcome == "completed"
    assert r.states.shape == run.states.shape
    err = rel_diff(r.states, run.states)
    print(f"every option on ({estimator}), {t_final} s: worst relative state difference {err:.2e}")
    assert err < 1e-9
    np.testing.assert_allclose(r.inputs[:, 0], run.inputs, rtol=1e-9, atol=1e-12)
    for i, name in enumerate(["phi_hat", "phi_dot_hat", "theta_hat", "theta_dot_hat", "drive", "motor_current"]):
        np.testing.assert_allclose(r.signals[name], run.signals[:, i], rtol=1e-9, atol=1e-12, err_msg=name)


@pytest.mark.parametrize("make,name", [
    (lambda: twip.Imu(dlpf_hz=7), "dlpf_hz"),
    (lambda: twip.Imu(gyro_range_dps=300), "gyro_range"),
    (lambda: twip.Imu(accel_range_g=3), "accel_range"),
    (lambda: twip.Imu(gyro_noise=-1.0), "gyro_noise"),
    (lambda: twip.Imu(accel_noise=math.nan), "accel_noise"),
    (lambda: twip.Imu(gyro_bias_walk=-1.0), "gyro_bias_walk"),
    (lambda: twip.Imu(gyro_bias=math.inf), "gyro_bias"),
    (lambda: twip.Imu(sample_rate=0.0), "sample_rate"),
    (lambda: twip.Imu(height=math.nan), "height"),
    (lambda: twip.Dlpf(600.0, 1e-3), "bandwidth"),
    (lambda: twip.Dlpf(40.0, -1e-3), "delay"),
    (lambda: twip.TiltEstimator.complementary(0.0), "time_constant"),
    (lambda: twip.TiltEstimator.kalman(r_angle=-1.0), "r_angle"),
    (lambda: twip.TiltEstimator.kalman(q_bias=0.0), "q_bias"),
    (lambda: twip.MotorDriver(battery=0.0), "battery"),
    (lambda: twip.MotorDriver(bridge_drop=12.0), "bridge_drop"),
    (lambda: twip.MotorDriver(resistance=-1.0), "resistance"),
    (lambda: twip.MotorDriver(inductance=-1e-3), "inductance"),
    (lambda: twip.MotorDriver(efficiency=1.2), "efficiency"),
    (lambda: twip.MotorDriver(current_limit=0.0), "current_limit"),
    (lambda: twip.MotorDriver(assumed_battery=-1.0), "assumed_battery"),
    (lambda: twip.Push(-1.0, 0.1), "push.t"),
    (lambda: twip.Push(1.0, math.nan), "push.impulse"),
    (lambda: twip.Force(horizontal=math.inf), "force.horizontal"),
    (lambda: twip.Realism(encoder_cpr=0.0), "encoder_cpr"),
    (lambda: twip.Realism(estimator="bogus"), "estimator"),
    (lambda: twip.Realism(control_period=0.0), "control_period"),
    (lambda: twip.Realism(backlash=-0.01), "backlash"),
    (lambda: twip.Realism(backlash=math.nan), "backlash"),
    (lambda: twip.Realism(pushes=[(1.0, 0.1)] * 9), "pushes"),
    (lambda: twip.Realism(pushes=["push"]), "pushes"),
    (lambda: twip.Realism(slope_profile=[(1.0, 0.1), (0.5, 0.1)]), "slope_profile.distance"),
    (lambda: twip.Realism(slope_profile=[(1.0, 2.0)]), "slope_profile.slope"),
    (lambda: twip.Realism(seed=-1), "seed"),
    (lambda: twip.Realism(stream=1.5), "stream"),
    # An OverflowError naming nothing; "seed = NaN" for a string.
    (lambda: twip.Realism.thesis_like(seed=-1), "invalid seed = -1: must be an integer"),
    (lambda: twip.Realism.thesis_like(stream=2**64), "stream = 18446744073709551616"),
    (lambda: twip.Realism(seed="1"), "seed = '1'"),
    # A rate the DLPF cannot run at failed at the first run, naming a bandwidth; the ranges
    # were named and valued in SI (gyro_range = 5.236).
    (lambda: twip.Imu(sample_rate=37.3), "invalid sample_rate = 37.3: must be below half"),
    (lambda: twip.Imu(gyro_range_dps=300), "invalid gyro_range_dps = 300: must be 250"),
    (lambda: twip.Imu(accel_range_g=3), "invalid accel_range_g = 3: must be 2"),
    # The estimate was NaN, handed back without a word.
    (lambda: twip.TiltEstimator.kalman().filter([0, .1, .2], [9.8] * 3, [0, 1, 0], 1e160),
     "invalid dt = 1e160: overflows the estimator's state"),
    # A settle runs before every run and cannot be interrupted: 1e9 s hung for good.
    (lambda: twip.Realism.thesis_like().replace(settle=1e9), "invalid settle = 1(e9|000000000): must be finite, >= 0 and <= 600"),
    # A data sheet value past floating point's range was blamed on no_load_current.
    (lambda: twip.DcMotor.from_data_sheet(12.0, 1e308, 0.35, 7.0, 43.7), "invalid no_load_rpm = 1e308"),
    (lambda: twip.DcMotor.from_data_sheet(1e-308, 251.0, 0.35, 7.0, 43.7), "invalid rated_voltage = 1e-308"),
])
def test_invalid_settings_name_the_parameter(make, name):
    with pytest.raises(twip.InvalidParameterError, match=name.replace(".", r"\.")):
        make()


def test_invalid_runs_name_the_parameter(balanbot):
    sc = scenarios.get("flat-lqr")
    with pytest.raises(twip.InvalidParameterError, match="dt"):
        sc.run(realism=twip.Realism(imu=twip.Imu()), dt=0.003, control_period=0.006)
    with pytest.raises(twip.InvalidParameterError, match="control_period"):
        sc.run(realism=twip.Realism(control_period=0.0025))
    # The 3-DOF rig checks the same (its own tests: tests/test_planar_realism.py).
    with pytest.raises(twip.InvalidParameterError, match="dt"):
        scenarios.get("circle-pid").run(realism=twip.Realism(imu=twip.Imu()), dt=0.003, control_period=0.006)
    with pytest.raises(TypeError):
        sc.run(realism="thesis")
    # A rig's settle runs a whole loop period first, uninterruptibly: 1e7 s hung for good.
    for run in (sc.run, scenarios.get("circle-pid").run):
        with pytest.raises(twip.InvalidParameterError, match="invalid control_period = 10000000: over dt is more than 1e8 plant steps"):
            run(realism=twip.Realism.thesis_like(), control_period=1e7)


def plain(value):
    """A Realism setting as comparable plain data: the pyclasses have no __eq__, so compare their fields."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, twip.TiltEstimator):
        return ("TiltEstimator", value.kind, plain(value.parameters))
    if hasattr(value, "to_dict"):
        return (type(value).__name__, plain(value.to_dict()))
    if isinstance(value, (twip.Push, twip.Force)):
        return (type(value).__name__, {k: plain(getattr(value, k)) for k in dir(value) if not k.startswith("_")})
    return value


def test_settings_round_trip():
    r = twip.Realism.thesis_like(seed=2, stream=9)
    full = r.to_dict()
    assert plain(r.replace().to_dict()) == plain(full)
    assert plain(twip.Realism(**full).to_dict()) == plain(full)
    busy = r.replace(pushes=[twip.Push(1.0, 0.1, 0.2), twip.Push(2.5, -0.05)], force=twip.Force(0.3, -0.1, 0.15),
                     estimator=twip.TiltEstimator.kalman())
    assert plain(twip.Realism(**busy.to_dict()).to_dict()) == plain(busy.to_dict())
    assert plain(busy.to_dict()) != plain(full)
    assert plain(r.replace(imu=r.imu.replace(dlpf_hz=20)).to_dict()) != plain(full)
    assert r.replace(delay=False).delay is False and r.replace(delay=False).seed == 2
    assert r.imu.dlpf_hz == 42 and r.imu.dlpf_cfg == 3 and r.imu.gyro_range_dps == 250
    assert r.motor.current_limit == 2.0 and twip.MotorDriver().current_limit is None
    assert twip.Realism().is_ideal and not r.is_ideal
    assert "Realism(" in repr(r) and "TiltEstimator.complementary" in repr(r.estimator)
    assert len(twip.Dlpf.table()) == 7


@pytest.mark.parametrize("name", ["slope-lqr-sim", "circle-pid", "circle-smc-fuzzy"])
def test_backlash_parity_with_the_reference(balanbot, name):
    """3 degrees of play in each gear train on the thesis-like robot: the rotors cross it on
    their own and engage in plastic impacts. The core's rigs and the reference's agree over 2 s,
    and the play changes the run."""
    from conftest import part_parity

    realism = twip.Realism.thesis_like(seed=4, stream=2).replace(backlash=math.radians(3))
    r, run, err = part_parity(name, realism, balanbot, backlash=None)
    print(f"{name} with 3 degrees of backlash, 2 s: worst relative state difference {err:.1e}")
    assert r.outcome == run.outcome and err < 1e-9


@pytest.mark.parametrize("name", ["slope-lqr-sim", "circle-pid"])
def test_a_rolling_start_carries_its_rotors_through_the_play(balanbot, name):
    """The start state's wheels turn relative to the body, and their rotors turn with them, in
    the core's rigs and the reference's alike (the core's test
    a_rolling_start_keeps_its_speed_through_a_tiny_play has the physics: rotors started at rest
    took 3/4 of the wheels' speed in an impact)."""
    import dataclasses

    from conftest import reference_rig_run

    sc = scenarios.get(name)
    x0 = np.array(sc.x0, dtype=float)
    rates = {4: 0.8, 5: 0.3, 6: 0.4} if name.startswith("circle") else {1: 1.5, 3: 6.0}  # phi_dot, v, omega / theta_dot
    for i, rate in rates.items():
        x0[i] += rate
    sc = dataclasses.replace(sc, x0=x0)
    realism = twip.Realism.thesis_like(seed=4, stream=2).replace(backlash=math.radians(3))
    r = sc.run(realism=realism, t_final=1.0)
    run = reference_rig_run(name, sc, realism, balanbot, 1.0)
    assert r.outcome == run.outcome and rel_diff(r.states, run.states) < 1e-9
