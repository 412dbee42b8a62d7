"""Monte Carlo sweeps: determinism, replay, checkpoints, interrupts, Dask, statistics, errors."""
import json
import math
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import twip
from twip import scenarios

PERTURB = {
    "m_body": twip.Uniform(rel=0.2),
    "com_height": twip.Normal(rel=0.1),
    "mu_ground": twip.Uniform(low=0.0, high=0.01),
    "phi0": twip.Normal(std=0.05),
}
SHORT = {"t_final": 3.0}


def same(a, b):
    assert a.metrics.keys() == b.metrics.keys()
    for k in a.metrics:
        np.testing.assert_array_equal(a.metrics[k], b.metrics[k], err_msg=k)
    assert a.steps == b.steps


def sweep(n=64, scenario="flat-lqr-sim", **kw):
    kw.setdefault("perturb", PERTURB)
    kw.setdefault("options", SHORT)
    kw.setdefault("seed", 7)
    return twip.montecarlo(scenario, n, progress=False, **kw)


# Both 2-DOF families run on the lane kernel (the fuzzy one with its trapezoid sets), and
# both trackers on the planar one.
LANE_FAMILIES = ["flat-lqr-sim", "flat-fuzzy-sim"]
ALL_LANE_FAMILIES = LANE_FAMILIES + ["circle-pid", "circle-smc-fuzzy"]


@pytest.mark.parametrize("scenario", LANE_FAMILIES)
def test_same_bits_on_one_and_two_threads_and_in_shards(tmp_path, scenario):
    one, two = sweep(scenario=scenario, threads=1), sweep(scenario=scenario, threads=2)
    same(one, two)
    same(one, sweep(scenario=scenario, checkpoint=tmp_path / "c", shard_size=7))
    assert one.kernel == "lanes"
    loaded = sweep(scenario=scenario, checkpoint=tmp_path / "c", shard_size=7)  # every shard from the checkpoint
    same(one, loaded)
    assert loaded.kernel == "lanes"


@pytest.mark.parametrize("scenario", LANE_FAMILIES)
@pytest.mark.parametrize("index", [0, 17, 63])
def test_a_sample_rerun_alone_is_bitwise_the_same(index, scenario):
    r = sweep(scenario=scenario)
    alone = r.rerun(index)
    assert r.metric_names[2:] == ("mean_abs_pitch_error", "mean_abs_speed_error", "pitch_settling_time",
                                  "speed_settling_time", "final_position_error", "peak_abs_input", "peak_current",
                                  "peak_torque", "peak_command", "saturation_share")
    for name in ("valid",) + r.metric_names:
        assert np.array_equal(alone[name], r.metrics[name][index], equal_nan=True), name


@pytest.mark.parametrize("scenario", LANE_FAMILIES)
@pytest.mark.parametrize("index", [0, 17, 63])
def test_a_sample_replayed_with_its_trajectory_agrees_to_rounding(index, scenario):
    """The lane kernel fuses multiply-adds; the full runner does not. The bounds leave
    ~100x over the worst measured at these indices (printed)."""
    r = sweep(scenario=scenario)
    alone = r.replay(index)
    names = ("mean_abs_pitch_error", "mean_abs_speed_error", "final_position_error", "peak_abs_input")
    worst = max(abs(alone.metrics[n] - r.metrics[n][index]) / max(abs(r.metrics[n][index]), 1e-300) for n in names)
    print(f"{scenario} sample {index}: worst relative difference {worst:.1e}")
    for name in names:
        assert alone.metrics[name] == pytest.approx(r.metrics[name][index], rel=1e-13, abs=1e-15), name
    for name in ("pitch_settling_time", "speed_settling_time"):
        assert abs(alone.metrics[name] - r.metrics[name][index]) <= 1e-3 + 1e-12, name  # one step at most
    assert alone.fell == bool(r.metrics["fell"][index])


# Gaussians beside triangles and shoulders: a basis the lanes evaluate set by set (not as trapezoids).
GAUSSIAN_SETS = [[twip.Gaussian(-0.3, 0.15), twip.Triangle(-0.3, 0.0, 0.3), twip.Gaussian(0.3, 0.15)],
                 [twip.Trapezoid(-math.inf, -math.inf, -2, -0.5), twip.Triangle(-2, 0, 2),
                  twip.Trapezoid(0.5, 2, math.inf, math.inf)]]


def case(name):
    """A case of every kernel: (scenario, montecarlo keywords) of `name`, a scenario's name
    with "+gauss" (fuzzy with Gaussian sets), "+own-friction" (a
    sliding-mode tracker whose own model has friction: the general planar runner) and
    "+rig" (the thesis-like rig). The scenario stays a name where it can (Dask needs one).
    A child process stopped by a signal (below) builds it too."""
    base = name.split("+")[0]
    options = {"laps": 0.05 if "+rig" in name else 0.1} if base.startswith("circle") else {"t_final": 3.0}
    if "+gauss" in name:
        options["sets"] = GAUSSIAN_SETS
    kw = dict(perturb={"m_body": twip.Uniform(rel=0.2), "phi0": twip.Normal(std=0.05)}, seed=11, progress=False,
              realism=twip.Realism.thesis_like() if "+rig" in name else None, shard_size=200, threads=2)
    if "+own-friction" in name:  # a controller object: the scenario goes whole
        sc = scenarios.get(base, **options)
        return sc.replace(controller=twip.SmcTracker(twip.PlanarModel(sc.model.params, twip.Friction.gb37()))), kw
    return base, {**kw, "options": options}


def test_fuzzy_sets_of_any_kind_run_on_lanes_deterministically_and_replay_to_rounding():
    """Gaussians beside a triangle and shoulders: on lanes too (their e^x the lanes'
    polynomial, within 2 ulp of libm's), the same on one and two threads."""
    sc = scenarios.get("flat-fuzzy-sim", sets=GAUSSIAN_SETS, t_final=2.0)
    kw = dict(perturb={"m_body": twip.Uniform(rel=0.2)}, seed=1, progress=False)
    a = twip.montecarlo(sc, 16, threads=1, **kw)
    b = twip.montecarlo(sc, 16, threads=2, **kw)
    same(a, b)
    assert a.kernel == "lanes"
    trapezoids = twip.montecarlo(scenarios.get("flat-fuzzy-sim", t_final=2.0), 16, **kw)
    assert not np.array_equal(a.metrics["mean_abs_pitch_error"], trapezoids.metrics["mean_abs_pitch_error"]), "the sets act"
    for i in (0, 5, 15):
        assert a.replay(i).metrics["mean_abs_pitch_error"] == pytest.approx(a.metrics["mean_abs_pitch_error"][i], rel=1e-11)


