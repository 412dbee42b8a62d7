"""`twip reproduce`: every thesis scenario, the Table 5.1/5.2 comparisons, robustness
sweeps and fall maps; figures, report.json and report.md (written from report.json's
content) in one folder."""
from __future__ import annotations

import json
import os
import re
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional

import numpy as np

import twip
from twip import output, scenarios
from twip.plot import metric_unit
from twip.report import experiments, sensitivity
from twip.report.claims import (RUN_KEYS, SETTLING, THESIS_TABLE_5_1, claims_for, headline, judge, measure, pid_over_smc,
                                 summary as claims_summary, summary_line, table_5_1_claims, table_5_1_holds, table_5_2_claims, with_sensitivity,
                                 with_thesis_lambda1)
from twip.report.markdown import render_markdown
from twip.report.numbers import dec, jsonable, sig
from twip.report.rig import rig_check, rig_summary
from twip.report.sweeps import fall_maps, robustness_sweeps
from twip.report.terrain import TERRAIN_SCENARIOS, terrain_rows
from twip.scenarios import is_planar
from twip.scenarios.tracking import THESIS_TABLE_5_2

DEFAULT_OUT = "twip-report"

#: Where the thesis pairs two figures of one run ("Fig 4.14 and Fig 4.15", "Fig 4.16 and
#: Fig 4.18"): the path goes in the first, the time series in the second.
_COMPANION = {"4.14": "4.15", "4.16": "4.18"}


class Steps:
    """One line per step with its time, as the steps finish."""

    def __init__(self, quiet=False):
        self.started = time.perf_counter()
        self.log: List[dict] = []
        self.quiet = quiet

    def attempt(self, label: str, fn: Callable, *args, **kw):
        """fn(*args, **kw) as one step; a failure is reported on its line and gives None."""
        t = time.perf_counter()
        try:
            out = fn(*args, **kw)
        except Exception as e:  # the rest of the report is still worth writing
            self.done(f"{label}: FAILED ({type(e).__name__}: {e})", time.perf_counter() - t)
            return None
        self.done(label, time.perf_counter() - t)
        return out

    def done(self, label, seconds):
        self.log.append({"step": label, "seconds": round(seconds, 3)})
        if not self.quiet:
            total = time.perf_counter() - self.started
            print(f"  {label:64s} {seconds:7.2f} s   (total {total:5.1f} s)", flush=True)


#: The figure formats `reproduce` writes (animations stay GIFs).
FORMATS = ("png", "svg", "pdf")


class Figures:
    """The figures to render: file name -> caption, and the jobs that draw them. A figure
    named `x.png` is written as `x.<fmt>` (vector output with svg or pdf)."""

    def __init__(self, out: Path, fmt: str = "png"):
        self.out = str(out)
        self.fmt = fmt
        self.captions: Dict[str, str] = {}
        self.jobs: List[tuple] = []

    def add(self, filename: str, caption: str, make: Callable[[str], Any]) -> None:
        if filename.endswith(".png"):
            filename = filename[:-len("png")] + self.fmt
        self.captions[filename] = caption
        self.jobs.append((filename, make, self.out))


def quick_options(name: str, quick: bool) -> dict:
    """Shorter runs for --quick, from the options the scenario has."""
    if not quick:
        return {}
    have = scenarios.options(name)
    wanted = {"t_final": 6.0, "laps": 2, "hold": 2.0, "settle": 2.0}
    return {k: v for k, v in wanted.items() if k in have}


def controller_family(sc) -> str:
    kind = type(sc.controller).__name__.replace("Controller", "").replace("Tracker", "")
    if getattr(sc.controller, "fuzzy", False) and kind == "Smc":
        kind = "Smc-fuzzy"
    return {"Lqr": "LQR", "Fuzzy": "fuzzy adaptive backstepping + PD", "Pid": "PID", "Smc": "sliding mode",
            "Smc-fuzzy": "sliding mode, fuzzy adaptive"}.get(kind, kind)


def figure_key(sc):
    """Scenarios in the thesis's order: by their figure number, then by name."""
    m = re.match(r"(\d+)\.(\d+)", str(sc.thesis.get("figure", "")))
    return (int(m.group(1)), int(m.group(2)), sc.name) if m else (99, 99, sc.name)


def jobs_default() -> int:
    return max(1, min(2, os.cpu_count() or 1))


#: The most figure-rendering processes `jobs` may ask for (the thread cap of the sweeps).
MAX_JOBS = twip._core.MAX_THREADS


