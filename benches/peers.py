"""twip against what a user would write instead, on one workload, measured in one run.

Workload: closed-loop 2-DOF model + LQR with integral action (scenario flat-lqr-sim:
180 deg/s, controller every 1 ms step), RK4 at dt = 1 ms for 10 s, N robots with
m_body ±20 %, com_height ±10 %, i_body ±20 % (uniform), as twip.montecarlo draws them.
Peers: a NumPy loop vectorised over samples, Numba @njit(parallel=True), and JAX
jit(vmap(lax.scan)) on the CPU (float64). Each peer gets the very same robots and
gains and must reproduce twip's metrics (mean |pitch error|, mean |speed error|) to
rel 1e-9. Printed: sample-steps per second and the ratios.

Workload `fuzzy` (`--workload fuzzy|lqr|all`): the same robots under scenario flat-fuzzy-sim
(fuzzy adaptive backstepping + PD, the thesis's flat gains and N/Z/P sets, controller every
1 ms, 180 deg/s), against a Numba-parallel peer written from the thesis's equations; the peer
must reproduce twip's mean |pitch error| and mean |speed error| to rel 1e-9.

Run:  .venv/bin/pip install numba jax && .venv/bin/python benches/peers.py [--n 20000]
(numba and jax are benchmark-only dependencies, not twip's.)
"""
import argparse
import math
import os
import time

import numpy as np

import twip
import twip.scenarios

T_FINAL, DT = 10.0, 1e-3
STEPS = round(T_FINAL / DT)
PERTURB = {
    "m_body": twip.Uniform(rel=0.2),
    "com_height": twip.Uniform(rel=0.1),
    "i_body": twip.Uniform(rel=0.2),
}


def problem(n):
    """twip's sweep of n samples, and the per-sample robots and shared gains for the peers."""
    sc = twip.scenarios.get("flat-lqr-sim", t_final=T_FINAL)
    start = time.perf_counter()
    result = twip.montecarlo("flat-lqr-sim", n, perturb=PERTURB, seed=1, progress=False,
                             options={"t_final": T_FINAL}, threads=os.cpu_count())
    elapsed = time.perf_counter() - start
    assert not result.metrics["fell"].any()
    robots = [result.sample(i) for i in range(n)]
    p = {f: np.array([r[0].to_dict()[f] for r in robots]) for f in twip.RobotParams.fields}
    speed = sc.reference.sample(0.0)[1]
    phi_s, u_s = sc.controller.steady_state(speed)
    plant_phi_s = np.arcsin(p["mu_ground"] * speed / (p["m_body"] * p["g"] * p["com_height"]))
    shared = dict(gains=np.array(sc.controller.gains), phi_s=phi_s, u_s=u_s, speed=speed, period=sc.controller.period)
    return result, elapsed, p, plant_phi_s, shared


def coefficients(p):
    rotor = p["gear_ratio"] ** 2 * p["i_motor"]
    r, l = p["wheel_radius"], p["com_height"]
    return np.stack([
        p["i_body"] + p["m_body"] * l * l + rotor,                   # m11
        (p["m_body"] + p["m_wheels"]) * r * r + p["i_wheels"] + rotor,  # m22
        p["m_body"] * r * l,                                          # mrl
        rotor,
        p["m_body"] * p["g"] * l,                                     # mgl
        p["gear_ratio"] * p["torque_constant"],                       # torque per amp
        p["mu_bearing"],
        p["mu_ground"],
        r,
    ])


# ---- NumPy: the whole population advanced one step at a time ----------------------
def numpy_peer(c, plant_phi_s, s):
    m11, m22, mrl, rotor, mgl, ku, mus, mug, _r = c
    k = s["gains"]

    def deriv(x, u):
        phi, phid, _th, thd = x
        sp, cp = np.sin(phi), np.cos(phi)
        bearing = mus * (thd - phid)
        f1 = mgl * sp + bearing - ku * u
        f2 = mrl * sp * phid * phid - bearing - mug * thd + ku * u
        m12 = mrl * cp - rotor
        det = m11 * m22 - m12 * m12
        return np.stack([phid, (m22 * f1 - m12 * f2) / det, thd, (m11 * f2 - m12 * f1) / det])

    n = c.shape[1]
    x = np.zeros((4, n))
    z = np.zeros(n)
    sum_pitch = np.zeros(n)
    sum_speed = np.zeros(n)
    for _ in range(STEPS):
        err = x[3] - s["speed"]
        u = s["u_s"] - (k[0] * (x[0] - s["phi_s"]) + k[1] * x[1] + k[2] * err) - k[3] * z
        z = z + err * s["period"]
        sum_pitch += np.abs(x[0] - plant_phi_s)
        sum_speed += np.abs(x[3] - s["speed"])
        k1 = deriv(x, u)
        k2 = deriv(x + k1 * (DT * 0.5), u)
        k3 = deriv(x + k2 * (DT * 0.5), u)
        k4 = deriv(x + k3 * DT, u)
        x = x + (k1 + (k2 + k3) * 2.0 + k4) * (DT / 6.0)
    sum_pitch += np.abs(x[0] - plant_phi_s)
    sum_speed += np.abs(x[3] - s["speed"])
    return sum_pitch / (STEPS + 1), sum_speed / (STEPS + 1)


