"""Identification with the gear play declared (issue 61): `identify(..., backlash=)` and
`twip identify --backlash` replay the rig's backlash (the rotors crossing the play, the
impacts, the encoder on the motor shaft) as the simulator runs it. The robot is not the
Balanbot: the second robot of benches/sysid.py (3 kg, 0.2 m, 100 mm wheels, 50:1, 2.5 A)."""
import math
import warnings

import numpy as np
import pytest

import twip
from twip.cli import main
from twip.sysid import Sensors, identify
from twip.sysid.estimator import Estimator, Problem

FREE = ["m_body", "com_height", "i_body", "mu_bearing"]
TALL = twip.RobotParams.balanbot().replace(m_body=3.0, m_wheels=0.3, i_body=0.04, i_wheels=3.75e-4, i_motor=5e-6,
                                           gear_ratio=50.0, torque_constant=0.015, wheel_radius=0.05, com_height=0.2,
                                           mu_bearing=0.02, mu_ground=0.005)
DRIVER = twip.MotorDriver.thesis_like().replace(current_limit=2.5)


def full_rig_log(seconds, noiseless=False):
    """The full thesis-like rig (sensors, driver, delay, gearhead friction, 1 deg of play), without
    the settle at rest (the start's transient excites the log)."""
    rig = twip.Realism.thesis_like(seed=0).replace(motor=DRIVER, settle=None)
    if noiseless:
        imu = rig.imu.replace(gyro_noise=0.0, accel_noise=0.0, gyro_bias=0.0, gyro_bias_walk=0.0,
                              accel_bias=(0.0, 0.0), quantise=False)
        rig = rig.replace(imu=imu, encoder_cpr=1e9)
    sc = twip.scenarios.get("flat-lqr", params=TALL, controller_params=TALL)
    run = twip.simulate(sc.model, sc.controller, [0.05, 0, 0, 0], seconds, dt=1e-3, reference=sc.reference, realism=rig)
    assert run.outcome == "completed"
    return run, rig


def test_the_declared_play_replays_a_noiseless_rig_log():
    """At the true robot and the run's own states at the segments' starts, the prediction of a
    noiseless raw-sensor log of the full rig is the log up to the winding's current at each
    segment's start, its steady value (measured, 4 s: gyro 1.1e-6 rad/s RMS, accel_x 1.8e-6
    m/s^2, gaps 1.5e-6); without the play 1.7e-3 and 2.6e-3, over 1000x."""
    run, rig = full_rig_log(4.0, noiseless=True)
    log = run.to_log()
    rms = {}
    for backlash in (rig.backlash, None):
        p = Problem(log, TALL, FREE + ["coulomb"], DRIVER, rig.friction, 0.25, Sensors.of(rig), None, 1e-3, backlash)
        _, _, out, gaps = Estimator(p, None, 1).evaluate(np.zeros(len(FREE) + 1 + len(p.biased)), run.states[p.segments])
        rms[backlash] = {s: float(np.sqrt(np.mean((p.y[s] - out[s])[p.used[s]] ** 2))) for s in ("gyro", "accel_x", "enc")}
        rms[backlash]["gap"] = float(np.max(np.abs(gaps)))
    print(rms)
    played, rigid = rms[rig.backlash], rms[None]
    assert played["gyro"] < 1e-5 and played["accel_x"] < 1e-4 and played["gap"] < 1e-4, played
    for s in ("gyro", "accel_x", "enc", "gap"):
        assert rigid[s] > 30 * played[s], (s, played, rigid)


def play_jacobian(run, rig, h):
    """The estimator's Jacobian with the play declared (`Estimator.linearise`: the base run
    records its impacts and openings, the perturbed runs replay them) at the true robot and
    the run's own start states, for steps h: the columns of m_body, com_height, i_body,
    mu_bearing and coulomb (relative), and of the four start states (scaled as the estimator does)."""
    p = Problem(run.to_log(), TALL, FREE + ["coulomb"], DRIVER, rig.friction, 0.25, Sensors.of(rig), None, 1e-3,
                rig.backlash)
    estimator = Estimator(p, None, 1)
    estimator.param_step = estimator.state_step = h
    *_, (jg, js) = estimator.linearise(np.zeros(estimator.n_g), run.states[p.segments])
    return np.column_stack([jg[:, :len(FREE) + 1], js])


