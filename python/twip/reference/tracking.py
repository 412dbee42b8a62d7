"""Reference trajectory tracking (thesis 4.64-4.121, errata T1-T12), in plain Python/numpy.

Written apart from the Rust core (crates/twip-core/src/: control/{trajectory,pid,smc}.rs, hardware/motor.rs,
sim/tracking_metrics.rs) and never calling it: the trajectories by their own
formulas, the motor from the data sheet, the PID in the Arduino's units, the sliding-mode
trackers by the thesis's equations with the documented readings and guards, and a planar
closed-loop runner. Slow by design: for parity tests and for reading. One file because it is
read against one section of the thesis (4.3) and the trackers, their paths and the runner that
closes their loop are checked as one against the core.

Conventions (twip's): state [x, y, psi, phi, phi_dot, v, omega]; input [u_r, u_l], wheel
torques [N m]; u_r > u_l turns left; phi > 0 leans towards forward travel.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from twip.reference.fuzzy import GridBasis, Trapezoid
from twip.reference.real import real, reals

TWO_PI = 2.0 * math.pi


class TrackSample(NamedTuple):
    """Where the robot should be at time t and how the reference moves there."""

    x: float
    y: float
    psi: float
    v: float
    omega: float
    v_dot: float
    omega_dot: float


def _check(name: str, value: float, positive: bool = False, non_negative: bool = False) -> float:
    value = real(name, value)
    if not math.isfinite(value):
        raise ValueError(f"invalid {name} = {value}: must be finite")
    if positive and not value > 0:
        raise ValueError(f"invalid {name} = {value}: must be > 0")
    if non_negative and value < 0:
        raise ValueError(f"invalid {name} = {value}: must be >= 0")
    return value


def wrap(angle: float) -> float:
    """angle mod 2 pi in [-pi, pi)."""
    return angle - TWO_PI * math.floor((angle + math.pi) / TWO_PI)


# --- trajectories -----------------------------------------------------------------------


class Circle:
    """Constant speed round a circle. direction +1 turns left (counter-clockwise), -1 right.
    By default it starts at the origin heading along +x (centre (0, direction * radius))."""

    def __init__(self, radius, speed, centre=None, direction=1, phase=None):
        self.radius = _check("radius", radius, positive=True)
        self.speed = _check("speed", speed, positive=True)
        if isinstance(direction, (bool, np.bool_)) or direction not in (1, -1):
            raise ValueError(f"invalid direction = {direction}: must be +1 (counter-clockwise) or -1")
        self.direction = float(direction)
        if centre is None:
            centre = (0.0, self.direction * self.radius)
        self.centre = (_check("centre", centre[0]), _check("centre", centre[1]))
        self.phase = -self.direction * math.pi / 2 if phase is None else _check("phase", phase)

    @property
    def period(self) -> float:
        return TWO_PI * self.radius / self.speed

    def sample(self, t: float) -> TrackSample:
        rate = self.direction * self.speed / self.radius
        angle = self.phase + rate * t
        return TrackSample(
            self.centre[0] + self.radius * math.cos(angle),
            self.centre[1] + self.radius * math.sin(angle),
            angle + self.direction * math.pi / 2,
            self.speed,
            rate,
            0.0,
            0.0,
        )

    def distance(self, x: float, y: float) -> float:
        return abs(math.hypot(x - self.centre[0], y - self.centre[1]) - self.radius)


class Line:
    """A straight line from `start` at `heading` [rad], constant speed."""

    def __init__(self, speed, heading=0.0, start=(0.0, 0.0)):
        self.speed = _check("speed", speed, positive=True)
        self.heading = _check("heading", heading)
        self.start = (_check("start", start[0]), _check("start", start[1]))

    def sample(self, t: float) -> TrackSample:
        s = self.speed * t
        return TrackSample(self.start[0] + s * math.cos(self.heading), self.start[1] + s * math.sin(self.heading),
                           self.heading, self.speed, 0.0, 0.0, 0.0)

    def distance(self, x: float, y: float) -> float:
        dx, dy = x - self.start[0], y - self.start[1]
        return abs(-math.sin(self.heading) * dx + math.cos(self.heading) * dy)


class FigureEight:
    """The lemniscate of Gerono x = a sin(W t), y = (a/2) sin(2 W t), W = 2 pi / period, about
    `centre`: the right lobe clockwise, the left one counter-clockwise. The heading is kept on
    its one continuous branch, [-5 pi/4, pi/4]."""

    def __init__(self, half_width, period, centre=(0.0, 0.0)):
        self.a = _check("half_width", half_width, positive=True)
        self.period = _check("period", period, positive=True)
        self.centre = (_check("centre", centre[0]), _check("centre", centre[1]))

    def _derivatives(self, t):
        w = TWO_PI / self.period
        a = self.a
        s1, c1 = math.sin(w * t), math.cos(w * t)
        s2, c2 = math.sin(2 * w * t), math.cos(2 * w * t)
        pos = (a * s1, 0.5 * a * s2)
        d1 = (a * w * c1, a * w * c2)
        d2 = (-a * w * w * s1, -2 * a * w * w * s2)
        d3 = (-a * w**3 * c1, -4 * a * w**3 * c2)
        return pos, d1, d2, d3

    def sample(self, t: float) -> TrackSample:
        (px, py), (xd, yd), (xdd, ydd), (x3, y3) = self._derivatives(t)
        v2 = xd * xd + yd * yd
        v = math.sqrt(v2)
        cross = xd * ydd - yd * xdd
        dot = xd * xdd + yd * ydd
        psi = math.atan2(yd, xd)
        if psi > math.pi / 2:  # the continuous branch never visits (pi/2, pi]: it is psi - 2 pi
            psi -= TWO_PI
        omega = cross / v2
        omega_dot = (xd * y3 - yd * x3) / v2 - 2 * cross * dot / (v2 * v2)
        return TrackSample(self.centre[0] + px, self.centre[1] + py, psi, v, omega, dot / v, omega_dot)

    def distance(self, x: float, y: float) -> float:
        """Distance to the curve: a scan over 64 parameters, then Newton from each local
        minimum of the scan (the curve crosses itself)."""
        ts = [self.period * k / 64 for k in range(64)]
        d2 = []
        for t in ts:
            s = self.sample(t)
            d2.append((s.x - x) ** 2 + (s.y - y) ** 2)
        best = min(d2)
        for k, t in enumerate(ts):
            if d2[k] > d2[k - 1] or d2[k] > d2[(k + 1) % 64]:
                continue
            for _ in range(4):
                (px, py), (xd, yd), (xdd, ydd), _ = self._derivatives(t)
                ex, ey = self.centre[0] + px - x, self.centre[1] + py - y
                h = xd * xd + yd * yd + ex * xdd + ey * ydd
                if h <= 0:
                    break
                t -= (ex * xd + ey * yd) / h
            s = self.sample(t)
            best = min(best, (s.x - x) ** 2 + (s.y - y) ** 2)
        return math.sqrt(best)


MAX_WAYPOINTS = 16


class Waypoints:
    """Straight legs through the points at constant speed, each inner corner rounded by a
    circular arc of `corner_radius` (smaller where the legs are too short: the arc's tangent
    length is at most half of either leg). corner_radius = 0 gives sharp corners (the heading
    jumps). After the last point the reference stops there."""

    def __init__(self, points, speed, corner_radius=0.0):
        pts = [tuple(reals(f"points[{i}]", p)) for i, p in enumerate(points)]
        if len(pts) < 2:
            raise ValueError(f"invalid waypoints = {len(pts)}: needs at least 2 points")
        if len(pts) > MAX_WAYPOINTS:
            raise ValueError(f"invalid waypoints = {len(pts)}: at most {MAX_WAYPOINTS} points")
        for p in pts:
            for c in p:
                if not math.isfinite(c):
                    raise ValueError(f"invalid waypoints = {c}: every coordinate must be finite")
        self.speed = _check("speed", speed, positive=True)
        self.corner_radius = _check("corner_radius", corner_radius, non_negative=True)
        legs = []
        for p, q in zip(pts, pts[1:]):
            length = math.hypot(q[0] - p[0], q[1] - p[1])
            if length == 0:
                raise ValueError(f"invalid waypoints = {length}: consecutive points must differ")
            legs.append((p, q, length, math.atan2(q[1] - p[1], q[0] - p[0])))
        # Tangent length cut from each end of each leg, and the arcs' (radius, turn).
        cut_in = [0.0] * len(legs)
        cut_out = [0.0] * len(legs)
        arcs = []
        for i in range(len(legs) - 1):
            turn = wrap(legs[i + 1][3] - legs[i][3])
            half = math.tan(abs(turn) / 2)
            rho = 0.0
            if half > 0 and self.corner_radius > 0:
                rho = min(self.corner_radius, 0.5 * min(legs[i][2], legs[i + 1][2]) / half)
            cut_out[i] = cut_in[i + 1] = rho * half
            arcs.append((rho, turn))
        # Pieces: (start s, length, start x, start y, start heading, curvature).
        self.pieces = []
        s = 0.0
        for i, (p, q, length, heading) in enumerate(legs):
            c, sn = math.cos(heading), math.sin(heading)
            straight = length - cut_in[i] - cut_out[i]
            x0, y0 = p[0] + cut_in[i] * c, p[1] + cut_in[i] * sn
            self.pieces.append((s, straight, x0, y0, heading, 0.0))
            s += straight
            if i < len(arcs) and arcs[i][0] > 0:
                rho, turn = arcs[i]
                self.pieces.append((s, rho * abs(turn), x0 + straight * c, y0 + straight * sn, heading,
                                    math.copysign(1.0 / rho, turn)))
                s += rho * abs(turn)
        self.length = s

    @staticmethod
    def _at(piece, along):
        _, _, x0, y0, h0, k = piece
        if k == 0.0:
            return x0 + along * math.cos(h0), y0 + along * math.sin(h0), h0
        h = h0 + k * along
        return x0 + (math.sin(h) - math.sin(h0)) / k, y0 - (math.cos(h) - math.cos(h0)) / k, h

    def sample(self, t: float) -> TrackSample:
        s = self.speed * t
        if s >= self.length:
            last = self.pieces[-1]
            x, y, h = self._at(last, last[1])
            return TrackSample(x, y, h, 0.0, 0.0, 0.0, 0.0)
        piece = self.pieces[0]
        for p in self.pieces:
            if p[0] <= s:
                piece = p
        x, y, h = self._at(piece, max(s - piece[0], 0.0))
        return TrackSample(x, y, h, self.speed, self.speed * piece[5], 0.0, 0.0)

    def distance(self, x: float, y: float) -> float:
        best = math.inf
        for p in self.pieces:
            s0, length, x0, y0, h0, k = p
            if k == 0.0:
                c, s = math.cos(h0), math.sin(h0)
                along = min(max((x - x0) * c + (y - y0) * s, 0.0), length)
                d = math.hypot(x - x0 - along * c, y - y0 - along * s)
            else:
                cx, cy = x0 - math.sin(h0) / k, y0 + math.cos(h0) / k
                # Angle of (x, y) seen from the centre, measured along the arc's direction.
                a0 = math.atan2(y0 - cy, x0 - cx)
                a = math.atan2(y - cy, x - cx)
                swept = (a - a0) * math.copysign(1.0, k) % TWO_PI
                if swept <= abs(k) * length:
                    d = abs(math.hypot(x - cx, y - cy) - 1.0 / abs(k))
                else:
                    ex, ey, _ = self._at(p, length)
                    d = min(math.hypot(x - x0, y - y0), math.hypot(x - ex, y - ey))
            best = min(best, d)
        return best


# --- motor -----------------------------------------------------------------------------------


class DcMotor:
    """Brushed DC motor and gearbox, quasi-static (no inductance): i = (V - k_e eta w)/R,
    wheel torque eta k_t i with k_t = k_e; w is the wheel's speed relative to the body."""

    def __init__(self, resistance, k_t, gear_ratio, friction, supply, pwm_max=255.0):
        self.resistance = _check("resistance", resistance, positive=True)
        self.k_t = _check("k_t", k_t, positive=True)
        self.gear_ratio = _check("gear_ratio", gear_ratio, positive=True)
        self.friction = _check("friction", friction, non_negative=True)
        self.supply = _check("supply", supply, positive=True)
        self.pwm_max = _check("pwm_max", pwm_max, positive=True)

    @classmethod
    def from_data_sheet(cls, rated_voltage, no_load_rpm, no_load_current, stall_current, gear_ratio, supply):
        resistance = rated_voltage / stall_current
        w_motor = no_load_rpm * TWO_PI / 60.0 * gear_ratio
        k = (rated_voltage - no_load_current * resistance) / w_motor
        return cls(resistance, k, gear_ratio, k * no_load_current / w_motor, supply)

    @classmethod
    def gb37y3530(cls, supply=11.1):
        """Table 2.3: 12 V, 251 rpm and 350 mA no-load, 7 A stall, 43.7:1; three 3.7 V cells."""
        return cls.from_data_sheet(12.0, 251.0, 0.35, 7.0, 43.7, supply)

    def current(self, voltage, relative_speed):
        return (voltage - self.k_t * self.gear_ratio * relative_speed) / self.resistance

    def torque(self, voltage, relative_speed):
        return self.gear_ratio * self.k_t * self.current(voltage, relative_speed)

    def voltage_for_torque(self, torque, relative_speed):
        return torque * self.resistance / (self.gear_ratio * self.k_t) + self.k_t * self.gear_ratio * relative_speed

    def pwm_voltage(self, pwm):
        return min(max(pwm, -self.pwm_max), self.pwm_max) * self.supply / self.pwm_max

    def torque_limits(self, relative_speed):
        return self.torque(-self.supply, relative_speed), self.torque(self.supply, relative_speed)

    def torque_per_count(self):
        return self.torque(self.supply / self.pwm_max, 0.0)


