"""Controller design: knobs per family, `twip.tune`, `twip.worst_case`, controller files and
their commands. The tunings here are tiny (a few robots, a few candidates, short runs); the
issue's targets are measured by benches/design_targets.py."""
import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

import twip
from twip import scenarios
from twip.design import controller_file, knobs, uncertainty
from twip.sysid import Fit

from test_cli import run  # cli.main in-process: (code, out, err)

#: A short slope-lqr (0.5 s holds) on the thesis-like rig: the runs of these tests.
SHORT = dict(hold=0.5, settle=0.5)
FOUR = ("m_body", "com_height", "i_body", "mu_bearing")


def short(name="slope-lqr", **options):
    return scenarios.get(name, **{**SHORT, **options})


def box(rel):
    return {k: twip.Uniform(rel=rel) for k in FOUR}


def fingerprint(sc):
    return twip._core.controller_fingerprint(sc.controller)


# --- knobs ---------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["slope-lqr", "flat-lqr", "slope-fuzzy", "circle-pid", "circle-smc"])
def test_the_scenario_controller_own_knobs_rebuild_it_exactly(name):
    sc = scenarios.get(name)
    fam = knobs.family_of(sc.controller)
    own = fam.read(sc.controller, sc)
    assert set(own) == {k.name for k in fam.knobs}
    assert all(k.unit for k in fam.knobs)
    assert fingerprint(knobs.apply(sc, own)) == fingerprint(sc)


def test_a_knob_changes_the_controller_and_keeps_the_rest():
    sc = scenarios.get("slope-fuzzy")
    tuned = knobs.apply(sc, {"k1": 20.0})
    assert tuned.controller.k1 == 20.0 and tuned.controller.k2 == sc.controller.k2
    assert tuned.controller.period == sc.controller.period
    sc = scenarios.get("circle-smc")
    tuned = knobs.apply(sc, {"k_phi": 3.0})
    assert tuned.controller.gains["k_phi"] == 3.0 and tuned.controller.gains["r1"] == sc.controller.gains["r1"]
    sc = scenarios.get("circle-pid")
    assert knobs.apply(sc, {"kp_pitch": 30.0}).controller.gains["kp_pitch"] == 30.0


def test_lqr_knobs_are_weights_redesigned_at_the_scenario_speed():
    sc = scenarios.get("slope-lqr")
    q, r = [10.0, 10.0, 100.0, 10.0], 100.0
    tuned = knobs.apply(sc, dict(zip(knobs.LQR_Q + ("r",), q + [r])))
    direct = twip.LqrController.design(sc.controller.model, math.radians(250), q, r, period=sc.controller.period)
    np.testing.assert_array_equal(tuned.controller.gains, direct.gains)


@pytest.mark.parametrize("delay", [False, True])
def test_lqr_knobs_redesign_a_discrete_controller_as_it_was_designed(delay):
    """A discrete (and delay-aware) design tuned by its weights stays one: its knobs were
    once redesigned in continuous time, other gains than the same weights give."""
    sc = scenarios.get("slope-lqr")
    own = sc.controller
    speed = own.design_info["theta_dot_ref"]
    q, r = [10.0, 10.0, 100.0, 10.0], 100.0
    made = twip.LqrController.design(own.model, speed, q, r, period=own.period, discrete=True, delay=delay)
    tuned = knobs.apply(dataclasses.replace(sc, controller=made), dict(zip(knobs.LQR_Q + ("r",), q + [r])))
    assert (tuned.controller.design_info["discrete"], tuned.controller.design_info["delay"]) == (True, delay)
    np.testing.assert_array_equal(tuned.controller.gains, made.gains)


def test_knob_spaces_are_log_scaled_and_round_trip():
    sc = scenarios.get("slope-fuzzy")
    space = knobs.space(sc, ["kp", "k1"])
    assert space.ranges[0] == pytest.approx((-0.1, -0.001))  # kp = -0.01: a decade each side, sign kept
    values = space.values([0.5, 0.5])
    assert values["kp"] == pytest.approx(-0.01) and values["k1"] == pytest.approx(10.0)
    assert space.unit(values) == pytest.approx([0.5, 0.5])


def test_bad_knobs_are_named():
    sc = scenarios.get("slope-lqr")
    with pytest.raises(twip.InvalidParameterError, match="unknown knob 'q_x'.*q_phi"):
        knobs.space(sc, ["q_x"])
    with pytest.raises(twip.InvalidParameterError, match="'r'.*inverted"):
        knobs.space(sc, {"r": (100.0, 1.0)})
    with pytest.raises(twip.InvalidParameterError, match="same sign"):
        knobs.space(sc, {"r": (0.0, 1.0)})
    with pytest.raises(twip.InvalidParameterError, match="no tunable knobs"):
        knobs.family_of(object())
    with pytest.raises(twip.InvalidParameterError, match="budget = 0"):
        twip.tune(short(), perturb=box(0.1), budget=0, progress=False)
    with pytest.raises(twip.InvalidParameterError, match="unknown knob"):
        twip.tune(short(), perturb=box(0.1), knobs=["k_phi"], budget=3, n=2, progress=False)


