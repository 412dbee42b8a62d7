"""Bad input to the command line, the figures, the animations and a sweep's options: a
clear error naming the option or parameter and the value, before any work (never a
traceback, a hang, a huge allocation or a result thrown away at the end)."""
import concurrent.futures
import math

import numpy as np
import pytest

pytest.importorskip("matplotlib")
pytest.importorskip("PIL")

import twip  # noqa: E402
from twip import animate, budget, cli, plot, scenarios  # noqa: E402
from twip.cli import args as cli_args  # noqa: E402


def run(args, capsys):
    """cli.main in-process: (exit code, stderr)."""
    try:
        code = cli.main([str(a) for a in args])
    except SystemExit as e:
        code = e.code
    return code, capsys.readouterr().err


def no_work(*args, **kw):
    raise AssertionError("the work ran before the input was checked")


@pytest.fixture(scope="module")
def sweep_result():
    sc = scenarios.get("slope-lqr-sim", t_final=0.2)
    return twip.montecarlo(sc, 4, perturb={"m_body": twip.Uniform(rel=0.1), "phi0": twip.Uniform(low=-0.1, high=0.1)},
                           progress=False, threads=1)


@pytest.fixture(scope="module")
def short_run():
    return scenarios.get("slope-lqr-sim", t_final=0.1).run()


# 1. --option nan, and the factories that take t_final


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e400"])
def test_option_refuses_a_number_that_is_not_finite(value, capsys):
    code, err = run(["sweep", "slope-lqr-sim", "-n", 4, "--quiet", "--option", f"t_final={value}"], capsys)
    assert code == 2 and f"--option t_final: '{value}' is not a finite number" in err
    assert "Traceback" not in err


@pytest.mark.parametrize("name", ["slope-lqr-sim", "flat-lqr-sim", "slope-fuzzy-sim", "flat-fuzzy-sim"])
def test_scenarios_check_t_final(name):
    with pytest.raises(twip.InvalidParameterError, match=r"t_final must be finite and > 0, got nan"):
        scenarios.get(name, t_final=math.nan)
    with pytest.raises(TypeError, match=r"t_final must be a real number, got 'nan'"):
        scenarios.get(name, t_final="nan")


# 2. outputs and sizes checked before a search


