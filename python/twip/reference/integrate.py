"""Classical fixed-step RK4, written out for the reference."""
from __future__ import annotations

import numpy as np


def rk4_step(model, x, u, dt: float) -> np.ndarray:
    """One RK4 step of `model.deriv` with the input `u` held over the step."""
    x = np.asarray(x, dtype=float)
    k1 = model.deriv(x, u)
    k2 = model.deriv(x + 0.5 * dt * k1, u)
    k3 = model.deriv(x + 0.5 * dt * k2, u)
    k4 = model.deriv(x + dt * k3, u)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
