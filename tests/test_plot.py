"""twip.plot and twip.animate: every figure type is drawn and written, and the helpers keep
what a reader needs (spikes survive thinning, frames follow the requested rate)."""
import math

import numpy as np
import pytest

pytest.importorskip("matplotlib")
PIL = pytest.importorskip("PIL")

import twip  # noqa: E402
from twip import animate, plot, scenarios  # noqa: E402

plot.use_agg()


@pytest.fixture(scope="module")
def slope_run():
    sc = scenarios.get("slope-fuzzy", hold=1.0, settle=1.0)
    return sc, sc.run()


@pytest.fixture(scope="module")
def circle_run():
    sc = scenarios.get("circle-smc-fuzzy", laps=2)
    return sc, sc.run(record_every=20)


def is_png(path):
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_thinning_keeps_extremes_in_time_order():
    t = np.linspace(0.0, 10.0, 200_001)
    y = np.sin(3 * t)
    y[123_457] = 50.0  # a one-sample spike
    tt, yy = plot._thin(t, y)
    assert len(tt) <= 3100
    assert np.all(np.diff(tt) >= 0)
    assert yy.max() == 50.0 and yy.min() == pytest.approx(y.min())
    short_t, short_y = plot._thin(t[:100], y[:100])
    assert len(short_t) == 100


def test_timeseries_and_tracking_figures(tmp_path, slope_run, circle_run):
    sc, r = slope_run
    fig = plot.result(r, scenario=sc, path=tmp_path / "slope.png")
    assert is_png(tmp_path / "slope.png")
    titles = [a.get_title() for a in fig.axes]
    assert "Body pitch" in titles and any("Fuzzy weights" in t for t in titles)
    pitch = fig.axes[0]
    assert pitch.get_ylabel() == "pitch [deg]"
    assert max(np.max(line.get_ydata()) for line in pitch.get_lines()) > 5  # degrees, not radians
    sc, r = circle_run
    fig = plot.result(r, scenario=sc, path=tmp_path / "circle.png")
    assert is_png(tmp_path / "circle.png")
    assert any(a.get_title() == "Sliding surfaces" for a in fig.axes)
    plot.paths({"nominal": r}, trajectory=sc.reference, path=tmp_path / "paths.png")
    assert is_png(tmp_path / "paths.png")


def test_sweep_histograms_and_fall_maps(tmp_path):
    res = twip.montecarlo("slope-lqr-sim", 200, perturb={"phi0": twip.Uniform(low=-1.0, high=1.0),
                                                        "phi_dot0": twip.Uniform(low=-20.0, high=20.0)},
                          seed=5, progress=False, options={"t_final": 2.0})
    assert 0 < res.fall_rate < 1
    plot.sweep(res, path=tmp_path / "hist.png")
    assert is_png(tmp_path / "hist.png")
    phi0 = plot.perturbed_values(res, "phi0")
    assert phi0.min() >= -1.0 and phi0.max() <= 1.0 and len(phi0) == 200
    # A state named by its index, as --perturb x0[0]=... does: the same values and axis.
    np.testing.assert_array_equal(plot.perturbed_values(res, "x0[0]"), phi0)
    ax = plot.fall_map(res, "x0[0]", "phi_dot0", bins=(6, 6), path=tmp_path / "map.png").axes[0]
    assert "initial pitch" in ax.get_xlabel() and is_png(tmp_path / "map.png")
    fig = plot.fall_maps([res, res], "phi0", "phi_dot0", bins=(6, 6), path=tmp_path / "maps.png")
    assert is_png(tmp_path / "maps.png")
    assert "initial pitch" in fig.axes[0].get_xlabel() and "[deg]" in fig.axes[0].get_xlabel()


def test_comparison_figures(tmp_path):
    rows51 = [{"surface": s, "case": c, "controller": k, "outcome": "completed", "pitch_error_deg": 0.1 + i,
               "speed_error_deg_s": 10.0 + i, "stop_far_cm": 0.0, "stop_home_cm": 0.0}
              for i, (s, c, k) in enumerate((s, c, k) for s in ("flat", "slope") for c in ("nominal", "all +20 %")
                                            for k in ("lqr", "fuzzy"))]
    plot.table_5_1(rows51, thesis={("flat", "lqr"): (3.2, 25.5)}, path=tmp_path / "t51.png")
    rows52 = [{"controller": k, "plant": p, "outcome": "completed", "x": 0.01 * (i + 1), "y": 0.02}
              for i, (k, p) in enumerate((k, p) for k in ("circle-pid", "circle-smc") for p in ("nominal", "+20%"))]
    plot.table_5_2(rows52, thesis={"pid": (0.072, 0.076), "smc": (0.027, 0.03)}, path=tmp_path / "t52.png")
    assert is_png(tmp_path / "t51.png") and is_png(tmp_path / "t52.png")


