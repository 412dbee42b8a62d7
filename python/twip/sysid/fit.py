"""The answer of `twip.identify`: the fitted robot, its uncertainty, and what the log could
not determine."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np
from scipy import stats

from twip import checks
from twip.sysid import misfit, spread
from twip.sysid.estimator import Estimator, Problem, Solution
from twip.sysid.problem import ENC_SPAN
from twip.sysid.log import RunLog

#: Smallest eigenvalue of the normalised information matrix below which a combination of
#: parameters counts as undetermined (the log does not tell its members apart).
UNDETERMINED = 1e-8
#: How much higher (half a chi-square: the cost's units) the cost may be with the parameters
#: without information held at their start values: about none, for a parameter the
#: prediction does not depend on.
HELD_COST = 1.0
#: A positive parameter fitted more than this factor away from its start (|d| > ln of it, the
#: value being start*exp(d)) is no physical answer: starts are what one knows of the robot, off
#: by tens of percent, not by orders of magnitude. Seen: 8 free parameters, mu_bearing and
#: i_wheels sunk 1800x and 27000x towards zero in a local minimum, "converged" with deviations
#: of 1e-8 of their values.
MOVED = 100.0
#: A 95 % interval wider than this fraction of its value either side is worth a line in the
#: summary, with the run that would narrow it (issue 61's goal at 1 kHz is 1.5 %).
WIDE = 0.015
#: The summary's reminder that no interval takes in an error of what was not fitted. Measured on
#: a dithered speed-step rig log: a held i_wheels 1.3x the robot's moved m_body and com_height
#: by 40 deviations, an IMU declared at 0.12 m for 0.15 m moved i_body by 4.6, all quiet.
HELD = ("intervals assume exact: the held parameters and the declared rig (driver, IMU height and filter, "
        "encoder CPR)")
HELD_SPLIT = "; on the flat the m_body/com_height split leans most on the held i_wheels and m_wheels"
#: Which run would pin each parameter down.
EXCITATION = {
    "m_body": "tilt the body: a speed trip that pitches it",
    "com_height": "tilt the body: a speed trip that pitches it",
    "i_body": "tilt the body quickly: sharp speed steps (twip.sysid.speed_steps) and a dither on the "
              "command (twip.sysid.Dithered)",
    "m_wheels": "a speed trip: accelerate and brake the wheels",
    "i_wheels": "a speed trip: accelerate and brake the wheels",
    "i_motor": "a speed trip: accelerate and brake the wheels",
    "gear_ratio": "a speed trip: accelerate and brake the wheels",
    "torque_constant": "a speed trip with large currents, at several speeds",
    "wheel_radius": "a speed trip (and an accelerometer or a known distance)",
    "mu_bearing": "runs at several steady wheel speeds",
    "mu_ground": "runs at several steady wheel speeds",
    "g": "nothing: g is known; do not free it",
    "slope": "a run on the slope that climbs and descends",
    "battery": "PWM duties over their range at several wheel speeds",
    "bridge_drop": "PWM duties over their range at several wheel speeds",
    "resistance": "PWM duties over their range at several wheel speeds",
    "efficiency": "PWM duties over their range at several wheel speeds",
}


@dataclass(frozen=True)
class Undetermined:
    """A combination of free parameters the log cannot determine: `weights` by name (a unit
    eigenvector of the normalised information), and the runs that would fix it."""

    weights: Dict[str, float]
    eigenvalue: float
    advice: Tuple[str, ...]

    def __str__(self) -> str:
        combo = " ".join(f"{w:+.2f}*{n}" for n, w in self.weights.items())
        return f"undetermined: {combo} (relative changes); would fix it: " + "; ".join(self.advice)


class Fit:
    """Fitted values of the free parameters with their covariance, per-signal RMS residuals
    and a diagnosis of what the log could not determine."""

    def __init__(self, problem: Problem, solution: Solution, cost_at: Optional[Callable[[np.ndarray], float]] = None):
        #: The estimator's raw answer (offsets, start states, weights, linearisation).
        self._problem, self.solution = problem, solution
        self.names: Tuple[str, ...] = tuple(u.name for u in problem.unknowns)
        n_p = len(self.names)
        info = solution.information[:n_p, :n_p] if n_p else np.zeros((0, 0))
        self.undetermined: List[Undetermined] = _undetermined(self.names, info)
        # A parameter the log says nothing about stays at its start value.
        dead = {n for u in self.undetermined if u.eigenvalue == 0.0 for n in u.weights}
        delta = np.array([0.0 if n in dead else d for n, d in zip(self.names, solution.delta)])
        if dead and cost_at is not None and not cost_at(delta) <= solution.cost + HELD_COST:
            # Held there, they predict the log worse: the (numerically rank-deficient)
            # information mislabelled them, and the others' values lean on theirs. They
            # keep their fitted values, without an interval (`_covariance` gives none to
            # a parameter whose information is not positive).
            delta = np.asarray(solution.delta, dtype=float)
        self.values: Dict[str, float] = problem.values(delta)
        model, driver, params, slope = problem.model_parts(delta)
        #: The fitted robot (a RobotParams), the slope and (for a pwm log) the driver.
        self.robot = params
        self.slope = slope
        self.driver = driver
        #: The gearhead friction of the fitted model (`friction=`, with a free coulomb fitted), or None.
        self.friction = model.friction
        self.converged = solution.converged
        self.message = solution.message
        far = [f"{u.name} {'rose' if d > 0 else 'fell'} {math.exp(abs(d)):.3g}x (to {self.values[u.name]:.3g})"
               for u, d in zip(problem.unknowns, delta) if u.positive and abs(d) > math.log(MOVED)]
        if far:
            # Not an answer to claim an interval for: a local minimum, or more free parameters
            # than the log tells apart.
            self.converged = False
            self.message = (f"{', '.join(far)} from the start, beyond {MOVED:g}x: no physical value; a local "
                            "minimum or more free parameters than the log tells apart. Free fewer parameters or "
                            f"start them closer to the robot (the search: {self.message})")
        self.iterations = solution.iterations
        #: The sensor offsets estimated beside the parameters (gyro [rad/s], accel_x [m/s^2]).
        self.offsets: Dict[str, float] = dict(zip(problem.biased, map(float, solution.biases)))
        self.sigma = dict(solution.sigma)
        scale = np.array([u.slope_at(d) for u, d in zip(problem.unknowns, delta)])
        cov_delta = _covariance(solution.information)[:n_p, :n_p]
        if not self.converged:
            # Away from the minimum the curvature bounds nothing: no interval is claimed.
            cov_delta = np.full((n_p, n_p), math.inf)
        #: Covariance of the free parameters (in their units), start states accounted for;
        #: inf where the log (or a fit that did not converge) does not bound a parameter.
        self.covariance = cov_delta * np.outer(scale, scale)
        std = np.sqrt(np.clip(np.diag(self.covariance), 0, None))
        self.std: Dict[str, float] = dict(zip(self.names, std))
        with np.errstate(invalid="ignore", divide="ignore"):
            self.correlation = self.covariance / np.outer(std, std)
        #: RMS of measured - predicted, per signal, in the signal's units.
        self.rms: Dict[str, float] = {s: float(np.sqrt(np.nanmean(r**2))) for s, r in solution.residuals.items()}
        #: With `controller=`: the fitted robot's closed-loop simulation error per signal.
        self.closed_loop_rms: Optional[Dict[str, float]] = None
        #: What the fit assumed and did not fit: the motor driver of a pwm log, and where it came from.
        self.assumed: Dict[str, str] = {}
        #: The signals whose residuals are not the noise the log shows (`twip.SysidMisfitWarning`).
        self.misfits: List[str] = misfit.check(problem, solution.residuals)
        if self.converged and solution.spread is not None:
            # ... and the parameters the residuals spread wider than the noise would.
            self.misfits += spread.check(self.names, solution.spread)
        #: What the fit left out of the log, and why (the summary's NOTE lines).
        self.notes: List[str] = []
        if problem.still:
            self.notes.append(
                f"enc: left out in {problem.still} of {len(problem.ranges)} segments, where the wheels turned less "
                f"than {ENC_SPAN} counts: there the encoder's rounding follows the motion rather than being noise, "
                "and biased mu_bearing by up to +22 % on a robot balancing in place. The intervals are without "
                "those rows; to use them, drive the robot (twip.sysid.speed_steps, twip.sysid.Dithered) or log "
                "a finer encoder")
        #: Why the answer may be far off: the misfits, and a fit that did not converge. Empty
        #: when the fit converged and the model explains the log.
        self.warnings: List[str] = list(self.misfits)
        if not self.converged:
            self.warnings.append(f"not converged ({self.message}): the values are the last point reached, "
                                 "without intervals")

    def interval(self, name: str, level: float = 0.95) -> Tuple[float, float]:
        """The two-sided `level` confidence interval of parameter `name` (normal approximation),
        the held parameters and the declared rig taken as exact (`HELD`)."""
        if name not in self.values:
            raise KeyError(f"{name!r} was not free (free: {', '.join(self.names)})")
        if not (0 < level < 1):
            raise ValueError(f"level = {level!r}: must be in (0, 1)")
        z = stats.norm.ppf(0.5 + level / 2)
        return self.values[name] - z * self.std[name], self.values[name] + z * self.std[name]

    def summary(self) -> str:
        """A table of the estimates with their 95 % intervals, the residuals and the diagnosis."""
        lines = [f"{'parameter':<16} {'start':>12} {'fitted':>12} {'std':>10} {'95 % interval':>27}"]
        for u in self._problem.unknowns:
            lo, hi = self.interval(u.name)
            lines.append(f"{u.name:<16} {u.start:>12.6g} {self.values[u.name]:>12.6g} {self.std[u.name]:>10.3g} "
                         f"  [{lo:>11.6g}, {hi:>11.6g}]")
        for name, value in self.offsets.items():
            lines.append(f"{'(' + name + ' offset)':<16} {'':>12} {value:>12.4g}")
        lines.append("residual RMS: " + ", ".join(f"{s} {v:.3g}" for s, v in self.rms.items()))
        lines.append(("converged: " if self.converged else "NOT CONVERGED: ") + self.message)
        lines.extend(f"assumed {k}: {v}" for k, v in self.assumed.items())
        lines.append(HELD + (HELD_SPLIT if {"m_body", "com_height"} & set(self.names) else ""))
        lines.extend(str(u) for u in self.undetermined)
        lines.extend("NOTE: " + n for n in self.notes)
        lines.extend(self.wide())
        lines.extend("MISFIT: " + w for w in self.misfits)
        return "\n".join(lines)

    def wide(self) -> List[str]:
        """A line for each parameter whose 95 % interval reaches beyond WIDE of its value either
        side: how wide, and the run that would narrow it. Not a misfit: the log holds little
        about it (an 8 s log of a robot catching itself left i_body at ±2-3 %)."""
        lines = []
        for name in self.names:
            lo, hi = self.interval(name)
            half = (hi - lo) / 2 / abs(self.values[name]) if self.values[name] else math.inf
            if self.converged and math.isfinite(half) and half > WIDE:
                lines.append(f"WIDE: {name} is known to ±{half:.1%} (95 %); to narrow it: "
                             f"{EXCITATION.get(name, 'a run that excites it')}")
        return lines

    def predicted(self) -> Dict[str, np.ndarray]:
        """The fitted model's prediction of each compared signal on the fitted log."""
        return dict(self.solution.predicted)

    def validate(self, other: RunLog, segment: Optional[float] = None) -> Dict[str, float]:
        """Predicts `other` with the fitted robot (its own start states fitted, parameters held)
        and returns the RMS error of each signal there."""
        checks.of_type("other", other, RunLog, "a twip.RunLog (the run to predict)")
        p = self._problem
        params = self.robot
        check = Problem(other, params, [], self.driver or p.driver, p.friction, segment or p.segment,
                        p.sensors, [s for s in p.outputs if getattr(other, s) is not None], p.max_step, p.backlash)
        sigma = {s: self.sigma[s] for s in check.outputs}
        solution = Estimator(check, sigma, max_iter=50).run()
        return {s: float(np.sqrt(np.nanmean(r**2))) for s, r in solution.residuals.items()}

    def plot(self, path) -> None:
        """Measured against predicted for each compared signal, with the residuals below."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        t = self._problem.log.t
        outputs = self._problem.outputs
        fig, axes = plt.subplots(2, len(outputs), figsize=(4.2 * len(outputs), 5.5), sharex=True, squeeze=False)
        for j, s in enumerate(outputs):
            measured = self._problem.y[s]
            axes[0, j].plot(t, measured, lw=0.8, color="0.55", label="measured")
            axes[0, j].plot(t, self.solution.predicted[s], lw=1.0, color="C0", label="predicted")
            axes[0, j].set_title(f"{s} [{_UNITS[s]}]")
            axes[1, j].plot(t, self.solution.residuals[s], lw=0.6, color="C3")
            axes[1, j].set_title(f"measured − predicted, RMS {self.rms[s]:.3g} {_UNITS[s]}")
            axes[1, j].set_xlabel("t [s]")
        axes[0, 0].legend(loc="best", fontsize=8)
        items = [f"{n} = {self.values[n]:.4g} ± {self.std[n]:.2g}" for n in self.names]
        per_line = max(1, len(outputs))
        lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
        fig.suptitle("\n".join(["twip.identify (± one standard deviation)", *lines]), fontsize=9)
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)

    def __repr__(self) -> str:
        inner = ", ".join(f"{n}={self.values[n]:.6g}±{self.std[n]:.2g}" for n in self.names)
        return f"Fit({inner}, converged={self.converged})"


_UNITS = {"phi": "rad", "phi_dot": "rad/s", "theta": "rad", "theta_dot": "rad/s", "gyro": "rad/s",
          "enc": "counts", "accel_x": "m/s²", "accel_z": "m/s²"}


#: Relative eigenvalue of the normalised information at or below which a direction has no
#: information at all (rounding): the variance along it is infinite, never zero.
NO_INFORMATION = 1e-14


def _covariance(info: np.ndarray) -> np.ndarray:
    """The inverse of the information matrix, inf in the rows and columns of the parameters
    that move along a direction without information."""
    n = info.shape[0]
    if n == 0:
        return info
    d = np.sqrt(np.clip(np.diag(info), 0, None))
    dead = d <= math.sqrt(NO_INFORMATION) * max(float(d.max()), 1e-300)
    cov = np.full((n, n), math.inf)
    alive = np.flatnonzero(~dead)
    if len(alive):
        normal = info[np.ix_(alive, alive)] / np.outer(d[alive], d[alive])
        values, vectors = np.linalg.eigh(normal)
        empty = values <= NO_INFORMATION * max(float(values.max()), 1e-300)
        kept = vectors[:, ~empty]
        inner = (kept / values[~empty]) @ kept.T / np.outer(d[alive], d[alive])
        unbounded = np.any(np.abs(vectors[:, empty]) > 1e-6, axis=1)
        inner[unbounded, :] = math.inf
        inner[:, unbounded] = math.inf
        cov[np.ix_(alive, alive)] = inner
    return cov


def _undetermined(names, info: np.ndarray) -> List[Undetermined]:
    """The eigenvectors of the normalised information with negligible eigenvalues, and the
    parameters with no information at all."""
    if not len(names):
        return []
    diag = np.diag(info).copy()
    out = []
    dead = diag <= NO_INFORMATION * max(float(diag.max()), 1e-300)
    for i in np.flatnonzero(dead):
        out.append(Undetermined({names[i]: 1.0}, 0.0, (EXCITATION.get(names[i], "a run that moves it"),)))
    alive = np.flatnonzero(~dead)
    if len(alive) > 1:
        d = np.sqrt(diag[alive])
        normal = info[np.ix_(alive, alive)] / np.outer(d, d)
        values, vectors = np.linalg.eigh(normal)
        for k in np.flatnonzero(values < UNDETERMINED * values.max()):
            v = vectors[:, k] / np.linalg.norm(vectors[:, k])
            weights = {names[alive[i]]: float(v[i]) for i in np.argsort(-np.abs(v)) if abs(v[i]) > 0.2}
            advice = tuple(dict.fromkeys(EXCITATION.get(n, "a run that moves it") for n in weights))
            out.append(Undetermined(weights, float(values[k]), advice))
    return out