def test_a_negative_lqr_weight_is_refused_by_its_knob():
    # The design took Q = diag(-1, 10, 1, 1), an indefinite cost, and returned gains.
    sc = scenarios.get("slope-lqr")
    weights = dict(q_phi=10.0, q_phi_dot=10.0, q_theta_dot=1.0, q_z=1.0, r=1000.0)
    for name in weights:
        with pytest.raises(twip.InvalidParameterError, match=f"knob '{name}' = -1: a weight of the lqr cost"):
            knobs.apply(sc, {**weights, name: -1.0})
        with pytest.raises(twip.InvalidParameterError, match=f"knob '{name}': range \\(-10, -1\\) is negative"):
            knobs.space(sc, {name: (-10.0, -1.0)})
    assert knobs.space(scenarios.get("circle-pid"), {"kp_speed": (-10.0, -1.0)}).ranges == ((-10.0, -1.0),)


def test_knob_ranges_and_values_must_be_real_numbers():
    sc = short()
    for given in ((1, 10**400), (1, math.nan)):
        with pytest.raises(twip.InvalidParameterError, match="knob 'r': range's high must be finite"):
            knobs.space(sc, {"r": given})
    for given in (np.array([1 + 2j, 10 + 0j]), [1 + 2j, 10.0], ("1", "10"), (True, 10)):  # not cut to a real part
        with pytest.raises(TypeError, match="knob 'r': range's low must be a real number"):
            knobs.space(sc, {"r": given})
    for given in ("19", (1, 2, 3), 5):  # a string is not read char by char
        with pytest.raises(TypeError, match="knob 'r': range must be two numbers"):
            knobs.space(sc, {"r": given})
    with pytest.raises(TypeError, match=r"knobs: a knob name must be a string, got \['r'\]"):
        knobs.space(sc, [["r"]])
    assert knobs.space(sc, {"r": np.array([1.0, 10.0])}).ranges == ((1.0, 10.0),)
    weights = dict(q_phi=10.0, q_phi_dot=10.0, q_theta_dot=1.0, q_z=1.0)
    for r in (1 + 2j, np.complex128(3), "7", True, None, np.array([1.0])):
        with pytest.raises(TypeError, match=r"knob 'r' must be a real number"):
            knobs.apply(sc, {**weights, "r": r})
    with pytest.raises(twip.InvalidParameterError, match="knob 'r' must be finite"):
        knobs.apply(sc, {**weights, "r": math.inf})
    with pytest.raises(TypeError, match="values must be a dict"):
        knobs.apply(sc, None)
    assert fingerprint(knobs.apply(sc, {**weights, "r": np.float32(1000)})) == fingerprint(sc)


# --- common random numbers -------------------------------------------------------------

def test_every_candidate_meets_the_same_robots_and_the_same_noise():
    """Two controllers on one seed: the same drawn robots; and sample i alone (another n)
    is the sweep's sample i, so its noise is (seed, i)'s whatever else runs."""
    rig = twip.Realism.thesis_like()
    a = short()
    b = knobs.apply(a, dict(q_phi=10.0, q_phi_dot=10.0, q_theta_dot=100.0, q_z=10.0, r=100.0))
    ra = uncertainty.sweep(a, 6, box(0.3), 5, rig, None)
    rb = uncertainty.sweep(b, 6, box(0.3), 5, rig, None)
    for k in FOUR:
        np.testing.assert_array_equal(ra.drawn(k), rb.drawn(k))
    assert not np.array_equal(ra.metrics["mean_abs_pitch_error"], rb.metrics["mean_abs_pitch_error"])
    alone = uncertainty.sweep(b, 3, box(0.3), 5, rig, None)
    for k in rb.metric_names[2:]:
        np.testing.assert_array_equal(alone.metrics[k], rb.metrics[k][:3])
    other = uncertainty.sweep(b, 3, box(0.3), 6, rig, None)
    assert not np.array_equal(other.drawn("m_body"), rb.drawn("m_body")[:3])


# --- tune --------------------------------------------------------------------------------