def test_narrow_gaussians_far_out_fall_back_to_the_nearest_set_in_a_run_as_on_lanes():
    """With narrow Gaussians the memberships far out are subnormal: a run's 1/sum overflowed
    and made xi NaN, so the replay of sample 1 diverged where its lane (whose e^x flushes
    those to 0) stayed up. Both now take the nearest set alone."""
    narrow = [[twip.Gaussian(-0.3, 0.01), twip.Gaussian(0.0, 0.01), twip.Gaussian(0.3, 0.01)],
              [twip.Gaussian(-2.0, 0.1), twip.Gaussian(0.0, 0.1), twip.Gaussian(2.0, 0.1)]]
    sc = scenarios.get("flat-fuzzy-sim", t_final=3.0, sets=narrow)
    r = twip.montecarlo(sc, 2, perturb={"phi0": twip.Uniform(low=-0.6, high=0.6)}, seed=4, progress=False)
    alone = r.replay(1)
    assert alone.outcome == "completed" and not r.metrics["fell"][1]
    assert alone.metrics["mean_abs_pitch_error"] == pytest.approx(r.metrics["mean_abs_pitch_error"][1], rel=1e-9)


def test_a_robot_that_certainly_falls_has_fall_rate_one():
    r = sweep(perturb={"phi0": twip.Uniform(low=1.2, high=1.4)})
    assert r.fall_rate == 1.0
    assert np.all(r.metrics["t_end"] < 0.1)
    lo, hi = r.fall_rate_interval()
    assert hi == 1.0 and lo > 0.9


def test_wilson_interval_against_a_hand_computed_case():
    # 8 of 10, 95 %: z = 1.959964; centre (0.8 + z^2/20)/(1 + z^2/10) = 0.7167, half-width 0.2139
    lo, hi = twip.wilson_interval(8, 10)
    assert lo == pytest.approx(0.4902, abs=1e-4)
    assert hi == pytest.approx(0.9433, abs=1e-4)
    assert twip.wilson_interval(0, 50)[0] == 0.0


def test_wilson_interval_up_to_the_largest_confidence_below_one():
    """z from the tail: 0.5 + c/2 rounded to 1 at the largest c < 1 (StatisticsError, not
    naming confidence) and lost digits of z close to it."""
    from scipy.stats import norm

    for c in (0.95, 1 - 1e-9, 0.9999999999999999):
        z, p, n = norm.isf((1 - c) / 2), 0.3, 10
        denom = 1 + z * z / n
        centre, half = (p + z * z / (2 * n)) / denom, z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
        assert twip.wilson_interval(3, 10, c) == pytest.approx((centre - half, centre + half), rel=1e-13, abs=0), c


def test_summary_and_pandas():
    r = sweep()
    s = r.summary()
    assert s["samples"] == 64 and s["invalid"] == 0 and 0 <= s["fall_rate"] <= 1
    assert s["mean_abs_pitch_error"]["q05"] <= s["mean_abs_pitch_error"]["median"] <= s["mean_abs_pitch_error"]["q95"]
    # Every sample runs to t_final = 3 s at dt = 1 ms unless it falls; steps count the RK4 steps.
    assert r.steps == int(np.sum(np.rint(r.metrics["t_end"] / 1e-3)))
    assert not r.metrics["fell"].any() and r.steps == 64 * 3000
    assert r.config["seed"] == 7 and r.config["perturb"] == list(PERTURB)
    assert "fall rate" in repr(r)
    pd = pytest.importorskip("pandas")
    assert len(r.to_pandas()) == 64


def test_invalid_draws_are_reported_per_sample_not_raised():
    r = sweep(perturb={"m_body": twip.Normal(mean=0.0, std=0.5)})
    assert 0 < np.sum(~r.valid) < 64
    assert np.all(np.isnan(r.metrics["mean_abs_pitch_error"][~r.valid]))
    assert r.summary()["invalid"] == int(np.sum(~r.valid))


@pytest.mark.parametrize(
    "kwargs,message",
    [
        (dict(n=0), "positive integer"),
        (dict(n=-5), "positive integer"),
        (dict(perturb={"mass": twip.Uniform(rel=0.1)}), "unknown perturbation 'mass'"),
        # One quantity under two names: the later draw overwrote the earlier, both stored as drawn.
        (dict(perturb={"phi0": twip.Uniform(abs=0.1), "x0[0]": twip.Uniform(low=0.2, high=0.3)}),
         "perturb: 'phi0' and 'x0\\[0\\]' are the same quantity; give it once"),
        (dict(perturb={"m_body": twip.Uniform(rel=-0.1)}), "negative width"),
        (dict(perturb={"m_body": twip.Uniform(low=1.0, high=0.5)}), "negative width"),
        (dict(perturb={"m_body": twip.Normal(std=-1.0)}), "negative width"),
        (dict(perturb={"slope": twip.Uniform(rel=0.1)}), "nonzero nominal"),
        (dict(perturb={"phi0": twip.Normal(rel=0.1)}), "phi0: rel= needs a nonzero nominal"),
        (dict(perturb={"m_body": twip.Uniform(low=math.nan, high=1.0)}), "m_body: low = nan must be a finite"),
        (dict(perturb={"m_body": twip.Uniform(low=0.5, high=math.inf)}), "m_body: high = inf must be a finite"),
        (dict(perturb={"phi0": twip.Normal(mean=math.nan, std=0.1)}), "phi0: mean = nan must be a finite"),
        (dict(perturb={"phi0": twip.Normal(std=0.1, high=math.nan)}), "phi0: .*a bound is NaN"),
        # Finite, but the draws overflowed to inf (every sample invalid, or NaN metrics).
        (dict(perturb={"m_body": twip.Uniform(low=-1e308, high=1e308)}), "m_body: .*high - low overflows"),
        (dict(perturb={"m_body": twip.Uniform(rel=1.5e308)}), "m_body: .*high - low overflows"),
        (dict(perturb={"m_body": twip.Normal(std=1e308)}), r"m_body: Normal std = 1e\+308 .*overflows"),
        (dict(perturb={"phi0": twip.Normal(std=1e308, low=-1.0, high=1.0)}), "phi0: Normal std .*overflows"),
        (dict(shard_size=0), "shard_size = 0"),
        (dict(shard_size=-8), "shard_size = -8"),
        (dict(perturb={"m_body": 0.2}), "expected twip.Uniform"),
        (dict(threads=0), "threads"),
        (dict(seed=-1), "seed"),
        (dict(seed=True), r"seed = True: must be an integer"),  # was taken as seed 1, as n=True is not
    ],
)
def test_bad_input(kwargs, message):
    n = kwargs.pop("n", 8)
    with pytest.raises(twip.InvalidParameterError, match=message):
        sweep(n=n, **kwargs)


