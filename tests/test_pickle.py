"""Every value class of twip._core pickles and copies to an object that behaves as the
original (same repr, same numbers bit for bit, the same simulation), and a SweepResult
survives pickling and a process pool with its replay and rerun."""
import concurrent.futures
import copy
import math
import multiprocessing
import pickle

import numpy as np
import pytest

import twip
from twip import _core

P = twip.RobotParams.balanbot()
FLAT = twip.SlopeModel(P)
PLANAR = twip.PlanarModel(P)

#: Classes of twip._core that deliberately do not pickle, each with the reason. Every
#: class of the core holds settings, a model, a controller, a reference or a realism part,
#: so none is here; a result or handle class added later belongs here (with the TypeError
#: it raises) or in SAMPLES.
#: The envs' native batches hold N robots mid-episode (their rigs' noise streams and clocks):
#: an env is rebuilt from its settings and seed, not pickled.
UNPICKLABLE = {}


def _unpicklable_batches():
    from twip import envs

    for env in (envs.BalanceVectorEnv, envs.TrackVectorEnv):
        batch = env(2).settings.batch(2)
        name = type(batch).__name__
        UNPICKLABLE[name] = (batch, f"cannot pickle 'twip._core.{name}' object")


_unpicklable_batches()


def _sc2():
    return twip.scenarios.get("flat-lqr-sim", t_final=0.5)


def _sc3():
    return twip.scenarios.get("circle-pid", laps=0.02)


def run2(**parts):
    """States of a short 2-DOF run (flat-lqr-sim) with some of its parts replaced."""
    sc, realism = _sc2(), parts.pop("realism", None)
    return sc.replace(**parts).run(realism=realism).states


def run3(**parts):
    """States of a short 3-DOF run (circle-pid) with some of its parts replaced."""
    sc, realism = _sc3(), parts.pop("realism", None)
    return sc.replace(**parts).run(realism=realism).states


TIMES = np.linspace(0.0, 40.0, 23)
XS = np.linspace(-2.0, 2.0, 17)


def path_probe(r):
    return [[list(r.sample(t).values()) for t in TIMES], [r.distance(0.3 * t, -0.1 * t) for t in TIMES], run3(reference=r)]


