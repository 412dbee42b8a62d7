"""Fuzzy logic systems: memberships (4.31), the normalised basis xi (4.29, 4.39), parity, errors."""
import math

import numpy as np
import pytest
import skfuzzy

import twip
import twip.reference.fuzzy as rf

INF = math.inf


def thesis_sets(lib):
    """twip's default (phi, phi_dot) x (N, Z, P) sets, built with `lib` (twip or the reference)."""
    def shoulders(inner, outer):
        return [lib.Trapezoid(-INF, -INF, -outer, -inner), lib.Trapezoid(-outer, -inner, inner, outer),
                lib.Trapezoid(inner, outer, INF, INF)]
    return [shoulders(0.1, 0.3), shoulders(0.5, 2.0)]


def gapped_sets(lib):
    """Finite sets with gaps and no shoulders: the no-rule-fires fallback is needed."""
    return [[lib.Trapezoid(-3, -2, -2, -1), lib.Triangle(-0.5, 0, 0.5), lib.Trapezoid(1, 1.5, 2, 3)],
            [lib.Gaussian(-1, 0.2), lib.Gaussian(0, 0.1), lib.Gaussian(2, 0.3)]]


def mixed_sets(lib):
    """Three inputs with 2, 3 and 4 sets of every kind."""
    return [[lib.Trapezoid(-INF, -INF, -1, 1), lib.Trapezoid(-1, 1, INF, INF)],
            [lib.Triangle(-2, -1, 0), lib.Gaussian(0, 0.5), lib.Trapezoid(0, 1, 1, 1)],
            [lib.Trapezoid(-4, -3, -2, -1), lib.Trapezoid(-1, -1, 0, 0), lib.Gaussian(1, 1), lib.Triangle(2, 3, 4)]]


BASES = {"thesis": thesis_sets, "gapped": gapped_sets, "mixed": mixed_sets}


