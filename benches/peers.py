"""twip against what a user would write instead, on one workload, measured in one run.

Workload: closed-loop 2-DOF model + LQR with integral action (scenario flat-lqr-sim:
180 deg/s, controller every 1 ms step), RK4 at dt = 1 ms for 10 s, N robots with
m_body ±20 %, com_height ±10 %, i_body ±20 % (uniform), as twip.montecarlo draws them.
Peers: a NumPy loop vectorised over samples, Numba @njit(parallel=True), and JAX
jit(vmap(lax.scan)) on the CPU (float64). Each peer gets the very same robots and
gains and must reproduce twip's metrics (mean |pitch error|, mean |speed error|) to
rel 1e-9. Printed: sample-steps per second and the ratios.

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
    args = ap.parse_args()
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
