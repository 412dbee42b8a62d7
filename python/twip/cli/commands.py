"""The `twip` commands: one small function each, taking the parsed arguments and
returning the exit code. Bad arguments raise UsageError (cli.args)."""
from __future__ import annotations

import dataclasses
import json
import math
import os
import shlex
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any, Dict, List

import numpy as np

import twip
from twip import output, report, scenarios
from twip.cli.design import with_controller
from twip.cli.args import (UsageError, key_value, stall_current, get_scenario, perturbation, realism, robot, scenario_name,
                           scenario_options)
from twip.plot import metric_unit
from twip.report.claims import claims_for
from twip.report.reproduce import MAX_JOBS
from twip.report.numbers import fmt, jsonable
from twip.checkpoint import CheckpointWriteError
from twip.sweep import StreamedSweepResult, fits_in_memory


def metric_lines(metrics: dict) -> List[str]:
    lines = []
    for name, value in metrics.items():
        label, scale, unit = metric_unit(name)
        lines.append(f"  {label:48s} {value * scale:12.4g} {unit}")
    return lines


def sweep_summary(result, metrics) -> str:
    lo, hi = result.fall_rate_interval()
    s = result.summary()
    lines = [f"{result.config['scenario']}: {s['samples']} samples ({s['invalid']} invalid), seed {result.config['seed']}"]
    lines += [f"  invalid: {count} samples, {reason}" for reason, count in s["invalid_reasons"].items()]
    lines += [f"  warning: {warning}" for warning in s["warnings"]]
    if s.get("over_stall_current"):
        lines.append(f"  warning: {s['over_stall_current']} samples asked one motor for more than its stall current "
                     f"({result.stall_current:g} A): the real robot cannot do those runs as simulated")
    lines += [f"  fall rate {result.fall_rate:.2%}  (95 % CI {lo:.2%} – {hi:.2%})" + (
                  f" over the {s['samples'] - s['invalid']} valid samples" if s["invalid"] else ""),
              f"  {'metric (samples that did not fall)':48s} {'unit':>6s} {'q05':>10s} {'median':>10s} {'q95':>10s}"]
    for name in metrics:
        label, scale, unit = metric_unit(name)
        q = np.array([s[name][k] for k in ("q05", "median", "q95")], float) * scale
        lines.append(f"  {label:48s} {unit:>6s} {q[0]:10.4g} {q[1]:10.4g} {q[2]:10.4g}")
    return "\n".join(lines)


def check_outputs(args) -> None:
    """Refuses, before a run, output paths that cannot be written (--plot, --animate,
    --csv) and animation settings out of range."""
    from twip import animate, plot

    if getattr(args, "plot", None):
        try:
            plot.check_path(args.plot)
        except twip.TwipError as e:
            raise UsageError(f"--plot: {e}") from None
    if getattr(args, "animate", None):
        try:
            animate.check_options(args.animate, args.fps)
        except twip.TwipError as e:
            raise UsageError(f"--animate: {e}") from None
    if getattr(args, "csv", None):
        check_output_file("--csv", args.csv)


def check_output_file(option: str, path) -> None:
    """Refuses, before the work, an output file whose folder is missing or not writable."""
    from twip import plot

    try:
        plot.check_folder(path)
    except twip.TwipError as e:
        raise UsageError(f"{option}: {e}") from None


def write_csv(result, path) -> None:
    """The per-sample table (drawn values and metrics, units in the column names) as CSV;
    a streamed sweep's shard by shard (bounded memory)."""
    parts = result.shards() if isinstance(result, StreamedSweepResult) else [result.metrics]
    with output.writing(path) as f:  # a full disk or a Ctrl-C leaves no cut-short table
        header = False
        for part in parts:
            table = result.table(part)
            if not header:
                f.write(",".join(table) + "\n")
                header = True
            np.savetxt(f, np.column_stack([np.asarray(v, float) for v in table.values()]), delimiter=",", fmt="%.10g")


def resume_command() -> str:
    return "twip " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if len(sys.argv) > 1 else "the same command"


def list_scenarios(args) -> int:
    for name in scenarios.names():
        sc = scenarios.get(name)
        print(f"{name:18s} {sc.description}")
    return 0


