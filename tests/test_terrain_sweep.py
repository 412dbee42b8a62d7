"""Sweeps of the 3-DOF tracking scenarios on terrain (docs/terrain.md): the slope and
heading axes redraw the terrain plane per sample, reaching the model and the grade's
feed-forward; the same bits on any thread count, in shards, resumed and rerun; sweeps of PID
and sliding mode run on the planar lanes on terrain ("planar-lanes"), which agree with a
replay on the general runner to rounding (1e-12 relative, as on flat ground), and through the
rig on the rig's lanes on terrain ("planar-realism-lanes"), which agree with a replay through
the rig as the flat rig's lanes do (rounding amplified by the thesis-like rig's quantisers);
a tracker without lanes runs through the rig on the general runner, bit for bit."""
import math

import numpy as np
import pytest

import twip

AXES = {
    "m_body": twip.Uniform(rel=0.2),
    "slope": twip.Uniform(low=0.0, high=math.radians(12)),
    "heading": twip.Uniform(low=-math.pi, high=math.pi),
}


def incline(n=12, tracker="pid", **kw):
    kw.setdefault("perturb", AXES)
    kw.setdefault("seed", 3)
    kw.setdefault("progress", False)
    return twip.montecarlo("incline-circle", n, options={"tracker": tracker, "laps": 0.1}, **kw)


def same(a, b):
    assert a.metrics.keys() == b.metrics.keys()
    for k in a.metrics:
        np.testing.assert_array_equal(a.metrics[k], b.metrics[k], err_msg=k)
    assert a.steps == b.steps


def test_slope_and_heading_are_drawn_per_sample_and_reach_the_model_and_the_feed_forward():
    r = incline()
    assert r.kernel == "planar-lanes" and "lifted" in r.metric_names
    slope, heading = r.drawn("slope"), r.drawn("heading")
    assert np.all((slope >= 0) & (slope < math.radians(12))) and np.ptp(slope) > math.radians(5)
    assert np.all(np.abs(heading) <= math.pi) and np.ptp(heading) > 2.0
    cols = r.table()
    assert np.array_equal(cols["slope[rad]"], slope) and np.array_equal(cols["heading[rad]"], heading)
    params, (s, h, terrain), x0 = r.sample(4)
    assert (s, h) == (slope[4], heading[4]) and (terrain.slope, terrain.uphill_heading) == (s, h)
    # The sample is a run of its robot on its own plane, the feed-forward of that plane (on
    # lanes: to rounding).
    sc = twip.scenarios.get("incline-circle", tracker="pid", laps=0.1)
    ff = twip.GradeFeedForward(sc.controller.tracker, terrain, sc.controller.params)
    direct = twip.simulate(twip.PlanarModel(params, terrain=terrain), ff, x0, sc.t_final, sc.dt, reference=sc.reference)
    assert direct.metrics["mean_abs_y_error"] == pytest.approx(r.metrics["mean_abs_y_error"][4], rel=1e-12)
    # The nominal plane's feed-forward on the drawn plane is another run.
    stale = twip.simulate(twip.PlanarModel(params, terrain=terrain), sc.controller, x0, sc.t_final, sc.dt,
                          reference=sc.reference)
    assert stale.metrics["mean_abs_pitch"] != r.metrics["mean_abs_pitch"][4]


@pytest.mark.parametrize("tracker", ["pid", "smc-fuzzy"])
def test_same_bits_on_threads_in_shards_resumed_rerun_and_replayed(tmp_path, tracker):
    one = incline(tracker=tracker, threads=1)
    same(one, incline(tracker=tracker, threads=2))
    same(one, incline(tracker=tracker, checkpoint=tmp_path / "c", shard_size=5))
    same(one, incline(tracker=tracker, checkpoint=tmp_path / "c", shard_size=5))  # every shard read back
    for i in (0, 7):
        alone = one.rerun(i)
        for k in ("valid",) + one.metric_names:
            assert np.array_equal(alone[k], one.metrics[k][i], equal_nan=True), k
        replayed = one.replay(i)
        assert one.kernel == "planar-lanes"
        for k in ("mean_abs_y_error", "mean_abs_pitch", "max_path_error_settled", "peak_abs_torque"):
            assert replayed.metrics[k] == pytest.approx(one.metrics[k][i], rel=1e-12, nan_ok=True), k


def test_a_resumed_checkpoint_on_another_terrain_is_refused(tmp_path):
    incline(n=4, checkpoint=tmp_path / "c", shard_size=2)
    other = twip.scenarios.get("incline-circle", tracker="pid", laps=0.1, slope_deg=7.0)
    with pytest.raises(Exception, match="(?i)checkpoint|fingerprint|different|another"):
        twip.montecarlo(other, 4, perturb=AXES, seed=3, progress=False, checkpoint=tmp_path / "c", shard_size=2)


