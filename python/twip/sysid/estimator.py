"""The prediction-error estimator by multiple shooting.

The log is cut into segments. Each segment is predicted from its own start state, which is an
unknown beside the free parameters, so the unstable open-loop plant is only followed for one
segment and a noisy measurement never serves as an initial condition (that would bias the
estimate: errors in variables). The cost is the sum over the logged signals of (measured -
predicted)^2 / sigma^2, sigma each signal's noise level. Levenberg-Marquardt on the
Gauss-Newton normal equations; the start states are eliminated segment by segment (a Schur
complement), which gives the free parameters' covariance with the start states' uncertainty
accounted for. Central finite differences: one `_core.sysid_shoot` call predicts the base and
every perturbed run on all cores (all segments' start states are perturbed at once).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Mapping, NamedTuple, Optional

import numpy as np

from twip import _core, checks
from twip.sysid import play, spread, units
from twip.sysid.joins import MAX_JOINS, passed, stuck_boundary
from twip.sysid.kkt import kkt_matrix
from twip.sysid.log import LogError
from twip.sysid.measure import noise_floor, noise_level
from twip.sysid.play import ROBUST_LIMIT, robust, robust_slope
from twip.sysid.problem import Problem
from twip.sysid.signals import correlation_time

#: Relative step of a parameter's central difference, and absolute step of a start state. With
#: gear play the perturbed runs replay the base run's impacts and openings (`_core.sysid_shoot`;
#: free, m_body's column was 61x the smooth one at 1e-4): the same columns at 1e-6 to 1e-3.
PARAM_STEP = 1e-5
STATE_STEP = 1e-6
#: A decrease of the cost (half a chi-square) below which the fit has converged.
CHI2_TOLERANCE = 1e-6


class Search(NamedTuple):
    """Where one search (`Estimator._search`) ended, and the boundaries it passed (joined or
    released) at `passed` [s]."""

    x: np.ndarray
    starts: np.ndarray
    converged: bool
    message: str
    iterations: int
    passed: List[float]


@dataclass
class Solution:
    """The estimator's answer: offsets, start states, bias, weights and the linearisation."""

    delta: np.ndarray
    starts: np.ndarray
    biases: np.ndarray  # of Problem.biased
    sigma: Dict[str, float]
    cost: float
    iterations: int
    converged: bool
    message: str
    information: np.ndarray  # of (delta, biases), start states eliminated
    residuals: Dict[str, np.ndarray]  # measured - predicted, in the signals' units
    predicted: Dict[str, np.ndarray]
    spread: Optional[np.ndarray] = None  # each parameter's deviation, residuals' over noise model's