def tiny_tune(threads=None, **kw):
    options = dict(perturb=box(0.3), realism=twip.Realism.thesis_like(), n=6, budget=8, validate=8, seed=3,
                   progress=False, threads=threads)
    options.update(kw)
    return twip.tune(short(), **options)


def test_a_tuning_is_bitwise_the_same_on_one_and_two_threads():
    one, two = tiny_tune(threads=1), tiny_tune(threads=2)
    assert one.knobs == two.knobs
    pd.testing.assert_frame_equal(one.history, two.history, check_exact=True)
    np.testing.assert_array_equal(one.validation.metrics["t_end"], two.validation.metrics["t_end"])


def test_a_tuning_answers_with_a_validated_controller():
    t = tiny_tune()
    assert len(t.history) == 8 and set(t.knobs) == set(knobs.LQR_Q + ("r",))
    assert t.scenario.controller is t.controller
    assert fingerprint(knobs.apply(short(), t.knobs)) == fingerprint(t.scenario)
    # held out: other robots than the tuning set's, the same for the tuned and the own controller
    assert t.validation.seed == t.baseline.seed != 3
    np.testing.assert_array_equal(t.validation.drawn("m_body"), t.baseline.drawn("m_body"))
    # the first candidate is the scenario's own controller (thesis weights); the winner is no worse
    first = t.history.iloc[0]
    assert (first["q_phi"], first["q_theta_dot"], first["r"]) == (10.0, 1.0, 1000.0)  # exactly, not via log scale
    assert t.history["cost"].min() <= first["cost"]
    assert "fall rate" in t.summary()


def test_the_first_candidate_is_the_own_controller_exactly_in_any_range():
    # r = 1000 sits low in (900, 1e6): SciPy's rescaling of the first generation, (u - 0.5) + 0.5,
    # dropped its last bits, so the first candidate ran r = 999.9999999999998, not the own controller.
    t = tiny_tune(knobs={"r": (900.0, 1e6)}, budget=5, validate=2)
    assert t.history["r"].iloc[0] == 1000.0
    own = uncertainty.sweep(short(), 6, box(0.3), 3, twip.Realism.thesis_like(), None)
    assert t.history["fall_rate"].iloc[0] == own.fall_rate


def test_ctrl_c_returns_the_best_candidate_so_far():
    calls = []

    def objective(result):  # as a Ctrl-C during the 4th candidate's sweep would
        calls.append(result.fall_rate)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return float(len(calls))  # the first (the scenario's own weights) is the best

    t = tiny_tune(objective=objective)
    assert t.interrupted and len(t.history) == 3
    assert t.knobs == pytest.approx(dict(q_phi=10.0, q_phi_dot=10.0, q_theta_dot=1.0, q_z=1.0, r=1000.0))
    assert t.validation is not None and t.validation.n == 8


@pytest.mark.parametrize("value", [np.complex128(1 + 2j), None, "x", np.array([1.0, 2.0]), math.nan, math.inf])
def test_an_objective_that_returns_no_finite_number_is_named(value):
    # not its real part, not SciPy's "map-like callable", not "no candidate could be built"
    with pytest.raises(twip.InvalidParameterError, match=r"objective returned .*must be a finite real number"):
        tiny_tune(n=3, budget=3, validate=3, objective=lambda result: value)


def sweeps_of(monkeypatch):
    """The sizes of the sweeps tune runs from now on."""
    sizes = []
    sweep = uncertainty.sweep

    def counted(sc, n, *args):
        sizes.append(n)
        return sweep(sc, n, *args)

    monkeypatch.setattr(uncertainty, "sweep", counted)
    return sizes


def test_constraints_and_sizes_are_checked_before_the_sweeps(monkeypatch):
    sizes = sweeps_of(monkeypatch)
    with pytest.raises(TypeError, match="constraints must be a dict"):
        tiny_tune(constraints=[("peak_current", 1.0)])
    for bound, error in ((math.nan, twip.InvalidParameterError), (True, TypeError), ("2", TypeError)):
        with pytest.raises(error, match="constraints: the bound of peak_current"):
            tiny_tune(constraints={"peak_current": bound})
    with pytest.raises(twip.InvalidParameterError, match="unknown metric 'nope'"):
        tiny_tune(constraints={"nope": 1.0})
    for name in ("validate", "n"):  # not "montecarlo: n = ..." after the search
        with pytest.raises(twip.MemoryBudgetError, match=f"tune: {name} = 1,000,000,000,000 robots"):
            tiny_tune(**{name: 10**12, "budget": 2})
    assert max(sizes) <= 1  # at most the one robot that gives the metrics' names
    t = tiny_tune(n=3, budget=3, validate=3, constraints={"peak_current": np.int64(100)})
    assert t.settings["n"] == 3


