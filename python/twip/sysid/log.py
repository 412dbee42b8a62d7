"""A logged run of a 2-DOF robot: any subset of its signals on one time base, in SI units."""
from __future__ import annotations

import csv
import math
import os
import re
import warnings
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, Mapping, Optional, Union

import numpy as np

from twip import _core, checks, output
from twip.sysid import units

#: The signals a log may hold, with their units (the constructor's keywords).
SIGNALS: Dict[str, str] = {
    "u": "A (the lumped motor current of SlopeModel)",
    "pwm": "driver counts (the duty both motors get)",
    "phi": "rad (body pitch)",
    "phi_dot": "rad/s",
    "theta": "rad (wheel angle, absolute)",
    "theta_dot": "rad/s",
    "gyro": "rad/s (pitch rate as the gyro reads it)",
    "accel_x": "m/s^2 (specific force along the body's forward axis)",
    "accel_z": "m/s^2 (specific force along the body's axis, up)",
    "enc": "counts (the wheels' mean angle relative to the body)",
}
#: Unit names `scale=` understands, as SI units per logged unit.
UNIT_NAMES = {"deg": math.pi / 180, "degrees": math.pi / 180, "deg/s": math.pi / 180, "rad": 1.0, "ms": 1e-3, "us": 1e-6,
              "mA": 1e-3, "g": 9.80665}


class LogError(_core.InvalidParameterError):
    """A log that cannot be used as given: the message names the column, row or name."""


@dataclass(frozen=True)
class RunLog:
    """Signals on the time base `t` [s]; each given signal has one value per sample."""

    t: np.ndarray
    u: Optional[np.ndarray] = None
    pwm: Optional[np.ndarray] = None
    phi: Optional[np.ndarray] = None
    phi_dot: Optional[np.ndarray] = None
    theta: Optional[np.ndarray] = None
    theta_dot: Optional[np.ndarray] = None
    gyro: Optional[np.ndarray] = None
    accel_x: Optional[np.ndarray] = None
    accel_z: Optional[np.ndarray] = None
    enc: Optional[np.ndarray] = None
    slope: float = 0.0
    #: Columns of a CSV that were not signals (kept out of the fit).
    ignored: tuple = field(default=(), compare=False)

    def __post_init__(self):
        t = _column("t", self.t)
        if len(t) < 2:
            raise LogError(f"t: {len(t)} samples; a log needs at least 2")
        steps = np.diff(t)
        bad = np.flatnonzero(~(steps > 0))
        if len(bad):
            row = int(bad[0]) + 1
            raise LogError(f"t: not increasing at row {row} (t = {float(t[row - 1])!r} then {float(t[row])!r})")
        object.__setattr__(self, "t", t)
        for name in SIGNALS:
            value = getattr(self, name)
            if value is None:
                continue
            column = _column(name, value)
            if len(column) != len(t):
                raise LogError(f"{name}: {len(column)} values for {len(t)} samples of t")
            object.__setattr__(self, name, column)
        slope = checks.real("slope", self.slope)
        if not abs(slope) < math.pi / 2:  # a robot cannot stand on a wall or beyond
            raise LogError(f"slope = {slope!r} rad ({math.degrees(slope):.4g} deg): must be within "
                           "(-pi/2, pi/2) rad, +-90 deg")
        object.__setattr__(self, "slope", slope)
        if not self.signals():
            raise LogError("the log has no signal besides t: give at least one of " + ", ".join(SIGNALS))
        problem = units.problems(t, self.signals())
        if problem:
            raise LogError(problem)

    def signals(self) -> Dict[str, np.ndarray]:
        """The signals present, by name."""
        return {n: getattr(self, n) for n in SIGNALS if getattr(self, n) is not None}

    def __len__(self) -> int:
        return len(self.t)

    def slice(self, start: float, stop: float) -> "RunLog":
        """The samples with start <= t < stop."""
        keep = (self.t >= start) & (self.t < stop)
        return RunLog(self.t[keep], slope=self.slope, **{n: v[keep] for n, v in self.signals().items()})

    def with_signals(self, **changes) -> "RunLog":
        """A copy with signals replaced (None removes one)."""
        values = {**self.signals(), **changes}
        return RunLog(self.t, slope=self.slope, **{n: v for n, v in values.items() if v is not None})

    @classmethod
    def from_csv(cls, path: Union[str, Path], slope: float = 0.0, columns: Optional[Mapping[str, str]] = None,
                 scale: Optional[Mapping[str, Union[float, str]]] = None) -> "RunLog":
        """Reads a CSV with a header row. `columns` maps header names to signal names
        ({"angle": "phi"}); `scale` multiplies a signal into SI, by a number or a unit name
        ({"phi": "deg"}, {"u": 1e-3}). Columns that are neither t nor a signal are ignored."""
        checks.of_type("path", path, (str, os.PathLike), "a file path (str or Path)")
        checks.of_type("columns", columns, (Mapping, type(None)), "a dict {header: signal name} or None")
        checks.of_type("scale", scale, (Mapping, type(None)), "a dict {signal: number or unit name} or None")
        columns, scale = dict(columns or {}), dict(scale or {})
        path = Path(path)
        try:
            # utf-8-sig: a spreadsheet's byte order mark is not part of the first header.
            with path.open(newline="", encoding="utf-8-sig") as f:
                reader = csv.reader(_lines(f, path))
                try:
                    header = next(reader, None)
                    if header is None:
                        raise LogError(f"{path}: empty file")
                    header = [h.strip() for h in header]
                    names = _names(path, header, columns)
                    data = _read(path, reader, header, names)
                except csv.Error as e:  # e.g. a cell beyond the csv module's field size limit
                    raise LogError(f"{path}: line {reader.line_num}: {e}; a log is a CSV of numbers") from None
        except OSError as e:
            raise LogError(f"path = {str(path)!r}: {e.strerror}") from None
        except UnicodeDecodeError as e:
            raise LogError(f"path = {str(path)!r}: not a text file (byte {e.start} is not UTF-8; a log is CSV)") from None
        data = {name: values * _factor(name, scale.get(name, 1.0)) for name, values in data.items()}
        for name in scale:
            if name not in data:
                raise LogError(f"scale: {name!r} is not a column of the log")
        ignored = tuple(h for h, n in zip(header, names) if n != "t" and n not in SIGNALS)
        _warn_near_misses(path, ignored, data)
        return cls(data.pop("t"), slope=slope, ignored=ignored, **data)

    def to_csv(self, path: Union[str, Path]) -> None:
        """Writes t and the signals present, in SI, with a header."""
        names = ["t", *self.signals()]
        table = np.column_stack([self.t, *self.signals().values()])
        with output.writing(path) as f:
            np.savetxt(f, table, delimiter=",", header=",".join(names), comments="", fmt="%.17g")


