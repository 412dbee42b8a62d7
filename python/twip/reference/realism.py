"""Reference of the real robot in the loop: MPU-6050 (noise, bias, DLPF, LSB), tilt
estimators, encoder, PWM motor drive, pushes, a constant force, slope changes, and the
runner that puts them round a 2-DOF controller. Plain Python floats and numpy, written
from the equations in twip-core's module docs (hardware/: imu.rs, tilt.rs, encoder.rs, driver.rs,
disturbance.rs, realism.rs), never calling the Rust core. The noise comes from
`twip.reference.rng.Sfc64`, so a run draws the very numbers the core draws.

One file because it is one independent reading of the hardware chain, to be checked against
the core's modules side by side in the order the signal flows (sensor, estimator, encoder,
driver, disturbances, runner); its parts share the noise's draw order, which a split would
hide across files.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np

from twip.reference.backlash import GearPlay, heun
from twip.reference.friction import Friction
from twip.reference.rng import Sfc64
from twip.reference.settle import settle
from twip.reference.slope import SlopeModel

STANDARD_GRAVITY = 9.80665
DEG = math.pi / 180.0

# Table 2.2: (accel Hz, accel delay s, gyro Hz, gyro delay s) per DLPF_CFG.
DLPF_TABLE = [
    (260.0, 0.0, 256.0, 0.98e-3),
    (184.0, 2.0e-3, 188.0, 1.9e-3),
    (94.0, 3.0e-3, 98.0, 2.8e-3),
    (44.0, 4.9e-3, 42.0, 4.8e-3),
    (21.0, 8.5e-3, 20.0, 8.3e-3),
    (10.0, 13.8e-3, 10.0, 13.4e-3),
    (5.0, 19.0e-3, 5.0, 18.6e-3),
]


def dlpf_config(hz: float) -> int:
    for i, (a, _, g, _) in enumerate(DLPF_TABLE):
        if abs(a - hz) < 0.5 or abs(g - hz) < 0.5:
            return i
    raise ValueError(f"invalid dlpf_hz = {hz}")


# --- DLPF ----------------------------------------------------------------------------------


def _bandwidth_ratio(zeta: float) -> float:
    """-3 dB bandwidth over the natural frequency of a unit second-order low-pass."""
    a = 1.0 - 2.0 * zeta * zeta
    return math.sqrt(a + math.sqrt(a * a + 1.0))


class Dlpf:
    """Second-order section (bilinear, prewarped at the bandwidth) with its DC delay set
    to `delay`, then a pure delay (whole samples + first-order Thiran all-pass) for what
    the section cannot reach. `delay == 0` passes samples through."""

    def __init__(self, bandwidth: float, delay: float, period: float):
        self.bypass = delay == 0.0
        self.b0 = self.a1 = self.a2 = 0.0
        self.allpass = None
        self.whole = 0
        self.zeta = self.natural = self.pure = 0.0
        self.prime(0.0)
        if self.bypass:
            return
        wb = 2.0 * math.pi * bandwidth
        half = wb * period * 0.5
        kappa = half / math.tan(half)  # the bilinear map scales the DC delay by this
        target = delay * wb / kappa
        root2 = math.sqrt(2.0)
        if target >= root2:
            zeta, natural, pure = 1.0 / root2, wb, delay - kappa * root2 / wb
        else:
            lo, hi = 0.0, 1.0 / root2
            for _ in range(80):
                mid = (lo + hi) * 0.5
                if 2.0 * mid * _bandwidth_ratio(mid) < target:
                    lo = mid
                else:
                    hi = mid
            zeta = (lo + hi) * 0.5
            natural, pure = wb / _bandwidth_ratio(zeta), 0.0
        k = wb / math.tan(half)
        k2, wn2, cross = k * k, natural * natural, 2.0 * zeta * natural * k
        a0 = k2 + cross + wn2
        self.b0 = wn2 / a0
        self.a1 = 2.0 * (wn2 - k2) / a0
        self.a2 = (k2 - cross + wn2) / a0
        samples = pure / period
        whole = math.floor(samples)
        frac = samples - whole
        self.whole = int(whole)
        if frac > 1e-12:
            self.allpass = (1.0 - frac) / (1.0 + frac)
        self.zeta, self.natural, self.pure = zeta, natural, pure
        self.prime(0.0)

    @classmethod
    def mpu6050(cls, cfg: int, sensor: str, period: float) -> "Dlpf":
        a, ad, g, gd = DLPF_TABLE[cfg]
        return cls(a, ad, period) if sensor == "accel" else cls(g, gd, period)

    def prime(self, v: float):
        self.s2 = (self.b0 - self.a2) * v
        self.s1 = (2.0 * self.b0 - self.a1) * v + self.s2
        self.ap_x = self.ap_y = v
        self.ring = [v] * max(self.whole, 1)
        self.head = 0

    def filter(self, x: float) -> float:
        if self.bypass:
            return x
        y = self.b0 * x + self.s1
        self.s1 = 2.0 * self.b0 * x - self.a1 * y + self.s2
        self.s2 = self.b0 * x - self.a2 * y
        out = y
        if self.allpass is not None:
            eta = self.allpass
            out = eta * y + self.ap_x - eta * self.ap_y
            self.ap_x, self.ap_y = y, out
        if self.whole > 0:
            delayed = self.ring[self.head]
            self.ring[self.head] = out
            self.head = (self.head + 1) % self.whole
            out = delayed
        return out


# --- IMU ----------------------------------------------------------------------------------


@dataclass
class ImuSettings:
    """SI units, as twip.Imu."""

    dlpf_hz: float = 42.0
    height: float = 0.12
    gyro_noise: float = 0.005 * DEG
    accel_noise: float = 400e-6 * STANDARD_GRAVITY
    gyro_bias: float = 0.0
    gyro_bias_walk: float = 0.0
    accel_bias: Tuple[float, float] = (0.0, 0.0)
    gyro_range_dps: float = 250.0
    accel_range_g: float = 2.0
    quantise: bool = True
    sample_rate: float = 1000.0


def specific_force(x, xdot, sin_slope, cos_slope, radius, height, g):
    """(f_x, f_z) at the sensor in its axes: acceleration of p = r theta (cos a, sin a) +
    h (sin phi, cos phi) minus gravity, projected on the body's (forward, up) axes."""
    phi, phi_dot = x[0], x[1]
    s, c = math.sin(phi), math.cos(phi)
    sin_pa = s * cos_slope + c * sin_slope
    cos_pa = c * cos_slope - s * sin_slope
    wheel = radius * xdot[3]
    return wheel * cos_pa + height * xdot[1] - g * s, wheel * sin_pa - height * phi_dot * phi_dot + g * c