def random_points(rng, n, dim):
    """Points near the sets, far outside all of them, and at +-inf."""
    near = rng.normal(0, 2, (n // 2, dim))
    far = rng.choice([-1, 1], (n // 2 - 2, dim)) * 10 ** rng.uniform(1, 300, (n // 2 - 2, dim))
    inf = np.array([[INF] * dim, [-INF] * dim])
    return np.vstack([near, far, inf])


@pytest.mark.parametrize("name", BASES)
def test_xi_is_a_partition_of_unity_everywhere(name):
    basis = twip.FuzzyBasis(BASES[name](twip))
    x = random_points(np.random.default_rng(1), 10_000, basis.n_inputs)
    xi = basis.eval(x)
    assert xi.shape == (10_000, basis.n_rules)
    assert np.all(np.isfinite(xi)) and np.all(xi >= 0.0)
    np.testing.assert_allclose(xi.sum(axis=1), 1.0, rtol=0, atol=1e-14)


@pytest.mark.parametrize("name", BASES)
def test_rust_and_reference_basis_agree(name):
    basis, ref = twip.FuzzyBasis(BASES[name](twip)), rf.GridBasis(BASES[name](rf))
    x = random_points(np.random.default_rng(2), 2_000, basis.n_inputs)
    xi, expected = basis.eval(x), ref.eval(x)
    # The reference divides by D of (4.29); Rust normalises each input (D factorises).
    # Products of tiny Gaussian memberships go subnormal in the reference's D, so values
    # below 1e-200 are compared absolutely.
    np.testing.assert_allclose(xi, expected, rtol=1e-14, atol=1e-200)
    print(f"{name}: worst |xi_rust - xi_ref| = {np.max(np.abs(xi - expected)):.1e}")


def mu_4_31(x, a, b, c, d):
    """(4.31) as printed; a crisp edge (a = b or c = d) takes the flat branch (no 0/0)."""
    if x < a or x > d:
        return 0.0
    if b <= x <= c:
        return 1.0
    if a <= x <= b:
        return (x - a) / (b - a)
    return (d - x) / (d - c)


TRAPEZOIDS = [(-1.0, 0.0, 0.5, 2.0), (0.0, 1.0, 1.0, 3.0), (-0.5, -0.5, 1.0, 1.25), (-2.0, 0.0, 1.5, 1.5),
              (0.25, 0.25, 0.25, 0.25), (-3.0, -1.0, 1.0, 3.0)]


@pytest.mark.parametrize("abcd", TRAPEZOIDS)
def test_trapezoid_matches_4_31_and_scikit_fuzzy(abcd):
    x = np.arange(-4000, 4001) / 1000.0  # hits every breakpoint exactly
    mu = twip.Trapezoid(*abcd)(x)
    direct = np.array([mu_4_31(v, *abcd) for v in x])
    np.testing.assert_allclose(mu, direct, rtol=1e-15, atol=0)
    np.testing.assert_allclose(mu, skfuzzy.trapmf(x, np.array(abcd)), rtol=1e-15, atol=0)
    np.testing.assert_allclose(mu, rf.Trapezoid(*abcd)(x), rtol=1e-15, atol=0)


def test_shoulders_triangles_and_gaussians():
    left, right = twip.Trapezoid(-INF, -INF, 0, 1), twip.Trapezoid(0, 1, INF, INF)
    x = np.array([-INF, -1e300, 0.0, 0.25, 1.0, 1e300, INF])
    np.testing.assert_array_equal(left(x), [1, 1, 1, 0.75, 0, 0, 0])
    np.testing.assert_array_equal(right(x), [0, 0, 0, 0.25, 1, 1, 1])
    np.testing.assert_array_equal(twip.Triangle(0, 1, 3)([0.5, 1, 2]), [0.5, 1, 0.5])
    x = np.linspace(-5, 5, 101)
    np.testing.assert_allclose(twip.Gaussian(0.5, 1.5)(x), skfuzzy.gaussmf(x, 0.5, 1.5), rtol=1e-14)
    np.testing.assert_allclose(twip.Triangle(-1, 0.5, 2)(x), skfuzzy.trimf(x, [-1, 0.5, 2]), rtol=1e-15)


def test_memberships_are_vectorised():
    t = twip.Trapezoid(0, 1, 2, 4)
    assert isinstance(t(0.5), float) and t(0.5) == 0.5 == t.eval(0.5)
    grid = np.array([[0.5, 3.0], [5.0, 1.5]])
    out = t(grid)
    assert out.shape == (2, 2)
    np.testing.assert_array_equal(out, [[0.5, 0.5], [0.0, 1.0]])
    np.testing.assert_array_equal(t([0.5, 3]), [0.5, 0.5])
    assert t.breakpoints == (0.0, 1.0, 2.0, 4.0)
    assert twip.Triangle(0, 1, 2).breakpoints == (0.0, 1.0, 2.0)
    g = twip.Gaussian(1.0, 2.0)
    assert (g.mean, g.sigma) == (1.0, 2.0) and g(1.0) == 1.0


def test_rules_are_ordered_as_4_39():
    basis = twip.FuzzyBasis.default()
    assert (basis.n_inputs, basis.n_rules) == (2, 9)
    # xi_1 = N(phi) N(phi_dot), xi_2 = N(phi) Z(phi_dot), ..., xi_9 = P(phi) P(phi_dot).
    for k, (phi, phi_dot) in enumerate([(p, q) for p in (-1, 0, 1) for q in (-5, 0, 5)]):
        xi = basis.eval([phi, phi_dot])
        assert xi.shape == (9,) and xi[k] == 1.0, (k, xi)
    # Two sets blend on each input: four rules fire, as the product of the memberships.
    xi = basis.eval([0.2, -1.25])
    expected = np.outer([0, 0.5, 0.5], [0.5, 0.5, 0]).ravel()
    np.testing.assert_allclose(xi, expected, rtol=1e-15)


def test_no_rule_fires_falls_back_to_the_nearest_set():
    basis = twip.FuzzyBasis([[twip.Trapezoid(-3, -2, -2, -1), twip.Triangle(-0.5, 0, 0.5), twip.Triangle(1, 2, 3)]])
    np.testing.assert_array_equal(basis.eval(np.array([[0.7], [0.8], [-100.0], [INF], [-INF]])),
                                  [[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 0, 1], [1, 0, 0]])
    ref = rf.GridBasis([[rf.Trapezoid(-3, -2, -2, -1), rf.Triangle(-0.5, 0, 0.5), rf.Triangle(1, 2, 3)]])
    np.testing.assert_array_equal(ref.eval([0.8]), [0, 0, 1])
    # Gaussians far out underflow to 0: the nearest in standard deviations fires.
    g = twip.FuzzyBasis([[twip.Gaussian(-1, 0.1), twip.Gaussian(1, 1.0)]])
    np.testing.assert_array_equal(g.eval([-60.0]), [0, 1])


def test_a_subnormal_sum_fires_the_nearest_set_in_both():
    """Memberships ~1e-309 sum to a subnormal whose inverse overflows: no rule fires, in twip
    and in the reference alike (dividing would give shares of a few significant bits)."""
    def sets(lib):
        return [[lib.Gaussian(0.0, 1.0), lib.Gaussian(0.01, 1.0)], [lib.Gaussian(0.0, 1.0)]]
    x = [37.73, 0.0]
    mu = [math.exp(-0.5 * (x[0] - m) ** 2) for m in (0.0, 0.01)]
    assert 0.0 < sum(mu) and math.isinf(1.0 / sum(mu)), mu
    expected = [0.0, 1.0]
    np.testing.assert_array_equal(rf.GridBasis(sets(rf)).eval(x), expected)
    np.testing.assert_array_equal(twip.FuzzyBasis(sets(twip)).eval(x), expected)
    # Just inside the band's edge both divide, and agree.
    near = [37.6, 0.0]
    np.testing.assert_allclose(rf.GridBasis(sets(rf)).eval(near), twip.FuzzyBasis(sets(twip)).eval(near), rtol=1e-12)


def test_basis_sets_round_trip():
    basis = twip.FuzzyBasis(thesis_sets(twip))
    again = twip.FuzzyBasis(basis.sets)
    x = np.random.default_rng(3).normal(0, 1, (50, 2))
    np.testing.assert_array_equal(again.eval(x), basis.eval(x))
    np.testing.assert_array_equal(twip.FuzzyBasis(basis).eval(x), basis.eval(x))
    assert "Trapezoid(-inf, -inf, -0.3, -0.1)" in repr(basis)


def test_sets_pickle_as_themselves():
    """Dask ships a sweep's options (sets included) to its workers pickled."""
    import pickle

    x = np.linspace(-3, 3, 61)
    for s in [twip.Trapezoid(-math.inf, -math.inf, -2, -0.5), twip.Triangle(-2, 0, 2), twip.Gaussian(0.3, 0.15)]:
        again = pickle.loads(pickle.dumps(s))
        assert type(again) is type(s) and repr(again) == repr(s)
        np.testing.assert_array_equal(again(x), s(x))


def test_a_nan_input_is_refused_an_infinite_one_is_not():
    """mu(NaN) was NaN, and the basis' xi NaN everywhere; +-inf is a shoulder's side."""
    for s in (twip.Trapezoid(0, 1, 2, 3), twip.Triangle(0, 1, 2), twip.Gaussian(0, 1)):
        with pytest.raises(twip.NonFiniteError, match=r"^x\[0\] = NaN"):
            s(math.nan)
        with pytest.raises(twip.NonFiniteError, match=r"^x\[1\] = NaN"):
            s.eval(np.array([0.5, math.nan]))
        assert s(INF) == 0.0
    assert twip.Trapezoid(-INF, -INF, 0, 1)(-INF) == 1.0
    basis = twip.FuzzyBasis.default()
    with pytest.raises(twip.NonFiniteError, match=r"^x\[1\] = NaN"):
        basis.eval([0.0, math.nan])
    with pytest.raises(twip.NonFiniteError, match=r"^x\[3\] = NaN"):
        basis.eval(np.array([[0.0, 0.0], [0.0, math.nan]]))
    assert basis.eval([INF, 0.0]).sum() == pytest.approx(1.0)


def test_errors_name_the_set_and_the_breakpoint():
    with pytest.raises(twip.InvalidParameterError, match=r"Trapezoid\(a=0.0, b=2.0, c=1.0, d=3.0\).*trapezoid.c = 1"):
        twip.Trapezoid(0, 2, 1, 3)
    with pytest.raises(twip.InvalidParameterError, match=r"trapezoid.b = -1"):
        twip.Trapezoid(0, -1, 1, 3)
    with pytest.raises(twip.InvalidParameterError, match=r"trapezoid.d = 0.5"):
        twip.Trapezoid(0, 0, 1, 0.5)
    with pytest.raises(twip.InvalidParameterError, match=r"Triangle.*triangle.c = 0.5"):
        twip.Triangle(0, 1, 0.5)
    with pytest.raises(twip.InvalidParameterError, match="left shoulder"):
        twip.Trapezoid(-INF, 0, 1, 2)
    with pytest.raises(twip.InvalidParameterError, match="right shoulder"):
        twip.Trapezoid(0, 1, 2, INF)
    with pytest.raises(twip.InvalidParameterError, match="NaN"):
        twip.Trapezoid(0, math.nan, 1, 2)
    with pytest.raises(twip.InvalidParameterError, match="gaussian.sigma"):
        twip.Gaussian(0, 0)
    with pytest.raises(twip.InvalidParameterError, match="empty"):
        twip.FuzzyBasis([[]])
    with pytest.raises(TypeError, match=r"sets\[0\]\[1\]"):
        twip.FuzzyBasis([[twip.Triangle(0, 1, 2), 3.0]])
    with pytest.raises(twip.ShapeError, match="x"):
        twip.FuzzyBasis.default().eval([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="Trapezoid.c"):
        rf.Trapezoid(0, 2, 1, 3)
