"""Reference speed schedule, LQR-with-integral controller, design and runner (numpy/scipy)."""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg import solve_continuous_are

from twip.reference.real import real, reals


class SpeedSchedule:
    """Legs of (goal [rad], speed [rad/s] > 0, hold [s]) from theta = 0 at t = 0."""

    def __init__(self, legs):
        self.legs = [tuple(reals(f"legs[{i}]", leg)) for i, leg in enumerate(legs)]

    @classmethod
    def constant(cls, speed: float) -> "SpeedSchedule":
        return cls([(math.copysign(math.inf, speed), abs(speed), 0.0)]) if speed else cls([])

    def sample(self, t: float):
        start, at, active = 0.0, 0.0, None
        for goal, speed, hold in self.legs:
            if start > t:
                break
            active = (start, at, goal, speed)
            start += abs(goal - at) / speed + hold
            at = goal
        if active is None:
            return 0.0, 0.0
        t0, origin, goal, speed = active
        travelled = speed * (t - t0)
        if travelled < abs(goal - origin):
            sign = 1.0 if goal >= origin else -1.0
            return origin + sign * travelled, sign * speed
        return goal, 0.0


def lqr_design(model, theta_dot_ref: float, Q, R: float, point: str = "operating"):
    """K-hat of (4.17)-(4.23) on [phi, phi_dot, theta_dot, z]; scipy's CARE solver."""
    if point == "thesis":
        A3, B3, _ = model.linearize_thesis()
    else:
        x_s, u_s = model.equilibrium(theta_dot_ref)
        A3, B3 = _jacobian(model, x_s, u_s)
    A = np.zeros((4, 4))
    A[:3, :3] = A3
    A[3, 2] = 1.0
    B = np.vstack([B3.reshape(3, 1), [[0.0]]])
    Q = np.diag(Q) if np.ndim(Q) == 1 else np.asarray(Q, dtype=float)
    X = solve_continuous_are(A, B, Q, np.array([[R]]))
    return (B.T @ X / R).ravel()


def _jacobian(model, x0, u0, h=1e-6):
    """Central differences on [phi, phi_dot, theta_dot] (the reference has no analytic one)."""
    keep = [0, 1, 3]
    cols = []
    for i in keep:
        e = np.zeros(4)
        e[i] = h
        cols.append((model.deriv(x0 + e, u0) - model.deriv(x0 - e, u0))[keep] / (2 * h))
    B = (model.deriv(x0, u0 + h) - model.deriv(x0, u0 - h))[keep] / (2 * h)
    return np.column_stack(cols), B


class LqrController:
    """u = u_s - k1 (x - x_s) - k2 z, z integrated by forward Euler at the controller's period."""

    internal_names = ("z", "phi_s", "u_s", "theta_dot_ref")

    def __init__(self, model, gains, point: str = "operating", period: float = 0.005):
        self.model, self.point, self.period = model, point, real("period", period)
        self.gains = np.asarray(reals("gains", np.ravel(np.asarray(gains, dtype=object))), float)
        self.reset()

    def reset(self):
        self.z = 0.0
        self.internals = (0.0, 0.0, 0.0, 0.0)

    def steady_state(self, speed):
        x_s, u_s = self.model.equilibrium_linear(speed) if self.point == "thesis" else self.model.equilibrium(speed)
        return x_s[0], u_s

    def update(self, t, y, ref):
        _theta_ref, speed = ref
        phi_s, u_s = self.steady_state(speed)
        err = y[3] - speed
        k = self.gains
        u = u_s - (k[0] * (y[0] - phi_s) + k[1] * y[1] + k[2] * err) - k[3] * self.z
        self.internals = (self.z, phi_s, u_s, speed)
        self.z += err * self.period
        return u


def simulate(model, controller, x0, t_final, dt, reference, fall_limit=math.radians(60), internals=False):
    """Plain loop: controller every period (zero-order hold), RK4 in between.

    Returns (t, states, inputs), and the controller's `internals` per sample as a fourth
    array (one row per sample, as of the last update) when `internals=True`."""
    from twip.reference.integrate import rk4_step

    n = round(t_final / dt)
    per_update = round(controller.period / dt)
    x, u = np.array(x0, float), 0.0
    ts, xs, us, ins = [], [], [], []
    for k in range(n):
        t = k * dt
        ref = reference.sample(t)
        if k % per_update == 0:
            u = controller.update(t, x, ref)
        ts.append(t)
        xs.append(x)
        us.append(u)
        ins.append(controller.internals)
        x = rk4_step(model, x, u, dt)
        if abs(x[0]) > fall_limit:
            break
    ts.append(len(ts) * dt)
    xs.append(x)
    us.append(u)
    ins.append(controller.internals)
    out = np.array(ts), np.array(xs), np.array(us)
    return out + (np.array(ins),) if internals else out