class Ziggurat:
    """Standard normals by Marsaglia & Tsang's ziggurat (256 layers), two per 64-bit word:
    32 bits give the layer (8), the sign (1) and a 23-bit uniform; wedges and the tail
    draw more from the stream (a fresh word's low half per retry)."""

    R = 3.654152885361009
    V = 4.928673233974658e-3

    def __init__(self):
        f = self._gauss
        x = [0.0] * 257
        x[0] = self.V / f(self.R)
        x[1] = self.R
        for i in range(1, 255):
            x[i + 1] = math.sqrt(-2.0 * math.log(self.V / x[i] + f(x[i])))
        self.x, self.f = x, [f(v) for v in x]

    @staticmethod
    def _gauss(x):
        return math.exp(-0.5 * x * x)

    def fill(self, rng: Sfc64, n: int):
        out = []
        while len(out) < n:
            word = rng.next_u64()
            out.append(self._normal(word & 0xFFFFFFFF, rng))
            if len(out) < n:
                out.append(self._normal(word >> 32, rng))
        return out

    def _normal(self, bits, rng):
        x, f = self.x, self.f
        while True:
            i = bits & 0xFF
            sign = 1.0 if bits & 0x100 == 0 else -1.0
            z = (bits >> 9) * (1.0 / 8388608.0) * x[i]
            if z < x[i + 1]:
                return sign * z
            if i == 0:
                while True:
                    a = -math.log(1.0 - rng.uniform()) / self.R
                    b = -math.log(1.0 - rng.uniform())
                    if 2.0 * b > a * a:
                        return sign * (self.R + a)
            if f[i + 1] + rng.uniform() * (f[i] - f[i + 1]) < self._gauss(z):
                return sign * z
            bits = rng.next_u64() & 0xFFFFFFFF