def test_a_fit_covariance_becomes_the_uncertainty(balanbot):
    """Uncorrelated, each parameter keeps its fit's std, widened only so that the ±3 std clamp
    leaves the variance the fit's."""
    fit = fake_fit(balanbot, np.diag([0.01**2, 0.002**2]))
    sc, perturb = uncertainty.scenario_for("slope-lqr", fit, None)
    assert sc.model.params.m_body == pytest.approx(balanbot.m_body * 1.01)
    clamp = math.sqrt(uncertainty.clamped_variance(uncertainty.FIT_REACH))
    assert 0.997 < clamp < 0.998  # the clamp trims 0.5 % of the variance
    assert perturb["m_body"].std == pytest.approx(0.01 / clamp) and perturb["com_height"].std == pytest.approx(0.002 / clamp)
    assert perturb["m_body"].high - fit.values["m_body"] == pytest.approx(3 * perturb["m_body"].std)


def _widened(perturb, names):
    """The variances a Fit's independent draws have: each std's square, clamp included."""
    return np.array([perturb[n].std**2 for n in names]) * uncertainty.clamped_variance(uncertainty.FIT_REACH)


def test_a_fits_independent_draws_are_at_least_as_wide_as_its_covariance(balanbot):
    """Dropping the correlations would narrow the set along a correlated combination (at 0.95,
    1.95 → 1.01 along (1, 1)/√2); each variance is widened to its row of |Σ| so that the
    independent draws' covariance minus the fit's is positive semidefinite."""
    names = ("m_body", "com_height", "i_body", "mu_bearing")
    scale = np.diag([0.002 * getattr(balanbot, n) for n in names])
    rng = np.random.default_rng(3)
    for _ in range(200):
        a = rng.normal(size=(4, 4)) * rng.uniform(0.1, 3, size=4)  # correlated, of unequal sizes
        cov = scale @ (a @ a.T + 1e-3 * np.eye(4)) @ scale
        perturb = uncertainty.fit_perturbations(fake_fit(balanbot, cov, names=names))
        excess = np.diag(_widened(perturb, names)) - cov
        assert np.linalg.eigvalsh(excess).min() >= -1e-12 * np.abs(cov).max(), cov
    # Drawn (the core's sampler, clamped): along the fit's principal axis at least its variance
    # (4.84 s² here; 5.26 s² expected; the fit's own stds, independent, gave 3.46 s²).
    s = 4e-4
    cov = s**2 * np.array([[4.0, 1.8], [1.8, 1.0]])  # stds 2s and s, correlation 0.9
    fit = fake_fit(balanbot, cov)
    sc, perturb = uncertainty.scenario_for("slope-lqr", fit, None)
    tuples = twip.perturbation.resolve(perturb, sc)
    drawn = np.array([[d[0][n] for n in fit.names] for d in
                      (twip._core.sweep_draw(sc.model, sc.x0, tuples, 7, i) for i in range(20000))])
    axis = np.linalg.eigh(cov)[1][:, -1]
    assert np.var(drawn @ axis) / s**2 > axis @ cov @ axis / s**2 == pytest.approx(4.843, abs=1e-3)
    assert np.var(drawn, axis=0) == pytest.approx(_widened(perturb, fit.names), rel=0.03)


def fake_fit(robot, cov, converged=True, names=("m_body", "com_height")):
    """A Fit of `names` (m_body 1 % off) with covariance `cov` (the estimator's answer is not needed)."""
    fit = Fit.__new__(Fit)
    fit.names = tuple(names)
    fit.values = {n: getattr(robot, n) * (1.01 if n == "m_body" else 1.0) for n in names}
    fit.robot = robot.replace(m_body=robot.m_body * 1.01)
    fit.covariance = np.asarray(cov, float)
    fit.converged, fit.message = converged, "converged"
    return fit


def test_a_fit_with_a_singular_covariance_is_refused(balanbot):
    for cov in (np.array([[1e-4, 1e-4], [1e-4, 1e-4]]), np.array([[1e-4, 0], [0, math.inf]])):
        with pytest.raises(twip.InvalidParameterError, match="singular"):
            twip.tune("slope-lqr", robot=fake_fit(balanbot, cov), budget=2, progress=False)


def test_when_every_candidate_falls_tune_says_so():
    # Every robot starts tipped past the fall limit: no controller holds it.
    tipped = {"phi0": twip.Uniform(low=1.5, high=1.6)}
    with pytest.raises(twip.TuningError, match="every one of 6 candidates failed"):
        twip.tune(short(), perturb=tipped, n=3, budget=6, validate=3, progress=False)