def simulate(args) -> int:
    check_outputs(args)
    name = scenario_name(args.scenario)
    params = robot(args.param, args.robot)
    options = scenario_options(name, args.option)
    ctrl_params = twip.RobotParams.balanbot() if args.nominal_controller else None
    sc = get_scenario(name, params=params, controller_params=ctrl_params, options=options, robot_file=args.robot)
    sc = with_controller(sc, args.controller)
    overrides: Dict[str, Any] = {}
    if args.t_final is not None:
        overrides["t_final"] = args.t_final
    if args.dt is not None:
        overrides["dt"] = args.dt
    if args.realism is not None:
        overrides["realism"] = realism(args.realism, args.robot)
    started = time.perf_counter()
    r = sc.run(stall_current=stall_current(args.robot), **overrides)
    elapsed = time.perf_counter() - started
    # The thesis's claims are about the thesis's robot and controller: another robot (a file)
    # or a tuned controller gets none.
    thesis_robot = sc.model.params.to_dict() == twip.RobotParams.balanbot().to_dict()
    claims = (claims_for(sc, r) if thesis_robot and not overrides and not args.param and not options
              and not args.controller else [])
    if args.json:
        print(json.dumps(jsonable({"scenario": name, "outcome": r.outcome, "t_end": r.t_end, "steps": r.steps,
                                    "seconds": elapsed, "metrics": r.metrics, "claims": claims,
                                   "warnings": list(r.warnings)}), indent=1))
    else:
        changed = ", ".join(([args.robot] if args.robot else []) + (args.param or [])) or "RobotParams.balanbot()"
        print(f"{name}: {sc.description}")
        print(f"robot: {changed}" + ("; controller designed for balanbot()" if args.nominal_controller else ""))
        if options:
            print("options: " + ", ".join(f"{k}={v}" for k, v in options.items()))
        end = f" at t = {r.t_end:.3f} s" if r.fell else f" after {r.t[-1]:.2f} s"
        print(f"outcome: {r.outcome}{end} ({r.steps:,} RK4 steps in {elapsed * 1e3:.1f} ms)")
        print("\n".join(metric_lines(r.metrics)))
        if claims:
            print("\nthe thesis's claims (twip reproduce puts them all in report.md):")
            for c in claims:
                print(f"  {c['claim']}: thesis {fmt(c['thesis'])}, ours {fmt(c['ours'])} {c['unit']}  "
                      f"[{c['status']}: {c['reason']}]")
    for warning in r.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    if args.plot:
        from twip import plot

        plot.use_agg()
        plot.result(r, scenario=sc, path=args.plot)
        print(f"wrote {args.plot}", file=sys.stderr)
    if args.animate:
        from twip import animate

        info = animate.gif(r, args.animate, scenario=sc, fps=args.fps)
        print(f"wrote {args.animate} ({info['frames']} frames, {info['seconds']:.1f} s at x{info['speed']:g})", file=sys.stderr)
    return 0


def sweep(args) -> int:
    check_outputs(args)
    if args.plot and not fits_in_memory(args.n):
        raise UsageError(f"--plot: the metrics of -n {args.n:,} samples do not fit the memory budget, so the sweep "
                         "streams them to --checkpoint and draws no histograms; leave out --plot (the summary "
                         "and --csv are written shard by shard)")
    name = scenario_name(args.scenario)
    params = robot(args.param, args.robot)
    options = scenario_options(name, args.option)
    pairs = [perturbation(p) for p in args.perturb or []]
    perturb = dict(pairs)
    if len(perturb) < len(pairs):
        twice = sorted(name for name, count in Counter(name for name, _ in pairs).items() if count > 1)
        raise UsageError(f"--perturb {', '.join(twice)}: given more than once (each quantity once)")
    if args.map and not set(args.map) <= set(perturb):
        raise UsageError(f"--map {','.join(args.map)}: both must be --perturb names ({', '.join(perturb) or 'none given'})")
    sc = get_scenario(name, params=params, options=options, robot_file=args.robot)  # designed once, here; bad options are named
    sc = with_controller(sc, args.controller)
    if not perturb:
        print("note: no --perturb given, every sample is the same robot", file=sys.stderr)
    try:
        result = twip.montecarlo(sc, args.n, perturb=perturb, seed=args.seed, threads=args.threads,
                                 progress=not args.quiet, checkpoint=args.checkpoint, realism=realism(args.realism, args.robot),
                                 stall_current=stall_current(args.robot))
    except (KeyboardInterrupt, CheckpointWriteError) as stop:  # a full disk stops it as Ctrl-C does
        partial = getattr(stop, "partial", None)
        if partial is not None and partial.n:
            print(f"{'interrupted' if isinstance(stop, KeyboardInterrupt) else 'stopped'}: the {partial.n:,} "
                  "samples that finished:", file=sys.stderr)
            print(sweep_summary(partial, list(partial.metric_names[2:])), file=sys.stderr)
        if args.checkpoint:
            print(f"finished shards are in {args.checkpoint}; resume with:\n  {resume_command()}", file=sys.stderr)
        else:
            print("nothing was kept: pass --checkpoint DIR to keep finished shards and resume", file=sys.stderr)
        raise
    metrics = list(result.metric_names[2:])
    speed = (f"{result.steps:,} RK4 steps in {result.elapsed:.2f} s: "
             f"{result.steps / max(result.elapsed, 1e-9) / 1e6:.1f} M sample-steps/s ({result.kernel})")
    if args.json:
        s = result.summary()
        print(json.dumps(jsonable({"scenario": name, "n": result.n, "seed": args.seed, "perturb": args.perturb or [],
                                    "realism": args.realism, "invalid": s["invalid"],
                                    "invalid_reasons": s["invalid_reasons"],
                                    "fall_rate": result.fall_rate, "fall_rate_95ci": list(s["fall_rate_95ci"]),
                                    "quantiles": {m: s[m] for m in metrics}}), indent=1))
    else:
        print(sweep_summary(result, metrics))
        if args.realism is not None:
            print(f"  realism: {args.realism} (sensors, driver, delay, gearhead friction and backlash in the loop)")
        print(f"  {speed}")
    if args.csv:
        write_csv(result, args.csv)
        print(f"wrote {args.csv}", file=sys.stderr)
    if args.plot:
        from twip import plot

        plot.use_agg()
        pngs = [args.plot]
        plot.sweep(result, path=args.plot)
        if args.map or len(perturb) >= 2:
            x, y = args.map or list(perturb)[:2]
            stem, ext = os.path.splitext(args.plot)
            plot.fall_map(result, x, y, path=f"{stem}-fall-map{ext or '.png'}")
            pngs.append(f"{stem}-fall-map{ext or '.png'}")
        print("wrote " + ", ".join(pngs), file=sys.stderr)
    return 0