def jobs_of(jobs) -> int:
    """`jobs` (None: jobs_default()) checked before any work, not when the figures come."""
    if jobs is None:
        return jobs_default()
    if isinstance(jobs, bool) or not isinstance(jobs, (int, np.integer)):
        raise TypeError(f"jobs must be an integer or None, got {jobs!r} ({type(jobs).__name__})")
    if not 1 <= jobs <= MAX_JOBS:
        raise twip.InvalidParameterError(f"jobs = {jobs!r}: must be from 1 to {MAX_JOBS}")
    return int(jobs)


def _run_scenarios(quick: bool, steps: Steps):
    """Every scenario, in the thesis's order: (runs, claims, summary, the experiments' runs with
    the thesis-like robot)."""
    summary: Dict[str, Any] = {}
    built = []
    for name in scenarios.names():
        if name in TERRAIN_SCENARIOS:  # not the thesis's: the future-work rows run them
            continue
        try:
            built.append(scenarios.get(name, **quick_options(name, quick)))
        except Exception as e:  # one broken scenario must not stop the report
            summary[name] = {"error": str(e)}
            steps.done(f"scenario {name}: FAILED to build ({e})", 0.0)
    runs: Dict[str, Any] = {}
    rig: Dict[str, Any] = {}
    claims: List[dict] = []
    for sc in sorted(built, key=figure_key):
        t0 = time.perf_counter()
        try:
            r = sc.run(record_every=10 if is_planar(sc) else 1)
        except Exception as e:
            summary[sc.name] = {"error": str(e)}
            steps.done(f"scenario {sc.name}: FAILED ({e})", time.perf_counter() - t0)
            continue
        runs[sc.name] = (sc, r)
        # The thesis's experiments (not its "-sim" runs) also with the thesis-like robot in the loop.
        real = None if sc.name.endswith("-sim") else sc.run(realism=twip.Realism.thesis_like(),
                                                            record_every=10 if is_planar(sc) else 1)
        if real is not None:
            rig[sc.name] = real
        # Where twip holds at a goal and the thesis turns at once, the stop also with the thesis's hold.
        own = None
        if "thesis_hold" in sc.thesis:
            own_sc = scenarios.get(sc.name, **{**quick_options(sc.name, quick), "hold": sc.thesis["thesis_hold"]})
            own = (own_sc, own_sc.run())
        claims.extend(claims_for(sc, r, real, own))
        summary[sc.name] = {
            "description": sc.description, "controller": controller_family(sc), "figure": sc.thesis.get("figure"),
            "outcome": r.outcome, "t_end": sig(r.t_end if r.t_end is not None else r.t[-1]),
            "metrics": {k: sig(v * metric_unit(k)[1]) for k, v in r.metrics.items()},
            "units": {k: metric_unit(k)[2] for k in r.metrics},
        }
        steps.done(f"scenario {sc.name} ({r.outcome}, {r.steps:,} steps)", time.perf_counter() - t0)
    return runs, claims, summary, rig


#: How a figure of the thesis's experiment is labelled: ours are simulations, of the ideal
#: plant and of the thesis-like robot (`rig`).
RIG_LABEL = "thesis-like robot (simulated)"


def _rig_label(run) -> str:
    """The thesis-like run's legend entry, with its fall as the rows state it ("fell at 6.39 s")."""
    return RIG_LABEL if run.outcome == "completed" else f"{RIG_LABEL}, {run.outcome} at {dec(run.t_end, 2)} s"


def _analogue(fig_no: str, experiment: bool) -> str:
    what = "simulation of the experiment: ideal plant and thesis-like robot" if experiment else "simulation"
    return f"Fig {fig_no} analogue ({what})"