def test_a_constraint_counts_a_robot_over_it_as_failed():
    with pytest.raises(twip.TuningError, match="broke a constraint"):  # no robot keeps under it
        tiny_tune(constraints={"mean_abs_pitch_error": 1e-9}, budget=5)
    free, loose = tiny_tune(budget=5), tiny_tune(budget=5, constraints={"mean_abs_pitch_error": 10.0})
    pd.testing.assert_frame_equal(free.history, loose.history)
    with pytest.raises(twip.InvalidParameterError, match="unknown metric 'nope'"):
        tiny_tune(constraints={"nope": 1.0})


def test_a_constraint_bounds_the_metrics_magnitude():
    """final_position_error is signed (negative: past the goal); a 0.05 m bound let through a
    robot 22 cm past it. A NaN breaks a bound; a bound below 0 would break every robot."""
    from twip.design.objective import check_constraints, failures

    class Result:
        metrics = {"valid": np.array([True, True, True, True, False]), "fell": np.zeros(5, bool),
                   "final_position_error": np.array([0.01, -0.22, 0.3, np.nan, -1.0])}

    np.testing.assert_array_equal(failures(Result(), {"final_position_error": 0.05}), [False, True, True, True])
    with pytest.raises(twip.InvalidParameterError, match="the bound of final_position_error must be finite and >= 0"):
        check_constraints({"final_position_error": -0.05}, ("final_position_error",))


# --- worst case --------------------------------------------------------------------------

def tiny_worst(threads=None, **kw):
    options = dict(perturb=box(0.3), realism=twip.Realism.thesis_like(), budget=24, seed=2, threads=threads)
    options.update(kw)
    return twip.worst_case(short(), **options)


def test_a_worst_case_search_is_bitwise_the_same_on_one_and_two_threads():
    one, two = tiny_worst(threads=1), tiny_worst(threads=2)
    pd.testing.assert_frame_equal(one.history, two.history, check_exact=True)
    assert one.params == two.params and one.metric == two.metric


def test_a_worst_case_starts_space_filling_and_replays():
    w = tiny_worst(budget=64)
    assert w.evaluations == 64 == len(w.history)
    nominal = short().model.params
    # The first generation: the box's 16 corners, then a Latin hypercube inside it.
    rel = np.column_stack([w.history[k] / getattr(nominal, k) - 1 for k in FOUR])
    np.testing.assert_allclose(np.abs(rel[:16]), 0.3, rtol=1e-9)
    assert len({tuple(np.sign(r)) for r in rel[:16]}) == 16
    assert (np.abs(rel) <= 0.3 + 1e-12).all() and (np.abs(rel[16:]) < 0.3 - 1e-9).any()
    assert w.metric == w.history["metric"].max()
    run = w.replay()
    assert run.fell == w.fell
    assert w.robot.m_body == w.params["m_body"]


def ctrl_c_in_robot(monkeypatch, k):
    """Makes the k-th robot sweep from now on meet a Ctrl-C (the first is worst_case's probe)."""
    calls, sweep = [], uncertainty.sweep

    def counted(*args):
        calls.append(1)
        if len(calls) == k:
            raise KeyboardInterrupt
        return sweep(*args)

    monkeypatch.setattr(uncertainty, "sweep", counted)


def test_ctrl_c_in_a_worst_case_search_keeps_the_worst_robot_so_far(monkeypatch, capsys):
    """A Ctrl-C in the search lost every robot tried (KeyboardInterrupt and nothing else;
    `twip worst-case` printed "interrupted" alone): now `.partial` is the worst of them."""
    whole = tiny_worst(budget=64, threads=2)
    ctrl_c_in_robot(monkeypatch, 40)  # in the second generation: the first (16 corners, 16 inside) is kept
    with pytest.raises(KeyboardInterrupt) as stop:
        tiny_worst(budget=64, threads=2)
    partial = stop.value.partial
    assert partial.settings["interrupted"] and partial.evaluations == 32
    pd.testing.assert_frame_equal(partial.history, whole.history.iloc[:32], check_exact=True)
    assert partial.metric == whole.history["metric"].iloc[:32].max() and partial.replay().fell == partial.fell
    ctrl_c_in_robot(monkeypatch, 150)
    code, out, err = run(["worst-case", "flat-lqr", "--perturb", "m_body=±10%", "--budget", "200"], capsys)
    assert code == 130 and "interrupted: the worst of the robots tried so far" in err and "m_body" in err, err