#: Per class: instances that differ from each other in what the probe sees.
SAMPLES = {
    "RobotParams": [P, P.replace(m_body=1.7, wheel_radius=0.0331)],
    "SlopeModel": [FLAT, twip.SlopeModel(P, 0.2, friction=twip.Friction.gb37())],
    "PlanarModel": [PLANAR, twip.PlanarModel(P, friction=twip.Friction(0.01, stick_speed=0.1)),
                    twip.PlanarModel(P, terrain=twip.Terrain.plane(0.1, 0.5))],
    "Terrain": [twip.Terrain.plane(0.1, 0.5), twip.Terrain.ramp(0.2, 1.0, start=0.01, blend=0.02),
                twip.Terrain.bumps(0.04, 1.0),
                twip.Terrain.grid([-1.0, 0.0, 1.0], [-1.0, 0.5, 1.0], [[0.0, 0.1, 0.0], [0.02, 0.0, 0.05], [0.0, 0.0, 0.1]])],
    "GradeFeedForward": [twip.GradeFeedForward(twip.PidTracker.table_4_1(P), twip.Terrain.plane(0.1, 0.5), P),
                         twip.GradeFeedForward(twip.scenarios.get("circle-smc", laps=0.02).controller,
                                               twip.Terrain.bumps(0.04, 1.0), P.replace(m_body=1.7))],
    "Friction": [twip.Friction.gb37(), twip.Friction.gb37_beside(0.003).with_stick(0.1),
                 twip.Friction(0.02, breakaway=0.03, viscous=1e-3)],
    "DcMotor": [twip.DcMotor.gb37y3530(), twip.DcMotor.gb37y3530(supply=7.4),
                twip.DcMotor(1.9, 0.017, 30.0, friction=1e-6)],
    "Trapezoid": [twip.Trapezoid(-1.0, -0.5, 0.1, 0.7), twip.Trapezoid(-0.3, 0.0, 0.0, 1.0 / 3.0)],
    "Triangle": [twip.Triangle(-1.0, 0.0, 1.0), twip.Triangle(-0.1, 0.2, 0.7)],
    "Gaussian": [twip.Gaussian(0.0, 0.5), twip.Gaussian(0.1, 1.0 / 7.0)],
    "FuzzyBasis": [twip.FuzzyBasis.default(),
                   twip.FuzzyBasis([[twip.Gaussian(0.0, 0.3), twip.Triangle(-1.0, 0.0, 1.0)], [twip.Gaussian(0.1, 0.2)]])],
    "FuzzyController": [
        twip.scenarios.get("flat-fuzzy-sim", t_final=0.5).controller,
        twip.FuzzyController.thesis_flat(FLAT, gamma=3.0, ki=0.01, s0=np.linspace(-0.3, 0.3, 9)),
        twip.FuzzyController(twip.SlopeModel(P.replace(m_body=1.3)), 30.0, 33.0, -0.1, -0.9, adapt=False,
                             sets=[[twip.Gaussian(-0.2, 0.1), twip.Gaussian(0.0, 0.1), twip.Gaussian(0.2, 0.1)],
                                   [twip.Triangle(-9.0, -3.0, 0.0), twip.Triangle(-1.0, 0.0, 1.0), twip.Triangle(0.0, 3.0, 9.0)]],
                             s0=[0.1] * 9),
    ],
    "LqrController": [
        _sc2().controller,
        twip.LqrController(FLAT, [-60.0, -5.0, -0.3, -1.0 / 3.0], point="thesis"),
        twip.LqrController.design(FLAT, math.radians(90), [100.0, 1.0, 1.0, 10.0], 7.0, period=0.002),
    ],
    "PidTracker": [_sc3().controller, twip.PidTracker(P, gains={"kp_pitch": 27.1}, units="si"),
                   twip.PidTracker(P.replace(half_track=0.11), units={"pitch": 50.0}, motor=twip.DcMotor.gb37y3530(12.6))],
    "SmcTracker": [twip.scenarios.get("circle-smc", laps=0.02).controller,
                   twip.scenarios.get("circle-smc-fuzzy", laps=0.02).controller,
                   twip.SmcTracker(PLANAR, fuzzy=True, boundary_layer=(0.3, 0.1), gamma=(0.07, 900.0), leakage=0.01,
                                   motor_limits=False, pitch_offset=False)],
    "SpeedSchedule": [_sc2().reference, twip.SpeedSchedule.constant(math.radians(100)),
                      twip.SpeedSchedule.go_and_return(0.7, 2.9, 0.0335, hold=1.3)],
    "Circle": [_sc3().reference, twip.Circle(0.7, 0.21, direction="cw", phase=0.3),
               twip.Circle(1.1, 0.1, centre=(0.2, -1.0), direction=-1)],
    "Line": [twip.Line(0.2), twip.Line(0.15, heading=0.3, start=(0.1, -0.2))],
    "FigureEight": [twip.FigureEight(0.8, 40.0), twip.FigureEight(1.3, 33.3, centre=(0.1, 0.2))],
    "Waypoints": [twip.Waypoints([(0, 0), (1, 0), (1, 1)], 0.2),
                  twip.Waypoints([(0, 0), (0.5, 0.1), (1.0, 0.9), (0.2, 1.3)], 0.17, corner_radius=0.13)],
    "Imu": [twip.Imu.data_sheet(), twip.Imu.thesis_like(),
            twip.Imu(dlpf_hz=20.0, gyro_noise=1e-4, accel_bias=(0.01, -0.02), gyro_range_dps=500.0, sample_rate=500.0)],
    "Dlpf": [twip.Dlpf.mpu6050(42.0), twip.Dlpf.mpu6050(20.0, "accel", 997.0), twip.Dlpf(30.0, 0.011)],
    "TiltEstimator": [twip.TiltEstimator.complementary(), twip.TiltEstimator.complementary(0.37),
                      twip.TiltEstimator.kalman(), twip.TiltEstimator.kalman(2e-3, 3e-6, 0.3)],
    "MotorDriver": [twip.MotorDriver.data_sheet(), twip.MotorDriver.thesis_like(),
                    twip.MotorDriver(battery=12.2, resistance=1.9, assumed_battery=11.1, current_limit=1.5)],
    "Push": [twip.Push(0.2, 0.3), twip.Push(0.25, -0.4, height=0.05)],
    "Force": [twip.Force(0.4), twip.Force(-0.3, 1.0, height=0.02)],
    "Realism": [
        twip.Realism.thesis_like(),
        twip.Realism(imu=twip.Imu.data_sheet(), estimator="kalman", encoder_cpr=2797.0, delay=True, seed=7, stream=3),
        twip.Realism(motor=twip.MotorDriver.thesis_like(), pushes=[(0.1, 0.2)], force=twip.Force(0.1),
                     friction=twip.Friction.gb37(), backlash=0.01, control_period=0.005),
        twip.Realism(slope_profile=[(0.01, 0.05), (0.02, -0.01)], pushes=[twip.Push(0.3, 0.1, 0.2)]),
    ],
}