def _relative_speeds(x, radius, half_track):
    """Right and left wheel speeds relative to the body [rad/s]."""
    phi_dot, v, omega = x[4], x[5], x[6]
    return (v + half_track * omega) / radius - phi_dot, (v - half_track * omega) / radius - phi_dot


# --- PID (4.64-4.70) ----------------------------------------------------------------------------


class PidTracker:
    """u_R, u_L = u_phi + u_v +- u_psi in PWM counts, in the Arduino's units (see twip's
    PidUnits); each wheel gets the motor's torque at its PWM voltage and the relative wheel
    speed measured at the update, held to the next one."""

    internal_names = ("u_phi", "u_v", "u_psi", "e_v", "e_psi", "int_v", "int_psi", "pwm_r", "pwm_l")

    def __init__(self, params, gains, units, motor=None, period=0.005):
        self.radius, self.half_track = float(params.wheel_radius), float(params.half_track)
        self.gains = dict(gains)
        self.units = dict(units)
        self.motor = motor if motor is not None else DcMotor.gb37y3530()
        self.period = _check("period", period, positive=True)
        self.reset()

    @staticmethod
    def arduino_units(params, period=0.005):
        """Pitch in degrees, speed in encoder counts (700 per wheel turn) per update, heading in
        degrees measured clockwise, integrals summed once per update."""
        deg = 180.0 / math.pi
        return dict(pitch=deg, speed=700.0 / (TWO_PI * float(params.wheel_radius)) * period, heading=-deg,
                    integral_step=1.0)

    @classmethod
    def table_4_1(cls, params, motor=None, period=0.005):
        gains = dict(kp_pitch=25.0, kd_pitch=3.0, kp_speed=-25.0, ki_speed=-0.005, kp_yaw=-8.0, ki_yaw=-0.001,
                     kd_yaw=-0.03)
        return cls(params, gains, cls.arduino_units(params, period), motor, period)

    def reset(self):
        self.int_v = self.int_psi = 0.0
        self.internals = (0.0,) * len(self.internal_names)

    def update(self, t, x, ref):
        g, u = self.gains, self.units
        u_phi = g["kp_pitch"] * u["pitch"] * x[3] + g["kd_pitch"] * u["pitch"] * x[4]
        e_v = u["speed"] * (ref.v - x[5])
        u_v = g["kp_speed"] * e_v + g["ki_speed"] * self.int_v
        e_psi = u["heading"] * wrap(ref.psi - x[2])
        u_psi = g["kp_yaw"] * e_psi + g["ki_yaw"] * self.int_psi + g["kd_yaw"] * u["heading"] * (ref.omega - x[6])
        m = self.motor
        pwm = [min(max(u_phi + u_v + s * u_psi, -m.pwm_max), m.pwm_max) for s in (1.0, -1.0)]
        speeds = _relative_speeds(x, self.radius, self.half_track)
        torque = np.array([m.torque(m.pwm_voltage(p), w) for p, w in zip(pwm, speeds)])
        self.internals = (u_phi, u_v, u_psi, e_v, e_psi, self.int_v, self.int_psi, pwm[0], pwm[1])
        self.int_v += u["integral_step"] * e_v
        self.int_psi += u["integral_step"] * e_psi
        return torque


