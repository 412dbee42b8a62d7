"""The 3-DOF model on an inclined plane, derived by Lagrange-d'Alembert with sympy.

Run it (`python scripts/derive_terrain.py`) to print the equations; tests/test_terrain.py
imports `derive()` and checks that twip's closed form (crates/twip-core/src/model/terrain_model.rs,
docs/terrain.md) is what this derivation gives.

The derivation works in the plane's own frame (e1 uphill in the plane, e2 level, n the
normal), where the plane is inertial and the robot is the flat robot under a tilted gravity
ĝ = −g (sin β e1 + cos β n). Coordinates q = (X, Y, χ, φ', θ_r, θ_l): the contact midpoint
in the plane, the heading in the plane from uphill, the pitch from the normal and the wheel
angles. Rolling: Ẋ = v cos χ, Ẏ = v sin χ, θ̇_r,l = (v ± b ω)/R, with ν = (φ̇', v, ω).
Every body is written out in 3-D; nothing is taken from the flat model's closed form.
"""
from __future__ import annotations

import sympy as sp


def derive():
    """Returns a dict: the mass matrix `M` and forces `f` (M ν̇ = f) in ν = (φ̇', v, ω) with
    the symbols used, and `normal_sum`, `normal_diff` (N_r + N_l and N_l − N_r) in terms of ν̇."""
    t = sp.symbols("t")
    Mb, Mw, Ixx, Iyy, Izz, Iwa, Iwd, rot, R, b, l, g, mus, mug, beta = sp.symbols(
        "M_b M_w I_xx I_yy I_zz I_wa I_wd J_rot R b l g mu_s mu_g beta", positive=True)
    ur, ul = sp.symbols("u_r u_l")
    X, Y, chi, ph, thr, thl = [sp.Function(n)(t) for n in ("X", "Y", "chi", "phi", "theta_r", "theta_l")]
    q = [X, Y, chi, ph, thr, thl]
    d = sp.Matrix([sp.cos(chi), sp.sin(chi), 0])
    a = sp.Matrix([-sp.sin(chi), sp.cos(chi), 0])
    n = sp.Matrix([0, 0, 1])
    up = sp.Matrix([sp.sin(beta), 0, sp.cos(beta)])  # the vertical in the plane's frame
    P = sp.Matrix([X, Y, 0])
    # Body: COM at the axle + l along its axis; axes e1 forward, e2 = a, e3 the body axis.
    e3 = sp.sin(ph) * d + sp.cos(ph) * n
    e1 = sp.cos(ph) * d - sp.sin(ph) * n
    rG = P + R * n + l * e3
    wb = chi.diff(t) * n + ph.diff(t) * a
    Rb = sp.Matrix.hstack(e1, a, e3)
    Ib = Rb * sp.diag(Ixx, Iyy, Izz) * Rb.T
    # Wheels (per side mass M_w/2, spin I_wa, diametral I_wd), right at −b a.
    wheels = []
    for side, th in ((-1, thr), (1, thl)):
        c = P + R * n + side * b * a
        w = chi.diff(t) * n + th.diff(t) * a
        Iw = Iwa * a * a.T + Iwd * (d * d.T + n * n.T)
        wheels.append((c, w, Iw, th))
    T = sp.Rational(1, 2) * Mb * (rG.diff(t).T * rG.diff(t))[0] + sp.Rational(1, 2) * (wb.T * Ib * wb)[0]
    for c, w, Iw, th in wheels:
        T += sp.Rational(1, 4) * Mw * (c.diff(t).T * c.diff(t))[0] + sp.Rational(1, 2) * (w.T * Iw * w)[0]
        T += sp.Rational(1, 2) * rot * (th.diff(t) - ph.diff(t)) ** 2  # J_rot = η² I_M / 2 per wheel
    V = g * (Mb * (up.T * rG)[0] + sum(sp.Rational(1, 2) * Mw * (up.T * c)[0] for c, *_ in wheels))
    D = sum(sp.Rational(1, 4) * mus * (th.diff(t) - ph.diff(t)) ** 2 + sp.Rational(1, 4) * mug * th.diff(t) ** 2
            for *_, th in wheels)
    Q = {thr: ur, thl: ul, ph: -(ur + ul)}
    L = T - V
    E = [sp.diff(L.diff(qi.diff(t)), t) - L.diff(qi) + D.diff(qi.diff(t)) - Q.get(qi, 0) for qi in q]
    # Rolling: q̇ = S(q) ν.
    pd, v, om, pdd, vd, omd = sp.symbols("phidot v omega phiddot vdot omegadot")
    S = sp.Matrix([[0, sp.cos(chi), 0], [0, sp.sin(chi), 0], [0, 0, 1], [1, 0, 0], [0, 1 / R, b / R], [0, 1 / R, -b / R]])
    nu, nud = sp.Matrix([pd, v, om]), sp.Matrix([pdd, vd, omd])
    qd = S * nu
    qdd = S.diff(t).subs(chi.diff(t), om) * nu + S * nud
    subs = {}
    for i, qi in enumerate(q):
        subs[qi.diff(t, 2)] = qdd[i]
    for i, qi in enumerate(q):
        subs[qi.diff(t)] = qd[i]
    eqs = (S.T * sp.Matrix([e.subs(subs) for e in E])).applyfunc(sp.expand)
    # Expanded, not simplified: simplifying took ~80 % of the test's time, and `check` proves
    # the differences zero exactly without it (`vanishes`); `main` simplifies for printing.
    M = eqs.jacobian(nud)
    f = (-(eqs - M * nud)).applyfunc(sp.expand)
    # Normal forces by Newton–Euler on the whole robot, about the contact midpoint P:
    # N_r + N_l = n·Σ m (a − ĝ);  b (N_l − N_r) = d·[Σ (r − P) × m (a − ĝ) + Σ dH/dt].
    gvec = -g * up
    bodies = [(Mb, rG, wb, Ib)] + [(Mw / 2, c, w, Iw) for c, w, Iw, _ in wheels]
    force = sp.zeros(3, 1)
    moment = sp.zeros(3, 1)
    for m, r, w, I in bodies:
        acc = r.diff(t, 2) - gvec
        force += m * acc
        moment += (r - P).cross(m * acc) + (I * w).diff(t)
    normal_sum = sp.expand((n.T * force)[0].subs(subs))
    normal_diff = sp.expand((d.T * moment)[0].subs(subs) / b)
    syms = dict(M_b=Mb, M_w=Mw, I_xx=Ixx, I_yy=Iyy, I_zz=Izz, I_wa=Iwa, I_wd=Iwd, J_rot=rot, R=R, b=b, l=l, g=g,
                mu_s=mus, mu_g=mug, beta=beta, u_r=ur, u_l=ul, phi=ph, chi=chi, phidot=pd, v=v, omega=om,
                phiddot=pdd, vdot=vd, omegadot=omd)
    return dict(M=M, f=f, normal_sum=normal_sum, normal_diff=normal_diff, syms=syms)