#: Per class: what a copy must reproduce bit for bit (values, arrays, simulated states).
PROBES = {
    "RobotParams": lambda p: [list(p.to_dict().values()), run2(model=twip.SlopeModel(p))],
    "SlopeModel": lambda m: [m.deriv([0.1, -0.2, 0.3, 2.0], 0.4), m.linearize([0.0] * 4), run2(model=m)],
    "PlanarModel": lambda m: [m.deriv([0.0, 0.0, 0.1, 0.05, 0.1, 0.2, 0.3], [0.1, -0.05]), run3(model=m)],
    "Friction": lambda f: [[f.torque(w) for w in XS], run2(model=twip.SlopeModel(P, friction=f))],
    "DcMotor": lambda m: [[m.torque(v, w) for v in XS for w in XS], run3(controller=twip.PidTracker(P, motor=m))],
    "Trapezoid": lambda s: [s(XS)],
    "Triangle": lambda s: [s(XS)],
    "Gaussian": lambda s: [s(XS)],
    "FuzzyBasis": lambda b: [b.eval(np.stack([XS] * b.n_inputs, axis=1) * 0.3)],
    "FuzzyController": lambda c: [run2(controller=c)],
    "LqrController": lambda c: [run2(controller=c)],
    "PidTracker": lambda c: [run3(controller=c)],
    "Terrain": lambda t: [[t.local(x, 0.3 * x) for x in XS / 2], run3(model=twip.PlanarModel(P, terrain=t))],
    "GradeFeedForward": lambda c: [run3(model=twip.PlanarModel(P, terrain=c.terrain), controller=c)],
    "SmcTracker": lambda c: [c.weights, run3(controller=c)],
    "SpeedSchedule": lambda s: [[s.sample(t) for t in TIMES], run2(reference=s)],
    "Circle": path_probe,
    "Line": path_probe,
    "FigureEight": path_probe,
    "Waypoints": path_probe,
    "Imu": lambda i: [run2(realism=twip.Realism(imu=i, seed=1))],
    "Dlpf": lambda f: [f.filter(np.sin(np.arange(200) * 0.05))],
    "TiltEstimator": lambda e: [e.filter(np.full(50, 0.3), np.full(50, 9.8), np.full(50, 0.01), 1e-3),
                                run2(realism=twip.Realism(imu=twip.Imu.thesis_like(), estimator=e))],
    "MotorDriver": lambda d: [run2(realism=twip.Realism(motor=d))],
    "Push": lambda p: [run2(realism=twip.Realism(pushes=[p]))],
    "Force": lambda f: [run2(realism=twip.Realism(force=f))],
    # A slope profile is for the 2-DOF model (the 3-DOF one is on flat ground).
    "Realism": lambda r: [run2(realism=r), None if r.slope_profile else run3(realism=r)],
}

COPIES = {
    "pickle": lambda x: pickle.loads(pickle.dumps(x)),
    "copy": copy.copy,
    "deepcopy": copy.deepcopy,
}


def bits(value):
    """`value` as bytes, exact to the bit (floats, arrays, nested lists and tuples)."""
    if isinstance(value, dict):
        return b"{" + b"".join(bits(k) + bits(v) for k, v in value.items()) + b"}"
    if isinstance(value, (list, tuple)):
        return b"[" + b"".join(bits(v) for v in value) + b"]"
    return np.asarray(value).tobytes() + str(np.asarray(value).dtype).encode()


def pickled(obj):
    """What pickle stores of `obj`, with every number as its bits (pickle's own bytes also
    depend on which objects the arrays share, such as their dtypes)."""
    if isinstance(obj, (dict, list, tuple)):
        return type(obj).__name__, [pickled(v) for v in (obj.items() if isinstance(obj, dict) else obj)]
    if obj is None or isinstance(obj, (str, bool, int, float, complex, np.ndarray, np.generic)):
        return obj if isinstance(obj, str) else bits(obj)
    make, args, *state = obj.__reduce__()
    return getattr(make, "__qualname__", make), pickled(args), pickled(state)


def core_classes():
    return sorted(n for n in dir(_core) if isinstance(getattr(_core, n), type)
                  and not issubclass(getattr(_core, n), BaseException))


