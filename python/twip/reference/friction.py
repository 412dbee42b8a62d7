"""Reference gearhead friction (Coulomb + viscous + Stribeck, tanh-regularised), one wheel.

tau_f(w) = (tau_c + (tau_s - tau_c) exp(-(w/w_s)^2)) tanh(w/w_eps) + b_v w, with w the
wheel's speed relative to the body [rad/s]. The core's crates/twip-core/src/model/friction.rs
holds the same law; the models here apply it on their own route (as a Rayleigh-like
generalised force along each wheel's relative-speed direction).

With a stick band (stick_speed > 0, Karnopp): a wheel with |w| < stick_speed is held by
whatever torque, up to the breakaway torque, gives dw/dt = -w / STICK_TIME; beyond that
torque it breaks away at +-breakaway; outside the band sign(w) is exact.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twip.reference.real import real

# GB37Y3530-12V-251R data sheet (docs/parameters.md): no-load current, k_t, gear ratio.
GB37_NO_LOAD_CURRENT = 0.35
GB37_TORQUE_CONSTANT = 9.925e-3
GB37_GEAR_RATIO = 43.7
STICK_TIME = 5e-3  # how fast a held wheel comes to rest [s]


@dataclass(frozen=True)
class Friction:
    coulomb: float
    breakaway: float
    stribeck_speed: float
    viscous: float
    smoothing_speed: float
    stick_speed: float = 0.0

    @classmethod
    def gb37(cls) -> "Friction":
        """The no-load torque eta k_t I0 as Coulomb; breakaway 1.25x; w_s = 1, w_eps = 0.1 rad/s."""
        tau = GB37_GEAR_RATIO * GB37_TORQUE_CONSTANT * GB37_NO_LOAD_CURRENT
        return cls(tau, 1.25 * tau, 1.0, 0.0, 0.1)

    @classmethod
    def of(cls, f) -> "Friction | None":
        """A Friction from None, this class or anything with the same attributes (twip.Friction)."""
        if f is None:
            return None
        names = ("coulomb", "breakaway", "stribeck_speed", "viscous", "smoothing_speed")
        return cls(*(real(n, getattr(f, n)) for n in names), real("stick_speed", getattr(f, "stick_speed", 0.0)))

    def torque(self, w: float) -> float:
        """The slip law (the whole law without a stick band)."""
        level = self.coulomb + (self.breakaway - self.coulomb) * math.exp(-((w / self.stribeck_speed) ** 2))
        sign = float(np.sign(w)) if self.stick_speed > 0 else math.tanh(w / self.smoothing_speed)
        return level * sign + self.viscous * w

    def torques(self, w, a0, S) -> np.ndarray:
        """Torques on wheels at speeds `w` whose accelerations are a0 - S tau (S from the
        mass matrix): the slip law, except that wheels in the stick band are held while
        the torque that takes stays within +-breakaway; the one that would need most beyond
        it breaks away at +-breakaway and the rest are held against it."""
        w, a0, S = np.asarray(w, float), np.asarray(a0, float), np.asarray(S, float)
        tau = np.array([self.torque(v) for v in w])
        if self.stick_speed <= 0:
            return tau
        held = np.abs(w) < self.stick_speed
        while held.any():
            h, o = np.flatnonzero(held), np.flatnonzero(~held)
            need = np.linalg.solve(S[np.ix_(h, h)], a0[h] + w[h] / STICK_TIME - S[np.ix_(h, o)] @ tau[o])
            excess = np.abs(need) - self.breakaway
            if not (excess > 0).any():
                tau[h] = need
                break
            worst = int(np.argmax(excess))  # the wheel that needs most breaks away first
            tau[h[worst]] = math.copysign(self.breakaway, need[worst])
            held[h[worst]] = False
        return tau