# --- sliding mode backstepping (4.71-4.121) ----------------------------------------------------


def guarded_inverse(x: float, width: float) -> float:
    """1/x for |x| >= width, x/width^2 inside: continuous, odd, bounded by 1/width."""
    return 1.0 / x if abs(x) >= width else x / (width * width)


def guarded_inverse_slope(x: float, width: float) -> float:
    return -1.0 / (x * x) if abs(x) >= width else 1.0 / (width * width)


def switch(s: float, width: float) -> float:
    """sgn(s) for width 0, else the boundary layer sat(s / width)."""
    if width == 0.0:
        return float(np.sign(s))
    return min(max(s / width, -1.0), 1.0)


def thesis_gains(torque_unit: float) -> dict:
    """Published (4.3.2) gains; k_s3, k_s4 and g_ymax4 are torques read in units of
    `torque_unit` N m (one PWM count, see twip's errata T7); k1, k2, k3, k_phi are twip's."""
    return dict(k1=2.0, k2=2.0, k3=4.0, k_phi=2.0, r1=-25.0, r2=3.0, k_s3=-2.0 * torque_unit,
                k_s4=-1.0 * torque_unit, g_y4=1.0 * torque_unit, k_eta3=-2.0, k_eta4=-5.0, g_y3=1.0)