def test_every_core_class_pickles_or_is_refused_on_purpose():
    """A new class of the core needs SAMPLES and PROBES here, or a place in UNPICKLABLE."""
    classes = set(core_classes())
    assert classes == set(SAMPLES) | set(UNPICKLABLE), (classes - set(SAMPLES) - set(UNPICKLABLE),
                                                         set(SAMPLES) - classes)
    assert not set(SAMPLES) & set(UNPICKLABLE)
    assert set(PROBES) == set(SAMPLES)
    for name, objs in SAMPLES.items():
        assert len(objs) >= 2 and all(type(o) is getattr(_core, name) for o in objs), name
    # UNPICKLABLE maps a class name to (an instance, the TypeError's message).
    for obj, message in UNPICKLABLE.values():
        with pytest.raises(TypeError, match=message):
            pickle.dumps(obj)


CASES = [(name, i) for name, objs in SAMPLES.items() for i in range(len(objs))]


class Probes(dict):
    """Each sample's probe, computed once when first asked for."""

    def __missing__(self, case):
        name, i = case
        self[case] = bits(PROBES[name](SAMPLES[name][i]))
        return self[case]


@pytest.fixture(scope="module")
def probes():
    return Probes()


@pytest.mark.parametrize("how", sorted(COPIES))
@pytest.mark.parametrize("name,i", CASES, ids=[f"{n}{i}" for n, i in CASES])
def test_copy_behaves_as_the_original(name, i, how, probes):
    obj = SAMPLES[name][i]
    twin = COPIES[how](obj)
    assert type(twin) is type(obj)
    assert twin is not obj
    assert repr(twin) == repr(obj)
    assert pickled(twin) == pickled(obj)  # every number it pickles, bit for bit
    assert bits(PROBES[name](twin)) == probes[(name, i)]


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_probes_tell_the_samples_apart(name, probes):
    """A probe sees what differs between two objects of a class (so the test above can fail)."""
    seen = [probes[(name, i)] for i in range(len(SAMPLES[name]))]
    assert len(set(seen)) == len(seen), name


def test_models_keep_their_friction():
    for model in (SAMPLES["SlopeModel"][1], SAMPLES["PlanarModel"][1]):
        twin = pickle.loads(pickle.dumps(model))
        assert twin.friction == model.friction and twin.friction is not None


def test_lqr_keeps_its_design_info():
    designed, given = SAMPLES["LqrController"][2], SAMPLES["LqrController"][1]
    twin = pickle.loads(pickle.dumps(designed))
    info, copied = designed.design_info, twin.design_info
    assert sorted(copied) == sorted(info) and bits([copied[k] for k in info]) == bits(list(info.values()))
    assert pickle.loads(pickle.dumps(given)).design_info is None
    with pytest.raises(twip.InvalidParameterError, match="already has its design_info"):
        designed.__setstate__({"A": 1})
    assert designed.design_info["poles"] is not None


def test_controllers_pickle_their_configuration_not_a_run():
    """A controller object holds no run state: after a run, it (and its pickle) runs as it
    did before; the fuzzy controller's starting weights s0 and the fuzzy SMC's fresh
    weights are settings and come along."""
    fuzzy = SAMPLES["FuzzyController"][1]
    first = run2(controller=fuzzy)
    twin = pickle.loads(pickle.dumps(fuzzy))
    assert bits(twin.s0) == bits(fuzzy.s0) and any(twin.s0)
    assert bits(run2(controller=twin)) == bits(first) == bits(run2(controller=fuzzy))
    smc = SAMPLES["SmcTracker"][1]
    first = run3(controller=smc)
    twin = copy.deepcopy(smc)
    assert bits(twin.weights) == bits(smc.weights) and not np.any(twin.weights[0])
    assert bits(run3(controller=twin)) == bits(first)


@pytest.mark.parametrize("name", [n for n in dir(_core) if isinstance(getattr(_core, n), type)
                                  and issubclass(getattr(_core, n), BaseException)])
def test_errors_pickle(name):
    """A worker's error comes back through a process pool as itself."""
    err = getattr(_core, name)("m_body = -1: must be > 0")
    twin = pickle.loads(pickle.dumps(err))
    assert type(twin) is type(err) and twin.args == err.args


def test_unpickling_validates():
    """Unpickling goes through the constructor: a doctored pickle is refused by name."""
    make, (settings,) = twip.Circle(0.5, 0.2).__reduce__()
    settings["radius"] = -0.5
    with pytest.raises(twip.InvalidParameterError, match="radius"):
        make(settings)
    make, args = twip.SpeedSchedule.constant(1.0).__reduce__()
    with pytest.raises(twip.InvalidParameterError, match="speed"):
        make([(1.0, -2.0, 0.0)])


# --- sweep results ----------------------------------------------------------------------------------

