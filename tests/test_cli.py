"""The `twip` command line: reproduce, simulate, sweep, list, and its errors.

`twip reproduce --quick` runs once per session (about 20-30 s on 2 cores); the other tests
call `twip.cli.main` in-process.
"""
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("matplotlib")
pytest.importorskip("PIL")

import twip  # noqa: E402
from twip import cli, scenarios  # noqa: E402
from twip.cli import args as cli_args  # noqa: E402

SKIPPED_KEYS = {"figure", "hold", "distance", "thesis_hold"}  # settings, not claims
#: Each basis and the status its rows get (a prediction's: reproduced or differs).
BASES = {"prediction": None, "calibrated": "calibrated", "partly calibrated": "calibrated", "input, deviated": "deviated",
         "duplicate": "duplicate"}


def twip_command():
    """The installed console script, else `python -m twip`."""
    script = Path(sys.executable).with_name("twip")
    return [str(script)] if script.exists() else [sys.executable, "-m", "twip"]


def run(args, capsys):
    """cli.main in-process: (exit code, stdout, stderr); argparse's exits included."""
    try:
        code = cli.main([str(a) for a in args])
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    proc = subprocess.run(twip_command() + ["reproduce", "--quick", "--out", str(out)], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    return out, proc.stdout


@pytest.fixture(scope="module")
def report(report_dir):
    return json.loads((report_dir[0] / "report.json").read_text())


def test_reproduce_writes_every_figure_and_both_reports(report_dir, report):
    out, stdout = report_dir
    assert (out / "report.md").stat().st_size > 1000
    for filename in report["figures"]:
        path = out / filename
        assert path.exists() and path.stat().st_size > 1000, filename
        head = path.read_bytes()[:8]
        assert head.startswith(b"\x89PNG") or head.startswith(b"GIF89a"), filename
    # one figure per thesis figure the scenarios name, and the comparisons
    names = set(report["figures"])
    for name, s in report["scenarios"].items():
        assert "error" not in s, (name, s)
        assert f"fig{s['figure']}_{name}.png" in names
    for fig in ("4.2", "4.7", "4.9", "4.11", "4.14", "4.16", "4.18"):
        assert any(n.startswith(f"fig{fig}_") for n in names), fig
    assert {"table5.1.png", "table5.2.png"} <= names
    assert any(n.startswith("sweep_") for n in names)
    # progress: one line per step with its time
    assert len(re.findall(r"\d+\.\d\d s\s+\(total", stdout)) >= len(report["steps"]) - 1


def test_the_terrain_rows_are_future_work_not_claims(report_dir, report):
    """Tracking on terrain: report.json's "future_work" rows (predictions of twip), not among
    the thesis's claims or scenarios, and their table in report.md."""
    rows = report["future_work"]
    assert rows and all(r["basis"].startswith("prediction of twip") for r in rows)
    assert not any(c["id"].startswith("future-work/") for c in report["claims"])
    assert not {"incline-circle", "figure-eight-bumps"} & set(report["scenarios"])
    assert "## Future work: tracking on terrain" in (report_dir[0] / "report.md").read_text()


def test_report_json_has_a_row_per_thesis_claim(report):
    ids = [c["id"] for c in report["claims"]]
    assert len(ids) == len(set(ids))
    expected = []
    for name in scenarios.names():
        expected += [f"{name}/{k}" for k in scenarios.get(name).thesis if k not in SKIPPED_KEYS]
    expected += [f"table-5.1/{c}-{s}/{what}" for c in ("lqr", "fuzzy") for s in ("flat", "slope")
                 for what in ("pitch", "speed")]
    expected += ["table-5.1/fuzzy-beats-lqr-flat", "table-5.1/fuzzy-beats-lqr-slope", "table-5.2/smc-beats-pid"]
    assert sorted(expected) == sorted(ids)
    for c in report["claims"]:
        assert c["basis"] in BASES, c
        assert c["status"] == BASES[c["basis"]] or (c["basis"] == "prediction" and c["status"] in ("reproduced", "differs")), c
        assert c["reason"] and "\n" not in c["reason"], c
        assert c["ours"] is not None, c


def test_table_5_1_rows_carry_the_thesis_like_robot(report):
    rows = [c for c in report["claims"] if c["id"].startswith("table-5.1/") and c["id"].count("/") == 2]
    assert len(rows) == 8
    for c in rows:
        assert c["realism"]["outcome"] == "completed" and c["realism"]["ours"] > 0, c


def test_experiment_rows_carry_the_thesis_like_robot(report):
    experiments = [c for c in report["claims"] if "/" in c["id"] and not c["id"].split("/")[0].endswith("-sim")
                   and not c["id"].startswith("table-")]
    assert {c["id"].split("/")[0] for c in experiments} == {"slope-lqr", "slope-fuzzy", "flat-lqr", "flat-fuzzy",
                                                           "circle-pid", "circle-smc", "circle-smc-fuzzy"}
    for c in experiments:
        real = c["realism"]
        assert (real["ours"] is not None) == (real["outcome"] == "completed"), c["id"]
    # The model-based sliding-mode tracker falls on the thesis-like robot (its gearheads' friction);
    # the rows say when, and the others complete.
    fell = {c["id"].split("/")[0] for c in experiments if c["realism"]["outcome"] == "fell"}
    assert fell == {"circle-smc"}, fell
    assert all(0 < c["realism"]["t_end"] < 36 for c in experiments if c["id"].startswith("circle-smc/"))
    assert not any("realism" in c for c in report["claims"] if c["id"].split("/")[0].endswith("-sim"))
    # Every such row, Tables 5.1 and 5.2 included, states the thesis-like robot's verdict, whichever it is.
    checked = experiments + [c for c in report["claims"] if c["id"].startswith("table-")]
    for c in checked:
        assert "holds" in c["realism"] and "thesis-like robot" in c["reason"], c["id"]
        if c["status"] == "reproduced" and not c["realism"]["holds"]:
            assert "ideal plant only" in c["reason"], c["id"]


def test_claims_on_unpublished_choices_carry_their_sensitivity(report, report_dir):
    by_id = {c["id"]: c for c in report["claims"]}
    for cid in ("table-5.1/lqr-flat/speed", "table-5.1/fuzzy-beats-lqr-slope", "slope-fuzzy-sim/pitch_settling_time",
                "table-5.2/smc-beats-pid"):
        s = by_id[cid]["sensitivity"]
        assert s["low"] <= s["high"] and 0 <= s["holds"] <= 1 and s["runs"] >= 2, (cid, s)
    # Table 5.2's conclusion is judged with the thesis's λ1 (4.74): sliding mode is then not better
    # than PID (ratio below 1); with twip's correction T8 it is, and the row says so.
    smc = by_id["table-5.2/smc-beats-pid"]
    assert smc["status"] == "differs" and smc["ours"] < 1.0 < 2.0 < smc["corrected"]["ours"]
    assert "T8" in smc["reason"] and "λ1" not in smc["sensitivity"]["choices"]
    md = (report_dir[0] / "report.md").read_text()
    section = md.split("## How much our numbers depend on what the thesis does not give")[1]
    for cid in ("table-5.1/lqr-flat/speed", "table-5.2/smc-beats-pid", "table-5.1/fuzzy-beats-lqr-flat"):
        line = next(l for l in section.splitlines() if l.startswith(f"| {cid} |"))
        assert _numbers(line.split(" | ")[2]) == _flat(by_id[cid]["sensitivity"]["low"])


def test_inputs_and_fits_are_calibrated_not_reproduced(report, report_dir):
    """The audit's seven: the fuzzy gains (inputs), the flat LQR gains and the slope phi_s (the
    robot is fitted to them), the 36 s lap (the wheel radius came from it), omega_r (the
    reference's own value); and the experiment's 0.1 m/s (the reference's own speed). The
    thesis's settings twip deviates from and the second sliding-mode row are not counted either."""
    calibrated = {c["id"] for c in report["claims"] if c["basis"] == "calibrated"}
    assert calibrated == {"flat-lqr-sim/gains", "slope-fuzzy-sim/gains", "flat-fuzzy-sim/gains",
                          "slope-lqr-sim/phi_s_deg", "circle-pid/lap_s", "circle-smc/omega_r",
                          "circle-smc-fuzzy/omega_r", "circle-smc-fuzzy/speed_about"}
    partly = {c["id"] for c in report["claims"] if c["basis"] == "partly calibrated"}
    assert partly == {"slope-lqr/pitch_about_deg", "slope-fuzzy-sim/pitch_settling_time", "table-5.1/fuzzy-flat/speed"}
    deviated = {c["id"] for c in report["claims"] if c["basis"] == "input, deviated"}
    assert deviated == {"slope-fuzzy-sim/phi_s_deg", "flat-lqr-sim/phi_s_deg", "flat-fuzzy-sim/phi_s_deg"}
    assert {c["id"] for c in report["claims"] if c["basis"] == "duplicate"} == {"circle-smc/table_5_2"}
    n = {s: sum(c["status"] == s for c in report["claims"]) for s in ("reproduced", "differs", "calibrated")}
    summary = report["summary"]
    assert (summary["predictions"], summary["reproduced"], summary["calibrated"]) == (
        sum(c["basis"] == "prediction" for c in report["claims"]), n["reproduced"], n["calibrated"])
    assert {"reproduced_with_rig", "deviated", "duplicate"} <= set(summary)
    first = (report_dir[0] / "report.md").read_text().splitlines()[0]
    assert "on the ideal plant" in first and "with the thesis-like robot" in first, first
    predictions = sum(c["basis"] == "prediction" for c in report["claims"])
    md = (report_dir[0] / "report.md").read_text()
    opening = (f"**{predictions} predictions: {n['reproduced']} reproduced, {n['differs']} differ; not counted: "
               f"{n['calibrated']} calibrated")
    assert opening in md.split("## ")[0]


def _numbers(cell):
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e[+-]?\d+)?", cell)]