def test_the_jacobian_with_the_play_declared_is_the_same_for_any_step():
    """A perturbed run that let its impacts fall where its own motion puts them moved some by
    a whole plant step, and the differences saw the jumps: m_body's column grew as 1/h (6.2e5
    at h = 1e-4, 6.1e4 at 1e-3, the smooth column 4.9e3) and pointed elsewhere (benches/sysid.py
    --play-jacobian). Replaying the base run's events, the columns at 1e-4 and 1e-3 are the
    one at 1e-6. (8 s: on this robot's first 4 s no perturbation moved an impact, and the
    held play's differences passed; on 8 s they failed, m_body's column 61x at 1e-4.)"""
    run, rig = full_rig_log(8.0)
    reference = play_jacobian(run, rig, 1e-6)
    names = FREE + ["coulomb", "phi", "phi_dot", "theta", "theta_dot"]
    for h in (1e-4, 1e-3):
        columns = play_jacobian(run, rig, h)
        for j, name in enumerate(names):
            a, b = columns[:, j], reference[:, j]
            cosine = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
            ratio = np.linalg.norm(a) / np.linalg.norm(b)
            print(f"h {h:g} {name}: norm {np.linalg.norm(a):.4g} / {np.linalg.norm(b):.4g}, cosine {cosine:.5f}")
            assert cosine > 0.99 and abs(ratio - 1) < 0.05, (h, name, cosine, ratio)


def test_a_free_run_with_the_play_declared_moves_continuously_with_the_robot():
    """Each perturbed run on its own (as a trial step runs: its impacts where its own motion
    puts them), its central differences at the true robot and the run's own start states. With
    each impact applied at its plant step's end, an impact that a perturbation moved across a
    step's end jumped the prediction: m_body's column was 6.2e5 at h = 1e-4 and 6.1e4 at 1e-3,
    against 1.0e4 at 1e-6 (benches/sysid.py --play-jacobian). Located within its step, the
    prediction moves continuously: the columns at 1e-4 and 1e-3 are the one at 1e-6, and the
    replayed Jacobian's."""
    run, rig = full_rig_log(8.0)
    p = Problem(run.to_log(), TALL, FREE + ["coulomb"], DRIVER, rig.friction, 0.25, Sensors.of(rig), None, 1e-3,
                rig.backlash)
    estimator = Estimator(p, None, 1)
    starts, x = run.states[p.segments], np.zeros(estimator.n_g)

    def free_columns(h):
        at = []
        for j in range(len(FREE)):
            up, down = x.copy(), x.copy()
            up[j], down[j] = h, -h
            at.append((estimator.evaluate(up, starts)[1] - estimator.evaluate(down, starts)[1]) / (2 * h))
        return np.column_stack(at)

    reference = free_columns(1e-6)
    replayed = play_jacobian(run, rig, 1e-6)[:, :len(FREE)]
    for h, columns in ((1e-4, free_columns(1e-4)), (1e-3, free_columns(1e-3)), ("replayed", replayed)):
        for j, name in enumerate(FREE):
            a, b = columns[:, j], reference[:, j]
            cosine = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
            ratio = np.linalg.norm(a) / np.linalg.norm(b)
            print(f"h {h} {name}: norm {np.linalg.norm(a):.4g} / {np.linalg.norm(b):.4g}, cosine {cosine:.5f}")
            assert cosine > 0.99 and abs(ratio - 1) < 0.05, (h, name, cosine, ratio)