def reproduce(args) -> int:
    if args.jobs is not None and not 1 <= args.jobs <= MAX_JOBS:
        raise UsageError(f"--jobs {args.jobs}: must be from 1 to {MAX_JOBS}")
    report.reproduce(args.out, quick=args.quick, jobs=args.jobs, animations=not args.no_animations,
                     fmt=args.format, dpi=args.dpi)
    return 0


def robot_init(args) -> int:
    """twip robot init FILE: the default robot, its motor and driver, commented."""
    from twip import robot_file

    path = Path(args.file)
    if path.exists() and not args.force:
        raise UsageError(f"{path} exists; pass --force to overwrite it")
    check_output_file("FILE", path)
    robot_file.init(path)
    print(f"wrote {path}: the Balanbot (RobotParams.balanbot()), its GB37Y3530 motor and L298 driver", file=sys.stderr)
    return 0


def export(args) -> int:
    """twip export SCENARIO --out DIR: the tuned controller for a firmware (twip.firmware)."""
    from twip import firmware

    if not args.out.strip():  # Path('') is the current folder
        raise UsageError(f"--out {args.out!r}: give the folder to write (--out . --force for the current one)")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out}: exists and is not a folder")
    robot_file = twip.Robot.from_file(args.robot) if args.robot else None
    target = scenario_name(args.scenario)
    options = scenario_options(target, args.option)
    if args.controller or options:  # the scenario for the robot, with its options and the file's controller
        params = robot_file.params if robot_file else None
        built = scenarios.get(target, params=params, **scenarios.robot_options(target, robot_file), **options)
        target = with_controller(built, args.controller) if args.controller else built
    summary = firmware.export(target, out, robot=robot_file, units_=args.units,
                              replay_seconds=args.replay_seconds, force=args.force)
    print(f"wrote {out}/: {summary['family']} controller of {args.scenario} in {args.units} units, "
          f"{summary['updates']} recorded updates ({summary['outcome']}); build and check with "
          f"`make -C {shlex.quote(str(out))} check` (twip-ffi sources: {summary['source']})", file=sys.stderr)
    if not summary["source_found"]:
        # An installed wheel carries no Rust sources: the Makefile needs a twip checkout.
        print(f"note: {summary['source']} has no twip-ffi Cargo.toml; give a twip checkout's with "
              f"`make -C {shlex.quote(str(out))} TWIP_SRC=<twip>/crates/twip-ffi check` or TWIP_SRC=... "
              "when exporting", file=sys.stderr)
    return 0


