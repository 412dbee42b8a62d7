"""DARE, dlqr and c2d: SciPy's own DAREX cases, python-control's dlqr, SciPy's zero-order hold,
and the named errors.

SciPy's `TestSolveDiscreteAre` lists 19 cases with the absolute tolerance its residual
Aᵀ X A − X − Aᵀ X B (R + Bᵀ X B)⁻¹ Bᵀ X A + Q must reach (`max_tol`, from `min_decimal`, with
SciPy's own relaxations); none is marked a known failure. The first three have complex data:
twip's solver is real, so they are refused by name (a ShapeError would be wrong: it is the
kind of number), and the 16 real ones must pass at SciPy's tolerances with a stable loop.
"""
import math

import numpy as np
import pytest
import scipy.linalg as sl
import scipy.signal as ss

import twip

darex = pytest.importorskip("scipy.linalg.tests.test_solvers").TestSolveDiscreteAre
CASES = [tuple(np.atleast_2d(np.asarray(m)) for m in case[:4]) + (case[4],) for case in darex.cases]
REAL = [j for j, case in enumerate(CASES) if not any(np.iscomplexobj(m) for m in case[:4])]
COMPLEX = [j for j in range(len(CASES)) if j not in REAL]


def _residual(x, a, b, q, r):
    xa, xb = x @ a, x @ b
    return a.T @ xa - x + q - a.T @ xb @ np.linalg.solve(r + b.T @ xb, b.T @ xa)


def _real(case):
    return [np.asarray(m, float) for m in case[:4]]


def test_scipy_lists_the_cases_we_expect():
    assert len(CASES) == 19 and len(REAL) == 16 and COMPLEX == [0, 1, 2]
    assert not any(case[4] for case in CASES), "SciPy marks no DAREX case a known failure"


@pytest.mark.parametrize("j", REAL)
def test_darex_at_scipys_tolerance(j):
    a, b, q, r = _real(CASES[j])
    x = twip.dare(a, b, q, r)
    np.testing.assert_allclose(_residual(x, a, b, q, r), 0, atol=darex.max_tol[j])
    np.testing.assert_allclose(x, x.T, rtol=0, atol=0)
    k = np.linalg.solve(r + b.T @ x @ b, b.T @ x @ a)
    assert np.abs(np.linalg.eigvals(a - b @ k)).max() < 1


@pytest.mark.parametrize("j", REAL)
def test_darex_agrees_with_scipy(j):
    """Where SciPy's own answer is accurate (its residual within its tolerance), ours is the
    same solution: the stabilising one is unique."""
    a, b, q, r = _real(CASES[j])
    theirs = sl.solve_discrete_are(a, b, q, r)
    if np.abs(_residual(theirs, a, b, q, r)).max() > darex.max_tol[j]:
        pytest.skip("SciPy's own solution misses its tolerance here")
    ours = twip.dare(a, b, q, r)
    assert np.abs(ours - theirs).max() <= 1e-6 * max(1.0, np.abs(theirs).max())


@pytest.mark.filterwarnings("error")  # refused, not cast with a ComplexWarning first
@pytest.mark.parametrize("j", COMPLEX)
def test_complex_darex_cases_are_refused_by_name(j):
    a, b, q, r = CASES[j][:4]
    first = next(name for name, m in zip("ABQR", (a, b, q, r)) if np.iscomplexobj(m))
    with pytest.raises(twip.InvalidParameterError, match=rf"^{first}\[\d+\] = .*: not a real number \(got complex\)$"):
        twip.dare(a, b, q, r)


def test_singular_r_as_scipy_allows():
    """DAREX #3 has R = 0: SciPy's extended pencil needs no inverse of R, nor does ours."""
    a, b, q, r = _real(CASES[6])
    assert np.all(r == 0)
    np.testing.assert_allclose(twip.dare(a, b, q, r), sl.solve_discrete_are(a, b, q, r), atol=1e-12)


def _systems():
    rng = np.random.default_rng(59)
    yield "double integrator", *twip.c2d([[0, 1], [0, 0]], [0, 1], 0.1), np.eye(2), 1.0
    for n, m in [(3, 1), (4, 2), (6, 3)]:
        a = rng.normal(size=(n, n))
        b = rng.normal(size=(n, m))
        yield f"random {n}x{m}", a, b, np.diag(rng.uniform(0.1, 10, n)), np.diag(rng.uniform(0.1, 10, m))
    model = twip.SlopeModel(twip.RobotParams.balanbot(), math.radians(15))
    info = twip.LqrController.design(model, math.radians(250), [10, 10, 1, 1], 1000.0).design_info
    ad, bd = twip.c2d(info["A"], info["B"], 0.005)
    yield "twip slope model (4.19) at 5 ms", ad, bd, np.diag([10.0, 10, 1, 1]), 1000.0


@pytest.mark.parametrize("name, a, b, q, r", list(_systems()), ids=[s[0] for s in _systems()])
def test_dlqr_equals_python_control(name, a, b, q, r):
    control = pytest.importorskip("control")
    k, s, e = twip.dlqr(a, b, q, r)
    k_c, s_c, e_c = control.dlqr(a, b, q, r)
    scale = max(1.0, np.abs(s_c).max())
    np.testing.assert_allclose(k, k_c, rtol=0, atol=1e-9 * max(1.0, np.abs(k_c).max()))
    np.testing.assert_allclose(s, s_c, rtol=0, atol=1e-9 * scale)
    key = lambda z: (round(z.real, 9), round(z.imag, 9))  # noqa: E731
    np.testing.assert_allclose(sorted(e, key=key), sorted(e_c, key=key), atol=1e-9)
    assert e.dtype == np.complex128 and np.abs(e).max() < 1


