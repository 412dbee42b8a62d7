"""The sliding-mode tracker's fuzzy grids in the C ABI: `twip export` writes any n x n grid
of trapezoid, triangle or Gaussian sets into TwipSmcConfig, the exported C replays the f32
controller's commands on the host (`make check`, 1e-5 relative), bad grids are named at
export, and a configuration, header or library of another C ABI version is refused by a
clear check."""
import math
import re
import subprocess

import numpy as np
import pytest

import twip
from twip import _core, scenarios
from twip.firmware import export, header
from twip.firmware.export import REPLAY_TOLERANCE

from test_export import _check, _relative, needs_tools

PHI5 = [-0.3, -0.15, 0.0, 0.15, 0.3]
OMEGA5 = [-1.0, -0.5, 0.0, 0.5, 1.0]
RATE5 = [-2.0, -1.0, 0.0, 1.0, 2.0]
#: The fuzzy-sets study's 5 x 5 Gaussian grids (docs/fuzzy_sets.md): σ half the spacing.
YAW_5X5 = twip.FuzzyBasis.grid("gaussian", [PHI5, OMEGA5], [0.075, 0.25])
PITCH_5X5 = twip.FuzzyBasis.grid("gaussian", [PHI5, RATE5], [0.075, 0.5])


def _smc(yaw=None, pitch=None):
    """circle-smc-fuzzy, with other grids when given."""
    sc = scenarios.get("circle-smc-fuzzy")
    if yaw is None:
        return sc
    return sc.replace(controller=sc.controller.replace(yaw_sets=yaw, pitch_sets=pitch))


def test_the_scenario_takes_the_study_grids_by_name_from_the_command_line(tmp_path):
    """`twip export circle-smc-fuzzy --option sets=gaussian-5x5` exports the study's 5 x 5
    Gaussian grids: the same configuration as the Python API's; a bad name is named."""
    from twip.cli import main

    assert repr(scenarios.get("circle-smc-fuzzy", sets="gaussian-5x5").controller) == repr(_smc(YAW_5X5, PITCH_5X5).controller)
    assert main(["export", "circle-smc-fuzzy", "--option", "sets=gaussian-5x5", "--out", str(tmp_path / "cli"),
                 "--replay-seconds", "0.1"]) == 0
    export(_smc(YAW_5X5, PITCH_5X5), tmp_path / "api", replay_seconds=0.1)
    config = (tmp_path / "cli" / "twip_config.c").read_text()
    assert re.search(r"\.n_sets = 5", config) and config == (tmp_path / "api" / "twip_config.c").read_text()
    with pytest.raises(twip.InvalidParameterError, match="sets = 'gauss'.*gaussian-5x5"):
        scenarios.get("circle-smc-fuzzy", sets="gauss")


def _triangles_7x7():
    phi = [-0.45, -0.3, -0.15, 0.0, 0.15, 0.3, 0.45]
    omega = [-1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5]
    return (twip.FuzzyBasis.grid("triangle", [phi, omega]),
            twip.FuzzyBasis.grid("triangle", [phi, [2 * w for w in omega]]))


def _config(sc) -> dict:
    rec = _core.ffi_record(sc.model, sc.controller, [float(v) for v in sc.x0], 0.01, sc.dt, sc.reference)
    return header.decode(header.structs(), "TwipSmcConfig", rec["config"])


def test_the_configuration_carries_the_grids_it_was_given():
    f32 = lambda v: float(np.float32(v))  # noqa: E731
    thesis = _config(_smc())
    assert thesis["abi_version"] == header.macros()["TWIP_ABI_VERSION"] == 2
    assert thesis["n_sets"] == 3 and thesis["pitch_sets"][0][0]["kind"] == 0
    assert thesis["pitch_sets"][0][1]["p"] == [f32(-0.3), f32(-0.1), f32(0.1), f32(0.3)]  # the thesis's Z of φ
    gaussian = _config(_smc(YAW_5X5, PITCH_5X5))
    assert gaussian["n_sets"] == 5
    for name, centres, sigmas in (("yaw_sets", (PHI5, OMEGA5), (0.075, 0.25)), ("pitch_sets", (PHI5, RATE5), (0.075, 0.5))):
        for i, row in enumerate(gaussian[name]):
            assert [m["kind"] for m in row] == [1] * 5 + [0] * 2
            assert [m["p"][:2] for m in row[:5]] == [[f32(c), f32(sigmas[i])] for c in centres[i]]
            assert all(m["p"] == [0.0] * 4 for m in row[5:]), "the slots past n are zero"
    triangles = _config(_smc(*_triangles_7x7()))
    assert triangles["n_sets"] == 7 and triangles["yaw_sets"][1][6]["p"][2:] == [np.inf, np.inf]


@needs_tools
@pytest.mark.parametrize("grids", ["3x3 trapezoids", "5x5 gaussians"])
def test_the_exported_c_replays_the_trackers_commands(grids, tmp_path):
    sc = _smc() if grids == "3x3 trapezoids" else _smc(YAW_5X5, PITCH_5X5)
    summary = export(sc, tmp_path, replay_seconds=5.0)
    assert summary["family"] == "smc" and summary["updates"] == 1000
    out = _check(tmp_path)
    assert out.startswith("smc: 1000 updates replayed")
    assert _relative(out) <= REPLAY_TOLERANCE
    c = (tmp_path / "twip_config.c").read_text()
    assert ".abi_version = 2," in c and f".n_sets = {grids[0]}," in c
    if grids == "5x5 gaussians":
        # φ's means in degrees, ω's sigmas in deg/s of yaw rate (firmware units).
        assert "8.594367f * TWIP_RAD_PER_DEG,  /* 8.59437 deg of pitch */" in c  # 0.15 rad, the fewest digits
        assert "14.323945f * TWIP_RAD_PER_DEG,  /* 14.3239 deg/s of yaw rate */" in c  # σ = 0.25 rad/s


