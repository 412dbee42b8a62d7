"""Reference 3-DOF realism rig, as twip-core's hardware/planar_rig.rs (numpy, slow).

Each wheel is driven through its own bridge and motor (`Driven`'s winding, at that wheel's speed
relative to the body); the MPU-6050's pitch channels read the pitch-plane motion and a second
channel's gyro reads the z axis (omega cos phi); the sensor follows each wheel's angle relative to
the body by the trapezoid rule on the plant's steps; the firmware reads an encoder per wheel, takes
the heading psi = R (beta_r - beta_l) / (2 b) and the position by dead reckoning along the mean
heading, and turns each wheel's torque into a duty. The model is `twip.reference.PlanarModel`
(Kane's method), so the parity of a run checks the rig and the model together.

On a terrain (the model's `terrain`) the plant and the sensors work in the ground plane's frame:
the wheels turn relative to the body's pitch about the axle phi' = phi + delta, forces and pushes
act at phi', and the accelerometer reads the pitch-plane motion there with gravity g cos(roll)
(the roll's sine from the axle's height gradient in 3-D), the pitch gyro phi_dot', the z gyro
omega cos(phi').
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twip.reference.backlash import GearPlay, heun
from twip.reference.realism import (Driven, Encoder, Mpu6050, PwmActuator, Realism, TiltFilter, rk4_sampled,
                                    settle_at_rest, specific_force)
from twip.reference.rng import Sfc64


@dataclass
class PlanarRigRun:
    t: np.ndarray
    states: np.ndarray
    inputs: np.ndarray  # the wheel torques being applied [N m]
    signals: np.ndarray  # x_hat ... omega_hat, drive_r, drive_l, current_r, current_l
    outcome: str = "completed"


class PlanarPlant:
    """The planar model with pushes, a constant force, and optionally a winding per wheel."""

    def __init__(self, model, realism: Realism):
        p = model.params
        self.model, self.params = model, p
        self.inv_r, self.b_r = 1.0 / p.wheel_radius, p.half_track / p.wheel_radius
        self.force = realism.force
        self.has_force = realism.force[0] != 0.0 or realism.force[1] != 0.0
        self.pushes = sorted(realism.pushes)
        self.next_push = 0
        m = realism.motor
        self.windings = None if m is None else [Driven(None, m, p), Driven(None, m, p)]
        self.torque_per_amp = None if m is None else m.efficiency * (p.gear_ratio * p.torque_constant)
        self.play = None  # each gear train (backlash)
        if realism.backlash:
            self.play = GearPlay(realism.backlash, model.rotor_per_wheel(), 1.0, model.friction, 2)

    def motor_speeds(self, x):
        w = self.wheel_speeds(x)
        return list(w) if self.play is None else self.play.motor_speeds(w)

    def torques(self, x, u, stage="start"):
        """The wheel torques at an RK4 stage."""
        if self.windings is None:
            return list(u)
        speeds = self.motor_speeds(x)
        return [self.torque_per_amp * d.stage_current_at(wi, ui, stage) for d, wi, ui in zip(self.windings, speeds, u)]

    def mean_torques(self, x, u):
        """The wheel torques' means over the step (what an open train's rotor is driven by)."""
        if self.windings is None:
            return list(u)
        return [self.torque_per_amp * d.mean_current_at(wi, ui) for d, wi, ui in zip(self.windings, self.motor_speeds(x), u)]

    def shaft_offsets(self):
        return [0.0, 0.0] if self.play is None else list(self.play.offset)

    def engaged(self):
        return (True, True) if self.play is None else tuple(self.play.engaged())

    def in_plane(self, x):
        """The state in the ground plane's frame (itself on flat ground)."""
        return x if self.model.terrain is None else self.model.in_plane(x)

    def wheel_speeds(self, x):
        x = self.in_plane(x)
        roll = self.inv_r * x[5] - x[4]
        turn = self.b_r * x[6]
        return roll + turn, roll - turn

    def body_force(self, fx, fz, height, phi):
        return height * (fx * math.cos(phi) - fz * math.sin(phi)), fx

    def deriv(self, x, u, stage="start"):
        extra = self.body_force(*self.force, self.in_plane(x)[3]) if self.has_force else None
        return self.model.deriv_geared(x, self.torques(x, u, stage), self.engaged(), extra)[0]

    def between_steps(self, t, dt, x, u):
        if self.play is not None:
            for i, hit in enumerate(self.play.elapsed(dt, list(self.wheel_speeds(x)))):
                if hit is not None:
                    self._impact_at_its_time(x, i, *hit)
        while self.next_push < len(self.pushes) and self.pushes[self.next_push][0] < t + dt * 0.5:
            _, impulse, height = self.pushes[self.next_push]
            self.next_push += 1
            # On terrain at the pitch from the plane's normal; phi_dot jumps as phi_dot' does.
            phi = self.in_plane(x)[3]
            q = self.body_force(impulse, 0.0, height, phi)
            jump = np.linalg.solve(self.model.mass_matrix(phi), [q[0], q[1], 0.0])
            x[4] += jump[0]
            x[5] += jump[1]
        if self.windings is not None:
            for d, wi, ui in zip(self.windings, self.motor_speeds(x), u):
                d.start_step_at(wi, ui, dt)
        if self.play is not None:
            motor = self.torques(x, u)
            extra = self.body_force(*self.force, self.in_plane(x)[3]) if self.has_force else None
            d, tau = self.model.deriv_geared(x, motor, self.engaged(), extra)
            w = self.wheel_speeds(x)
            acc = self.wheel_accelerations(x, d)
            j = self.play.inertia
            self.play.next_step(list(w), [m - f - j * a for m, f, a in zip(motor, tau, acc)], self.mean_torques(x, u))

    def _impact_at_its_time(self, x, i, rotor, late):
        """Train `i`'s impact `late` [s] before the step's end at `x`: back along the open
        motion, the impact, forward engaged (planar_rig.rs's gear_elapsed)."""
        torques = self.play.motors()
        before = self.engaged()
        after = tuple(True if k == i else e for k, e in enumerate(before))
        extra = (lambda y: self.body_force(*self.force, self.in_plane(y)[3])) if self.has_force else (lambda y: None)

        def motion(engaged):
            return lambda y: self.model.deriv_geared(y, torques, engaged, extra(y))[0]

        x[:] = heun(x, -late, motion(before))
        self.model.engage(x, i, rotor, before)
        x[:] = heun(x, late, motion(after))
        self.play.engage(i, self.wheel_speeds(x)[i])

    def end_step(self, x):
        """The step under way ended at x: the windings' currents are carried to it."""
        if self.windings is not None:
            for d, wi in zip(self.windings, self.motor_speeds(x)):
                d.end_step_at(wi)

    def wheel_accelerations(self, x, d):
        """Each wheel's acceleration relative to the body from the derivative d (on terrain,
        to phi_dd' = phi_dd + delta' omega_dot + delta'' omega^2)."""
        phi_dd = d[4]
        if self.model.terrain is not None:
            _, _, _, (_, d1, d2), _, _ = self.model._ground(x)
            phi_dd = d[4] + d1 * d[6] + d2 * x[6] ** 2
        roll = self.inv_r * d[5] - phi_dd
        turn = self.b_r * d[6]
        return roll + turn, roll - turn

    def currents(self, x, u):
        if self.windings is None:
            return [ui / (self.params.gear_ratio * self.params.torque_constant) for ui in u]
        return [d.current_at(wi, ui) for d, wi, ui in zip(self.windings, self.motor_speeds(x), u)]