def _scenario_figures(runs: dict, rig: dict, quick: bool, steps: Steps, figures: Figures) -> None:
    """One figure per thesis figure, an experiment's with the thesis-like robot's run beside
    the ideal plant's; a tracker also gets its path on the ±20 % plants."""
    from twip import plot
    from twip.scenarios import tracking as tracking_sc

    for name, (sc, r) in runs.items():
        fig_no = str(sc.thesis.get("figure", "")) or "x"
        beside = (_rig_label(rig[name]), rig[name]) if name in rig else None
        head = _analogue(fig_no, beside is not None)
        if not is_planar(sc):
            figures.add(f"fig{fig_no}_{name}.png", f"{head}: {sc.description}",
                        lambda p, sc=sc, r=r, head=head, beside=beside: plot.timeseries(
                            r, scenario=sc, path=p, beside=beside, title=f"{head}: {sc.name}\n{sc.description}"))
            continue
        paths = {"plant = controller's model": r, **({beside[0]: beside[1]} if beside else {})}
        t0 = time.perf_counter()
        nominal = sc.model.params
        for label, factor in (("plant +20 %", 1.2), ("plant −20 %", 0.8)):
            other = scenarios.get(name, params=tracking_sc.mismatched(nominal, factor), controller_params=nominal,
                                  **quick_options(name, quick))
            paths[label] = other.run(record_every=10)
        steps.done(f"scenario {name}: ±20 % plants for the path figure", time.perf_counter() - t0)
        companion = _COMPANION.get(fig_no)
        experiment = name in rig and fig_no != "4.16"  # Figs 4.16/4.18 are the thesis's simulation
        head = _analogue(fig_no, experiment)
        figures.add(f"fig{fig_no}_{name}.png", f"{head}: the path of {name} (nominal and ±20 % plants"
                    f"{', thesis-like robot' if name in rig else ''})",
                    lambda p, sc=sc, paths=paths, head=head: plot.paths(
                        paths, trajectory=sc.reference, path=p,
                        title=f"{head}: {sc.name}, nominal and ±20 % plants\n{sc.description}"))
        ts_name = f"fig{companion}_{name}.png" if companion else f"fig{fig_no}_{name}_signals.png"
        ts_head = _analogue(companion or fig_no, experiment)
        figures.add(ts_name, f"{ts_head}: {name}'s pitch, speed, yaw rate, torques and internals",
                    lambda p, sc=sc, r=r, h=ts_head, f=fig_no, beside=beside: plot.tracking(
                        r, scenario=sc, path=p, show_path=True, beside=beside,
                        title=f"{h}: {sc.name}, the signals of Fig {f}'s run\n{sc.description}"))


def _table_5_1(quick: bool, steps: Steps, figures: Figures, claims: List[dict]):
    """(each controller on its own experiment, the analogue on one schedule): rows for report.json."""
    from twip import plot
    from twip.scenarios import fuzzy as fuzzy_sc

    cases = ("nominal", "all +20 %") if quick else None
    rows = steps.attempt("Table 5.1 analogue: LQR vs fuzzy on one schedule, nominal and wrong plants",
                         fuzzy_sc.compare_table, cases=cases, controllers=("lqr", "fuzzy", "fuzzy-fixed")) or []
    # The claims: each controller on its own experiment, as the thesis measured its rows.
    own = steps.attempt("Table 5.1: each controller on its own experiment", experiments.table_5_1_rows,
                        twip.Realism.thesis_like()) or []
    claims.extend(table_5_1_claims(own))
    if rows or own:
        drawn = [{**r, "case": "own\nexperiment"} for r in own] + rows
        figures.add("table5.1.png", "Table 5.1: mean |pitch error| and |speed error|, each controller on its own experiment "
                    "(the thesis's rows, with the thesis-like robot) and, for comparison, every controller on the fuzzy "
                    "experiments' schedule with nominal and wrong plants (simulations)",
                    lambda p: plot.table_5_1(drawn, thesis=THESIS_TABLE_5_1, path=p, thesis_on="own\nexperiment", title=(
                        "Table 5.1 (simulations): 'own experiment' is each controller's own run (LQR: Figs 4.3/4.10, fuzzy: "
                        "Figs 4.8/4.12),\nthe other groups the fuzzy runs' schedule for every controller, plant changed "
                        "(diamonds: thesis; rings: thesis-like robot; log scale)")))
    return own, [{"surface": r["surface"], "plant": r["case"], "controller": r["controller"], "outcome": r["outcome"],
             "pitch_error_deg": dec(r["pitch_error_deg"], 3), "speed_error_deg_s": dec(r["speed_error_deg_s"], 1),
             "stop_far_cm": dec(r["stop_far_cm"], 1), "stop_home_cm": dec(r["stop_home_cm"], 1),
             **({"outcome_realism": r["outcome_realism"],
                 "pitch_error_deg_realism": dec(r["pitch_error_deg_realism"], 3),
                 "speed_error_deg_s_realism": dec(r["speed_error_deg_s_realism"], 1)} if "outcome_realism" in r else {})}
            for r in rows]


