"""Tracking on terrain (docs/terrain.md): the grade's feed-forward, terrain= on the 3-DOF
scenarios, the new scenarios and `twip reproduce`'s future-work rows."""
import math
import pickle

import numpy as np
import pytest

import twip
from twip import scenarios
from twip.report import terrain as terrain_report

P = twip.RobotParams.balanbot()


def rest_facing_uphill(slope):
    """The 2-DOF slope model's rest pitch: the terrain model's facing straight uphill
    (tests/test_terrain.py::test_facing_uphill_is_the_slope_model)."""
    xs, _ = twip.SlopeModel(P, slope).equilibrium(0.0)
    return xs[0]


@pytest.mark.parametrize("tracker", ["pid", "smc"])
def test_the_feed_forward_holds_the_robot_at_rest_on_a_grade(tracker):
    """Standing still facing uphill at the rest pitch of a 10 deg plane: with the feed-forward
    the tracker's own equilibrium is the robot's and it stays put; without it the same
    tracker first rolls back down the grade."""
    slope = math.radians(10.0)
    terrain = twip.Terrain.plane(slope, 0.0)
    model = twip.PlanarModel(P, terrain=terrain)
    plain = twip.PidTracker.table_4_1(P) if tracker == "pid" else twip.SmcTracker(twip.PlanarModel(P))
    x0 = np.array([0.0, 0.0, 0.0, rest_facing_uphill(slope), 0.0, 0.0, 0.0])
    stand = twip.Line(1e-9)  # standing still, in effect: 2 nm in the run
    held = twip.simulate(model, twip.GradeFeedForward(plain, terrain, P), x0=x0, t_final=2.0, reference=stand)
    free = twip.simulate(model, plain, x0=x0, t_final=2.0, reference=stand)
    assert held.outcome == "completed"
    assert np.abs(held.states[:, :2]).max() < 1e-8, held.states[-1]
    assert np.abs(held.states[:, 3] - x0[3]).max() < 1e-8
    assert np.abs(free.states[:, 0]).max() > 0.1


def test_grade_feed_forward_refuses_what_is_not_a_tracker_and_pickles():
    terrain = twip.Terrain.bumps(0.04, 1.0)
    with pytest.raises(TypeError, match="3-DOF"):
        twip.GradeFeedForward(object(), terrain, P)
    ff = twip.GradeFeedForward(twip.PidTracker.table_4_1(P), terrain, P)
    back = pickle.loads(pickle.dumps(ff))
    assert back.period == ff.period == 0.005
    sc = scenarios.get("circle-pid", terrain=terrain, laps=1)
    a = sc.run(record_every=100)
    b = sc.replace(controller=back).run(record_every=100)
    assert np.array_equal(a.states, b.states)


def test_every_3dof_scenario_takes_a_terrain_and_level_ground_is_flat():
    """terrain= on each tracker's scenario; a level plane runs the flat scenario's run bit for
    bit (with its feed-forward, which is zero there)."""
    level = twip.Terrain.plane(0.0, 0.7)
    for name in ("circle-pid", "circle-smc", "circle-smc-fuzzy"):
        flat = scenarios.get(name, laps=1).run(record_every=50)
        on = scenarios.get(name, laps=1, terrain=level).run(record_every=50)
        assert on.outcome == flat.outcome == "completed"
        assert np.array_equal(on.states, flat.states), name


def test_the_incline_scenarios_run_every_tracker():
    for tracker in terrain_report.TRACKERS:
        sc = scenarios.get("incline-circle", tracker=tracker, slope_deg=5.0, uphill_heading=math.pi / 2, laps=1)
        assert sc.model.terrain is not None and "not a thesis claim" in sc.description and sc.thesis == {}
        assert sc.run(record_every=100).outcome == "completed", tracker
    with pytest.raises(twip.InvalidParameterError, match="invalid tracker"):
        scenarios.get("incline-circle", tracker="lqr")


def test_the_future_work_rows_are_predictions_not_claims():
    rows = terrain_report.terrain_rows(quick=True)
    assert len(rows) == len(terrain_report.cases(quick=True))
    assert len({r["id"] for r in rows}) == len(rows)
    assert all(r["basis"].startswith("prediction of twip") and "not a thesis claim" in r["basis"] for r in rows)
    fuzzy = [r for r in rows if r["tracker"] == "smc-fuzzy"]
    assert {r["grade_feed_forward"] for r in fuzzy} == {False, True}
    text = "\n".join(terrain_report.markdown(rows))
    assert "not thesis claims" in text and text.count("\n| `") == len(rows)
