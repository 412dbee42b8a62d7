"""Reference 3-DOF planar model, built body by body with Kane's method.

The Rust core hand-writes the closed form of the Lagrange–d'Alembert equations
(crates/twip-core/src/model/planar.rs). This reference gets the same equations by another
route, so that agreement between the two is evidence for both: every rigid body's velocity
and angular velocity are written as linear maps ("partial velocities") of the
quasi-velocities nu = (phi_dot, v, omega), and Kane's equations

    sum_i  J_i^T (F_i - m_i a_i)  +  W_i^T (tau_i - I_i alpha_i - w_i x I_i w_i)  +  Q  =  0

are assembled numerically at each call. Vectors are in the yaw frame (e_f forward, e_l to
the left, e_z up), which turns at omega about e_z; the body's rotation is in body axes.

State [x, y, psi, phi, phi_dot, v, omega]; input [u_r, u_l], the motor torques [N m] on
the wheels (the body feels the reaction). Per side: wheel mass M_w/2, spin inertia I_w/2,
diametral inertia I_wd, rotor eta^2 I_M/2 on the relative angle theta_side - phi, bearing
friction mu_s/2 on theta_side_dot - phi_dot and ground friction mu_g/2 on theta_side_dot.

On a terrain (twip.reference.terrain) the same equations hold in the frame of the ground's
local plane at the contact point, which is inertial on a plane: the yaw frame is then
(d, a, n) with n the ground's normal, the pitch phi' is from n, and gravity has components
along d and a too (every body's weight enters Kane's sum, the wheels' included). The state
keeps phi from the most vertical direction perpendicular to the axle: phi' = phi + delta,
delta and its derivatives along the heading from 3-D vectors (terrain.frame).
"""
from __future__ import annotations

import math

import numpy as np

from twip.reference.friction import Friction
from twip.reference.params import RobotParams
from twip.reference import terrain as _terrain