def test_a_fit_with_the_play_declared_is_never_a_quiet_answer_far_off():
    """From 15-25 % off, the full rig's 8 s log with its friction and play declared. Measured:
    the fit does not converge (before the impacts' schedule was replayed, m_body +14 %, i_body
    +25 %; with it, m_body +62 %, i_body +241 %: the cost still jumps where a step moves an
    impact, docs/sysid.md). Not built is a fit that finds this robot from so far. What holds:
    such an answer is never quiet."""
    run, rig = full_rig_log(8.0)
    start = TALL.replace(m_body=3.0 * 1.2, com_height=0.2 * 0.8, i_body=0.04 * 1.25, mu_bearing=0.02 * 0.85)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = identify(run.to_log(), start, FREE + ["coulomb"], driver=DRIVER, sensors=Sensors.of(rig),
                       friction=rig.friction, backlash=rig.backlash)
    assert "gear play, declared" in fit.summary()
    worst = max(abs(fit.values[n] / getattr(TALL, n) - 1) for n in FREE)
    assert worst < 0.05 or fit.warnings, fit.summary()


def test_bad_play_is_refused_by_name(tmp_path, capsys):
    run, rig = full_rig_log(1.0)
    log = run.to_log()
    with pytest.raises(twip.InvalidParameterError, match="backlash"):
        identify(log, TALL, ["m_body"], driver=DRIVER, backlash=-0.01)
    with pytest.raises(twip.InvalidParameterError, match="backlash"):
        identify(log, TALL, ["m_body"], driver=DRIVER, backlash=math.nan)
    log.to_csv(tmp_path / "rig.csv")
    with pytest.raises(SystemExit):
        main(["identify", str(tmp_path / "rig.csv"), "--free", "m_body", "--backlash", "-1"])
    assert "--backlash" in capsys.readouterr().err
    # The command line passes the play on, in degrees.
    main(["identify", str(tmp_path / "rig.csv"), "--free", "m_body", "--imu-dlpf", "42", "--backlash", "1"])
    assert "0.01745 rad (1 deg) of gear play, declared" in capsys.readouterr().out


USER = twip.RobotParams.balanbot().replace(m_body=1.8, m_wheels=0.1, i_body=0.0135, i_wheels=2e-5, i_motor=3e-6,
                                           gear_ratio=30.0, torque_constant=0.012, wheel_radius=0.02, com_height=0.12,
                                           mu_bearing=0.008, mu_ground=0.002)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_issues_robot_with_friction_and_play_declared_is_within_3_percent(seed):
    """The issue's robot (1.8 kg, 0.12 m, 40 mm wheels, 30:1, 3 A driver) on the full rig, 8 s,
    from 15-25 % off, friction and play declared, coulomb free. Measured: noise seed 0 within
    0.51 % (i_body -0.51 %), converged, quiet (with the friction alone: i_body -2.59 %); seed 1
    within 1.52 %, converged, quiet (before the impacts' schedule was replayed: within 1.04 % but
    "no step lowered the cost", so flagged)."""
    driver = twip.MotorDriver.thesis_like().replace(current_limit=3.0)
    rig = twip.Realism.thesis_like(seed=seed).replace(motor=driver, settle=None)
    sc = twip.scenarios.get("flat-lqr", params=USER, controller_params=USER)
    run = twip.simulate(sc.model, sc.controller, [0.05, 0, 0, 0], 8.0, dt=1e-3, reference=sc.reference, realism=rig)
    start = USER.replace(m_body=1.8 * 1.2, com_height=0.12 * 0.8, i_body=0.0135 * 1.25, mu_bearing=0.008 * 0.85)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = identify(run.to_log(), start, FREE + ["coulomb"], driver=driver, sensors=Sensors.of(rig),
                       friction=rig.friction, backlash=rig.backlash)
    assert fit.converged and not fit.warnings and not caught, fit.summary()
    for name in FREE:
        assert abs(fit.values[name] / getattr(USER, name) - 1) < (0.06 if name == "i_body" else 0.03), fit.summary()