def _flat(value):
    if isinstance(value, bool):
        return []
    if isinstance(value, (list, tuple)):
        return [v for x in value for v in _flat(x)]
    return [] if value is None else [float(value)]


def test_report_md_numbers_equal_report_json(report_dir, report):
    md = (report_dir[0] / "report.md").read_text()
    table = md.split("## How much our numbers depend")[0]  # the claims' table, before the sensitivity one
    rows = {line.split(" | ")[0][2:]: line for line in table.splitlines() if line.startswith("| ")}
    for c in report["claims"]:
        cells = [x.strip() for x in rows[c["id"]].strip("|").split(" | ")]
        assert cells[0] == c["id"]
        assert _numbers(cells[2]) == _flat(c["thesis"]), (c["id"], cells[2])
        assert _numbers(cells[3]) == _flat(c["ours"]), (c["id"], cells[3])
        if isinstance(c["ours"], bool):
            assert cells[3] == ("yes" if c["ours"] else "no")
        real = c.get("realism", {})
        assert _numbers(cells[4]) == (_flat(real.get("ours")) + _flat(real.get("t_end"))), (c["id"], cells[4])
        if real.get("outcome", "completed") != "completed":
            assert cells[4].startswith(real["outcome"]), (c["id"], cells[4])
        assert cells[6] == c["basis"] and cells[7] == c["status"]
    # Table 5.2: every row's numbers
    for r in report["table_5_2"]:
        line = next(l for l in md.splitlines() if l.startswith(f"| `{r['controller']}` | {r['plant']} |"))
        nums = _numbers(" ".join(line.split(" | ")[3:7]))
        assert nums == [r["x_cm"], r["y_cm"], r["x_settled_cm"], r["y_settled_cm"], r["path_settled_cm"], r["pitch_deg"]]
    # Table 5.1: the pitch and speed of every cell
    for r in report["table_5_1"]:
        assert f"{r['pitch_error_deg']:.3f}, {r['speed_error_deg_s']:.1f}; {r['stop_far_cm']:.1f} / " in md


