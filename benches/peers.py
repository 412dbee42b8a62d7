"""twip against what a user would write instead, on one workload, measured in one run.

Workload: closed-loop 2-DOF model + LQR with integral action (scenario flat-lqr-sim:
180 deg/s, controller every 1 ms step), RK4 at dt = 1 ms for 10 s, N robots with
m_body ±20 %, com_height ±10 %, i_body ±20 % (uniform), as twip.montecarlo draws them.
Peers: a NumPy loop vectorised over samples, Numba @njit(parallel=True), and JAX
jit(vmap(lax.scan)) on the CPU (float64). Each peer gets the very same robots and
gains and must reproduce twip's metrics (mean |pitch error|, mean |speed error|) to
rel 1e-9. Printed: sample-steps per second and the ratios. twip and its Numba peer are timed
in alternating rounds (twip, Numba, twip, Numba, ...), and each round's ratio is printed: a
shared machine's speed drifts over minutes, and a round's two runs see nearly the same machine.

Workload `fuzzy` (`--workload fuzzy|lqr|circle-pid|all`): the same robots under scenario
flat-fuzzy-sim (fuzzy adaptive backstepping + PD, the thesis's flat gains and N/Z/P sets, controller every
1 ms, 180 deg/s), against a Numba-parallel peer written from the thesis's equations; the peer
must reproduce twip's mean |pitch error| and mean |speed error| to rel 1e-9.

Workload `circle-pid` (`--workload circle-pid`, default 1024 samples): the same perturbations on
the 3-DOF model (state x, y, psi, phi, phi_dot, v, omega; no friction) under scenario
circle-pid (Table 4.1's PID tracker in the Arduino's units, its PWM through the DC motor model,
controller every 5 ms, RK4 at 1 ms; three laps of the r = 0.6 m circle, 108 s = 108000 steps),
against a Numba-parallel peer written from the equations. The peer must reproduce all seven of
twip's tracking metrics (mean |x|, |y| errors, the same after the first lap, max path error
after it, mean |pitch|, peak |torque|) to rel 1e-9. Against twip's general runner it agreed to
4e-13 (worst of 2000 samples), all of it libm's sin and cos against twip's own polynomial
(model/math.rs): with that polynomial the peer agreed bit for bit. twip now sweeps circle-pid on
its planar lane kernel (fused multiply-adds), which agrees with the general runner to rounding.

Run:  .venv/bin/pip install numba jax && .venv/bin/python benches/peers.py [--n 20000] [--kernel-copy avx2]
On an AVX-512 machine, `--as-avx2` races twip's avx2 copy against Numba compiled for Haswell
(LLVM's 256-bit code without AVX-512), the nearest this machine comes to an AVX2 CPU.
(numba and jax are benchmark-only dependencies, not twip's.)
"""
import argparse
import functools
import math
import os
import time

import numpy as np

import twip
import twip.scenarios

# LLVM features that switch AVX-512 off, for Numba (`--as-avx2`).
AVX512_OFF = ",".join("-" + f for f in ("avx512f", "avx512cd", "avx512dq", "avx512bw", "avx512vl",
                                         "avx512ifma", "avx512vbmi", "avx512vnni", "avx512bf16",
                                         "avx512vpopcntdq", "avx512bitalg", "avx512vbmi2", "avx512fp16"))

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
    robots = [result.sample(i) for i in range(n)]
    p = {f: np.array([r[0].to_dict()[f] for r in robots]) for f in twip.RobotParams.fields}
    speed = sc.reference.sample(0.0)[1]
    plant_phi_s = np.arcsin(p["mu_ground"] * speed / (p["m_body"] * p["g"] * p["com_height"]))
    nominal = {f: np.array([v]) for f, v in ctrl.model.params.to_dict().items()}
    cn = coefficients(nominal)[:, 0]
    controller_model = (cn[0], cn[1], cn[2], cn[3], cn[5])
    law = (ctrl.k1, ctrl.k2, ctrl.kp, ctrl.kd, ctrl.ki, ctrl.gamma, ctrl.sigma, ctrl.steady_pitch(speed))
    c = np.ascontiguousarray(coefficients(p))
    try:
        run = numba_fuzzy_factory()
        run(c[:, :8].copy(), plant_phi_s[:8].copy(), controller_model, law, speed, STEPS, DT)  # compile
        peer = functools.partial(run, c, plant_phi_s, controller_model, law, speed, STEPS, DT)
    except ImportError:
        peer = None
    t_twip, peer_time, rounds = against_peer(lambda: twip.montecarlo("flat-fuzzy-sim", n, **kw), peer, repeats)
    rows = [("twip (Rust, lanes, all cores)", n, t_twip, "reference")]
    rows.append(peer_row(peer_time, n, lambda got: check("numba fuzzy", got, result, slice(None))))
    table(f"workload: flat-fuzzy-sim, RK4 dt={DT}, {T_FINAL} s = {STEPS} steps per sample", rows, repeats)
    print_rounds(rounds)


