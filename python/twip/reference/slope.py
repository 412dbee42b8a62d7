"""Reference 2-DOF slope model, in the thesis's own arrangement (errata applied).

The rows are the pitch equation (3.20) and the sum of both Lagrange equations (3.21),
with the corrections of docs/errata.md: no Coriolis term in (3.20), and the body's
slope potential M_b g r theta sin(alpha) (not M_b g l r ...). Solved with numpy; the Rust
core uses the symmetric mass-matrix form instead, so the two are independent.
"""
from __future__ import annotations

import math

import numpy as np

from twip.reference.friction import Friction
from twip.reference.params import RobotParams
from twip.reference.real import real


class SlopeModel:
    """State [phi, phi_dot, theta, theta_dot]; input: lumped motor current u [A]."""

    def __init__(self, params, slope: float = 0.0, friction=None):
        self.params = RobotParams.of(params)
        # Gearhead friction per wheel (None: the thesis's model); both wheels turn at beta_dot.
        self.friction = Friction.of(friction)
        slope = real("slope", slope)
        if not math.isfinite(slope) or abs(slope) >= math.pi / 2:
            raise ValueError(f"invalid slope = {slope}: must be within (-pi/2, pi/2) rad")
        self.slope = slope

    def mass_matrix(self, phi: float):
        """The 2x2 matrix of (3.20)/(3.21) (called a_ij in (4.34))."""
        p = self.params
        Mb, Mw, l, r = p.m_body, p.m_wheels, p.com_height, p.wheel_radius
        rotor = p.gear_ratio**2 * p.i_motor
        cpa = math.cos(phi + self.slope)
        return np.array(
            [
                [rotor + Mb * l**2 + p.i_body, Mb * l * r * cpa - rotor],
                [Mb * l**2 + Mb * r * l * cpa + p.i_body, (Mb + Mw) * r**2 + Mb * r * l * cpa + p.i_wheels],
            ]
        )

    def deriv(self, x, u, extra=None) -> np.ndarray:
        """`extra`: generalised forces (q_phi, q_theta) on the body and wheels (a force on the
        body), added before the gearhead friction is found (a held wheel holds against them)."""
        return self.deriv_geared(x, u, True, extra)[0]

    def deriv_geared(self, x, u, engaged: bool, extra=None):
        """(derivative, gearhead friction torque per wheel). With the gear trains open
        (backlash, not `engaged`) the wheels get neither the motors' torque nor the friction
        and the rotors' inertia eta^2 I_M leaves them."""
        p = self.params
        phi, phi_dot, _theta, theta_dot = (float(v) for v in x)
        u = float(np.asarray(u, dtype=float).reshape(-1)[0]) if engaged else 0.0
        Mb, Mw, l, r, g, a = p.m_body, p.m_wheels, p.com_height, p.wheel_radius, p.g, self.slope
        # (3.20) corrected: a11 phi'' + a12 theta'' - Mb g l sin(phi) - mu_s (theta' - phi') = -eta tau u
        rhs1 = Mb * g * l * math.sin(phi) + p.mu_bearing * (theta_dot - phi_dot) - p.gear_ratio * p.torque_constant * u
        # (3.21) corrected: ... - Mb r l sin(phi+a) phi'^2 + (Mw + Mb) g r sin(a) - Mb g l sin(phi) + mu_g theta' = 0
        rhs2 = (
            Mb * r * l * math.sin(phi + a) * phi_dot**2
            - (Mw + Mb) * g * r * math.sin(a)
            + Mb * g * l * math.sin(phi)
            - p.mu_ground * theta_dot
        )
        if extra is not None:  # row 2 is the sum of Lagrange's two rows
            rhs1 += extra[0]
            rhs2 += extra[0] + extra[1]
        M = self.mass_matrix(phi) if engaged else self._rotorless(phi)
        qdd = np.linalg.solve(M, np.array([rhs1, rhs2]))
        tau = 0.0
        if self.friction is not None and engaged:
            # Both wheels' torque 2 tau adds to rhs1 (the summed row (3.21) cancels it).
            r = 2 * np.linalg.solve(M, np.array([1.0, 0.0]))
            beta_dot = theta_dot - phi_dot
            (tau,) = self.friction.torques([beta_dot], [qdd[1] - qdd[0]], [[r[0] - r[1]]])
            qdd = qdd + tau * r
        phi_dd, theta_dd = qdd
        return np.array([phi_dot, phi_dd, theta_dot, theta_dd]), float(tau)

    def rotor_inertia(self) -> float:
        return self.params.gear_ratio**2 * self.params.i_motor

    def _rotorless(self, phi):
        """The mass matrix without the rotors (their terms sit in row 1; row 2 sums them away)."""
        M = self.mass_matrix(phi)
        rotor = self.rotor_inertia()
        M[0, 0] -= rotor
        M[0, 1] += rotor
        return M

    def engage(self, x, rotor_speed: float) -> float:
        """The plastic impact of the open trains' rotors on the wheels' flanks: one impulse P
        on beta against the rotorless masses (-P on row 1; the summed row 2 gets none). Updates
        x's rates in place; returns the common speed."""
        M = self._rotorless(float(x[0]))
        resp = np.linalg.solve(M, np.array([-1.0, 0.0]))
        j = self.rotor_inertia()
        impulse = (rotor_speed - (x[3] - x[1])) / ((resp[1] - resp[0]) + 1.0 / j)
        x[1] += resp[0] * impulse
        x[3] += resp[1] * impulse
        return rotor_speed - impulse / j

    def energy(self, x) -> float:
        """T of (3.1) (with beta = theta - phi) plus the corrected potential (3.2)+(3.3)."""
        p = self.params
        phi, phi_dot, theta, theta_dot = (float(v) for v in x)
        Mb, Mw, l, r, g, a = p.m_body, p.m_wheels, p.com_height, p.wheel_radius, p.g, self.slope
        beta_dot = theta_dot - phi_dot
        kinetic = (
            0.5 * Mw * r**2 * theta_dot**2
            + 0.5 * Mb * (phi_dot**2 * l**2 + r**2 * theta_dot**2 + 2 * r * theta_dot * phi_dot * l * math.cos(phi + a))
            + 0.5 * p.i_wheels * theta_dot**2
            + 0.5 * p.i_body * phi_dot**2
            + 0.5 * p.i_motor * p.gear_ratio**2 * beta_dot**2
        )
        potential = Mw * g * r * theta * math.sin(a) + Mb * g * (l * math.cos(phi) + r * theta * math.sin(a))
        return kinetic + potential

    def equilibrium(self, theta_dot_ref: float):
        """Corrected (4.42): sin(phi_s) = ((Mw + Mb) g r sin(a) + mu_g theta_dot) / (Mb g l)."""
        p = self.params
        s = ((p.m_wheels + p.m_body) * p.g * p.wheel_radius * math.sin(self.slope) + p.mu_ground * theta_dot_ref) / (
            p.m_body * p.g * p.com_height
        )
        if abs(s) >= 1:
            raise ValueError(f"no equilibrium: sin(phi_s) = {s}")
        u_s = (p.m_body * p.g * p.com_height * s + p.mu_bearing * theta_dot_ref) / (p.gear_ratio * p.torque_constant)
        return np.array([math.asin(s), 0.0, 0.0, theta_dot_ref]), u_s

    def linearize_thesis(self):
        """(4.2)-(4.10) with d2 corrected: returns (A, B, D) on [phi, phi_dot, theta_dot]."""
        p = self.params
        Mb, g, l, r = p.m_body, p.g, p.com_height, p.wheel_radius
        a = self.mass_matrix(0.0)  # (4.2): cos(phi + alpha) -> cos(alpha) at phi = 0
        c = np.array([[-Mb * g * l, p.mu_bearing, -p.mu_bearing], [-Mb * g * l, 0.0, p.mu_ground]])
        d = np.array([0.0, (p.m_wheels + Mb) * g * r * math.sin(self.slope)])
        b = np.array([-p.gear_ratio * p.torque_constant, 0.0])
        ainv = np.linalg.inv(a)
        abar, dbar, bbar = -ainv @ c, -ainv @ d, ainv @ b
        A = np.vstack([[0.0, 1.0, 0.0], abar])
        return A, np.concatenate([[0.0], bbar])[:, None], np.concatenate([[0.0], dbar])[:, None]

    def equilibrium_linear(self, theta_dot_ref: float):
        """(4.12)-(4.13) on the thesis's linear model."""
        A, B, D = self.linearize_thesis()
        a11, a13, a21, a23 = A[1, 0], A[1, 2], A[2, 0], A[2, 2]
        b1, b2, d1, d2 = B[1, 0], B[2, 0], D[1, 0], D[2, 0]
        phi_s = ((a23 * b1 - a13 * b2) * theta_dot_ref + b1 * d2 - b2 * d1) / (a11 * b2 - a21 * b1)
        u_s = ((a11 * a23 - a13 * a21) * theta_dot_ref + a11 * d2 - a21 * d1) / (a21 * b1 - a11 * b2)
        return np.array([phi_s, 0.0, 0.0, theta_dot_ref]), u_s
