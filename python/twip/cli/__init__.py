"""The `twip` command line.

    twip reproduce [--out DIR] [--quick]      the thesis's simulations, figures and tables
    twip simulate SCENARIO [...]              one scenario: metrics, a plot, an animation
    twip sweep SCENARIO -n N [...]            a Monte Carlo robustness sweep
    twip tune SCENARIO --perturb ... [...]    tune its controller over uncertain robots
    twip worst-case SCENARIO --perturb ...    the worst robot inside the perturbations
    twip list                                 the scenarios and what they are

Run `twip COMMAND --help` for the options and examples.
"""
from __future__ import annotations

import argparse
import os
import sys
import warnings

import twip
from twip.cli import design
from twip.cli.args import (Parser, UsageError, add_realism_option, add_robot_option, file_name, formatter, map_names,
                           positive_float, positive_int, seed)
from twip.report import DEFAULT_OUT

__all__ = ["build_parser", "main", "UsageError"]


REPRODUCE_EPILOG = """examples:
  twip reproduce                        everything into twip-report/ (about a minute on 2 cores)
  twip reproduce --out /tmp/r --quick   shorter runs, fewer samples: a smoke test
  twip reproduce --jobs 1               render the figures in this process only
  twip reproduce --format pdf           vector figures (svg or pdf); --dpi N for the PNGs

writes: one PNG per thesis figure analogue (fig4.2_slope-lqr-sim.png, ...), table5.1.png,
table5.2.png, sweep_*.png, fall_maps.png, two GIFs, report.md and report.json (the same
numbers: report.md is written from report.json's content)."""


SIMULATE_EPILOG = """examples:
  twip simulate slope-lqr
  twip simulate flat-fuzzy --option ki=-0.004 --plot flat-fuzzy.png
  twip simulate slope-lqr --param m_body=1.0 --nominal-controller   a heavier robot, same controller
  twip simulate slope-lqr-sim --option point=thesis --option t_final=20
  twip simulate circle-smc-fuzzy --option laps=1 --animate circle.gif
  twip simulate slope-lqr --realism thesis-like --plot real.png

--param sets a RobotParams field of the plant (SI units; `twip list` for scenarios);
--option a scenario keyword (a value ending in 'deg' is converted to radians)."""


SWEEP_EPILOG = """examples:
  twip sweep slope-lqr -n 2000 --perturb m_body=±20% --perturb com_height=±20%
  twip sweep flat-fuzzy -n 500 --perturb slope=0:5deg --perturb phi0=~2deg --plot sweep.png
  twip sweep slope-lqr-sim -n 5000 --perturb phi0=-1:1 --perturb phi_dot0=-20:20 \\
             --option t_final=4 --plot basin.png            (also writes basin-fall-map.png)
  twip sweep circle-smc -n 20 --perturb m_body=±20% --option laps=2
  twip sweep slope-lqr -n 1000 --perturb m_body=±20% --realism thesis-like

--perturb forms: name=±20% (relative), name=±0.01 (absolute), name=low:high (uniform),
name=~5% or name=~0.02 (normal, relative or absolute std). Names: RobotParams fields,
'slope', and the initial state phi0, phi_dot0, theta0, theta_dot0 (2-DOF scenarios), or
x0, y0, psi0, phi0, phi_dot0, v0, omega0 (3-DOF tracking scenarios: flat, no slope).
--realism runs every sample with sensors, motor driver and delay in the loop, each sample
with its own sensor noise (2-DOF scenarios only; a tracking scenario is refused).
A sweep is the same bit for bit on any number of threads and resumes from --checkpoint."""


