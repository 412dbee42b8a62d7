"""What declared gear play changes in the estimator (`identify(..., backlash=)`).

The IMU samples the pitch rate after an impact at its sample and before it otherwise: a
parameter that moves an impact across a sample instant moves that one sample by the impact's
jump, which the filter spreads over the next samples (15-21 noise levels on the tall robot's
log of benches/sysid.py), so the cost jumps there. The filtered rows near each impact are left
out, as a segment's start is, and the fit's convergence allows for the rows that enter and
leave those windows from one iteration to the next.
"""
from __future__ import annotations

import math
from typing import Dict, Optional, Tuple

import numpy as np

from twip.sysid.kkt import kkt_matrix
from twip.sysid.measure import impact_samples

#: With gear play declared, the fit has also converged when the gaps are below the start
#: states' difference step and the undamped step moves every parameter by less than
#: PLAY_STEP of its standard deviation (white noise's: the fit's own is larger): rows enter
#: and leave the impacts' windows from one iteration to the next (`Problem.note_impacts`), so
#: the cost keeps moving by a fraction of a chi-square unit and no decrease settles below
#: CHI2_TOLERANCE (the mid robot's log: 0.02 to 0.3 for 30 iterations, the steps 0.04-0.26
#: of those deviations, within 0.51 % of the robot, "not converged after 50 iterations").
PLAY_STEP = 0.25
#: ... or when its search has stalled within STALL_STEP of a deviation of that step, the last
#: accepted step moving no parameter by more than STALL_MOVE of one: the friction's stick
#: band switches within plant steps, which the differences do not replay, so the cost along
#: the Gauss-Newton step can rise from its first 1 % (mid robot seed 2: the start states'
#: columns' prediction -0.0063, measured +0.0015), and the line search only closes the gaps
#: (mid seeds 2 and 3, and two robots never tuned on, stalled 0.2-0.54 of a deviation short,
#: "not converged after 50 iterations", within 0.07-1.44 %). The step not taken is added to
#: the covariance.
STALL_STEP = 1.0
STALL_MOVE = 0.01
#: With gear play declared, a residual beyond ROBUST_LIMIT noise levels costs as in Huber's
#: loss: linearly in its size, not squared. Where the model's impacts are not quite the log's,
#: the jumps leak past the left-out windows (tall robot, seed 2: the gyro's residuals 26-32
#: samples after an impact 2.6 noise levels in RMS, far from them 0.62), and squared they
#: pulled the fit there: benches/sysid.py --accuracy --robots tall --case 'friction and play'
#: seeds 2 and 3 were i_body +6.76 % (warned) and +10.6 % (not converged); with the limit 2,
#: +2.62 % and +0.30 %, converged and quiet. Only with the play: its noise
#: levels follow the residuals from the start (`Estimator._levels`), so that a limit in them
#: means something; without the play the first levels are the log's second differences, far
#: below a filtered signal's residuals, and the same limit made the user robot's clean 1 kHz
#: fit lose itself (i_body +314 %, not converged).
ROBUST_LIMIT = 2.0


def rows_near_impacts(grid, sensors, settled: Dict[str, np.ndarray], states: np.ndarray,
                      sensed: np.ndarray) -> Dict[str, np.ndarray]:
    """The rows compared of each signal (`settled`: the segments' starts left out), less the
    filtered signals' rows from the IMU sample before each impact of a run (its `states` [n, 4]
    and `sensed` [n, 2] on `grid`) to `measure.IMPACT_DELAYS` filter delays after it."""
    # An impact at a sample changes the rate the IMU samples there (the state's is before it).
    jumps = np.flatnonzero(sensed[:, 1] != states[:, 1])
    n = len(grid.t)
    used = dict(settled)
    for s in settled:
        after = impact_samples(sensors, s)
        if after == 0:
            continue
        # Grid samples from the one before the impact (it may move there) to the last that
        # still reads the impact's sample through the filter (the register is one behind).
        edges = np.zeros(n + 1, dtype=np.int64)
        np.add.at(edges, np.maximum(jumps - 1, 0), 1)
        np.add.at(edges, np.minimum(jumps + after + 2, n), -1)
        near = np.cumsum(edges[:n]) > 0
        used[s] = settled[s] & ~near[grid.rows]
    return used


def robust(r: np.ndarray, limit: float = ROBUST_LIMIT) -> np.ndarray:
    """Residuals `r` (in noise levels) rescaled so that half their sum of squares is Huber's
    loss with `limit` k: r within it, sign(r) sqrt(2 k |r| - k^2) beyond (its slope is
    continuous at the limit, so the Gauss-Newton steps and central differences see a smooth
    function). An infinite limit leaves them as they are."""
    if not math.isfinite(limit):
        return r
    size = np.abs(r)
    return np.where(size > limit, np.sign(r) * np.sqrt(np.maximum(2 * limit * size - limit * limit, 0.0)), r)


def robust_slope(rescaled: np.ndarray, limit: float = ROBUST_LIMIT) -> np.ndarray:
    """d robust(r) / dr, from the rescaled residuals `robust` gave: 1 within the limit, k / |r~|
    beyond (for a Jacobian column written by hand, as a sensor offset's)."""
    if not math.isfinite(limit):
        return np.ones_like(rescaled)
    size = np.abs(rescaled)
    return np.where(size > limit, limit / np.maximum(size, limit), 1.0)


def stop(hess, con, gaps, step, moved, free, gap_tolerance: float) -> Tuple[Optional[str], np.ndarray]:
    """Has a fit with gear play converged, and by how much may it be short of the Gauss-Newton
    model's minimum? With the `gaps` below `gap_tolerance` (the start states' difference
    step): when the parameters' undamped `step` is within PLAY_STEP of their standard
    deviations (from the normal equations `hess` over the unknowns `free` and the gaps'
    constraints `con`: white noise, so smaller than the fit's own), or within STALL_STEP of
    them while the last accepted step `moved` none by more than STALL_MOVE of one. Returns
    why (None: not converged) and the step not taken, which the covariance adds."""
    if np.max(np.abs(gaps), initial=0.0) >= gap_tolerance:
        return None, np.zeros(len(step))
    kkt, _ = kkt_matrix(hess[np.ix_(free, free)], con[:, free])
    deviation = np.sqrt(np.maximum(np.diag(np.linalg.pinv(kkt, rcond=1e-15, hermitian=True))[:len(step)], 1e-300))
    short = float(np.max(np.abs(step) / deviation, initial=0.0))
    if short < PLAY_STEP:
        return f"steps within {PLAY_STEP} of a deviation", np.asarray(step)
    if short < STALL_STEP and np.max(np.abs(moved) / deviation, initial=0.0) < STALL_MOVE:
        return (f"stalled {short:.2f} of a deviation short of the Gauss-Newton step, intervals widened by it",
                np.asarray(step))
    return None, np.zeros(len(step))