def _basis_sets(inner, outer):
    inf = math.inf
    return [Trapezoid(-inf, -inf, -outer, -inner), Trapezoid(-outer, -inner, inner, outer),
            Trapezoid(inner, outer, inf, inf)]


class SmcTracker:
    """Sliding-mode backstepping tracker (4.73-4.98, 4.120-4.121) and, with fuzzy=True, its
    fuzzy adaptive form (4.99-4.119). Gains in SI (torques in N m); pitch_sign -1 reads the
    pitch positive leaning backward, the convention under which the published r1, r2 work."""

    def __init__(self, model, gains, fuzzy=False, pitch_sign=-1, width=(0.02, 0.5), guards=(0.05, 0.2),
                 gamma=(0.05, 1000.0), leakage=0.0, pitch_offset=True, motor=None, period=0.005,
                 yaw_sets=None, pitch_sets=None):
        self.model = model
        p = model.params
        self.radius, self.half_track = float(p.wheel_radius), float(p.half_track)
        self.g = dict(gains)
        self.fuzzy = bool(fuzzy)
        self.pitch_sign = real("pitch_sign", pitch_sign)
        self.width_eta, self.width_s1 = reals("boundary_layer", width)
        self.eps_e3, self.eps_d = reals("guards", guards)
        self.gamma1, self.gamma2 = reals("gamma", gamma)
        self.leakage = real("leakage", leakage)
        self.pitch_offset = bool(pitch_offset)
        self.motor = motor
        self.period = real("period", period)
        self.basis1 = GridBasis(yaw_sets or [_basis_sets(0.1, 0.3), _basis_sets(0.25, 1.0)])  # (phi, omega)
        self.basis2 = GridBasis(pitch_sets or [_basis_sets(0.1, 0.3), _basis_sets(0.5, 2.0)])  # (phi, phi_dot)
        k = self.basis1.n_rules
        self.internal_names = ("s_eta", "s1", "lambda1", "lambda2", "lambda3", "lambda3_dot", "e1", "e2", "e3",
                               "c_psi", "c_y", "f1_hat", "f2_hat", "d", "phi_s") + tuple(
            f"c1_{j}" for j in range(1, k + 1)) + tuple(f"c2_{j}" for j in range(1, k + 1))
        self.reset()

    #: The names with the 3 x 3 bases (an instance's own follow its bases).
    internal_names = ("s_eta", "s1", "lambda1", "lambda2", "lambda3", "lambda3_dot", "e1", "e2", "e3",
                      "c_psi", "c_y", "f1_hat", "f2_hat", "d", "phi_s") + tuple(
        f"c1_{k}" for k in range(1, 10)) + tuple(f"c2_{k}" for k in range(1, 10))

    def reset(self):
        self.c1 = np.zeros(self.basis1.n_rules)
        self.c2 = np.zeros(self.basis2.n_rules)
        self._steady = None  # (v_r, omega_r, phi_s) last computed
        self.internals = (0.0,) * len(self.internal_names)

    def steady_pitch(self, v, omega):
        """The controller model's pitch when driving steadily at (v, omega): phi_dot = v_dot = 0
        in both rows, solved for phi by Newton from 0."""
        phi = 0.0
        for _ in range(8):
            res = self._steady_residual(phi, v, omega)
            h = 1e-7
            slope = (self._steady_residual(phi + h, v, omega) - self._steady_residual(phi - h, v, omega)) / (2 * h)
            phi -= res / slope
        return phi

    def _steady_residual(self, phi, v, omega):
        # The torque that holds v_dot = 0 leaves phi_ddot; at the steady pitch both vanish.
        x = np.array([0.0, 0.0, 0.0, phi, 0.0, v, omega])
        f = self.model.deriv(x, np.zeros(2))
        m = self.model.mass_matrix(phi)
        g = np.linalg.solve(m[:2, :2], np.array([-1.0, 1.0 / self.radius]))
        return f[4] - g[0] * f[5] / g[1]

    def update(self, t, x, ref):
        g = self.g
        k1, k2, k3 = g["k1"], g["k2"], g["k3"]
        X, Y, psi, phi, phi_dot, v, omega = (float(c) for c in x)
        # Kinematic errors (4.73), (4.75), (4.76).
        dx, dy = ref.x - X, ref.y - Y
        e1 = math.cos(psi) * dx + math.sin(psi) * dy
        e2 = -math.sin(psi) * dx + math.cos(psi) * dy
        e3 = wrap(ref.psi - psi)
        s3, c3 = math.sin(e3), math.cos(e3)
        e1d = omega * e2 - v + ref.v * c3
        e2d = -omega * e1 + ref.v * s3
        e3d = ref.omega - omega
        # Virtual controls (4.74), (4.81), (4.82) with the guards, and their derivatives.
        phi_s = 0.0
        if self.pitch_offset:
            if self._steady is None or self._steady[:2] != (ref.v, ref.omega):
                self._steady = (ref.v, ref.omega, self.steady_pitch(ref.v, ref.omega))
            phi_s = self._steady[2]
        lam1 = -g["k_phi"] * (phi - phi_s)
        lam1_dot = -g["k_phi"] * phi_dot
        lam2 = ref.v * c3 + k1 * e1
        lam2_dot = ref.v_dot * c3 - ref.v * s3 * e3d + k1 * e1d
        eb = e3 + k3 * e2  # (4.77)
        ebd = e3d + k3 * e2d
        q, qd = guarded_inverse(eb, self.eps_e3), guarded_inverse_slope(eb, self.eps_e3) * ebd
        n = k2 * eb + e2 * ref.v * s3 * q + k3 * ref.v * s3 + ref.omega
        nd = (k2 * ebd + (e2d * ref.v * s3 + e2 * ref.v_dot * s3 + e2 * ref.v * c3 * e3d) * q + e2 * ref.v * s3 * qd
              + k3 * (ref.v_dot * s3 + ref.v * c3 * e3d) + ref.omega_dot)
        den = 1.0 + k3 * e1
        r = guarded_inverse(den, self.eps_d)
        lam3 = n * r
        lam3_dot = nd * r + n * guarded_inverse_slope(den, self.eps_d) * k3 * e1d
        # The controller model's g2 (4.72).
        m = self.model.mass_matrix(phi)
        g21, g22 = np.linalg.solve(m[:2, :2], np.array([-1.0, 1.0 / self.radius]))
        g23 = self.half_track / self.radius / m[2, 2]
        # Sliding surfaces (4.85), (4.92), (4.94); r1 acts on the controller's own pitch.
        r1, r2 = self.pitch_sign * g["r1"], g["r2"]
        s_eta = omega - lam3
        s1 = r1 * (phi_dot - lam1) + r2 * (v - lam2)
        d = r1 * g21 + r2 * g22
        sw_eta, sw1 = switch(s_eta, self.width_eta), switch(s1, self.width_s1)
        if self.fuzzy:
            xi1 = self.basis1.eval([phi, omega])
            xi2 = self.basis2.eval([phi, phi_dot])
            f1, f2 = float(self.c1 @ xi1), float(self.c2 @ xi2)
        else:
            f = self.model.deriv(np.asarray(x, float), np.zeros(2))  # f2 of (4.72)
            f1 = f[6]
            f2 = (r1 * f[4] + r2 * f[5] - r1 * lam1_dot - r2 * lam2_dot) / d
        # (4.106) with the published signs read as (4.115)'s (errata T5), and (4.115).
        c_y = (lam3_dot - f1 - (g["g_y3"] - g["k_eta3"]) * sw_eta + g["k_eta4"] * s_eta) / g23
        c_psi = -f2 - (g["k_s3"] - g["g_y4"]) * sw1 - g["k_s4"] * s1
        u = np.array([0.5 * c_psi + 0.5 * c_y, 0.5 * c_psi - 0.5 * c_y])
        if self.motor is not None:
            for i, w in enumerate(_relative_speeds(x, self.radius, self.half_track)):
                lo, hi = self.motor.torque_limits(w)
                u[i] = min(max(u[i], lo), hi)
        self.internals = (s_eta, s1, lam1, lam2, lam3, lam3_dot, e1, e2, e3, c_psi, c_y, f1, f2, d, phi_s,
                          *self.c1, *self.c2)
        if self.fuzzy:
            # (4.107), (4.116) by forward Euler, with optional leakage.
            self.c1 = self.c1 + self.period * (s_eta * xi1 / self.gamma1 - self.leakage * self.c1)
            self.c2 = self.c2 + self.period * (xi2 * s1 * d / self.gamma2 - self.leakage * self.c2)
        return u