@needs_tools
def test_in_si_units_a_5x5_gaussian_tracker_replays_within_tolerance(tmp_path):
    # Not bit for bit as the thesis's trapezoids are (test_export.py): the library `make
    # check` links computes the Gaussians' exp with the libm crate (its core is no_std),
    # the recording with the platform's (docs/firmware.md).
    export(_smc(YAW_5X5, PITCH_5X5), tmp_path, units_="si", replay_seconds=2.0)
    assert _relative(_check(tmp_path)) <= REPLAY_TOLERANCE


def test_the_f32_tracker_with_5x5_gaussians_follows_the_f64_one():
    # As test_export.py's test_f32_run_follows_the_f64_run, for the richer grids.
    sc = _smc(YAW_5X5, PITCH_5X5)
    rec = _core.ffi_record(sc.model, sc.controller, [float(v) for v in sc.x0], 20.0, sc.dt, sc.reference)
    run = sc.run(t_final=20.0)
    at = np.rint(rec["t"].astype(float) / sc.dt).astype(int)
    states, inputs = run.states[at], run.inputs[at]
    assert np.max(np.abs(states - rec["y"]) / np.maximum(np.abs(states).max(axis=0), 1e-9)) < 2e-3
    assert np.max(np.abs(inputs - rec["u"])) / np.abs(inputs).max() < 5e-4


def test_a_set_that_f32_cannot_hold_is_named_at_export(tmp_path):
    tiny = twip.FuzzyBasis.grid("gaussian", [[-0.3, 0.0, 0.3], [-1.0, 0.0, 1.0]], [[0.1, 0.1, 0.1], [0.1, 1e-50, 0.1]])
    with pytest.raises(twip.InvalidParameterError, match=r"invalid yaw_sets\[1\]\[1\] = 1e-50: does not fit in f32"):
        export(_smc(tiny, tiny), tmp_path, replay_seconds=0.1)
    huge = twip.FuzzyBasis.grid("gaussian", [[-1e39, 0.0, 1e39], [-1.0, 0.0, 1.0]], [1.0, 1.0])
    with pytest.raises(twip.InvalidParameterError, match=r"invalid pitch_sets\[0\]\[0\] = -1e\+?39: does not fit"):
        export(_smc(twip.FuzzyBasis.grid("triangle", [[-1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]]), huge), tmp_path,
               replay_seconds=0.1)
    # Valid in f64, not in f32: a ramp 1e-40 wide, whose slope 1/width f32 cannot hold.
    inf = math.inf
    ramp = [twip.Trapezoid(-inf, -inf, 0.0, 1e-40), twip.Trapezoid(0.0, 1e-40, 0.5, 0.6), twip.Trapezoid(0.5, 0.6, inf, inf)]
    with pytest.raises(twip.InvalidParameterError,
                       match=r"invalid pitch_sets\[0\]\[0\] = .*: makes a ramp whose slope 1/width is not finite"):
        export(_smc(twip.FuzzyBasis.grid("triangle", [[-1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]]), twip.FuzzyBasis([ramp, ramp])),
               tmp_path, replay_seconds=0.1)
    assert not (tmp_path / "replay_data.c").exists()


def _make_check(folder) -> subprocess.CompletedProcess:
    return subprocess.run(["make", "-s", "-C", str(folder), "check"], capture_output=True, text=True, timeout=900)


@needs_tools
def test_a_stale_configuration_or_header_is_refused_not_misread(tmp_path):
    export("circle-smc-fuzzy", tmp_path, replay_seconds=0.5)
    h, c, twip_h = (tmp_path / name for name in ("twip_config.h", "twip_config.c", "twip.h"))
    good = {p: p.read_text() for p in (h, c, twip_h)}
    # A configuration exported for version 1 against today's header: the compiler stops.
    h.write_text(good[h].replace("#define TWIP_CONFIG_ABI_VERSION 2", "#define TWIP_CONFIG_ABI_VERSION 1"))
    done = _make_check(tmp_path)
    assert done.returncode != 0 and "written for another C ABI version than this twip.h" in done.stderr
    # The same past the compiler (the version field edited): the library refuses it at init.
    h.write_text(good[h])
    c.write_text(good[c].replace(".abi_version = 2,", ".abi_version = 1,", 1))
    done = _make_check(tmp_path)
    assert done.returncode == 2
    assert "init failed: the configuration was written for another version of the C ABI" in done.stdout
    # A header of another version than the library's: refused before anything is read.
    c.write_text(good[c].replace(".abi_version = 2,", ".abi_version = 3,", 1))
    h.write_text(good[h].replace("#define TWIP_CONFIG_ABI_VERSION 2", "#define TWIP_CONFIG_ABI_VERSION 3"))
    twip_h.write_text(good[twip_h].replace("#define TWIP_ABI_VERSION 2", "#define TWIP_ABI_VERSION 3"))
    done = _make_check(tmp_path)
    assert done.returncode == 2
    assert "twip.h is the C ABI's version 3, the library's is 2" in done.stdout
    # As exported, it passes.
    for p, text in good.items():
        p.write_text(text)
    assert _relative(_check(tmp_path)) <= REPLAY_TOLERANCE


def test_the_example_halts_on_a_library_of_another_version(tmp_path):
    export("circle-smc-fuzzy", tmp_path, replay_seconds=0.1)
    example = (tmp_path / "example.c").read_text()
    assert re.search(r"if \(twip_abi_version\(\) != TWIP_ABI_VERSION\) halt\(TWIP_ERR_ABI\);\n\s+"
                     r"if \(\(s = TWIP_INIT", example)