def identify(args) -> int:
    """twip identify CSV --free ...: the fitted robot, its intervals and the diagnosis."""
    import tomllib

    from twip import robot_file, sysid

    check_outputs(args)  # --plot and --out before the fit, not after it
    if args.out:
        check_output_file("--out", args.out)
        if Path(args.out).resolve() == Path(args.log).resolve():  # the measured run, replaced by a TOML file
            raise UsageError(f"--out {args.out}: is the log being fitted; give another file for the fitted robot")
    columns = dict(key_value(text, "--column") for text in args.column or [])
    scale = {}
    for text in args.scale or []:
        name, value = key_value(text, "--scale")
        try:
            scale[name] = float(value)
        except ValueError:
            scale[name] = value
    log = sysid.RunLog.from_csv(args.log, slope=math.radians(args.slope), columns=columns, scale=scale)
    start = twip.Robot.from_file(args.robot) if args.robot else None
    robot = start.params if start else twip.RobotParams.balanbot()
    free = [f.strip() for f in args.free.split(",") if f.strip()]
    signals = [s.strip() for s in args.signals.split(",")] if args.signals else None
    if args.gyro_bias_walk is not None and args.imu_dlpf is None:
        raise UsageError(f"--gyro-bias-walk {args.gyro_bias_walk:g}: describes the IMU, so it needs --imu-dlpf too")
    walk = math.radians(args.gyro_bias_walk or 0.0)
    # The robot file's [sensors] unless a flag says otherwise: its encoder_cpr was ignored
    # for 700, and an enc column of another encoder misfit by the ratio.
    declared = start.sensors if start and start.sensors else robot_file.Sensors()
    cpr = args.encoder_cpr if args.encoder_cpr is not None else declared.encoder_cpr
    height = args.imu_height if args.imu_height is not None else declared.imu_height
    try:  # Sensors checks the height, before an IMU is built with it
        sensors = sysid.Sensors(encoder_cpr=cpr, imu_height=height)
    except twip.TwipError as e:
        raise UsageError(f"--imu-height: {e}") from None
    if args.imu_dlpf is not None:
        sensors = dataclasses.replace(sensors, imu=twip.Imu(dlpf_hz=args.imu_dlpf, height=height,
                                                             sample_rate=args.imu_rate, gyro_bias_walk=walk))
    fit = sysid.identify(log, robot, free, segment=args.segment, driver=start.driver if start else None,
                         friction=identify_friction(args), sensors=sensors, signals=signals,
                         backlash=math.radians(args.backlash) if args.backlash else None)
    print(f"twip identify {args.log}: {len(log)} samples over {log.t[-1] - log.t[0]:.3g} s; "
          f"signals {', '.join(fit.rms)}")
    print(fit.summary())
    trusted = fit.converged and not fit.misfits
    if args.out and not (trusted or args.force):
        why = "did not converge" if not fit.converged else "does not explain the log (MISFIT above)"
        print(f"twip identify: not writing {args.out}: the fit {why}; --force writes it anyway", file=sys.stderr)
    elif args.out:
        tables = tomllib.loads(Path(args.robot).read_text()) if args.robot else {}
        driver = dict(tables.get("driver", {})) or (robot_file.balanbot_driver() if fit.driver is not None else {})
        if fit.driver is not None:
            driver.update({k: v for k, v in fit.driver.to_dict().items() if k in fit.names})
        # The sensors the fit read the log with, beside the file's IMU axes (they were dropped).
        given = "sensors" in tables or args.encoder_cpr is not None or args.imu_height is not None
        sensors = {**tables.get("sensors", {}), "encoder_cpr": cpr, "imu_height": height} if given else None
        robot_file.save(fit.robot, args.out, tables.get("motor"), driver or None, sensors)
        print(f"wrote {args.out}")
    if args.plot:
        fit.plot(args.plot)
        print(f"wrote {args.plot}")
    return 0 if trusted else 1


def identify_friction(args):
    """The gearhead friction of --friction and --friction-*, or None."""
    law = twip.Realism.thesis_like().friction if args.friction else None
    if args.friction_coulomb is None:
        if law is None and (args.friction_breakaway is not None or args.friction_stick is not None):
            raise UsageError("--friction-breakaway and --friction-stick need --friction-coulomb or --friction")
    elif law is None:
        law = twip.Friction(args.friction_coulomb)
    else:
        law = law.replace(coulomb=args.friction_coulomb, breakaway=law.breakaway * args.friction_coulomb / law.coulomb)
    if law is not None and args.friction_breakaway is not None:
        law = law.replace(breakaway=args.friction_breakaway)
    if law is not None and args.friction_stick is not None:
        law = law.replace(stick_speed=args.friction_stick)
    return law
