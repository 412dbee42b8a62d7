"""CARE on the CAREX benchmark cases of SciPy's own test suite, read from the installed SciPy.

SciPy's `TestSolveContinuousAre` lists 20 cases: 15 standard ones, each with the number of
decimals its residual X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q must reach (`min_decimal`), and 5 that
SciPy itself marks as known failures ("Bad Residual Accuracy"). twip must pass all 15 at
SciPy's decimals; on the hard ones it must beat SciPy's own relative residual (relative to
the norms of the equation's terms) in at least 2, with a stable closed loop.
"""
import numpy as np
import pytest
import scipy.linalg as sl

import twip

carex = pytest.importorskip("scipy.linalg.tests.test_solvers").TestSolveContinuousAre
CASES = [tuple(np.atleast_2d(np.asarray(m, float)) for m in case[:4]) + (case[4],) for case in carex.cases]
STANDARD = [j for j, case in enumerate(CASES) if not case[4]]
HARD = [j for j, case in enumerate(CASES) if case[4]]
HARD_TO_PASS = 2


def _residual(x, a, b, q, r):
    xb = x @ b
    terms = (x @ a, a.T @ x, q, xb @ np.linalg.solve(r, xb.T))
    res = terms[0] + terms[1] + q - terms[3]
    return res, np.linalg.norm(res) / sum(np.linalg.norm(t) for t in terms)


def test_scipy_lists_the_cases_we_expect():
    assert len(STANDARD) == 15 and len(HARD) == 5


@pytest.mark.parametrize("j", STANDARD)
def test_standard_case_at_scipys_decimals(j):
    a, b, q, r, _ = CASES[j]
    x = twip.care(a, b, q, r)
    res, _ = _residual(x, a, b, q, r)
    np.testing.assert_array_almost_equal(res, np.zeros_like(res), decimal=carex.min_decimal[j])
    closed = a - b @ np.linalg.solve(r, b.T @ x)
    assert np.linalg.eigvals(closed).real.max() < 0


def test_hard_cases_beat_scipy():
    passed = []
    for j in HARD:
        a, b, q, r, _ = CASES[j]
        try:
            x = twip.care(a, b, q, r)
        except twip.TwipError:
            continue
        _, ours = _residual(x, a, b, q, r)
        _, theirs = _residual(sl.solve_continuous_are(a, b, q, r), a, b, q, r)
        closed = a - b @ np.linalg.solve(r, b.T @ x)
        if ours <= theirs and ours < 1e-12 and np.linalg.eigvals(closed).real.max() < 0:
            passed.append(j)
    assert len(passed) >= HARD_TO_PASS, passed
