"""Controller files: a tuned controller's knobs in TOML (`twip tune --out tuned.toml`), put
into a scenario by `twip simulate/sweep/export --controller tuned.toml`.

    [controller]   scenario (the one it was tuned on) and family (lqr, fuzzy, pid, smc)
    [robot]        the robot the controller was built for (RobotParams fields)
    [knobs]        the knob values (twip.design.knobs), in their units
    [tuning]       how it was tuned and what it did on held-out robots (informational)

The knobs, not the gains, are kept: an LQR is designed again from them. So a file is refused
on another scenario or another robot, where the same knobs would build another controller
than the one tuned and validated.
"""
from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

from twip import _core, checks, output
from twip.design import knobs as knob_space

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python < 3.11
    import tomli as tomllib  # type: ignore[no-redef]


class ControllerFileError(_core.InvalidParameterError):
    """A controller file that cannot be read or does not fit the scenario: names the file."""


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return '"' + str(v).replace("\\", "\\\\").replace('"', '\\"') + '"'


def save(path, tuning) -> None:
    """Writes `tuning` (a twip.design.Tuning) to `path`."""
    fam = knob_space.family_of(tuning.controller)
    units = {k.name: k.unit for k in fam.knobs}
    lines = ["# A controller tuned by twip (twip tune); use it with --controller FILE.",
             "[controller]", f"scenario = {_value(tuning.scenario.name)}", f"family = {_value(fam.name)}", "",
             "[robot]"]
    lines += [f"{k} = {_value(float(v))}" for k, v in design_robot(tuning.controller).to_dict().items()]
    lines += ["", "[knobs]"]
    for name, v in tuning.knobs.items():
        lines.append(f"{name} = {_value(float(v))}  # {units[name]}")
    lines += ["", "[tuning]"]
    info = dict(tuning.settings)
    for label, result in (("validation", tuning.validation), ("baseline", tuning.baseline)):
        if result is not None:
            info[f"{label}_fall_rate"] = float(result.fall_rate)
            info[f"{label}_robots"] = int(result.n)
    info["interrupted"] = bool(tuning.interrupted)
    for key, v in info.items():
        if isinstance(v, float) and not math.isfinite(v):
            continue
        if key == "ranges":
            v = [x for pair in v for x in pair]  # flat: low, high per knob
        lines.append(f"{key} = {_value(v)}")
    output.write_text(path, "\n".join(lines) + "\n")


def load(path) -> dict:
    """{"scenario", "family", "knobs"} of a controller file."""
    path = Path(checks.of_type("path", path, (str, os.PathLike), "a file path"))
    try:
        text = checks.read_text_file(path)  # TOML is UTF-8, whatever the locale
    except OSError as e:
        raise ControllerFileError(f"{path}: cannot read the controller file ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise ControllerFileError(f"{path}: not UTF-8 text, as TOML is ({e.reason} at byte {e.start})") from None
    if text is None:
        raise ControllerFileError(f"{path}: more than {checks.MAX_TEXT_FILE:,} characters; a controller file is "
                                  "a few lines of TOML (twip tune --out FILE writes one)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ControllerFileError(f"{path}: not valid TOML ({e})") from None
    except ValueError as e:  # an integer of more than 4300 digits (Python's limit)
        raise ControllerFileError(f"{path}: not a controller file ({e})") from None
    head, values = data.get("controller"), data.get("knobs")
    if not isinstance(head, dict) or "family" not in head or not isinstance(values, dict) or not values:
        raise ControllerFileError(f"{path}: a controller file needs [controller] with family = ... and [knobs]")
    for name, v in values.items():
        if checks.finite_number(v) is None:  # 10**400 was a bare OverflowError
            raise ControllerFileError(f"{path}: knob {name} = {checks.shown(v)} must be a finite number")
    knobs = {k: float(v) for k, v in values.items()}
    robot = data.get("robot")
    if robot is not None:
        fields = _core.RobotParams.fields
        if not isinstance(robot, dict) or not robot:
            raise ControllerFileError(f"{path}: [robot] must be a table of RobotParams fields")
        for name, v in robot.items():
            if name not in fields:
                raise ControllerFileError(f"{path}: [robot] {name}: not a RobotParams field ({', '.join(fields)})")
            if checks.finite_number(v) is None:
                raise ControllerFileError(f"{path}: [robot] {name} = {checks.shown(v)} must be a finite number")
        robot = {k: float(v) for k, v in robot.items()}
    return {"scenario": head.get("scenario"), "family": head["family"], "robot": robot, "knobs": knobs}


def design_robot(controller):
    """The RobotParams `controller` was built for: its model's (a PidTracker has none: the
    robot of its pickle)."""
    model = getattr(controller, "model", None)
    return model.params if model is not None else controller.__reduce__()[1][0]


def apply(scenario, path):
    """`scenario` with the controller of file `path` (its knobs on the scenario's controller,
    which must be of the file's family)."""
    spec = load(path)
    fam = knob_space.family_of(scenario.controller)
    if fam.name != spec["family"]:
        raise ControllerFileError(f"{path}: a {spec['family']} controller; {scenario.name} runs a {fam.name} "
                                  "controller")
    if spec["scenario"] is not None and spec["scenario"] != scenario.name:
        raise ControllerFileError(f"{path}: tuned on {spec['scenario']}; this is {scenario.name}, whose run its "
                                  "knobs were not tuned for (tune it on this scenario)")
    if spec["robot"] is not None:
        here = design_robot(scenario.controller).to_dict()
        off = [f"{k} = {v:g} (tuned: {spec['robot'][k]:g})" for k, v in here.items()
               if k in spec["robot"] and v != spec["robot"][k]]
        if off:
            raise ControllerFileError(f"{path}: tuned for another robot than this scenario's controller is built for: "
                                      + ", ".join(off) + "; run it with the robot it was tuned for (--robot FILE)")
    try:
        built = knob_space.apply(scenario, spec["knobs"])
    except _core.InvalidParameterError as e:
        raise ControllerFileError(f"{path}: {e}") from None
    if spec["robot"] is None:
        warnings.warn(f"{path}: names no [robot] (written by an older twip): its knobs are applied to this "
                      "scenario's robot unchecked", stacklevel=2)
    return built
