"""python-control interop: twip's models as `control.StateSpace` and `control.NonlinearIOSystem`.

    import control, numpy as np, twip, twip.interop
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    sys = twip.interop.to_statespace(model, [0, 0, 0, 0], 0.0)     # exact Jacobian, x = [phi, phi_dot, theta, theta_dot]
    # LqrController's gains act on [phi, phi_dot, theta_dot - ref, z], z = integral of (theta_dot - ref):
    # drop theta (nothing depends on it) and append z, as LqrController.design does (thesis 4.19).
    keep = [0, 1, 3]
    A = np.zeros((4, 4)); A[:3, :3] = sys.A[np.ix_(keep, keep)]; A[3, 2] = 1.0
    B = np.vstack([sys.B[keep, :], [[0.0]]])
    K, S, E = control.lqr(A, B, np.diag([100.0, 1.0, 1.0, 1.0]), 480.0)   # K is (1, 4) in that order
    ctrl = twip.LqrController(model, K)                             # = LqrController.design(model, 0.0, Q, R)
    nl = twip.interop.to_nlsys(model)                               # update function = model.deriv

The full (1, 4) K of `control.lqr(sys, Q, R)` on the plant's own states is in the order
[phi, phi_dot, theta, theta_dot]: LqrController would read its theta and theta_dot gains as
the speed and integral gains. `tests/test_interop.py` runs the recipe above.

python-control is an optional dependency: `pip install 'twip[control]'`.
"""
from __future__ import annotations

import numpy as np

from twip import _core, checks

#: State and input names, per model (the order of `deriv`).
SLOPE_STATES = ("phi", "phi_dot", "theta", "theta_dot")
SLOPE_INPUTS = ("u",)
PLANAR_STATES = ("x", "y", "psi", "phi", "phi_dot", "v", "omega")
PLANAR_INPUTS = ("u_r", "u_l")

#: Central-difference step of the planar Jacobian (the 2-DOF model has an exact one).
_STEP = 1e-6


def _control():
    try:
        import control
    except ImportError as e:
        raise ImportError("twip.interop needs python-control: pip install 'twip[control]'") from e
    return control


def _names(model):
    if isinstance(model, _core.SlopeModel):
        return SLOPE_STATES, SLOPE_INPUTS
    if isinstance(model, _core.PlanarModel):
        return PLANAR_STATES, PLANAR_INPUTS
    raise TypeError(f"model must be a twip.SlopeModel or twip.PlanarModel, got {type(model).__name__}")


def jacobians(model, x0, u0):
    """(A, B) of `model` about (x0, u0): exact for a SlopeModel, central differences of
    `deriv` (step 1e-6, relative error ~1e-9) for a PlanarModel."""
    states, inputs = _names(model)
    x0 = checks.vector("x0", x0, len(states))
    u0 = checks.vector("u0", u0, len(inputs))
    if isinstance(model, _core.SlopeModel):
        return model.linearize(x0, float(u0[0]))
    a = np.empty((len(states), len(states)))
    b = np.empty((len(states), len(inputs)))
    for j in range(len(states)):
        h = _STEP * max(1.0, abs(x0[j]))
        dx = np.zeros(len(states))
        dx[j] = h
        a[:, j] = (model.deriv(x0 + dx, u0) - model.deriv(x0 - dx, u0)) / (2 * h)
    for j in range(len(inputs)):
        h = _STEP * max(1.0, abs(u0[j]))
        du = np.zeros(len(inputs))
        du[j] = h
        b[:, j] = (model.deriv(x0, u0 + du) - model.deriv(x0, u0 - du)) / (2 * h)
    return a, b


def to_statespace(model, x0, u0):
    """`model` linearised about (x0, u0) as a `control.StateSpace` with every state as an
    output (C = I, D = 0) and named states and inputs."""
    control = _control()
    states, inputs = _names(model)
    a, b = jacobians(model, x0, u0)
    n = len(states)
    return control.ss(a, b, np.eye(n), np.zeros((n, len(inputs))), states=list(states), inputs=list(inputs),
                      outputs=list(states))


def to_nlsys(model, name=None):
    """`model` as a `control.NonlinearIOSystem`: the update function is `model.deriv`,
    the outputs are the states."""
    control = _control()
    states, inputs = _names(model)

    def update(t, x, u, params):
        return model.deriv(x, u)

    return control.nlsys(update, None, states=list(states), inputs=list(inputs), outputs=list(states),
                         name=name or type(model).__name__)
