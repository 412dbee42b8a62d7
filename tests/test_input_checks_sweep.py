"""A sweep's inputs, its checkpoint folder's files and a robot file's [sensors], refused by
name (TypeError for a wrong type, InvalidParameterError for a bad value) before any work,
never a raw Python error, a MemoryError or a silently wrong result."""
import json
import re
import sys
import warnings

import numpy as np
import pytest

import twip
from twip import robot_file, scenarios

SHORT = {"t_final": 0.3}


def tiny(n=4, **kw):
    kw.setdefault("options", SHORT)
    return twip.montecarlo("flat-lqr-sim", n, progress=False, **kw)


def test_a_shard_size_that_makes_too_many_shards_is_refused_before_the_layout(tmp_path):
    # 10**9 shards: a 10**9-entry layout list, then a MemoryError.
    with pytest.raises(twip.InvalidParameterError, match=r"n = 100,000,000,000 samples in shards of shard_size = 100 "
                                                         r"make 1,000,000,000 shards, more than MAX_SHARDS"):
        tiny(10**11, checkpoint=tmp_path / "c", shard_size=100)
    assert not (tmp_path / "c").exists()


def test_drawn_takes_only_samples_of_the_sweep():
    r = tiny(perturb={"phi0": twip.Normal(std=0.02)})
    for bad in (100, -1, 1.7, "a", True):
        expect = f"index = {bad!r}: this sweep has samples 0..3"
        with pytest.raises(twip.InvalidParameterError, match=re.escape(expect)):
            r.drawn("phi0", [bad])
    with pytest.raises(TypeError, match=r"index must be a list of sample indices .* got 2 \(int\)"):
        r.drawn("phi0", 2)
    np.testing.assert_array_equal(r.drawn("phi0", np.array([3, 1], np.uint64)), r.drawn("phi0")[[3, 1]])


def test_params_must_be_robot_params_and_state_indices_ascii_digits():
    with pytest.raises(TypeError, match=r"params must be a twip.RobotParams .* got \{'m_body': 1\} \(dict\)"):
        tiny(params={"m_body": 1})
    for name in ("x0[¹]", "x0[٣]", "x0[" + "9" * 5000 + "]"):
        with pytest.raises(twip.InvalidParameterError, match=r"unknown perturbation 'x0\["):
            tiny(perturb={name: twip.Uniform(abs=0.1)})


def test_wilson_interval_checks_its_counts():
    for args, error, message in (((0, -3), twip.InvalidParameterError, "n = -3: the number of trials must be >= 0"),
                                 ((1.5, 3), TypeError, r"successes must be an integer, got 1.5 \(float\)"),
                                 ((0, "3"), TypeError, r"n must be an integer, got '3' \(str\)"),
                                 ((True, 3), TypeError, r"successes must be an integer, got True \(bool\)"),
                                 ((4, 3), twip.InvalidParameterError, "successes = 4: must be from 0 to n = 3")):
        with pytest.raises(error, match=message):
            twip.wilson_interval(*args)
    assert twip.wilson_interval(0, 0) == (0.0, 1.0)  # no trials: nothing known
    assert twip.wilson_interval(np.int64(8), np.int64(10)) == twip.wilson_interval(8, 10)


@pytest.mark.parametrize("name", ["flat-lqr", "slope-lqr", "flat-fuzzy", "slope-fuzzy"])
def test_settle_is_named_settle_not_hold(name):
    with pytest.raises(twip.InvalidParameterError, match=r"settle must be finite and >= 0, got -1.0"):
        scenarios.get(name, settle=-1.0)
    with pytest.raises(TypeError, match=r"settle must be a real number, got 'x' \(str\)"):
        scenarios.get(name, settle="x")


def test_a_checkpoint_path_is_a_non_empty_str_or_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(twip.InvalidParameterError, match="checkpoint = '': an empty path is the working directory"):
        tiny(checkpoint="")
    assert not list(tmp_path.iterdir())  # no lock, manifest or shard in the working directory
    for bad in (5, b"c"):
        expect = f"checkpoint must be a folder path (str or os.PathLike), got {bad!r}"
        with pytest.raises(TypeError, match=re.escape(expect)):
            tiny(checkpoint=bad)


@pytest.mark.parametrize("content", ["[]", '{"manifest": 5}', '{"manifest": {"config": {"n": 4}, "shard_size": "x"}}',
                                     '{"manifest": {"config": {"n": 4}, "shard_size": true}}', "{}", "5"])
def test_a_manifest_that_is_not_a_sweeps_is_refused_by_name(tmp_path, content):
    (tmp_path / "manifest.json").write_text(content)
    with pytest.raises(twip.InvalidParameterError,
                       match=r"manifest.json cannot be read \(not a sweep's manifest.*use a new folder"):
        tiny(checkpoint=tmp_path)
    assert (tmp_path / "manifest.json").read_text() == content and not list(tmp_path.glob("shard-*"))


@pytest.mark.parametrize("content", ['{"pid": "abc"}', "[1, 2]", '{"pid": 10000000000000000000000, "host": "h"}',
                                     '{"pid": -1, "host": "h"}', '{"pid": true, "host": "h"}', "\udcff"])
def test_a_corrupt_lock_file_is_named_and_taken_over(tmp_path, content):
    # The OS lock is free (no live holder): the file's text names no sweep, so it is stale.
    (tmp_path / "lock").write_bytes(content.encode(errors="surrogateescape"))
    with pytest.warns(UserWarning, match=r"the lock file .*lock held .* not a sweep's pid and host; took it over"):
        assert tiny(checkpoint=tmp_path).n == 4
    assert (tmp_path / "lock").read_text() == ""  # released cleanly


def test_threads_may_be_a_numpy_integer():
    assert tiny(threads=np.int64(2)).n == 4


def _sensors(tmp_path, line):
    path = tmp_path / "mine.toml"
    robot_file.init(path)
    text = path.read_text()
    path.write_text(text[:text.index("[sensors]")] + f"[sensors]\n{line}\n")
    return path


@pytest.mark.parametrize("line, message", [
    ("encoder_cpr = 0.5", r"\[sensors\] encoder_cpr: invalid encoder_cpr = 0.5: must be finite and >= 1"),
    ("imu_height = -1", r"\[sensors\] imu_height: -1 m is outside 0..10 m"),
    ("imu_height = 1e308", r"\[sensors\] imu_height: 1e\+308 m is outside 0..10 m"),
])
def test_sensors_are_checked_at_their_line_with_the_rigs_bounds(tmp_path, line, message):
    path = _sensors(tmp_path, line)
    with pytest.raises(robot_file.RobotFileError, match=re.escape(str(path)) + ":[1-9][0-9]*: " + message):
        twip.Robot.from_file(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert twip.Robot.from_file(_sensors(tmp_path, "encoder_cpr = 1\nimu_height = 0")).realism().encoder_cpr == 1


def test_a_value_shown_in_a_message_never_raises_itself():
    # str() of an int past Python's 4300-digit limit raises ValueError: the message must not.
    from twip import checks

    assert checks.shown(10**5000) == f"an integer of more than {sys.get_int_max_str_digits()} digits"
    assert checks.shown(10**399 * 9) == "an integer of 400 digits"