def ends_as_replayed(r, i, replayed):
    """Sample i of sweep `r` ends as its replay: the same outcome; a run that did not complete
    at the same time (a completed run's `t_end` is None, the sweep's is the run's length)."""
    m = {k: r.metrics[k][i] for k in ("fell", "t_end", "lifted", "off_terrain")}
    assert bool(m["fell"]) == (replayed.outcome != "completed")
    assert bool(m["lifted"]) == (replayed.outcome == "lifted") and bool(m["off_terrain"]) == (replayed.outcome == "off_terrain")
    if replayed.outcome == "completed":
        assert replayed.t_end is None and m["t_end"] == pytest.approx(r.config["t_final"], rel=1e-12)
    else:
        assert replayed.t_end == m["t_end"]


@pytest.mark.parametrize("tracker", ["pid", "smc-fuzzy"])
def test_through_the_rig_on_terrain_on_lanes_the_same_bits_everywhere_and_replayed(tmp_path, tracker):
    """The thesis-like rig on drawn planes, the grade fed forward: on the rig's lanes, the same
    bits on 1 and 2 threads, in shards, resumed and rerun alone; a replay through the rig (its
    noise the sample's stream) ends as the sample does and agrees to rounding amplified by the
    rig's quantisers (IMU registers, encoder and duty counts): measured within 3.1e-7 relative
    (PID, 3.6 s) and 1.6e-10 (smc-fuzzy), where the flat rig's lanes give 2.0e-7 for circle-pid
    over the same 3.6 s, so rel=1e-6. (Without quantisers a lane is its run's within 1e-12:
    `sweep::terrain::tests::a_rig_lane_on_terrain_agrees_with_the_rig_run_to_rounding`.)"""
    kw = dict(realism=twip.Realism.thesis_like(), tracker=tracker)
    one = incline(threads=1, **kw)
    assert one.kernel == "planar-realism-lanes"
    same(one, incline(threads=2, **kw))
    same(one, incline(checkpoint=tmp_path / "c", shard_size=5, **kw))
    same(one, incline(checkpoint=tmp_path / "c", shard_size=5, **kw))  # every shard read back
    ideal = incline(tracker=tracker)
    assert not np.array_equal(one.metrics["mean_abs_pitch"], ideal.metrics["mean_abs_pitch"])
    for i in range(len(one.valid)):
        alone = one.rerun(i)
        for k in ("valid",) + one.metric_names:
            assert np.array_equal(alone[k], one.metrics[k][i], equal_nan=True), k
    for i in (0, 3, 7):
        replayed = one.replay(i)
        ends_as_replayed(one, i, replayed)
        for k in ("mean_abs_y_error", "mean_abs_pitch", "max_path_error_settled", "peak_abs_torque"):
            assert replayed.metrics[k] == pytest.approx(one.metrics[k][i], rel=1e-6, nan_ok=True), k


def test_through_the_rig_on_terrain_a_tracker_without_lanes_runs_on_the_general_runner_bitwise():
    """A sliding-mode tracker whose own model has friction (no law on lanes) runs through the
    rig on terrain on the general runner, and replays bit for bit."""
    sc = twip.scenarios.get("incline-circle", tracker="smc", laps=0.1)
    model = twip.PlanarModel(sc.model.params, twip.Friction.gb37())
    sc = sc.replace(controller=twip.GradeFeedForward(twip.SmcTracker(model), sc.model.terrain, sc.model.params))
    kw = dict(perturb=AXES, seed=3, progress=False, realism=twip.Realism.thesis_like())
    one, two = twip.montecarlo(sc, 4, threads=1, **kw), twip.montecarlo(sc, 4, threads=2, **kw)
    same(one, two)
    assert one.kernel == "planar-realism"
    assert one.replay(1).metrics["mean_abs_pitch"] == one.metrics["mean_abs_pitch"][1]


def test_a_hard_turn_across_a_steep_drawn_plane_lifts():
    """Across a 0.45-0.5 rad plane at 1.5 m/s, turning at 8 rad/s: every sample ends
    "lifted" (counted as fallen too), as a run of it does."""
    perturb = {"slope": twip.Uniform(low=0.45, high=0.5), "heading": twip.Uniform(low=-0.01, high=0.01),
               "psi0": twip.Uniform(low=1.57, high=1.571), "v0": twip.Uniform(low=1.5, high=1.51),
               "omega0": twip.Uniform(low=-8.0, high=-7.9)}
    r = incline(n=4, perturb=perturb)
    assert r.kernel == "planar-lanes"
    assert r.lift_rate == 1.0 and r.fall_rate == 1.0
    assert r.replay(2).outcome == "lifted"
    assert r.replay(2).t_end == r.metrics["t_end"][2]
    # Through the rig, on its lanes, as a replay through the rig.
    rig = incline(n=4, perturb=perturb, realism=twip.Realism.thesis_like())
    assert rig.kernel == "planar-realism-lanes" and rig.lift_rate == 1.0
    ends_as_replayed(rig, 2, rig.replay(2))
    flat = twip.montecarlo("circle-pid", 4, options={"laps": 0.1}, progress=False)
    assert flat.lift_rate == 0.0


def _coast(t, y, ref):
    return [0.0, 0.0]