NOISE_BATCH = 32  # the core draws its normals 32 at a time; the sequence is the same


_MAGIC = 1.5 / np.finfo(float).eps  # adding and removing it rounds to nearest even


def _register(v, lsb, per_lsb):
    counts = min(max(v * per_lsb, -32768.0), 32767.0)
    return ((counts + _MAGIC) - _MAGIC) * lsb


class Mpu6050:
    def __init__(self, s: ImuSettings):
        self.s = s
        period = 1.0 / s.sample_rate
        self.period = period
        cfg = dlpf_config(s.dlpf_hz)
        self.gyro_filter = Dlpf.mpu6050(cfg, "gyro", period)
        self.ax_filter = Dlpf.mpu6050(cfg, "accel", period)
        self.az_filter = Dlpf.mpu6050(cfg, "accel", period)
        band = math.sqrt(0.5 / period)
        self.sigma_gyro, self.sigma_accel = s.gyro_noise * band, s.accel_noise * band
        self.sigma_walk = s.gyro_bias_walk * math.sqrt(period)
        self.gyro_range, self.accel_range = s.gyro_range_dps * DEG, s.accel_range_g * STANDARD_GRAVITY
        self.gyro_lsb, self.accel_lsb = self.gyro_range / 32768.0, self.accel_range / 32768.0
        self.gyro_per_lsb, self.accel_per_lsb = 32768.0 / self.gyro_range, 32768.0 / self.accel_range
        self.bias = s.gyro_bias
        self.primed = False
        self.reading = (0.0, 0.0, 0.0)  # accel x, accel z, gyro
        self.gauss, self.noise = Ziggurat(), []

    def sample(self, fx, fz, rate, rng):
        if not self.noise:
            self.noise = self.gauss.fill(rng, NOISE_BATCH)
        n0, n1, n2, n3 = self.noise[:4]
        del self.noise[:4]
        s = self.s
        clean = (rate + self.bias, fx + s.accel_bias[0], fz + s.accel_bias[1])
        gr, ar = self.gyro_range, self.accel_range
        if not self.primed:
            # The filters act on the converter's output, which never leaves the range.
            self.gyro_filter.prime(min(max(clean[0], -gr), gr))
            self.ax_filter.prime(min(max(clean[1], -ar), ar))
            self.az_filter.prime(min(max(clean[2], -ar), ar))
            self.primed = True
        gyro = self.gyro_filter.filter(min(max(clean[0] + self.sigma_gyro * n0, -gr), gr))
        ax = self.ax_filter.filter(min(max(clean[1] + self.sigma_accel * n1, -ar), ar))
        az = self.az_filter.filter(min(max(clean[2] + self.sigma_accel * n2, -ar), ar))
        self.bias += self.sigma_walk * n3
        if s.quantise:
            a, ai, g, gi = self.accel_lsb, self.accel_per_lsb, self.gyro_lsb, self.gyro_per_lsb
            self.reading = (_register(ax, a, ai), _register(az, a, ai), _register(gyro, g, gi))
        else:
            self.reading = (ax, az, gyro)


# --- tilt estimators -----------------------------------------------------------------------


class TiltFilter:
    """("complementary", {"time_constant"}) or ("kalman", {"q_angle", "q_bias", "r_angle"})."""

    def __init__(self, kind: str, **params):
        self.kind, self.params = kind, params
        self.angle = self.bias = 0.0
        self.p = [[0.0, 0.0], [0.0, 0.0]]
        self.started = False

    def update(self, tilt, rate, dt):
        if not self.started:
            self.started = True
            self.angle = tilt
            if self.kind == "kalman":
                one_dps = math.pi / 180.0
                self.p = [[self.params["r_angle"], 0.0], [0.0, one_dps * one_dps]]
            return self.angle, rate - self.bias
        if self.kind == "complementary":
            tau = self.params["time_constant"]
            a = tau / (tau + dt)
            self.angle = a * (self.angle + dt * rate) + (1.0 - a) * tilt
        else:
            q_angle, q_bias, r_angle = self.params["q_angle"], self.params["q_bias"], self.params["r_angle"]
            self.angle += dt * (rate - self.bias)
            (p00, p01), (p10, p11) = self.p
            p00 = p00 - dt * (p01 + p10) + dt * dt * p11 + q_angle * dt
            p01 = p01 - dt * p11
            p10 = p10 - dt * p11
            p11 = p11 + q_bias * dt
            s = p00 + r_angle
            k0, k1 = p00 / s, p10 / s
            innovation = tilt - self.angle
            self.angle += k0 * innovation
            self.bias += k1 * innovation
            self.p = [[p00 - k0 * p00, p01 - k0 * p01], [p10 - k1 * p00, p11 - k1 * p01]]
        return self.angle, rate - self.bias