#: The longest line a log may have [characters]: a row of numbers is a few hundred; a
#: longer one (a file without line breaks) is refused before the csv module holds it whole.
MAX_LINE = 1 << 20
#: Rows read between checks of the columns' size against the memory budget.
BUDGET_ROWS = 1 << 16


def _lines(f, path):
    """The file's lines, each at most MAX_LINE characters."""
    number = 0
    while True:
        line = f.readline(MAX_LINE + 1)
        if not line:
            return
        number += 1
        if len(line) > MAX_LINE:
            raise LogError(f"{path}: line {number} is longer than {MAX_LINE:,} characters: not a log of numbers "
                           "(a row of a log is a few hundred)")
        yield line


def _names(path, header, columns) -> list:
    """The signal name each header is read as, checked: each name once, t among them."""
    for h in columns:
        if h not in header:
            raise LogError(f"columns: {h!r} is not a column of {path} (columns: {', '.join(header)})")
    names = [columns.get(h, h) for h in header]
    for target in columns.values():
        if target != "t" and target not in SIGNALS:
            raise LogError(f"columns: {target!r} is not a signal (signals: t, {', '.join(SIGNALS)})")
    given: Dict[str, str] = {}
    for h, name in zip(header, names):
        if name in given and (name == "t" or name in SIGNALS):
            raise LogError(f"{path}: columns {given[name]!r} and {h!r} are both read as {name!r}; map one of "
                           f"them to another name or leave it out (columns=, --column)")
        given[name] = h
    if "t" not in names:
        sep = next((c for c in ";\t|" if len(header) == 1 and c in header[0]), None)
        if sep is not None:  # a spreadsheet's export in a locale that writes decimal commas
            raise LogError(f"{path}: the header {header[0]!r} is one column: the file is separated by {sep!r}, not "
                           "commas; save it as CSV with commas between the columns and points in the numbers")
        near = [h for h in header if _bare(h) == "t"]
        way = f"columns={{{near[0]!r}: 't'}} (--column '{near[0]}=t')" if near else "columns={...: 't'}"
        raise LogError(f"{path}: no 't' column (columns: {', '.join(header)}); map one with {way}")
    return names


