"""Controllers written in Python run through the same Rust runner as the built-in ones:
the same run bit for bit when they compute the same law, realism included; clear errors
for a bad `u`; the exception of a failing controller with its traceback."""
from __future__ import annotations

import traceback

import numpy as np
import pytest

import twip
from twip import scenarios


class PythonLqr:
    """LqrController's law ((4.13) with integral action, gain order [phi, phi_dot,
    theta_dot, z]), written in Python."""

    def __init__(self, model, gains, period):
        self.model, self.k, self.period = model, np.asarray(gains, float).ravel(), period
        self.reset()

    def reset(self):
        self.z, self.cache, self.last_z = 0.0, None, 0.0

    def update(self, t, y, ref):
        speed = ref[1]
        if self.cache is None or self.cache[0] != speed:
            xs, us = self.model.equilibrium(speed)
            self.cache = (speed, xs[0], us)
        _, phi_s, u_s = self.cache
        error = y[3] - speed
        k = self.k
        u = u_s - (k[0] * (y[0] - phi_s) + k[1] * y[1] + k[2] * error) - k[3] * self.z
        self.last_z = self.z
        self.z += error * self.period
        return u

    def internals(self):
        return {"z": self.last_z}


@pytest.mark.parametrize("realism", [None, "thesis-like"])
def test_python_lqr_reproduces_the_builtin_run(realism):
    sc = scenarios.get("flat-lqr")
    options = {} if realism is None else {"realism": twip.Realism.thesis_like()}
    builtin = sc.run(**options)
    mine = PythonLqr(sc.model, sc.controller.gains, sc.controller.period)
    ours = twip.simulate(sc.model, mine, sc.x0, sc.t_final, sc.dt, reference=sc.reference, **options)
    assert ours.outcome == builtin.outcome == "completed"
    scale = np.max(np.abs(builtin.states))
    assert np.max(np.abs(ours.states - builtin.states)) <= 1e-12 * scale
    assert np.max(np.abs(ours.inputs - builtin.inputs)) <= 1e-12 * np.max(np.abs(builtin.inputs))
    for name, value in builtin.metrics.items():
        assert ours.metrics[name] == pytest.approx(value, rel=1e-12, abs=1e-15), name
    np.testing.assert_allclose(ours.internals["z"], builtin.internals["z"], rtol=0, atol=1e-15)
    if realism:  # the controller read the estimator's output, as the built-in one did
        np.testing.assert_array_equal(ours.measurements, builtin.measurements)


def test_reset_is_called_before_each_run_and_period_is_used():
    sc = scenarios.get("flat-lqr-sim")
    mine = PythonLqr(sc.model, sc.controller.gains, sc.controller.period)
    a = twip.simulate(sc.model, mine, sc.x0, 2.0, sc.dt, reference=sc.reference)
    b = twip.simulate(sc.model, mine, sc.x0, 2.0, sc.dt, reference=sc.reference)  # z starts at 0 again
    np.testing.assert_array_equal(a.states, b.states)
    calls = []
    twip.simulate(sc.model, lambda t, y, r: calls.append(t) or 0.0, [0.0] * 4, 0.1, 1e-3, control_period=5e-3)
    assert len(calls) == 20 and calls[1] == pytest.approx(5e-3)


def _planar_balance_gains(model, v):
    """LQR on the planar model's [phi, phi_dot, v, omega] subsystem, linearised by central
    differences of `deriv` about upright travel at speed v."""
    x0, h = np.array([0, 0, 0, 0, 0, v, 0.0]), 1e-6
    rows = [3, 4, 5, 6]
    a = np.zeros((4, 4))
    b = np.zeros((4, 2))
    for j, i in enumerate(rows):
        dx = np.zeros(7)
        dx[i] = h
        a[:, j] = (model.deriv(x0 + dx, [0, 0])[rows] - model.deriv(x0 - dx, [0, 0])[rows]) / (2 * h)
    for j in range(2):
        du = np.zeros(2)
        du[j] = h
        b[:, j] = (model.deriv(x0, du)[rows] - model.deriv(x0, -du)[rows]) / (2 * h)
    # Integral action on the speed error: the fifth state z' = v - v_ref.
    a5 = np.zeros((5, 5))
    a5[:4, :4], a5[4, 2] = a, 1.0
    b5 = np.vstack([b, np.zeros((1, 2))])
    k, _, _ = twip.lqr(a5, b5, np.diag([10.0, 1.0, 1.0, 0.2, 1.0]), np.diag([1.0, 1.0]))
    return k


