"""twip.simulate and SimResult on input that broke them: named errors, not raw ones."""
import pytest

import twip


def test_a_figure_eight_too_fast_to_sample_is_refused_by_its_period():
    """A figure eight of period 1e-200 sampled inf and NaN from the start: the 3-DOF run
    diverged before its first log row and simulate failed reading that row (an IndexError)."""
    for period in (1e-200, 1e-60):  # 1e-60 passed the first form of this check: omega_dot inf
        with pytest.raises(twip.InvalidParameterError, match=rf"invalid period = {period:g}: with half_width gives a reference beyond"):
            twip.FigureEight(1.0, period)
    sc = twip.scenarios.get("circle-pid")
    r = twip.simulate(sc.model, sc.controller, sc.x0, 1.0, reference=twip.FigureEight(1.0, 1e-20))
    assert r.fell and len(r.t) > 0


def test_an_unknown_reference_name_is_named_with_the_runs_names():
    r = twip.scenarios.get("circle-pid", laps=0.05).run()
    with pytest.raises(twip.InvalidParameterError, match=r"reference: unknown name 'nope'; this run's are x, y, psi"):
        r.reference("nope")
    assert r.reference("x").shape == r.t.shape