# --- encoder --------------------------------------------------------------------------------


class Encoder:
    """Counts floor(beta * cpr / 2 pi) of the wheel's angle relative to the body."""

    def __init__(self, cpr: float):
        self.counts_per_rad = cpr / (2.0 * math.pi)
        self.rad_per_count = 2.0 * math.pi / cpr
        self.last = None

    def read(self, beta, dt):
        count = math.floor(beta * self.counts_per_rad)
        speed = (count - self.last) * self.rad_per_count / dt if self.last is not None and dt > 0 else 0.0
        self.last = count
        return count * self.rad_per_count, speed


# --- motor drive ----------------------------------------------------------------------------


@dataclass
class MotorDriver:
    battery: float = 11.1
    bridge_drop: float = 0.0
    resistance: float = 12.0 / 7.0
    inductance: float = 0.0
    efficiency: float = 1.0
    current_limit: float = math.inf
    assumed_battery: Optional[float] = None


def _clamp(v, limit):
    return min(max(v, -limit), limit)


def _round_half_away(v):
    return math.copysign(math.floor(abs(v) + 0.5), v)


class Driven:
    """Per motor: V = pwm/255 (V_bat - V_drop); L di/dt = V - R i - k eta (theta' - phi');
    |i| <= limit; the plant gets the lumped current 2 eff i. With L > 0 the current is a
    state carried from step to step, and each RK4 stage ("start", "half", "end") feels the
    exact solution for the duty held and the speed linear in time from the step's start to
    the stage; the first stage weighs the decaying transient so that RK4 integrates it
    exactly (as twip-core's `Winding::stepped_current`)."""

    PWM_MAX = 255.0

    def __init__(self, plant, driver: MotorDriver, params):
        self.plant = plant
        k, eta = params.torque_constant, params.gear_ratio
        self.volts_per_count = (driver.battery - driver.bridge_drop) / self.PWM_MAX
        self.back_emf = k * eta
        self.conductance = 1.0 / driver.resistance
        self.lumped_per_amp = 2.0 * driver.efficiency
        self.limit = driver.current_limit
        self.tau = driver.inductance / driver.resistance
        # Per stage: (weight of the transient i0 - i_ss(w0), current per rad/s of the speed's change).
        self.factors = {"dt": 0.0, "start": (0.0, 0.0), "half": (0.0, 0.0), "end": (0.0, 0.0), "mean": 0.0}
        # The step under way: the current and the speed at its start, the steady current there.
        self.current = self.speed = self.steady = 0.0
        self.open_rotor = None  # the motors' speed while their gear trains are open (backlash)

    def motor_speed(self, x):
        return x[3] - x[1] if self.open_rotor is None else self.open_rotor

    def free_current(self, pwm, w):
        volts = _clamp(pwm, self.PWM_MAX) * self.volts_per_count
        return (volts - self.back_emf * w) * self.conductance

    def _prepare(self, dt):
        if self.factors["dt"] == dt:
            return
        tau, per_speed = self.tau, self.back_emf * self.conductance

        def at(s):
            decay = math.exp(-s / tau)
            return decay, per_speed * (1.0 - tau / s * (1.0 - decay))

        half, end = at(dt / 2.0), at(dt)
        mean = tau / dt * (1.0 - end[0])
        # Simpson's weights (1, 4, 1)/6 then integrate the transient e^(-s/tau) exactly.
        first = 6.0 * mean - 4.0 * half[0] - end[0]
        self.factors = {"dt": dt, "start": (first, 0.0), "half": half, "end": end, "mean": mean}

    def stepped_at(self, w, stage):
        """Inductive: the current at an RK4 stage, the motor at w there."""
        decay, follow = self.factors[stage]
        return _clamp(decay * (self.current - self.steady) + self.steady - follow * (w - self.speed), self.limit)

    def start_step_at(self, w, pwm, dt):
        """A step of dt starts at the relative wheel speed w under the duty pwm (inductive only)."""
        if self.tau <= 0:
            return
        self._prepare(dt)
        self.speed, self.steady = w, self.free_current(pwm, w)

    def end_step_at(self, w):
        """The step under way ended at the relative wheel speed w (inductive only)."""
        if self.tau > 0:
            self.current = self.stepped_at(w, "end")

    def current_at(self, w, pwm):
        """Per motor, now, at the relative wheel speed w."""
        if self.tau > 0:
            return self.current
        return _clamp(self.free_current(pwm, w), self.limit)

    def stage_current_at(self, w, pwm, stage):
        """Per motor, at an RK4 stage, at the relative wheel speed w there."""
        if self.tau > 0:
            return self.stepped_at(w, stage)
        return _clamp(self.free_current(pwm, w), self.limit)

    def mean_current_at(self, w, pwm):
        """Per motor, the mean over the step with the speed w held (an open train's rotor)."""
        if self.tau <= 0:
            return _clamp(self.free_current(pwm, w), self.limit)
        return _clamp(self.steady + (self.current - self.steady) * self.factors["mean"], self.limit)

    def start_step(self, x, pwm, dt):
        self.start_step_at(self.motor_speed(x), pwm, dt)

    def end_step(self, x):
        self.end_step_at(self.motor_speed(x))

    def motor_current(self, x, pwm):
        """Per motor, now."""
        return self.current_at(self.motor_speed(x), pwm)

    def stage_current(self, x, pwm, stage):
        """The lumped current the mechanics feel at an RK4 stage."""
        return self.lumped_per_amp * self.stage_current_at(self.motor_speed(x), pwm, stage)

    def mean_current(self, x, pwm):
        """The lumped current's mean over the step (an open train's rotor)."""
        return self.lumped_per_amp * self.mean_current_at(self.motor_speed(x), pwm)

    def deriv(self, x, pwm, stage="start"):
        return self.plant.deriv(x, self.stage_current(x, pwm, stage))


