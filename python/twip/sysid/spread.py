"""How far the fit's own residuals spread its estimate: the empirical (cluster-robust) sandwich
beside the noise model's covariance, and the check that the two agree.

The estimator's covariance assumes the residuals are its noise model's: each signal's noise at
its level, correlated as its own residuals are (`Estimator.covariance`). Where the model misses
a part of the log that moves with the parameters, the residuals are not that noise: they are
large exactly where the prediction is sensitive, and the parameters they pull on are less
certain than the noise model says. The empirical sandwich measures that from the residuals
themselves: each segment's residuals move the parameters by A J_k^T r_k (A the globals' rows of
the KKT matrix's inverse, J_k and r_k the segment's rows), and the covariance of those moves
over the segments is what the log's residuals, not the model, say (White's sandwich with
clusters; a segment is long against the filtered signals' correlation time). Where it is wider
than the noise model's, the interval takes it, and a ratio above SPREAD_LIMIT (White's
information-matrix test in spirit) is a misfit: the model does not explain the log where it
matters for that parameter.

Measured (benches/sysid.py's tall robot, full rig, friction and play declared, noise seed 2,
before this check): i_body +6.76 % with a standard deviation of 1.50 %, converged and quiet;
the empirical sandwich gave 4.83 %. The gyro's residuals 26-84 samples after the model's
impacts were 1.5-2.6 of its noise level, those far from any impact 0.62: the model's impacts
were not the log's, and the level taken from all residuals hid it. On seeds 0, 1 and 5 (within
0.8 %) the empirical deviations were 0.7-1.0 of the noise model's.
"""
from __future__ import annotations

import math
from typing import List, Sequence

import numpy as np

from twip.sysid.misfit import ADVICE

#: A parameter misfits when the residuals spread its estimate more than this many times as
#: wide (standard deviations) as the noise model does. The empirical deviation of S segments
#: has a relative sampling error of about 1/sqrt(2 S) (12 % for the 32 segments of an 8 s log).
SPREAD_LIMIT = 2.0
#: Fewer segments than this give no empirical covariance worth comparing.
MIN_SEGMENTS = 8


def empirical(a: np.ndarray, jg: np.ndarray, js: np.ndarray, r: np.ndarray, ranges: Sequence[range],
              n_g: int, n_signals: int) -> np.ndarray:
    """The covariance of the global unknowns (n_g of them) that the residuals `r` show, segment
    by segment: the spread over the segments of A J_k^T r_k. `a`: the globals' rows of the KKT
    matrix's inverse over the unknowns (globals, then 4 start states per segment); `jg` and `js`:
    the Jacobian's global columns and each row's own segment's four, rows signal by signal as
    `Estimator.residual` stacks them."""
    n = len(r) // n_signals
    starts = np.array([rg.start for rg in ranges])
    moves = np.zeros((len(ranges), n_g))
    own = a[:, n_g:].reshape(n_g, len(ranges), 4)  # each segment's start states' columns
    for k in range(n_signals):
        rows = slice(k * n, (k + 1) * n)
        weighted_g = np.add.reduceat(jg[rows] * r[rows, None], starts, axis=0)  # [S, n_g]
        weighted_s = np.add.reduceat(js[rows] * r[rows, None], starts, axis=0)  # [S, 4]
        moves += weighted_g @ a[:, :n_g].T
        moves += np.einsum("sc,gsc->sg", weighted_s, own)
    moves -= moves.mean(axis=0)
    return moves.T @ moves * len(ranges) / max(len(ranges) - 1, 1)


def widened(model: np.ndarray, a: np.ndarray, jacobian, r: np.ndarray, ranges: Sequence[range], n_signals: int):
    """The noise `model`'s covariance of the globals widened to the residuals' empirical one
    (`larger`), and each global's ratio of the two deviations (`ratios`); `model` and ones with
    fewer than MIN_SEGMENTS segments or no globals. The arguments as `empirical` takes them."""
    if len(ranges) < MIN_SEGMENTS or len(model) == 0:
        return model, np.ones(len(model))
    measured = empirical(a, *jacobian, r, ranges, len(model), n_signals)
    return larger(model, measured), ratios(model, measured)


def larger(model: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """The least covariance at least as wide as both `model` and `measured` in every direction
    (each eigenvalue of `measured` in `model`'s metric raised to 1): `model` where the residuals
    spread the estimate less, `measured` where they spread it more."""
    d = np.sqrt(np.clip(np.diag(model), 0, None))
    if not len(d) or not np.all(np.isfinite(model)) or not np.all(d > 0):
        return model
    values, vectors = np.linalg.eigh(model / np.outer(d, d))
    if values.min() <= 1e-12 * values.max():
        return model
    root = vectors * np.sqrt(values)
    inverse = vectors / np.sqrt(values)
    m = inverse.T @ (measured / np.outer(d, d)) @ inverse
    lam, u = np.linalg.eigh((m + m.T) / 2)
    inner = (u * np.maximum(lam, 1.0)) @ u.T
    return root @ inner @ root.T * np.outer(d, d)


def ratios(model: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Each unknown's empirical standard deviation over the noise model's (1 where either is
    not a finite positive number)."""
    a, b = np.diag(model), np.diag(measured)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.sqrt(b / a)
    return np.where(np.isfinite(out) & (a > 0), out, 1.0)


def check(names: Sequence[str], ratio: Sequence[float]) -> List[str]:
    """One sentence for each parameter whose residuals spread it more than SPREAD_LIMIT times as
    wide as the noise model does."""
    return [f"{n}: the residuals spread its estimate {q:.1f}x as wide as the noise model does (segment by "
            f"segment): they are not noise where the prediction depends on {n}, so the model does not explain "
            f"the log there and the value may be off by more than its noise; its interval is widened to what the "
            f"residuals show. {ADVICE}" for n, q in zip(names, ratio) if math.isfinite(q) and q > SPREAD_LIMIT]
