"""Shared fixtures: the default robot and random valid robots."""
import os
import signal

# NumPy's and SciPy's bundled OpenBLAS start a thread per core for every product and solve,
# and their threads spin while they wait. pytest's workers already fill the cores, and the
# tests' matrices are small: with one thread each, eight noisy fits of test_sysid's
# coverage test took 3.3 s of CPU against 8.0 s (loaded 2-core VM). Set before either
# library loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest

import twip

try:  # CI runs the property tests on fixed examples, so that a run can be repeated; a
    # developer's runs keep exploring new ones (and print the seed of a failure).
    from hypothesis import settings

    settings.register_profile("ci", derandomize=True)
    if os.environ.get("CI"):
        settings.load_profile("ci")
except ImportError:  # pragma: no cover - hypothesis is a test dependency
    pass

# A run started in the background by a shell (`make test &`) inherits SIGINT ignored, and
# so would the processes the Ctrl-C tests start and interrupt: give it Python's handler.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


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


def rel_diff(a, b):
    """Largest |a - b|, each entry relative to max(|b|, 1): relative for large entries, absolute near 0."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.max(np.abs(a - b) / np.maximum(np.abs(b), 1.0))


def max_energy_drift(model, x0, u, dt, t_final, step=twip.rk4_step):
    """Worst |E - E0| / |E0| sampled every 10 ms over [0, t_final] with the input u held, and the trajectory."""
    traj = run(model, x0, u, dt, round(t_final / dt), step)
    e = np.array([model.energy(x) for x in traj[:: max(1, round(0.01 / dt))]])
    return np.max(np.abs(e - e[0])) / abs(e[0]), traj


def run(model, x0, u, dt, n, step=twip.rk4_step):
    """The trajectory of n steps of `step` from x0 with the input held (n + 1 rows)."""
    x = np.array(x0, dtype=float)
    traj = [x]
    for _ in range(n):
        x = step(model, x, u, dt)
        traj.append(x)
    return np.array(traj)


def reference_rig_run(name, sc, realism, params, t_final):
    """Scenario `sc` (named `name`: a circle tracker or an LQR scenario) with `realism` in
    twip.reference's rigs, its controller rebuilt from the reference's parts."""
    import twip.reference as ref
    import twip.reference.planar_realism as rpr
    import twip.reference.realism as rr
    import twip.reference.tracking as rtr

    rrealism = rr.Realism.from_twip(realism, params)
    if name.startswith("circle-"):
        if name == "circle-pid":
            tracker = rtr.PidTracker.table_4_1(params, motor=rtr.DcMotor.gb37y3530())
        else:
            motor = rtr.DcMotor.gb37y3530()
            tracker = rtr.SmcTracker(ref.PlanarModel(params), rtr.thesis_gains(motor.torque_per_count()),
                                     fuzzy=name.endswith("fuzzy"), motor=motor, period=0.005, gamma=(0.05, 1000.0))
        return rpr.simulate(ref.PlanarModel(params), tracker, sc.x0, t_final, sc.dt,
                            rtr.Circle(sc.reference.radius, sc.reference.speed), rrealism)
    model = ref.SlopeModel(params, sc.model.slope)
    ctrl = ref.LqrController(model, sc.controller.gains, point=sc.controller.point, period=sc.controller.period)
    return rr.simulate(model, ctrl, sc.x0, t_final, sc.dt, ref.SpeedSchedule(sc.reference.legs), rrealism)


def part_parity(name, realism, params, **part_off):
    """2 s of scenario `name` with `realism` in the core's rig and the reference's, and with the
    part `part_off` turns off (it must change the run): (core run, reference run, worst relative
    state difference)."""
    from twip.scenarios import get

    sc = get(name)
    r = sc.run(realism=realism, t_final=2.0)
    without = sc.run(realism=realism.replace(**part_off), t_final=2.0)
    assert not np.array_equal(r.states, without.states), f"{part_off} changes nothing"
    run = reference_rig_run(name, sc, realism, params, 2.0)
    return r, run, rel_diff(r.states, run.states)