# ---- Numba, 3-DOF model + PID tracker on a circle: one sample per iteration of a parallel loop ----
CIRCLE_METRICS = ("mean_abs_x_error", "mean_abs_y_error", "mean_abs_x_error_settled", "mean_abs_y_error_settled",
                  "max_path_error_settled", "mean_abs_pitch", "peak_abs_torque")


def planar_coefficients(p):
    """The 3-DOF model's constants per sample: M(phi) nu_dot + h(phi, nu) = B u, nu = (phi_dot, v, omega)."""
    r, cz, b = p["wheel_radius"], p["com_height"], p["half_track"]
    rotor = p["gear_ratio"] * p["gear_ratio"] * p["i_motor"]
    wheel_line = p["m_wheels"] + (p["i_wheels"] + rotor) / (r * r)
    mbc = p["m_body"] * cz
    k = mbc * cz + p["i_body_roll"] - p["i_body_yaw"]
    mu = p["mu_bearing"] + p["mu_ground"]
    return np.stack([
        mbc * cz + p["i_body"] + rotor,                                  # m_phiphi
        p["m_body"] + wheel_line,                                        # m_vv
        p["i_body_yaw"] + 2.0 * p["i_wheel_diam"] + b * b * wheel_line,  # m_omegaomega at phi = 0
        k,                                                               # m_omegaomega's sin^2 phi term
        mbc,
        rotor / r,                                                       # rotor's share of m_phiv
        mbc * p["g"],
        p["mu_bearing"],
        p["mu_bearing"] / r,
        mu / (r * r),                                                    # on v
        b * b * mu / (r * r),                                            # on omega
        1.0 / r,
        b / r,
    ])


