"""The 2-DOF slope model: energy, derivation, integrator order, parity, errors."""
import math

import numpy as np
import pytest

import twip
import twip.reference as ref
from conftest import frictionless, max_energy_drift, random_params, rel_diff, run


@pytest.mark.parametrize("slope", [0.0, 0.1])
def test_energy_is_conserved_and_converges_with_dt(balanbot, slope):
    """Falls from 0.3 rad and swings through; 1e5 RK4 steps at 1 ms, then at 0.5 ms."""
    model = twip.SlopeModel(frictionless(balanbot), slope)
    x0 = [0.3, 0.5, 0.0, 2.0]
    drift, traj = max_energy_drift(model, x0, 0.0, 1e-3, 100.0)
    assert np.max(np.abs(traj[:, 0])) > math.pi, "the body should swing through the bottom"
    drift_half, _ = max_energy_drift(model, x0, 0.0, 0.5e-3, 100.0)
    print(f"slope={slope}: relative energy drift {drift:.2e} at dt=1ms, {drift_half:.2e} at dt=0.5ms")
    assert drift < 1e-7
    assert drift_half < drift / 10


def test_friction_dissipates(balanbot):
    model = twip.SlopeModel(balanbot, 0.0)
    traj = run(model, [0.3, 0.5, 0.0, 2.0], 0.0, 1e-3, 5000)
    e = [model.energy(x) for x in traj[::100]]
    assert all(b <= a + 1e-12 for a, b in zip(e, e[1:])), "energy must not grow with friction and no input"


def test_rk4_is_fourth_order(balanbot):
    model = twip.SlopeModel(balanbot, 0.05)
    x0, u, t = [0.2, 0.0, 0.0, 1.0], 0.3, 0.5
    exact = run(model, x0, u, 1e-4, 5000)[-1]
    errors = [np.linalg.norm(run(model, x0, u, dt, round(t / dt))[-1] - exact) for dt in (0.02, 0.01)]
    ratio = errors[0] / errors[1]
    print(f"RK4 error ratio when halving dt: {ratio:.2f}")
    assert 12 <= ratio <= 20


def test_derivation_with_sympy():
    """Re-derive the equations from T, U, D and Q with sympy; compare with deriv."""
    sp = pytest.importorskip("sympy")
    t = sp.symbols("t")
    Mb, Mw, Ib, Iw, IM, eta, tau, r, l, mus, mug, g, alpha, u = sp.symbols(
        "M_b M_w I_b I_w I_M eta tau_i r l mu_s mu_g g alpha u", real=True
    )
    phi, theta = sp.Function("phi")(t), sp.Function("theta")(t)
    beta = theta - phi
    # Kinetic energy (3.1): body velocity = wheel centre along the slope + rotation about the axle.
    body_vx = r * theta.diff(t) * sp.cos(alpha) + l * phi.diff(t) * sp.cos(phi)
    body_vy = r * theta.diff(t) * sp.sin(alpha) - l * phi.diff(t) * sp.sin(phi)
    T = (
        sp.Rational(1, 2) * Mw * (r * theta.diff(t)) ** 2
        + sp.Rational(1, 2) * Mb * (body_vx**2 + body_vy**2)
        + sp.Rational(1, 2) * Iw * theta.diff(t) ** 2
        + sp.Rational(1, 2) * Ib * phi.diff(t) ** 2
        + sp.Rational(1, 2) * IM * eta**2 * beta.diff(t) ** 2
    )
    # Potential (3.2) + corrected (3.3): heights r theta sin(alpha) and l cos(phi) above it.
    U = Mw * g * r * theta * sp.sin(alpha) + Mb * g * (l * sp.cos(phi) + r * theta * sp.sin(alpha))
    D = sp.Rational(1, 2) * (mus * beta.diff(t) ** 2 + mug * theta.diff(t) ** 2)
    # Q_beta = eta tau u on beta = theta - phi: virtual work on phi is -Q_beta, on theta +Q_beta.
    Q = {phi: -eta * tau * u, theta: eta * tau * u}
    L = T - U
    eqs = []
    for q in (phi, theta):
        e = L.diff(q.diff(t)).diff(t) - L.diff(q) + D.diff(q.diff(t)) - Q[q]
        eqs.append(sp.expand(e))
    pdd, tdd = sp.symbols("pdd tdd")
    p0, pd, th0, thd = sp.symbols("p0 pd th0 thd")
    subs = {phi.diff(t, 2): pdd, theta.diff(t, 2): tdd}
    eqs = [e.subs(subs) for e in eqs]
    subs = {phi.diff(t): pd, theta.diff(t): thd}
    eqs = [e.subs(subs).subs({phi: p0, theta: th0}) for e in eqs]
    # Linear in the accelerations: M [pdd, tdd] = -rest. Solve numerically, not symbolically.
    M, rest = sp.linear_eq_to_matrix(eqs, [pdd, tdd])
    args = (p0, pd, th0, thd, u, Mb, Mw, Ib, Iw, IM, eta, tau, r, l, mus, mug, g, alpha)
    f_M = sp.lambdify(args, M.tolist(), "math")
    f_rest = sp.lambdify(args, rest.tolist(), "math")
    rng = np.random.default_rng(1)
    for _ in range(50):
        p = random_params(rng)
        a = rng.uniform(-0.4, 0.4)
        x = rng.uniform([-1.5, -5, -10, -20], [1.5, 5, 10, 20])
        uu = rng.uniform(-2, 2)
        vals = (*x, uu, p.m_body, p.m_wheels, p.i_body, p.i_wheels, p.i_motor, p.gear_ratio,
                p.torque_constant, p.wheel_radius, p.com_height, p.mu_bearing, p.mu_ground, p.g, a)
        d = twip.SlopeModel(p, a).deriv(x, uu)
        expected = np.linalg.solve(np.array(f_M(*vals), dtype=float), np.array(f_rest(*vals), dtype=float).ravel())
        np.testing.assert_allclose(d[[1, 3]], expected, rtol=1e-10, atol=1e-10)


