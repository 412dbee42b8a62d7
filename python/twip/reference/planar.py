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
"""
from __future__ import annotations

import math

import numpy as np

from twip.reference.friction import Friction
from twip.reference.params import RobotParams


def _cross(a, b) -> np.ndarray:
    """a x b for 3-vectors (np.cross is slow on tiny arrays)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


class PlanarModel:
    """The 3-DOF planar model on flat ground (pure numpy, slow, for cross-checks)."""

    def __init__(self, params, friction=None):
        self.params = RobotParams.of(params)
        self.friction = Friction.of(friction)  # per wheel, on theta_side_dot - phi_dot
        p = self.params
        R, b = p.wheel_radius, p.half_track
        self._inertia_body = np.diag([p.i_body_roll, p.i_body, p.i_body_yaw])
        self._weight = np.array([0.0, 0.0, -p.m_body * p.g])
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
    def _kane(self, x, u, engaged=(True, True)):
        """Returns (M, f) with M nu_dot = f; a wheel not `engaged` (its gear train open, backlash)
        has neither its rotor nor its motor's torque."""
        p = self.params
        phi = float(x[3])
        nu = np.array([float(x[4]), float(x[5]), float(x[6])])
        u = np.asarray(u, dtype=float).reshape(2)
        Omega = (0.0, 0.0, nu[2])  # the yaw frame's angular velocity
        # Body: weight, inertial force and Euler's torque I alpha + w x I w.
        J, a0, W, al0 = self._body(phi, nu)
        I_b = self._inertia_body
        w = W @ nu
        M = p.m_body * J.T @ J + W.T @ I_b @ W
        f = J.T @ (self._weight - p.m_body * a0) - W.T @ (I_b @ al0 + _cross(w, I_b @ w))
        # Wheels (their weight does no work on flat ground): a = J nu_dot + Omega x v,
        # dH/dt = I W nu_dot + Omega x (I w).
        m_w = p.m_wheels / 2
        for Jw, Ww, Iw in self._wheels:
            M += m_w * Jw.T @ Jw + Ww.T @ Iw @ Ww
            f -= m_w * Jw.T @ _cross(Omega, Jw @ nu) + Ww.T @ _cross(Omega, Iw @ (Ww @ nu))
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

    def engage(self, x, wheel: int, rotor_speed: float, engaged) -> float:
        """The plastic impact of wheel `wheel`'s rotor on its flank (the trains `engaged` as
        before it): one impulse along its row against the masses without the open rotors.
        Updates x's rates in place; returns the common speed."""
        M, _ = self._kane(np.asarray(x, float), np.zeros(2), engaged)
        rel = np.asarray(self._rel[wheel])
        resp = np.linalg.solve(M, rel)
        j = self.rotor_per_wheel()
        impulse = (rotor_speed - rel @ x[4:]) / (rel @ resp + 1.0 / j)
        x[4:] += resp * impulse
        return rotor_speed - impulse / j

    def energy(self, x) -> float:
        """Kinetic energy of every body plus the body's potential M_b g c_z cos(phi)."""
        p = self.params
        x = np.asarray(x, dtype=float)
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
