"""n x n fuzzy grids for the adaptive controllers (the thesis's future work item 2): the
grid builder, named errors, parity with the pure-Python reference, and the sweep's lanes."""
import math

import numpy as np
import pytest

import twip
import twip.reference as ref
import twip.reference.fuzzy as rf
from twip.reference.control import SpeedSchedule as RefSchedule
from twip.reference.control import simulate as ref_simulate
from conftest import rel_diff

SPEED = math.radians(180)
PHI5 = [-0.3, -0.15, 0.0, 0.15, 0.3]
RATE5 = [-2.0, -1.0, 0.0, 1.0, 2.0]


def _breakpoints(m):
    return m.breakpoints if isinstance(m, twip.Trapezoid) else (m.mean, m.sigma)


def _ref_breakpoints(m):
    return (m.a, m.b, m.c, m.d) if isinstance(m, rf.Trapezoid) else (m.mean, m.sigma)


@pytest.mark.parametrize("kind, widths", [("gaussian", [0.08, 0.6]), ("triangle", None),
                                          ("trapezoid", [0.03, 0.2])])
def test_grid_sets_match_the_reference_builder(kind, widths):
    basis = twip.FuzzyBasis.grid(kind, [PHI5, RATE5], widths)
    assert basis.n_rules == 25
    expected = rf.regular_grid(kind, [PHI5, RATE5], widths)
    for row, ref_row in zip(basis.sets, expected):
        np.testing.assert_allclose([_breakpoints(m) for m in row], [_ref_breakpoints(m) for m in ref_row], atol=1e-15)
    xs = np.array([[0.0, 0.0], [0.11, -1.3], [-0.5, 4.0], [0.29, 0.05]])
    np.testing.assert_allclose(basis.eval(xs), rf.GridBasis(expected).eval(xs), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(basis.eval(xs).sum(axis=1), 1.0, rtol=1e-14)


def test_the_thesis_sets_as_a_regular_trapezoid_grid():
    basis = twip.FuzzyBasis.grid("trapezoid", [[-0.4, 0.0, 0.4], [-2.5, 0.0, 2.5]], [0.1, 0.5])
    for row, want in zip(basis.sets, twip.FuzzyBasis.default().sets):
        np.testing.assert_allclose([m.breakpoints for m in row], [m.breakpoints for m in want], atol=1e-15)


@pytest.mark.parametrize("args, name", [
    (("gaussian", [[0.0], [0.0]], [1.0, 1.0]), "n"),
    (("gaussian", [list(range(8)), list(range(8))], [1.0, 1.0]), "n"),
    (("gaussian", [[0.0, 0.0, 1.0], RATE5[:3]], [1.0, 1.0]), "centres"),
    (("gaussian", [[0.0, math.nan], [0.0, 1.0]], [1.0, 1.0]), "centres"),
    (("gaussian", [[0.0, 1.0], [0.0, 1.0]], [0.0, 1.0]), "widths"),
    (("gaussian", [[0.0, 1.0], [0.0, 1.0]], [[1.0, -1.0], 1.0]), "widths"),
    (("trapezoid", [[0.0, 1.0], [0.0, 1.0]], [0.6, 0.1]), "widths"),
    (("triangle", [[0.0, 1.0], [0.0, 1.0]], [0.1, 0.1]), "widths"),
    (("bell", [[0.0, 1.0], [0.0, 1.0]], [0.1, 0.1]), "kind"),
])
def test_bad_grids_are_named(args, name):
    with pytest.raises(twip.InvalidParameterError, match=rf"\b{name}\b"):
        twip.FuzzyBasis.grid(*args)


def test_the_capacity_is_named():
    with pytest.raises(twip.InvalidParameterError, match=r"n = 8.*at most 7 sets per input \(49 rules\)"):
        twip.FuzzyBasis.grid("gaussian", [list(range(8)), list(range(8))], [1.0, 1.0])
    model = twip.SlopeModel(twip.RobotParams.balanbot(), 0.0)
    sets = [[twip.Gaussian(float(k), 1.0) for k in range(8)]] * 2
    with pytest.raises(twip.InvalidParameterError, match="at most 7"):
        twip.FuzzyController.thesis_flat(model, sets=sets)
    with pytest.raises(twip.ShapeError, match="sets"):
        twip.FuzzyController.thesis_flat(model, sets=[sets[0][:3], sets[0][:4]])
    with pytest.raises(twip.ShapeError, match="s0"):
        twip.FuzzyController.thesis_flat(model, sets=twip.FuzzyBasis.grid("triangle", [PHI5, RATE5]), s0=np.zeros(9))


def _run_both(balanbot, rust, reference, t_final=6.0):
    legs = [(0.5 / balanbot.wheel_radius, SPEED, 1.0), (0.0, SPEED, 0.0)]
    model = twip.SlopeModel(balanbot, 0.0)
    r = twip.simulate(model, rust, np.zeros(4), t_final, 1e-3, reference=twip.SpeedSchedule(legs))
    _, xs, us, ins = ref_simulate(ref.SlopeModel(balanbot, 0.0), reference, np.zeros(4), t_final, 1e-3,
                                  RefSchedule(legs), internals=True)
    return r, xs, us, ins


@pytest.mark.parametrize("kind, widths", [("gaussian", [0.08, 0.6]), ("triangle", None), ("trapezoid", [0.03, 0.2])])
def test_a_5x5_controller_matches_the_reference(balanbot, kind, widths):
    s0 = np.linspace(-0.5, 0.5, 25)
    rust = twip.FuzzyController(twip.SlopeModel(balanbot, 0.0), 30, 33, -0.1, -0.9,
                                sets=twip.FuzzyBasis.grid(kind, [PHI5, RATE5], widths), s0=s0)
    reference = rf.FuzzyController(ref.SlopeModel(balanbot, 0.0), 30, 33, -0.1, -0.9, gamma=rust.gamma,
                                   sigma=rust.sigma, sets=rf.regular_grid(kind, [PHI5, RATE5], widths), s0=s0)
    assert rust.internal_names == list(reference.internal_names) and len(rust.internal_names) == 56
    r, xs, us, ins = _run_both(balanbot, rust, reference)
    assert r.outcome == "completed"
    assert rel_diff(r.states, xs) < 1e-9 and rel_diff(r.inputs[:, 0], us) < 1e-9
    allr = np.column_stack([r.internals[n] for n in reference.internal_names])
    np.testing.assert_allclose(allr, ins, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(allr[0, 25:50], s0)


def test_the_default_3x3_is_unchanged_when_given_as_a_grid(balanbot):
    """The thesis's sets passed explicitly, or as a 3 x 3 FuzzyBasis: the same bits as the default."""
    model = twip.SlopeModel(balanbot, 0.0)
    legs = [(0.5 / balanbot.wheel_radius, SPEED, 1.0), (0.0, SPEED, 0.0)]
    runs = [twip.simulate(model, c, np.zeros(4), 4.0, 1e-3, reference=twip.SpeedSchedule(legs)) for c in (
        twip.FuzzyController.thesis_flat(model), twip.FuzzyController.thesis_flat(model, sets=twip.FuzzyBasis.default()))]
    np.testing.assert_array_equal(runs[0].states, runs[1].states)
    assert list(runs[0].internals) == list(runs[1].internals)


@pytest.mark.parametrize("n", [2, 5, 7])
def test_grids_pickle_export_and_sweep(balanbot, n):
    import pickle
    model = twip.SlopeModel(balanbot, 0.0)
    centres = [list(np.linspace(-0.3, 0.3, n)), list(np.linspace(-2.0, 2.0, n))]
    ctrl = twip.FuzzyController.thesis_flat(model, sets=twip.FuzzyBasis.grid("gaussian", centres, [0.1, 0.8]))
    again = pickle.loads(pickle.dumps(ctrl))
    assert len(again.s0) == n * n and len(again.internal_names) == 2 * n * n + 6
    assert [m.mean for m in again.sets.sets[0]] == pytest.approx(centres[0])


# --- the sliding-mode tracker with fuzzy adaptive backstepping ---------------------------------

OMEGA5 = [-1.0, -0.5, 0.0, 0.5, 1.0]


def _smc_grids(kind, widths):
    yaw = twip.FuzzyBasis.grid(kind, [PHI5, OMEGA5], widths)
    pitch = twip.FuzzyBasis.grid(kind, [PHI5, RATE5], widths)
    return yaw, pitch


@pytest.mark.parametrize("kind, widths", [("trapezoid", [0.03, 0.1]), ("gaussian", [0.08, 0.3])])
def test_a_5x5_sliding_mode_tracker_matches_the_reference(balanbot, kind, widths):
    from twip.reference import tracking as rtr
    import twip.scenarios as scenarios
    sc = scenarios.get("circle-smc-fuzzy")
    yaw, pitch = _smc_grids(kind, widths)
    ctrl = sc.controller.replace(yaw_sets=yaw, pitch_sets=pitch)
    assert ctrl.yaw_sets.n_rules == 25 and len(ctrl.weights[0]) == 25
    t_final = 6.0
    r = sc.replace(controller=ctrl).run(t_final=t_final)
    assert r.outcome == "completed"
    motor = rtr.DcMotor.gb37y3530()
    ref_yaw = rf.regular_grid(kind, [PHI5, OMEGA5], widths)
    ref_pitch = rf.regular_grid(kind, [PHI5, RATE5], widths)
    reference = rtr.SmcTracker(ref.PlanarModel(balanbot), rtr.thesis_gains(motor.torque_per_count()), fuzzy=True,
                               motor=motor, period=0.005, gamma=(0.05, 1000.0), yaw_sets=ref_yaw, pitch_sets=ref_pitch)
    circle = rtr.Circle(sc.reference.radius, sc.reference.speed)
    _, xs, us, ins = rtr.simulate_planar(ref.PlanarModel(balanbot), reference, sc.x0, t_final, sc.dt, circle)
    assert tuple(r.internals) == tuple(reference.internal_names) and len(reference.internal_names) == 15 + 50
    assert rel_diff(r.states, xs) < 1e-9
    assert np.max(np.abs(r.inputs - us)) / np.max(np.abs(us)) < 1e-9
    for i, n in enumerate(reference.internal_names):
        assert np.max(np.abs(r.internals[n] - ins[:, i])) <= 1e-9 * max(np.max(np.abs(ins[:, i])), 1e-300), n


def test_the_tracker_refuses_grids_of_two_sizes():
    import twip.scenarios as scenarios
    ctrl = scenarios.get("circle-smc-fuzzy").controller
    with pytest.raises(twip.ShapeError, match="pitch_sets"):
        ctrl.replace(yaw_sets=twip.FuzzyBasis.grid("triangle", [PHI5, OMEGA5]))


def test_sweeps_of_5x5_grids_take_the_lanes():
    """A 5 x 5 grid's sweep runs on the lanes (their agreement with the runner: the Rust tests)."""
    import twip.scenarios as scenarios
    from twip.sweep import kernel_for
    sets = twip.FuzzyBasis.grid("gaussian", [PHI5, RATE5], [0.08, 0.6])
    sc = scenarios.get("slope-fuzzy", sets=sets, hold=1.0, settle=1.0)
    assert kernel_for(sc) == "lanes"
    res = twip.montecarlo(sc, 8, perturb={"m_body": twip.Uniform(rel=0.2)}, seed=3, progress=False)
    assert res.n == 8 and res.metrics["valid"].all() and not res.metrics["fell"].any()


# --- the C ABI and the firmware export ---------------------------------------------------------

def test_the_c_abi_runs_a_5x5_grid_as_the_f64_controller():
    """The f32 controller through the C ABI on the f32 plant, against the f64 run (the
    tolerances of tests/test_export.py), and its config decoded from the header's layout."""
    from twip import _core
    from twip.firmware import header
    import twip.scenarios as scenarios
    sets = twip.FuzzyBasis.grid("gaussian", [PHI5, RATE5], [0.08, 0.6])
    sc = scenarios.get("slope-fuzzy", sets=sets)
    seconds = 10.0
    rec = _core.ffi_record(sc.model, sc.controller, [float(v) for v in sc.x0], seconds, sc.dt, sc.reference)
    run = sc.run(t_final=seconds)
    at = np.rint(rec["t"].astype(float) / sc.dt).astype(int)
    states, inputs = run.states[at], run.inputs[at]
    span = np.maximum(np.abs(states).max(axis=0), 1e-9)
    assert np.max(np.abs(states - rec["y"]) / span) < 2e-3
    assert np.max(np.abs(inputs - rec["u"])) / np.abs(inputs).max() < 5e-4
    config = header.decode(header.structs(), "TwipFuzzyConfig", rec["config"])
    assert config["n_sets"] == 5 and header.macros()["TWIP_FUZZY_MAX_SETS"] == 7
    assert [s["p"][0] for s in config["sets"][0][:5]] == pytest.approx(PHI5, rel=1e-6)


def test_the_export_writes_a_5x5_grid(tmp_path):
    from twip.firmware.export import export
    import twip.scenarios as scenarios
    sc = scenarios.get("slope-fuzzy", sets=twip.FuzzyBasis.grid("triangle", [PHI5, RATE5]))
    export(sc, tmp_path, units_="si", replay_seconds=1.0)
    c = (tmp_path / "twip_config.c").read_text()
    assert ".n_sets = 5" in c
