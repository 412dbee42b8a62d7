"""`twip tune` and `twip worst-case`, and the --controller FILE option of simulate, sweep
and export."""
from __future__ import annotations

import sys
from collections import Counter

import twip
from twip.design.tune import DEFAULT_BUDGET
from twip.cli.args import (UsageError, formatter, get_scenario, file_name, perturbation, positive_int, realism, robot,
                           scenario_name, seed, add_realism_option, add_robot_option)

TUNE_EPILOG = """examples:
  twip tune slope-lqr --perturb m_body=±30% --perturb com_height=±30% --perturb i_body=±30% \\
            --perturb mu_bearing=±30% --realism thesis-like --budget 200 --out tuned.toml
  twip sweep slope-lqr -n 2000 --perturb m_body=±30% --realism thesis-like --controller tuned.toml
  twip export slope-lqr --controller tuned.toml --out fw

Every candidate runs on the same -n robots with the same noise; the tuned controller and the
scenario's own are then compared on --validate held-out robots (another seed)."""

WORST_EPILOG = """example:
  twip worst-case slope-lqr --perturb m_body=±8% --perturb com_height=±8% --perturb i_body=±8% \\
                  --perturb mu_bearing=±8% --realism thesis-like --budget 400

Searches the perturbations' support (a uniform's interval, a normal's ±3 std) for the robot
that falls first, or else tilts furthest; then checks it on --confirm fresh noise seeds."""


def add_controller_option(p) -> None:
    p.add_argument("--controller", type=file_name("the scenario's own controller"), metavar="FILE",
                   help="a tuned controller file (twip tune --out FILE): its knobs "
                   "on the scenario's controller")


def with_controller(sc, path):
    """The scenario with the controller of --controller FILE (or as it is without one)."""
    if not path:
        return sc
    from twip.design import controller_file

    return controller_file.apply(sc, path)


def _perturb(args) -> dict:
    pairs = [perturbation(p) for p in args.perturb or []]
    perturb = dict(pairs)
    if len(perturb) < len(pairs):
        twice = sorted(name for name, count in Counter(name for name, _ in pairs).items() if count > 1)
        raise UsageError(f"--perturb {', '.join(twice)}: given more than once (each quantity once)")
    return perturb


def add_parsers(sub) -> None:
    p = sub.add_parser("tune", help="tune a scenario's controller over uncertain robots",
                       description="Tune the knobs of a scenario's controller (LQR weights, fuzzy, PID or "
                                   "sliding-mode gains) so that it keeps perturbed robots up; write a controller "
                                   "file for --controller.", epilog=TUNE_EPILOG, formatter_class=formatter)
    p.add_argument("scenario", metavar="SCENARIO", help="a scenario name (twip list)")
    p.add_argument("--perturb", action="append", metavar="NAME=SPEC", help="a perturbed quantity (repeatable; "
                   "the forms of twip sweep)")
    add_realism_option(p)
    p.add_argument("--budget", type=positive_int, default=DEFAULT_BUDGET, metavar="N",
                   help="candidate controllers to evaluate (default %(default)s)")
    p.add_argument("-n", type=positive_int, default=256, metavar="N", help="robots per candidate (default 256)")
    p.add_argument("--validate", type=positive_int, default=2000, metavar="N", help="held-out robots (default 2000)")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default 0)")
    p.add_argument("--threads", type=positive_int, metavar="K", help="worker threads (default: all cores)")
    p.add_argument("--out", type=file_name("no file"), metavar="FILE", help="write the tuned controller (TOML) here")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_robot_option(p)
    p.set_defaults(func=tune)

    p = sub.add_parser("worst-case", help="search the worst robot inside the perturbations",
                       description="Search the support of the perturbations for the robot the scenario's "
                                   "controller handles worst, and check it on fresh noise.",
                       epilog=WORST_EPILOG, formatter_class=formatter)
    p.add_argument("scenario", metavar="SCENARIO", help="a scenario name (twip list)")
    p.add_argument("--perturb", action="append", metavar="NAME=SPEC", required=True,
                   help="a perturbed quantity (repeatable)")
    add_realism_option(p)
    p.add_argument("--budget", type=positive_int, default=400, metavar="N", help="robots to run (default 400)")
    p.add_argument("--metric", default=None, help="margin (default), time_to_fall, or a sweep metric such as "
                   "peak_current (a larger magnitude: worse)")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default 0)")
    p.add_argument("--confirm", type=positive_int, default=20, metavar="N",
                   help="fresh noise seeds the worst robot is run on (default 20)")
    p.add_argument("--threads", type=positive_int, metavar="K", help="robots run side by side (default: all cores)")
    add_controller_option(p)
    add_robot_option(p)
    p.set_defaults(func=worst_case)


def tune(args) -> int:
    from twip.cli.commands import check_output_file  # (commands imports this module)

    if args.out:  # before the search, not after it
        check_output_file("--out", args.out)
    name = scenario_name(args.scenario)
    sc = get_scenario(name, params=robot(None, args.robot), robot_file=args.robot)
    perturb = _perturb(args)
    if not perturb:
        print("note: no --perturb given, every robot is the same", file=sys.stderr)
    try:
        result = twip.tune(sc, perturb=perturb, realism=realism(args.realism, args.robot), n=args.n,
                           budget=args.budget, seed=args.seed, validate=args.validate, progress=not args.quiet,
                           threads=args.threads)
    except KeyboardInterrupt as stop:  # a second Ctrl-C, in the validation: the search's best is kept
        partial = getattr(stop, "partial", None)
        if partial is not None:
            print(f"interrupted before the held-out validation; the best candidate so far, not validated:\n"
                  f"{partial.summary()}", file=sys.stderr)
            if args.out:
                partial.save(args.out)
                print(f"wrote {args.out} (not validated)", file=sys.stderr)
        raise
    print(result.summary())
    if args.out:
        result.save(args.out)
        print(f"wrote {args.out}", file=sys.stderr)
    return 0


def worst_case(args) -> int:
    from twip.sweep import fits_in_memory

    if not fits_in_memory(args.confirm):  # its sweep would be refused only after the search
        raise UsageError(f"--confirm {args.confirm:,}: the metrics of that many runs do not fit the memory budget; "
                         "confirm on fewer noise seeds")
    name = scenario_name(args.scenario)
    sc = with_controller(get_scenario(name, params=robot(None, args.robot), robot_file=args.robot), args.controller)
    rig = realism(args.realism, args.robot)
    try:
        found = twip.worst_case(sc, perturb=_perturb(args), realism=rig, metric=args.metric, budget=args.budget,
                                seed=args.seed, threads=args.threads)
    except KeyboardInterrupt as stop:  # the robots tried so far: their worst, before the command ends
        if getattr(stop, "partial", None) is not None:
            print("interrupted: the worst of the robots tried so far (not confirmed on fresh noise):", file=sys.stderr)
            _print_worst(name, stop.partial, sc, file=sys.stderr)
        raise
    _print_worst(name, found, sc)
    check = found.confirm(args.confirm)
    print(f"on {check.n} fresh noise seeds: falls in {int(check.metrics['fell'].sum())}")
    return 0


def _print_worst(name, found, sc, file=None) -> None:
    nominal = sc.model.params.to_dict()
    print(f"{name}: worst of {found.evaluations} robots ({found.settings['metric']} = {found.metric:.4g}): "
          + ("falls" if found.fell else "stays up"), file=file)
    for k, v in found.params.items():
        rel = f" ({v / nominal[k] - 1:+.1%})" if k in nominal and nominal[k] else ""
        print(f"  {k:16s} {v:.6g}{rel}", file=file)