def test_parity_deriv_at_random_states():
    rng = np.random.default_rng(2)
    worst = 0.0
    for _ in range(1000):
        p = random_params(rng)
        a = rng.uniform(-0.4, 0.4)
        x = rng.uniform([-3, -10, -50, -50], [3, 10, 50, 50])
        u = rng.uniform(-3, 3)
        d_rust = twip.SlopeModel(p, a).deriv(x, u)
        d_ref = ref.SlopeModel(p, a).deriv(x, u)
        err = rel_diff(d_rust, d_ref)
        worst = max(worst, err)
    print(f"worst relative deriv difference Rust vs reference: {worst:.2e}")
    assert worst < 1e-12


def test_parity_open_loop_run(balanbot):
    """10 s at dt = 1 ms from a small tilt with a small current: falls, swings, damps."""
    x0, u, dt, n = [0.05, 0.0, 0.0, 0.0], 0.05, 1e-3, 10_000
    a = run(twip.SlopeModel(balanbot, 0.1), x0, u, dt, n)
    b = run(ref.SlopeModel(balanbot, 0.1), x0, u, dt, n, step=ref.rk4_step)
    err = rel_diff(a, b)
    print(f"worst relative state difference over 10 s: {err:.2e}")
    assert err < 1e-9


def test_energy_matches_reference(balanbot):
    rng = np.random.default_rng(3)
    for _ in range(100):
        a = rng.uniform(-0.4, 0.4)
        x = rng.uniform(-3, 3, 4)
        assert twip.SlopeModel(balanbot, a).energy(x) == pytest.approx(ref.SlopeModel(balanbot, a).energy(x), rel=1e-13)


def test_linearize_is_the_exact_jacobian(balanbot):
    model = twip.SlopeModel(balanbot, 0.2)
    rng = np.random.default_rng(4)
    for _ in range(20):
        x0, u0 = rng.uniform(-1, 1, 4), rng.uniform(-1, 1)
        A, B = model.linearize(x0, u0)
        h = 1e-6
        A_fd = np.column_stack([(model.deriv(x0 + h * e, u0) - model.deriv(x0 - h * e, u0)) / (2 * h) for e in np.eye(4)])
        B_fd = (model.deriv(x0, u0 + h) - model.deriv(x0, u0 - h)) / (2 * h)
        np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(B[:, 0], B_fd, rtol=1e-6, atol=1e-6)


