"""`twip export SCENARIO --out DIR`: the tuned controller of a scenario, for the firmware.

The folder holds
- `twip.h`: twip-ffi's C header;
- `twip_config.h` / `twip_config.c`: the controller's, tilt filter's and PWM feed-forward's
  configurations as C initialisers, in firmware units (or SI) with each conversion beside
  its value, and the macros of the family (`TWIP_INIT`, `TWIP_UPDATE`, ...);
- `example.c`: an Arduino-style `setup()` / `loop()` around the library;
- `replay_data.c` and `replay_check.c`: a closed-loop run of the `f32` controller on the
  `f32` plant, every update recorded, and a harness that replays its measurements and
  references through the C ABI and prints the largest difference from the recorded
  commands (`make check`, within 1e-5 relative);
- `Makefile`: builds twip-ffi's static library for the host with cargo (from `TWIP_SRC`),
  then `example` and `check`.
"""
from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from twip import _core, budget, checks, scenarios
from twip.firmware import header, units
from twip.robot_file import Robot

#: Largest relative difference `make check` accepts (of the largest recorded command).
REPLAY_TOLERANCE = 1e-5
#: Default length of the recorded run [s] (the scenario's own if shorter).
REPLAY_SECONDS = 20.0
#: Memory one recorded value takes at its peak [bytes]: as f32 and f64, and as C text
#: while the file is joined. Measured on flat-lqr, 400,000 updates: 153 MB of peak RSS
#: above a 10 s replay's, 383 bytes per update, 35 per value as `_check_replay_size`
#: counts them (11; the LQR records 8); kept generous for wider text.
REPLAY_BYTES_PER_VALUE = 64


@dataclass(frozen=True)
class Family:
    """A controller family of the C ABI: its names there and its sizes."""

    name: str
    config: str
    state: str
    reference: str
    nx: int
    nu: int
    pwm: str  # which PWM feed-forward its command needs: "pwm_lumped" or "pwm_wheel"


FAMILIES = {f.name: f for f in (
    Family("lqr", "TwipLqrConfig", "TwipLqr", "TwipSpeedRef", 4, 1, "pwm_lumped"),
    Family("fuzzy", "TwipFuzzyConfig", "TwipFuzzy", "TwipSpeedRef", 4, 1, "pwm_lumped"),
    Family("pid", "TwipPidConfig", "TwipPid", "TwipPlanarRef", 7, 2, "pwm_wheel"),
    Family("smc", "TwipSmcConfig", "TwipSmc", "TwipPlanarRef", 7, 2, "pwm_wheel"),
)}

UNITS = ("firmware", "si")


def _initialiser(layout, family, ctype, value, path, table, firmware, depth=1) -> str:
    """The C initialiser of `value` (a decoded struct, array or scalar) with comments."""
    pad = "    " * depth
    if isinstance(value, dict):
        items = []
        for f in layout[ctype]:
            sub = f"{path}.{f.name}" if path else f.name
            items.append(_item(layout, family, f.ctype, value[f.name], sub, table, firmware, depth, f".{f.name} = "))
        return "{\n" + "\n".join(items) + "\n" + "    " * (depth - 1) + "}"
    if isinstance(value, list):
        items = [_item(layout, family, ctype, v, f"{path}[{i}]", table, firmware, depth, "")
                 for i, v in enumerate(value)]
        return "{\n" + "\n".join(items) + "\n" + "    " * (depth - 1) + "}"
    raise TypeError(value)


def _item(layout, family, ctype, value, path, table, firmware, depth, label) -> str:
    pad = "    " * depth
    if isinstance(value, (dict, list)):
        return f"{pad}{label}{_initialiser(layout, family, ctype, value, path, table, firmware, depth + 1)},"
    if ctype == "int32_t":
        return f"{pad}{label}{int(value)},"
    expr, comment = units.scalar(family, path, value, table, firmware)
    return f"{pad}{label}{expr}," + (f"  /* {comment} */" if comment else "")


def _rows(name: str, ctype: str, data: np.ndarray) -> str:
    rows = ",\n".join("    {" + ", ".join(units.c_float(v) for v in row) + "}" for row in np.atleast_2d(data))
    return f"const {ctype} {name}[{len(data)}][{data.shape[1]}] = {{\n{rows}\n}};\n"


def _imu_macros(sensors) -> str:
    """The IMU's axes as `example.c` reads them: index (0 x, 1 y, 2 z) and sign of the axis
    that points forward, up, and along the axle (the pitch rate)."""
    lines = []
    for key, macro in (("imu_forward", "FORWARD"), ("imu_up", "UP"), ("imu_pitch", "PITCH")):
        index, sign = sensors.axis(key)
        lines.append(f"#define TWIP_IMU_{macro} {index}  /* {getattr(sensors, key)}: [sensors] {key} */")
        lines.append(f"#define TWIP_IMU_{macro}_SIGN {sign:d}.0f")
    return "\n".join(lines)