def numba_circle_pid_factory():
    import numba

    @numba.njit(inline="always")
    def deriv(cf, x, u_r, u_l):
        """d/dt [x, y, psi, phi, phi_dot, v, omega] under the wheel torques u_r, u_l."""
        m_pp, m_vv, m_ww0, k, mbc, rotor_r, mgc, mu_s, mu_s_r, mu_v, mu_w, inv_r, b_r = cf
        _x, _y, psi, phi, phid, v, omega = x
        s, cp = math.sin(phi), math.cos(phi)
        sc, w2, u_sum = s * cp, omega * omega, u_r + u_l
        # f = B u - h on (phi_dot, v, omega)
        f_p = mgc * s + k * sc * w2 - mu_s * phid + mu_s_r * v - u_sum
        f_v = mbc * s * (phid * phid + w2) - mu_v * v + mu_s_r * phid + inv_r * u_sum
        f_w = b_r * (u_r - u_l) - (2.0 * k * sc * phid + mbc * s * v + mu_w) * omega
        # M's (phi, v) block by Cramer's rule; its yaw row is diagonal
        m_pv = mbc * cp - rotor_r
        det = m_pp * m_vv - m_pv * m_pv
        phi_dd = (m_vv * f_p - m_pv * f_v) / det
        v_dot = (m_pp * f_v - m_pv * f_p) / det
        omega_dot = f_w / (m_ww0 + k * s * s)
        return v * math.cos(psi), v * math.sin(psi), omega, phid, phi_dd, v_dot, omega_dot

    @numba.njit(inline="always")
    def plus(x, d, h):
        """x + d h for 7-tuples."""
        return (x[0] + d[0] * h, x[1] + d[1] * h, x[2] + d[2] * h, x[3] + d[3] * h, x[4] + d[4] * h,
                x[5] + d[5] * h, x[6] + d[6] * h)

    @numba.njit(inline="always")
    def rk4(cf, x, u_r, u_l, dt):
        k1 = deriv(cf, x, u_r, u_l)
        k2 = deriv(cf, plus(x, k1, dt * 0.5), u_r, u_l)
        k3 = deriv(cf, plus(x, k2, dt * 0.5), u_r, u_l)
        k4 = deriv(cf, plus(x, k3, dt), u_r, u_l)
        slope = plus(plus(k1, k4, 1.0), plus(k2, k3, 1.0), 2.0)  # k1 + k4 + 2 (k2 + k3)
        return plus(x, slope, dt / 6.0)

    @numba.njit(inline="always")
    def circle_at(circle, t):
        """The counter-clockwise circle's point, heading and turn rate at t."""
        cx, cy, radius, speed, phase = circle
        rate = speed / radius
        angle = phase + rate * t
        return cx + radius * math.cos(angle), cy + radius * math.sin(angle), angle + math.pi / 2, rate

    @numba.njit(inline="always")
    def wrap(angle):
        """angle mod 2 pi in [-pi, pi)."""
        return angle - 2.0 * math.pi * math.floor((angle + math.pi) / (2.0 * math.pi))

    @numba.njit(inline="always")
    def wheel_torque(motor, pwm, speed):
        """The DC motor's torque at the wheel for a (saturated) PWM count at relative wheel speed `speed`."""
        resistance, k_t, gear, supply, pwm_max = motor
        volts = pwm * supply / pwm_max
        return gear * k_t * ((volts - k_t * gear * speed) / resistance)

    @numba.njit(parallel=True, fastmath=False)
    def run(c, gains, units, geometry, motor, circle, steps, per_update, dt, settle):
        kp_phi, kd_phi, kp_v, ki_v, kp_psi, ki_psi, kd_psi = gains
        u_pitch, u_speed, u_heading = units
        radius_c, half_track_c = geometry
        cx, cy, radius, speed, _phase = circle
        pwm_max = motor[4]
        n = c.shape[1]
        out = np.empty((7, n))
        for i in numba.prange(n):
            cf = (c[0, i], c[1, i], c[2, i], c[3, i], c[4, i], c[5, i], c[6, i], c[7, i], c[8, i], c[9, i],
                  c[10, i], c[11, i], c[12, i])
            x = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            int_v = int_psi = tau_r = tau_l = 0.0
            sum_x = sum_y = sum_xs = sum_ys = sum_pitch = path_max = peak = 0.0
            settled = 0
            for step in range(steps + 1):  # the metrics also count the state after the last step
                t = dt * step
                xr, yr, psi_r, omega_r = circle_at(circle, t)
                if step < steps and step % per_update == 0:
                    # the tracker (4.67-4.70) on the true state, its torques held for per_update steps
                    _x, _y, psi, phi, phid, v, omega = x
                    u_phi = kp_phi * u_pitch * phi + kd_phi * u_pitch * phid
                    e_v = u_speed * (speed - v)
                    u_v = kp_v * e_v + ki_v * int_v
                    e_psi = u_heading * wrap(psi_r - psi)
                    u_psi = kp_psi * e_psi + ki_psi * int_psi + kd_psi * u_heading * (omega_r - omega)
                    pwm_r = min(max(u_phi + u_v + u_psi, -pwm_max), pwm_max)
                    pwm_l = min(max(u_phi + u_v - u_psi, -pwm_max), pwm_max)
                    int_v += e_v  # the Arduino's running sums
                    int_psi += e_psi
                    # the motors see each wheel's speed relative to the body
                    tau_r = wheel_torque(motor, pwm_r, (v + half_track_c * omega) / radius_c - phid)
                    tau_l = wheel_torque(motor, pwm_l, (v - half_track_c * omega) / radius_c - phid)
                ex, ey = abs(x[0] - xr), abs(x[1] - yr)
                sum_x += ex
                sum_y += ey
                sum_pitch += abs(x[3])
                if t >= settle:
                    sum_xs += ex
                    sum_ys += ey
                    path_max = max(path_max, abs(math.sqrt((x[0] - cx) ** 2 + (x[1] - cy) ** 2) - radius))
                    settled += 1
                peak = max(peak, abs(tau_r), abs(tau_l))
                if step < steps:
                    x = rk4(cf, x, tau_r, tau_l, dt)
            out[0, i], out[1, i] = sum_x / (steps + 1), sum_y / (steps + 1)
            out[2, i], out[3, i] = sum_xs / settled, sum_ys / settled
            out[4, i], out[5, i], out[6, i] = path_max, sum_pitch / (steps + 1), peak
        return out

    return run