def test_thesis_linearization_matches_jacobian_on_flat(balanbot):
    """On the flat at phi = 0 the thesis's (4.6)-(4.10) is the exact Jacobian (reduced state)."""
    model = twip.SlopeModel(balanbot, 0.0)
    A3, B3, D3 = model.linearize_thesis()
    A, B = model.linearize([0, 0, 0, 0], 0.0)
    keep = [0, 1, 3]
    np.testing.assert_allclose(A3, A[np.ix_(keep, keep)], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(B3, B[keep], rtol=1e-12)
    np.testing.assert_array_equal(D3, np.zeros((3, 1)))
    ref_A, ref_B, ref_D = ref.SlopeModel(balanbot, 0.3).linearize_thesis()
    A3, B3, D3 = twip.SlopeModel(balanbot, 0.3).linearize_thesis()
    np.testing.assert_allclose(A3, ref_A, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(B3, ref_B, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(D3, ref_D, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("slope", [0.0, math.radians(15)])
def test_equilibrium_is_a_steady_state(balanbot, slope):
    model = twip.SlopeModel(balanbot, slope)
    theta_dot = math.radians(250)
    x_s, u_s = model.equilibrium(theta_dot)
    np.testing.assert_allclose(model.deriv(x_s, u_s), [0, 0, theta_dot, 0], atol=1e-12)
    x_r, u_r = ref.SlopeModel(balanbot, slope).equilibrium(theta_dot)
    np.testing.assert_allclose(x_s, x_r, rtol=1e-13)
    assert u_s == pytest.approx(u_r, rel=1e-13)
    # The linear model's phi_s is the nonlinear one's sine: (4.12) drops the arcsin.
    x_l, _ = model.equilibrium(theta_dot, linear=True)
    assert x_l[0] == pytest.approx(math.sin(x_s[0]), rel=1e-12)


def test_no_equilibrium_on_a_too_steep_slope(balanbot):
    with pytest.raises(twip.NoEquilibriumError, match="sin phi_s"):
        twip.SlopeModel(balanbot, 0.3).equilibrium(1e4)


@pytest.mark.parametrize(
    "field,value,message",
    [("m_body", -1.0, "m_body = -1"), ("com_height", 0.0, "com_height = 0"),
     ("mu_ground", -0.1, "mu_ground = -0.1"), ("g", float("nan"), "g = NaN"),
     ("wheel_radius", float("inf"), "wheel_radius = inf")],
)
def test_invalid_params_name_field_and_value(balanbot, field, value, message):
    with pytest.raises(twip.InvalidParameterError, match=message):
        balanbot.replace(**{field: value})


def test_params_api(balanbot):
    assert isinstance(twip.InvalidParameterError("x"), ValueError)
    with pytest.raises(twip.InvalidParameterError, match="unknown RobotParams field 'mass'"):
        balanbot.replace(mass=1.0)
    with pytest.raises(twip.InvalidParameterError, match="missing: .*m_wheels"):
        twip.RobotParams(m_body=1.0)
    # A NaN given is a bad value, named as one; it was reported as a field not given.
    with pytest.raises(twip.InvalidParameterError, match=r"m_body = NaN") as e:
        twip.RobotParams.from_dict(dict(balanbot.to_dict(), m_body=float("nan")))
    assert "missing" not in str(e.value)
    assert twip.RobotParams.from_dict(balanbot.to_dict()) == balanbot
    assert twip.RobotParams(**balanbot.to_dict()) == balanbot
    assert balanbot.replace(m_body=2.0).m_body == 2.0
    assert balanbot.wheel_radius == pytest.approx(1 / 30)
    import pickle
    assert pickle.loads(pickle.dumps(balanbot)) == balanbot


def test_bad_arrays_raise_named_errors(balanbot):
    model = twip.SlopeModel(balanbot)
    with pytest.raises(twip.ShapeError, match="x"):
        model.deriv([0.0, 0.0, 0.0], 0.0)
    with pytest.raises(twip.NonFiniteError, match=r"x\[1\] = NaN"):
        model.deriv([0.0, float("nan"), 0.0, 0.0], 0.0)
    with pytest.raises(twip.NonFiniteError, match="u"):
        model.deriv([0.0, 0.0, 0.0, 0.0], float("inf"))
    with pytest.raises(twip.InvalidParameterError, match="dt"):
        twip.rk4_step(model, [0, 0, 0, 0], 0.0, -1e-3)
    with pytest.raises(twip.InvalidParameterError, match="slope"):
        twip.SlopeModel(balanbot, 2.0)
    with pytest.raises(TypeError, match="model must be"):
        twip.rk4_step("not a model", [0, 0, 0, 0], 0.0, 1e-3)


class ThesisAsPrinted(ref.SlopeModel):
    """(3.20) and (3.21) exactly as printed: the extra Coriolis term in (3.20) and the
    body's slope potential M_b g l r sin(alpha) in (3.21). For errata E2/E3 only."""

    def deriv(self, x, u):
        p = self.params
        phi, phi_dot, _theta, theta_dot = (float(v) for v in x)
        Mb, Mw, l, r, g, a = p.m_body, p.m_wheels, p.com_height, p.wheel_radius, p.g, self.slope
        rhs1 = (Mb * r * theta_dot * phi_dot * l * math.sin(phi + a) + Mb * g * l * math.sin(phi)
                + p.mu_bearing * (theta_dot - phi_dot) - p.gear_ratio * p.torque_constant * float(u))
        rhs2 = (Mb * r * phi_dot**2 * l * math.sin(phi + a) - Mw * g * r * math.sin(a)
                - Mb * g * l * (r * math.sin(a) - math.sin(phi)) - p.mu_ground * theta_dot)
        phi_dd, theta_dd = np.linalg.solve(self.mass_matrix(phi), [rhs1, rhs2])
        return np.array([phi_dot, phi_dd, theta_dot, theta_dd])


def test_thesis_as_printed_does_not_conserve_energy(balanbot):
    """Errata E2: with the Coriolis term of (3.20) energy drifts even on the flat."""
    p = frictionless(balanbot)
    x0 = [0.3, 0.5, 0.0, 2.0]
    drifts = {}
    for name, model in (("corrected", ref.SlopeModel(p, 0.0)), ("as printed", ThesisAsPrinted(p, 0.0))):
        traj = run(model, x0, 0.0, 1e-3, 3000, step=ref.rk4_step)
        e = np.array([model.energy(x) for x in traj])
        drifts[name] = np.max(np.abs(e - e[0])) / abs(e[0])
    print(f"relative energy drift over 3 s: {drifts}")
    assert drifts["corrected"] < 1e-8
    assert drifts["as printed"] > 1e-2


def test_thesis_potential_is_not_a_steady_state(balanbot):
    """Errata E3: (4.42) as printed (M_b g l r sin(alpha)) is not where the robot can stand."""
    slope, speed = math.radians(15), math.radians(250)
    p = balanbot
    printed = math.asin((p.m_wheels * p.g * p.wheel_radius * math.sin(slope)
                         + p.m_body * p.g * p.com_height * p.wheel_radius * math.sin(slope)
                         + p.mu_ground * speed) / (p.m_body * p.g * p.com_height))
    model = twip.SlopeModel(p, slope)
    x_s, u_s = model.equilibrium(speed)
    print(f"phi_s corrected {math.degrees(x_s[0]):.2f} deg, as printed {math.degrees(printed):.2f} deg")
    assert abs(model.deriv(x_s, u_s)[3]) < 1e-12
    x_bad = x_s.copy()
    x_bad[0] = printed
    assert abs(model.deriv(x_bad, u_s)[3]) > 1.0


def test_on_the_slope_the_steady_pitch_depends_on_the_direction_of_travel(balanbot):
    """The report's reason for slope-lqr's "pitch about 12.5 degrees": ground friction adds to
    the slope's load going up and takes from it coming down (4.42), so the steady pitch is
    12.6° up at 250 deg/s, 11.0° standing and 9.5° coming down; (4.12)'s 12.5° is the first."""
    model = twip.SlopeModel(balanbot, math.radians(15))
    up, still, down = (math.degrees(model.equilibrium(math.radians(v))[0][0]) for v in (250, 0, -250))
    print(f"15 deg slope, steady pitch: {up:.2f} deg up at 250 deg/s, {still:.2f} standing, {down:.2f} coming down")
    assert abs(up - 12.5) < 0.25 and down < still < up
    assert abs(down - 12.5) > 2.0 and up - still == pytest.approx(still - down, rel=0.05)