def test_the_worst_case_of_the_8_percent_box_falls_on_fresh_noise():
    """Issue 59's target: in the ±8 % box, where random robots almost all stay up, the search
    finds a falling robot (a corner: benches/design_targets.py finds it at run 13 of 400),
    and that robot falls on noise it was not found with."""
    # The rig without the estimator's settle at rest, issue 59's landscape: settled, the box's
    # worst robot of 64 runs stays up (metric 0.028 against 1.91), the falls having been the start's.
    rig = twip.Realism.thesis_like().replace(settle=None)
    w = twip.worst_case("slope-lqr", perturb=box(0.08), realism=rig, budget=64, seed=0)
    assert w.fell and w.metric > 1.0
    assert w.replay().fell
    fresh = w.confirm(8)
    assert fresh.seed != 0 and fresh.metrics["fell"].all()


def test_a_normals_support_is_its_3_std_within_its_clamps():
    from twip.design.worst_case import support

    sc = short()
    m = sc.model.params.m_body
    std = 0.1 * m
    assert support({"m_body": twip.Uniform(rel=0.1)}, sc)["m_body"] == (m * 0.9, m * 1.1)
    assert support({"m_body": twip.Normal(rel=0.1)}, sc)["m_body"] == (m - 3 * std, m + 3 * std)
    assert support({"m_body": twip.Normal(rel=0.1, low=0.9 * m)}, sc)["m_body"] == (0.9 * m, m + 3 * std)
    # A clamp past mean + 3 std puts every draw on it: the box was (1.5 m, 1.3 m), inverted, and the
    # search ran robots between them that the distribution never draws.
    assert support({"m_body": twip.Normal(rel=0.1, low=1.5 * m, high=2 * m)}, sc)["m_body"] == (1.5 * m, 1.5 * m)
    w = twip.worst_case(sc, perturb={"m_body": twip.Normal(rel=0.1, low=1.5 * m, high=2 * m)}, budget=2, threads=1)
    assert (w.history["m_body"] == 1.5 * m).all()


def test_a_metric_the_runs_do_not_measure_is_never_the_worst():
    # circle-pid's settled errors are NaN on a run shorter than its settling: the answer was
    # the first robot, with metric NaN, and no word.
    sc = scenarios.get("circle-pid", laps=0.05)
    message = r"metric = 'max_path_error_settled': NaN on every one of the 5"
    with pytest.raises(twip.InvalidParameterError, match=message):
        twip.worst_case(sc, perturb={"m_body": twip.Uniform(rel=0.3)}, metric="max_path_error_settled", budget=5,
                        threads=1)


def test_worst_case_budgets_and_a_box_of_one_robot():
    for budget in (1, 2, 4, 5):
        w = twip.worst_case(short(), perturb={"m_body": twip.Uniform(rel=0.3)}, budget=budget, seed=1, threads=1)
        assert w.evaluations == len(w.history) == budget and w.metric == w.history["metric"].max()
    # low == high: one robot, run once (it was run `budget` times, each the same)
    m = short().model.params.m_body
    w = twip.worst_case(short(), perturb={"m_body": twip.Uniform(low=m, high=m)}, budget=6, threads=1)
    assert w.evaluations == 1 and w.params == {"m_body": m} and w.settings["budget"] == 6


def test_worst_case_bad_input_is_named():
    with pytest.raises(twip.InvalidParameterError, match="budget = 0"):
        twip.worst_case(short(), perturb=box(0.1), budget=0)
    with pytest.raises(twip.InvalidParameterError, match="metric = 'nope'"):
        twip.worst_case(short(), perturb=box(0.1), metric="nope", budget=3)
    with pytest.raises(twip.InvalidParameterError, match="perturb: empty"):
        twip.worst_case(short(), perturb={}, budget=3)


def test_a_worst_case_is_a_robot_that_could_be_simulated():
    # Slopes past 90 degrees and negative masses are no robots: left out, with a warning.
    with pytest.warns(UserWarning, match=r"4 of the 8 robots tried could not be simulated \(slope: must be"):
        w = twip.worst_case(short(), perturb={"slope": twip.Uniform(low=0.0, high=3.1)}, budget=8, threads=1)
    assert w.history["valid"].sum() == 4 and math.isfinite(w.metric) and w.params["slope"] < math.pi / 2
    assert w.metric == w.history["metric"][w.history["valid"]].max()
    with pytest.warns(UserWarning, match="m_body: must be > 0"):  # the box's low corner is below 0
        w = twip.worst_case(short(), perturb={"m_body": twip.Normal(rel=0.5)}, budget=8, threads=1)
    assert w.robot.m_body == w.params["m_body"] > 0
    with pytest.raises(twip.InvalidParameterError, match="perturb: none of the 6 robots tried could be simulated"):
        twip.worst_case(short(), perturb={"slope": twip.Uniform(low=2.0, high=3.1)}, budget=6, threads=1)