class PlanarSensors:
    """The pitch-plane IMU and the z gyro, the tilt filter, an encoder per wheel; the truth
    for each part left out."""

    def __init__(self, realism: Realism, params, dt, model=None):
        self.model = model  # its terrain, if any, is the ground the sensors read on
        self.imu = None if realism.imu is None else (Mpu6050(realism.imu), Mpu6050(realism.imu))
        kind, tuning = realism.estimator
        self.tilt = TiltFilter(kind, **tuning)
        cpr = realism.encoder_cpr
        self.encoders = None if cpr is None else (Encoder(cpr), Encoder(cpr))
        self.beta, self.beta_dot = [0.0, 0.0], [0.0, 0.0]
        self.pose, self.last_beta_hat = [0.0, 0.0, 0.0], None
        self.r, self.b, self.inv_r, self.g = params.wheel_radius, params.half_track, 1.0 / params.wheel_radius, params.g
        self.next_sample, self.dt = 0.0, dt
        self.rng = Sfc64(realism.seed, realism.stream)
        self.last_read = None
        self.shaft = [0.0, 0.0]  # each motor shaft's angle minus its wheel's (backlash)
        self.realism = realism

    def settle(self, x0, period):
        """The estimator reads the pitch IMU at rest at x0's pitch (the realism's `settle`)."""
        settle_at_rest(self, x0[3], self.g, period)

    def _on_terrain(self, x, xdot):
        """On terrain: (phi_dot', phi_dd', sin delta, cos delta, cos roll, phi') from 3-D vectors."""
        _, _, a, (delta, d1, d2), _, _ = self.model._ground(x)
        phi_dd = xdot[4] + d1 * xdot[6] + d2 * x[6] ** 2
        return x[4] + d1 * x[6], phi_dd, math.sin(delta), math.cos(delta), math.sqrt(1.0 - a[2] ** 2), x[3] + delta

    def sample(self, t, x, xdot):
        terrain = self.model is not None and self.model.terrain is not None
        rate, phi_dd, sin_d, cos_d, cos_roll, tilted = (
            self._on_terrain(x, xdot) if terrain else (x[4], xdot[4], 0.0, 1.0, 1.0, x[3]))
        turn = self.b * x[6] * self.inv_r
        roll = x[5] * self.inv_r - rate
        speeds = [roll + turn, roll - turn]
        if t > 0.0:
            half = self.dt * 0.5
            self.beta = [b + half * (d + s) for b, d, s in zip(self.beta, self.beta_dot, speeds)]
        self.beta_dot = speeds
        if self.imu is not None and t + self.dt * 0.5 >= self.next_sample:
            pitch, yaw = self.imu
            x4 = [x[3], rate, 0.0, x[5] * self.inv_r]
            xdot4 = [rate, phi_dd, x[5] * self.inv_r, xdot[5] * self.inv_r]
            fx, fz = specific_force(x4, xdot4, sin_d, cos_d, self.r, pitch.s.height, self.g * cos_roll)
            pitch.sample(fx, fz, rate, self.rng)
            yaw.sample(0.0, self.g, x[6] * math.cos(tilted), self.rng)
            self.next_sample += pitch.period

    def read(self, t, x):
        dt = 0.0 if self.last_read is None else t - self.last_read
        self.last_read = t
        if self.imu is not None:
            ax, az, gyro = self.imu[0].reading
            phi, phi_dot = self.tilt.update(math.atan2(-ax, az), gyro, dt)
            omega_gyro = self.imu[1].reading[2] / math.cos(phi)
        else:
            phi, phi_dot, omega_gyro = x[3], x[4], x[6]
        if self.encoders is None:
            return np.array([x[0], x[1], x[2], phi, phi_dot, x[5], omega_gyro])
        b_r, w_r = self.encoders[0].read(self.beta[0] + self.shaft[0], dt)
        b_l, w_l = self.encoders[1].read(self.beta[1] + self.shaft[1], dt)
        r, b = self.r, self.b
        psi = r * (b_r - b_l) / (2.0 * b)
        v = r * ((w_r + w_l) / 2.0 + phi_dot)
        last = self.last_beta_hat if self.last_beta_hat is not None else (b_r, b_l)
        ds = r * ((b_r - last[0]) + (b_l - last[1])) / 2.0
        mid = (self.pose[2] + psi) / 2.0
        self.pose = [self.pose[0] + ds * math.cos(mid), self.pose[1] + ds * math.sin(mid), psi]
        self.last_beta_hat = (b_r, b_l)
        omega = omega_gyro if self.imu is not None else r * (w_r - w_l) / (2.0 * b)
        return np.array([self.pose[0], self.pose[1], psi, phi, phi_dot, v, omega])