def _config_files(fam, config, tilt, pwm, table, firmware, layout, geometry, period, sensors) -> tuple:
    macros = "\n".join(f"#define {f.name} {units.c_float(f.value)}  /* {f.how} */" for f in table.values())
    layout_version = header.macros()["TWIP_ABI_VERSION"]
    h = f"""/* The exported configuration of a twip controller ({fam.name}). Written by `twip export`. */
#ifndef TWIP_CONFIG_H
#define TWIP_CONFIG_H

#include "twip.h"

/* The C ABI version this configuration was written for: a twip.h of another version lays
   the structs out otherwise (the library refuses the configuration: TWIP_ERR_ABI). */
#define TWIP_CONFIG_ABI_VERSION {layout_version}
#if TWIP_ABI_VERSION != TWIP_CONFIG_ABI_VERSION
#error "twip_config.c was written for another C ABI version than this twip.h: export it again with this twip"
#endif

/* Conversions: SI units per firmware unit. A value written `X * TWIP_FACTOR` is X in the
   firmware unit named beside it. */
{macros}

#define TWIP_FAMILY "{fam.name}"
#define TWIP_STATE {fam.state}
#define TWIP_CONFIG {fam.config}
#define TWIP_REFERENCE {fam.reference}
#define TWIP_INIT twip_{fam.name}_init
#define TWIP_UPDATE twip_{fam.name}_update
#define TWIP_RESET twip_{fam.name}_reset
#define TWIP_NX {fam.nx}
#define TWIP_NU {fam.nu}
#define TWIP_LOOP_PERIOD_S {units.c_float(period)}
#define TWIP_WHEEL_RADIUS {units.c_float(geometry[0])}  /* m */
#define TWIP_HALF_TRACK {units.c_float(geometry[1])}  /* m */
#define TWIP_PWM_MAX {int(round(pwm["motor"]["pwm_max"]))}  /* the duty's full scale, counts */
{_imu_macros(sensors)}

extern const {fam.config} twip_controller_config;
extern const TwipTiltConfig twip_tilt_config;
extern const TwipPwmConfig twip_pwm_config;
extern const float twip_encoder_cpr;

#endif
"""
    c = f"""/* The tuned configuration, as C initialisers. Written by `twip export`. */
#include <math.h>
#include "twip_config.h"

const {fam.config} twip_controller_config = {_initialiser(layout, fam.name, fam.config, config, "", table, firmware)};

const TwipTiltConfig twip_tilt_config = {_initialiser(layout, "tilt", "TwipTiltConfig", tilt, "", table, firmware)};

/* The command-to-PWM feed-forward of the motor driver. */
const TwipPwmConfig twip_pwm_config = {_initialiser(layout, "pwm", "TwipPwmConfig", pwm, "", table, firmware)};

const float twip_encoder_cpr = {units.c_float(table["TWIP_COUNTS_PER_RAD"].value * 2 * math.pi)};  /* counts per wheel turn */
"""
    return h, c


def _replay_files(fam, rec) -> tuple:
    n = len(rec["t"])
    data = f"""/* A closed-loop run of the f32 controller, every update: recorded by `twip export`. */
#include "replay_data.h"

const int replay_n = {n};
const float replay_t[{n}] = {{{", ".join(units.c_float(v) for v in rec["t"])}}};
{_rows("replay_y", "float", rec["y"])}{_rows("replay_ref", "float", rec["reference"])}{_rows("replay_u", "float", rec["u"])}"""
    h = f"""#ifndef REPLAY_DATA_H
#define REPLAY_DATA_H
extern const int replay_n;
extern const float replay_t[{n}];
extern const float replay_y[{n}][{fam.nx}];
extern const float replay_ref[{n}][{rec["reference"].shape[1]}];
extern const float replay_u[{n}][{fam.nu}];
#endif
"""
    return data, h


def _tracker_motor(controller):
    """The motor of a PID or sliding-mode tracker (None for the others, or without limits)."""
    if isinstance(controller, _core.PidTracker):
        return controller.motor
    if isinstance(controller, _core.SmcTracker):
        return controller.to_dict()["motor"]
    return None


