"""The lane kernels' copies (AVX-512, AVX2, baseline) chosen at run time: every copy this CPU
runs and this build holds gives the same sweep, bit for bit, through the dispatcher a user's
sweep takes; a chosen copy is named by `twip.kernel_copy()`, kept in TWIP_KERNEL_COPY for the
processes a sweep starts, and applied by `import twip`; bad choices are refused and change
nothing. (A wheel `make` builds on a CPU with AVX2 and FMA holds no baseline copy; the Rust
tests run that copy's kernels against the others.)"""
import os
import subprocess
import sys

import numpy as np
import pytest

import twip
from test_sweep import case

COPIES = ("avx512", "avx2", "baseline")
WIDEST = twip.kernel_copy()
# The copies this CPU has instructions for and this build holds, widest first.
HERE = tuple(twip.available_kernel_copies())
NARROWEST = HERE[-1]


@pytest.fixture(autouse=True)
def widest_after():
    yield
    twip.use_kernel_copy(None)


# Every lane kernel: 2-DOF (LQR, fuzzy with trapezoids and with Gaussian sets), the 2-DOF
# rig, the planar trackers and the planar rig.
LANE_CASES = {"flat-lqr-sim": "lanes", "flat-fuzzy-sim": "lanes", "flat-fuzzy-sim+gauss": "lanes",
              "flat-lqr-sim+rig": "realism-lanes", "circle-pid": "planar-lanes",
              "circle-smc-fuzzy": "planar-lanes", "circle-pid+rig": "planar-realism-lanes"}


@pytest.mark.parametrize("name", LANE_CASES)
def test_every_copy_this_cpu_runs_gives_the_same_sweep(name):
    if len(HERE) == 1:
        pytest.skip(f"this process runs one copy only ({WIDEST})")
    sc, kw = case(name)
    kw = {**kw, "threads": 1}
    results = {}
    for copy in HERE:
        assert twip.use_kernel_copy(copy) == copy == twip.kernel_copy()
        results[copy] = twip.montecarlo(sc, 16, **kw)
    widest = results[WIDEST]
    assert widest.kernel == LANE_CASES[name]
    for copy, r in results.items():
        assert r.steps == widest.steps, copy
        for k in widest.metrics:
            assert np.array_equal(r.metrics[k], widest.metrics[k], equal_nan=True), (copy, k)


def test_the_copies_this_process_runs_are_the_widest_and_narrower_ones_this_build_holds():
    assert HERE[0] == WIDEST
    assert list(HERE) == sorted(HERE, key=COPIES.index)
    # Only the baseline copy may be left out of a build, and only where the CPU has wider ones.
    left_out = set(COPIES[COPIES.index(WIDEST):]) - set(HERE)
    assert not left_out or (left_out == {"baseline"} and WIDEST != "baseline")


def test_a_copy_this_build_does_not_hold_is_refused_and_named_so():
    if "baseline" in HERE:
        pytest.skip("this build holds every copy this CPU runs")
    with pytest.raises(twip.InvalidParameterError, match=r"invalid kernel copy \"baseline\": this build of twip does not hold it"):
        twip.use_kernel_copy("baseline")
    assert twip.kernel_copy() == WIDEST


def test_a_chosen_copy_is_named_and_kept_in_the_environment():
    assert twip.use_kernel_copy(NARROWEST) == NARROWEST == twip.kernel_copy()
    assert os.environ["TWIP_KERNEL_COPY"] == NARROWEST
    assert twip.use_kernel_copy(None) == WIDEST == twip.kernel_copy()
    assert "TWIP_KERNEL_COPY" not in os.environ


def test_an_unknown_copy_is_refused_and_nothing_changes():
    twip.use_kernel_copy(NARROWEST)
    with pytest.raises(twip.InvalidParameterError, match=r"invalid kernel copy \"avx9\": must be one of"):
        twip.use_kernel_copy("avx9")
    assert twip.kernel_copy() == NARROWEST == os.environ["TWIP_KERNEL_COPY"]


def test_a_copy_this_cpu_lacks_is_refused():
    lacking = COPIES[:COPIES.index(WIDEST)]
    if not lacking:
        pytest.skip("this CPU runs every copy")
    with pytest.raises(twip.InvalidParameterError, match=f"its widest copy is \"{WIDEST}\""):
        twip.use_kernel_copy(lacking[0])
    assert twip.kernel_copy() == WIDEST


def run_python(code, value):
    env = {**os.environ, "TWIP_KERNEL_COPY": value}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)


def test_import_applies_the_environment_variable_and_names_it_when_it_is_bad():
    done = run_python("import twip; print(twip.kernel_copy())", NARROWEST)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == NARROWEST
    bad = run_python("import twip", "avx9")
    assert bad.returncode != 0
    assert "environment variable TWIP_KERNEL_COPY='avx9'" in bad.stderr, bad.stderr