def test_python_tracker_runs_on_the_planar_model():
    model = twip.PlanarModel(twip.RobotParams.balanbot())
    circle = twip.Circle(radius=0.6, speed=0.2)
    k = _planar_balance_gains(model, 0.2)

    class SpeedAndYaw:
        period = 5e-3

        def __init__(self):
            self.z = 0.0

        def reset(self):
            self.z = 0.0

        def update(self, t, y, ref):  # ref: x, y, psi, v, omega, v_dot, omega_dot
            error = np.array([y[3], y[4], y[5] - ref[3], y[6] - ref[4], self.z])
            self.z += (y[5] - ref[3]) * self.period
            return -k @ error

        def internals(self):
            return {"z_speed": self.z}

    x0 = [0.6, 0.0, np.pi / 2, 0.0, 0.0, 0.2, 0.2 / 0.6]
    r = twip.simulate(model, SpeedAndYaw(), x0, 10.0, 1e-3, reference=circle)
    assert r.outcome == "completed" and r.inputs.shape[1] == 2
    late = r.t > 5.0
    assert np.mean(np.abs(r.states[late, 5] - 0.2)) < 0.02  # it drives at the circle's speed
    assert np.mean(np.abs(r.states[late, 6] - 0.2 / 0.6)) < 0.02  # and turns at its rate
    assert set(r.internals) == {"z_speed"}


def test_bad_inputs_name_the_time_and_value():
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    run = lambda c: twip.simulate(model, c, [0.05, 0, 0, 0], 1.0, 1e-3, control_period=1e-3)  # noqa: E731
    with pytest.raises(twip.NonFiniteError, match=r"u = \[NaN\] at t = 0 s"):
        run(lambda t, y, r: float("nan"))
    with pytest.raises(twip.ShapeError, match=r"u = \[1.0, 2.0\] \(2 numbers\) at t = 0 s"):
        run(lambda t, y, r: [1.0, 2.0])
    with pytest.raises(TypeError, match="u = hello"):
        run(lambda t, y, r: "hello")
    with pytest.raises(twip.ShapeError, match=r"shape \[3\]"):
        run(lambda t, y, r: np.zeros(3))
    run(lambda t, y, r: np.zeros((1, 1)))  # one value in any shape is fine
    with pytest.raises(TypeError, match="no `period`"):
        run_obj = type("NoPeriod", (), {"update": lambda self, t, y, r: 0.0})()
        twip.simulate(model, run_obj, [0.0] * 4, 1.0, 1e-3)
    with pytest.raises(TypeError, match="a callable f"):
        run(object())


def test_an_exception_propagates_with_its_traceback():
    model = twip.SlopeModel(twip.RobotParams.balanbot())
    seen = []

    def controller(t, y, ref):
        seen.append(t)
        if t >= 0.5:
            raise KeyError("my bug")
        return 0.0

    with pytest.raises(KeyError, match="my bug") as info:
        twip.simulate(model, controller, [0.0] * 4, 10.0, 1e-3, control_period=1e-2)
    assert "controller" in "".join(traceback.format_tb(info.value.__traceback__))
    assert max(seen) == pytest.approx(0.5)  # no call after the failing one


def _python_lqr_scenario():
    sc = scenarios.get("flat-lqr-sim")
    return sc, sc.replace(controller=PythonLqr(sc.model, sc.controller.gains, sc.controller.period))