class PwmActuator:
    """The firmware's duty: V = R i + k eta w_measured, rounded, saturated."""

    def __init__(self, driver: MotorDriver, params, command_per_amp=None):
        """`command_per_amp`: 2 eff for the lumped current (default), eff eta k_t for a wheel torque."""
        assumed = driver.battery if driver.assumed_battery is None else driver.assumed_battery
        self.supply = assumed - driver.bridge_drop
        self.resistance = driver.resistance
        self.back_emf = params.torque_constant * params.gear_ratio
        self.command_per_amp = 2.0 * driver.efficiency if command_per_amp is None else command_per_amp

    def duty(self, command, w):
        volts = self.resistance * (command / self.command_per_amp) + self.back_emf * w
        return min(max(_round_half_away(volts / self.supply * 255.0), -255.0), 255.0)

    def drive(self, u, y):
        return self.duty(u, y[3] - y[1])


# --- disturbances ---------------------------------------------------------------------------


def mass_matrix(params, slope, phi):
    """The symmetric M(phi) of M q'' = f on (phi, theta)."""
    p = params
    rotor = p.gear_ratio * p.gear_ratio * p.i_motor
    m11 = p.i_body + p.m_body * p.com_height * p.com_height + rotor
    m22 = (p.m_body + p.m_wheels) * p.wheel_radius**2 + p.i_wheels + rotor
    m12 = p.m_body * p.wheel_radius * p.com_height * math.cos(phi + slope) - rotor
    return np.array([[m11, m12], [m12, m22]])