def _table_5_2(quick: bool, steps: Steps, figures: Figures, claims: List[dict]) -> List[dict]:
    from twip import plot
    from twip.scenarios import tracking as tracking_sc

    laps = 2 if quick else 3
    rows = steps.attempt("Table 5.2: PID vs sliding mode, nominal and ±20 % plants", tracking_sc.compare,
                         laps=laps, realism=twip.Realism.thesis_like()) or []
    thesis_rows = steps.attempt("Table 5.2 with the thesis's λ1 (4.74)", tracking_sc.compare, laps=laps,
                                pitch_offset=False, realism=twip.Realism.thesis_like()) or []
    if rows and thesis_rows:
        with_thesis_lambda1(claims, thesis_rows)
        claims.extend(table_5_2_claims(rows, thesis_rows))
    if rows and thesis_rows:
        # The verdict is the thesis's λ1's: its runs first, twip's correction T8 beside them.
        drawn = thesis_rows + [{**r, "controller": f"{r['controller']} (λ1 corrected, T8)"} for r in rows
                               if r["controller"] != "circle-pid"]
        figures.add("table5.2.png", "Table 5.2 (simulations): mean |x − x_r|, |y − y_r| per tracker and plant with the "
                    "thesis's λ1 (4.74), which decides the row, and the sliding-mode trackers with twip's correction T8; "
                    "the thesis's rows as lines (PID: its experiment; sliding mode: simulation or experiment, not stated)",
                    lambda p: plot.table_5_2(drawn, thesis=THESIS_TABLE_5_2, path=p, title=(
                        "Table 5.2 (simulations): the trackers with the thesis's λ1 (4.74), and the sliding-mode ones with "
                        "twip's λ1 (T8);\nk1–k3 and k_φ are twip's (unpublished); rings: thesis-like robot; log scale")))
    return [{"controller": r["controller"], "plant": r["plant"], "outcome": r["outcome"],
             "x_cm": dec(100 * r["x"], 2), "y_cm": dec(100 * r["y"], 2),
             "x_settled_cm": dec(100 * r["x_settled"], 2), "y_settled_cm": dec(100 * r["y_settled"], 2),
             "path_settled_cm": dec(100 * r["path_settled"], 2), "pitch_deg": dec(r["pitch_deg"], 2),
             "realism_outcome": r["realism_outcome"], "x_realism_cm": dec(100 * r["x_realism"], 2),
             "y_realism_cm": dec(100 * r["y_realism"], 2)} for r in rows]


def _sensitivity(quick: bool, steps: Steps, claims: List[dict]) -> None:
    """Reruns the claims that rest on unpublished choices over those choices (report.sensitivity)."""
    table: dict = {}
    table.update(steps.attempt("sensitivity: Table 5.1's experiments over their joint choices", sensitivity.table_5_1,
                               table_5_1_holds, quick) or {})
    table.update(steps.attempt("sensitivity: every scenario's claims over its joint choices",
                               sensitivity.scenario_claims, judge, measure, RUN_KEYS, quick, SETTLING) or {})
    table.update(steps.attempt("sensitivity: Table 5.2's conclusion over k1-k3, k_φ, loop and friction",
                               sensitivity.smc_versus_pid, pid_over_smc, 2 if quick else 3, quick) or {})
    with_sensitivity(claims, table)


def _animations(runs: dict, quick: bool, figures: Figures) -> None:
    """Two GIFs: the first 2-DOF experiment on a slope and the first tracker."""
    from twip import animate

    two = [n for n in runs if not is_planar(runs[n][0]) and not n.endswith("-sim") and runs[n][0].model.slope]
    three = [n for n in runs if is_planar(runs[n][0])]
    for name in two[:1] + three[:1]:
        sc, r = runs[name]
        view = "top view of the path, side view of the pitch" if is_planar(sc) else "side view on the slope"
        gif_kw = {"fps": 10.0, "max_seconds": 4.0} if quick else {}
        figures.add(f"anim_{name}.gif", f"animation of {name}: {view}",
                    lambda p, sc=sc, r=r, kw=gif_kw: animate.gif(r, p, scenario=sc, **kw))


def _write_reports(out: Path, report: dict, steps: Steps) -> dict:
    t0 = time.perf_counter()
    report["steps"] = list(steps.log)
    report["seconds"] = round(time.perf_counter() - steps.started, 2)
    report = jsonable(report)
    output.write_text(out / "report.json", json.dumps(report, indent=1, ensure_ascii=False, allow_nan=False) + "\n")
    output.write_text(out / "report.md", render_markdown(report))
    steps.done("report.md, report.json", time.perf_counter() - t0)
    return report