def test_worst_case_metrics_are_the_scenarios_and_ranked_by_magnitude():
    w = twip.worst_case(scenarios.get("circle-pid", laps=0.05), perturb={"m_body": twip.Uniform(rel=0.1)},
                        budget=3, threads=np.int64(1))  # a planar sweep's pitch metric: mean_abs_pitch
    assert 0 < w.metric < 1 and not w.fell
    # final_position_error is signed: overshooting the goal by 0.79 m is worse than stopping 0.34 m short
    w = tiny_worst(perturb=box(0.3), realism=None, budget=8, seed=0, metric="final_position_error", threads=1)
    assert (w.history["metric"] >= 0).all() and w.metric == w.history["metric"].max()
    final = uncertainty.sweep(short(), 1, w._perturb(), 0, None, 1).metrics["final_position_error"][0]
    assert final < 0 and w.metric == -final
    with pytest.raises(TypeError, match="metric must be a metric name"):
        twip.worst_case(short(), perturb=box(0.1), metric=np.array(["margin"]), budget=3)
    for metric in ("fell", "t_end"):  # how a run ended: "time_to_fall" ranks it
        with pytest.raises(twip.InvalidParameterError, match=f"metric = '{metric}'"):
            twip.worst_case(short(), perturb=box(0.1), metric=metric, budget=3)


# --- controller files and the command line ------------------------------------------------

def test_a_controller_file_round_trips(tmp_path):
    t = tiny_tune(budget=5)
    path = tmp_path / "tuned.toml"
    t.save(path)
    again = controller_file.apply(short(), path)
    np.testing.assert_array_equal(again.controller.gains, t.controller.gains)
    with pytest.raises(controller_file.ControllerFileError, match="a lqr controller; slope-fuzzy runs a fuzzy"):
        controller_file.apply(scenarios.get("slope-fuzzy"), path)
    (tmp_path / "bad.toml").write_text("[controller]\nfamily = \"lqr\"\n[knobs]\nq_x = 1.0\n")
    with pytest.raises(controller_file.ControllerFileError, match="unknown knob 'q_x'"):
        controller_file.apply(short(), tmp_path / "bad.toml")


def same_run(a, b):
    return a.steps == b.steps and all(np.array_equal(getattr(a, k), getattr(b, k))
                                      for k in ("t", "states", "inputs", "measurements"))


def test_a_controller_file_names_its_scenario_and_robot(tmp_path):
    # The file kept the knobs and the scenario's name, never checked: on another robot (or
    # another LQR scenario) it designed, silently, another controller than the one tuned.
    heavy = twip.RobotParams.balanbot().replace(m_body=1.0)
    rig = twip.Realism.thesis_like()
    t = twip.tune(scenarios.get("slope-lqr", params=heavy, **SHORT), perturb=box(0.3), realism=rig, n=4, budget=5,
                  validate=2, seed=3, progress=False)
    path = tmp_path / "tuned.toml"
    t.save(path)
    spec = controller_file.load(path)
    assert spec["robot"] == heavy.to_dict() and spec["scenario"] == "slope-lqr"
    assert 'realism = "thesis-like"' in path.read_text()
    again = controller_file.apply(scenarios.get("slope-lqr", params=heavy, **SHORT), path)
    assert same_run(again.run(realism=rig), t.scenario.run(realism=rig))
    with pytest.raises(controller_file.ControllerFileError, match=r"another robot .*m_body = 0.8301 \(tuned: 1\)"):
        controller_file.apply(short(), path)
    with pytest.raises(controller_file.ControllerFileError, match="tuned on slope-lqr; this is flat-lqr"):
        controller_file.apply(scenarios.get("flat-lqr", params=heavy), path)
    old = tmp_path / "old.toml"  # an older file, without [robot]: applied, with a warning
    old.write_text("[controller]\nscenario = \"slope-lqr\"\nfamily = \"lqr\"\n[knobs]\nr = 100.0\n")
    with pytest.warns(UserWarning, match="names no \\[robot\\]"):
        np.testing.assert_array_equal(controller_file.apply(short(), old).controller.gains,
                                      knobs.apply(short(), {"r": 100.0}).controller.gains)