SWEEPS = {
    "lqr": lambda: twip.montecarlo("flat-lqr-sim", 8, perturb={"m_body": twip.Uniform(rel=0.2)},
                                   options={"t_final": 1.0}, progress=False),
    "fuzzy": lambda: twip.montecarlo("flat-fuzzy-sim", 6, perturb={"m_body": twip.Uniform(rel=0.2)},
                                     options={"t_final": 1.0}, progress=False),
    "tracking": lambda: twip.montecarlo("circle-pid", 4, perturb={"m_body": twip.Uniform(rel=0.2)},
                                        options={"laps": 0.05}, progress=False),
    "realism": lambda: twip.montecarlo("flat-lqr-sim", 6, perturb={"m_body": twip.Uniform(rel=0.2)},
                                       options={"t_final": 1.0}, realism=twip.Realism.thesis_like(), progress=False),
}


@pytest.fixture(scope="module", params=sorted(SWEEPS))
def sweep(request):
    return SWEEPS[request.param]()


def test_sweep_result_pickles(sweep):
    twin = pickle.loads(pickle.dumps(sweep))
    assert type(twin) is type(sweep)
    assert sorted(twin.metrics) == sorted(sweep.metrics)
    assert bits(twin.metrics) == bits(sweep.metrics)
    assert repr(twin) == repr(sweep)
    assert repr(twin.summary()) == repr(sweep.summary())  # repr: a NaN quantile equals itself
    for i in (0, sweep.n - 1):
        assert bits(twin.rerun(i)) == bits(sweep.rerun(i))
        assert bits(twin.replay(i).states) == bits(sweep.replay(i).states)
        assert bits(twin.sample(i)[2]) == bits(sweep.sample(i)[2])


def test_a_sweep_result_another_twip_made_refuses_every_way_back_to_a_sample(sweep):
    """A result pickled (or checkpointed) by another twip: its `rerun` said "bit for bit the
    sweep's" and ran this twip's numbers, whose draws and kernels may have changed since."""
    older = pickle.loads(pickle.dumps(sweep))
    older.config = {**older.config, "twip": "0.0.1"}
    for way_back in (older.rerun, older.replay, older.sample, lambda i: older.drawn(older.config["perturb"][0], [i])):
        with pytest.raises(twip.InvalidParameterError, match=rf"this sweep was made by twip 0.0.1, and this is twip {twip.__version__}"):
            way_back(0)
    assert bits(older.metrics) == bits(sweep.metrics)  # what it holds is still read


def test_sweep_result_comes_back_from_a_process_pool():
    local = SWEEPS["lqr"]()
    spawn = multiprocessing.get_context("spawn")  # a fresh interpreter: nothing shared with this one
    with concurrent.futures.ProcessPoolExecutor(max_workers=1, mp_context=spawn) as pool:
        remote = pool.submit(twip.montecarlo, "flat-lqr-sim", 8, perturb={"m_body": twip.Uniform(rel=0.2)},
                             options={"t_final": 1.0}, progress=False).result(timeout=300)
        sc = _sc3()
        run = pool.submit(twip.simulate, sc.model, sc.controller, sc.x0, sc.t_final, sc.dt, reference=sc.reference,
                          realism=twip.Realism.thesis_like()).result(timeout=300)
    assert bits(remote.metrics) == bits(local.metrics)
    assert bits(remote.rerun(3)) == bits(local.rerun(3))
    assert bits(remote.replay(3).states) == bits(local.replay(3).states)
    assert bits(run.states) == bits(sc.run(realism=twip.Realism.thesis_like()).states)


def test_streamed_sweep_result_pickles_as_a_reader_of_its_checkpoint(tmp_path):
    """A sweep too large for memory pickles as its checkpoint folder's reader: the copy
    reads the same shards while the folder is there."""
    from twip import sweep as tsweep

    twip.set_memory_budget(40 * tsweep.BYTES_PER_SAMPLE - 1)  # the metrics no longer fit
    try:
        streamed = twip.montecarlo("flat-lqr-sim", 40, perturb={"m_body": twip.Uniform(rel=0.2)},
                                   options={"t_final": 0.5}, progress=False, checkpoint=tmp_path, shard_size=16)
    finally:
        twip.set_memory_budget(None)
    twin = pickle.loads(pickle.dumps(streamed))
    assert isinstance(twin, tsweep.StreamedSweepResult)
    assert repr(twin) == repr(streamed)
    assert bits([dict(p) for p in twin.shards()]) == bits([dict(p) for p in streamed.shards()])
    assert bits(twin.rerun(5)) == bits(streamed.rerun(5))