def closed_form(s):
    """twip's closed form (docs/terrain.md) in the same symbols: M, f, N_r + N_l, N_l − N_r."""
    Mb, Mw, Ixx, Iyy, Izz, Iwa, Iwd, J, R, b, l, g, mus, mug, beta = (s[k] for k in (
        "M_b", "M_w", "I_xx", "I_yy", "I_zz", "I_wa", "I_wd", "J_rot", "R", "b", "l", "g", "mu_s", "mu_g", "beta"))
    ph, chi, pd, v, om, pdd, vd, omd, ur, ul = (s[k] for k in (
        "phi", "chi", "phidot", "v", "omega", "phiddot", "vdot", "omegadot", "u_r", "u_l"))
    rotor, Iw = 2 * J, 2 * Iwa  # η² I_M and I_w of both wheels
    sn, cs = sp.sin(ph), sp.cos(ph)
    k = Mb * l**2 + Ixx - Izz
    m_pp = Mb * l**2 + Iyy + rotor
    m_vv = Mb + Mw + (Iw + rotor) / R**2
    m_pv = Mb * l * cs - rotor / R
    m_ww = Izz + k * sn**2 + 2 * Iwd + b**2 * (Mw + (Iw + rotor) / R**2)
    M = sp.Matrix([[m_pp, m_pv, 0], [m_pv, m_vv, 0], [0, 0, m_ww]])
    usum, udiff = ur + ul, ur - ul
    sb, cb, sc, cc = sp.sin(beta), sp.cos(beta), sp.sin(chi), sp.cos(chi)
    # The flat model's forces with M_b g l sin φ' → M_b g l (cos β sin φ' − sin β cos χ cos φ'),
    # plus the grade's pull on v and the lean's yaw torque.
    f_p = Mb * g * l * (cb * sn - sb * cc * cs) + k * sn * cs * om**2 - mus * pd + mus * v / R - usum
    f_v = Mb * l * sn * (pd**2 + om**2) - (mus + mug) * v / R**2 + mus * pd / R + usum / R - (Mb + Mw) * g * sb * cc
    f_w = b * udiff / R - (2 * k * sn * cs * pd + Mb * l * sn * v + b**2 * (mus + mug) / R**2) * om \
        + Mb * g * l * sb * sc * sn
    f = sp.Matrix([f_p, f_v, f_w])
    # Normal forces (docs/terrain.md).
    normal_sum = (Mb + Mw) * g * cb - Mb * l * (sn * pdd + cs * pd**2)
    # The moment about the heading: the cross slope's weight and the turn's centripetal
    # force at the heights of the body's COM (R + l cos φ') and the wheels' centres (R), the
    # wheels' spin turning (gyroscopic), and the body's pitch-yaw coupling.
    H = Mb * (R + l * cs) + Mw * R
    normal_diff = (g * sb * sc * H - (H + Iw / R) * v * om
                   - om * pd * (k * sp.cos(2 * ph) + Iyy + Mb * l**2 + 2 * Mb * R * l * cs)
                   - omd * sn * (k * cs + Mb * R * l)) / b
    return dict(M=M, f=f, normal_sum=normal_sum, normal_diff=normal_diff)


