"""The command line's value parsers: numbers, name=value pairs, perturbations, robots,
scenario options. Each raises UsageError (one line, exit code 2) on bad input."""
from __future__ import annotations

import argparse
import math
import re
from typing import Optional

import twip
from twip import scenarios

class UsageError(Exception):
    """A bad command-line argument: reported on one line, exit code 2."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage dump) and exit code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def formatter(prog):
    return argparse.RawDescriptionHelpFormatter(prog, max_help_position=32)


def parse_value(text: str):
    """An option value: true/false, none, an int, a float (a trailing 'deg' converts degrees
    to radians), or else the string itself."""
    low = text.strip().lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    if low in ("none", "null"):
        return None
    try:
        return int(text)
    except ValueError:
        pass
    if _number(text) is None:
        return text
    return parse_number(text)  # a number: refused when not finite (nan would reach the core as a string)


def _number(text: str) -> Optional[float]:
    """The number `text` spells (a trailing 'deg' in radians), or None."""
    t = text.strip().replace("−", "-")
    scale = 1.0
    if t.lower().endswith("deg"):
        t, scale = t[:-3], math.pi / 180
    try:
        return float(t) * scale
    except ValueError:
        return None


def parse_number(text: str) -> float:
    value = _number(text)
    if value is None:
        raise UsageError(f"'{text}' is not a number")
    if not math.isfinite(value):
        raise UsageError(f"'{text}' is not a finite number")
    return value


def key_value(text: str, what: str):
    if "=" not in text:
        raise UsageError(f"malformed {what} '{text}': expected name=value")
    name, value = text.split("=", 1)
    name = name.strip()
    if not name or not value.strip():
        raise UsageError(f"malformed {what} '{text}': expected name=value")
    return name, value.strip()


def file_name(without: str):
    """The type of an option naming a file or folder: a path, not an empty one (`--robot "$ROBOT"`
    with the variable unset ran the Balanbot, and `--csv "$OUT"` wrote nothing, exit 0: the
    empty path was taken for no option). `without`: what leaving the option out gives."""
    def path(text: str) -> str:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"{text!r} is not a file name (leave the option out for {without})")
        return text

    return path


def add_robot_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", type=file_name("the Balanbot"), metavar="FILE",
                   help="the robot file (TOML; `twip robot init FILE` writes one) instead "
                   "of the Balanbot; its [motor] (else the Balanbot's at its [driver]'s battery) is the trackers' "
                   "motor, and with its [driver] goes into --realism thesis-like and twip export's PWM feed-forward")


def robot(param_args, robot_file=None) -> "twip.RobotParams":
    """The robot of --robot FILE (default RobotParams.balanbot()) with the --param changes."""
    base = twip.Robot.from_file(robot_file).params if robot_file else twip.RobotParams.balanbot()
    fields = list(twip.RobotParams.fields)
    changes = {}
    for text in param_args or []:
        name, value = key_value(text, "--param")
        if name not in fields:
            raise UsageError(f"unknown --param '{name}'; RobotParams fields: {', '.join(fields)}")
        try:
            changes[name] = float(parse_number(value))
        except UsageError:
            raise UsageError(f"malformed --param '{text}': '{value}' is not a number") from None
    return base.replace(**changes) if changes else base


def scenario_name(name: str) -> str:
    if name not in scenarios.names():
        raise UsageError(f"unknown scenario '{name}'; known: {', '.join(scenarios.names())}")
    return name


def scenario_options(name: str, option_args) -> dict:
    """--option name=value pairs, checked against the scenario's own keyword arguments."""
    known = scenarios.options(name)
    open_ended = "**" in known
    known.pop("**", None)
    options = {}
    for text in option_args or []:
        key, value = key_value(text, "--option")
        if key not in known and not open_ended:
            raise UsageError(f"unknown --option '{key}' for {name}; its options: {', '.join(known) or 'none'}")
        try:
            options[key] = parse_value(value)
        except UsageError as e:
            raise UsageError(f"--option {key}: {e}") from None
    return options