def test_simulate_prints_metrics_and_writes_a_plot_and_an_animation(tmp_path, capsys):
    png, gif = tmp_path / "run.png", tmp_path / "run.gif"
    code, out, err = run(["simulate", "flat-lqr-sim", "--t-final", "3", "--plot", png, "--animate", gif], capsys)
    assert code == 0, err
    assert "outcome: completed" in out and "mean |φ − φ_s|" in out
    assert png.read_bytes()[:4] == b"\x89PNG" and gif.read_bytes()[:6] == b"GIF89a"


def test_simulate_shows_the_thesis_claims_and_json(capsys):
    code, out, _ = run(["simulate", "slope-lqr-sim"], capsys)
    assert code == 0 and "the thesis's claims" in out and "errata E6" in out
    code, out, _ = run(["simulate", "circle-smc", "--option", "laps=1", "--json"], capsys)
    data = json.loads(out)
    assert code == 0 and data["outcome"] == "completed" and "mean_abs_x_error" in data["metrics"]


def test_simulate_with_params_and_a_mismatched_controller(capsys):
    code, out, err = run(["simulate", "flat-lqr", "--param", "m_body=1.0", "--nominal-controller", "--option", "hold=1"],
                         capsys)
    assert code == 0, err
    assert "m_body=1.0" in out and "controller designed for balanbot()" in out