@pytest.mark.parametrize(
    "kwargs,message",
    [
        (dict(perturb={1: twip.Uniform(abs=0.1)}), r"perturb's keys must be parameter names \(str\), got 1 \(int\)"),
        (dict(perturb=[("m_body", twip.Uniform(abs=0.1))]), r"perturb must be a dict .*got \[.*\(list\)"),
        (dict(scenario=5), r"scenario must be a scenario name or a twip.scenarios.Scenario, got 5 \(int\)"),
        (dict(client=object()), r"client must be a dask.distributed.Client, got <object .*\(object\)"),
    ],
)
def test_arguments_of_the_wrong_type_are_type_errors_naming_them(kwargs, message):
    # Each was an AttributeError from deep inside ('int' object has no attribute 'startswith').
    with pytest.raises(TypeError, match=message):
        sweep(n=8, **kwargs)


def test_a_drawn_value_is_asked_for_by_name():
    with pytest.raises(TypeError, match=r"name must be a perturbation name \(str.*got 0 \(int\)"):
        sweep(n=2).drawn(0)


def test_the_core_refuses_spreads_whose_draws_overflow():
    sc = scenarios.get("flat-lqr-sim")
    for spread, name in [(("uniform", -1e308, 1e308, -1e308, 1e308), "high"), (("normal", 1.0, 1e308, -1.0, 1.0), "std")]:
        with pytest.raises(twip.InvalidParameterError, match=rf"invalid {name} = 1e308: .*overflows"):
            twip._core.sweep_draw(sc.model, sc.x0, [("param", 0, *spread)], 0, 0)


def test_seeds_and_indices_out_of_range_are_named_not_an_overflow():
    """Each was pyo3's OverflowError naming neither the argument nor its value."""
    sc, planar = scenarios.get("flat-lqr-sim"), scenarios.get("circle-pid")
    big = 2**64
    for call, given in [
        (lambda: twip._core.sweep_noise_seed(-1), "seed = -1"),
        (lambda: twip._core.sweep_noise_seed(big), f"seed = {big}"),
        (lambda: twip._core.sweep_draw(sc.model, sc.x0, [], -1, 0), "seed = -1"),
        (lambda: twip._core.sweep_draw(sc.model, sc.x0, [], 0, -1), "index = -1"),
        (lambda: twip._core.sweep_planar_draw(planar.model, planar.x0, [], 0, big), f"index = {big}"),
        (lambda: twip._core.sweep_raw(sc.model, sc.controller, sc.x0, 0.1, sc.dt, sc.reference, [], -1, 0, 1), "seed = -1"),
        (lambda: twip._core.sweep_raw(sc.model, sc.controller, sc.x0, 0.1, sc.dt, sc.reference, [], 0, -1, 1), "start = -1"),
        (lambda: twip._core.sweep_planar_raw(planar.model, planar.controller, planar.x0, 0.1, planar.dt,
                                             planar.reference, [], np.int64(-3), 0, 1), "seed = np.int64(-3)"),
    ]:
        with pytest.raises(twip.InvalidParameterError, match=rf"invalid {re.escape(given)}: must be an integer in \[0, 2\*\*64\)"):
            call()
    assert twip._core.sweep_noise_seed(np.uint64(big - 1)) == twip._core.sweep_noise_seed(big - 1)


def test_a_changed_configuration_is_refused_by_the_checkpoint(tmp_path):
    sweep(n=16, checkpoint=tmp_path, shard_size=8)
    with pytest.raises(twip.InvalidParameterError, match="different configuration.*perturb"):
        sweep(n=16, checkpoint=tmp_path, shard_size=8, perturb={"m_body": twip.Uniform(rel=0.3)})


def test_a_checkpoint_of_a_sweep_with_fuzzy_sets_in_its_options_resumes_and_refuses_other_sets(tmp_path):
    """Options may hold objects (fuzzy sets, by name on the API): the manifest names them by
    their repr (JSON cannot hold them: this sweep once failed with json's TypeError), and the
    controller's fingerprint tells other sets apart."""
    kw = dict(n=16, scenario="flat-fuzzy-sim", checkpoint=tmp_path, shard_size=8)
    first = sweep(options={**SHORT, "sets": GAUSSIAN_SETS}, **kw)
    assert first.kernel == "lanes" and "Gaussian(-0.3, 0.15)" in (tmp_path / "manifest.json").read_text()
    same(first, sweep(options={**SHORT, "sets": GAUSSIAN_SETS}, **kw))
    wider = [[twip.Gaussian(-0.3, 0.2)] + GAUSSIAN_SETS[0][1:], GAUSSIAN_SETS[1]]
    with pytest.raises(twip.InvalidParameterError, match="different configuration.*differs in: controller"):
        sweep(options={**SHORT, "sets": wider}, **kw)


def test_a_model_with_friction_is_refused_before_the_checkpoint_is_touched_and_realism_carries_it(tmp_path):
    sc = scenarios.get("flat-lqr-sim", **SHORT)
    rough = sc.replace(model=twip.SlopeModel(sc.model.params, sc.model.slope, twip.Friction.gb37()))
    with pytest.raises(twip.InvalidParameterError, match=r"model.friction: .*realism=twip.Realism\(friction=...\)"):
        twip.montecarlo(rough, 8, progress=False, checkpoint=tmp_path / "ck")
    assert not (tmp_path / "ck").exists()
    circle = scenarios.get("circle-pid", laps=0.05)
    rough_circle = circle.replace(model=twip.PlanarModel(circle.model.params, twip.Friction.gb37()))
    with pytest.raises(twip.InvalidParameterError, match="model.friction"):
        twip.montecarlo(rough_circle, 8, progress=False, checkpoint=tmp_path / "ck")
    assert not (tmp_path / "ck").exists()
    carried = twip.montecarlo(sc, 8, progress=False, realism=twip.Realism(friction=twip.Friction.gb37()))
    assert carried.kernel == "realism-lanes"
    assert not np.array_equal(carried.metrics["mean_abs_speed_error"], twip.montecarlo(sc, 8, progress=False).metrics["mean_abs_speed_error"])


def test_a_checkpoint_begun_on_another_kernel_is_refused(tmp_path):
    """Kernels agree to rounding, not bit for bit: a sweep begun on the general 3-DOF runner
    (as circle-pid was before it moved to the planar lane kernel) does not resume on lanes."""
    kw = dict(name="circle-pid", n=16, checkpoint=tmp_path, shard_size=8)
    tracking_sweep(**kw)
    manifest = tmp_path / "manifest.json"
    stored = json.loads(manifest.read_text())
    assert stored["manifest"]["config"]["kernel"] == "planar-lanes"
    stored["manifest"]["config"]["kernel"] = "planar"
    manifest.write_text(json.dumps(stored))
    with pytest.raises(twip.InvalidParameterError, match=r"different configuration.*differs in: kernel\)"):
        tracking_sweep(**kw)