# --- runner and metrics ------------------------------------------------------------------------------


def simulate_planar(model, controller, x0, t_final, dt, reference, fall_limit=math.radians(60)):
    """Plain loop: controller every period (zero-order hold), RK4 in between.
    Returns (t, states, inputs, internals), one row per step plus the final state."""
    from twip.reference.integrate import rk4_step

    n = round(t_final / dt)
    per_update = round(controller.period / dt)
    x, u = np.array(x0, float), np.zeros(2)
    ts, xs, us, ins = [], [], [], []
    for k in range(n):
        t = k * dt
        if k % per_update == 0:
            u = np.asarray(controller.update(t, x, reference.sample(t)), float)
        ts.append(t)
        xs.append(x)
        us.append(u)
        ins.append(controller.internals)
        x = rk4_step(model, x, u, dt)
        if abs(x[3]) > fall_limit:
            break
    ts.append(len(ts) * dt)
    xs.append(x)
    us.append(u)
    ins.append(controller.internals)
    return np.array(ts), np.array(xs), np.array(us), np.array(ins)


def tracking_errors(t, states, reference, settle):
    """Mean |x - x_r| and |y - y_r| overall and for t >= settle, max distance to the path for
    t >= settle."""
    refs = np.array([reference.sample(tk)[:2] for tk in t])
    ex, ey = np.abs(states[:, 0] - refs[:, 0]), np.abs(states[:, 1] - refs[:, 1])
    late = t >= settle
    path = [reference.distance(px, py) for px, py in states[late, :2]]
    return dict(mean_abs_x_error=ex.mean(), mean_abs_y_error=ey.mean(), mean_abs_x_error_settled=ex[late].mean(),
                mean_abs_y_error_settled=ey[late].mean(), max_path_error_settled=max(path))


