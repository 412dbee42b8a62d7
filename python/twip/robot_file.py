"""Robot files: a robot described in TOML, with its units and thesis symbols beside each value.

    [robot]                 every RobotParams field, SI units (see FIELDS)
    [motor]                 optional: the motor's data sheet, as DcMotor.from_data_sheet takes it
    [driver]                optional: battery, bridge drop, current limit (the motor driver)
    [sensors]               optional: encoder counts per wheel turn, the IMU's height and axes

`RobotParams.from_file(path)` reads the [robot] table; `twip.Robot.from_file(path)` reads
all three, and `Robot.realism()` is `Realism.thesis_like()` with the file's motor and driver
in place of the Balanbot's; `Robot.controller_motor()` is the motor a tracker built for the
robot assumes (`twip.scenarios.robot_options`). The plant takes the torque constant from
[robot]; [motor] sets the winding's resistance (unless [driver] names one) and the trackers' motor (a warning says when
the sheet's torque constant differs by more than 2 %). Without a [driver] table the driver
is `MotorDriver.thesis_like()`'s (the L298's drop, 1 mH, 2 A) with the sheet's resistance;
a [driver] table starts from the same driver (as the rig and `twip.identify` do) and sets what
it names (current_limit = 0: none). [sensors] sets the rig's encoder and IMU height
(`Robot.realism()`) and what `twip export` converts firmware units with and maps the IMU's axes
by; without it both are the Balanbot's (700 counts per turn, 0.12 m, x forward, z up, y the
pitch axis), and the export says so. `twip robot init FILE` writes the default robot, commented.
Errors name the file, the key and its line.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, Optional, Tuple

from twip import _core, checks, output

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python < 3.11
    import tomli as tomllib  # type: ignore[no-redef]

#: Every RobotParams field: (unit, thesis symbol, what it is).
FIELDS: Dict[str, Tuple[str, str, str]] = {
    "m_body": ("kg", "M_b", "body mass"),
    "m_wheels": ("kg", "M_w", "both wheels' mass"),
    "i_body": ("kg m^2", "I_b", "body pitch inertia about its centre of mass"),
    "i_wheels": ("kg m^2", "I_w", "both wheels' inertia about the axle"),
    "i_motor": ("kg m^2", "I_M", "both rotors' inertia (reflected as gear_ratio^2 i_motor)"),
    "gear_ratio": ("1", "eta", "gearbox ratio"),
    "torque_constant": ("N m/A", "tau_i", "torque per ampere at the motor shaft"),
    "wheel_radius": ("m", "r, R", "wheel radius"),
    "com_height": ("m", "l, c_z", "axle to the body's centre of mass"),
    "mu_bearing": ("N m s/rad", "mu_s", "viscous friction between body and wheels (both)"),
    "mu_ground": ("N m s/rad", "mu_g", "viscous rolling friction (both wheels)"),
    "half_track": ("m", "b", "half the distance between the wheels"),
    "i_body_roll": ("kg m^2", "I_xx", "body roll inertia"),
    "i_body_yaw": ("kg m^2", "I_zz", "body yaw inertia"),
    "i_wheel_diam": ("kg m^2", "I_wd", "one wheel's inertia about a diameter"),
    "g": ("m/s^2", "g", "gravity"),
}

#: The [motor] table: DcMotor.from_data_sheet's arguments (one motor).
MOTOR: Dict[str, Tuple[str, str]] = {
    "rated_voltage": ("V", "the data sheet's test voltage"),
    "no_load_rpm": ("rpm", "no-load speed at the gearbox output"),
    "no_load_current": ("A", "no-load current"),
    "stall_current": ("A", "stall current at the rated voltage"),
}

#: The [driver] table: MotorDriver's settings (per motor).
DRIVER: Dict[str, Tuple[str, str]] = {
    "battery": ("V", "battery voltage"),
    "bridge_drop": ("V", "H-bridge drop, source + sink"),
    "current_limit": ("A", "current limit per motor (0: none; absent: the thesis-like 2 A)"),
    "inductance": ("H", "winding inductance"),
    "resistance": ("ohm", "winding resistance (absent: the [motor] sheet's rated_voltage / stall_current, else "
                          "MotorDriver.thesis_like()'s)"),
    "efficiency": ("1", "gearbox efficiency: the share of the winding's torque that reaches the wheel "
                        "(absent: MotorDriver.thesis_like()'s, a 37 mm gearmotor's)"),
}

#: The [sensors] table: numbers, and the IMU's axes as "+x", "-y"...
SENSORS: Dict[str, Tuple[str, str]] = {
    "encoder_cpr": ("counts", "encoder counts per wheel turn (after the gearbox, all edges counted)"),
    "imu_height": ("m", "the IMU's height on the body's axis above the axle"),
    "imu_forward": ("axis", "the IMU axis (and sign) that points forward, e.g. \"+x\""),
    "imu_up": ("axis", "the IMU axis that points up the body, e.g. \"+z\""),
    "imu_pitch": ("axis", "the gyroscope axis whose rate is the pitch rate (along the axle), e.g. \"+y\""),
}
#: An IMU axis as the robot file writes it.
AXES = ("+x", "-x", "+y", "-y", "+z", "-z")

_TABLES = {"robot": FIELDS, "motor": MOTOR, "driver": DRIVER, "sensors": SENSORS}


@dataclass(frozen=True)
class Sensors:
    """A robot file's [sensors]: the encoder's counts per wheel turn, the IMU's height [m]
    on the body's axis and which of its axes (with sign) point forward, up and along the
    axle (the pitch rate). The defaults are the Balanbot's."""

    encoder_cpr: float = field(default_factory=lambda: _core.Realism.thesis_like().encoder_cpr)
    imu_height: float = field(default_factory=lambda: _core.Realism.thesis_like().imu.height)
    imu_forward: str = "+x"
    imu_up: str = "+z"
    imu_pitch: str = "+y"

    def axis(self, name: str) -> Tuple[int, int]:
        """(index 0..2, sign ±1) of the IMU axis `name` ("imu_forward", "imu_up", "imu_pitch")."""
        text = getattr(self, name)
        return "xyz".index(text[1]), (1 if text[0] == "+" else -1)