def test_tune_checks_out_before_the_search(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(twip, "tune", no_work)
    code, err = run(["tune", "slope-lqr", "--perturb", "m_body=±5%", "--quiet", "--out", tmp_path / "no" / "x.toml"],
                    capsys)
    assert code == 2 and "--out" in err and "does not exist" in err


def test_worst_case_checks_confirm_before_the_search(capsys, monkeypatch):
    monkeypatch.setattr(twip, "worst_case", no_work)
    code, err = run(["worst-case", "slope-lqr", "--perturb", "m_body=±5%", "--confirm", 10**12], capsys)
    assert code == 2 and "--confirm 1,000,000,000,000" in err and "memory budget" in err


# 3. an output path that is a folder


def test_an_output_path_that_is_a_folder_is_refused_before_the_work(tmp_path, capsys, monkeypatch, short_run):
    folder = tmp_path / "d.gif"
    folder.mkdir()
    with pytest.raises(twip.InvalidParameterError, match="d.gif'?: is a folder"):
        plot.check_folder(folder)
    with pytest.raises(twip.InvalidParameterError, match="is a folder"):
        animate.gif(short_run, folder)
    monkeypatch.setattr(twip, "montecarlo", no_work)
    code, err = run(["sweep", "slope-lqr-sim", "-n", 4, "--quiet", "--csv", folder], capsys)
    assert code == 2 and "--csv" in err and "is a folder" in err
    for option in ("--plot", "--animate"):
        code, err = run(["simulate", "slope-lqr-sim", "--t-final", "0.1", option, folder], capsys)
        assert code == 2 and option in err and "is a folder" in err


# 4. animation: fps a GIF cannot hold, a speed whose frame count overflows


def test_animation_refuses_fps_below_a_gif_frame_delay(tmp_path):
    with pytest.raises(twip.InvalidParameterError, match=r"fps = 0.001: must be a number in \[0.001526, 100\]"):
        animate.check_options(tmp_path / "a.gif", fps=0.001)
    animate.check_options(tmp_path / "a.gif", fps=animate.MIN_FPS)


def test_animation_names_a_speed_too_small_to_count_frames(tmp_path, short_run):
    with pytest.raises(twip.InvalidParameterError, match=r"speed = 5e-324: too slow"):
        animate.gif(short_run, tmp_path / "a.gif", speed=5e-324)


# 5, 6. figure bins and metrics


@pytest.mark.parametrize("bins", [0, 10**6, 10**9, 2.5, True, "auto"])
def test_sweep_figure_bounds_bins(bins, sweep_result):
    with pytest.raises(twip.InvalidParameterError, match=rf"bins = {bins!r}: must be an integer from 1 to 1000"):
        plot.sweep(sweep_result, bins=bins)


@pytest.mark.parametrize("bins", [(10**5, 10**5), (0, 4), 10**5, (4,), (4, 4, 4)])
def test_fall_maps_bound_bins(bins, sweep_result):
    for draw in (lambda: plot.fall_map(sweep_result, "m_body", "phi0", bins=bins),
                 lambda: plot.fall_maps([sweep_result], "m_body", "phi0", bins=bins)):
        with pytest.raises(twip.InvalidParameterError, match=r"bins = .*: must be an integer from 1 to 1000 or a pair"):
            draw()


@pytest.mark.parametrize("metrics", [["nope"], "fell", [], [3]])
def test_sweep_figure_checks_metrics(metrics, sweep_result):
    with pytest.raises(twip.InvalidParameterError, match=r"metrics = .*: must be a list of one or more of .*"
                                                         r"mean_abs_pitch_error"):
        plot.sweep(sweep_result, metrics=metrics)


def test_fall_maps_needs_a_sweep():
    with pytest.raises(twip.InvalidParameterError, match=r"results = \[\]: give one or more sweeps"):
        plot.fall_maps([], "m_body", "phi0")


# 7. --perturb units


@pytest.mark.parametrize("spec", ["m_body=±5%deg", "m_body=~5deg%", "m_body=~5%deg"])
def test_perturb_refuses_percent_with_degrees(spec):
    with pytest.raises(cli_args.UsageError, match=r"a % is a share of the nominal, it takes no 'deg'"):
        cli_args.perturbation(spec)


def test_perturb_refuses_degrees_on_the_low_end_only():
    with pytest.raises(cli_args.UsageError, match=r"'deg' on the low end only; write low:highdeg"):
        cli_args.perturbation("phi0=1deg:2")
    # a trailing deg is both ends' unit, also when both ends say it
    for spec in ("phi0=1:2deg", "phi0=1deg:2deg"):
        _, dist = cli_args.perturbation(spec)
        assert (dist.low, dist.high) == pytest.approx((math.radians(1), math.radians(2)))


# 8. montecarlo's client and on_error


def test_montecarlo_client_must_be_a_dask_client():
    with concurrent.futures.ThreadPoolExecutor(1) as pool, \
            pytest.raises(TypeError, match=r"client must be a dask.distributed.Client, got .*ThreadPoolExecutor"):
        twip.montecarlo("slope-lqr-sim", 4, client=pool, progress=False, options={"t_final": 0.1})


@pytest.mark.parametrize("on_error", [np.array(["stop", "x"]), ["stop"], None])
def test_montecarlo_on_error_must_be_a_name(on_error):
    with pytest.raises(twip.InvalidParameterError, match=r"on_error = .*: must be one of 'stop', 'record'"):
        twip.montecarlo("slope-lqr-sim", 4, on_error=on_error, progress=False, options={"t_final": 0.1})


# 9. a shard over the budget, from the command line (no shard_size there)


def test_sweep_shard_over_the_budget_names_no_api_only_option(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(budget, "_budget", 10**6)
    code, err = run(["sweep", "slope-lqr-sim", "-n", 10**8, "--quiet", "--checkpoint", tmp_path / "ck"], capsys)
    assert code == 2 and "memory budget" in err and "sweep fewer samples" in err
    assert "shard_size" not in err
    with pytest.raises(budget.MemoryBudgetError, match="pass a smaller shard_size"):  # the API's own option
        twip.montecarlo("slope-lqr-sim", 10**6, shard_size=10**5, checkpoint=tmp_path / "ck2", progress=False)


# 10. TWIP_MEMORY_BUDGET


@pytest.mark.parametrize("value", ["inf", "nan", "-1", "1e400", "-inf"])
def test_memory_budget_variable_must_be_a_positive_number(value, monkeypatch):
    monkeypatch.setattr(budget, "_budget", None)
    monkeypatch.setenv(budget.ENV, value)
    with pytest.raises(twip.InvalidParameterError, match=rf"TWIP_MEMORY_BUDGET = '{value}': must be a positive"):
        budget.memory_budget()