def _command(name: str):
    """The command `name` of twip.cli.commands, imported when it runs: `twip --help` does not
    load what the commands need (the report, plotting, sweeps)."""
    def run(args):
        import importlib

        return getattr(importlib.import_module("twip.cli.commands"), name)(args)

    return run


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="twip", description=__doc__, formatter_class=formatter)
    parser.add_argument("--version", action="version", version=f"twip {twip.__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True

    p = sub.add_parser("reproduce", help="regenerate the thesis's simulations, figures and tables",
                       description="Run every thesis scenario, the Table 5.1/5.2 comparisons and robustness sweeps; "
                                   "write figures, report.md and report.json.",
                       epilog=REPRODUCE_EPILOG, formatter_class=formatter)
    p.add_argument("--out", default=DEFAULT_OUT, type=file_name(f"{DEFAULT_OUT}/"), metavar="DIR",
                   help=f"output folder (default: {DEFAULT_OUT}/)")
    p.add_argument("--quick", action="store_true", help="shorter runs, fewer laps and samples (for tests)")
    p.add_argument("--jobs", type=int, default=None, metavar="K",
                   help="processes rendering the figures (default: up to 2)")
    p.add_argument("--no-animations", action="store_true", help="skip the GIFs")
    p.add_argument("--format", choices=("png", "svg", "pdf"), default="png",
                   help="figure format: png (default), or svg / pdf for vector output")
    p.add_argument("--dpi", type=positive_float, default=None, metavar="N",
                   help="resolution of the PNGs (default 150; 60 with --quick)")
    p.set_defaults(func=_command("reproduce"))

    p = sub.add_parser("demo", help="the same as `reproduce --quick`",
                       description="An alias of `twip reproduce --quick`.", formatter_class=formatter,
                       epilog="example:\n  twip demo --out /tmp/demo")
    p.add_argument("--out", default=DEFAULT_OUT, type=file_name(f"{DEFAULT_OUT}/"), metavar="DIR",
                   help=f"output folder (default: {DEFAULT_OUT}/)")
    # Every option `reproduce` reads: a Namespace without format and dpi crashed `twip demo`.
    p.set_defaults(func=lambda a: _command("reproduce")(argparse.Namespace(out=a.out, quick=True, jobs=None,
                                                                            no_animations=False, format="png",
                                                                            dpi=None)))

    p = sub.add_parser("simulate", help="run one scenario, print its metrics, plot or animate it",
                       description="Run one named scenario and print its metrics (and the thesis's claims about it).",
                       epilog=SIMULATE_EPILOG, formatter_class=formatter)
    p.add_argument("scenario", metavar="SCENARIO", help="a scenario name (twip list)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="a RobotParams field of the plant (repeatable)")
    p.add_argument("--option", action="append", metavar="NAME=VALUE", help="a scenario option (repeatable)")
    p.add_argument("--nominal-controller", action="store_true",
                   help="design the controller for balanbot() even when --param changes the plant (model mismatch)")
    p.add_argument("--t-final", type=positive_float, metavar="SECONDS", help="override the run's duration")
    p.add_argument("--dt", type=positive_float, metavar="SECONDS", help="override the RK4 step (default 1 ms)")
    add_realism_option(p)
    p.add_argument("--plot", type=file_name("no figure"), metavar="OUT.png", help="write a figure of the run")
    p.add_argument("--animate", type=file_name("no animation"), metavar="OUT.gif",
                   help="write an animated GIF of the run")
    p.add_argument("--fps", type=positive_float, default=20.0, help="GIF frames per second (default 20)")
    p.add_argument("--json", action="store_true", help="print the metrics as JSON")
    add_robot_option(p)
    design.add_controller_option(p)
    p.set_defaults(func=_command("simulate"))

    p = sub.add_parser("sweep", help="Monte Carlo robustness sweep of one scenario",
                       description="Run N perturbed copies of a scenario (controller designed once for the nominal "
                                   "robot) and summarise the fall rate and the metrics.",
                       epilog=SWEEP_EPILOG, formatter_class=formatter)
    p.add_argument("scenario", metavar="SCENARIO", help="a scenario name (twip list)")
    p.add_argument("-n", type=positive_int, required=True, metavar="N", help="number of samples")
    p.add_argument("--perturb", action="append", metavar="NAME=SPEC", help="a perturbed quantity (repeatable)")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default 0)")
    p.add_argument("--checkpoint", metavar="DIR", help="write shards here and resume from them")
    p.add_argument("--threads", type=positive_int, metavar="K", help="worker threads (default: all cores)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="nominal robot change (repeatable)")
    p.add_argument("--option", action="append", metavar="NAME=VALUE", help="a scenario option (repeatable)")
    p.add_argument("--plot", type=file_name("no figure"), metavar="OUT.png", help="histograms (and a fall-rate map over the first two perturbations)")
    p.add_argument("--map", type=map_names, metavar="X,Y", help="the two perturbed quantities of the fall-rate map")
    add_realism_option(p)
    p.add_argument("--csv", type=file_name("no table"), metavar="OUT.csv", help="write the per-sample metrics")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_robot_option(p)
    design.add_controller_option(p)
    p.set_defaults(func=_command("sweep"))

    design.add_parsers(sub)

    p = sub.add_parser("robot", help="robot files: `twip robot init FILE` writes the default robot",
                       description="Write a robot file (TOML) to describe your own robot; pass it to other "
                                   "commands with --robot FILE.", formatter_class=formatter,
                       epilog="example:\n  twip robot init my.toml && twip simulate flat-lqr --robot my.toml")
    p.add_argument("action", choices=("init",), help="init: write the default robot (the Balanbot), commented")
    p.add_argument("file", metavar="FILE", help="the robot file to write")
    p.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    p.set_defaults(func=_command("robot_init"))

    p = sub.add_parser("export", help="write a scenario's tuned controller for a firmware (C, twip-ffi)",
                       description="Write DIR with twip-ffi's header, the scenario's controller as a C initialiser "
                                   "(firmware units with each conversion beside its value, or SI), an Arduino-style "
                                   "example and a Makefile whose `make check` replays a recorded closed-loop run "
                                   "through the C ABI.", formatter_class=formatter,
                       epilog="example:\n  twip export flat-lqr --out fw && make -C fw check")
    p.add_argument("scenario", metavar="SCENARIO", help="a scenario name (twip list)")
    p.add_argument("--out", required=True, metavar="DIR", help="the folder to write (made if missing; a folder "
                   "that holds files is refused without --force)")
    p.add_argument("--force", action="store_true", help="write into a folder that holds files, overwriting them")
    p.add_argument("--units", choices=("firmware", "si"), default="firmware",
                   help="firmware: degrees, encoder counts per loop, PWM counts, ms (default); si: SI throughout")
    p.add_argument("--replay-seconds", type=positive_float, default=20.0, metavar="S",
                   help="length of the recorded run that `make check` replays (default 20 s)")
    p.add_argument("--option", action="append", metavar="NAME=VALUE",
                   help="a scenario option (repeatable; e.g. circle-smc-fuzzy's sets=gaussian-5x5)")
    add_robot_option(p)
    design.add_controller_option(p)
    p.set_defaults(func=_command("export"))

    p = sub.add_parser("identify", help="fit a robot's parameters to a logged run (CSV)",
                       description="Fit the --free parameters of the robot (--robot FILE, default the Balanbot) to "
                                   "a logged run by multiple shooting, and print the estimates with their 95 % "
                                   "intervals and what the log could not determine (docs/sysid.md).",
                       formatter_class=formatter,
                       epilog="example:\n  twip identify run.csv --robot start.toml --free m_body,com_height,i_body,"
                              "mu_bearing --out fitted.toml --plot fit.png")
    p.add_argument("log", metavar="CSV", help="the log: a header row with t and any of "
                   "u, pwm, phi, phi_dot, theta, theta_dot, gyro, accel_x, accel_z, enc (SI units)")
    p.add_argument("--free", required=True, metavar="A,B,...", help="the parameters to fit (RobotParams fields, "
                   "'slope', and with a pwm log the driver's battery, bridge_drop, resistance, efficiency)")
    add_robot_option(p)
    p.add_argument("--slope", type=float, default=0.0, metavar="DEG", help="the ground's slope in the log [deg]")
    p.add_argument("--column", action="append", metavar="HEADER=SIGNAL", help="read column HEADER as SIGNAL "
                   "(repeatable), e.g. --column angle=phi")
    p.add_argument("--scale", action="append", metavar="SIGNAL=FACTOR", help="multiply SIGNAL into SI by a number "
                   "or a unit name (deg, deg/s, ms, us, mA, g), e.g. --scale phi=deg (repeatable)")
    p.add_argument("--signals", metavar="A,B,...", help="the logged outputs to compare (default: all present)")
    p.add_argument("--segment", type=positive_float, default=0.25, metavar="S",
                   help="multiple-shooting segment length [s] (default 0.25)")
    p.add_argument("--encoder-cpr", type=positive_float, metavar="N",
                   help="encoder counts per wheel turn, for an enc column (default: the --robot file's [sensors], "
                        "else 700)")
    p.add_argument("--imu-height", type=float, metavar="M",
                   help="the IMU's height above the axle [m], for accel columns (default: the --robot file's "
                        "[sensors], else 0.12)")
    p.add_argument("--imu-dlpf", type=positive_float, metavar="HZ",
                   help="the MPU-6050 DLPF bandwidth the gyro and accel columns were read through (one of "
                        "Table 2.2's: 260, 184, 94, 44/42, 21/20, 10, 5): the predictions pass through the same "
                        "filter (default: the columns are unfiltered)")
    p.add_argument("--imu-rate", type=positive_float, default=1000.0, metavar="HZ",
                   help="the IMU's sample rate with --imu-dlpf; the log must be sampled at it (default 1000)")
    p.add_argument("--gyro-bias-walk", type=positive_float, metavar="DPS",
                   help="the gyroscope's bias random walk [deg/s/sqrt(s)] with --imu-dlpf, which the intervals "
                        "take in (default: none)")
    p.add_argument("--friction", choices=("thesis-like",), help="the gearheads' friction law to start from: "
                   "thesis-like is the rig's (Realism.thesis_like().friction); free its level with --free ...,coulomb")
    p.add_argument("--friction-coulomb", type=positive_float, metavar="NM", help="the gearhead's Coulomb friction "
                   "per wheel [N m] (with --friction: its level, the breakaway scaled with it)")
    p.add_argument("--friction-breakaway", type=positive_float, metavar="NM",
                   help="the static (breakaway) torque per wheel [N m] (default: the law's, else the Coulomb level)")
    p.add_argument("--friction-stick", type=positive_float, metavar="RAD/S",
                   help="the stick band's half-width [rad/s] (default: the law's, else none)")
    p.add_argument("--backlash", type=positive_float, metavar="DEG", help="each gear train's free play at the wheel "
                   "[deg], declared (not fitted): the predictions carry the motors through it, as the rig does "
                   "(the thesis-like rig's: 1; default: none)")
    p.add_argument("--out", type=file_name("no file"), metavar="FILE", help="write the fitted robot as a robot file (TOML); not for a fit that "
                   "did not converge or does not explain the log, unless --force")
    p.add_argument("--force", action="store_true", help="write --out even when the fit did not converge or misfits")
    p.add_argument("--plot", type=file_name("no figure"), metavar="FILE", help="draw measured against predicted signals and residuals")
    p.set_defaults(func=_command("identify"))

    p = sub.add_parser("list", help="list the scenarios", description="List the named scenarios.",
                       formatter_class=formatter)
    p.set_defaults(func=_command("list_scenarios"))
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    prog = f"twip {args.command}"
    # Warnings (e.g. an absolute ± over half the nominal) as one line each, named by the command.
    show = warnings.showwarning
    warnings.showwarning = lambda message, *rest: print(f"{prog}: warning: {message}", file=sys.stderr)
    try:
        return args.func(args)
    except UsageError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except twip.TwipError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except ImportError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # `twip ... | head`: the reader left, nothing to report
        sys.stdout = open(os.devnull, "w")
        return 0
    except OSError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    finally:
        warnings.showwarning = show


if __name__ == "__main__":
    sys.exit(main())
