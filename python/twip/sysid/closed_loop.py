"""The closed-loop simulation error: the robot's own controller drives the candidate robot
from the log's first state, and the whole run is compared with the log. It needs no
logged input and tests what matters for control (does the fitted robot behave like the
real one under its controller?), but noise in the log does not reach the simulated
controller, so use it on clean logs or to check a shooting fit, not for intervals."""
from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from twip import _core
from twip.sim import simulate
from twip.sysid.estimator import PARAM_STEP, Problem, Solution
from twip.sysid.measure import noise_level, predict


def _simulated(problem: Problem, controller, reference, delta, biases, x0) -> dict:
    """The compared signals of `controller` driving the robot at offsets `delta` from x0."""
    log = problem.log
    dt = float(np.mean(np.diff(log.t)))
    model, _, params, slope = problem.model_parts(delta)
    # The declared gear play in the loop, as the rig has it.
    realism = _core.Realism(backlash=problem.backlash) if problem.backlash else None
    result = simulate(model, controller, x0, log.t[-1] - log.t[0] + 0.5 * dt, dt=dt, reference=reference,
                      realism=realism)
    n, k = len(log), min(len(log), len(result.t))
    states = np.full((n, 4), np.nan)
    states[:k] = result.states[:k]
    rates = np.full((n, 4), np.nan)
    if any(s.startswith("accel") for s in problem.outputs):
        for i in range(k):
            rates[i] = model.deriv(states[i], result.inputs[i])
    out = {s: predict(s, states, rates, params.wheel_radius, params.g, slope, problem.sensors,
                      [range(0, n)]) for s in problem.outputs}
    for s, b in zip(problem.biased, biases):
        out[s] = out[s] + b
    return out


def error(problem: Problem, fit, controller, reference) -> dict:
    """RMS of the log against the fitted robot under `controller`, per signal (NaN rows,
    after a fall, count as missing)."""
    delta = fit.solution.delta
    out = _simulated(problem, controller, reference, delta, fit.solution.biases, fit.solution.starts[0])
    return {s: float(np.sqrt(np.nanmean((problem.y[s] - out[s]) ** 2))) for s in problem.outputs}


def run(problem: Problem, controller, reference, max_iter: int) -> Solution:
    """Fits `problem`'s parameters and sensor offsets by the closed-loop simulation error."""
    log = problem.log
    steps = np.diff(log.t)
    dt = float(steps.mean())
    if np.max(np.abs(steps - dt)) > 1e-9 * max(dt, 1.0):
        raise _core.InvalidParameterError("method='closed-loop': the log must be sampled at a constant rate")
    x0 = problem.initial_states()[0]
    sigma = {s: noise_level(s, y) for s, y in problem.y.items()}
    n_p = len(problem.unknowns)

    def outputs(x):
        return _simulated(problem, controller, reference, x[:n_p], x[n_p:], x0)

    def residual(x):
        try:
            out = outputs(x)
        except _core.InvalidParameterError:
            return np.full(len(log) * len(problem.outputs), 1e6)
        r = np.concatenate([np.where(problem.used[s], problem.y[s] - out[s], 0.0) / sigma[s]
                            for s in problem.outputs])
        # A candidate that falls early leaves NaN rows: a large, finite penalty.
        return np.where(np.isfinite(r), r, 1e6)

    x_start = np.zeros(n_p + len(problem.biased))
    fit = optimize.least_squares(residual, x_start, method="lm", diff_step=PARAM_STEP, max_nfev=max_iter * (len(x_start) + 1))
    out = outputs(fit.x)
    residuals = {s: np.where(problem.used[s], problem.y[s] - out[s], np.nan) for s in problem.outputs}
    converged = bool(fit.success) and math.isfinite(fit.cost)
    return Solution(fit.x[:n_p], x0[None], fit.x[n_p:], sigma, float(fit.cost), int(fit.nfev), converged,
                    f"closed loop: {fit.message}", fit.jac.T @ fit.jac, residuals, out)
