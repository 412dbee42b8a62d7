"""Controller files: a tuned controller's knobs in TOML (`twip tune --out tuned.toml`), put
into a scenario by `twip simulate/sweep/export --controller tuned.toml`.

    [controller]   scenario (the one it was tuned on) and family (lqr, fuzzy, pid, smc)
    [knobs]        the knob values (twip.design.knobs), in their units
    [tuning]       how it was tuned and what it did on held-out robots (informational)

The knobs, not the gains, are kept: an LQR is designed again for the robot it runs on.
"""
from __future__ import annotations

import math
import os
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
             "[knobs]"]
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
    return {"scenario": head.get("scenario"), "family": head["family"], "knobs": knobs}


def apply(scenario, path):
    """`scenario` with the controller of file `path` (its knobs on the scenario's controller,
    which must be of the file's family)."""
    spec = load(path)
    fam = knob_space.family_of(scenario.controller)
    if fam.name != spec["family"]:
        raise ControllerFileError(f"{path}: a {spec['family']} controller; {scenario.name} runs a {fam.name} "
                                  "controller")
    try:
        return knob_space.apply(scenario, spec["knobs"])
    except _core.InvalidParameterError as e:
        raise ControllerFileError(f"{path}: {e}") from None
