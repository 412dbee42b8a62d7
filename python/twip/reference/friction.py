"""Reference gearhead friction (Coulomb + viscous + Stribeck, tanh-regularised), one wheel.

tau_f(w) = (tau_c + (tau_s - tau_c) exp(-(w/w_s)^2)) tanh(w/w_eps) + b_v w, with w the
wheel's speed relative to the body [rad/s]. The core's crates/twip-core/src/model/friction.rs
holds the same law; the models here apply it on their own route (as a Rayleigh-like
generalised force along each wheel's relative-speed direction).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

# GB37Y3530-12V-251R data sheet (docs/parameters.md): no-load current, k_t, gear ratio.
GB37_NO_LOAD_CURRENT = 0.35
GB37_TORQUE_CONSTANT = 9.925e-3
GB37_GEAR_RATIO = 43.7


@dataclass(frozen=True)
class Friction:
    coulomb: float
    breakaway: float
    stribeck_speed: float
    viscous: float
    smoothing_speed: float

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
        return cls(*(float(getattr(f, n)) for n in ("coulomb", "breakaway", "stribeck_speed", "viscous", "smoothing_speed")))

    def torque(self, w: float) -> float:
        level = self.coulomb + (self.breakaway - self.coulomb) * math.exp(-((w / self.stribeck_speed) ** 2))
        return level * math.tanh(w / self.smoothing_speed) + self.viscous * w