@pytest.mark.parametrize("period", [1e-3, 0.005, 0.1, 2.0])
def test_c2d_equals_scipys_zero_order_hold(period):
    rng = np.random.default_rng(7)
    model = twip.SlopeModel(twip.RobotParams.balanbot(), 0.2)
    info = twip.LqrController.design(model, 3.0, [10, 10, 1, 1], 1000.0).design_info
    for a, b in [(info["A"], info["B"]), (rng.normal(size=(5, 5)), rng.normal(size=(5, 2)))]:
        ad, bd = twip.c2d(a, b, period)
        ad_s, bd_s, *_ = ss.cont2discrete((a, b, np.eye(len(a)), 0), period, method="zoh")
        np.testing.assert_allclose(ad, ad_s, rtol=1e-12, atol=1e-13 * np.abs(ad_s).max())
        np.testing.assert_allclose(bd, bd_s, rtol=1e-12, atol=1e-13 * np.abs(bd_s).max())


def test_c2d_accepts_a_1d_b_and_names_bad_input():
    ad, bd = twip.c2d([[-1.0]], [1.0], 0.5)
    assert bd.shape == (1, 1) and bd[0, 0] == pytest.approx(1 - math.exp(-0.5), rel=1e-15)
    with pytest.raises(twip.InvalidParameterError, match="period"):
        twip.c2d([[1.0]], [1.0], 0.0)
    with pytest.raises(twip.InvalidParameterError, match="period"):
        twip.c2d([[1.0]], [1.0], math.nan)
    with pytest.raises(twip.InvalidParameterError, match="overflows"):
        twip.c2d([[1e3]], [1.0], 1e3)
    with pytest.raises(twip.ShapeError, match="B"):
        twip.c2d(np.eye(2), [1.0], 0.1)
    with pytest.raises(twip.NonFiniteError, match="A"):
        twip.c2d([[math.inf]], [1.0], 0.1)


def test_not_stabilizable():
    with pytest.raises(twip.NotStabilizableError, match="mode at λ = 2 is unstable"):
        twip.dare(np.diag([2.0, 0.5]), [0.0, 1.0], np.eye(2), 1.0)


def test_a_unit_circle_mode_invisible_to_q():
    with pytest.raises(twip.NotDetectableError):
        twip.dare([[1.0]], [1.0], [[0.0]], 1.0)


@pytest.mark.parametrize("name, args", [
    ("A", (np.ones((2, 3)), np.ones((2, 1)), np.eye(2), 1.0)),
    ("B", (np.eye(2), np.ones((3, 1)), np.eye(2), 1.0)),
    ("Q", (np.eye(2), np.ones((2, 1)), np.eye(3), 1.0)),
    ("R", (np.eye(2), np.ones((2, 1)), np.eye(2), np.eye(2))),
])
def test_bad_shapes(name, args):
    with pytest.raises(twip.ShapeError, match=name):
        twip.dare(*args)
    with pytest.raises(twip.ShapeError, match=name):
        twip.dlqr(*args)


@pytest.mark.parametrize("which", range(4))
def test_non_finite(which):
    args = [np.eye(2) * 0.5, np.ones((2, 1)), np.eye(2), np.eye(1)]
    args[which] = args[which].copy()
    args[which][0, 0] = math.nan
    with pytest.raises(twip.NonFiniteError, match="ABQR"[which]):
        twip.dare(*args)


def test_not_symmetric():
    with pytest.raises(twip.InvalidParameterError, match="Q"):
        twip.dare(np.eye(2) * 0.5, np.ones((2, 1)), [[1.0, 0.5], [0.0, 1.0]], 1.0)
    with pytest.raises(twip.InvalidParameterError, match="R"):
        twip.dare(np.eye(2) * 0.5, np.eye(2), np.eye(2), [[1.0, 0.5], [0.0, 1.0]])


def test_singular_r_where_the_pencil_does_not_allow_it():
    """R = 0 and a cost that never sees the state (Q = 0, A stable): the extended pencil is
    singular (its determinant vanishes for every λ) and R + Bᵀ X B = 0 at X = 0, so no gain
    exists. SciPy returns X = 0 here without a word; twip names it."""
    args = ([[0.5]], [1.0], [[0.0]], 0.0)
    with pytest.raises(twip.NoStabilizingSolutionError):
        twip.dare(*args)
    with pytest.raises(twip.NoStabilizingSolutionError):
        twip.dlqr(*args)


def test_a_rotation_no_cost_sees():
    """A = rotation by 90°, Q = 0: SciPy returns X = 0, whose loop (K = 0) keeps both
    eigenvalues on the unit circle; no stabilising solution exists, and twip says why."""
    with pytest.raises(twip.NotDetectableError):
        twip.dare([[0.0, -1.0], [1.0, 0.0]], [1.0, 0.0], np.zeros((2, 2)), 1.0)
