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
from twip.sysid.measure import impact_samples, noise_level

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
    estimator.robust_limit = math.inf  # the prediction's own columns (Huber's rescaling is smooth, not a jump)
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
    puts them), the central differences of its states at the true robot and the run's own
    start states. With each impact applied at its plant step's end, an impact that a
    perturbation moved across a step's end jumped the prediction: m_body's column was 6.2e5 at
    h = 1e-4 and 6.1e4 at 1e-3, against 1.0e4 at 1e-6 (benches/sysid.py --play-jacobian).
    Located within its step, the states' columns of m_body, com_height and i_body at 1e-4 are
    the one at 1e-6, and the replayed runs' (the IMU's are not: it samples the pitch rate
    before or after an impact, whichever side of the sample the impact falls, so its rows near
    an impact are left out: test_the_imu_rows_after_an_impact_are_left_out). The motion is not
    continuous everywhere: mu_bearing's free column at 1e-4 is 12x the one at 1e-6 (cosine
    0.08), and at 1e-3 every column is 10-29x its 1e-6 one; measured, not traced (the openings are still
    decided at a step's start), so those are printed, not checked."""
    run, rig = full_rig_log(8.0)
    p = Problem(run.to_log(), TALL, FREE + ["coulomb"], DRIVER, rig.friction, 0.25, Sensors.of(rig), None, 1e-3,
                rig.backlash)
    starts, n = run.states[p.segments], len(FREE) + 1
    # Each state in units of its size over the run, so that no component dominates the cosines.
    scale = np.std(run.states, axis=0)

    def columns(h, replayed):
        at = []
        for j in range(len(FREE)):
            moved = [np.zeros(n), np.zeros(n), np.zeros(n)]
            moved[1][j], moved[2][j] = h, -h
            if replayed:  # the first run records its events, the others replay them
                states = p.shoot(moved, np.stack([starts] * 3))[0][1:]
            else:
                states = np.stack([p.shoot([d], starts[None])[0][0] for d in moved[1:]])
            at.append(((states[0] - states[1]) / scale / (2 * h)).reshape(-1))
        return np.column_stack(at)

    reference = columns(1e-6, False)
    for h, replayed in ((1e-4, False), (1e-6, True), (1e-3, False)):
        got = columns(h, replayed)
        for j, name in enumerate(FREE):
            a, b = got[:, j], reference[:, j]
            cosine = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
            ratio = np.linalg.norm(a) / np.linalg.norm(b)
            print(f"h {h} {'replayed' if replayed else 'free'} {name}: norm {np.linalg.norm(a):.4g} / "
                  f"{np.linalg.norm(b):.4g}, cosine {cosine:.5f}")
            if name != "mu_bearing" and h != 1e-3:
                assert cosine > 0.99 and abs(ratio - 1) < 0.05, (h, replayed, name, cosine, ratio)


#: The third robot of benches/sysid.py: 1.2 kg, 0.08 m, 66 mm wheels, 34:1, 2 A.
MID = twip.RobotParams.balanbot().replace(m_body=1.2, m_wheels=0.08, i_body=0.006, i_wheels=1e-5, i_motor=2e-6,
                                          gear_ratio=34.0, torque_constant=0.01, wheel_radius=0.033, com_height=0.08,
                                          mu_bearing=0.005, mu_ground=0.002)
MID_DRIVER = twip.MotorDriver.thesis_like().replace(current_limit=2.0)


def fitted_from_off(robot, driver, seed, play=True, every=1):
    """The full rig's 8 s log of `robot` (noise `seed`, `driver`; every `every`-th row, as a firmware
    logs at its loop period), fitted from 15-25 % off with its friction and (with `play`) its
    play declared, coulomb free: the Fit and the warnings it raised."""
    rig = twip.Realism.thesis_like(seed=seed).replace(motor=driver, settle=None)
    sc = twip.scenarios.get("flat-lqr", params=robot, controller_params=robot)
    run = twip.simulate(sc.model, sc.controller, [0.05, 0, 0, 0], 8.0, dt=1e-3, reference=sc.reference, realism=rig)
    start = robot.replace(**{n: getattr(robot, n) * f for n, f in
                             (("m_body", 1.2), ("com_height", 0.8), ("i_body", 1.25), ("mu_bearing", 0.85))})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = run.to_log()
        log = twip.RunLog(log.t[::every], slope=log.slope, **{n: v[::every] for n, v in log.signals().items()})
        fit = identify(log, start, FREE + ["coulomb"], driver=driver, sensors=Sensors.of(rig),
                       friction=rig.friction, backlash=rig.backlash if play else None)
    return fit, caught


@pytest.mark.parametrize("name, seed", [("tall", 0), ("mid", 0), ("tall", 3)])
def test_the_full_rig_with_friction_and_play_declared_is_within_3_percent(name, seed):
    """From 15-25 % off, the full rig's 8 s log with its friction and play declared, coulomb
    free (benches/sysid.py --accuracy --case "friction and play declared"). Measured before the
    IMU rows near impacts were left out: not converged and flagged, tall i_body +241 % (the
    impacts' schedule replayed) and +204 % (located too), mid mu_bearing -79 %: the cost jumped
    by thousands where a parameter moved an impact across an IMU sample (docs/sysid.md). With
    them (and the residuals' noise levels): tall within 0.76 %, mid within 0.52 %, converged,
    quiet; without the play's convergence test (PLAY_STEP) the mid robot's fit did not converge
    in 50 iterations (within 0.51 %, its cost moving by 0.02-0.3 from one to the next). Tall
    noise seed 3 before the residuals beyond two noise levels cost as in Huber's loss
    (`play.robust`): i_body +10.6 % (not converged); with it +0.30 %, converged, quiet (seed 2:
    its own test below)."""
    robot, driver = (TALL, DRIVER) if name == "tall" else (MID, MID_DRIVER)
    fit, caught = fitted_from_off(robot, driver, seed)
    assert "gear play, declared" in fit.summary()
    assert fit.converged and not fit.warnings and not caught, fit.summary()
    for n in FREE:
        assert abs(fit.values[n] / getattr(robot, n) - 1) < (0.06 if n == "i_body" else 0.03), fit.summary()


def test_with_the_play_declared_the_noise_levels_follow_the_residuals():
    """Read from the filtered signals, the first noise levels are far below a rig log's
    residuals (at the tall robot's truth 2.5x, 4.5x and 26.7x for gyro, accel_x, accel_z), so
    each row that enters or leaves an impact's window weighed thousands. With the play
    declared they are the residuals' own from the first iteration on, not only after a fit
    that converged: here two iterations from the true robot, not converged, the levels those
    of the residuals at the last iteration's start (its step moves them: gyro's level 1.58x
    the final residuals', measured), not the first levels."""
    run, rig = full_rig_log(4.0)
    p = Problem(run.to_log(), TALL, FREE + ["coulomb"], DRIVER, rig.friction, 0.25, Sensors.of(rig), None, 1e-3,
                rig.backlash)
    solution = Estimator(p, None, 2).run()
    assert not solution.converged, solution.message
    for s in ("gyro", "accel_x", "accel_z"):
        rms = float(np.sqrt(np.nanmean(solution.residuals[s] ** 2)))
        first = noise_level(s, p.y[s])
        print(s, solution.sigma[s], rms, first)
        assert 0.5 < solution.sigma[s] / rms < 2, (s, solution.sigma[s], rms)
        assert abs(math.log(solution.sigma[s] / rms)) < abs(math.log(first / rms)), (s, solution.sigma[s], rms, first)


def test_the_imu_rows_after_an_impact_are_left_out():
    """An impact at an IMU sample jumps the pitch rate the IMU samples there; a parameter that
    moves the impact across the sample moves that sample, and the filter spreads it over the
    next ones (15-21 noise levels on this log). The filtered signals' rows from the sample
    before each impact to IMPACT_DELAYS filter delays after it are left out, the encoder's
    kept; without the play nothing is left out but the segments' starts."""
    run, rig = full_rig_log(2.0)
    sensors = Sensors.of(rig)
    for backlash in (rig.backlash, None):
        p = Problem(run.to_log(), TALL, FREE, DRIVER, rig.friction, 0.25, sensors, None, 1e-3, backlash)
        estimator = Estimator(p, None, 1)
        estimator.evaluate(np.zeros(estimator.n_g), run.states[p.segments])
        states, _, _, geometry = p.shoot([np.zeros(len(FREE))], run.states[p.segments][None])
        impacts = np.flatnonzero(geometry[0][3][:, 1] != states[0][:, 1])
        assert np.array_equal(p.used["enc"], p.settled["enc"])
        if backlash is None:
            assert all(np.array_equal(p.used[s], p.settled[s]) for s in p.outputs)
            continue
        assert len(impacts) > 10, impacts
        for s in ("gyro", "accel_x", "accel_z"):
            after = impact_samples(sensors, s)
            assert after > 0
            for i in impacts:
                assert not p.used[s][max(i - 1, 0):i + after + 2].any(), (s, i)
            # What is left out is only near an impact (or at a segment's start).
            near = np.zeros(len(p.log), dtype=bool)
            for i in impacts:
                near[max(i - 1, 0):i + after + 2] = True
            assert np.array_equal(p.used[s], p.settled[s] & ~near), s


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
    fit, caught = fitted_from_off(USER, twip.MotorDriver.thesis_like().replace(current_limit=3.0), seed)
    assert fit.converged and not fit.warnings and not caught, fit.summary()
    for name in FREE:
        assert abs(fit.values[name] / getattr(USER, name) - 1) < (0.06 if name == "i_body" else 0.03), fit.summary()


def test_a_fit_whose_residuals_spread_it_wider_than_noise_warns_and_widens_its_interval():
    """The issue's robot on the full rig with its friction declared and its play not (so the
    model lacks the play), noise seed 0, from 15-25 % off. mu_bearing comes out -0.65 %, about
    9 of the noise model's deviations off; its residuals, segment by segment, spread it 3.4x as
    wide (coulomb too). Before the empirical spread (`sysid.spread`) that was a quiet answer.
    The Fit warns by name, and the widened deviation puts the truth within 3 of them (measured
    2.7). (Tall seed 2 with the play declared was this test's case until Huber's loss made that
    fit right: +2.62 %, quiet.)"""
    fit, caught = fitted_from_off(USER, twip.MotorDriver.thesis_like().replace(current_limit=3.0), 0, play=False)
    print(fit.summary(), fit.solution.spread)
    assert any(w.startswith("mu_bearing: the residuals spread") for w in fit.warnings), fit.summary()
    assert any(issubclass(w.category, twip.SysidMisfitWarning) for w in caught)
    j = fit.names.index("mu_bearing")
    widened, ratio = fit.std["mu_bearing"], fit.solution.spread[j]
    off = abs(fit.values["mu_bearing"] - USER.mu_bearing)
    assert off > 3 * widened / ratio and off < 3 * widened, (off, widened, ratio)


def test_a_play_fit_stops_where_its_search_stalls_within_a_deviation():
    """`play.stop` on a toy problem (two unknowns, unit deviations, no gaps to close): a step
    within PLAY_STEP of a deviation has converged; one within STALL_STEP has only if the last
    accepted step moved nothing; open gaps or a longer step have not. The step not taken comes
    back for the covariance."""
    from twip.sysid import play

    hess, con, none = np.eye(2), np.zeros((0, 2)), np.zeros(0)
    free = np.arange(2)
    why, short = play.stop(hess, con, none, np.array([0.1, -0.2]), np.full(2, np.inf), free, 1e-6)
    assert why.startswith("steps within") and np.allclose(short, [0.1, -0.2])
    why, short = play.stop(hess, con, none, np.array([0.5, 0.3]), np.array([0.0, 1e-3]), free, 1e-6)
    assert why.startswith("stalled 0.50") and np.allclose(short, [0.5, 0.3])
    assert play.stop(hess, con, none, np.array([0.5, 0.3]), np.array([0.0, 0.1]), free, 1e-6)[0] is None
    assert play.stop(hess, con, none, np.array([1.5, 0.0]), np.zeros(2), free, 1e-6)[0] is None
    gaps = np.array([1e-3])
    assert play.stop(hess, np.array([[1.0, 0.0]]), gaps, np.array([0.1, 0.0]), np.zeros(2), free, 1e-6)[0] is None


TINY = twip.RobotParams.balanbot().replace(m_body=0.5, m_wheels=0.04, i_body=4.2e-4, i_wheels=4.5e-6, i_motor=1e-6,
                                           gear_ratio=20.0, torque_constant=0.006, wheel_radius=0.015, com_height=0.05,
                                           mu_bearing=0.002, mu_ground=0.001)


def test_a_play_fit_whose_search_stalls_converges_with_its_interval_widened():
    """A robot the estimator was never tuned on (0.5 kg, 0.05 m, 30 mm wheels, 20:1, 1 A
    driver), full rig, friction and play declared, from 15-25 % off. Before the stall rule:
    within 0.07 % but "not converged after 50 iterations" (so no robot written without
    --force): the gaps closed, the undamped step stuck 0.54 of a deviation short, and every
    accepted step only closed the gaps (the friction's stick band switches within plant steps,
    which the differences do not replay). Now it has converged there, quiet, and its intervals,
    widened by the step not taken, hold the truth."""
    fit, caught = fitted_from_off(TINY, twip.MotorDriver.thesis_like().replace(current_limit=1.0), 0)
    assert fit.converged and "stalled" in fit.message and not fit.warnings and not caught, fit.summary()
    for n in FREE:
        assert abs(fit.values[n] / getattr(TINY, n) - 1) < 0.03, fit.summary()
        lo, hi = fit.interval(n)
        assert lo <= getattr(TINY, n) <= hi, (n, lo, hi, fit.summary())


def test_the_most_open_gap_beyond_the_tolerance_names_its_boundary():
    """`joins.stuck_boundary` on toy gaps: each state's gap in units of that state's size (at
    least 1), the segment whose start is missed most, none within the tolerance."""
    from twip.sysid.joins import stuck_boundary

    starts = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 10.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    gaps = np.array([[0.0, 0.0, 0.0, 3e-6], [0.0, 0.0, 2e-5, 0.0]])
    # 2e-5 in a state of size 10 is 2e-6: the first boundary's 3e-6 is the larger.
    assert stuck_boundary(gaps, starts, 1e-6) == 1
    assert stuck_boundary(gaps * [[1], [10]], starts, 1e-6) == 2
    assert stuck_boundary(gaps, starts, 1e-5) is None
    assert stuck_boundary(None, starts, 1e-6) is None
    assert stuck_boundary(np.full((2, 4), np.nan), starts, 1e-6) is None


def test_a_play_fit_whose_gap_stays_open_joins_the_segments_there():
    """The mid robot's noise seed 3, full rig, friction and play declared, from 15-25 % off.
    Before the joins: within 0.62 %, but "not converged after 50 iterations" (so no robot
    written without --force): the gap at the first boundary (0.25 s) stayed at 1e-4, where the
    prediction jumps within the last plant steps. The two segments there joined, the fit
    converges, quiet, within 3 %."""
    fit, caught = fitted_from_off(MID, MID_DRIVER, 3)
    assert fit.converged and "segments joined at t = 0.250 s" in fit.message, fit.summary()
    assert not fit.warnings and not caught, fit.summary()
    for n in FREE:
        assert abs(fit.values[n] / getattr(MID, n) - 1) < 0.03, fit.summary()
    # Another log is predicted with the segments asked for (0.25 s), not the joined first one's 0.5 s.
    problem = fit._problem
    assert problem.segment == 0.25 and problem.log.t[problem.segments[1]] == pytest.approx(0.5)


def test_a_play_fit_whose_joined_segment_stays_open_releases_the_boundaries_instead():
    """The mid robot's noise seed 3 at the 5 ms loop period, full rig, friction and play
    declared, from 15-25 % off. With joins only: joined at 2.25, 2.5, 2.75 and 3.0 s, each
    joined segment's end jumping in turn, then "not converged after 50 iterations" (within
    0.73 %, so no robot written without --force). From the same point, the boundaries at 2.25
    and 2.5 s released (the later segment's start free of the earlier end): converged, quiet,
    within 0.52 %, and every 95 % interval holds the truth."""
    fit, caught = fitted_from_off(MID, MID_DRIVER, 3, every=5)
    assert fit.converged and "continuity released at t = 2.250, 2.500 s" in fit.message, fit.summary()
    assert not fit.warnings and not caught, fit.summary()
    for n in FREE:
        assert abs(fit.values[n] / getattr(MID, n) - 1) < 0.03, fit.summary()
        low, high = fit.interval(n)
        assert low <= getattr(MID, n) <= high, (n, fit.summary())


@pytest.mark.parametrize("seed", [0, 5])
def test_gear_play_left_out_of_the_model_is_a_misfit(seed):
    """The mid robot's full-rig log fitted with its friction declared and its play not: quiet
    before, off by 3.7-5.4 % over noise seeds 0-7 (seed 0: m_body +3.9 %; seed 5: 5.4 %, a quiet
    answer beyond the issue's 5 %). The gyro's residuals come in spikes where the gear trains hit
    (kurtosis 25-33, against 2.8-15.3 with the play declared): the fit warns, naming the play."""
    fit, caught = fitted_from_off(MID, MID_DRIVER, seed, play=False)
    assert any(m.startswith("gyro: the residuals come in spikes") and "backlash=" in m for m in fit.misfits), fit.summary()
    assert caught and fit.warnings


def test_a_play_fit_whose_impacts_miss_the_logs_is_within_3_percent_and_says_so():
    """The tall robot's noise seed 2, full rig, friction and play declared: within 3 % (i_body
    +2.62 % since Huber's loss; +6.76 % before), but the model's impacts are not the log's: the
    gyro's residuals come in spikes (kurtosis 68) where they miss, and the fit says so. Quiet
    before the residuals' tails were checked, as was the same log at 5 ms, at i_body +3.8 %."""
    fit, caught = fitted_from_off(TALL, DRIVER, 2)
    assert fit.converged, fit.summary()
    for n in FREE:
        assert abs(fit.values[n] / getattr(TALL, n) - 1) < 0.03, fit.summary()
    assert any(m.startswith("gyro: the residuals come in spikes") and "at other times than the model's" in m
               for m in fit.misfits), fit.summary()