def _cross(a, b) -> np.ndarray:
    """a x b for 3-vectors (np.cross is slow on tiny arrays)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


class PlanarModel:
    """The 3-DOF planar model on flat ground (pure numpy, slow, for cross-checks)."""

    def __init__(self, params, friction=None, terrain=None):
        self.params = RobotParams.of(params)
        self.terrain = terrain  # a twip.reference.terrain.Terrain, or None: flat ground
        self.friction = Friction.of(friction)  # per wheel, on theta_side_dot - phi_dot
        p = self.params
        R, b = p.wheel_radius, p.half_track
        self._inertia_body = np.diag([p.i_body_roll, p.i_body, p.i_body_yaw])
        # d(theta_side_dot)/d(nu) and d(theta_side_dot - phi_dot)/d(nu), right then left.
        self._spin = [np.array([0.0, 1.0 / R, b / R]), np.array([0.0, 1.0 / R, -b / R])]
        self._rel = [s - np.array([1.0, 0.0, 0.0]) for s in self._spin]
        # Wheels: partial velocities of the centre (at axle + side b e_l, velocity
        # (v - side b omega) e_f) and of the angular velocity (0, theta_side_dot, omega), all
        # constant; the wheel's inertia diag(I_wd, I_wa, I_wd) is constant in the yaw frame.
        inertia = np.diag([p.i_wheel_diam, p.i_wheels / 2, p.i_wheel_diam])
        self._wheels = []
        for side, spin in ((-1.0, self._spin[0]), (1.0, self._spin[1])):
            J = np.array([[0.0, 1.0, -side * b], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
            W = np.vstack([np.zeros(3), spin, [0.0, 0.0, 1.0]])
            self._wheels.append((J, W, inertia))

    # --- kinematics -----------------------------------------------------------------
    def _body(self, phi: float, nu: np.ndarray):
        """Body COM: velocity partials J, acceleration bias a0 (a = J nu_dot + a0);
        angular velocity partials W (body axes) and angular acceleration bias al0."""
        cz = self.params.com_height
        s, c = math.sin(phi), math.cos(phi)
        phi_dot, v, omega = nu
        # r_G = axle + cz (s e_f + c e_z); v_G = (v + cz c phi_dot, cz s omega, -cz s phi_dot)
        J = np.array([[cz * c, 1.0, 0.0], [0.0, 0.0, cz * s], [-cz * s, 0.0, 0.0]])
        vel = J @ nu
        # d/dt of the components at fixed nu, plus (omega e_z) x v_G for the turning frame.
        a0 = np.array([-cz * s * phi_dot**2, cz * c * phi_dot * omega, -cz * c * phi_dot**2])
        a0 += _cross((0.0, 0.0, omega), vel)
        # Angular velocity in body axes: (-omega s, phi_dot, omega c).
        W = np.array([[0.0, 0.0, -s], [1.0, 0.0, 0.0], [0.0, 0.0, c]])
        al0 = np.array([-omega * c * phi_dot, 0.0, -omega * s * phi_dot])
        return J, a0, W, al0

    # --- equations of motion ----------------------------------------------------------
    def _kane(self, x, u, engaged=(True, True), up=(0.0, 0.0, 1.0)):
        """Returns (M, f) with M nu_dot = f; a wheel not `engaged` (its gear train open, backlash)
        has neither its rotor nor its motor's torque. `up`: the vertical in the yaw frame (on
        terrain, the frame of the ground plane), x[3:] the pitch from its normal and rates."""
        p = self.params
        up = np.asarray(up, dtype=float)
        phi = float(x[3])
        nu = np.array([float(x[4]), float(x[5]), float(x[6])])
        u = np.asarray(u, dtype=float).reshape(2)
        Omega = (0.0, 0.0, nu[2])  # the yaw frame's angular velocity
        # Body: weight, inertial force and Euler's torque I alpha + w x I w.
        J, a0, W, al0 = self._body(phi, nu)
        I_b = self._inertia_body
        w = W @ nu
        M = p.m_body * J.T @ J + W.T @ I_b @ W
        f = J.T @ (-p.m_body * p.g * up - p.m_body * a0) - W.T @ (I_b @ al0 + _cross(w, I_b @ w))
        # Wheels (their weight does no work on flat ground): a = J nu_dot + Omega x v,
        # dH/dt = I W nu_dot + Omega x (I w).
        m_w = p.m_wheels / 2
        for Jw, Ww, Iw in self._wheels:
            M += m_w * Jw.T @ Jw + Ww.T @ Iw @ Ww
            f -= m_w * Jw.T @ (_cross(Omega, Jw @ nu) + p.g * up) + Ww.T @ _cross(Omega, Iw @ (Ww @ nu))
        # Rotors: kinetic energy 1/2 eta^2 (I_M/2) (theta_side_dot - phi_dot)^2.
        rotor = self.rotor_per_wheel()
        for rel, on in zip(self._rel, engaged):
            if on:
                M += rotor * np.outer(rel, rel)
        # Motor torques (power u_side (theta_side_dot - phi_dot)) and Rayleigh friction.
        for u_side, rel, spin, on in zip(u, self._rel, self._spin, engaged):
            f += ((u_side if on else 0.0) - (p.mu_bearing / 2) * (rel @ nu)) * rel - (p.mu_ground / 2) * (spin @ nu) * spin
        return M, f

    def rotor_per_wheel(self) -> float:
        return self.params.gear_ratio**2 * self.params.i_motor / 2

    def _gearhead(self, M, f, nu, engaged=(True, True)):
        """f with each engaged wheel's gearhead friction torque tau_i along -rel_i (w_dot = a0 -
        S tau over those wheels), and the torques (0 on an open wheel)."""
        on = [i for i, e in enumerate(engaged) if e]
        tau = np.zeros(2)
        if not on:
            return f, tau
        R = np.array(self._rel)[on]
        tau[on] = self.friction.torques(R @ nu, R @ np.linalg.solve(M, f), R @ np.linalg.solve(M, R.T))
        return f - R.T @ tau[on], tau

    def mass_matrix(self, phi: float) -> np.ndarray:
        """M(phi) of M nu_dot + h = B u, nu = (phi_dot, v, omega)."""
        M, _ = self._kane(np.array([0.0, 0.0, 0.0, phi, 0.0, 0.0, 0.0]), np.zeros(2))
        return M

    def deriv(self, x, u, extra=None) -> np.ndarray:
        """`extra`: generalised forces (q_phi, q_v) of a force on the body, added to f."""
        return self.deriv_geared(x, u, (True, True), extra)[0]

    def deriv_geared(self, x, u, engaged, extra=None):
        """(derivative, each wheel's gearhead friction torque); a wheel not `engaged` has its
        gear train open (backlash): no motor torque, no friction, no rotor."""
        x = np.asarray(x, dtype=float)
        if x.shape != (7,) or np.asarray(u).size != 2:
            raise ValueError("x must have 7 entries and u 2")
        if self.terrain is not None:
            out = self._on_terrain(x, u, engaged, extra)
            return out[0], out[5]
        M, f = self._kane(x, u, engaged)
        if extra is not None:
            f[0] += extra[0]
            f[1] += extra[1]
        tau = np.zeros(2)
        if self.friction is not None:
            f, tau = self._gearhead(M, f, x[4:], engaged)
        nu_dot = np.linalg.solve(M, f)
        psi, v = x[2], x[5]
        return np.array([v * math.cos(psi), v * math.sin(psi), x[6], x[4], *nu_dot]), tau

    # --- on terrain ---------------------------------------------------------------------
    def _ground(self, x):
        """The yaw frame on the ground plane at the contact point, delta and its derivatives
        along the heading in the plane, the height and the vertical in the yaw frame."""
        h, gx, gy = self.terrain.local(float(x[0]), float(x[1]))
        n, d, a, _ = _terrain.frame(gx, gy, float(x[2]))
        delta, d1, d2 = _terrain.delta_of_chi(gx, gy, float(x[2]))
        return n, d, a, (delta, d1, d2), h, np.array([d[2], a[2], n[2]])

    def in_plane(self, x):
        """The state in the ground plane's frame: phi' = phi + delta, phi_dot' = phi_dot + delta' omega."""
        _, _, _, (delta, d1, _), _, _ = self._ground(x)
        xp = np.array(x, dtype=float)
        xp[3] += delta
        xp[4] += d1 * x[6]
        return xp

    def _on_terrain(self, x, u, engaged=(True, True), extra=None):
        """(derivative, nu_dot' in the plane frame, plane-frame state, up, frame, gearhead
        torques); `engaged` and `extra` (forces on (phi', v)) as `deriv_geared`'s."""
        n, d, a, (delta, d1, d2), _, up = self._ground(x)
        xp = self.in_plane(x)
        M, f = self._kane(xp, u, engaged, up=up)
        if extra is not None:
            f[0] += extra[0]
            f[1] += extra[1]
        tau = np.zeros(2)
        if self.friction is not None:
            f, tau = self._gearhead(M, f, xp[4:], engaged)
        nu_dot = np.linalg.solve(M, f)
        v, omega = x[5], x[6]
        # The travel direction d turns at omega about n: d_dot = omega a; psi = atan2(d_y, d_x).
        psi_dot = omega * (d[0] * a[1] - d[1] * a[0]) / (d[0] ** 2 + d[1] ** 2)
        phi_dd = nu_dot[0] - d1 * nu_dot[2] - d2 * omega**2
        deriv = np.array([v * d[0], v * d[1], psi_dot, x[4], phi_dd, nu_dot[1], nu_dot[2]])
        return deriv, nu_dot, xp, up, (n, d, a), tau

    def normal_forces(self, x, u):
        """(N_r, N_l) [N] by Newton-Euler on the whole robot about the contact midpoint, from
        Kane's accelerations: N_r + N_l = n . sum m (a - g), and b (N_l - N_r) = d . [sum
        (r - P) x m (a - g) + dH/dt]. On flat ground when there is no terrain."""
        p = self.params
        if self.terrain is None:
            up = np.array([0.0, 0.0, 1.0])
            xp = np.asarray(x, dtype=float)
            M, f = self._kane(xp, u)
            nu_dot = np.linalg.solve(M, f)
        else:
            _, nu_dot, xp, up, _, _ = self._on_terrain(x, u)
        phi, nu = float(xp[3]), xp[4:7]
        cz, R, b = p.com_height, p.wheel_radius, p.half_track
        s, c = math.sin(phi), math.cos(phi)
        force = np.zeros(3)
        moment = np.zeros(3)
        # Body: a = J nu_dot + a0 (yaw frame), dH/dt = I alpha + w x I w in body axes.
        J, a0, W, al0 = self._body(phi, nu)
        acc = J @ nu_dot + a0 + p.g * up
        r = np.array([cz * s, 0.0, R + cz * c])
        force += p.m_body * acc
        w = W @ nu
        I_b = self._inertia_body
        dh_body = I_b @ (W @ nu_dot + al0) + _cross(w, I_b @ w)
        # Body axes (e1 = c d - s n, e2 = a, e3 = s d + c n) to the yaw frame.
        to_yaw = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
        moment += _cross(r, p.m_body * acc) + to_yaw @ dh_body
        Omega = np.array([0.0, 0.0, nu[2]])
        for side, (Jw, Ww, Iw) in zip((-1.0, 1.0), self._wheels):
            acc = Jw @ nu_dot + _cross(Omega, Jw @ nu) + p.g * up
            r = np.array([0.0, side * b, R])
            force += p.m_wheels / 2 * acc
            moment += _cross(r, p.m_wheels / 2 * acc) + Iw @ (Ww @ nu_dot) + _cross(Omega, Iw @ (Ww @ nu))
        total, diff = force[2], moment[0] / b
        return (total - diff) / 2, (total + diff) / 2

    def engage(self, x, wheel: int, rotor_speed: float, engaged) -> float:
        """The plastic impact of wheel `wheel`'s rotor on its flank (the trains `engaged` as
        before it): one impulse along its row against the masses without the open rotors.
        Updates x's rates in place; returns the common speed. On terrain in the plane's frame
        (the rates phi_dot', v, omega), written back."""
        if self.terrain is not None:
            xp = self.in_plane(x)
            flat = PlanarModel(self.params, friction=self.friction)
            speed = flat.engage(xp, wheel, rotor_speed, engaged)
            x[4:] = xp[4:] - np.array([self._ground(x)[3][1] * xp[6], 0.0, 0.0])
            return speed
        M, _ = self._kane(np.asarray(x, float), np.zeros(2), engaged)
        rel = np.asarray(self._rel[wheel])
        resp = np.linalg.solve(M, rel)
        j = self.rotor_per_wheel()
        impulse = (rotor_speed - rel @ x[4:]) / (rel @ resp + 1.0 / j)
        x[4:] += resp * impulse
        return rotor_speed - impulse / j

    def energy(self, x) -> float:
        """Kinetic energy of every body plus the body's potential M_b g c_z cos(phi). On
        terrain: the potential of every body's centre from its height, less the flat
        model's axle height R (the flat model's zero)."""
        p = self.params
        x = np.asarray(x, dtype=float)
        if self.terrain is not None:
            n, d, a, (delta, d1, _), h, _ = self._ground(x)
            xp = x.copy()
            xp[3] += delta
            xp[4] += d1 * x[6]
            flat = PlanarModel(self.params).energy(xp) - p.m_body * p.g * p.com_height * math.cos(xp[3])
            axle = h + p.wheel_radius * n[2]
            body = axle + p.com_height * (math.cos(xp[3]) * n[2] + math.sin(xp[3]) * d[2])
            wheels = sum(axle + side * p.half_track * a[2] for side in (-1.0, 1.0))
            R = p.wheel_radius
            return flat + p.g * (p.m_body * (body - R) + p.m_wheels / 2 * (wheels - 2 * R))
        phi = float(x[3])
        nu = x[4:7]
        J, _, W, _ = self._body(phi, nu)
        vel, w = J @ nu, W @ nu
        kinetic = 0.5 * p.m_body * vel @ vel + 0.5 * w @ self._inertia_body @ w
        for Jw, Ww, Iw in self._wheels:
            kinetic += 0.5 * (p.m_wheels / 2) * (Jw @ nu) @ (Jw @ nu) + 0.5 * (Ww @ nu) @ Iw @ (Ww @ nu)
        for rel in self._rel:
            kinetic += 0.5 * p.gear_ratio**2 * (p.i_motor / 2) * (rel @ nu) ** 2
        return kinetic + p.m_body * p.g * p.com_height * math.cos(phi)
