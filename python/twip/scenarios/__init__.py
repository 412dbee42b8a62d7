"""The thesis's scenarios, by name: `twip.scenarios.get("flat-lqr").run()`.

Each scenario is a plant, a controller designed for it, a reference schedule and a
duration, plus the thesis's own claims about it (for reports). `get` takes the robot
(`params=`), the controller's own robot when it differs from the plant
(`controller_params=`, for model-mismatch studies) and scenario options;
`robot_options(name, robot)` gives the options that put a robot file's motor into a
tracker.
"""
from twip.scenarios.registry import (  # noqa: F401
    MAX_TRIP_SECONDS,
    Scenario,
    get,
    is_planar,
    names,
    options,
    register,
    robot_options,
    trip_time,
)

# Each module registers its scenarios on import; none imports this package back.
from twip.scenarios import fuzzy, lqr, terrain, tracking  # noqa: E402,F401