# ---- Numba: one sample per iteration of a parallel loop ----------------------------
def numba_peer_factory():
    import numba

    @numba.njit(inline="always")
    def deriv(c, i, phi, phid, thd, u):
        sp, cp = math.sin(phi), math.cos(phi)
        bearing = c[6, i] * (thd - phid)
        f1 = c[4, i] * sp + bearing - c[5, i] * u
        f2 = c[2, i] * sp * phid * phid - bearing - c[7, i] * thd + c[5, i] * u
        m12 = c[2, i] * cp - c[3, i]
        det = c[0, i] * c[1, i] - m12 * m12
        return (c[1, i] * f1 - m12 * f2) / det, (c[0, i] * f2 - m12 * f1) / det

    @numba.njit(parallel=True, fastmath=False)
    def run(c, plant_phi_s, k, phi_s, u_s, speed, period, steps, dt):
        n = c.shape[1]
        out_pitch = np.empty(n)
        out_speed = np.empty(n)
        for i in numba.prange(n):
            phi = phid = th = thd = 0.0
            z = 0.0
            sp_sum = sv_sum = 0.0
            for _ in range(steps):
                err = thd - speed
                u = u_s - (k[0] * (phi - phi_s) + k[1] * phid + k[2] * err) - k[3] * z
                z += err * period
                sp_sum += abs(phi - plant_phi_s[i])
                sv_sum += abs(thd - speed)
                a1, b1 = deriv(c, i, phi, phid, thd, u)
                h = dt * 0.5
                a2, b2 = deriv(c, i, phi + phid * h, phid + a1 * h, thd + b1 * h, u)
                a3, b3 = deriv(c, i, phi + (phid + a1 * h) * h, phid + a2 * h, thd + b2 * h, u)
                a4, b4 = deriv(c, i, phi + (phid + a2 * h) * dt, phid + a3 * dt, thd + b3 * dt, u)
                v1, v2, v3, v4 = phid, phid + a1 * h, phid + a2 * h, phid + a3 * dt
                w1, w2, w3, w4 = thd, thd + b1 * h, thd + b2 * h, thd + b3 * dt
                phi += (v1 + (v2 + v3) * 2.0 + v4) * (dt / 6.0)
                phid += (a1 + (a2 + a3) * 2.0 + a4) * (dt / 6.0)
                th += (w1 + (w2 + w3) * 2.0 + w4) * (dt / 6.0)
                thd += (b1 + (b2 + b3) * 2.0 + b4) * (dt / 6.0)
            sp_sum += abs(phi - plant_phi_s[i])
            sv_sum += abs(thd - speed)
            out_pitch[i] = sp_sum / (steps + 1)
            out_speed[i] = sv_sum / (steps + 1)
        return out_pitch, out_speed

    return run


