"""The estimator's problem: a log, a starting robot and the free parameters, the model at any
point of them, its predictions by multiple shooting (`_core.sysid_shoot`), and the segments
the log is cut into.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

import numpy as np

from twip import _core, budget, checks
from twip.sysid.grid import Grid
from twip.sysid.log import LogError, RunLog
from twip.sysid.measure import BIASED, FILTERED, OUTPUTS, Sensors, predict, settling_samples
from twip.sysid.play import rows_near_impacts
from twip.sysid.signals import segments, smooth_rate

#: The most integration steps one prediction of a log may take (`max_step` and the log's span).
MAX_STEPS = 10**8
#: Fields of `twip.MotorDriver` that can be free when the log's input is `pwm`.
DRIVER_FIELDS = ("battery", "bridge_drop", "resistance", "efficiency")
#: The gearhead friction's level that can be free when `friction=` gives the law to start from;
#: the breakaway torque moves with it (their ratio is kept, so breakaway >= coulomb holds).
FRICTION_FIELDS = ("coulomb",)


#: An encoder's rows are compared only in segments where its counts span at least this many.
#: Below that the rounding is not noise but a function of the motion (a staircase under a
#: creeping wheel), and the fit takes it up: robots balancing in place on a 700 CPR rig got
#: mu_bearing +5 to +22 %, 3-9 deviations off, quiet. With 4, those fits were within 2.3
#: deviations (mu_bearing within 1.1), and no segment of a dithered speed-step run was left out.
ENC_SPAN = 4


@dataclass(frozen=True)
class Unknown:
    """A free parameter: where it lives (`robot`, `driver`, `friction` or `slope`) and its start value.
    All but the slope are positive (`Problem._unknown` refuses a start <= 0) and estimated as
    start * exp(d), so no step leaves their domain and d is the relative change; the slope
    (any sign) as start + d."""

    name: str
    where: str
    start: float

    @property
    def positive(self) -> bool:
        return self.where != "slope"

    def value(self, d: float) -> float:
        # Clipped: a wild trial step gives a huge value the model refuses, not an overflow.
        return self.start * math.exp(min(max(d, -30.0), 30.0)) if self.positive else self.start + d

    def slope_at(self, d: float) -> float:
        """d(value)/dd at d: turns the offsets' covariance into the parameter's."""
        return self.value(d) if self.positive else 1.0


class Problem:
    """A log, a starting robot and the free parameters, as the estimator sees them."""

    def _check_size(self, n_globals: int) -> None:
        """The integration steps of one prediction and the normal equations' arrays, before
        any is made: a tiny `max_step`, a gap in the log or tiny segments would otherwise
        hang or exhaust the memory."""
        step = self.max_step
        steps = float(np.sum(np.ceil(np.diff(self.log.t) / step)))
        if steps > MAX_STEPS:
            raise LogError(f"max_step = {step!r}: one prediction of this log would take {steps:.3g} integration "
                           f"steps, more than {MAX_STEPS:.0e} (a gap in t, or a step too small)")
        n = n_globals + 4 * len(self.segments)
        # The normal equations and the KKT matrix (n x n each), and each segment's end
        # against every unknown (linearise).
        budget.check(f"identify with {len(self.segments)} segments", 8.0 * (3 * n * n + 4 * len(self.segments) * n),
                     "use longer segments (segment=)")

    def __init__(self, log: RunLog, params, free: Sequence[str], driver, friction, segment: float,
                 sensors: Sensors, signals: Optional[Sequence[str]], max_step: float, backlash: Optional[float] = None):
        self.log, self.params, self.driver, self.friction = log, params, driver, friction
        #: Each gear train's play at the wheel [rad], declared (None: none).
        self.backlash = backlash
        self.sensors = sensors
        self.max_step = checks.real("max_step", max_step, above=0)
        if log.u is not None:
            self.input = log.u
            self.driven = False
        elif log.pwm is not None:
            self.input = log.pwm
            self.driven = True
        else:
            raise LogError("the log has neither u (motor current) nor pwm: the estimator needs the input")
        available = [s for s in OUTPUTS if getattr(log, s) is not None]
        self.outputs = list(signals) if signals is not None else available
        for s in self.outputs:
            if s not in OUTPUTS:
                raise LogError(f"signals: {s!r} is not an output signal ({', '.join(OUTPUTS)})")
            if getattr(log, s) is None:
                raise LogError(f"signals: {s!r} was asked for but the log has no {s!r} column")
        if not self.outputs:
            raise LogError("the log has no measured output (phi, phi_dot, theta, theta_dot, gyro, enc, accel_x, "
                           "accel_z): nothing to compare predictions with")
        self.unknowns = [self._unknown(name) for name in free]
        if len(set(free)) != len(free):
            raise LogError(f"free: {list(free)} names a parameter twice")
        self.biased = [s for s in BIASED if s in self.outputs]
        #: The shooting segments' length asked for [s] (`cut` may join some into longer ones).
        self.segment = segment
        self.segments = segments(log.t, segment)
        self._check_size(len(self.unknowns) + len(self.biased))
        filtered = sensors.imu is not None and any(s in self.outputs for s in FILTERED)
        self._imu_rate = sensors.imu.sample_rate if filtered else None
        self.cut(self.segments)
        n_unknowns = len(self.unknowns) + 4 + len(self.biased)
        n_data = len(log) * len(self.outputs)
        if n_data <= n_unknowns:
            raise LogError(f"the log is too short: {n_data} measurements for {n_unknowns} unknowns "
                           f"({len(self.unknowns)} parameters, 4 start states for each of {len(self.segments)} "
                           "segments); log longer or use longer segments")
        self.y = {s: getattr(log, s) for s in self.outputs}

    def cut(self, starts: Sequence[int]) -> None:
        """The shooting segments from rows `starts` (0 first): the grid, each segment's rows and
        the rows compared (all but the filtered signals' settling at segment starts)."""
        self.segments = list(starts)
        # A log slower than the IMU (a firmware's loop period) is predicted at the IMU's samples.
        self.grid = Grid(self.log.t, self.input, self.segments, self._imu_rate)
        ends = [*self.segments[1:], len(self.log)]
        self.ranges = [range(a, b) for a, b in zip(self.segments, ends)]
        self.settled = {}
        #: The segments whose encoder rows are left out (counts spanning < ENC_SPAN).
        self.still = 0
        for s in self.outputs:
            used = np.ones(len(self.log), dtype=bool)
            for r in self.ranges:
                settled = self.grid.rows[r.start:r.stop] - self.grid.rows[r.start] >= settling_samples(self.sensors, s)
                used[r.start:r.stop] = settled
                if s == "enc" and np.ptp(self.log.enc[r.start:r.stop]) < ENC_SPAN:
                    used[r.start:r.stop] = False
                    self.still += 1
            self.settled[s] = used
        #: The rows compared at the current point: the settled ones, less those near its impacts.
        self.used = dict(self.settled)

    def jumps(self) -> bool:
        """Whether the prediction can jump within a plant step: impacts in the gear play, or the
        gearhead friction's stick band switching."""
        return self.backlash is not None or (self.friction is not None and self.friction.stick_speed > 0)

    def note_impacts(self, states: np.ndarray, sensed: np.ndarray) -> None:
        """Leave out the filtered signals' rows near the impacts of a run (its states [n, 4]
        and `sensed` [n, 2] on the grid, as `shoot` gives them): `play.rows_near_impacts`."""
        self.used = dict(self.settled)
        if self.backlash is not None and sensed is not None:
            self.used = rows_near_impacts(self.grid, self.sensors, self.settled, states, sensed)

    def _unknown(self, name: str) -> Unknown:
        unknown = self._locate(name)
        if unknown.where != "slope" and not unknown.start > 0:
            # Fitted as a factor on its start (`Unknown`): from 0 it could not move.
            raise LogError(f"free: {name!r} starts at {unknown.start!r}; a free parameter other than the slope is "
                           f"fitted relative to its start, so it must start > 0: give a small positive {name} "
                           "to start from")
        return unknown

    def _locate(self, name: str) -> Unknown:
        fields = self.params.to_dict()
        if name in fields:
            return Unknown(name, "robot", float(fields[name]))
        if name == "slope":
            return Unknown(name, "slope", float(self.log.slope))
        if name in DRIVER_FIELDS:
            if self.log.pwm is None or self.log.u is not None:
                raise LogError(f"free: {name!r} is a motor driver field; it can be fitted only from a log whose "
                               "input is pwm (and that has no u column)")
            return Unknown(name, "driver", float(self.driver.to_dict()[name]))
        if name in FRICTION_FIELDS:
            if self.friction is None or not self.friction.coulomb > 0:
                raise LogError(f"free: {name!r} is the gearhead friction's level; give friction= (a twip.Friction "
                               "with coulomb > 0) to start from")
            return Unknown(name, "friction", float(self.friction.coulomb))
        raise LogError(f"free: {name!r} is not a parameter (RobotParams fields: {', '.join(fields)}; 'slope'; "
                       f"with a pwm log, the driver's {', '.join(DRIVER_FIELDS)}; with friction=, "
                       f"{', '.join(FRICTION_FIELDS)})")

    # --- the model at a parameter vector ------------------------------------------------

    def values(self, delta: np.ndarray) -> Dict[str, float]:
        """The free parameters' values at relative offsets `delta`."""
        return {u.name: u.value(d) for u, d in zip(self.unknowns, delta)}

    def model_parts(self, delta: np.ndarray):
        values = self.values(delta)
        robot = {k: v for k, v in values.items() if self._where(k) == "robot"}
        params = self.params.replace(**robot) if robot else self.params
        slope = values.get("slope", self.log.slope)
        friction = self.friction
        if "coulomb" in values:
            scale = values["coulomb"] / friction.coulomb
            friction = friction.replace(coulomb=values["coulomb"], breakaway=friction.breakaway * scale)
        model = _core.SlopeModel(params, slope, friction)
        driver_changes = {k: v for k, v in values.items() if self._where(k) == "driver"}
        driver = self.driver.replace(**driver_changes) if (self.driven and driver_changes) else self.driver
        return model, (driver if self.driven else None), params, slope

    def _where(self, name: str) -> str:
        return next(u.where for u in self.unknowns if u.name == name)

    def shoot(self, deltas: List[np.ndarray], starts: np.ndarray):
        """States and rates [K, n, 4] for parameter offsets `deltas` and start states [K, S, 4],
        each segment's end carried to the next one's start [K, S, 4], and each run's
        (radius, g, slope, what the sensors see besides the state [n, 2]). With gear play the
        first run is the base: the others hold each segment's play where it has it and replay its
        impacts and openings, plant step by plant step."""
        parts = [self.model_parts(d) for d in deltas]
        drivers = [p[1] for p in parts] if self.driven else None
        grid = self.grid
        states, rates, ends, sensed = _core.sysid_shoot([p[0] for p in parts], starts, grid.t, grid.u,
                                                        np.asarray(grid.segments, dtype=np.int64), self.max_step,
                                                        drivers, self.backlash)
        geometry = [(p[2].wheel_radius, p[2].g, p[3], sensed[k]) for k, p in enumerate(parts)]
        return states, rates, ends, geometry

    def outputs_of(self, states, rates, geometry, biases: np.ndarray) -> Dict[str, np.ndarray]:
        radius, g, slope, sensed = geometry
        out = {s: self.grid.at_rows(predict(s, states, rates, radius, g, slope, self.sensors, self.grid.ranges, sensed))
               for s in self.outputs}
        for s, b in zip(self.biased, biases):
            out[s] = out[s] + b
        return out

    # --- starting guesses ---------------------------------------------------------------

    def initial_states(self) -> np.ndarray:
        """Each segment's start state from the measurements at its first samples."""
        log, n = self.log, len(self.log)
        phi = log.phi if log.phi is not None else (
            np.arctan2(log.accel_x, log.accel_z) if log.accel_x is not None and log.accel_z is not None
            else np.zeros(n))
        rate = log.phi_dot if log.phi_dot is not None else (log.gyro if log.gyro is not None else np.gradient(phi, log.t))
        if log.theta is not None:
            theta = log.theta
        elif log.enc is not None:
            theta = log.enc * (2 * math.pi / self.sensors.encoder_cpr) + phi
        else:
            theta = np.zeros(n)
        wheel = log.theta_dot if log.theta_dot is not None else smooth_rate(theta, log.t)
        columns = np.column_stack([phi, rate, theta, wheel])
        return np.array([columns[s] for s in self.segments])
