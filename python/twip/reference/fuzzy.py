"""Reference fuzzy logic systems (4.27-4.31, 4.39) and the fuzzy adaptive backstepping + PD
controller (4.41-4.56, errata F1-F8 applied), in numpy.

Written apart from the Rust core: memberships by masks rather than branches, the basis by
the thesis's own formula (4.29) (product of every rule, divided by their sum) rather than
per-input normalisation, and G1 from the thesis's row arrangement (4.32)-(4.35) rather
than the symmetric mass matrix.
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from twip.reference.real import real, reals


def _check_order(name: str, values: dict) -> None:
    keys = list(values)
    for k, v in values.items():
        if math.isnan(v):
            raise ValueError(f"invalid {name}.{k} = {v}: must not be NaN")
    for lo, hi in zip(keys, keys[1:]):
        if values[lo] > values[hi]:
            raise ValueError(f"invalid {name}.{hi} = {values[hi]}: breakpoints must satisfy "
                             f"{' <= '.join(keys)} ({name}{tuple(values.values())})")


class Trapezoid:
    """(4.31); a = b = -inf is a left shoulder, c = d = +inf a right one."""

    def __init__(self, a: float, b: float, c: float, d: float):
        self.a, self.b, self.c, self.d = (real(n, v) for n, v in zip("abcd", (a, b, c, d)))
        _check_order("Trapezoid", {"a": self.a, "b": self.b, "c": self.c, "d": self.d})
        if math.isinf(self.a) and self.a != self.b:
            raise ValueError(f"invalid Trapezoid.a = {self.a}: an infinite a needs b = a (a shoulder)")
        if math.isinf(self.d) and self.d != self.c:
            raise ValueError(f"invalid Trapezoid.d = {self.d}: an infinite d needs c = d (a shoulder)")

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        a, b, c, d = self.a, self.b, self.c, self.d
        with np.errstate(invalid="ignore", divide="ignore"):
            rising = np.where((x >= a) & (x < b), (x - a) / (b - a), 0.0)
            falling = np.where((x > c) & (x <= d), (d - x) / (d - c), 0.0)
        out = np.where((x >= b) & (x <= c), 1.0, rising + falling)
        out = np.where(np.isnan(x), np.nan, out)
        return out if out.ndim else float(out)

    def distance(self, x: float) -> float:
        """How far x is from where the set is non-zero (for the no-rule-fires case)."""
        return max(self.a - x, x - self.d, 0.0)


class Triangle(Trapezoid):
    def __init__(self, a: float, b: float, c: float):
        super().__init__(a, b, b, c)


class Gaussian:
    """exp(-(x - mean)^2 / (2 sigma^2)), sigma > 0."""

    def __init__(self, mean: float, sigma: float):
        self.mean, self.sigma = real("mean", mean), real("sigma", sigma)
        if not math.isfinite(self.mean):
            raise ValueError(f"invalid Gaussian.mean = {self.mean}: must be finite")
        if not (math.isfinite(self.sigma) and self.sigma > 0):
            raise ValueError(f"invalid Gaussian.sigma = {self.sigma}: must be finite and > 0")

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        z = (x - self.mean) / self.sigma
        with np.errstate(over="ignore"):  # far out z^2 overflows to inf and exp gives 0
            out = np.exp(-0.5 * (z * z))  # z * z, not z ** 2: pow is not always exact
        return out if out.ndim else float(out)

    def distance(self, x: float) -> float:
        return abs(x - self.mean) / self.sigma


def _silent(total: float) -> bool:
    """Whether an input's memberships, summing to `total`, fire no rule: none holds it, or they
    hold it so faintly (a subnormal sum) that 1/total overflows. twip's definition (the Rust
    core's module docs): such an input fires its nearest set alone."""
    return not (total > 0 and math.isfinite(1.0 / float(total)))


def _nearest(sets, x: float) -> int:
    """Index of the nearest set; ties go to the last set when x > 0, the first otherwise."""
    dist = [s.distance(x) for s in sets]
    best = min(dist)
    ties = [j for j, v in enumerate(dist) if v == best]
    return ties[-1] if x > 0 else ties[0]


class GridBasis:
    """Normalised fuzzy basis xi(x) of (4.29) over every combination of one set per input,
    product inference; rules in row-major order (the last input varies fastest, as (4.39))."""

    def __init__(self, sets_per_input):
        self.sets = [list(s) for s in sets_per_input]
        if not self.sets or any(len(s) == 0 for s in self.sets):
            raise ValueError("every input needs at least one set")
        self.n_inputs = len(self.sets)
        self.n_rules = int(np.prod([len(s) for s in self.sets]))

    def eval(self, x):
        x = np.asarray(x, dtype=float)
        if x.ndim == 2:
            return np.array([self.eval(row) for row in x])
        if x.shape != (self.n_inputs,):
            raise ValueError(f"x has shape {x.shape}, expected ({self.n_inputs},)")
        mu = [np.array([s(xi) for s in sets]) for sets, xi in zip(self.sets, x)]
        w = np.array([math.prod(m[j] for m, j in zip(mu, idx)) for idx in self._rules()])
        D = w.sum()
        if math.isnan(D) or (D > 0 and not any(_silent(m.sum()) for m in mu)):
            return w / D
        # No rule fires: each silent input falls back to its nearest set alone.
        parts = []
        for m, sets, xi in zip(mu, self.sets, x):
            s = m.sum()
            if not _silent(s):
                parts.append(m / s)
            else:
                one = np.zeros(len(sets))
                one[_nearest(sets, xi)] = 1.0
                parts.append(one)
        return np.array([math.prod(p[j] for p, j in zip(parts, idx)) for idx in self._rules()])

    def _rules(self):
        return itertools.product(*[range(len(s)) for s in self.sets])