def test_a_checkpoint_of_an_older_shard_layout_is_refused(tmp_path):
    """3-DOF shards gained the lifted and off_terrain columns within one version: a folder
    begun before (no shard_format, the first layout) is refused, never resumed with mixed shards."""
    kw = dict(name="circle-pid", n=16, checkpoint=tmp_path, shard_size=8)
    tracking_sweep(**kw)
    manifest = tmp_path / "manifest.json"
    stored = json.loads(manifest.read_text())
    assert stored["manifest"]["config"]["shard_format"] == twip.sweep.SHARD_FORMAT
    del stored["manifest"]["config"]["shard_format"]
    manifest.write_text(json.dumps(stored))
    with pytest.raises(twip.InvalidParameterError, match=r"different configuration.*differs in: shard_format\)"):
        tracking_sweep(**kw)


def test_a_changed_scenario_object_is_refused_by_the_checkpoint(tmp_path):
    sc = scenarios.get("flat-lqr-sim", **SHORT)
    run = lambda s: twip.montecarlo(s, 16, perturb=PERTURB, seed=7, progress=False, checkpoint=tmp_path, shard_size=8)
    run(sc)
    changes = {
        "control_period": sc.replace(control_period=2e-3),
        "reference": sc.replace(reference=twip.SpeedSchedule.constant(1.0)),
        # The same gains at another period: a controller's repr does not show its period.
        "controller": sc.replace(controller=scenarios.get("flat-lqr-sim", period=2e-3).controller),
    }
    for key, changed in changes.items():
        with pytest.raises(twip.InvalidParameterError, match=f"different configuration.*differs in: {key}\\)"):
            run(changed)
    same(run(sc), sweep(n=16))  # the unchanged scenario resumes


def test_simulate_refuses_settle_for_a_slope_model():
    sc = scenarios.get("flat-lqr-sim")
    with pytest.raises(twip.InvalidParameterError, match="settle: only a PlanarModel"):
        twip.simulate(sc.model, sc.controller, sc.x0, 0.1, settle=0.05)


# Each case's kernel, and its samples: 8 000, fewer where a kernel is slow (each a few
# seconds on two cores).
SIGNAL_CASES = {
    "flat-lqr-sim": ("lanes", 8_000), "flat-fuzzy-sim": ("lanes", 8_000),
    "circle-pid": ("planar-lanes", 8_000), "circle-smc-fuzzy": ("planar-lanes", 8_000),
    "circle-smc+own-friction": ("planar", 2_000), "flat-lqr-sim+rig": ("realism-lanes", 8_000),
    "circle-pid+rig": ("planar-realism-lanes", 8_000), "circle-smc+own-friction+rig": ("planar-realism", 1_000),
}
SCRIPT = r"""
import sys, twip
sys.path.insert(0, sys.argv[4])
from test_sweep import case
sc, kw = case(sys.argv[3])
try:
    twip.montecarlo(sc, int(sys.argv[2]), checkpoint=sys.argv[1], **kw)
except KeyboardInterrupt as e:
    print("interrupted", len(e.partial.metrics["valid"]), flush=True)
    sys.exit(3)
print("finished", flush=True)
"""


def start_and_stop(folder, sig, n, name):
    tests = os.path.dirname(os.path.abspath(__file__))
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT, str(folder), str(n), name, tests], stdout=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not list(folder.glob("shard-*.npz")):
        assert time.monotonic() < deadline and proc.poll() is None, "no shard was written"
        time.sleep(0.02)
    sent = time.monotonic()
    proc.send_signal(sig)
    out, _ = proc.communicate(timeout=30)
    return proc.returncode, out, time.monotonic() - sent


@pytest.mark.parametrize("name", SIGNAL_CASES)
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL])
def test_interrupted_sweep_resumes_to_the_uninterrupted_result(tmp_path, sig, name):
    kernel, n = SIGNAL_CASES[name]
    folder = tmp_path / "run"
    code, out, waited = start_and_stop(folder, sig, n, name)
    shards = len(list(folder.glob("shard-*.npz")))
    print(f"{signal.Signals(sig).name}: stopped after {waited * 1e3:.0f} ms with {shards} of {n // 200} shards written")
    assert 0 < shards < n // 200
    if sig == signal.SIGINT:
        assert code == 3 and out.startswith("interrupted")  # how fast: benches/ctrl_c.py
    sc, kw = case(name)
    if sig == signal.SIGKILL:  # killed holding the lock: taken over, and said so
        with pytest.warns(UserWarning, match="took over the lock left by pid"):
            resumed = twip.montecarlo(sc, n, checkpoint=folder, **kw)
    else:
        resumed = twip.montecarlo(sc, n, checkpoint=folder, **kw)
    assert len(list(folder.glob("shard-*.npz"))) == n // 200
    if sig == signal.SIGINT:  # a clean stop leaves no half-written file (SIGKILL may)
        assert not list(folder.glob("*.tmp*"))
    fresh = twip.montecarlo(sc, n, **kw)
    assert fresh.kernel == resumed.kernel == kernel
    same(resumed, fresh)
    assert np.array_equal(resumed.metrics["index"], np.arange(n))


@pytest.mark.parametrize("name", SIGNAL_CASES)
def test_every_kernel_reruns_a_sample_bitwise_and_is_the_same_on_one_thread(name):
    """`rerun(i)` runs sample i alone through the sweep's engine: its metrics bit for bit;
    one thread and small shards change nothing."""
    sc, kw = case(name)
    r = twip.montecarlo(sc, 12, **{**kw, "shard_size": 5})
    assert r.kernel == SIGNAL_CASES[name][0]
    same(r, twip.montecarlo(sc, 12, **{**kw, "threads": 1}))
    for i in (0, 7, 11):
        alone = r.rerun(i)
        for k in ("valid",) + r.metric_names:
            assert np.array_equal(alone[k], r.metrics[k][i], equal_nan=True), (i, k)


def case_sweep(name):
    """A sweep of `case(name)` taking `n` and montecarlo's keywords."""
    sc, defaults = case(name)
    return lambda n, **kw: twip.montecarlo(sc, n, **{**defaults, **kw})


# (The general planar runner serves a tracker object, which Dask refuses: it needs a name.)
@pytest.mark.parametrize("family", ["2-DOF", "2-DOF fuzzy", "2-DOF rig lanes", "2-DOF Gaussian fuzzy rig", "tracking",
                                    "tracking pid", "2-DOF Gaussian fuzzy", "tracking rig"])
