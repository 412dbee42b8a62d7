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