class Disturbed:
    """The slope model on a piecewise-constant slope, with a constant force (fx, fz) at
    `height` on the body and horizontal pushes (t, J, h) applied between steps."""

    def __init__(self, params, base_slope, profile=(), force=(0.0, 0.0, 0.0), pushes=(), friction=None, backlash=None):
        self.params, self.radius = params, params.wheel_radius
        self.starts = [d for d, _ in profile]
        self.slopes = [base_slope] + [a for _, a in profile]
        self.models = [SlopeModel(params, a, friction=friction) for a in self.slopes]
        self.force = force
        self.has_force = force[0] != 0.0 or force[1] != 0.0
        self.pushes = sorted(pushes, key=lambda p: p[0])
        self.next = 0
        self.play = None  # both gear trains, lumped (backlash)
        if backlash:
            m = self.models[0]
            self.play = GearPlay(backlash, m.rotor_inertia(), 2.0, m.friction, 1)

    def shaft_offset(self):
        return 0.0 if self.play is None else self.play.offset[0]

    def open_rotor_speed(self, x):
        if self.play is None or self.play.engaged()[0]:
            return None
        return self.play.motor_speeds([x[3] - x[1]])[0]

    def gear_elapsed(self, dt, x):
        if self.play is None:
            return
        (hit,) = self.play.elapsed(dt, [x[3] - x[1]])
        if hit is None:
            return
        rotor, late = hit
        current = self.play.motors()[0] / (self.params.gear_ratio * self.params.torque_constant)

        def motion(engaged):
            def f(y):
                i = self.segment(y[2] * self.radius)
                return self.models[i].deriv_geared(y, current, engaged, self._extra(i, y))[0]
            return f

        # Back to the impact along the open motion, the impact, forward from it engaged.
        x[:] = heun(x, -late, motion(False))
        self.models[self.segment(x[2] * self.radius)].engage(x, rotor)
        x[:] = heun(x, late, motion(True))
        self.play.engage(0, x[3] - x[1])

    def gear_next(self, x, current, mean):
        """`current`: the lumped current at RK4's first stage; `mean`: its mean over the step
        (what an open train's rotor is driven by)."""
        if self.play is None:
            return
        i = self.segment(x[2] * self.radius)
        model = self.models[i]
        per_amp = self.params.gear_ratio * self.params.torque_constant
        d, tau = model.deriv_geared(x, current, self.play.engaged()[0], self._extra(i, x))
        contact = per_amp * current - 2.0 * tau - self.play.inertia * (d[3] - d[1])
        self.play.next_step([x[3] - x[1]], [contact], [per_amp * mean])

    def _extra(self, i, x):
        if not self.has_force:
            return None
        fx, fz, h = self.force
        slope = self.slopes[i]
        return (h * (fx * math.cos(x[0]) - fz * math.sin(x[0])), self.radius * (fx * math.cos(slope) + fz * math.sin(slope)))

    def segment(self, distance):
        i = len(self.starts)
        while i > 0 and distance < self.starts[i - 1]:
            i -= 1
        return i

    def deriv(self, x, u, stage="start"):
        i = self.segment(x[2] * self.radius)
        engaged = True if self.play is None else self.play.engaged()[0]
        return self.models[i].deriv_geared(x, u, engaged, self._extra(i, x))[0]

    def kick(self, t, dt, x):
        while self.next < len(self.pushes) and self.pushes[self.next][0] < t + dt * 0.5:
            _, j, h = self.pushes[self.next]
            slope = self.slopes[self.segment(x[2] * self.radius)]
            q = np.array([h * j * math.cos(x[0]), self.radius * j * math.cos(slope)])
            dv = np.linalg.solve(mass_matrix(self.params, slope, x[0]), q)
            x[1] += dv[0]
            x[3] += dv[1]
            self.next += 1


# --- the loop -------------------------------------------------------------------------------


