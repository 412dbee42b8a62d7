"""Peak motor current and wheel torque in every run's metrics and in sweeps; warnings
when a run asks more than the stall current; sweep tables with drawn values and units."""
from __future__ import annotations

import math

import numpy as np
import pytest

import twip
from twip import scenarios
from twip.cli import main


def test_2dof_peaks_are_the_lumped_current_shared_by_two_motors():
    sc = scenarios.get("flat-lqr")
    r = sc.run()
    p = sc.model.params
    peak_u = np.max(np.abs(r.inputs[:, 0]))
    assert r.metrics["peak_abs_input"] == pytest.approx(peak_u, rel=1e-12)
    assert r.metrics["peak_current"] == pytest.approx(peak_u / 2, rel=1e-12)
    assert r.metrics["peak_torque"] == pytest.approx(p.gear_ratio * p.torque_constant * peak_u / 2, rel=1e-12)


def test_3dof_peaks_are_per_wheel():
    sc = scenarios.get("circle-pid", laps=1)
    r = sc.run()
    p = sc.model.params
    peak_tau = np.max(np.abs(r.inputs))
    assert r.metrics["peak_torque"] == pytest.approx(peak_tau, rel=1e-12)
    assert r.metrics["peak_current"] == pytest.approx(peak_tau / (p.gear_ratio * p.torque_constant), rel=1e-12)


def test_a_run_above_the_stall_current_carries_a_warning(capsys):
    sc = scenarios.get("flat-lqr")
    peak = sc.run().metrics["peak_current"]
    assert sc.run(stall_current=2 * peak).warnings == ()
    (warning,) = sc.run(stall_current=peak / 2).warnings
    assert "stall current" in warning and f"{peak:.3g} A" in warning
    with pytest.raises(twip.InvalidParameterError, match="stall_current"):
        sc.run(stall_current=-1.0)
    # The CLI holds the run against the robot file's motor.
    assert main(["simulate", "flat-lqr", "--option", "hold=1", "--option", "settle=1"]) == 0
    assert "warning" not in capsys.readouterr().err  # the Balanbot's 7 A stall current is far above


def test_sweeps_keep_the_peaks_and_count_samples_above_stall():
    perturb = {"m_body": twip.Uniform(rel=0.2), "phi0": twip.Normal(std=0.05)}
    for name in ("flat-lqr-sim", "flat-fuzzy-sim"):  # the LQR and fuzzy laws on lanes
        s = twip.montecarlo(name, 16, perturb=perturb, seed=2, progress=False, stall_current=0.2)
        rerun = s.replay(3)
        assert s.metrics["peak_current"][3] == pytest.approx(rerun.metrics["peak_current"], rel=1e-9)
        assert s.summary()["over_stall_current"] == int(np.sum(s.metrics["peak_current"] > 0.2))
    planar = twip.montecarlo("circle-pid", 2, perturb={"m_body": twip.Uniform(rel=0.2)}, progress=False,
                             options={"laps": 1})
    assert planar.metrics["peak_current"][0] == pytest.approx(planar.replay(0).metrics["peak_current"], rel=1e-12)


def test_counting_samples_over_a_stall_current_refuses_a_bad_one(tmp_path):
    """over_stall_current(NaN) counted 0 samples and (-1) all of them."""
    kw = dict(perturb={"m_body": twip.Uniform(rel=0.2)}, seed=2, progress=False, options={"t_final": 0.2})
    whole = twip.montecarlo("flat-lqr-sim", 4, **kw)
    twip.set_memory_budget(4 * twip.sweep.BYTES_PER_SAMPLE - 1)  # streamed from the checkpoint's shards
    try:
        streamed = twip.montecarlo("flat-lqr-sim", 4, checkpoint=tmp_path, shard_size=2, **kw)
    finally:
        twip.set_memory_budget(None)
    assert type(streamed).__name__ == "StreamedSweepResult"
    for s in (whole, streamed):
        assert s.over_stall_current(0.001) == 4
        for bad in (math.nan, math.inf, -1.0, 0.0):
            with pytest.raises(twip.InvalidParameterError, match="stall_current"):
                s.over_stall_current(bad)


def test_sweep_tables_carry_the_drawn_values_and_units(tmp_path):
    perturb = {"m_body": twip.Uniform(rel=0.2), "phi0": twip.Normal(std=0.05), "slope": twip.Uniform(low=0, high=0.1)}
    s = twip.montecarlo("flat-lqr-sim", 6, perturb=perturb, seed=4, progress=False)
    df = s.to_pandas()
    for column in ("m_body[kg]", "phi0[rad]", "slope[rad]", "mean_abs_pitch_error[rad]", "mean_abs_speed_error[rad/s]",
                   "final_position_error[m]", "peak_current[A]", "t_end[s]"):
        assert column in df.columns, column
    for i in range(6):
        params, slope, x0 = s.sample(i)
        assert df["m_body[kg]"][i] == params.m_body and df["slope[rad]"][i] == slope and df["phi0[rad]"][i] == x0[0]
    path = tmp_path / "s.csv"
    assert main(["sweep", "flat-lqr-sim", "-n", "4", "--perturb", "m_body=±20%", "--csv", str(path), "--quiet"]) == 0
    header = path.read_text().splitlines()[0].split(",")
    assert "m_body[kg]" in header and "mean_abs_pitch_error[rad]" in header
    assert not math.isnan(float(path.read_text().splitlines()[1].split(",")[header.index("m_body[kg]")]))