def get_scenario(name, params=None, controller_params=None, options=None, robot_file=None):
    """The scenario, with the motor of --robot FILE in a tracker (scenarios.robot_options)."""
    robot_options = scenarios.robot_options(name, twip.Robot.from_file(robot_file)) if robot_file else {}
    try:
        return scenarios.get(name, params=params, controller_params=controller_params,
                             **{**robot_options, **(options or {})})
    except TypeError as e:  # a wrong option type or name that reached the factory
        given = ", ".join(f"{k}={v!r}" for k, v in (options or {}).items())
        raise UsageError(f"{name}: an --option does not fit ({given}): {e}") from None


_PERCENT = re.compile(r"^(?:±|\+-|\+/-)\s*([0-9.eE+-]+)\s*(%?)\s*(deg)?$")


def perturbation(text: str):
    """--perturb name=±20% | name=±0.01 | name=low:high | name=~5% | name=~0.02 (normal);
    a trailing 'deg' gives degrees."""
    name, spec = key_value(text, "--perturb")
    spec = spec.replace(" ", "").replace("−", "-")
    normal = spec.startswith("~")
    body = spec[1:] if normal else spec
    if "%" in body and "deg" in body.lower():
        raise UsageError(f"malformed --perturb '{text}': a % is a share of the nominal, it takes no 'deg'")
    if ":" in body and not normal and body.split(":")[0].lower().endswith("deg") and not body.lower().endswith("deg"):
        raise UsageError(f"malformed --perturb '{text}': 'deg' on the low end only; write low:highdeg "
                         "(a trailing 'deg' gives both ends in degrees)")
    try:
        if ":" in body and not normal:
            low, high = body.split(":", 1)
            unit = "deg" if high.lower().endswith("deg") and not low.lower().endswith("deg") else ""
            return name, twip.Uniform(low=parse_number(low + unit), high=parse_number(high))
        if normal:
            if body.endswith("%"):
                return name, twip.Normal(rel=parse_number(body[:-1]) / 100)
            return name, twip.Normal(std=parse_number(body))
        m = _PERCENT.match(body)
        if m:
            value = parse_number(m.group(1) + (m.group(3) or ""))
            return name, (twip.Uniform(rel=value / 100) if m.group(2) else twip.Uniform(abs=value))
    except UsageError:
        pass
    raise UsageError(f"malformed --perturb '{text}': use name=±20%, name=±0.01, name=low:high, name=~5% or name=~0.02")


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not an integer") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{value} must be a positive integer")
    return value


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text} must be a positive number")
    return value


def map_names(text: str):
    """--map X,Y: two perturbed quantities."""
    names = [n.strip() for n in text.split(",")]
    if len(names) != 2 or not all(names):
        raise argparse.ArgumentTypeError(f"'{text}' is not two names X,Y (e.g. phi0,phi_dot0)")
    return names


def seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not an integer") from None
    if not 0 <= value < 2**64:
        raise argparse.ArgumentTypeError(f"{value} must be in [0, 2**64)")
    return value


#: --realism's values, for `twip simulate` and `twip sweep` alike.
REALISM_CHOICES = ("ideal", "thesis-like")


def add_realism_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--realism", choices=REALISM_CHOICES,
                   help="the thesis-like robot in the loop: sensors, driver, delay, gearhead friction and backlash; "
                        "its estimator first settles 2 s at rest at the start pitch, as a firmware does")


def realism(choice: Optional[str], robot_file=None):
    """The twip.Realism that --realism CHOICE names (None when not given); thesis-like
    takes the motor and driver of --robot FILE when the file has them."""
    if choice is None:
        return None
    if choice == "ideal":
        return twip.Realism()
    return twip.Robot.from_file(robot_file).realism() if robot_file else twip.Realism.thesis_like()


def stall_current(robot_file=None) -> Optional[float]:
    """One motor's stall current [A]: the [motor] table of --robot FILE, else the Balanbot's
    GB37Y3530 when no file is given (None: a file without a motor)."""
    from twip import robot_file as files

    if robot_file:
        return twip.Robot.from_file(robot_file).stall_current
    return files.BALANBOT_MOTOR["stall_current"]