class RobotFileError(_core.InvalidParameterError):
    """A robot file that cannot be read: names the file, the key and the line."""


def _line_of(text: str, table: str, key: Optional[str]) -> int:
    """The 1-based line of `key` in `[table]` (of the table's header when key is None)."""
    current = None
    for number, line in enumerate(text.splitlines(), 1):
        header = re.match(r"\s*\[\s*([A-Za-z0-9_.-]+)\s*\]", line)
        if header:
            current = header.group(1)
            if key is None and current == table:
                return number
            continue
        # A bare, quoted ("m_body" = ...) or dotted (extra.x = ...) key.
        if current == table and key is not None and re.match(rf"\s*([\"']?){re.escape(key)}\1\s*[=.]", line):
            return number
    return 0


def _fail(path, text, table, key, message) -> RobotFileError:
    line = _line_of(text, table, key)
    where = f"[{table}]" + (f" {key}" if key else "")
    return RobotFileError(f"{path}:{line}: {where}: {message}")


#: Arguments of the core's constructors that hold a key of another table: the motor's
#: data sheet is read at the [driver]'s battery voltage.
_PASSED_ON = {"supply": ("driver", "battery")}


def _core_error(path, text, table: str, keys, error: Exception) -> RobotFileError:
    """A core constructor's error, under the key of the file its message names first (the
    one it is about: "invalid bridge_drop = 2: ... below the battery voltage")."""
    message = str(error)
    places = {**{key: (table, key) for key in keys}, **_PASSED_ON}
    named = [(m.start(), place) for name, place in places.items() if (m := re.search(rf"\b{name}\b", message))]
    return _fail(path, text, *(min(named)[1] if named else (table, None)), message)