def test_dask_local_cluster_gives_the_local_result(family):
    distributed = pytest.importorskip("dask.distributed")
    fuzzy = lambda **kw: sweep(scenario="flat-fuzzy-sim", **kw)  # noqa: E731
    rig = lambda **kw: rig_sweep(**kw)  # noqa: E731
    # Fuzzy with Gaussian sets: the workers get the sets pickled.
    gaussian_rig = lambda **kw: rig_sweep(scenario="flat-fuzzy-sim", options={**SHORT, "sets": GAUSSIAN_SETS}, **kw)  # noqa: E731
    pid = lambda **kw: tracking_sweep(name="circle-pid", **kw)  # noqa: E731
    run, n = {"2-DOF": (sweep, 96), "2-DOF fuzzy": (fuzzy, 96), "2-DOF rig lanes": (rig, 64),
              "2-DOF Gaussian fuzzy rig": (gaussian_rig, 16), "tracking": (tracking_sweep, 32), "tracking pid": (pid, 32),
              "2-DOF Gaussian fuzzy": (case_sweep("flat-fuzzy-sim+gauss"), 16), "tracking rig": (case_sweep("circle-pid+rig"), 8)}[family]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = run(n=n, client=client, shard_size=n // 4)
    same(remote, run(n=n))


# --- realism in sweeps ------------------------------------------------------------------
# Sweeps with `realism=`: the real robot's sensors, motor driver and delay in every run.

RIG_PERTURB = {"m_body": twip.Uniform(rel=0.2), "slope": twip.Uniform(low=0.0, high=0.3), "phi0": twip.Normal(std=0.02)}


def rig_sweep(n=48, realism=None, scenario="flat-lqr-sim", **kw):
    kw.setdefault("perturb", RIG_PERTURB)
    if isinstance(scenario, str):  # (a Scenario object carries its own options)
        kw.setdefault("options", SHORT)
    kw.setdefault("seed", 3)
    realism = twip.Realism.thesis_like() if realism is None else realism
    return twip.montecarlo(scenario, n, progress=False, realism=realism, **kw)


# LQR and fuzzy with any sets run any rig on lanes.
GAUSSIAN_FUZZY = scenarios.get("flat-fuzzy-sim", sets=GAUSSIAN_SETS, **SHORT)
RIGS = [("Gaussian fuzzy", GAUSSIAN_FUZZY), ("LQR", "flat-lqr-sim")]


@pytest.mark.parametrize("scenario", [s for _, s in RIGS], ids=[k for k, _ in RIGS])
def test_realism_sweep_is_the_same_on_one_and_two_threads(scenario):
    one, two = rig_sweep(threads=1, scenario=scenario), rig_sweep(threads=2, scenario=scenario)
    same(one, two)
    assert one.kernel == "realism-lanes"
    # The rig matters: some of these robots fall with it, none in the ideal loop.
    options = {"options": SHORT} if isinstance(scenario, str) else {}
    ideal = twip.montecarlo(scenario, 48, progress=False, perturb=RIG_PERTURB, seed=3, **options)
    assert 0 < one.metrics["fell"].sum() < 48 and not ideal.metrics["fell"].any()


def test_realism_sample_17_replayed_alone_agrees_to_rounding():
    """Over a second, before the quantisers' drift (see below), the replay of a rig lane
    (fuzzy, Gaussian sets) is its run to rounding; rerun(i) gives its bits."""
    r = rig_sweep(scenario="flat-fuzzy-sim", options={"t_final": 1.0, "sets": GAUSSIAN_SETS})
    alone = r.replay(17)
    assert alone.signals, "the replay ran with the realism"
    for name in ("mean_abs_pitch_error", "mean_abs_speed_error", "final_position_error", "peak_abs_input"):
        assert alone.metrics[name] == pytest.approx(r.metrics[name][17], rel=1e-9), name
    assert alone.fell == bool(r.metrics["fell"][17])
    # The noise is the sample's own stream: another stream gives another run.
    other = r.replay(17, realism=r.realism.replace(seed=twip._core.sweep_noise_seed(r.seed), stream=18))
    assert other.metrics["mean_abs_pitch_error"] != r.metrics["mean_abs_pitch_error"][17]


def test_a_rig_lane_replays_to_rounding_and_agrees_in_shards():
    """A lane through the rig against the rig's run of its robot (`replay`): the same
    source with fused multiply-adds. Quantised outputs (IMU registers, encoder counts, whole
    duty counts) let two roundings drift apart at the open-loop pendulum's rate (the core's
    test: ~1e-8 after 3 s, like the run against itself nudged by 1e-16), so 1e-6 here."""
    realism = twip.Realism.thesis_like()
    r = rig_sweep(realism=realism)
    assert r.kernel == "realism-lanes"
    for i in (0, 17, 40):
        alone = r.replay(i)
        assert alone.fell == bool(r.metrics["fell"][i])
        for name in ("mean_abs_pitch_error", "mean_abs_speed_error", "final_position_error", "peak_abs_input"):
            assert alone.metrics[name] == pytest.approx(r.metrics[name][i], rel=1e-6), (i, name)
    # Shards of any size, and one sample alone, give the same bits.
    same(r, twip.montecarlo("flat-lqr-sim", 48, progress=False, realism=realism, perturb=RIG_PERTURB, options=SHORT, seed=3, threads=2))
    fuzzy = twip.montecarlo("flat-fuzzy-sim", 20, progress=False, realism=realism, perturb=RIG_PERTURB, options=SHORT, seed=3)
    assert fuzzy.kernel == "realism-lanes"
    for i in (3, 17):
        alone = fuzzy.rerun(i)
        for name in ("valid",) + fuzzy.metric_names:
            assert np.array_equal(alone[name], fuzzy.metrics[name][i], equal_nan=True), name


def test_a_pushed_and_pulled_rig_runs_on_lanes_and_replays_to_rounding():
    """Pushes jump each lane's velocities between steps and a constant force adds to its
    equations, as in the rig's own run: over a second (before the quantisers' drift, see
    above) such a lane replays to rounding."""
    second = {"t_final": 1.0}
    thesis_like = twip.Realism.thesis_like()
    pushed = rig_sweep(realism=thesis_like.replace(pushes=[(0.4, 0.3)]), options=second)
    r = rig_sweep(realism=thesis_like.replace(pushes=[(0.4, 0.3)], force=twip.Force(horizontal=0.4, height=0.08),
                                              slope_profile=[(0.02, 0.04), (0.06, 0.0)]), options=second)
    assert pushed.kernel == r.kernel == "realism-lanes"
    plain = rig_sweep(options=second)
    assert not np.array_equal(pushed.metrics["mean_abs_speed_error"], plain.metrics["mean_abs_speed_error"]), "the push acted"
    assert not np.array_equal(r.metrics["mean_abs_speed_error"], pushed.metrics["mean_abs_speed_error"]), "the force acted"
    for i in (2, 17, 40):
        alone = r.replay(i)
        for name in ("mean_abs_pitch_error", "mean_abs_speed_error", "final_position_error", "peak_abs_input"):
            assert alone.metrics[name] == pytest.approx(r.metrics[name][i], rel=1e-9), (i, name)


def test_pushes_and_forces_without_a_height_act_at_each_samples_own_centre_of_mass():
    """A push or force without a height acts at the robot's centre of mass: on lanes each
    sample's own, as in its replay (the lanes once used the nominal robot's for every
    sample: 8-17 % off in mean |pitch error| with the centre of mass ±30 %)."""
    perturb = {**RIG_PERTURB, "com_height": twip.Uniform(rel=0.3)}
    realism = twip.Realism(pushes=[twip.Push(t=0.5, impulse=0.3)], force=twip.Force(horizontal=0.4),
                           control_period=5e-3)
    for scenario in ("flat-lqr-sim", "flat-fuzzy-sim"):
        r = rig_sweep(n=12, realism=realism, scenario=scenario, perturb=perturb, options={"t_final": 1.5})
        assert r.kernel == "realism-lanes"
        for i in range(12):
            alone = r.replay(i)
            for name in ("mean_abs_pitch_error", "mean_abs_speed_error", "final_position_error"):
                assert alone.metrics[name] == pytest.approx(r.metrics[name][i], rel=1e-9), (scenario, i, name)


def test_realism_noise_follows_the_sweep_seed_not_the_realism_seed():
    a = rig_sweep(n=8, perturb={}, seed=3)
    same(a, rig_sweep(n=8, perturb={}, seed=3, realism=twip.Realism.thesis_like(seed=99, stream=5)))
    b = rig_sweep(n=8, perturb={}, seed=4)
    # The same nominal robot in every sample: only the noise differs.
    assert len(set(a.metrics["mean_abs_pitch_error"])) == 8
    assert not np.any(a.metrics["mean_abs_pitch_error"] == b.metrics["mean_abs_pitch_error"])


@pytest.mark.parametrize("scenario", [s for _, s in RIGS], ids=[k for k, _ in RIGS])
def test_realism_checkpoint_resume_equals_the_uninterrupted_sweep(tmp_path, monkeypatch, scenario):
    import twip.sweep as tsweep

    run, calls = tsweep.run_samples, []

    def stop_at_shard_16(*args, **kw):
        calls.append(args[2])
        if calls == [0, 16]:
            raise KeyboardInterrupt  # as Ctrl-C during the second shard
        return run(*args, **kw)

    monkeypatch.setattr(tsweep, "run_samples", stop_at_shard_16)
    with pytest.raises(KeyboardInterrupt):
        rig_sweep(checkpoint=tmp_path, shard_size=16, scenario=scenario)
    assert len(list(tmp_path.glob("shard-*.npz"))) == 1
    calls.clear()
    resumed = rig_sweep(checkpoint=tmp_path, shard_size=16, scenario=scenario)
    assert calls == [16, 32], "the finished shard is loaded, not run again"
    monkeypatch.setattr(tsweep, "run_samples", run)
    same(resumed, rig_sweep(scenario=scenario))
    resumed.replay(40)  # the resumed result keeps its realism


def test_a_dask_worker_rebuilds_the_realism_from_the_config():
    import twip.sweep as tsweep

    realism = twip.Realism.thesis_like().replace(
        estimator=twip.TiltEstimator.kalman(), pushes=[(1.0, 0.3)], force=twip.Force(horizontal=0.5),
        slope_profile=[(0.2, 0.05)], motor=twip.MotorDriver.thesis_like().replace(current_limit=1.5))
    r = rig_sweep(n=16, realism=realism)
    raw = tsweep.run_shard_by_name(json.loads(json.dumps(r.config)), 4, 8, 1)
    assert raw["kernel"] == r.kernel == "realism-lanes"
    for name in ("fell", "mean_abs_pitch_error", "peak_abs_input", "t_end"):
        np.testing.assert_array_equal(raw[name], r.metrics[name][4:12], err_msg=name)


def test_realism_is_part_of_the_checkpoint_fingerprint(tmp_path):
    rig_sweep(n=16, checkpoint=tmp_path, shard_size=8)
    for changed in (twip.Realism.thesis_like().replace(delay=False),
                    twip.Realism.thesis_like().replace(motor=twip.MotorDriver.thesis_like().replace(battery=9.0))):
        with pytest.raises(twip.InvalidParameterError, match="different configuration.*realism"):
            rig_sweep(n=16, checkpoint=tmp_path, shard_size=8, realism=changed)
    with pytest.raises(twip.InvalidParameterError, match="different configuration.*realism"):
        sweep(n=16, checkpoint=tmp_path, shard_size=8, perturb=RIG_PERTURB, seed=3)
    # The realism's seed is not the sweep's noise key, so it does not change the sweep.
    rig_sweep(n=16, checkpoint=tmp_path, shard_size=8, realism=twip.Realism.thesis_like(seed=42))


@pytest.mark.parametrize("motor", [twip.MotorDriver(battery=2.0), twip.MotorDriver(current_limit=0.3)],
                         ids=["low-battery", "current-limit"])
def test_a_motor_driver_too_weak_for_the_slope_makes_every_robot_fall(motor):
    kw = dict(progress=False, seed=1, options={"t_final": 3.0}, perturb={"m_body": twip.Uniform(rel=0.1)})
    weak = twip.montecarlo("slope-lqr-sim", 16, realism=twip.Realism(motor=motor), **kw)
    assert weak.fall_rate == 1.0 and weak.valid.all() and np.all(weak.metrics["t_end"] < 1.5)
    assert twip.montecarlo("slope-lqr-sim", 16, realism=twip.Realism.thesis_like(), **kw).fall_rate == 0.0


@pytest.mark.parametrize(
    "realism,message",
    [
        ("thesis", "realism = 'thesis': must be a twip.Realism"),
        (twip.Imu(), "realism = Imu.*must be a twip.Realism"),
        (twip.Realism(imu=twip.Imu(sample_rate=300.0)), "dt = 0.001: must divide the IMU's sample period"),
        (twip.Realism(control_period=0.0025), "control_period = 0.0025: must be a whole multiple of dt"),
    ],
)
def test_bad_realism_is_refused_with_a_clear_error(realism, message):
    with pytest.raises(twip.InvalidParameterError, match=message):
        rig_sweep(n=4, realism=realism)


def test_tracking_realism_sweep_is_bitwise_on_1_and_2_threads_and_replays():
    """Each sample runs the 3-DOF rig with its own noise stream, on the planar rig's lane
    kernel; thread count changes nothing, rerunning sample i alone gives its bits, and
    replaying it with the full runner (realism with the sweep's noise key, stream i) its
    metrics to rounding: through the thesis-like rig's quantisers over 3 s, measured within
    3e-12 relative (rel=1e-9 leaves room), and bit for bit on the general runner."""
    sc = scenarios.get("circle-smc", laps=1).replace(t_final=3.0)
    kw = dict(perturb={"m_body": twip.Uniform(rel=0.1)}, seed=9, progress=False, realism=twip.Realism.thesis_like())
    one = twip.montecarlo(sc, 4, threads=1, **kw)
    two = twip.montecarlo(sc, 4, threads=2, **kw)
    assert one.kernel == "planar-realism-lanes"
    for k in one.metrics:
        assert np.array_equal(np.asarray(one.metrics[k]), np.asarray(two.metrics[k]), equal_nan=True), k
    ideal = twip.montecarlo(sc, 4, threads=2, **{**kw, "realism": None})
    assert not np.array_equal(one.metrics["mean_abs_x_error"], ideal.metrics["mean_abs_x_error"])
    assert one.rerun(2)["mean_abs_x_error"] == one.metrics["mean_abs_x_error"][2]
    for i in range(4):
        assert one.replay(i).metrics["mean_abs_x_error"] == pytest.approx(one.metrics["mean_abs_x_error"][i], rel=1e-9)
    # The general runner through the rig (a tracker whose own model has friction) replays bitwise.
    general = sc.replace(controller=twip.SmcTracker(twip.PlanarModel(sc.model.params, twip.Friction.gb37())))
    own = twip.montecarlo(general, 4, threads=2, **kw)
    assert own.kernel == "planar-realism"
    assert own.replay(2).metrics["mean_abs_x_error"] == own.metrics["mean_abs_x_error"][2]


# ============================================================================ 3-DOF tracking sweeps
# PlanarModel scenarios run in Rust too (_core.sweep_planar_raw); a fifth of a lap keeps
# each run to a few thousand steps.

TRACK_PERTURB = {
    "m_body": twip.Uniform(rel=0.2),
    "com_height": twip.Normal(rel=0.1),
    "mu_ground": twip.Uniform(low=0.0, high=0.01),
    "phi0": twip.Normal(std=0.03),
    "y0": twip.Uniform(abs=0.05),
}
TRACK_METRICS = ("mean_abs_x_error", "mean_abs_y_error", "mean_abs_x_error_settled", "mean_abs_y_error_settled",
                 "max_path_error_settled", "mean_abs_pitch", "peak_abs_torque", "peak_current", "peak_torque",
                 "peak_command", "saturation_share")
#: A tracking sweep's columns: twip.simulate's metrics, then how a run on terrain ended.
TRACK_COLUMNS = TRACK_METRICS + ("lifted", "off_terrain")


def tracking_sweep(n=32, name="circle-smc-fuzzy", **kw):
    kw.setdefault("perturb", TRACK_PERTURB)
    kw.setdefault("options", {"laps": 0.2})
    kw.setdefault("seed", 7)
    kw.setdefault("progress", False)
    return twip.montecarlo(name, n, **kw)


# Both trackers run on the planar lane kernel.
TRACKERS = ["circle-pid", "circle-smc-fuzzy"]


@pytest.mark.parametrize("name", TRACKERS)
def test_tracking_sweep_same_bits_on_one_and_two_threads_and_in_shards(tmp_path, name):
    one, two = tracking_sweep(name=name, threads=1), tracking_sweep(name=name, threads=2)
    same(one, two)
    assert one.kernel == "planar-lanes"
    assert one.metric_names == ("fell", "t_end") + TRACK_COLUMNS
    # Every sample is its own robot: the metrics differ from sample to sample.
    assert len(np.unique(one.metrics["mean_abs_y_error"])) == 32
    same(one, tracking_sweep(name=name, checkpoint=tmp_path / "c", shard_size=7))
    loaded = tracking_sweep(name=name, checkpoint=tmp_path / "c", shard_size=7)  # every shard from the checkpoint
    same(one, loaded)
    assert loaded.kernel == "planar-lanes"


@pytest.mark.parametrize("name", TRACKERS)
@pytest.mark.parametrize("index", [0, 17, 31])
def test_tracking_sample_rerun_alone_is_bitwise_the_same(name, index):
    r = tracking_sweep(name=name)
    alone = r.rerun(index)
    for k in ("valid",) + r.metric_names:
        assert np.array_equal(alone[k], r.metrics[k][index], equal_nan=True), k


@pytest.mark.parametrize("name", TRACKERS)
def test_tracking_sample_17_replayed_alone_agrees_to_rounding(name):
    """The full runner against the lane kernel, whose multiply-adds are fused: the metrics
    agree to rounding (the bound leaves over 1000x above the worst measured, printed:
    1.2e-16 PID, 7.4e-16 sliding mode). The general runner's replay, bit for bit, is
    tested with the frictional tracker below."""
    r = tracking_sweep(name=name)
    alone = r.replay(17)
    # The names of twip.simulate's metrics on a PlanarModel (NaN alike: a sample that fell
    # before the settle time has no settled metrics).
    worst = max(abs(alone.metrics[k] - r.metrics[k][17]) / abs(r.metrics[k][17]) for k in TRACK_METRICS
                if np.isfinite(r.metrics[k][17]) and r.metrics[k][17] != 0)
    print(f"{name} sample 17: worst relative difference {worst:.1e}")
    for k in TRACK_METRICS:
        np.testing.assert_allclose(alone.metrics[k], r.metrics[k][17], rtol=1e-12, atol=1e-15, err_msg=k)
    assert alone.fell == bool(r.metrics["fell"][17])
    assert alone.steps == int(round(r.metrics["t_end"][17] / 1e-3))
    params, slope, x0 = r.sample(17)
    assert slope is None and len(x0) == 7 and x0[1] != 0.0
    assert params.m_body != twip.RobotParams.balanbot().m_body


def test_a_tracker_whose_own_model_has_friction_takes_the_general_planar_runner():
    """Without adaptation the sliding-mode tracker takes its equivalent control from its own
    model; one with gearhead friction is not what the lanes evaluate: the general runner,
    deterministic and bit for bit the same replayed."""
    sc = scenarios.get("circle-smc", laps=0.2)
    own = twip.PlanarModel(sc.model.params, twip.Friction.gb37())
    sc = sc.replace(controller=twip.SmcTracker(own))
    one, two = (tracking_sweep(n=16, name=sc, options=None, threads=t) for t in (1, 2))
    same(one, two)
    assert one.kernel == "planar" == twip.sweep.kernel_for(sc)
    alone = one.replay(5)
    for k in TRACK_METRICS:
        np.testing.assert_equal(alone.metrics[k], one.metrics[k][5], err_msg=k)


def test_tracking_checkpoint_resumed_after_an_interrupt_equals_the_uninterrupted(tmp_path, monkeypatch):
    # A lap of circle-pid is 36 000 steps: a shard of 8 outlasts the watcher's 25 ms poll,
    # so the progress callback runs during the second shard and stops it as Ctrl-C would.
    kw = dict(name="circle-pid", options={"laps": 1}, checkpoint=tmp_path / "ck", shard_size=8)

    def interrupt_in_the_second_shard(bar, done):
        if bar.base > 0:
            raise KeyboardInterrupt

    with monkeypatch.context() as m:
        m.setattr(twip.sweep.ProgressBar, "update_to", interrupt_in_the_second_shard)
        with pytest.raises(KeyboardInterrupt) as stopped:
            tracking_sweep(progress=True, **kw)
    assert 8 <= stopped.value.partial.n < 32
    assert len(list((tmp_path / "ck").glob("shard-*.npz"))) == 1
    resumed = tracking_sweep(**kw)
    assert len(list((tmp_path / "ck").glob("shard-*.npz"))) == 4
    same(resumed, tracking_sweep(name="circle-pid", options={"laps": 1}))


def test_tracking_robots_that_certainly_fall_have_fall_rate_one():
    r = tracking_sweep(perturb={"phi0": twip.Uniform(low=1.1, high=1.3)})
    assert r.fall_rate == 1.0
    assert np.all(r.metrics["t_end"] < 0.1)


def test_tracking_summary_pandas_and_invalid_draws():
    r = tracking_sweep(perturb={"m_body": twip.Normal(mean=0.0, std=0.5), "x0": twip.Uniform(abs=0.02)})
    assert 0 < np.sum(~r.valid) < 32
    assert np.all(np.isnan(r.metrics["mean_abs_x_error"][~r.valid]))
    s = r.summary()
    assert s["invalid"] == int(np.sum(~r.valid)) and set(TRACK_METRICS) <= set(s)
    assert "mean_abs_pitch_error" not in s and "max_path_error_settled" in repr(r)
    assert r.steps == int(np.sum(np.rint(r.metrics["t_end"][r.valid] / 1e-3)))
    pytest.importorskip("pandas")
    units = {"mean_abs_pitch": "rad", "peak_abs_torque": "N m", "peak_current": "A", "peak_torque": "N m",
             "peak_command": "A", "saturation_share": None, "lifted": None, "off_terrain": None}
    assert list(r.to_pandas().columns) == ["index", "valid", "m_body[kg]", "x0[m]", "fell", "t_end[s]",
                                           *(k if units.get(k, "m") is None else f"{k}[{units.get(k, 'm')}]"
                                             for k in TRACK_COLUMNS)]


@pytest.mark.parametrize(
    "perturb,message",
    [
        ({"slope": twip.Uniform(low=0.0, high=0.1)}, "perturbation 'slope'.*3-DOF.*flat ground"),
        ({"theta0": twip.Uniform(abs=0.1)}, "unknown perturbation 'theta0'.*omega0"),
        ({"x0[7]": twip.Uniform(abs=0.1)}, r"unknown perturbation 'x0\[7\]'"),
    ],
)
def test_tracking_perturbations_the_planar_model_does_not_have_are_refused(perturb, message):
    with pytest.raises(twip.InvalidParameterError, match=message):
        tracking_sweep(n=4, perturb=perturb)


def test_the_core_refuses_a_slope_perturbation_of_a_planar_sweep_by_name():
    sc = scenarios.get("circle-pid", laps=0.1)
    with pytest.raises(twip.InvalidParameterError, match="slope = 0.1: .*3-DOF"):
        twip._core.sweep_planar_raw(sc.model, sc.controller, sc.x0, sc.t_final, sc.dt, sc.reference,
                                    [("slope", 0, "uniform", 0.0, 0.1, 0.0, 0.1)], 0, 0, 2)


# ============================================================================ traces of a few samples


def test_traces_keep_decimated_trajectories_of_the_samples_asked_for():
    r = sweep(n=32, traces=[3, 17], trace_every=50)
    assert sorted(r.traces) == [3, 17]
    for i, trace in r.traces.items():
        assert not r.metrics["fell"][i]
        assert len(trace.t) == 3000 // 50 + 1 and trace.t[1] == pytest.approx(0.05)  # 3 s, every 50 ms
        assert trace.metrics["mean_abs_pitch_error"] == pytest.approx(r.metrics["mean_abs_pitch_error"][i], rel=1e-9)
    assert sweep(n=32).traces == {}


@pytest.mark.parametrize("traces, trace_every, message", [
    ([32], 10, "sample index 32 is not in 0..31"),
    ([-1], 10, "sample index -1"),
    (["a"], 10, "sample index 'a'"),
    ([0], 0, "trace_every = 0"),
])
def test_bad_traces_are_named(traces, trace_every, message):
    with pytest.raises(twip.InvalidParameterError, match=message):
        sweep(n=32, traces=traces, trace_every=trace_every)


def test_a_sweep_keeps_a_few_trajectories_not_all():
    with pytest.raises(twip.InvalidParameterError, match="101 samples; a sweep keeps at most 100"):
        sweep(n=200, traces=range(101))


def test_kernel_copy_is_the_widest_the_cpu_flags_allow():
    """`twip.kernel_copy()` names the lane kernels' copy this CPU runs, as its own flags
    (/proc/cpuinfo on Linux) say it should be."""
    import platform
    from pathlib import Path

    copy = twip.kernel_copy()
    if platform.machine() not in ("x86_64", "AMD64"):
        assert copy == "baseline"
        return
    cpuinfo = Path("/proc/cpuinfo")
    if not cpuinfo.exists():
        pytest.skip("no /proc/cpuinfo to read the CPU's flags from")
    flags = next((set(line.split(":", 1)[1].split()) for line in cpuinfo.read_text().splitlines()
                  if line.startswith("flags")), set())
    want = "avx512" if {"avx512f", "fma"} <= flags else "avx2" if {"avx2", "fma"} <= flags else "baseline"
    assert copy == want, (copy, sorted(f for f in flags if f.startswith(("avx", "fma"))))


def test_a_dask_worker_refuses_a_sweep_it_does_not_rebuild_the_same():
    """A worker of another twip version, or whose scenario came out otherwise, ran its own
    numbers into the client's sweep without a word (the config was only read, never checked)."""
    import twip.sweep as tsweep

    r = rig_sweep(n=16)
    config = json.loads(json.dumps(r.config))  # as it crosses to a worker
    raw = tsweep.run_shard_by_name(config, 4, 8, 1)  # the same sweep: its bits
    np.testing.assert_array_equal(raw["t_end"], r.metrics["t_end"][4:12])
    for key, other in (("twip", "0.0.1"), ("controller", "another design"), ("t_final", 9.0)):
        with pytest.raises(twip.InvalidParameterError, match=rf"sweep worker on .* rebuilt another sweep than the "
                                                             rf"client's .*: they differ in {key}; run the same twip"):
            tsweep.run_shard_by_name({**config, key: other}, 4, 8, 1)
