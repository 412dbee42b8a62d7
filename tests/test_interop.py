"""python-control interop: to_statespace against python-control's own linearize of
to_nlsys, and control.lqr against twip.lqr; LqrController takes python-control's K."""
from __future__ import annotations

import numpy as np
import pytest

import twip

control = pytest.importorskip("control", reason="python-control is not installed (pip install 'twip[control]')")
from twip import interop  # noqa: E402


@pytest.mark.parametrize("kind", ["slope", "planar"])
def test_statespace_equals_python_controls_linearisation_of_the_nlsys(kind):
    params = twip.RobotParams.balanbot()
    if kind == "slope":
        model, x0, u0 = twip.SlopeModel(params, 0.2), [0.3, 0.5, 1.0, 2.0], 0.4
    else:
        model, x0, u0 = twip.PlanarModel(params), [0.1, 0.2, 0.3, 0.2, 0.4, 0.3, 0.5], [0.02, -0.01]
    mine = interop.to_statespace(model, x0, u0)
    theirs = control.linearize(interop.to_nlsys(model), x0, u0, copy_names=True)
    # python-control differentiates with forward differences (step 1e-6): agreement to ~1e-5.
    np.testing.assert_allclose(mine.A, theirs.A, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(mine.B, theirs.B, rtol=1e-4, atol=1e-5)
    assert list(mine.state_labels) == list(theirs.state_labels)
    # The nlsys's update function is deriv itself.
    np.testing.assert_array_equal(interop.to_nlsys(model).dynamics(0.0, x0, u0), model.deriv(x0, u0))


def test_python_controls_lqr_gains_drive_twips_controller():
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    sys = interop.to_statespace(model, [0, 0, 0, 0], 0.0)
    # The LQR state of the 2-DOF model without theta (its dynamics do not depend on it).
    keep = [0, 1, 3]
    q, r = np.diag([100.0, 1.0, 1.0]), np.array([[1.0]])
    a, b = sys.A[np.ix_(keep, keep)], sys.B[keep, :]
    k_control, s_control, _ = control.lqr(a, b, q, r)
    k_twip, s_twip, _ = twip.lqr(a, b, q, r)
    np.testing.assert_allclose(k_twip, k_control, rtol=1e-9)
    np.testing.assert_allclose(s_twip, s_control, rtol=1e-9)
    # A (1, 4) K as python-control returns it: [k_phi, k_phi_dot, k_theta_dot, k_z].
    row = np.hstack([np.asarray(k_control), [[0.0]]])
    assert row.shape == (1, 4)
    ctrl = twip.LqrController(model, row, period=1e-3)
    np.testing.assert_array_equal(ctrl.gains, row.ravel())
    r = twip.simulate(model, ctrl, [0.1, 0, 0, 0], 5.0, 1e-3)
    assert r.outcome == "completed" and abs(r.states[-1, 0]) < 1e-3


def test_bad_points_are_named():
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    with pytest.raises(twip.ShapeError, match=r"x0 has shape \(3,\), expected \(4,\)"):
        interop.to_statespace(model, [0, 0, 0], 0.0)
    with pytest.raises(twip.NonFiniteError, match="u0"):
        interop.to_statespace(model, [0, 0, 0, 0], float("nan"))
    with pytest.raises(TypeError, match="SlopeModel or twip.PlanarModel"):
        interop.to_nlsys(object())
    with pytest.raises(TypeError, match=r"x0 must be numbers, got 'abcd' \(str\)"):
        interop.jacobians(model, "abcd", [0.0])  # was numpy's "could not convert string to float"
    with pytest.raises(twip.InvalidParameterError, match=r"^x0\[2\] = 0.1j: not a real number \(got complex\)$"):
        interop.jacobians(model, np.array([0, 0, 0.1j, 0]), [0.0])  # was cast to its real parts


def test_the_module_docstring_recipe_runs_and_gives_the_design_gains():
    # The recipe once handed control.lqr's K on [phi, phi_dot, theta, theta_dot] to
    # LqrController, which reads [phi, phi_dot, theta_dot - ref, z]: two gains swapped.
    recipe = "\n".join(line[4:] for line in interop.__doc__.splitlines() if line.startswith("    "))
    scope: dict = {}
    exec(compile(recipe, "twip/interop.py docstring", "exec"), scope)
    design = twip.LqrController.design(scope["model"], 0.0, [100.0, 1.0, 1.0, 1.0], 480.0)
    np.testing.assert_allclose(scope["ctrl"].gains, design.gains, rtol=1e-8)
    r = twip.scenarios.get("flat-lqr").replace(controller=scope["ctrl"]).run()
    assert r.outcome == "completed"
