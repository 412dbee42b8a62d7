"""Shared fixtures: the default robot and random valid robots."""
import numpy as np
import pytest

import twip


@pytest.fixture
def balanbot():
    return twip.RobotParams.balanbot()


def random_params(rng: np.random.Generator, frictionless: bool = False) -> "twip.RobotParams":
    """A physically plausible robot, each field scaled by a factor in [0.5, 2]."""
    base = twip.RobotParams.balanbot().to_dict()
    changes = {k: v * rng.uniform(0.5, 2.0) for k, v in base.items() if k != "g"}
    if frictionless:
        changes.update(mu_bearing=0.0, mu_ground=0.0)
    return twip.RobotParams.balanbot().replace(**changes)


def frictionless(p):
    return p.replace(mu_bearing=0.0, mu_ground=0.0)


def run(model, x0, u, dt, n, step=twip.rk4_step):
    """The trajectory of n steps of `step` from x0 with the input held (n + 1 rows)."""
    x = np.array(x0, dtype=float)
    traj = [x]
    for _ in range(n):
        x = step(model, x, u, dt)
        traj.append(x)
    return np.array(traj)