def _numbers(path, text, data: dict, table: str, allowed: Dict[str, tuple]) -> Dict[str, float]:
    values = data.get(table, {})
    if not isinstance(values, dict):
        raise _fail(path, text, table, None, "must be a table")
    out = {}
    for key, value in values.items():
        if key not in allowed:
            raise _fail(path, text, table, key, f"unknown key; [{table}] takes {', '.join(allowed)}")
        if checks.finite_number(value) is None:
            raise _fail(path, text, table, key, f"{checks.shown(value)} is not a finite number")
        out[key] = checks.finite_number(value)
    return out


@dataclass(frozen=True)
class Robot:
    """A robot file's content: the parameters, and the motor and driver when it has them."""

    params: object
    motor: Optional[object] = None  # twip.DcMotor, from the [motor] data sheet
    driver: Optional[object] = None  # twip.MotorDriver
    stall_current: Optional[float] = None  # per motor [A], from the [motor] table
    sensors: Optional[Sensors] = None  # the [sensors] table

    @classmethod
    def from_file(cls, path) -> "Robot":
        return load(path)

    def controller_motor(self):
        """The motor the trackers built for this robot assume (their torque limits and their
        PWM-to-torque conversion), the one the PWM feed-forward of `twip export` drives: the
        [motor] table's (at the [driver]'s battery); without it, the Balanbot's GB37Y3530 at
        the [driver]'s battery; None without either (the scenarios' default motor)."""
        if self.motor is not None:
            return self.motor
        if self.driver is not None:
            return _core.DcMotor.gb37y3530(supply=self.driver.battery)
        return None

    def realism(self, **changes):
        """`Realism.thesis_like()` with this robot's motor driver, encoder and IMU height
        (those the file has)."""
        base = _core.Realism.thesis_like()
        if self.driver is not None:
            base = base.replace(motor=self.driver)
        if self.sensors is not None:
            base = base.replace(encoder_cpr=self.sensors.encoder_cpr,
                                imu=base.imu.replace(height=self.sensors.imu_height))
        return base.replace(**changes) if changes else base