def test_a_python_controller_sweep_is_the_same_on_any_number_of_workers_and_resumed(tmp_path):
    sc, mine = _python_lqr_scenario()
    perturb = {"m_body": twip.Uniform(rel=0.2), "phi0": twip.Normal(std=0.05)}
    one = twip.montecarlo(mine, 12, perturb=perturb, seed=3, threads=1, progress=False)
    two = twip.montecarlo(mine, 12, perturb=perturb, seed=3, threads=2, progress=False)
    assert one.kernel == "python" and one.metric_names == twip.montecarlo(sc, 2, progress=False).metric_names
    for name in one.metric_names:
        np.testing.assert_array_equal(one.metrics[name], two.metrics[name])
    twip.montecarlo(mine, 12, perturb=perturb, seed=3, threads=2, progress=False, checkpoint=tmp_path, shard_size=5)
    resumed = twip.montecarlo(mine, 12, perturb=perturb, seed=3, threads=2, progress=False, checkpoint=tmp_path,
                              shard_size=5)
    for name in one.metric_names:
        np.testing.assert_array_equal(one.metrics[name], resumed.metrics[name])
    # The same law as the built-in LQR (whose lane kernel fuses multiply-adds): the same metrics to rounding.
    builtin = twip.montecarlo(sc, 12, perturb=perturb, seed=3, progress=False)
    np.testing.assert_allclose(one.metrics["mean_abs_pitch_error"], builtin.metrics["mean_abs_pitch_error"], rtol=1e-9)


EDITED_LAW = """
SCALE = {scale}


class Damped:
    def __init__(self, gains, period):
        self.k, self.period = list(gains), period

    def reset(self):
        pass

    def update(self, t, y, ref):
        return -SCALE * (self.k[0] * y[0] + self.k[1] * y[1])
"""

EDITED_RUN = """
import sys, twip
sys.path.insert(0, {folder!r})
from law import Damped
sc = twip.scenarios.get("flat-lqr-sim", t_final=1.0)
mine = sc.replace(controller=Damped(sc.controller.gains, sc.controller.period))
kw = dict(perturb={{"phi0": twip.Normal(std=0.02)}}, seed=2, progress=False, shard_size=4)
r = twip.montecarlo(mine, 8, checkpoint={checkpoint!r}, **kw)
print(float(r.metrics["mean_abs_pitch_error"].sum()))
"""


def test_a_checkpoint_of_a_python_controller_is_not_resumed_after_its_code_changed(tmp_path):
    # A pickle holds the controller's state, not its code: the checkpoint's fingerprint
    # once missed an edit of the law and resumed the old law's shards.
    import os
    import shutil
    import subprocess
    import sys

    law, folder = tmp_path / "law.py", tmp_path / "ck"

    def run():
        script = EDITED_RUN.format(folder=str(tmp_path), checkpoint=str(folder))
        # No bytecode cache: an edit within the same second, of the same size, would run the old law.
        env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, env=env)

    law.write_text(EDITED_LAW.format(scale=1.0))
    before = run()
    assert before.returncode == 0, before.stderr[-2000:]
    law.write_text(EDITED_LAW.format(scale=0.5))
    again = run()
    assert again.returncode != 0 and "differs in: controller" in again.stderr, (again.stdout, again.stderr[-2000:])
    shutil.rmtree(folder)
    after = run()
    assert after.returncode == 0 and after.stdout != before.stdout, (before.stdout, after.stdout)


def test_an_unpicklable_controller_is_refused_before_any_sample_runs():
    sc = scenarios.get("flat-lqr-sim")
    calls = []
    with pytest.raises(twip.InvalidParameterError, match="cannot be pickled"):
        twip.montecarlo(sc.replace(controller=lambda t, y, r: calls.append(t) or 0.0), 4, progress=False)
    assert calls == []


class LostOnLoad:
    """Pickles, but its copy cannot be rebuilt (a handle to hardware, say)."""

    def __init__(self):
        self.period = 0.005

    def update(self, t, y, ref):
        return 0.0

    def __setstate__(self, state):
        raise RuntimeError("cannot reopen /dev/ttyUSB0")