def test_sweep_summary_plot_and_csv(tmp_path, capsys):
    png, csv = tmp_path / "sweep.png", tmp_path / "sweep.csv"
    code, out, err = run(["sweep", "flat-lqr-sim", "-n", "40", "--perturb", "m_body=±20%", "--perturb", "phi0=-0.3:0.3",
                          "--option", "t_final=2", "--seed", "3", "--threads", "2", "--quiet", "--plot", png,
                          "--csv", csv], capsys)
    assert code == 0, err
    assert "fall rate" in out and "40 samples" in out and "median" in out
    assert png.exists() and (tmp_path / "sweep-fall-map.png").exists()
    assert len(csv.read_text().splitlines()) == 41


def test_a_csv_cut_short_by_a_full_disk_is_not_left_and_the_error_names_it(tmp_path, capsys, monkeypatch):
    """The CSV was written in place: a disk that filled mid-table left the rows so far under
    its name (measured: 23,351 of 30,001 lines, the last cut mid-row), the file that was there
    gone, and the error said "[Errno 28] No space left on device" without naming the file."""
    import errno

    import numpy as np

    csv = tmp_path / "sweep.csv"
    csv.write_text("an earlier table\n")
    savetxt = np.savetxt

    def disk_fills(f, rows, *args, **kwargs):  # the first rows fit, then the disk is full
        savetxt(f, rows[: len(rows) // 2], *args, **kwargs)
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savetxt", disk_fills)
    code, _, err = run(["sweep", "flat-lqr-sim", "-n", "48", "--perturb", "m_body=±20%", "--option", "t_final=0.5",
                        "--quiet", "--csv", csv], capsys)
    assert code == 1 and f"No space left on device: '{csv}'" in err, err
    assert csv.read_text() == "an earlier table\n"  # the file that was there, whole
    assert [p.name for p in tmp_path.iterdir()] == ["sweep.csv"]  # no part file left


def test_sweep_fall_map_of_states_named_by_index(tmp_path, capsys):
    """--perturb x0[0]=... names the initial pitch by its index; --map picks the map's axes."""
    png = tmp_path / "s.png"
    code, _, err = run(["sweep", "slope-lqr-sim", "-n", "8", "--perturb", "x0[0]=-0.3:0.3", "--perturb", "m_body=±10%",
                        "--perturb", "phi_dot0=-1:1", "--map", "x0[0], phi_dot0", "--option", "t_final=1", "--quiet",
                        "--plot", png], capsys)
    assert code == 0, err
    assert (tmp_path / "s-fall-map.png").read_bytes()[:4] == b"\x89PNG"


def test_sweep_of_a_tracking_scenario(capsys):
    code, out, err = run(["sweep", "circle-smc-fuzzy", "-n", "2", "--perturb", "m_body=±10%", "--option", "laps=2",
                          "--quiet"], capsys)
    assert code == 0, err
    assert "2 samples" in out and "after the first lap" in out


def test_sweep_realism_changes_the_result(capsys):
    """--realism thesis-like puts sensor noise, the motor driver and the delay in every
    sample's loop: the same robots give other metrics (and the rig's lane kernel)."""
    args = ["sweep", "flat-lqr-sim", "-n", "8", "--perturb", "m_body=±10%", "--option", "t_final=1", "--seed", "2",
            "--quiet", "--json"]
    code, ideal_out, err = run(args, capsys)
    assert code == 0, err
    code, real_out, err = run(args + ["--realism", "thesis-like"], capsys)
    assert code == 0, err
    ideal, real = json.loads(ideal_out), json.loads(real_out)
    assert (ideal["realism"], real["realism"]) == (None, "thesis-like")
    assert real["quantiles"]["mean_abs_pitch_error"] != ideal["quantiles"]["mean_abs_pitch_error"]
    code, out, err = run(args[:-1] + ["--realism", "thesis-like"], capsys)
    assert code == 0, err
    assert "realism: thesis-like" in out and "(realism-lanes)" in out


def test_sweep_realism_of_a_tracking_scenario_runs_the_3dof_rig(capsys):
    code, out, err = run(["sweep", "circle-pid", "-n", "2", "--perturb", "m_body=±10%", "--realism", "thesis-like",
                          "--option", "laps=1", "--quiet"], capsys)
    assert code == 0, err
    assert "realism: thesis-like" in out and "(planar-realism-lanes)" in out


def test_sweep_checkpoint_resumes(tmp_path, capsys):
    args = ["sweep", "flat-lqr-sim", "-n", "16", "--perturb", "m_body=~10%", "--option", "t_final=1",
            "--checkpoint", tmp_path / "ck", "--quiet", "--json"]
    code1, out1, _ = run(args, capsys)
    code2, out2, _ = run(args, capsys)
    assert code1 == code2 == 0
    assert json.loads(out1) == json.loads(out2)
    assert list((tmp_path / "ck").glob("shard-*.npz"))


def test_list_names_every_scenario(capsys):
    code, out, _ = run(["list"], capsys)
    assert code == 0
    assert all(name in out for name in scenarios.names())


@pytest.mark.parametrize("command", ["reproduce", "simulate", "sweep", "demo", "list"])
def test_help_has_examples(command, capsys):
    code, out, _ = run([command, "--help"], capsys)
    assert code == 0 and f"usage: twip {command}" in out
    if command in ("reproduce", "simulate", "sweep", "demo"):
        assert "example" in out


BAD = {
    "unknown scenario": ["simulate", "no-such-scenario"],
    "unknown scenario (sweep)": ["sweep", "no-such-scenario", "-n", "4"],
    "param without =": ["simulate", "flat-lqr", "--param", "m_body"],
    "param not a number": ["simulate", "flat-lqr", "--param", "m_body=heavy"],
    "unknown param": ["simulate", "flat-lqr", "--param", "mass=1"],
    "core rejects the value": ["simulate", "flat-lqr", "--param", "m_body=-1"],
    "unknown option": ["simulate", "flat-lqr", "--option", "speed=3"],
    "negative n": ["sweep", "flat-lqr", "-n", "-5"],
    "zero n": ["sweep", "flat-lqr", "-n", "0"],
    "n not a number": ["sweep", "flat-lqr", "-n", "many"],
    "unknown perturb name": ["sweep", "flat-lqr", "-n", "4", "--perturb", "mass=±20%"],
    "malformed perturb": ["sweep", "flat-lqr", "-n", "4", "--perturb", "m_body=20"],
    "negative perturb width": ["sweep", "flat-lqr", "-n", "4", "--perturb", "m_body=±-20%"],
    "3-DOF perturb of slope": ["sweep", "circle-pid", "-n", "2", "--perturb", "slope=0:0.1"],
    "unknown realism": ["sweep", "flat-lqr", "-n", "4", "--realism", "noisy"],
    "map of one name": ["sweep", "flat-lqr", "-n", "4", "--map", "phi0"],
    "map of three names": ["sweep", "flat-lqr", "-n", "4", "--map", "phi0,phi_dot0,m_body"],
    "map of an empty name": ["sweep", "flat-lqr", "-n", "4", "--map", "phi0,"],
    "map of an unperturbed name": ["sweep", "flat-lqr", "-n", "4", "--perturb", "phi0=-1:1", "--perturb",
                                   "m_body=±10%", "--map", "phi0,phi_dot0"],
    "no command": [],
    "unknown command": ["frobnicate"],
    "negative jobs": ["reproduce", "--jobs", "0"],
    # An empty --robot (an unset shell variable) ran the Balanbot, exit 0.
    "empty robot file": ["simulate", "flat-lqr", "--robot", ""],
    "blank robot file (sweep)": ["sweep", "flat-lqr", "-n", "4", "--robot", " "],
    "empty controller file": ["simulate", "flat-lqr", "--controller", ""],
    # An empty output path wrote nothing, exit 0 (or the report into the working directory).
    "empty csv": ["sweep", "flat-lqr", "-n", "4", "--csv", ""],
    "empty plot": ["simulate", "flat-lqr", "--plot", ""],
    "empty animation": ["simulate", "flat-lqr", "--animate", ""],
    "empty identify out": ["identify", "run.csv", "--free", "m_body", "--out", ""],
    "empty tune out": ["tune", "flat-lqr", "--perturb", "m_body=±10%", "--out", ""],
    "empty report folder": ["reproduce", "--out", ""],
}


@pytest.mark.parametrize("args", BAD.values(), ids=BAD.keys())
def test_bad_arguments_give_one_line_and_exit_code_2(args, capsys):
    code, out, err = run(args, capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("twip") and "error:" in lines[0]
    assert "Traceback" not in err


def test_robot_init_names_a_folder_that_does_not_exist(tmp_path, capsys):
    # Was "twip robot: error: [Errno 2] No such file or directory: ...", exit code 1.
    code, out, err = run(["robot", "init", tmp_path / "missing" / "r.toml"], capsys)
    assert code == 2
    assert err == (f"twip robot: error: FILE: output '{tmp_path / 'missing' / 'r.toml'}': the folder "
                   f"{tmp_path / 'missing'} does not exist\n")


def test_the_console_script_reports_bad_input_without_a_traceback():
    proc = subprocess.run(twip_command() + ["simulate", "flat-lqr", "--param", "m_body=oops"], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "Traceback" not in proc.stderr


def test_perturb_forms():
    assert cli_args.perturbation("m_body=±20%") == ("m_body", twip.Uniform(rel=0.2))
    assert cli_args.perturbation("m_body=+-0.1") == ("m_body", twip.Uniform(abs=0.1))
    assert cli_args.perturbation("slope=0:10deg")[1].high == pytest.approx(0.17453292519943295)
    assert cli_args.perturbation("slope=0:10deg")[1].low == 0.0
    assert cli_args.perturbation("phi0=~2deg")[1].std == pytest.approx(0.03490658503988659)
    assert cli_args.perturbation("i_body=~5%") == ("i_body", twip.Normal(rel=0.05))


def test_demo_runs_reproduce_quick(tmp_path, capsys, monkeypatch):
    # `twip demo` passed reproduce a Namespace without format and dpi: an AttributeError traceback.
    from twip import report

    calls = []
    monkeypatch.setattr(report, "reproduce", lambda out, **kw: calls.append((out, kw)))
    code, _, err = run(["demo", "--out", tmp_path / "d"], capsys)
    assert code == 0 and "Traceback" not in err
    assert calls == [(str(tmp_path / "d"), dict(quick=True, jobs=None, animations=True, fmt="png", dpi=None))]


def test_a_file_written_for_the_user_appears_whole_or_not_at_all(tmp_path):
    """A Ctrl-C (or any error) while a controller, robot, log or report file is written leaves
    the file that was there and no part file; a path that is a folder is named."""
    from twip import output

    path = tmp_path / "tuned.toml"
    path.write_text("the earlier file\n")
    with pytest.raises(KeyboardInterrupt):
        with output.writing(path) as f:
            f.write("[controller]\n")
            raise KeyboardInterrupt
    assert path.read_text() == "the earlier file\n" and [p.name for p in tmp_path.iterdir()] == ["tuned.toml"]
    output.write_text(path, "new\n")
    assert path.read_text() == "new\n"
    with pytest.raises(IsADirectoryError, match=f"Is a directory: '{tmp_path}'"):
        output.write_text(tmp_path, "x")
    assert [p.name for p in tmp_path.iterdir()] == ["tuned.toml"]