# ---- JAX: jit(vmap(lax.scan)) -------------------------------------------------------
def jax_peer_factory():
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    def one(c, plant_phi_s, k, phi_s, u_s, speed, period):
        m11, m22, mrl, rotor, mgl, ku, mus, mug, _r = c

        def deriv(x, u):
            phi, phid, _th, thd = x
            sp, cp = jnp.sin(phi), jnp.cos(phi)
            bearing = mus * (thd - phid)
            f1 = mgl * sp + bearing - ku * u
            f2 = mrl * sp * phid * phid - bearing - mug * thd + ku * u
            m12 = mrl * cp - rotor
            det = m11 * m22 - m12 * m12
            return jnp.stack([phid, (m22 * f1 - m12 * f2) / det, thd, (m11 * f2 - m12 * f1) / det])

        def step(carry, _):
            x, z, sp_sum, sv_sum = carry
            err = x[3] - speed
            u = u_s - (k[0] * (x[0] - phi_s) + k[1] * x[1] + k[2] * err) - k[3] * z
            z = z + err * period
            sp_sum = sp_sum + jnp.abs(x[0] - plant_phi_s)
            sv_sum = sv_sum + jnp.abs(x[3] - speed)
            k1 = deriv(x, u)
            k2 = deriv(x + k1 * (DT * 0.5), u)
            k3 = deriv(x + k2 * (DT * 0.5), u)
            k4 = deriv(x + k3 * DT, u)
            return (x + (k1 + (k2 + k3) * 2.0 + k4) * (DT / 6.0), z, sp_sum, sv_sum), None

        init = (jnp.zeros(4), 0.0, 0.0, 0.0)
        (x, _z, sp_sum, sv_sum), _ = jax.lax.scan(step, init, None, length=STEPS)
        sp_sum = sp_sum + jnp.abs(x[0] - plant_phi_s)
        sv_sum = sv_sum + jnp.abs(x[3] - speed)
        return sp_sum / (STEPS + 1), sv_sum / (STEPS + 1)

    batched = jax.jit(jax.vmap(one, in_axes=(1, 0, None, None, None, None, None)))

    def run(c, plant_phi_s, s):
        out = batched(jnp.asarray(c), jnp.asarray(plant_phi_s), jnp.asarray(s["gains"]), s["phi_s"], s["u_s"],
                      s["speed"], s["period"])
        return tuple(np.asarray(o) for o in jax.block_until_ready(out))

    return run


