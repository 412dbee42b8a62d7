"""Reference gearbox backlash (crates/twip-core/src/hardware/backlash.rs): each gear train's
free play, its rotor turning on its own while the train is open, plastic impacts on the flanks.

The models' side (a wheel whose train is open gets no motor torque, no gearhead friction and
loses its rotor's inertia) is `deriv_geared` and `engage` of twip.reference.SlopeModel and
PlanarModel. This class holds the rotors and is advanced by the rigs between plant steps.
"""
from __future__ import annotations

import math

import numpy as np

GB37_BACKLASH = math.pi / 180.0  # 1 degree at the output: the data sheet gives none


class GearPlay:
    """`n` gear trains with `gap` of play [rad at the wheel]; each rotor of `inertia`
    [kg m^2 at the wheel] stands for `trains` trains with the gearhead `friction` each.
    They start open, centred, each rotor turning with its wheel (set at the first step)."""

    def __init__(self, gap: float, inertia: float, trains: float, friction, n: int):
        if not (math.isfinite(gap) and gap >= 0):
            raise ValueError(f"invalid gap = {gap}: must be finite and >= 0")
        self.half, self.inertia, self.trains, self.friction = gap / 2.0, inertia, trains, friction
        self.offset, self.rotor, self.flank = [0.0] * n, [0.0] * n, [0] * n
        self.motor, self.before = [0.0] * n, None

    def engaged(self):
        return [f != 0 for f in self.flank]

    def motor_speeds(self, wheel):
        return [r if f == 0 else w for r, f, w in zip(self.rotor, self.flank, wheel)]

    def elapsed(self, dt, after):
        """The step under way ended at wheel speeds `after`: open rotors advance; returns, for
        each that hit a flank moving into it, (its speed at the impact, how long before the
        step's end it reached the flank) (None otherwise): the plant locates the impact there."""
        hits = [None] * len(self.flank)
        if self.before is None:
            return hits
        for i, flank in enumerate(self.flank):
            if flank != 0:
                continue
            start = self.rotor[i]
            end = self._rotor_step(start, self.motor[i], dt)
            self.rotor[i] = end
            before = self.offset[i]
            self.offset[i] += dt * 0.5 * ((start + end) - (self.before[i] + after[i]))
            to = self.offset[i]
            closing = end - after[i]
            hit = 0
            if self.offset[i] >= self.half:
                self.offset[i] = self.half
                if closing > 0:
                    hit = 1
            elif self.offset[i] <= -self.half:
                self.offset[i] = -self.half
                if closing < 0:
                    hit = -1
            if hit != 0:
                late = self._lateness(hit, before, to, dt)
                hits[i] = (end - late * self._rotor_acceleration(end, self.motor[i]), late)
        return hits

    def _lateness(self, hit, before, to, dt):
        """How long before the step's end the offset, interpolated linearly, reached the flank."""
        flank, moved = (self.half, to - before) if hit > 0 else (-self.half, before - to)
        if not moved > 0:
            return 0.0
        over = to - flank if hit > 0 else flank - to
        return min(max(dt * (over / moved), 0.0), dt)

    def motors(self):
        """The motors' torques over the step under way [N m at the wheel]."""
        return list(self.motor)

    def engage(self, i, speed):
        self.flank[i] = 1 if self.offset[i] > 0 else -1
        self.rotor[i] = speed

    def next_step(self, wheel, contact, motor):
        """A step starts: engaged trains whose contact torque pulls the flanks apart open."""
        if self.before is None:
            self.rotor = list(wheel)  # the start state's rotors turn with their wheels
        for i, flank in enumerate(self.flank):
            if flank == 0:
                continue
            pushes = contact[i] >= 0 if flank == 1 else contact[i] <= 0
            self.rotor[i] = wheel[i]
            if not pushes:
                self.flank[i] = 0
        self.motor = list(motor)
        self.before = list(wheel)

    def _rotor_acceleration(self, speed, motor):
        j, n = self.inertia, self.trains
        if self.friction is None:
            return motor / j
        return (motor - n * self.friction.torques([speed], [motor / j], [[n / j]])[0]) / j

    def _rotor_step(self, speed, motor, dt):
        def accel(w):
            return self._rotor_acceleration(w, motor)

        k1 = accel(speed)
        k2 = accel(speed + k1 * dt / 2)
        k3 = accel(speed + k2 * dt / 2)
        k4 = accel(speed + k3 * dt)
        return speed + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def heun(x, h, f):
    """`x` moved by `h` [s] (negative: back) along `f` by Heun's rule: how the plants take a
    state to an impact located within a step and on from it (backlash.rs's `heun`)."""
    x = np.asarray(x, dtype=float)
    k1 = np.asarray(f(x), dtype=float)
    k2 = np.asarray(f(x + k1 * h), dtype=float)
    return x + (k1 + k2) * (h * 0.5)