class Estimator:
    """Constrained Gauss-Newton (Levenberg-Marquardt damped) over the global unknowns (the
    parameters' offsets, then the sensor offsets) and the segments' start states, with
    continuity between segments as constraints: each segment's end must meet the next
    one's start. Without continuity every segment would bring four unknowns of its own
    and the estimate of a nonlinear model would be biased by them (the incidental
    parameters problem: measured 1.5-4 % on a rig's raw sensors with 0.5-0.25 s segments);
    with it the answer is the whole run's least squares, while each prediction still only
    spans one segment of the unstable plant. The normal equations are dense (globals and
    4 per segment) and solved with the constraints' multipliers (a KKT system)."""

    def __init__(self, problem: Problem, sigma: Optional[Dict[str, float]], max_iter: int):
        self.p = problem
        self.max_iter = max_iter
        if sigma is not None:  # the caller's weights: one for each compared signal
            checks.of_type("weights", sigma, Mapping, "a dict {signal: noise standard deviation}")
            unknown = [s for s in sigma if s not in problem.outputs]
            missing = [s for s in problem.outputs if s not in sigma]
            if unknown or missing:
                what = f"{unknown[0]!r} is not a compared signal" if unknown else f"no noise level for {missing[0]!r}"
                raise LogError(f"weights: {what}; give one for each compared signal: {', '.join(problem.outputs)}")
            sigma = {s: checks.real(f"weights[{s!r}]", v, above=0) for s, v in sigma.items()}
        self.fixed_sigma = sigma is not None
        self.sigma = sigma if sigma is not None else {s: noise_level(s, y) for s, y in problem.y.items()}
        self.n_g = len(problem.unknowns) + len(problem.biased)
        self.param_step, self.state_step = PARAM_STEP, STATE_STEP
        #: With gear play: residuals beyond this many noise levels cost as in Huber's loss.
        self.robust_limit = ROBUST_LIMIT
        #: Segments whose start is free of the one before's end (`joins`: released).
        self.released: set = set()

    @property
    def ranges(self):
        """The samples of each shooting segment (the problem's, which a join cuts anew)."""
        return self.p.ranges

    # r = (y - h) / sigma, stacked signal by signal (with play, Huber's: `play.robust`); J = dr/d(unknowns)
    def residual(self, outputs: Dict[str, np.ndarray]) -> np.ndarray:
        r = np.concatenate([np.where(self.p.used[s], self.p.y[s] - outputs[s], 0.0) / self.sigma[s]
                            for s in self.p.outputs])
        return robust(r, self.robust_limit) if self.p.backlash is not None else r

    def split(self, x: np.ndarray):
        return x[:len(self.p.unknowns)], x[len(self.p.unknowns):]

    def evaluate(self, x, starts, schedule=None, strict=False):
        """(half the sum of squares, r, outputs, continuity gaps [S-1, 4]) at global unknowns
        `x`; an infinite cost where the model cannot be built (a step that left a
        parameter's domain; with `strict`, its error) or its prediction blew up. With gear
        play and `schedule` (the unknowns and start states of another point): the prediction with that point's
        impacts and openings replayed and its plays held, as the Jacobian's perturbed runs
        are (`sysid_shoot` runs that point first, then this one)."""
        delta, biases = self.split(x)
        k = 0
        try:
            if schedule is not None and self.p.backlash is not None:
                base_x, base_starts = schedule
                states, rates, ends, geometry = self.p.shoot([self.split(base_x)[0], delta], np.stack([base_starts, starts]))
                k = 1
            else:
                states, rates, ends, geometry = self.p.shoot([delta], starts[None])
        except (_core.InvalidParameterError, _core.NonFiniteError):
            if strict:
                raise
            return math.inf, None, None, None
        if schedule is None:
            # The point's own run: the rows near its own impacts are left out from here on (the
            # Jacobian's runs and the trial steps replay these impacts, so they keep these rows).
            self.p.note_impacts(states[0], geometry[0][3])
        out = self.p.outputs_of(states[k], rates[k], geometry[k], biases)
        r = self.residual(out)
        gaps = starts[1:] - ends[k, :-1]
        gaps[[j - 1 for j in self.released]] = 0.0
        finite = np.all(np.isfinite(r)) and np.all(np.isfinite(gaps))
        return (0.5 * float(r @ r) if finite else math.inf), r, out, gaps

    def linearise(self, x, starts):
        """The normal equations H = J^T J and g = J^T r (dense over the globals and
        4 start states per segment, assembled from each segment's blocks: J itself is
        sparse), the gaps, their Jacobian C [4 (S-1), n], and J's blocks: the globals'
        columns and each row's own segment's four."""
        n_p, n_seg = len(self.p.unknowns), len(self.ranges)
        delta, biases = self.split(x)
        deltas, runs = [delta], [starts]
        for j in range(n_p):
            for sign in (1, -1):
                d = delta.copy()
                d[j] += sign * self.param_step
                deltas.append(d)
                runs.append(starts)
        state_steps = self.state_step * np.maximum(1.0, np.abs(starts).max(axis=0))
        for c in range(4):
            for sign in (1, -1):
                s = starts.copy()
                s[:, c] += sign * state_steps[c]
                deltas.append(delta)
                runs.append(s)
        try:
            states, rates, ends, geometry = self.p.shoot(deltas, np.stack(runs))
        except _core.InvalidParameterError as e:
            # The point itself was built (evaluate): a difference step left a parameter's range.
            raise _core.InvalidParameterError(
                f"free: {e}: the fit's finite differences step each free parameter by {self.param_step:g} (of "
                "its value; the slope's in rad) either side of it: none can start at the edge of its range") from None
        h = [self.residual(self.p.outputs_of(states[k], rates[k], geometry[k], biases)) for k in range(len(deltas))]
        r, n = h[0], self.n_g + 4 * n_seg
        jg = np.zeros((len(r), self.n_g))
        d_ends = np.zeros((n_seg, 4, n))  # d(end_k)/d(unknowns)
        for j in range(n_p):
            jg[:, j] = (h[1 + 2 * j] - h[2 + 2 * j]) / (2 * self.param_step)
            d_ends[:, :, j] = (ends[1 + 2 * j] - ends[2 + 2 * j]) / (2 * self.param_step)
        for i, name in enumerate(self.p.biased):
            # An offset moves its own signal's rows only, by -1/sigma (with play, Huber's slope times).
            at = self.p.outputs.index(name) * len(self.p.log)
            column = np.where(self.p.used[name], -1.0 / self.sigma[name], 0.0)
            if self.p.backlash is not None:
                column = column * robust_slope(r[at:at + len(self.p.log)], self.robust_limit)
            jg[at:at + len(self.p.log), n_p + i] = column
        base = 1 + 2 * n_p
        # All segments' starts were moved at once: each row answers to its own segment's.
        js = np.column_stack([(h[base + 2 * c] - h[base + 2 * c + 1]) / (2 * state_steps[c]) for c in range(4)])
        for c in range(4):
            d_end = (ends[base + 2 * c] - ends[base + 2 * c + 1]) / (2 * state_steps[c])
            d_ends[np.arange(n_seg), :, self.n_g + 4 * np.arange(n_seg) + c] = d_end
        hess, grad = self.normal_equations(r, jg, js)
        gaps = (starts[1:] - ends[0, :-1]).reshape(-1)
        con = np.zeros((4 * (n_seg - 1), n))
        for k in range(n_seg - 1):
            con[4 * k:4 * k + 4] = -d_ends[k]
            con[4 * k:4 * k + 4, self.n_g + 4 * (k + 1):self.n_g + 4 * (k + 2)] += np.eye(4)
        kept = [i for i in range(len(gaps)) if i // 4 + 1 not in self.released]
        return hess, grad, gaps[kept], con[kept], (jg, js)

    def normal_equations(self, r, jg, js):
        """J^T J and J^T r from the global columns and each row's own-segment columns."""
        n, m, n_seg = len(self.p.log), len(self.p.outputs), len(self.ranges)

        def per_segment(rows: np.ndarray) -> np.ndarray:
            # Rows run signal by signal, each over the samples in time order: sum each
            # signal's rows over every segment's samples, then over the signals.
            stacked = rows.reshape(m, n, *rows.shape[1:])
            return sum(np.add.reduceat(stacked[i], self.p.segments, axis=0) for i in range(m))

        size = self.n_g + 4 * n_seg
        hess, grad = np.zeros((size, size)), np.zeros(size)
        hess[:self.n_g, :self.n_g] = jg.T @ jg
        grad[:self.n_g] = jg.T @ r
        d = per_segment(js[:, :, None] * js[:, None, :])
        b = per_segment(jg[:, :, None] * js[:, None, :])
        gk = per_segment(js * r[:, None])
        for k in range(n_seg):
            at = slice(self.n_g + 4 * k, self.n_g + 4 * k + 4)
            hess[at, at] = d[k]
            hess[:self.n_g, at] = b[k]
            hess[at, :self.n_g] = b[k].T
            grad[at] = gk[k]
        return hess, grad

    @staticmethod
    def step(hess, grad, gaps, con, lam, free):
        """The damped Gauss-Newton step of the `free` unknowns, with the linearised gaps
        closed (if `con` is given), and the multipliers."""
        h = hess[np.ix_(free, free)]
        # A tiny ridge keeps an unknown the log says nothing about where it is.
        h = h + lam * np.diag(np.diag(h)) + 1e-12 * max(float(np.max(np.diag(h))), 1e-300) * np.eye(len(free))
        g = grad[free]
        if con is None:
            return np.linalg.lstsq(h, -g, rcond=None)[0], np.zeros(0)
        kkt, scale = kkt_matrix(h, con[:, free])
        rhs = np.concatenate([-g, -gaps * scale])
        try:
            sol = np.linalg.solve(kkt, rhs)
        except np.linalg.LinAlgError:
            sol = np.linalg.lstsq(kkt, rhs, rcond=None)[0]
        return sol[:len(free)], sol[len(free):] * scale

    def covariance(self, hess, con, jacobian, times: Dict[str, float], r: np.ndarray):
        """Covariance of the global unknowns, the start states and continuity accounted for:
        the sandwich A B A^T of the fit's own weights. A, the globals' rows of the KKT
        matrix's inverse, turns the residuals' sum J^T r into the unknowns' change. B is the
        covariance of that sum: H = J^T J for white noise, for which A H A^T is the inverse's
        block itself. Filtered or coloured noise is not independent from sample to sample:
        each signal's J_s^T J_s counts `times[s]` times (its residuals' correlation time:
        samples per independent one), and the gyroscope's bias walk (`gyro_walk`) adds its
        own. Written as the block plus what these add, so that a direction without
        information keeps the block's huge variance (A H A^T would round it away). Widened to the
        spread the residuals `r` show (`spread.widened`, which also gives the ratios), compared
        with all of the noise model's, the bias walk's share included."""
        inverse = np.linalg.pinv(kkt_matrix(hess, con)[0], rcond=1e-15, hermitian=True)
        a = inverse[:self.n_g, :len(hess)]
        jg, js = jacobian
        n = len(self.p.log)
        weight = np.repeat([math.sqrt(times[s] - 1) for s in self.p.outputs], n)[:, None]
        correlated, _ = self.normal_equations(np.zeros(len(jg)), jg * weight, js * weight)
        model = inverse[:self.n_g, :self.n_g] + a @ correlated @ a.T + self.gyro_walk(jacobian, a)
        return spread.widened(model, a, jacobian, r, self.ranges, len(self.p.outputs))

    def gyro_walk(self, jacobian, a) -> np.ndarray:
        """The covariance the gyroscope's bias random walk (the IMU's `gyro_bias_walk`) adds to
        the global unknowns', `a` the rows of the globals in the inverse of the KKT matrix.
        The walk is a slow error shared by every later sample, which no correlation time
        found in a run's residuals takes in (without it, the thesis-like rig's intervals of
        m_body and com_height were 1.15x and 1.3x too narrow over 16 noise seeds, with it
        1.45x and 1.3x too wide). The walk's increment
        w_k over the interval before sample k (variance walk^2 dt_k) moves every gyro row from
        k on, so it moves the globals by w_k a Σ_{i>=k} J_i / sigma: their covariance is the
        sum over k of walk^2 dt_k (a Σ_{i>=k} J_i)(a Σ_{i>=k} J_i)^T / sigma^2 (the walk's
        start is the constant offset, an unknown of its own)."""
        imu = self.p.sensors.imu
        walk = float(imu.gyro_bias_walk) if imu is not None else 0.0
        if walk == 0.0 or "gyro" not in self.p.outputs:
            return np.zeros((self.n_g, self.n_g))
        jg, js = jacobian
        n, gyro = len(self.p.log), self.p.outputs.index("gyro")
        rows = slice(gyro * n, (gyro + 1) * n)
        segment = np.repeat(np.arange(len(self.ranges)), [len(r) for r in self.ranges])
        own = a[:, self.n_g + 4 * segment[:, None] + np.arange(4)]  # [globals, n, 4]
        moved = jg[rows] @ a[:, :self.n_g].T + np.einsum("ic,gic->ig", js[rows], own)
        later = np.cumsum(moved[::-1], axis=0)[::-1] / self.sigma["gyro"]
        dt = np.diff(self.p.log.t, prepend=self.p.log.t[0])
        return walk ** 2 * (later * dt[:, None]).T @ later

    def run(self) -> Solution:
        try:
            return self._run()
        except _core.NonFiniteError as e:
            # The start robot's prediction from the log's own start states blows up: the log's
            # columns disagree with the model (a unit, a sign), which the message names. (An
            # InvalidParameterError is a parameter's value, named as it is: not the log's.)
            raise LogError(units.diagnosis(self.p, e)) from None

    def _run(self) -> Solution:
        p = self.p
        x = np.zeros(self.n_g)
        starts = p.initial_states()
        # First the start states (and offsets) alone, the robot held and the segments apart: a
        # start state from a noisy or indirect measurement diverges fast on the unstable plant,
        # and a robot fitted to such predictions would be dragged anywhere (a huge inertia that
        # slows the fall). Then everything, joined up. Without the gear play: with the segments
        # apart, each one's play would be carried on from a neighbour's prediction gone astray
        # (from 3 % off, a rig log's fit then left for i_body +5000 %).
        backlash, p.backlash = p.backlash, None
        try:
            x, starts, _, _, iterations = self._minimise(x, starts, params=False, joined=False, tolerance=1e-6)
        finally:
            p.backlash = backlash
        segments, sigma = list(p.segments), dict(self.sigma)
        found = self._search(x, starts, release=False)
        if not found.converged and found.passed:
            # Joining left a gap open (the joined segment's end jumps in turn): from the same
            # point, the stuck boundaries are released instead.
            iterations += found.iterations
            p.cut(segments)
            self.sigma = sigma
            found = self._search(x, starts, release=True)
        x, starts, converged, message, used, gone = found
        iterations += used
        cost, r, out, _ = self.evaluate(x, starts)
        times = {s: correlation_time((p.y[s] - out[s])[p.used[s]]) for s in p.outputs}
        hess, _, _, con, jacobian = self.linearise(x, starts)
        cov, ratio = self.covariance(hess, con, jacobian, times, r)
        cov[:len(p.unknowns), :len(p.unknowns)] += np.outer(self.short, self.short)  # the step a play fit did not take
        delta, biases = self.split(x)
        information = np.linalg.pinv(cov, rcond=1e-13) if cov.size else cov
        return Solution(delta, starts, biases, dict(self.sigma), cost, iterations, converged,
                        f"{message} ({iterations} in all{passed(gone, bool(self.released))})", information,
                        {s: np.where(p.used[s], p.y[s] - out[s], np.nan) for s in p.outputs}, out,
                        ratio[:len(p.unknowns)])

    def _search(self, x, starts, release: bool) -> "Search":
        """Everything fitted, the segments joined up, the weights refitted to the residuals; a gap
        left open where the prediction jumps (`joins`) joins the segments there, or with
        `release` frees the later one's start."""
        p = self.p
        self.released = set()
        refits, iterations, gone = 0, 0, []
        while True:
            x, starts, converged, message, used = self._minimise(x, starts, params=True, joined=True)
            iterations += used
            if not converged and p.jumps() and len(gone) < MAX_JOINS:
                k = stuck_boundary(self.evaluate(x, starts)[3], starts, self.state_step)
                if k is not None:
                    gone.append(p.log.t[p.segments[k]])
                    if release:
                        self.released.add(k)
                    else:
                        p.cut(np.delete(p.segments, k))
                        starts = np.delete(starts, k, axis=0)
                    continue
            refits += 1
            if self.fixed_sigma or not converged:
                return Search(x, starts, converged, message, iterations, gone)
            # The noise levels the fit's residuals show; refit if a weight moved by > 5 %.
            _, _, out, _ = self.evaluate(x, starts)
            new = self._levels(out)
            moved = max(abs(new[s] / self.sigma[s] - 1) for s in p.outputs)
            self.sigma = new
            if moved < 0.05 or refits == 3:
                return Search(x, starts, converged, message, iterations, gone)

    def _levels(self, out) -> Dict[str, float]:
        """The noise levels the residuals of predictions `out` show. With gear play they are
        taken at every iteration: a parameter that moves an impact across a sample changes
        which rows are compared (`Problem.note_impacts`), and the first levels, read from the
        filtered signals, are far too small on a rig's log (at the tall robot's truth its
        residuals are 2.5x, 4.5x and 26.7x them for gyro, accel_x, accel_z), so that each
        such change weighed thousands."""
        p = self.p
        dof = 1 - (self.n_g + 4) / (len(p.log) * len(p.outputs))
        return {s: max(float(np.sqrt(np.mean((p.y[s] - out[s])[p.used[s]] ** 2) / dof)), noise_floor(s, p.y[s]))
                for s in p.outputs}

    def _expected_cost(self) -> float:
        """Half the chi-square a fit with the right noise levels has: half the residuals' count."""
        return max(0.5 * sum(int(np.count_nonzero(self.p.used[s])) for s in self.p.outputs), 1.0)

    def _merit(self, cost, gaps, rho):
        return cost + rho * float(np.sum(np.abs(gaps))) if gaps is not None else math.inf

    def _minimise(self, x, starts, params: bool, joined: bool, tolerance: float = 1e-12):
        n_p, n_seg = len(self.p.unknowns), len(self.ranges)
        free = np.arange(0 if params else n_p, self.n_g + 4 * n_seg)
        lam, rho = 1e-3, 0.0
        # With gear play, each trial step is weighed with this point's impacts and openings
        # replayed, the function the Jacobian differences (run free, the robot converged
        # quietly at i_body +5.4 %). The next iteration starts from the point's own.
        held = self.p.backlash is not None
        moved, self.short = np.full(n_p, np.inf), np.zeros(n_p)
        # The point the search starts from (the start robot, or where the last search ended):
        # a model that cannot be built is its error, a prediction that blows up a NonFiniteError
        # (`run` names the log's columns), not a point to step away from.
        cost, _, _, gaps = self.evaluate(x, starts, strict=True)
        if not math.isfinite(cost):
            raise _core.NonFiniteError("the prediction from the fit's starting point is not finite")
        levels = held and params and not self.fixed_sigma  # with play, from the start (_levels)
        for it in range(1, self.max_iter + 1):
            if held and (it > 1 or levels):
                # The last step was weighed with the schedule before it: this point's own.
                cost, _, out, gaps = self.evaluate(x, starts)
                if levels and math.isfinite(cost):
                    self.sigma = self._levels(out)
                    r = self.residual(out)
                    cost = 0.5 * float(r @ r)
            hess, grad, gap_vec, con, _ = self.linearise(x, starts)
            con_used = con if joined else None
            step, mu = self.step(hess, grad, gap_vec, con_used, 0.0, free)
            if joined:
                rho = max(rho, 2 * float(np.max(np.abs(mu), initial=0.0)))
            merit = self._merit(cost, gaps if joined else None, rho) if joined else cost
            closed = not joined or np.max(np.abs(gap_vec), initial=0.0) < 1e-9
            if params and closed and np.all(np.abs(step[:n_p]) < 1e-10) and it > 1:
                # The undamped step moves no parameter and the gaps are closed: converged.
                return x, starts, True, f"converged in {it} iterations", it
            if held and params and joined and it > 1:
                why, self.short = play.stop(hess, con, gap_vec, step[:n_p], moved, free, self.state_step)
                if why:
                    return x, starts, True, f"converged in {it} iterations ({why})", it
            # What the undamped step would gain, by the Gauss-Newton model of the cost.
            predicted = -(float(grad[free] @ step) + 0.5 * float(step @ hess[np.ix_(free, free)] @ step))
            # Every damped step closes the linearised gaps by `closing`: in full they would make
            # it as long as the gaps, however large lam, and far from the answer no such step
            # need lower the merit (a robot 25-75 % off stopped at its first step). Each failed
            # try damps more and closes half as much: a line search on the gaps.
            closing = 1.0
            for _ in range(16):
                step, _ = self.step(hess, grad, gap_vec * closing, con_used, lam, free)
                z = np.zeros(self.n_g + 4 * n_seg)
                z[free] = step
                new_x, new_starts = x + z[:self.n_g], starts + z[self.n_g:].reshape(n_seg, 4)
                new_cost, _, _, new_gaps = self.evaluate(new_x, new_starts, (x, starts) if held else None)
                new_merit = self._merit(new_cost, new_gaps, rho) if joined else new_cost
                if new_merit <= merit:
                    break
                lam *= 4
                closing /= 2
            else:
                if closed and predicted < CHI2_TOLERANCE:
                    # At the minimum to within rounding (an exact log's cost is ~0): no
                    # step can show, and none would move a confidence interval.
                    return x, starts, True, f"converged in {it} iterations (no step lowers the cost further)", it
                return x, starts, False, f"no step lowered the cost after {it} iterations", it
            decrease = merit - new_merit
            x, starts, cost, gaps, moved = new_x, new_starts, new_cost, new_gaps, z[:n_p]
            lam = max(lam / 3, 1e-12)
            closed = not joined or np.max(np.abs(gaps), initial=0.0) < 1e-9
            # The cost is half a chi-square (residuals over their noise): a decrease far
            # below 1 moves nothing a confidence interval could show. Where the model misfits
            # (a cost far above the residuals' count) the noise levels are too small and the
            # chi-square is that much too large: the refit with the residuals' noise levels
            # scales it back, so the tolerance scales with it.
            misfit = max(1.0, cost / self._expected_cost())
            if closed and (decrease < max(tolerance * merit, CHI2_TOLERANCE * misfit) or cost == 0):
                return x, starts, True, f"converged in {it} iterations", it
        return x, starts, False, f"not converged after {self.max_iter} iterations", self.max_iter
