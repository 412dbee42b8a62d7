"""The KKT matrix of the constrained Gauss-Newton problem (normal equations and the gaps'
constraints), shared by the estimator's steps, its covariance and the play's convergence test."""
from __future__ import annotations

import math
from typing import Tuple

import numpy as np


def kkt_matrix(h: np.ndarray, con: np.ndarray) -> Tuple[np.ndarray, float]:
    """[[h, C^T], [C, 0]] and the scale s of C = s con: the constraints are scaled to the
    normal equations' size, so that the matrix is balanced (1/sigma^2 weights make h's entries
    huge against the constraints')."""
    scale = math.sqrt(max(float(np.max(np.abs(np.diag(h)))), 1e-300))
    c = con * scale
    return np.block([[h, c.T], [c, np.zeros((c.shape[0], c.shape[0]))]]), scale
