"""The closed-loop runner's Python face: `simulate` and its `SimResult`."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from twip import _core, budget, checks, user_controller

#: Log columns of a run besides the controller's internals: t, state, input, reference.
_LOG_COLUMNS = {"slope": 1 + 4 + 1 + 2, "planar": 1 + 7 + 2 + 7}
#: Columns a realism adds (what the controller read, the plant's inputs, the motor currents; 2-DOF: raw readings).
_SIGNAL_COLUMNS = {"slope": 4 + 1 + 1 + 4, "planar": 7 + 2 + 2}
#: A generous guess of the internals a built-in controller logs (checked exactly when it matters).
_DEFAULT_INTERNALS = 16
#: The controllers whose internals the guess bounds; a user's controller logs as many as it likes.
_BUILT_IN_CONTROLLERS = (_core.LqrController, _core.FuzzyController, _core.PidTracker, _core.SmcTracker,
                         _core.GradeFeedForward)


@dataclass(frozen=True)
class SimResult:
    """One closed-loop run. Arrays have one row per logged sample (SI units, radians).

    `outcome`: "completed"; "fell" (|pitch| passed the fall limit at `t_end`); "diverged"
    (the state or the controller's output stopped being finite at `t_end`: a fall for
    `fell` and for sweeps; the metrics cover the samples before it); "interrupted" (Ctrl-C:
    the run up to `t_end`); on a terrain (docs/terrain.md) "lifted" (a wheel's normal force
    went below zero at `t_end`) and "off_terrain" (the robot left a grid's edge). A run that fell or diverged never settled: its settling times
    are `t_end`, as its sweep sample's are."""

    t: np.ndarray
    states: np.ndarray
    inputs: np.ndarray
    references: np.ndarray
    reference_names: tuple
    internals: dict
    outcome: str
    t_end: Optional[float]
    steps: int
    metrics: dict = field(default_factory=dict)
    # With `realism`: per sample, what the controller last read (2-DOF: phi_hat,
    # phi_dot_hat, theta_hat, theta_dot_hat; 3-DOF: x_hat ... omega_hat), the plant's input
    # ("drive", "drive_r"/"drive_l": PWM counts with a motor driver, else the command) and
    # the motor current ("motor_current" lumped, or "current_r"/"current_l", A).
    signals: dict = field(default_factory=dict)
    #: What the run asked that the robot could not give (e.g. more than the stall current).
    warnings: tuple = ()
    #: The 2-DOF model's slope [rad] (None for a PlanarModel), and the realism run, if any.
    slope: Optional[float] = None
    realism: Optional[object] = None

    @property
    def measurements(self) -> Optional[np.ndarray]:
        """What the controller read per sample, beside `states` (same columns)."""
        if not self.signals:
            return None
        names = [n for n in self.signals if n.endswith("_hat")]
        return np.column_stack([self.signals[n] for n in names])

    @property
    def fell(self) -> bool:
        """True when the run ended early: |pitch| passed the fall limit ("fell"), or the state
        or the input stopped being finite ("diverged"), which sweeps count as a fall too."""
        return self.outcome in ("fell", "diverged")

    @property
    def t_fall(self) -> Optional[float]:
        return self.t_end if self.fell else None

    def reference(self, name: str) -> np.ndarray:
        if name not in self.reference_names:
            raise _core.InvalidParameterError(f"reference: unknown name {name!r}; this run's are "
                                              f"{', '.join(self.reference_names)}")
        return self.references[:, self.reference_names.index(name)]

    def to_log(self):
        """A `twip.RunLog` of this 2-DOF run, as the robot would log it. Without realism:
        the input current u and the true states. With realism: the plant's input (pwm with a
        motor driver, else the current u) and the raw readings of the parts the rig has
        (gyro and accelerometer registers, the encoder's count); the states of the parts it
        does not have (pitch without an IMU, wheel angle without encoders) as they are."""
        from twip.sysid.log import RunLog

        if self.slope is None:
            raise _core.InvalidParameterError("to_log: only a 2-DOF (SlopeModel) run makes a RunLog")
        if self.realism is None:
            phi, phi_dot, theta, theta_dot = self.states.T
            return RunLog(self.t, u=self.inputs[:, 0], phi=phi, phi_dot=phi_dot, theta=theta, theta_dot=theta_dot,
                          slope=self.slope)
        columns = {}
        if self.realism.motor is not None:
            columns["pwm"] = self.signals["drive"]
        else:
            columns["u"] = self.signals["motor_current"]
        for name in ("gyro", "accel_x", "accel_z", "enc"):
            if not np.all(np.isnan(self.signals[name])):
                columns[name] = self.signals[name]
        # A rig without an IMU, or without encoders, reads those states as they are.
        phi, phi_dot, theta, theta_dot = self.states.T
        if self.realism.imu is None:
            columns.update(phi=phi, phi_dot=phi_dot)
        if self.realism.encoder_cpr is None:
            columns.update(theta=theta, theta_dot=theta_dot)
        return RunLog(self.t, slope=self.slope, **columns)


def simulate(
    model,
    controller,
    x0,
    t_final: float,
    dt: float = 1e-3,
    reference=None,
    control_period: Optional[float] = None,
    fall_limit: float = _core.DEFAULT_FALL_LIMIT,
    record_every: int = 1,
    settle: Optional[float] = None,
    realism=None,
    stall_current: Optional[float] = None,
) -> SimResult:
    """Runs `controller` on `model` from `x0` for `t_final` seconds.

    The plant is integrated with RK4 at `dt`; the controller updates every
    `control_period` (default: its own period, which must be a multiple of `dt`) and
    its input is held in between. The run ends early, cleanly, when |pitch| exceeds
    `fall_limit` (default 60 degrees). `record_every` keeps one sample in k in the log;
    metrics always use every step.

    A `PlanarModel` needs a trajectory as `reference` (twip.Circle, Line, FigureEight or
    Waypoints); its "_settled" metrics start at `settle` [s] (default: one lap of a
    circle or figure-eight, else 0).

    `realism` (a `twip.Realism`) puts the robot's real parts in the loop: sensors and
    estimator, motor driver, loop period and delay, disturbances; on a PlanarModel each
    wheel has its motor and encoder and the gyro's z axis gives the yaw rate.
    `inputs` hold the command in effect at each sample (current or wheel torques): with
    `delay` the one issued a loop period earlier (0 in the first period). `signals` and
    `measurements` hold the rest.

    `controller`: a twip controller, an object with `update(t, y, ref) -> u` and `period`
    [s] (optionally `reset()`, called before the run, and `internals() -> dict`, logged),
    or a callable `f(t, y, ref) -> u` run every `control_period` (default `dt`). `y` is what
    a built-in controller measures (the state, or the estimator's output with realism),
    `ref` the reference sample in the order of `SimResult.reference_names`, `u` a float
    or an array of the model's inputs.

    Metrics include `peak_current` [A, one motor] and `peak_torque` [N m, one wheel], what
    the motor got after the driver's clamps (its current limit, the duty at full), beside
    `peak_command` [A, one motor], what the controller asked, and `saturation_share`, the
    share of control periods whose command was beyond the driver (0 without realism's
    driver). With `stall_current` [A] (the motor's data sheet) a run that asked more
    carries a warning in `SimResult.warnings`.
    """
    checks.of_type("fall_limit", fall_limit, checks.REAL, "a pitch angle [rad]")
    if control_period is not None:
        control_period = checks.real("control_period", control_period, above=0)
    if not isinstance(controller, _BUILT_IN_CONTROLLERS):
        user_controller.check_period(controller, control_period, realism)
    if isinstance(model, _core.PlanarModel):
        if reference is None:
            raise _core.InvalidParameterError(
                "reference is required for a PlanarModel: a twip.Circle, Line, FigureEight or Waypoints")
        if settle is not None:
            settle = checks.real("settle", settle, at_least=0)

        def run(t_final, record_every):
            return _core.simulate_planar_raw(
                model, controller, x0, float(t_final), float(dt), reference,
                control_period=control_period, fall_limit=float(fall_limit), record_every=min(int(record_every), _MAX_RECORD_EVERY),
                settle=settle, realism=realism,
            )
    else:
        if settle is not None:  # the settled metrics are the tracking ones
            raise _core.InvalidParameterError("settle: only a PlanarModel (3-DOF tracking) takes settle")
        if reference is None:
            reference = _core.SpeedSchedule.constant(0.0)
        checks.of_type("reference", reference, _core.SpeedSchedule,
                       "a twip.SpeedSchedule (a trajectory such as twip.Circle goes with a PlanarModel)")

        def run(t_final, record_every):
            return _core.simulate_raw(
                model, controller, x0, float(t_final), float(dt), reference,
                control_period=control_period, fall_limit=float(fall_limit), record_every=min(int(record_every), _MAX_RECORD_EVERY),
                realism=realism,
            )

    # The log's width, when a guess would not fit: from a one-step run (the internals it logs).
    # A user's controller is not run for it (that would step its state before the run):
    # its internals() is asked as the runner asks it.
    def logged_extras():
        if not isinstance(controller, _BUILT_IN_CONTROLLERS):
            return _user_internals(controller) + (_SIGNAL_COLUMNS[_kind(model)] if realism is not None else 0)
        probe = run(dt, 1)
        return probe["internals"].shape[1] + (0 if probe.get("signals") is None else probe["signals"].shape[1])

    _check_log(model, t_final, dt, record_every, realism, logged_extras,
               exact=not isinstance(controller, _BUILT_IN_CONTROLLERS))
    if stall_current is not None:
        stall_current = checks.real("stall_current", stall_current, above=0)
    raw = run(t_final, record_every)
    names = raw["internal_names"]
    metrics = dict(raw["metrics"])
    notes = stall_warnings(metrics, stall_current) + drive_warnings(metrics, realism) + plausibility_warnings(model.params)
    if isinstance(model, _core.PlanarModel):
        # A run that diverged at once logs no row: it ended at 0.
        end = float(raw["t"][-1]) if len(raw["t"]) else 0.0
        notes += unsettled_warnings(metrics, end, settle is None, t_final)
    internals = {n: raw["internals"][:, i] for i, n in enumerate(names)}
    return SimResult(
        t=raw["t"],
        states=raw["states"],
        inputs=raw["inputs"],
        references=raw["references"],
        reference_names=tuple(raw["reference_names"]),
        internals=internals,
        outcome=raw["outcome"],
        t_end=raw["t_end"],
        steps=raw["steps"],
        metrics=metrics,
        signals={} if raw.get("signals") is None else {
            n: raw["signals"][:, i] for i, n in enumerate(raw["signal_names"])},
        warnings=notes,
        slope=None if isinstance(model, _core.PlanarModel) else model.slope,
        realism=realism,
    )


def stall_warnings(metrics: dict, stall_current: Optional[float]) -> tuple:
    """A warning when the run asked one motor for more than its stall current [A]."""
    peak = metrics.get("peak_command", metrics.get("peak_current", math.nan))
    if stall_current is None or not peak > stall_current:
        return ()
    return (f"the loop asked up to {peak:.3g} A of one motor, above its stall current {stall_current:.3g} A: "
            "the real robot cannot give this (run it with realism= to see what it does)",)


def drive_warnings(metrics: dict, realism) -> tuple:
    """A warning when the loop commanded one motor more current than its driver can give:
    the battery (less the bridge's drop) over the winding at stall, or the driver's limit.
    The driver is the realism's, else the default `MotorDriver()` (the ideal loop applies
    any command: 1e12 A ran without a word)."""
    driver = getattr(realism, "motor", None) if realism is not None else None
    driver = driver if driver is not None else _core.MotorDriver()
    most = (driver.battery - driver.bridge_drop) / driver.resistance
    if driver.current_limit is not None:
        most = min(most, driver.current_limit)
    peak = metrics.get("peak_command", metrics.get("peak_current", math.nan))
    if not peak > most:
        return ()
    share = metrics.get("saturation_share", 0.0)
    driven = realism is not None and getattr(realism, "motor", None) is not None
    saw = (f"the motor saw at most {metrics['peak_current']:.3g} A" if driven and "peak_current" in metrics
           else "the motor saw less")
    return (f"the loop commanded up to {peak:.3g} A of one motor, beyond the {most:.3g} A its driver can give "
            f"({driver.battery:g} V battery, {driver.bridge_drop:g} V drop, {driver.resistance:.3g} ohm"
            + (f", {driver.current_limit:g} A limit" if driver.current_limit is not None else "")
            + f"): {saw}" + (f", {100 * share:.3g} % of the control periods saturated" if share > 0 else ""),)


def plausibility_warnings(params) -> tuple:
    """A warning naming the values implausible for a tabletop robot (twip.plausibility)."""
    from twip.plausibility import implausible

    found = implausible(params)
    return (f"implausible for a tabletop robot (SI units): {'; '.join(found)}",) if found else ()


def _kind(model) -> str:
    """The key of `model`'s log layout: "planar" or "slope"."""
    return "planar" if isinstance(model, _core.PlanarModel) else "slope"


def _user_internals(controller) -> int:
    """How many internals a user's controller logs: the size of its internals() dict (none
    without one; a value that is not a dict is left to the runner, which names it)."""
    internals = getattr(controller, "internals", None)
    if not callable(internals):
        return 0
    logged = internals()
    return len(logged) if isinstance(logged, dict) else 0


def unsettled_warnings(metrics: dict, end: float, by_default: bool, t_final: float) -> tuple:
    """A warning when a tracking run ended before its settled metrics begin (they are NaN)."""
    settle = metrics["settle"]
    if not end < settle:
        return ()
    what = f"settle = {settle:g} s" + (" (by default one lap of the path)" if by_default else "")
    return (f"the run ended at t = {end:g} s (t_final = {t_final:g} s), before {what}: the _settled "
            f"metrics are NaN; run to t_final >= {settle:g} s or pass a smaller settle",)


def _positive_real(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise _core.InvalidParameterError(f"{name} = {value!r}: must be a real number, got {type(value).__name__}")
    return float(value)


def log_shape_guess(model, t_final: float, dt: float, record_every: int, realism=None):
    """(rows, columns) of a run's log, the columns generously guessed (16 internals)."""
    kind = _kind(model)
    columns = _LOG_COLUMNS[kind] + _DEFAULT_INTERNALS + (_SIGNAL_COLUMNS[kind] if realism is not None else 0)
    return t_final / dt / int(record_every) + 2, columns


#: A record_every beyond any run's step count keeps the first and last samples only; the
#: core takes it as a machine word.
_MAX_RECORD_EVERY = 2**62


def _check_log(model, t_final, dt, record_every, realism, internals, exact: bool = False) -> None:
    """Refuses, before the run, a record_every that is not a count and a log larger
    than the memory budget (naming the rows, columns and the record_every that fits).
    `internals()` says how many internal columns (and signals) the controller logs; it is
    asked when a generous guess does not fit, or always (`exact`) when no guess bounds it."""
    if isinstance(record_every, bool) or not isinstance(record_every, (int, np.integer)) or record_every < 1:
        raise _core.InvalidParameterError(
            f"record_every = {record_every!r}: must be an integer >= 1 (keep one logged sample in that many)")
    t_final, dt = _positive_real("t_final", t_final), _positive_real("dt", dt)
    if not (math.isfinite(t_final) and math.isfinite(dt) and t_final > 0 and dt > 0):
        return  # the core names the bad value
    rows, columns = log_shape_guess(model, t_final, dt, record_every, realism)
    if exact or rows * columns * 8 > budget.memory_budget():
        columns = _LOG_COLUMNS[_kind(model)] + internals()
    need = rows * columns * 8
    fits = max(1, math.ceil(int(record_every) * need / budget.memory_budget()))
    budget.check(f"simulate: the log of t_final = {t_final:g} s at dt = {dt:g} s ({rows:,.0f} rows x {columns} columns)",
                 need, f"keep fewer rows with record_every = {fits} or more, or a shorter t_final")