def _check_one_motor(sc, robot) -> None:
    """Refuses a tracker built for another motor than the robot file's: its torque limits or
    PWM conversion and the exported PWM feed-forward would be two motors."""
    wanted = robot.controller_motor() if robot is not None else None
    motor = _tracker_motor(sc.controller)
    if wanted is not None and motor is not None and motor.to_dict() != wanted.to_dict():
        raise _core.InvalidParameterError(
            f"robot: the scenario's tracker assumes {motor!r}, the robot file {wanted!r}; the PWM feed-forward "
            "would drive another motor than the tracker's: build the scenario with "
            "motor=robot.controller_motor() (twip.scenarios.robot_options(name, robot))")


def _loop_period(sc) -> float:
    """The period [s] the scenario runs its controller at, as `Scenario.run` does: its
    `control_period` when it has one, else the controller's own; refused, by name, below the
    simulation step (the runner updates at most once per step)."""
    if sc.control_period is not None:
        name, period = "control_period", sc.control_period
    else:
        name, period = "controller.period", getattr(sc.controller, "period", sc.dt)
    if not period >= sc.dt:
        raise _core.InvalidParameterError(
            f"{name} = {period!r} s: the controller updates at most once per simulation step, so its period "
            f"must be at least the scenario's dt = {sc.dt!r} s (and a whole multiple of it)")
    return period


def _check_replay_size(sc, seconds: float, period: float) -> None:
    """The recorded run and its C text against the memory budget, before recording."""
    updates = seconds / period + 1
    values = 1 + 2 * len(sc.x0) + 2  # t, y, the reference (at most a state's width), u
    budget.check(f"export: the replay of {seconds:g} s ({updates:,.0f} controller updates)",
                 updates * values * REPLAY_BYTES_PER_VALUE, "pass a shorter replay_seconds")


def _check_out(out, force: bool) -> Path:
    """The folder to write, refused when it is empty text (it would be the current folder)
    or a folder that holds files, unless `force` (an edited example.c would be lost)."""
    if not isinstance(out, (str, os.PathLike)) or not str(out).strip():
        raise _core.InvalidParameterError(
            f"out = {out!r}: give the folder to write (an empty name would be the current folder; pass '.' "
            "with force=True (--force) to mean it)")
    out = Path(out)
    try:
        held = sorted(p.name for p in out.iterdir()) if out.is_dir() else []
    except OSError as e:  # a name too long, a folder not readable
        raise _core.InvalidParameterError(f"out = {str(out)!r}: cannot be read as a folder ({e.strerror})") from None
    if held and not force:
        held = ", ".join(held[:5])
        raise _core.InvalidParameterError(
            f"out = {str(out)!r}: the folder is not empty ({held}...); an export would overwrite what is there, an "
            "edited example.c included: give a new folder, or force=True (--force) to overwrite")
    return out


def _sensors_of(robot, units_: str):
    """The robot file's [sensors] (the Balanbot's without one, with a warning when firmware
    units depend on them: the encoder's counts per turn scale the speed gains)."""
    from twip.robot_file import Sensors

    if robot is not None and robot.sensors is not None:
        return robot.sensors
    sensors = Sensors()
    if robot is not None and units_ == "firmware":
        warnings.warn(f"the robot file has no [sensors] table: the firmware-unit gains assume the Balanbot's encoder "
                      f"({sensors.encoder_cpr:g} counts per wheel turn) and IMU axes; add [sensors] encoder_cpr, "
                      "imu_height, imu_forward, imu_up and imu_pitch (twip robot init writes them)", stacklevel=3)
    return sensors


def _tracker_factor(fam, config: dict, driver, controller):
    """(N m per PWM count, derivation) of the motor the sliding-mode gains are counted on:
    the tracker's own (`has_motor`), else the feed-forward driver's; None for other families.
    The tracker's motor is its f64 one: the configuration's went through f32, and a factor
    of f32-rounded parameters turned k_s3 = -2 counts into -1.99999988."""
    if fam.name != "smc":
        return None
    own = bool(config["has_motor"])
    m = (_tracker_motor(controller) or _core.DcMotor.from_dict(config["motor"])) if own else driver
    whose = "the tracker's own motor" if own else "the PWM driver's motor (the tracker has none)"
    return m.torque_per_count(), f"TWIP_NM_PER_PWM of {whose}, at {m.supply:g} V"