# The name twip uses for the same thing.
FuzzyBasis = GridBasis


def default_sets():
    """The N, Z, P sets twip uses for (phi [rad], phi_dot [rad/s]) (docs/scenarios.md)."""
    inf = math.inf
    pitch = [Trapezoid(-inf, -inf, -0.3, -0.1), Trapezoid(-0.3, -0.1, 0.1, 0.3), Trapezoid(0.1, 0.3, inf, inf)]
    rate = [Trapezoid(-inf, -inf, -2.0, -0.5), Trapezoid(-2.0, -0.5, 0.5, 2.0), Trapezoid(0.5, 2.0, inf, inf)]
    return [pitch, rate]


def regular_grid(kind: str, centres, widths=None):
    """The sets of an n x n grid over (phi, phi_dot), as `twip.FuzzyBasis.grid` makes them:
    "gaussian" N(c_j, w_j); "triangle" peaks at c_j with feet at the neighbouring centres;
    "trapezoid" cores c_j +- w_j with feet at the neighbours' core edges; the outer
    triangles and trapezoids are shoulders."""
    inf = math.inf
    rows = []
    for i, c in enumerate(centres):
        c = reals(f"centres[{i}]", c)
        n = len(c)
        if not 2 <= n <= 7:
            raise ValueError(f"invalid n = {n}: must be from 2 to 7 sets per input")
        if any(not math.isfinite(v) for v in c) or any(b <= a for a, b in zip(c, c[1:])):
            raise ValueError(f"invalid centres[{i}] = {c}: must be finite and strictly increasing")
        w = [] if widths is None else widths[i]
        w = [real(f"widths[{i}]", w)] * n if np.ndim(w) == 0 else reals(f"widths[{i}]", w)
        lo = [-inf] + c[:-1]   # the left neighbour's centre (none: shoulder)
        hi = c[1:] + [inf]
        if kind == "gaussian":
            rows.append([Gaussian(m, s) for m, s in zip(c, w)])
        elif kind == "triangle":
            rows.append([Trapezoid(a, -inf if a == -inf else m, inf if d == inf else m, d)
                         for a, m, d in zip(lo, c, hi)])
        elif kind == "trapezoid":
            core_lo = [m - s for m, s in zip(c, w)]
            core_hi = [m + s for m, s in zip(c, w)]
            feet_lo = [-inf] + core_hi[:-1]
            feet_hi = core_lo[1:] + [inf]
            rows.append([Trapezoid(a, -inf if a == -inf else b, inf if d == inf else cc, d)
                         for a, b, cc, d in zip(feet_lo, core_lo, core_hi, feet_hi)])
        else:
            raise ValueError(f"invalid kind = {kind!r}")
    return rows


class FuzzyController:
    """u = -(1/G1) [e1 + S^T xi + k1 phi_dot + (1/2 + k2) z2] + kp e + kd e_dot + ki int(e),
    S' = z2 xi / gamma - sigma S, forward Euler at the controller's period; any n x n sets."""

    #: The names with the 3 x 3 sets (an instance's own follow its sets).
    internal_names = tuple(f"xi{k}" for k in range(1, 10)) + tuple(f"S{k}" for k in range(1, 10)) + (
        "z2", "e1", "phi_s", "V2", "e", "e_int")

    def __init__(self, model, k1, k2, kp, kd, gamma=20.0, sigma=0.05, ki=0.0, adapt=True, sets=None,
                 period=0.005, s0=None):
        self.model = model
        self.k1, self.k2, self.kp, self.kd, self.ki = (real(n, v) for n, v in zip(("k1", "k2", "kp", "kd", "ki"),
                                                                              (k1, k2, kp, kd, ki)))
        self.gamma, self.sigma = real("gamma", gamma), real("sigma", sigma)
        self.adapt, self.period = bool(adapt), real("period", period)
        self.basis = GridBasis(sets if sets is not None else default_sets())
        k = self.basis.n_rules
        self.internal_names = tuple(f"xi{j}" for j in range(1, k + 1)) + tuple(f"S{j}" for j in range(1, k + 1)) + (
            "z2", "e1", "phi_s", "V2", "e", "e_int")
        self.s0 = np.zeros(k) if s0 is None else np.array(s0, dtype=float)
        self.reset()

    def reset(self):
        self.S = self.s0.copy()
        self.e_int = 0.0
        self.internals = (0.0,) * len(self.internal_names)

    def g1(self, phi: float) -> float:
        """First entry of G = A^-1 b-bar, (4.32)-(4.35)."""
        p = self.model.params
        b = np.array([-p.gear_ratio * p.torque_constant, 0.0])
        return float(np.linalg.solve(self.model.mass_matrix(phi), b)[0])

    def update(self, t, y, ref):
        theta_ref, speed = ref
        phi, phi_dot, theta, theta_dot = (float(v) for v in y)
        phi_s = float(self.model.equilibrium(speed)[0][0])
        e1 = phi - phi_s
        z2 = phi_dot + self.k1 * e1
        xi = self.basis.eval([phi, phi_dot])
        e, e_dot = theta_ref - theta, speed - theta_dot
        u = -(e1 + self.S @ xi + self.k1 * phi_dot + (0.5 + self.k2) * z2) / self.g1(phi)
        u += self.kp * e + self.kd * e_dot + self.ki * self.e_int
        V2 = 0.5 * e1**2 + 0.5 * z2**2 + 0.5 * self.gamma * (self.S @ self.S)
        self.internals = tuple(xi) + tuple(self.S) + (z2, e1, phi_s, V2, e, self.e_int)
        if self.adapt:
            self.S = self.S + self.period * (z2 * xi / self.gamma - self.sigma * self.S)
        self.e_int += self.period * e
        return u