def surface_zero_dynamics(model, gains, pitch_sign=-1, speed=math.pi / 30, h=1e-6):
    """Eigenvalues of what is left of (phi, phi_dot, v, e1) once S1 = 0 is held (the
    equivalent control), driving straight at `speed`, linearised at the model's steady state.

    S1 = r1 (phi_dot + k_phi (phi - phi_s)) + r2 (v - v_r - k1 e1) with e1_dot = v_r - v;
    holding S1 at 0 with reaching rate 1 leaves one eigenvalue at -1 (dropped) and three
    that are the zero dynamics: S1 = 0 is a good surface only if they are in the left half-plane.
    """
    tracker = SmcTracker(model, gains, pitch_sign=pitch_sign, pitch_offset=True)
    phi_s = tracker.steady_pitch(speed, 0.0)
    x_s = np.array([0.0, 0.0, 0.0, phi_s, 0.0, speed, 0.0])
    acc = model.deriv(x_s, np.zeros(2))
    m = model.mass_matrix(phi_s)
    g = np.linalg.solve(m[:2, :2], np.array([-1.0, 1.0 / tracker.radius]))
    u_s = -acc[5] / g[1]  # the C_psi that holds the steady state
    rows = [3, 4, 5]

    def f(z, c_psi):
        x = x_s.copy()
        x[rows] = z
        return model.deriv(x, np.array([c_psi / 2, c_psi / 2]))[rows]

    z0 = x_s[rows]
    A = np.zeros((4, 4))
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        A[:3, i] = (f(z0 + e, u_s) - f(z0 - e, u_s)) / (2 * h)
    A[3, 2] = -1.0  # e1_dot = v_r - v
    B = np.zeros(4)
    B[:3] = (f(z0, u_s + h) - f(z0, u_s - h)) / (2 * h)
    r1 = pitch_sign * gains["r1"]
    c = np.array([r1 * gains["k_phi"], r1, gains["r2"], -gains["r2"] * gains["k1"]])
    closed = A - np.outer(B, c @ A + c) / (c @ B)
    eig = np.linalg.eigvals(closed)
    return np.delete(eig, np.argmin(np.abs(eig + 1.0)))