@dataclass
class Realism:
    """As twip.Realism; heights of pushes and force are explicit here."""

    imu: Optional[ImuSettings] = None
    estimator: Tuple[str, dict] = ("complementary", {"time_constant": 1.0})
    encoder_cpr: Optional[float] = None
    motor: Optional[MotorDriver] = None
    delay: bool = False
    control_period: Optional[float] = None
    pushes: Sequence[Tuple[float, float, float]] = ()
    force: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    slope_profile: Sequence[Tuple[float, float]] = ()
    friction: Optional[Friction] = None  # per wheel, on the rig's plant (None: the model's)
    backlash: Optional[float] = None  # each gear train's play at the wheel [rad]
    seed: int = 0
    stream: int = 0
    settle: Optional[float] = None  # seconds the estimator reads the IMU at rest before the run

    @classmethod
    def from_twip(cls, r, params) -> "Realism":
        """The same settings as a `twip.Realism` (reads its attributes only)."""
        com = params.com_height
        imu = None
        if r.imu is not None:
            i = r.imu
            imu = ImuSettings(i.dlpf_hz, i.height, i.gyro_noise, i.accel_noise, i.gyro_bias, i.gyro_bias_walk,
                              tuple(i.accel_bias), i.gyro_range_dps, i.accel_range_g, i.quantise, i.sample_rate)
        motor = None
        if r.motor is not None:
            m = r.motor
            motor = MotorDriver(m.battery, m.bridge_drop, m.resistance, m.inductance, m.efficiency,
                                math.inf if m.current_limit is None else m.current_limit, m.assumed_battery)
        f = r.force
        force = (0.0, 0.0, 0.0) if f is None else (f.horizontal, f.vertical, com if f.height is None else f.height)
        pushes = [(p.t, p.impulse, com if p.height is None else p.height) for p in r.pushes]
        return cls(imu, (r.estimator.kind, dict(r.estimator.parameters)), r.encoder_cpr, motor, r.delay,
                   r.control_period, pushes, force, list(r.slope_profile), Friction.of(r.friction),
                   getattr(r, "backlash", None), r.seed, r.stream, getattr(r, "settle", None))


class BalanceSensors:
    """IMU + tilt estimator + encoder; the truth for each part left out."""

    def __init__(self, realism: Realism, params, base_slope, dt):
        self.imu = Mpu6050(realism.imu) if realism.imu is not None else None
        kind, tuning = realism.estimator
        self.tilt = TiltFilter(kind, **tuning)
        self.encoder = Encoder(realism.encoder_cpr) if realism.encoder_cpr is not None else None
        self.starts = [d for d, _ in realism.slope_profile]
        self.trig = [(math.sin(a), math.cos(a)) for a in [base_slope] + [a for _, a in realism.slope_profile]]
        self.radius, self.g = params.wheel_radius, params.g
        self.next_sample, self.half_step = 0.0, dt * 0.5
        self.rng = Sfc64(realism.seed, realism.stream)
        self.last_read = None
        self.shaft = 0.0  # the motor shaft's angle minus the wheels' (backlash): the encoder counts the shaft
        self.realism, self.dt = realism, dt

    def settle(self, x0, period):
        """The estimator reads the IMU at rest at x0's pitch (the realism's `settle`)."""
        settle_at_rest(self, x0[0], self.g, period)

    def sample(self, t, x, xdot):
        if self.imu is not None and t + self.half_step >= self.next_sample:
            i = len(self.starts)
            while i > 0 and x[2] * self.radius < self.starts[i - 1]:
                i -= 1
            sin_a, cos_a = self.trig[i]
            fx, fz = specific_force(x, xdot, sin_a, cos_a, self.radius, self.imu.s.height, self.g)
            self.imu.sample(fx, fz, x[1], self.rng)
            self.next_sample += self.imu.period

    def read(self, t, x):
        dt = 0.0 if self.last_read is None else t - self.last_read
        self.last_read = t
        if self.imu is not None:
            ax, az, gyro = self.imu.reading
            phi, phi_dot = self.tilt.update(math.atan2(-ax, az), gyro, dt)
        else:
            phi, phi_dot = x[0], x[1]
        if self.encoder is not None:
            beta, beta_dot = self.encoder.read(x[2] - x[0] + self.shaft, dt)
            theta, theta_dot = beta + phi, beta_dot + phi_dot
        else:
            theta, theta_dot = x[2], x[3]
        return np.array([phi, phi_dot, theta, theta_dot])


@dataclass
class RigRun:
    t: np.ndarray
    states: np.ndarray
    inputs: np.ndarray  # the command being applied (lumped current, A)
    signals: np.ndarray  # phi_hat, phi_dot_hat, theta_hat, theta_dot_hat, drive, motor_current
    outcome: str = "completed"
    internals: List = field(default_factory=list)