def reproduce(out=DEFAULT_OUT, quick: bool = False, jobs: Optional[int] = None, animations: bool = True,
              quiet: bool = False, fmt: str = "png", dpi: Optional[float] = None) -> dict:
    """Runs every thesis scenario, the Table 5.1/5.2 comparisons and the robustness sweeps;
    writes the figures (`fmt`: png, svg or pdf; `dpi` for the PNGs, default 150, 60 with
    `quick`), report.md and report.json to `out`. Returns the report (a dict)."""
    from twip import plot

    jobs = jobs_of(jobs)
    if fmt not in FORMATS:
        raise twip.InvalidParameterError(f"fmt = {fmt!r}: must be one of {', '.join(FORMATS)}")
    if dpi is not None and not (isinstance(dpi, (int, float)) and 10 <= dpi <= 1200):
        raise twip.InvalidParameterError(f"dpi = {dpi!r}: must be a number in 10..1200")

    plot.use_agg()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    steps = Steps(quiet)
    mode = "quick" if quick else "full"
    if not quiet:
        print(f"twip {twip.__version__}: reproducing the thesis into {out}/ ({mode}; RobotParams.balanbot())", flush=True)
    figures = Figures(out, fmt)
    runs, claims, summary, rig = _run_scenarios(quick, steps)
    _scenario_figures(runs, rig, quick, steps, figures)
    table_5_1_own, table_5_1 = _table_5_1(quick, steps, figures, claims)
    table_5_2 = _table_5_2(quick, steps, figures, claims)
    _sensitivity(quick, steps, claims)
    sweeps = robustness_sweeps(runs, quick, steps, figures, controller_family, quick_options)
    basins = fall_maps(runs, quick, steps, figures, controller_family)
    if animations:
        _animations(runs, quick, figures)
    render(figures.jobs, jobs, steps, dpi=dpi if dpi is not None else (60 if quick else None))  # quick: smaller, faster
    future_work = steps.attempt("future work: the trackers on terrain (predictions of twip)", terrain_rows, quick) or []
    rig_rows = rig_check(claims)
    report = {
        "twip": twip.__version__, "mode": mode, "robot": twip.RobotParams.balanbot().to_dict(),
        "summary": {**claims_summary(claims), "rig": rig_summary(rig_rows)}, "claims": claims, "rig_check": rig_rows, "scenarios": summary, "table_5_1": table_5_1,
        "table_5_1_experiments": [{k: (dec(v, 3) if isinstance(v, float) else v) for k, v in r.items()} for r in table_5_1_own],
        "table_5_2": table_5_2,
        "sweeps": sweeps, "fall_maps": basins, "future_work": future_work, "figures": figures.captions,
    }
    report = _write_reports(out, report, steps)
    if not quiet:
        total = time.perf_counter() - steps.started
        print(f"done in {total:.1f} s: {len(claims)} claims ({summary_line(claims)}); {headline(report['summary'])}; "
              f"see {out}/report.md")
    return report


_FIGURE_JOBS: List[tuple] = []  # (filename, callable(path), folder); read by forked workers


def _render_job(index: int):
    filename, make, out = _FIGURE_JOBS[index]
    t = time.perf_counter()
    with output.replacing(Path(out) / filename) as part:  # a figure cut short is never left as it
        make(str(part))
    return filename, time.perf_counter() - t


def _ignore_ctrl_c() -> None:
    """A figure worker leaves Ctrl-C to its parent, which ends the pool (a terminal's
    Ctrl-C reaches every process of its group)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def render(fig_jobs: List[tuple], jobs: int, steps: Steps, dpi: Optional[float] = None) -> None:
    """Draws every figure job, in forked worker processes where fork is available. A Ctrl-C
    stops at once: the figures under way are dropped, not every queued one drawn first."""
    global _FIGURE_JOBS
    import multiprocessing

    from twip import plot

    t0 = time.perf_counter()
    before = plot.style(dpi=dpi)
    _FIGURE_JOBS = fig_jobs
    use_fork = jobs > 1 and len(fig_jobs) > 1 and "fork" in multiprocessing.get_all_start_methods()
    try:
        if use_fork:  # load the fonts and the text engine once, before the workers inherit them
            plot.warm_up()
            pool = multiprocessing.get_context("fork").Pool(jobs, initializer=_ignore_ctrl_c)
            try:
                for filename, seconds in pool.imap_unordered(_render_job, range(len(fig_jobs))):
                    steps.done(f"  {filename}", seconds)
            except BaseException:
                # A pool's shutdown waited for every queued figure (~30 s after a Ctrl-C).
                pool.terminate()
                raise
            else:
                pool.close()
            finally:
                pool.join()
                for filename, _, out in fig_jobs:  # those of workers ended mid-figure
                    for part in Path(out).glob(output.part_of(filename, "*").name):
                        part.unlink(missing_ok=True)
        else:
            for i in range(len(fig_jobs)):
                filename, seconds = _render_job(i)
                steps.done(f"  {filename}", seconds)
    finally:
        _FIGURE_JOBS = []
        plot.style(dpi=before["savefig.dpi"])
    steps.done(f"figures and animations: {len(fig_jobs)} files with {jobs} process(es)", time.perf_counter() - t0)