def test_a_controller_whose_pickle_cannot_be_loaded_is_refused_by_name():
    # Its bare RuntimeError surfaced from the sweep's first run, naming neither the
    # controller nor the pickling.
    sc = scenarios.get("flat-lqr-sim")
    with pytest.raises(twip.InvalidParameterError,
                       match=r"is pickled but its copy cannot be loaded \(RuntimeError: cannot reopen /dev/ttyUSB0\)"):
        twip.montecarlo(sc.replace(controller=LostOnLoad()), 4, progress=False)


SCRIPT = """
import sys, twip
sys.path.insert(0, {tests!r})
from test_user_controller import PythonLqr
sc = twip.scenarios.get("flat-lqr-sim")
mine = sc.replace(controller=PythonLqr(sc.model, sc.controller.gains, sc.controller.period))
print("started", flush=True)
try:
    r = twip.montecarlo(mine, {n}, perturb={{"m_body": twip.Uniform(rel=0.2)}}, seed=5, progress=False,
                        checkpoint={folder!r}, shard_size=50)
    print("done", r.n, float(r.metrics["mean_abs_pitch_error"].sum()))
except KeyboardInterrupt as stop:
    print("interrupted", stop.partial.n)
"""


def test_ctrl_c_stops_a_python_controller_sweep_and_it_resumes(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    tests = os.path.dirname(os.path.abspath(__file__))
    script = tmp_path / "sweep.py"
    script.write_text(SCRIPT.format(tests=tests, n=4000, folder=str(tmp_path / "ck")))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "started"
    deadline = time.monotonic() + 120  # a loaded machine: wait for the first shard, not a fixed time
    while not list((tmp_path / "ck").glob("shard-*.npz")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    assert out.startswith("interrupted"), out
    kept = int(out.split()[1])
    assert 0 < kept < 4000
    assert len(list((tmp_path / "ck").glob("shard-*.npz"))) >= kept // 50


def test_a_sweep_runs_a_python_controller_whose_own_model_has_friction_as_given():
    """Each sample runs a copy of the controller unpickled in a worker: the copy's own model
    keeps its gearhead friction (pickling a SlopeModel once dropped it, so every sample's
    controller aimed at the frictionless steady state and no sample matched its replay)."""
    sc = scenarios.get("flat-lqr-sim", t_final=1.0)
    rough = twip.SlopeModel(sc.model.params, sc.model.slope, twip.Friction.gb37())
    assert rough.equilibrium(3.0)[1] != sc.model.equilibrium(3.0)[1], "friction moves the steady input"
    mine = sc.replace(controller=PythonLqr(rough, sc.controller.gains, sc.controller.period))
    r = twip.montecarlo(mine, 4, perturb={"m_body": twip.Uniform(rel=0.2)}, seed=2, progress=False, threads=2)
    assert r.kernel == "python"
    for i in range(4):
        assert r.replay(i).metrics["mean_abs_speed_error"] == r.metrics["mean_abs_speed_error"][i], i


class Leaky:
    """A PD law with an integral and no reset(): one object run twice starts the second run
    from the first one's integral."""

    def __init__(self, gains, period):
        self.k, self.period, self.z = list(gains), period, 0.0

    def update(self, t, y, ref):
        self.z += y[0] * self.period
        return -(self.k[0] * y[0] + self.k[1] * y[1] + self.k[2] * (y[3] - ref[1])) - 5.0 * self.z


def test_a_checkpointed_sweep_runs_the_controller_as_given_and_leaves_it_alone(tmp_path):
    # The shard size of a checkpointed sweep is timed on one run, which ran the user's own
    # object: its integral was left at 0.017, and every sample (pickled after it) started
    # there; the in-memory sweep's metrics differed by 2-5x.
    sc = scenarios.get("flat-lqr-sim", t_final=1.0)
    kw = dict(perturb={"phi0": twip.Normal(std=0.02)}, seed=2, progress=False, threads=1)
    memory = twip.montecarlo(sc.replace(controller=Leaky(sc.controller.gains, sc.controller.period)), 6, **kw)
    mine = sc.replace(controller=Leaky(sc.controller.gains, sc.controller.period))
    stored = twip.montecarlo(mine, 6, checkpoint=tmp_path, **kw)
    assert mine.controller.z == 0.0
    for name in memory.metric_names:
        np.testing.assert_array_equal(memory.metrics[name], stored.metrics[name], err_msg=name)


class WithSet(Leaky):
    """Holds a set of strings, which pickles in the process's hash order."""

    def __init__(self, gains, period):
        super().__init__(gains, period)
        self.logged = {"phi", "phi_dot", "theta_dot", "speed", "pitch_error", "z"}


RESUME = """
import sys, twip
sys.path.insert(0, {tests!r})
from test_user_controller import WithSet
sc = twip.scenarios.get("flat-lqr-sim", t_final=0.3)
mine = sc.replace(controller=WithSet(sc.controller.gains, sc.controller.period))
r = twip.montecarlo(mine, 8, perturb={{"phi0": twip.Normal(std=0.02)}}, seed=1, progress=False,
                    checkpoint={folder!r}, shard_size=4)
print(r.n, float(r.metrics["mean_abs_pitch_error"].sum()))
"""


def test_a_checkpoint_of_a_controller_holding_a_set_resumes_in_another_process(tmp_path):
    # A set of strings pickles in the hash order each process draws anew: the fingerprint
    # changed with PYTHONHASHSEED, and the resume was refused ("differs in: controller").
    import os
    import subprocess
    import sys

    tests = os.path.dirname(os.path.abspath(__file__))
    script = RESUME.format(tests=tests, folder=str(tmp_path / "ck"))
    outs = []
    for seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, env=env)
        assert proc.returncode == 0, proc.stderr[-2000:]
        outs.append(proc.stdout)
    assert outs[0] == outs[1]


CELL = """
class Cell:
    def __init__(self, k, period):
        self.k, self.period = list(k), period

    def update(self, t, y, ref):
        return -(self.k[0] * y[0] + {scale} * self.k[1] * y[1])
"""


def test_a_notebooks_controller_keeps_its_fingerprint_in_a_new_session(monkeypatch):
    # A notebook's classes have no source file: their bytecode was hashed with the cell's
    # file name, which names the kernel's session (/tmp/ipykernel_<pid>/...), so a checkpoint
    # was refused on resume after a restart. An edit of the law still changes it.
    import sys
    import types

    from twip import user_sweep

    def fingerprint(session, scale=1.0):
        module = types.ModuleType("notebook_cells")  # as a notebook's __main__: no __file__
        monkeypatch.setitem(sys.modules, "notebook_cells", module)
        exec(compile(CELL.format(scale=scale), f"/tmp/ipykernel_{session}/2941.py", "exec"), module.__dict__)
        return user_sweep.fingerprint(module.Cell([1.0, 2.0], 0.005))

    assert fingerprint(1111) == fingerprint(2222)
    assert fingerprint(1111) != fingerprint(1111, scale=0.5)


def test_a_function_controllers_fingerprint_follows_its_code(tmp_path, monkeypatch):
    # A plain function pickles by name: its body was in no fingerprint, and a checkpoint
    # resumed after an edit of the law mixed the old law's shards with the new one's.
    import functools
    import importlib
    import sys

    from twip import user_sweep

    monkeypatch.syspath_prepend(str(tmp_path))
    law = tmp_path / "edited_law.py"
    law.write_text("def law(t, y, ref, gain=1.0):\n    return -gain * (-11.0 * y[0] - 1.7 * y[1])\n")
    module = importlib.import_module("edited_law")
    monkeypatch.setitem(sys.modules, "edited_law", module)
    before = [user_sweep.fingerprint(module.law), user_sweep.fingerprint(functools.partial(module.law, gain=2.0))]
    law.write_text("def law(t, y, ref, gain=1.0):\n    return -gain * (-5.5 * y[0] - 1.7 * y[1])\n")
    module = importlib.reload(module)
    after = [user_sweep.fingerprint(module.law), user_sweep.fingerprint(functools.partial(module.law, gain=2.0))]
    assert before[0] != after[0] and before[1] != after[1]
    assert before[0].startswith("python:edited_law.law:")