def simulate(model, controller, x0, t_final, dt, reference, realism: Realism, fall_limit=math.radians(60)) -> PlanarRigRun:
    """The loop of twip-core's `runner::run_loop` with the 3-DOF rig."""
    p = model.params
    period = realism.control_period if realism.control_period is not None else controller.period
    controller.period = period
    if realism.friction is not None:
        model = type(model)(p, friction=realism.friction, terrain=model.terrain)
    plant = PlanarPlant(model, realism)
    sensors = PlanarSensors(realism, p, dt, model)
    actuator = None
    if realism.motor is not None:
        m = realism.motor
        actuator = PwmActuator(m, p, command_per_amp=m.efficiency * (p.gear_ratio * p.torque_constant))
    inv_r, b_r = 1.0 / p.wheel_radius, p.half_track / p.wheel_radius

    def drive(cmd, y):
        if actuator is None:
            return list(cmd)
        roll, turn = y[5] * inv_r - y[4], b_r * y[6]
        return [actuator.duty(cmd[0], roll + turn), actuator.duty(cmd[1], roll - turn)]

    n, per_update = round(t_final / dt), round(period / dt)
    x = np.array(x0, float)
    u = pending = command = pending_command = [0.0, 0.0]
    signals = [0.0] * 11
    ts, xs, us, ss = [], [], [], []
    sensors.settle(x, dt * per_update)
    sensors.sample(0.0, x, plant.deriv(x, u))
    outcome = "completed"
    for k in range(n):
        t = k * dt
        ref = reference.sample(t)
        if k % per_update == 0:
            sensors.shaft = plant.shaft_offsets()
            y = sensors.read(t, x)
            cmd = list(controller.update(t, y, ref))
            d = drive(cmd, y)
            if realism.delay:
                u, pending, command, pending_command = pending, d, pending_command, cmd
            else:
                u, command = d, cmd
            signals[:9] = [*y, *u]
        signals[9:] = plant.currents(x, u)
        ts.append(t)
        xs.append(x.copy())
        us.append(list(command))
        ss.append(list(signals))
        plant.between_steps(t, dt, x, u)
        x = rk4_sampled(plant, sensors, t, x, u, dt)
        plant.end_step(x)
        if abs(x[3]) > fall_limit:
            outcome = "fell"
            break
    signals[9:] = plant.currents(x, u)
    ts.append(len(ts) * dt)
    xs.append(x.copy())
    us.append(list(command))
    ss.append(list(signals))
    return PlanarRigRun(np.array(ts), np.array(xs), np.array(us), np.array(ss), outcome)