def load(path) -> Robot:
    """Reads a robot file (see the module docs)."""
    path = Path(path)
    try:
        text = checks.read_text_file(path)
    except OSError as e:
        raise RobotFileError(f"{path}: cannot read the robot file ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise RobotFileError(f"{path}: not a text file (byte {e.start} is not UTF-8; a robot file is TOML)") from None
    if text is None:
        raise RobotFileError(f"{path}: more than {checks.MAX_TEXT_FILE:,} characters; a robot file is a few kB of TOML "
                             "(`twip robot init FILE` writes one)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise RobotFileError(f"{path}: not valid TOML: {e}") from None
    except ValueError as e:  # an integer of more than 4300 digits (Python's limit)
        raise RobotFileError(f"{path}: not a robot file: {e}") from None
    for table in data:
        if table not in _TABLES:
            raise _fail(path, text, table, None, f"unknown table; a robot file has {', '.join(_TABLES)}")
    if "robot" not in data:
        raise RobotFileError(f"{path}:0: the [robot] table is missing")
    given = _numbers(path, text, data, "robot", FIELDS)
    missing = [k for k in FIELDS if k not in given]
    if missing:
        raise _fail(path, text, "robot", None, f"missing {', '.join(missing)} (every field carries a unit: "
                    "`twip robot init FILE` writes them all)")
    try:
        params = _core.RobotParams.from_dict(given)
    except _core.InvalidParameterError as e:
        raise _core_error(path, text, "robot", FIELDS, e) from None
    motor = stall = None
    if "motor" in data:
        sheet = _numbers(path, text, data, "motor", MOTOR)
        absent = [k for k in MOTOR if k not in sheet]
        if absent:
            raise _fail(path, text, "motor", None, f"missing {', '.join(absent)}")
        supply = _numbers(path, text, data, "driver", DRIVER).get("battery", 11.1)
        try:
            motor = _core.DcMotor.from_data_sheet(gear_ratio=params.gear_ratio, supply=supply, **sheet)
        except _core.InvalidParameterError as e:
            raise _core_error(path, text, "motor", MOTOR, e) from None
        stall = sheet["stall_current"]
        _check_torque_constant(path, params, motor)
    driver = None
    if "driver" in data:
        settings = _numbers(path, text, data, "driver", DRIVER)
        if settings.get("current_limit") == 0.0:
            settings["current_limit"] = None
        if motor is not None:  # the sheet's, unless the table names one (a fitted value, `twip identify`)
            settings.setdefault("resistance", motor.resistance)
        if "battery" in settings:  # the firmware's feed-forward assumes the file's battery
            settings["assumed_battery"] = settings["battery"]
        try:
            driver = _core.MotorDriver.thesis_like().replace(**settings)
        except _core.InvalidParameterError as e:
            raise _core_error(path, text, "driver", DRIVER, e) from None
    elif motor is not None:
        driver = _core.MotorDriver.thesis_like().replace(resistance=motor.resistance)
    from twip.plausibility import warn_if_implausible

    warn_if_implausible(params, where=str(path))
    sensors = _sensors(path, text, data) if "sensors" in data else None
    return Robot(params=params, motor=motor, driver=driver, stall_current=stall, sensors=sensors)


def _sensors(path, text, data) -> Sensors:
    """The [sensors] table, checked key by key."""
    values = data["sensors"]
    if not isinstance(values, dict):
        raise _fail(path, text, "sensors", None, "must be a table")
    out = {}
    for key, value in values.items():
        if key not in SENSORS:
            raise _fail(path, text, "sensors", key, f"unknown key; [sensors] takes {', '.join(SENSORS)}")
        if SENSORS[key][0] == "axis":
            if value not in AXES:
                raise _fail(path, text, "sensors", key, f"{checks.shown(value)} is not an axis; write one of {', '.join(AXES)}")
        elif checks.finite_number(value) is None:
            raise _fail(path, text, "sensors", key, f"{checks.shown(value)} is not a finite number")
        elif key == "encoder_cpr" and value <= 0:
            raise _fail(path, text, "sensors", key, f"{value!r}: counts per wheel turn must be > 0")
        elif key == "imu_height" and not 0 <= value <= checks.MAX_IMU_HEIGHT:  # 120 would be millimetres
            raise _fail(path, text, "sensors", key, f"{value!r} m is outside 0..{checks.MAX_IMU_HEIGHT:g} m "
                        "(the IMU's height above the axle, in metres)")
        out[key] = value if SENSORS[key][0] == "axis" else float(value)
    sensors = Sensors(**out)
    try:  # the rig's own bounds (encoder_cpr >= 1), here rather than at Robot.realism()
        Robot(params=None, sensors=sensors).realism()
    except _core.InvalidParameterError as e:
        raise _core_error(path, text, "sensors", SENSORS, e) from None
    axes = [getattr(sensors, k)[1] for k in ("imu_forward", "imu_up", "imu_pitch")]
    if len(set(axes)) != 3:
        raise _fail(path, text, "sensors", None, f"imu_forward, imu_up and imu_pitch must be three different axes, "
                    f"got {sensors.imu_forward}, {sensors.imu_up}, {sensors.imu_pitch}")
    _check_pitch_sign(path, text, sensors)
    return sensors


def _check_pitch_sign(path, text, sensors) -> None:
    """Warns when imu_pitch is not up x forward. An IMU's gyro and accelerometer share its
    right-handed axes (the MPU-6050's), and leaning forward turns the up axis towards the
    forward one, a positive rate about up x forward; a pitch axis of the other sign was taken
    as given, and `twip export`'s tilt filter then ran its gyro against its accelerometer."""
    (f, f_sign), (u, u_sign) = sensors.axis("imu_forward"), sensors.axis("imu_up")
    sign = f_sign * u_sign * (1 if (f - u) % 3 == 1 else -1)  # e_u x e_f = +-e_(the third axis)
    expected = ("+" if sign > 0 else "-") + "xyz"[3 - f - u]
    if sensors.imu_pitch != expected:
        from twip.plausibility import ImplausibleRobotWarning

        warnings.warn(f"{path}:{_line_of(text, 'sensors', 'imu_pitch')}: [sensors] imu_pitch = "
                      f"\"{sensors.imu_pitch}\", but with imu_forward = \"{sensors.imu_forward}\" and imu_up = "
                      f"\"{sensors.imu_up}\" leaning forward is a positive rate about up x forward, \"{expected}\", on "
                      "a right-handed IMU (the MPU-6050's gyro and accelerometer share its axes); with the other "
                      "sign the firmware's tilt filter runs its gyro against its accelerometer",
                      ImplausibleRobotWarning, stacklevel=4)


#: How far [robot]'s torque_constant may be from the [motor] sheet's before a warning: the
#: sheet's own rounding (the Balanbot's file: 0.05 %) is well inside.
TORQUE_CONSTANT_TOLERANCE = 0.02


def _check_torque_constant(path, params, motor) -> None:
    """Warns when the file's torque constant and its motor's data sheet disagree: the plant
    uses [robot]'s torque_constant (its driver takes only the sheet's resistance) while a
    tracker's motor is the sheet's, so a sheet of another motor would otherwise pass unnoticed."""
    sheet = motor.to_dict()["k_t"]
    if abs(sheet / params.torque_constant - 1) > TORQUE_CONSTANT_TOLERANCE:
        warnings.warn(f"{path}: [robot] torque_constant = {params.torque_constant!r} N m/A, but the [motor] data "
                      f"sheet gives {sheet:.6g} N m/A (from its rated_voltage, no_load_rpm, no_load_current and stall_current); the "
                      "plant uses torque_constant, the trackers' motor the sheet's", stacklevel=3)


def _format(value: float) -> str:
    return repr(float(value))


def dumps(params, sheet: Optional[dict] = None, driver: Optional[dict] = None,
          sensors: Optional[dict] = None) -> str:
    """A robot file's text: every field with its unit, symbol and meaning in a comment."""
    lines = ["# A twip robot file (TOML). SI units; the thesis's symbol in brackets.", "", "[robot]"]
    values = params.to_dict()
    for key, (unit, symbol, what) in FIELDS.items():
        lines.append(f"{key} = {_format(values[key])}".ljust(36) + f"# [{unit}] ({symbol}) {what}")
    for name, table, content in (("motor", MOTOR, sheet), ("driver", DRIVER, driver), ("sensors", SENSORS, sensors)):
        if content:
            lines += ["", f"[{name}]"]
            for key, (unit, what) in table.items():
                given = content.get(key)
                if given is None and table is DRIVER and key == "current_limit" and key in content:
                    given = 0.0  # no limit (MotorDriver's None); left out, it read back as the 2 A default
                if given is not None:
                    value = f'"{given}"' if unit == "axis" else _format(given)
                    lines.append(f"{key} = {value}".ljust(36) + f"# [{unit}] {what}")
    return "\n".join(lines) + "\n"


def save(params, path, sheet: Optional[dict] = None, driver: Optional[dict] = None,
         sensors: Optional[dict] = None) -> None:
    output.write_text(path, dumps(params, sheet, driver, sensors))


#: The Balanbot's motor (GB37Y3530-12V-251R, Table 2.3) and its L298 driver (thesis-like).
BALANBOT_MOTOR = {"rated_voltage": 12.0, "no_load_rpm": 251.0, "no_load_current": 0.35, "stall_current": 7.0}


def balanbot_driver() -> dict:
    d = _core.MotorDriver.thesis_like()
    return {"battery": d.battery, "bridge_drop": d.bridge_drop, "current_limit": d.current_limit or 0.0,
            "inductance": d.inductance, "efficiency": d.efficiency}


def init(path) -> None:
    """Writes the default robot (the Balanbot), its motor and driver, commented."""
    from dataclasses import asdict

    save(_core.RobotParams.balanbot(), path, BALANBOT_MOTOR, balanbot_driver(), asdict(Sensors()))