def _bare(header: str) -> str:
    """A header as the signal it likely names: lower case, without a unit ("Gyro (rad/s)": gyro)."""
    return re.sub(r"\s*[\[(].*[\])]\s*$", "", header).strip().lower()


def _warn_near_misses(path, ignored, read) -> None:
    """Warns of a column left out that is named like a signal the log does not have ("Gyro",
    "phi [rad]"): names are exact, and such a column was dropped without a word."""
    inputs = {"u", "pwm"}
    for h in ignored:
        name = _bare(h)
        if name in SIGNALS and name not in read and not (name in inputs and inputs & set(read)):
            warnings.warn(f"{path}: column {h!r} is not read: signal names are exact ({', '.join(SIGNALS)}); to read "
                          f"it as {name}, give columns={{{h!r}: {name!r}}} (--column '{h}={name}')", stacklevel=3)


def _read(path, reader, header, names) -> Dict[str, np.ndarray]:
    """The columns that are t or a signal, row by row: only their numbers are held (all the
    rows as text took 5.6x the file), grown within the memory budget. Blank lines are
    skipped (an editor's or a logger's trailing ones)."""
    from twip import budget

    wanted = [(j, h, name) for j, (h, name) in enumerate(zip(header, names)) if name == "t" or name in SIGNALS]
    values = {name: array("d") for _, _, name in wanted}
    rows = 0
    for row in reader:
        if not row or (len(row) == 1 and not row[0].strip()):
            continue
        if rows and rows % BUDGET_ROWS == 0:  # before the next block of rows (the first is a few MB at most)
            budget.check(f"RunLog.from_csv({str(path)!r})", 2 * 8 * len(wanted) * (rows + BUDGET_ROWS),
                         "read a part of the log (fewer rows)")
        for j, h, name in wanted:
            cell = row[j] if j < len(row) else None
            try:
                if cell is None or "_" in cell:  # float() reads "1_0" as 10.0
                    raise ValueError
                value = float(cell)
            except ValueError:
                shown = "(missing)" if cell is None else cell
                raise LogError(f"{path}: column {h!r}, row {reader.line_num}: {shown!r} is not a number") from None
            if not math.isfinite(value):
                raise LogError(f"{path}: column {h!r}, row {reader.line_num}: {cell!r} is not a finite number")
            values[name].append(value)
        rows += 1
    return {name: np.frombuffer(column, dtype=float) if len(column) else np.empty(0) for name, column in values.items()}


def _factor(name: str, scale) -> float:
    if isinstance(scale, str):
        if scale not in UNIT_NAMES:
            raise LogError(f"scale[{name!r}] = {scale!r}: not a unit name ({', '.join(UNIT_NAMES)}) or a number")
        return UNIT_NAMES[scale]
    if isinstance(scale, bool) or not isinstance(scale, checks.REAL):
        raise TypeError(f"scale[{name!r}] must be a number or a unit name ({', '.join(UNIT_NAMES)}), "
                        f"got {scale!r} ({type(scale).__name__})")
    factor = checks.real(f"scale[{name!r}]", scale)
    if factor == 0:
        raise LogError(f"scale[{name!r}] = {scale!r}: must be a finite nonzero number or a unit name")
    return factor


def _column(name: str, value) -> np.ndarray:
    checks.real_entries(name, value, LogError)
    try:
        column = np.ascontiguousarray(value, dtype=float)
    except (TypeError, ValueError):
        raise LogError(f"{name}: not an array of numbers") from None
    if column.ndim != 1:
        raise LogError(f"{name}: shape {column.shape}; a signal is one value per sample")
    bad = np.flatnonzero(~np.isfinite(column))
    if len(bad):
        raise LogError(f"{name}: row {int(bad[0])} is {float(column[bad[0]])!r}; every value must be finite")
    return column