# ---- Numba, fuzzy backstepping + PD: one sample per iteration of a parallel loop -----
def numba_fuzzy_factory():
    import numba

    @numba.njit(inline="always")
    def trapezoid(x, a, b, c, d):
        if x < a or x > d:
            return 0.0
        if x < b:
            return (x - a) / (b - a)
        if x <= c:
            return 1.0
        return (d - x) / (d - c)

    @numba.njit(inline="always")
    def negative_zero_positive(x, inner, outer):
        """The thesis's N, Z, P sets (shoulders outside), normalised to sum 1."""
        n = trapezoid(x, -math.inf, -math.inf, -outer, -inner)
        z = trapezoid(x, -outer, -inner, inner, outer)
        p = trapezoid(x, inner, outer, math.inf, math.inf)
        total = n + z + p
        return n / total, z / total, p / total

    @numba.njit(inline="always")
    def deriv(c, i, phi, phid, thd, u):
        sp, cp = math.sin(phi), math.cos(phi)
        bearing = c[6, i] * (thd - phid)
        f1 = c[4, i] * sp + bearing - c[5, i] * u
        f2 = c[2, i] * sp * phid * phid - bearing - c[7, i] * thd + c[5, i] * u
        m12 = c[2, i] * cp - c[3, i]
        det = c[0, i] * c[1, i] - m12 * m12
        return (c[1, i] * f1 - m12 * f2) / det, (c[0, i] * f2 - m12 * f1) / det

    @numba.njit(parallel=True, fastmath=False)
    def run(c, plant_phi_s, ctrl, law, speed, steps, dt):
        m11c, m22c, mrlc, rotorc, kuc = ctrl
        k1, k2, kp, kd, ki, gamma, sigma, phi_s = law
        n = c.shape[1]
        out_pitch = np.empty(n)
        out_speed = np.empty(n)
        for i in numba.prange(n):
            phi = phid = th = thd = 0.0
            s_hat = np.zeros(9)
            e_int = 0.0
            sp_sum = sv_sum = 0.0
            for step in range(steps):
                t = step * dt
                # the controller, every step
                e1 = phi - phi_s
                z2 = phid + k1 * e1
                w_phi = negative_zero_positive(phi, 0.1, 0.3)
                w_dot = negative_zero_positive(phid, 0.5, 2.0)
                f1 = 0.0
                for j in range(9):
                    f1 += s_hat[j] * (w_phi[j // 3] * w_dot[j % 3])
                m12 = mrlc * math.cos(phi) - rotorc
                g1 = (m22c * -kuc - m12 * kuc) / (m11c * m22c - m12 * m12)
                e = speed * t - th
                u = -(e1 + f1 + k1 * phid + (0.5 + k2) * z2) / g1 + kp * e + kd * (speed - thd) + ki * e_int
                for j in range(9):
                    s_hat[j] += dt * (z2 / gamma * (w_phi[j // 3] * w_dot[j % 3]) - sigma * s_hat[j])
                e_int += dt * e
                sp_sum += abs(phi - plant_phi_s[i])
                sv_sum += abs(thd - speed)
                # the plant, RK4 with u held
                a1, b1 = deriv(c, i, phi, phid, thd, u)
                h = dt * 0.5
                a2, b2 = deriv(c, i, phi + phid * h, phid + a1 * h, thd + b1 * h, u)
                a3, b3 = deriv(c, i, phi + (phid + a1 * h) * h, phid + a2 * h, thd + b2 * h, u)
                a4, b4 = deriv(c, i, phi + (phid + a2 * h) * dt, phid + a3 * dt, thd + b3 * dt, u)
                v1, v2, v3, v4 = phid, phid + a1 * h, phid + a2 * h, phid + a3 * dt
                w1, w2, w3, w4 = thd, thd + b1 * h, thd + b2 * h, thd + b3 * dt
                phi += (v1 + (v2 + v3) * 2.0 + v4) * (dt / 6.0)
                phid += (a1 + (a2 + a3) * 2.0 + a4) * (dt / 6.0)
                th += (w1 + (w2 + w3) * 2.0 + w4) * (dt / 6.0)
                thd += (b1 + (b2 + b3) * 2.0 + b4) * (dt / 6.0)
            sp_sum += abs(phi - plant_phi_s[i])
            sv_sum += abs(thd - speed)
            out_pitch[i] = sp_sum / (steps + 1)
            out_speed[i] = sv_sum / (steps + 1)
        return out_pitch, out_speed

    return run


def fuzzy_workload(n, repeats):
    """twip's flat-fuzzy-sim sweep against the Numba peer; prints the table."""
    sc = twip.scenarios.get("flat-fuzzy-sim", t_final=T_FINAL)
    ctrl = sc.controller
    assert (ctrl.period, ctrl.ki, ctrl.adapt) == (DT, 0.0, True) and not any(ctrl.s0)
    kw = dict(perturb=PERTURB, seed=1, progress=False, options={"t_final": T_FINAL})
    result = twip.montecarlo("flat-fuzzy-sim", n, **kw)
    assert not result.metrics["fell"].any() and result.kernel == "lanes"
    t_twip, _ = median_time(lambda: twip.montecarlo("flat-fuzzy-sim", n, **kw), repeats)
    robots = [result.sample(i) for i in range(n)]
    p = {f: np.array([r[0].to_dict()[f] for r in robots]) for f in twip.RobotParams.fields}
    speed = sc.reference.sample(0.0)[1]
    plant_phi_s = np.arcsin(p["mu_ground"] * speed / (p["m_body"] * p["g"] * p["com_height"]))
    nominal = {f: np.array([v]) for f, v in ctrl.model.params.to_dict().items()}
    cn = coefficients(nominal)[:, 0]
    controller_model = (cn[0], cn[1], cn[2], cn[3], cn[5])
    law = (ctrl.k1, ctrl.k2, ctrl.kp, ctrl.kd, ctrl.ki, ctrl.gamma, ctrl.sigma, ctrl.steady_pitch(speed))
    c = np.ascontiguousarray(coefficients(p))
    rows = [("twip (Rust, lanes, all cores)", n, t_twip, "reference")]
    try:
        run = numba_fuzzy_factory()
        run(c[:, :8].copy(), plant_phi_s[:8].copy(), controller_model, law, speed, STEPS, DT)  # compile
        t, got = median_time(lambda: run(c, plant_phi_s, controller_model, law, speed, STEPS, DT), repeats)
        rows.append(("Numba @njit(parallel=True)", n, t, check("numba fuzzy", got, result, slice(None))))
    except ImportError:
        rows.append(("Numba", 0, float("nan"), "not installed"))
    table(f"workload: flat-fuzzy-sim, RK4 dt={DT}, {T_FINAL} s = {STEPS} steps per sample", rows, repeats)


def table(title, rows, repeats):
    print(f"{title}, {os.cpu_count()} cores, median of {repeats} runs each\n")
    print(f"{'implementation':34s} {'samples':>8s} {'seconds':>9s} {'M sample-steps/s':>17s} {'twip is':>9s}  metrics")
    twip_rate = rows[0][1] * STEPS / rows[0][2]
    for name, n, t, note in rows:
        rate = n * STEPS / t if n else float("nan")
        ratio = twip_rate / rate if n else float("nan")
        print(f"{name:34s} {n:8d} {t:9.2f} {rate / 1e6:17.2f} {ratio:8.1f}x  {note}")
    print()


def median_time(run, repeats):
    """The median wall time of `repeats` calls, and the last call's value."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        value = run()
        times.append(time.perf_counter() - start)
    return sorted(times)[len(times) // 2], value


def check(name, got, result, sel):
    for value, metric in zip(got, ("mean_abs_pitch_error", "mean_abs_speed_error")):
        ref = result.metrics[metric][sel]
        err = np.max(np.abs(value - ref) / np.abs(ref))
        assert err < 1e-9, f"{name} disagrees with twip on {metric}: rel {err:.2e}"
    return "agrees (rel < 1e-9)"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=20_000, help="samples for twip and Numba")
    ap.add_argument("--n-slow", type=int, default=1_000, help="samples for NumPy and JAX")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each; the median time counts")
    ap.add_argument("--workload", choices=["lqr", "fuzzy", "all"], default="all")
    args = ap.parse_args()
    if args.workload in ("fuzzy", "all"):
        fuzzy_workload(args.n, args.repeats)
    if args.workload == "fuzzy":
        return
    print(f"workload: flat-lqr-sim, RK4 dt={DT}, {T_FINAL} s = {STEPS} steps per sample, {os.cpu_count()} cores\n")
    result, _, p, plant_phi_s, shared = problem(args.n)
    t_twip, _ = median_time(lambda: twip.montecarlo("flat-lqr-sim", args.n, perturb=PERTURB, seed=1, progress=False,
                                                    options={"t_final": T_FINAL}), args.repeats)
    c = coefficients(p)
    rates = {"twip": args.n * STEPS / t_twip}
    rows = [("twip (Rust, lanes, all cores)", args.n, t_twip, "reference")]
    # 1 -> 2 threads scaling of twip: three alternating pairs, the median ratio (on a
    # shared VM a single pair can be off by +-30 %).
    pairs = []
    for _ in range(3):
        pair = {}
        for threads in (1, 2):
            start = time.perf_counter()
            twip.montecarlo("flat-lqr-sim", args.n // 2, perturb=PERTURB, seed=1, progress=False,
                            options={"t_final": T_FINAL}, threads=threads)
            pair[threads] = (args.n // 2) * STEPS / (time.perf_counter() - start)
        pairs.append(pair)
    pairs.sort(key=lambda p: p[2] / p[1])
    rates["twip_1t"], rates["twip_2t"] = pairs[1][1], pairs[1][2]
    scaling = ", ".join(f"{p[2] / p[1]:.2f}x" for p in pairs)
    sel = slice(0, args.n_slow)
    t, got = median_time(lambda: numpy_peer(c[:, sel], plant_phi_s[sel], shared), args.repeats)
    rows.append(("NumPy, vectorised over samples", args.n_slow, t, check("numpy", got, result, sel)))
    rates["numpy"] = args.n_slow * STEPS / t
    try:
        run = numba_peer_factory()
        s = shared
        args_nb = (s["gains"], s["phi_s"], s["u_s"], s["speed"], s["period"], STEPS, DT)
        run(c[:, :8].copy(), plant_phi_s[:8].copy(), *args_nb)  # compile
        c_contiguous = np.ascontiguousarray(c)
        t, got = median_time(lambda: run(c_contiguous, plant_phi_s, *args_nb), args.repeats)
        rows.append(("Numba @njit(parallel=True)", args.n, t, check("numba", got, result, slice(None))))
        rates["numba"] = args.n * STEPS / t
    except ImportError:
        rows.append(("Numba", 0, float("nan"), "not installed"))
    try:
        run = jax_peer_factory()
        run(c[:, :8], plant_phi_s[:8], shared)  # compile for a small batch first
        run(c[:, sel], plant_phi_s[sel], shared)  # compile for this batch size
        t, got = median_time(lambda: run(c[:, sel], plant_phi_s[sel], shared), args.repeats)
        rows.append(("JAX jit(vmap(lax.scan)), CPU", args.n_slow, t, check("jax", got, result, sel)))
        rates["jax"] = args.n_slow * STEPS / t
    except ImportError:
        rows.append(("JAX", 0, float("nan"), "not installed"))
    print(f"median of {args.repeats} runs each\n")
    print(f"{'implementation':34s} {'samples':>8s} {'seconds':>9s} {'M sample-steps/s':>17s} {'twip is':>9s}  metrics")
    for name, n, t, note in rows:
        rate = n * STEPS / t if n else float("nan")
        ratio = rates["twip"] / rate if n else float("nan")
        print(f"{name:34s} {n:8d} {t:9.2f} {rate / 1e6:17.2f} {ratio:8.1f}x  {note}")
    print(f"\ntwip 1 -> 2 threads, median of three pairs: {rates['twip_1t'] / 1e6:.1f} -> "
          f"{rates['twip_2t'] / 1e6:.1f} M sample-steps/s ({rates['twip_2t'] / rates['twip_1t']:.2f}x; "
          f"all pairs: {scaling})")


if __name__ == "__main__":
    main()