def test_a_python_controller_sweep_on_terrain_has_the_lifted_and_off_terrain_columns():
    """As the built-in trackers' sweeps: a run that ended "lifted" is 1 in its column."""
    perturb = {"slope": twip.Uniform(low=0.45, high=0.5), "heading": twip.Uniform(low=-0.01, high=0.01),
               "psi0": twip.Uniform(low=1.57, high=1.571), "v0": twip.Uniform(low=1.5, high=1.51),
               "omega0": twip.Uniform(low=-8.0, high=-7.9)}
    sc = twip.scenarios.get("incline-circle", tracker="pid", laps=0.1).replace(controller=_coast)
    r = twip.montecarlo(sc, 3, perturb=perturb, seed=3, progress=False, threads=1)
    assert r.kernel == "python" and {"lifted", "off_terrain"} <= set(r.metric_names)
    assert r.lift_rate == 1.0 and r.fall_rate == 1.0 and not r.metrics["off_terrain"].any()


def test_over_bumps_the_terrain_is_fixed_and_its_robots_are_drawn():
    sc = twip.scenarios.get("figure-eight-bumps", tracker="smc").replace(t_final=1.0)
    r = twip.montecarlo(sc, 4, perturb={"m_body": twip.Uniform(rel=0.2)}, progress=False)
    assert r.kernel == "planar-lanes" and r.valid.all()
    params, (s, h, terrain), x0 = r.sample(1)
    assert s is None and h is None and repr(terrain) == repr(sc.model.terrain)
    assert r.replay(1).metrics["mean_abs_pitch"] == pytest.approx(r.metrics["mean_abs_pitch"][1], rel=1e-12)


@pytest.mark.parametrize("realism", [None, twip.Realism.thesis_like()], ids=["ideal", "rig"])
def test_a_grid_driven_off_ends_off_terrain_on_the_lanes_as_in_a_replay(realism):
    """A grid smaller than the circle: the lanes (ideal, or the rig's) end the samples
    "off_terrain" at the step a replay does, and the feed-forward (of the grid's local plane)
    is on lanes too."""
    xs, ys = np.linspace(-0.5, 0.5, 9), np.linspace(-0.04, 0.04, 5)
    z = 0.02 * np.sin(5 * xs)[:, None] * np.cos(4 * ys)[None, :]
    grid = twip.Terrain.grid(xs, ys, z)
    sc = twip.scenarios.get("incline-circle", tracker="pid", laps=0.1)
    sc = sc.replace(model=twip.PlanarModel(sc.model.params, terrain=grid),
                    controller=twip.GradeFeedForward(sc.controller.tracker, grid, sc.controller.params))
    r = twip.montecarlo(sc, 5, perturb={"m_body": twip.Uniform(rel=0.2)}, progress=False, realism=realism)
    assert r.kernel == ("planar-lanes" if realism is None else "planar-realism-lanes")
    off = r.metrics["off_terrain"]
    assert off.sum() >= 1, off
    i = int(np.argmax(off))
    replayed = r.replay(i)
    assert replayed.outcome == "off_terrain" and replayed.t_end == r.metrics["t_end"][i]
    ends_as_replayed(r, i, replayed)


def test_bad_axes_are_refused_by_name():
    bad = twip.InvalidParameterError
    with pytest.raises(bad, match="slope"):
        incline(n=2, perturb={"slope": twip.Uniform(low=0.0, high=math.radians(90))})
    with pytest.raises(bad, match="slope"):
        incline(n=2, perturb={"slope": twip.Uniform(low=-0.1, high=0.1)})
    with pytest.raises(bad, match="slope"):  # a normal unclamped reaches below 0
        incline(n=2, perturb={"slope": twip.Normal(std=0.05)})
    incline(n=2, perturb={"slope": twip.Normal(std=0.02, low=0.0, high=0.3)})
    bumps = twip.scenarios.get("figure-eight-bumps").replace(t_final=0.1)
    for name in ("heading", "slope"):
        with pytest.raises(bad, match=f"'{name}'.*no plane"):
            twip.montecarlo(bumps, 2, perturb={name: twip.Uniform(low=0.0, high=0.1)}, progress=False)
        with pytest.raises(bad, match=f"'{name}'.*flat ground"):
            twip.montecarlo("circle-pid", 2, perturb={name: twip.Uniform(low=0.0, high=0.1)}, progress=False)
    with pytest.raises(bad, match="heading.*2-DOF"):
        twip.montecarlo("flat-lqr", 2, perturb={"heading": twip.Uniform(low=0.0, high=0.1)}, progress=False)
    # The core refuses them too, by name, whatever the Python layer lets through.
    sc = twip.scenarios.get("figure-eight-bumps")
    with pytest.raises(bad, match="heading"):
        twip._core.sweep_planar_raw(sc.model, sc.controller, sc.x0, 0.1, sc.dt, sc.reference,
                                    [("heading", 0, "uniform", 0.0, 1.0, 0.0, 1.0)], 0, 0, 1)
    inc = twip.scenarios.get("incline-circle")
    with pytest.raises(bad, match="slope"):
        twip._core.sweep_planar_raw(inc.model, inc.controller, inc.x0, 0.1, inc.dt, inc.reference,
                                    [("slope", 0, "uniform", 0.0, 1.6, 0.0, 1.6)], 0, 0, 1)