def rk4_sampled(plant, sensors, t, x, u, dt):
    """One RK4 step of `plant`, its first stage shared with the sensors' sample (as the core's
    run_loop); each stage says where in the step it is (an inductive winding's current moves)."""
    half = dt * 0.5
    k1 = plant.deriv(x, u)
    sensors.sample(t, x, k1)
    k2 = plant.deriv(x + k1 * half, u, "half")
    k3 = plant.deriv(x + k2 * half, u, "half")
    k4 = plant.deriv(x + k3 * dt, u, "end")
    return x + (k1 + (k2 + k3) * 2.0 + k4) * (dt / 6.0)


def simulate(model, controller, x0, t_final, dt, reference, realism: Realism, fall_limit=math.radians(60)) -> RigRun:
    """The loop of twip-core's `simulate_rig`: per step, read/update/drive every control
    period (the command optionally one period late), log, kick the plant and start the
    winding's step, then RK4 with its first stage shared with the sensor's sample, and the
    winding's current carried to the step's end."""
    params = model.params
    period = realism.control_period if realism.control_period is not None else controller.period
    controller.period = period
    friction = realism.friction if realism.friction is not None else model.friction
    ground = Disturbed(params, model.slope, realism.slope_profile, realism.force, realism.pushes, friction,
                       realism.backlash)
    if realism.motor is not None:
        plant, actuator = Driven(ground, realism.motor, params), PwmActuator(realism.motor, params)
    else:
        plant, actuator = ground, None
    sensors = BalanceSensors(realism, params, model.slope, dt)

    def motor_current(x, u):
        return plant.lumped_per_amp * plant.motor_current(x, u) if actuator is not None else u

    n = round(t_final / dt)
    per_update = round(period / dt)
    x = np.array(x0, float)
    u = pending = command = pending_command = 0.0
    signals = [0.0] * 6
    ts, xs, us, ss, ins = [], [], [], [], []
    sensors.settle(x, dt * per_update)
    sensors.sample(0.0, x, plant.deriv(x, u))
    outcome = "completed"
    for k in range(n):
        t = k * dt
        ref = reference.sample(t)
        if k % per_update == 0:
            sensors.shaft = ground.shaft_offset()
            y = sensors.read(t, x)
            cmd = controller.update(t, y, ref)
            drive = actuator.drive(cmd, y) if actuator is not None else cmd
            if realism.delay:
                u, pending, command, pending_command = pending, drive, pending_command, cmd
            else:
                u, command = drive, cmd
            signals[:5] = [*y, u]
        signals[5] = motor_current(x, u)
        ts.append(t)
        xs.append(x.copy())
        us.append(command)
        ss.append(list(signals))
        ins.append(controller.internals)
        ground.gear_elapsed(dt, x)
        ground.kick(t, dt, x)
        if actuator is not None:
            plant.open_rotor = ground.open_rotor_speed(x)
            plant.start_step(x, u, dt)
            ground.gear_next(x, plant.stage_current(x, u, "start"), plant.mean_current(x, u))
            plant.open_rotor = ground.open_rotor_speed(x)
        else:
            ground.gear_next(x, u, u)
        x = rk4_sampled(plant, sensors, t, x, u, dt)
        if actuator is not None:
            plant.end_step(x)
        if abs(x[0]) > fall_limit:
            outcome = "fell"
            break
    signals[5] = motor_current(x, u)
    ts.append(len(ts) * dt)
    xs.append(x.copy())
    us.append(command)
    ss.append(list(signals))
    ins.append(controller.internals)
    return RigRun(np.array(ts), np.array(xs), np.array(us), np.array(ss), outcome, ins)


def settle_at_rest(sensors, phi, g, period):
    """A sensor's settle at pitch `phi` (reads every `period`), when its realism has one and
    an IMU: the estimator and the last read's time carry over."""
    r = sensors.realism
    if r.settle and r.imu is not None:
        sensors.last_read = settle(sensors.tilt, Mpu6050(r.imu), phi, g, r.settle, sensors.dt, period, r.seed, r.stream)
