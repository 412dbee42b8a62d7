"""Reference terrains and the robot's frame on them (pure numpy, written from the definitions).

A terrain is a height h(x, y) with its gradient. The robot's frame at the contact point
(x, y) facing the horizontal heading psi is built from 3-D vectors, not from the closed
forms of the Rust core: the ground's normal n, the travel direction d (in the ground
plane, horizontally along psi), the axle a = n x d (to the left), and the angle delta
between n and the most vertical direction perpendicular to the axle.
"""
from __future__ import annotations

import math

import numpy as np


class OffTerrain(ValueError):
    """The point is outside a grid."""


class Terrain:
    """h(x, y) as a function `height(x, y) -> (h, gx, gy)`."""

    def __init__(self, local):
        self.local = local

    @classmethod
    def plane(cls, slope, uphill_heading=0.0):
        t = math.tan(slope)
        gx, gy = t * math.cos(uphill_heading), t * math.sin(uphill_heading)
        return cls(lambda x, y: (gx * x + gy * y, gx, gy))

    @classmethod
    def ramp(cls, slope, uphill_heading=0.0, start=0.0, blend=0.1):
        grade, ux, uy = math.tan(slope), math.cos(uphill_heading), math.sin(uphill_heading)

        def local(x, y):
            s = ux * x + uy * y - start
            if s <= 0:
                return 0.0, 0.0, 0.0
            if s >= blend:
                return grade * (s - blend / 2), grade * ux, grade * uy
            # Grade rising as 3u^2 - 2u^3, its integral u^3 - u^4/2.
            u = s / blend
            g = grade * (3 * u**2 - 2 * u**3)
            return grade * blend * (u**3 - u**4 / 2), g * ux, g * uy

        return cls(local)

    @classmethod
    def bumps(cls, height, wavelength):
        k, a = 2 * math.pi / wavelength, height / 2

        def local(x, y):
            return (a * math.sin(k * x) * math.sin(k * y), a * k * math.cos(k * x) * math.sin(k * y),
                    a * k * math.sin(k * x) * math.cos(k * y))

        return cls(local)

    @classmethod
    def grid(cls, x, y, z):
        """Bicubic Hermite on the grid, node slopes by finite differences (numpy.gradient's
        second-order central differences would differ: twip uses the plain central ones)."""
        x, y, z = np.asarray(x, float), np.asarray(y, float), np.asarray(z, float)

        def slopes(axis_values, values, axis):
            out = np.empty_like(values)
            n = len(axis_values)
            for i in range(n):
                lo, hi = max(i - 1, 0), min(i + 1, n - 1)
                take = np.take(values, hi, axis=axis) - np.take(values, lo, axis=axis)
                idx = [slice(None)] * values.ndim
                idx[axis] = i
                out[tuple(idx)] = take / (axis_values[hi] - axis_values[lo])
            return out

        zx = slopes(x, z, 0)
        zy = slopes(y, z, 1)
        zxy = slopes(y, zx, 1)

        def h01(t):
            return (np.array([2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t, 3 * t**2 - 2 * t**3, t**3 - t**2]),
                    np.array([6 * t**2 - 6 * t, 3 * t**2 - 4 * t + 1, 6 * t - 6 * t**2, 3 * t**2 - 2 * t]))

        def local(px, py):
            if not (x[0] <= px <= x[-1] and y[0] <= py <= y[-1]):
                raise OffTerrain(f"({px}, {py}) is off the grid")
            i = min(max(np.searchsorted(x, px, side="right") - 1, 0), len(x) - 2)
            j = min(max(np.searchsorted(y, py, side="right") - 1, 0), len(y) - 2)
            hx, hy = x[i + 1] - x[i], y[j + 1] - y[j]
            (bu, du), (bv, dv) = h01((px - x[i]) / hx), h01((py - y[j]) / hy)
            h = gx = gy = 0.0
            for di in (0, 1):
                for dj in (0, 1):
                    f, fx, fy, fxy = z[i + di, j + dj], zx[i + di, j + dj], zy[i + di, j + dj], zxy[i + di, j + dj]
                    a = np.array([bu[2 * di], bu[2 * di + 1] * hx])
                    da = np.array([du[2 * di], du[2 * di + 1] * hx]) / hx
                    b = np.array([bv[2 * dj], bv[2 * dj + 1] * hy])
                    db = np.array([dv[2 * dj], dv[2 * dj + 1] * hy]) / hy
                    coef = np.array([[f, fy], [fx, fxy]])
                    h += a @ coef @ b
                    gx += da @ coef @ b
                    gy += a @ coef @ db
            return h, gx, gy

        return cls(local)


def frame(gx, gy, psi):
    """The robot's frame on the ground plane of gradient (gx, gy) at horizontal heading psi:
    (n, d, a, delta) with delta the angle from n to the most vertical direction perpendicular
    to the axle, positive towards d."""
    n = np.array([-gx, -gy, 1.0])
    n /= np.linalg.norm(n)
    d = np.array([math.cos(psi), math.sin(psi), gx * math.cos(psi) + gy * math.sin(psi)])
    d /= np.linalg.norm(d)
    a = np.cross(n, d)
    z = np.array([0.0, 0.0, 1.0])
    return n, d, a, math.atan2(z @ d, z @ n)


def delta_of_chi(gx, gy, psi, h=1e-4):
    """delta and its first two derivatives along the heading in the plane (chi, the frame
    turning about n), by central differences of `frame` turned by +-h about n."""
    n, d, a, delta = frame(gx, gy, psi)
    z = np.array([0.0, 0.0, 1.0])

    def at(angle):
        dd = math.cos(angle) * d + math.sin(angle) * a
        return math.atan2(z @ dd, z @ n)

    d1 = (at(h) - at(-h)) / (2 * h)
    d2 = (at(h) - 2 * delta + at(-h)) / h**2
    return delta, d1, d2