def export(scenario, out, robot=None, units_: str = "firmware", replay_seconds: float = REPLAY_SECONDS,
           source_dir: Optional[str] = None, force: bool = False) -> dict:
    """Writes the folder `out` for scenario `scenario` (a name or a Scenario) on `robot`
    (a `twip.Robot` from a robot file; default the Balanbot). The robot file's parameters
    throughout; when it has a [motor] or [driver] table, its motor for a tracker
    (`Robot.controller_motor()`: torque limits, PWM conversion) and for the PWM feed-forward
    with its driver: one motor throughout. Without either (and by default) the export is
    the simulation's two motors: a tracker keeps the thesis's (the GB37's data sheet at
    11.1 V, on which its PWM gains are counted) and the feed-forward drives
    `Realism.thesis_like()`'s driver (9.1 V after the bridge, efficiency 0.87), see
    docs/firmware.md. A Scenario whose tracker assumes another motor than the file's is
    refused. The file's [sensors] give the
    encoder's counts per turn (firmware units) and the IMU's axes (`example.c`). `out` must
    be a new or empty folder unless `force`. Returns a summary: the family, the number of
    recorded updates and the paths written."""
    if units_ not in UNITS:
        raise _core.InvalidParameterError(f"units = {units_!r}: must be one of {', '.join(UNITS)}")
    if isinstance(replay_seconds, bool) or not (isinstance(replay_seconds, (int, float)) and math.isfinite(replay_seconds)
                                                and replay_seconds > 0):
        raise _core.InvalidParameterError(f"replay_seconds = {replay_seconds!r}: must be a finite number > 0")
    checks.of_type("scenario", scenario, (str, scenarios.Scenario), "a scenario name or a twip.scenarios.Scenario")
    checks.of_type("robot", robot, (Robot, type(None)), "a twip.Robot (from a robot file) or None (the Balanbot)")
    out = _check_out(out, force)
    sensors = _sensors_of(robot, units_)
    params = robot.params if robot is not None else None
    if isinstance(scenario, str):
        sc = scenarios.get(scenario, params=params, **scenarios.robot_options(scenario, robot))
    else:
        sc = scenario
        _check_one_motor(sc, robot)
    realism = robot.realism() if robot is not None else _core.Realism.thesis_like()
    seconds = min(sc.t_final, replay_seconds)
    if seconds < sc.dt:  # else the core names it t_final, at the 32-bit build's rounding
        raise _core.InvalidParameterError(f"replay_seconds = {replay_seconds!r}: shorter than one step (dt = {sc.dt:g} s)")
    _check_replay_size(sc, seconds, _loop_period(sc))
    # The loop period the simulation runs (Scenario.control_period, if set) is the one
    # recorded and written as TWIP_LOOP_PERIOD_S.
    x0 = [float(v) for v in checks.real_entries("x0", sc.x0)]
    rec = _core.ffi_record(sc.model, sc.controller, x0, seconds, sc.dt, sc.reference,
                           control_period=sc.control_period)
    fam = FAMILIES[rec["family"]]
    parts = _core.ffi_firmware(realism, sc.model.params)
    if fam.pwm not in parts:
        raise _core.InvalidParameterError("the realism has no motor driver: the PWM feed-forward needs one")
    layout = header.structs()
    config = header.decode(layout, fam.config, rec["config"])
    tilt = header.decode(layout, "TwipTiltConfig", parts["tilt"])
    pwm = header.decode(layout, "TwipPwmConfig", parts[fam.pwm])
    period = config["period"]
    motor = _core.DcMotor.from_dict(pwm["motor"])
    table = units.factors(parts["encoder_cpr"] or sensors.encoder_cpr, period, motor.torque_per_count(),
                          _tracker_factor(fam, config, motor, sc.controller))
    p = sc.model.params
    h, c = _config_files(fam, config, tilt, pwm, table, units_ == "firmware", layout, (p.wheel_radius, p.half_track),
                         period, sensors)
    data, data_h = _replay_files(fam, rec)
    here = Path(__file__).parent / "templates"
    src = Path(source_dir or os.environ.get("TWIP_SRC") or _core.FFI_SOURCE_DIR).resolve()
    files = {
        "twip.h": _core.FFI_HEADER,
        "twip_config.h": h,
        "twip_config.c": c,
        "replay_data.c": data,
        "replay_data.h": data_h,
        "replay_check.c": (here / "replay_check.c").read_text().replace("@TOLERANCE@", repr(REPLAY_TOLERANCE)),
        "example.c": (here / "example.c").read_text(),
        "Makefile": (here / "Makefile").read_text().replace("@TWIP_SRC@", str(src)),
    }
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise _core.InvalidParameterError(f"out = {str(out)!r}: cannot create the folder ({e.strerror})") from None
    for name, text in files.items():
        try:
            (out / name).write_text(text)
        except OSError as e:  # e.g. a folder of that name (force=True)
            raise _core.InvalidParameterError(f"out = {str(out)!r}: cannot write {name} ({e.strerror})") from None
    return {"family": fam.name, "updates": len(rec["t"]), "outcome": rec["outcome"], "files": sorted(files),
            "out": str(out), "source": str(src), "source_found": (src / "Cargo.toml").is_file()}