def vanishes(expr):
    """Whether `expr` (a polynomial in sines and cosines of its angles, over rational functions
    of the other symbols) is identically zero. Each angle's sine and cosine become symbols s, c;
    the numerator is reduced modulo s² + c² − 1 for every angle. Those polynomials have coprime
    leading terms, so they are a Gröbner basis and the remainder is zero exactly when `expr` is:
    a proof, not a sampling, and much faster than `simplify`."""
    expr = sp.expand_trig(sp.expand(expr))
    angles = sorted({a.args[0] for a in expr.atoms(sp.sin, sp.cos)}, key=sp.default_sort_key)
    pairs = [(sp.Dummy(f"s{i}"), sp.Dummy(f"c{i}")) for i in range(len(angles))]
    expr = expr.subs({fn(a): v for a, (s, c) in zip(angles, pairs) for fn, v in ((sp.sin, s), (sp.cos, c))})
    if expr.atoms(sp.sin, sp.cos, sp.tan):
        raise ValueError(f"vanishes: a trigonometric term is left after expansion: {expr.atoms(sp.sin, sp.cos, sp.tan)}")
    numer = sp.numer(sp.together(expr))
    if not pairs:
        return sp.expand(numer) == 0
    gens = [v for pair in pairs for v in pair]
    _, rest = sp.reduced(sp.expand(numer), [s**2 + c**2 - 1 for s, c in pairs], *gens)
    return sp.expand(rest) == 0


def check(out=None, mine=None):
    """For each of M, f, N_r + N_l and N_l − N_r, whether the derivation minus the closed form
    (`mine`, default twip's) vanishes identically (all True when twip's equations are right)."""
    out = out or derive()
    mine = mine or closed_form(out["syms"])
    return {key: all(vanishes(e) for e in sp.Matrix([out[key] - mine[key]])) for key in ("M", "f", "normal_sum", "normal_diff")}


def main():
    out = derive()
    sp.init_printing(use_unicode=True)
    print("M ="), sp.pprint(out["M"].applyfunc(sp.simplify))
    print("f ="), sp.pprint(out["f"].applyfunc(sp.simplify))
    print("N_r + N_l ="), sp.pprint(sp.simplify(out["normal_sum"]))
    print("N_l - N_r ="), sp.pprint(sp.simplify(out["normal_diff"]))
    print("derivation minus twip's closed form vanishes:", check(out))


if __name__ == "__main__":
    main()