def circle_pid_workload(n, repeats):
    """twip's circle-pid sweep (3-DOF model, PID tracker, 3 laps) against the Numba peer; prints the table."""
    sc = twip.scenarios.get("circle-pid")
    ctrl, circle, motor = sc.controller, sc.reference.to_dict(), sc.controller.motor.to_dict()
    assert not np.any(sc.x0) and sc.model.friction is None and circle["direction"] == 1
    assert ctrl.units["integral_step"] == 1.0
    steps, per_update = round(sc.t_final / sc.dt), round(ctrl.period / sc.dt)
    kw = dict(perturb=PERTURB, seed=1, progress=False)
    result = twip.montecarlo("circle-pid", n, **kw)
    assert not result.metrics["fell"].any() and result.steps == n * steps
    robots = [result.sample(i) for i in range(n)]
    p = {f: np.array([r[0].to_dict()[f] for r in robots]) for f in twip.RobotParams.fields}
    c = np.ascontiguousarray(planar_coefficients(p))
    g, u = ctrl.gains, ctrl.units
    gains = tuple(g[k] for k in ("kp_pitch", "kd_pitch", "kp_speed", "ki_speed", "kp_yaw", "ki_yaw", "kd_yaw"))
    units = (u["pitch"], u["speed"], u["heading"])
    nominal = sc.model.params.to_dict()  # the tracker's robot: it turns wheel speeds with the nominal geometry
    geometry = (nominal["wheel_radius"], nominal["half_track"])
    motor = tuple(motor[k] for k in ("resistance", "k_t", "gear_ratio", "supply", "pwm_max"))
    circle = (*circle["centre"], circle["radius"], circle["speed"], circle["phase"])
    rest = (gains, units, geometry, motor, circle)
    try:
        run = numba_circle_pid_factory()
        run(c[:, :2].copy(), *rest, 10, per_update, sc.dt, sc.reference.period)  # compile
        peer = functools.partial(run, c, *rest, steps, per_update, sc.dt, sc.reference.period)
    except ImportError:
        peer = None
    t_twip, peer_time, rounds = against_peer(lambda: twip.montecarlo("circle-pid", n, **kw), peer, repeats)
    rows = [(f"twip (Rust, {result.kernel}, all cores)", n, t_twip, "reference")]
    rows.append(peer_row(peer_time, n, lambda got: check("numba circle-pid", got, result, slice(None), CIRCLE_METRICS)))
    table(f"workload: circle-pid, RK4 dt={sc.dt}, {sc.t_final:g} s = {steps} steps per sample", rows, repeats, steps)
    print_rounds(rounds)


def table(title, rows, repeats, steps=STEPS):
    print(f"{title}, {os.cpu_count()} cores, twip's {twip.kernel_copy()} lane kernels, median of {repeats} runs each\n")
    print(f"{'implementation':34s} {'samples':>8s} {'seconds':>9s} {'M sample-steps/s':>17s} {'twip is':>9s}  metrics")
    twip_rate = rows[0][1] * steps / rows[0][2]
    for name, n, t, note in rows:
        rate = n * steps / t if n else float("nan")
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


