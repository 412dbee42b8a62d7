"""Drive figures that are what the motor saw (issue 61, item 3): `peak_current` after the
driver's clamp, `peak_command` beside it, and the share of control periods whose command
was beyond the driver, per run and per sweep."""
import numpy as np
import pytest

import twip

ASKED = 3.56  # [A per motor]: what the user's controller asked of a 3 A driver
#: The thesis-like gearbox's efficiency: the wheel gets EFFICIENCY of the winding's torque, so
#: the model's lumped current for ASKED amperes in each winding is 2 ASKED EFFICIENCY.
EFFICIENCY = twip.MotorDriver.thesis_like().efficiency


class Constant:
    """A controller that asks ASKED amperes of each motor's winding through the thesis-like
    gearbox (a lumped current of 2 ASKED EFFICIENCY)."""
    period = 0.005

    def update(self, t, y, ref):
        return 2 * ASKED * EFFICIENCY


def three_amp_rig():
    return twip.Realism.thesis_like().replace(motor=twip.MotorDriver.thesis_like().replace(current_limit=3.0))


def run(realism=None):
    plant = twip.SlopeModel(twip.RobotParams.balanbot())
    return twip.simulate(plant, Constant(), [0.0, 0, 0, 0], 0.3, fall_limit=100.0, realism=realism)


def test_a_3_amp_driver_asked_for_3_56_amps_reports_what_the_motor_carried():
    r = run(three_amp_rig())
    assert r.outcome == "completed"
    m = r.metrics
    assert m["peak_command"] == pytest.approx(ASKED, rel=1e-12)
    # The winding's current, clamped at the limit (not 0.87 of it, what the wheel's torque
    # reads as through a lossless gearbox).
    assert EFFICIENCY < 1 and m["peak_current"] == pytest.approx(3.0, rel=1e-9)
    assert m["peak_current"] == pytest.approx(float(np.max(np.abs(r.signals["motor_current"]))) / 2 / EFFICIENCY,
                                              rel=1e-9)
    # Every period but the first (the one-period delay applies 0 A) asked beyond the driver.
    periods = round(0.3 / 0.005)
    assert m["saturation_share"] == pytest.approx((periods - 1) / periods, rel=1e-12)
    assert any("3.56 A" in w and "3 A limit" in w and "saturated" in w for w in r.warnings), r.warnings


def test_the_ideal_loop_delivers_every_command():
    m = run().metrics
    # No driver, no gearbox loss: each motor carries half the lumped current.
    assert m["peak_current"] == m["peak_command"] == pytest.approx(ASKED * EFFICIENCY, rel=1e-12)
    assert m["saturation_share"] == 0.0


def test_a_sweep_keeps_them_per_sample_and_in_its_summary():
    sc = twip.scenarios.get("flat-lqr-sim")
    # 0.8 A of winding current: through the 0.87 gearbox about what 0.7 A was through a lossless
    # one, where no robot of these fell and some asked more.
    limit = 0.8
    rig = twip.Realism.thesis_like().replace(motor=twip.MotorDriver.thesis_like().replace(current_limit=limit))
    s = twip.montecarlo(sc, 16, perturb={"phi0": twip.Uniform(low=0.1, high=0.2)}, realism=rig, progress=False, seed=3)
    assert {"peak_current", "peak_command", "saturation_share"} <= set(s.metric_names)
    m = s.metrics
    assert np.all(s.valid) and not np.any(m["fell"]) and np.all(m["peak_current"] <= limit * (1 + 1e-12))
    # A sample that asked more current than the driver gives saturated in some period.
    asked = m["peak_command"] > limit
    assert 0 < np.sum(asked) < s.n
    assert np.all(m["saturation_share"][asked] > 0)
    summary = s.summary()["saturation_share"]
    assert summary["median"] == pytest.approx(np.median(m["saturation_share"])) and summary["q95"] > 0
    for i in (0, 5):
        again = s.rerun(i)
        for name in ("peak_current", "peak_command", "saturation_share"):
            assert np.array_equal(again[name], m[name][i], equal_nan=True), name
