"""twip.simulate and SimResult on input that broke them: named errors, not raw ones."""
import pytest

import twip


def test_a_run_that_diverged_before_its_first_log_row_is_a_result():
    """A reference that is NaN from the start (a figure eight of period 1e-200) ends the
    run at t = 0 with an empty log: its warnings take the end at 0, not the log's last row
    (an IndexError before)."""
    sc = twip.scenarios.get("circle-pid")
    r = twip.simulate(sc.model, sc.controller, sc.x0, 1.0, reference=twip.FigureEight(1.0, 1e-200))
    assert r.outcome == "diverged" and r.t_end == 0.0 and len(r.t) == 0


def test_an_unknown_reference_name_is_named_with_the_runs_names():
    r = twip.scenarios.get("circle-pid", laps=0.05).run()
    with pytest.raises(twip.InvalidParameterError, match=r"reference: unknown name 'nope'; this run's are x, y, psi"):
        r.reference("nope")
    assert r.reference("x").shape == r.t.shape