def against_peer(twip_run, peer, repeats):
    """twip's run and its Numba peer's (None: not installed) timed in `repeats` alternating
    rounds: twip's median time, the peer's (median time, last value) or None, and each
    round's (twip's time, the peer's time)."""
    if peer is None:
        return median_time(twip_run, repeats)[0], None, []
    rounds, value = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        twip_run()
        middle = time.perf_counter()
        value = peer()
        rounds.append((middle - start, time.perf_counter() - middle))
    medians = [sorted(r[i] for r in rounds)[len(rounds) // 2] for i in (0, 1)]
    return medians[0], (medians[1], value), rounds


def peer_row(peer_time, n, checked):
    """The Numba peer's table row from `against_peer`'s (median time, value); `checked` turns
    its value into the metrics' note."""
    if peer_time is None:
        return ("Numba", 0, float("nan"), "not installed")
    return ("Numba @njit(parallel=True)", n, peer_time[0], checked(peer_time[1]))


def print_rounds(rounds):
    """How many times faster twip was than Numba in each round (the same samples for both)."""
    if rounds:
        ratios = sorted(peer / ours for ours, peer in rounds)
        print("twip is, round by round against Numba: " + ", ".join(f"{r:.1f}x" for r in ratios) + "\n")


def check(name, got, result, sel, metrics=("mean_abs_pitch_error", "mean_abs_speed_error")):
    for value, metric in zip(got, metrics, strict=True):
        ref = result.metrics[metric][sel]
        err = np.max(np.abs(value - ref) / np.abs(ref))
        assert err < 1e-9, f"{name} disagrees with twip on {metric}: rel {err:.2e}"
    return "agrees (rel < 1e-9)"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=None,
                    help="samples for twip and Numba (default 20000; circle-pid 1024, a sample being 108000 steps)")
    ap.add_argument("--n-slow", type=int, default=1_000, help="samples for NumPy and JAX (0: skip them)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each; the median time counts")
    ap.add_argument("--workload", choices=["lqr", "fuzzy", "circle-pid", "all"], default="all")
    ap.add_argument("--kernel-copy", choices=["avx512", "avx2", "baseline"], default=None,
                    help="run this copy of twip's lane kernels (default: the widest this CPU has; baseline needs a "
                         "wheel with every copy, `make build KERNEL_COPIES=all`)")
    ap.add_argument("--as-avx2", action="store_true",
                    help="an AVX2 machine's race on an AVX-512 one: twip's avx2 copy against Numba "
                         "compiled for Haswell (AVX2 and FMA, no AVX-512)")
    args = ap.parse_args()
    if args.as_avx2:
        if args.kernel_copy not in (None, "avx2"):
            ap.error(f"--as-avx2 runs twip's avx2 copy, not --kernel-copy {args.kernel_copy}")
        args.kernel_copy = "avx2"
        # Read when numba is first imported (the peers' factories import it). The features
        # must be given too: with a CPU name alone numba adds the host's, AVX-512 among them.
        os.environ["NUMBA_CPU_NAME"] = "haswell"
        os.environ["NUMBA_CPU_FEATURES"] = AVX512_OFF
        print("as on an AVX2 machine: Numba compiled for haswell, without AVX-512\n")
    if args.n_slow < 0 or (args.n is not None and args.n < 1):
        ap.error(f"--n must be at least 1 and --n-slow at least 0 (got --n {args.n}, --n-slow {args.n_slow})")
    if args.workload in ("lqr", "all") and args.n_slow > (args.n or 20_000):
        ap.error(f"--n-slow {args.n_slow} is more than the lqr workload's {args.n or 20_000} samples")
    twip.use_kernel_copy(args.kernel_copy)
    if args.workload in ("fuzzy", "all"):
        fuzzy_workload(args.n or 20_000, args.repeats)
    if args.workload in ("circle-pid", "all"):
        # 1024, so that twip's run takes about a second, as the other workloads' do: with 256
        # (0.3 s), the ~70 ms more that a twip run took after a pause of a second or more on
        # the project's VM (here, Numba's run) was a quarter of its time; 5.6-6.3x against 7.3x
        # (docs/performance.md, forty-fourth session).
        circle_pid_workload(args.n or 1024, args.repeats)
    if args.workload not in ("lqr", "all"):
        return
    args.n = args.n or 20_000
    print(f"workload: flat-lqr-sim, RK4 dt={DT}, {T_FINAL} s = {STEPS} steps per sample, {os.cpu_count()} cores, "
          f"twip's {twip.kernel_copy()} lane kernels\n")
    result, _, p, plant_phi_s, shared = problem(args.n)
    c = coefficients(p)
    try:
        run = numba_peer_factory()
        s = shared
        args_nb = (s["gains"], s["phi_s"], s["u_s"], s["speed"], s["period"], STEPS, DT)
        run(c[:, :8].copy(), plant_phi_s[:8].copy(), *args_nb)  # compile
        c_contiguous = np.ascontiguousarray(c)
        peer = functools.partial(run, c_contiguous, plant_phi_s, *args_nb)
    except ImportError:
        peer = None
    t_twip, peer_time, rounds = against_peer(
        lambda: twip.montecarlo("flat-lqr-sim", args.n, perturb=PERTURB, seed=1, progress=False,
                                options={"t_final": T_FINAL}), peer, args.repeats)
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
    if args.n_slow == 0:
        # Only twip against Numba, the speed targets' pair.
        rows.append(("NumPy", 0, float("nan"), "skipped (--n-slow 0)"))
    else:
        t, got = median_time(lambda: numpy_peer(c[:, sel], plant_phi_s[sel], shared), args.repeats)
        rows.append(("NumPy, vectorised over samples", args.n_slow, t, check("numpy", got, result, sel)))
        rates["numpy"] = args.n_slow * STEPS / t
    rows.append(peer_row(peer_time, args.n, lambda got: check("numba", got, result, slice(None))))
    if args.n_slow == 0:
        rows.append(("JAX", 0, float("nan"), "skipped (--n-slow 0)"))
    else:
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
    print()
    print_rounds(rounds)
    print(f"twip 1 -> 2 threads, median of three pairs: {rates['twip_1t'] / 1e6:.1f} -> "
          f"{rates['twip_2t'] / 1e6:.1f} M sample-steps/s ({rates['twip_2t'] / rates['twip_1t']:.2f}x; "
          f"all pairs: {scaling})")


if __name__ == "__main__":
    main()