def test_gif_of_a_slope_run(tmp_path, slope_run):
    sc, r = slope_run
    info = animate.gif(r, tmp_path / "slope.gif", scenario=sc, fps=20, speed=2.0)
    duration = r.t[-1] - r.t[0]
    assert info["frames"] == pytest.approx(duration * 20 / 2.0, abs=1.5)
    with PIL.Image.open(tmp_path / "slope.gif") as im:
        assert im.n_frames == info["frames"]
        assert im.info["duration"] == 50
        assert im.size == (560, 340)


def test_gif_of_a_tracking_run_is_sped_up_to_fit(tmp_path, circle_run):
    sc, r = circle_run
    info = animate.gif(r, tmp_path / "circle.gif", scenario=sc, max_seconds=6.0)
    assert info["speed"] >= (r.t[-1] - r.t[0]) / 6.0
    assert info["seconds"] <= 6.5
    assert (tmp_path / "circle.gif").stat().st_size < 2_000_000


def test_gif_rejects_a_bad_speed(tmp_path, slope_run):
    sc, r = slope_run
    with pytest.raises(ValueError, match="speed"):
        animate.gif(r, tmp_path / "x.gif", scenario=sc, speed=-1.0)
    assert math.isfinite(animate._speed(100.0, None, 15.0))


def test_pid_error_panel_shows_the_errors_in_cm_per_s_and_degrees():
    """The PID's own e_v (counts per 5 ms) and e_psi (degrees) must not be read as SI: the
    panel draws v_r - v in cm/s and psi_r - psi in degrees from the states."""
    sc = scenarios.get("circle-pid", laps=1)
    r = sc.run(record_every=5)
    fig = plot.tracking(r, scenario=sc)
    panel = next(ax for ax in fig.axes if ax.get_title() == "PID errors: speed and heading")
    lines = {line.get_label(): line.get_ydata() for line in panel.get_lines()}
    speed = next(v for k, v in lines.items() if "v_r" in k)
    heading = next(v for k, v in lines.items() if "psi" in k)
    # Drawn thinned (extremes kept): the peaks are the raw data's.
    expected_speed = 100 * (r.reference("v") - r.states[:, 5])
    expected_heading = np.degrees(r.reference("psi") - r.states[:, 2])
    assert np.max(np.abs(speed)) == pytest.approx(np.max(np.abs(expected_speed)))
    assert np.max(np.abs(heading)) == pytest.approx(np.max(np.abs(expected_heading)))
    # The thesis-scale numbers: a peak of about 13 cm/s when it sets off, under a degree of heading.
    assert 5 < np.max(np.abs(speed)) < 30
    assert np.max(np.abs(heading)) < 2.0


def test_report_figures_in_vector_formats_and_a_chosen_resolution(tmp_path):
    from twip.report.reproduce import Figures, reproduce

    figures = Figures(tmp_path, "svg")
    figures.add("fig4.2_slope-lqr-sim.png", "caption", lambda p: None)
    figures.add("anim_slope-lqr.gif", "an animation stays a GIF", lambda p: None)
    assert list(figures.captions) == ["fig4.2_slope-lqr-sim.svg", "anim_slope-lqr.gif"]
    with pytest.raises(twip.InvalidParameterError, match="fmt = 'bmp'"):
        reproduce(tmp_path, quick=True, fmt="bmp", quiet=True)
    with pytest.raises(twip.InvalidParameterError, match="dpi = 5"):
        reproduce(tmp_path, quick=True, dpi=5, quiet=True)
    sc = scenarios.get("slope-lqr-sim", t_final=2.0)
    fig = plot.timeseries(sc.run(), scenario=sc, path=tmp_path / "f.svg")
    assert (tmp_path / "f.svg").read_text().lstrip().startswith("<?xml")
    # The thesis's own values are drawn to read ours against.
    labels = [line.get_label() for ax in fig.axes for line in ax.get_lines()]
    assert any("thesis" in label and "12.5" in label for label in labels)
    assert any("settled by 5" in label for label in labels)