def test_a_controller_file_on_the_command_line_runs_as_tuned(tmp_path, capsys):
    import json

    robot_file = tmp_path / "heavy.toml"
    twip.robot_file.save(twip.RobotParams.balanbot().replace(m_body=1.0), robot_file)
    path = tmp_path / "tuned.toml"
    code, out, err = run(["tune", "flat-lqr", "--robot", robot_file, "--perturb", "m_body=±10%", "--budget", "5",
                          "-n", "3", "--validate", "2", "--quiet", "--out", path], capsys)
    assert code == 0, err
    t = twip.tune("flat-lqr", robot=twip.Robot.from_file(robot_file).params, perturb={"m_body": twip.Uniform(rel=0.1)},
                  n=3, budget=5, validate=2, progress=False)
    assert controller_file.load(path)["knobs"] == t.knobs
    code, out, err = run(["simulate", "flat-lqr", "--robot", robot_file, "--controller", path, "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["metrics"] == t.scenario.run().metrics
    code, out, err = run(["simulate", "flat-lqr", "--controller", path], capsys)
    assert code == 2 and "tuned for another robot" in err and "m_body = 0.8301 (tuned: 1)" in err


def test_a_controller_file_that_is_not_text_is_named(tmp_path):
    path = tmp_path / "binary.toml"
    path.write_bytes(b"\xff\xfe[controller]\n")
    with pytest.raises(controller_file.ControllerFileError, match="binary.toml: not UTF-8 text"):
        controller_file.load(path)
    with pytest.raises(TypeError, match="path must be a file path, got None"):
        controller_file.load(None)


@pytest.mark.parametrize("digits, message", [(400, r"knob q_phi = an integer of 400 digits must be a finite"),
                                              (5000, r"not a controller file \(Exceeds the limit")])
def test_a_controller_file_with_a_number_beyond_any_float_is_named(tmp_path, capsys, digits, message):
    # It was a bare OverflowError (ValueError past 4300 digits): a traceback on the command line.
    path = tmp_path / "huge.toml"
    path.write_text(f"[controller]\nfamily = \"lqr\"\n[knobs]\nq_phi = {'9' * digits}\n")
    with pytest.raises(controller_file.ControllerFileError, match=message):
        controller_file.load(path)
    code, _, err = run(["simulate", "flat-lqr", "--controller", path], capsys)
    assert code == 2 and "Traceback" not in err


def test_a_file_too_large_for_a_controller_file_is_refused_before_it_is_held(tmp_path):
    # /dev/zero was read until a MemoryError.
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * (1 << 20) + "\n")
    for path in (big, "/dev/zero"):
        with pytest.raises(controller_file.ControllerFileError, match=r"more than 1,048,576 characters"):
            controller_file.load(path)


def test_a_second_ctrl_c_in_twip_tune_keeps_the_best_candidate(tmp_path, capsys, monkeypatch):
    """A second Ctrl-C, in the held-out validation, ended `twip tune` with "interrupted" and
    nothing else: the search's best knobs (the API's `.partial`) were neither printed nor
    written to --out."""
    def ctrl_c(seed):  # the validation's first step: as a Ctrl-C landing there would
        raise KeyboardInterrupt

    monkeypatch.setattr(uncertainty, "held_out_seed", ctrl_c)
    path = tmp_path / "tuned.toml"
    code, out, err = run(["tune", "flat-lqr", "--perturb", "m_body=±10%", "--budget", "5", "-n", "3",
                          "--validate", "3", "--quiet", "--out", path], capsys)
    assert code == 130 and "interrupted before the held-out validation" in err and "knobs: q_phi = " in err, err
    assert f"wrote {path} (not validated)" in err
    saved = controller_file.load(path)
    assert saved["family"] == "lqr" and len(saved["knobs"]) == 5
    assert "validation_fall_rate" not in path.read_text()  # the file says it was not validated


def test_tune_and_worst_case_commands(tmp_path, capsys):
    path = tmp_path / "tuned.toml"
    code, out, err = run(["tune", "flat-lqr", "--perturb", "m_body=±10%", "--budget", "5", "-n", "3",
                              "--validate", "3", "--quiet", "--out", path], capsys)
    assert code == 0, err
    assert "held-out tuned: fall rate" in out and path.stat().st_size > 0
    code, out, err = run(["simulate", "flat-lqr", "--controller", path, "--json"], capsys)
    assert code == 0, err
    code, out, err = run(["sweep", "flat-lqr", "-n", "4", "--perturb", "m_body=±10%", "--quiet",
                              "--controller", path], capsys)
    assert code == 0 and "fall rate" in out, err
    code, out, err = run(["export", "flat-lqr", "--controller", path, "--out", tmp_path / "fw",
                              "--replay-seconds", "1"], capsys)
    assert code == 0, err
    code, out, err = run(["simulate", "flat-fuzzy", "--controller", path], capsys)
    assert code == 2 and "runs a fuzzy controller" in err
    code, out, err = run(["worst-case", "flat-lqr", "--perturb", "m_body=±10%", "--budget", "6",
                              "--confirm", "2"], capsys)
    assert code == 0 and "fresh noise seeds" in out, err
