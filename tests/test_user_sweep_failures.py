"""Sweeps of a Python controller when the controller fails or disagrees with the rig: a
raising or NaN-returning controller is recorded per sample (index and message) and counted
invalid with that reason, or stops the sweep naming the sample; a controller period that
conflicts with the loop's is refused, never ignored."""
from __future__ import annotations

import math

import numpy as np
import pytest

import twip
from twip import scenarios

#: |phi0| above which the failing controllers below fail at their first update.
LIMIT = 0.03


class Balancer:
    """A PD law on pitch (enough to balance flat-lqr-sim for a second)."""

    def __init__(self, gains, period):
        self.k, self.period = list(gains), period

    def reset(self):
        pass

    def update(self, t, y, ref):
        return -(self.k[0] * y[0] + self.k[1] * y[1] + self.k[2] * (y[3] - ref[1]))


class RaisesOnBigTilt(Balancer):
    def update(self, t, y, ref):
        if t == 0 and abs(y[0]) > LIMIT:
            raise ValueError(f"tilt {y[0]:.3f} beyond my table")
        return super().update(t, y, ref)


class NanOnBigTilt(Balancer):
    def update(self, t, y, ref):
        if t == 0 and abs(y[0]) > LIMIT:
            return math.nan
        return super().update(t, y, ref)


def _sweep(kind, **kw):
    sc = scenarios.get("flat-lqr-sim", t_final=0.5)
    mine = sc.replace(controller=kind(sc.controller.gains, sc.controller.period))
    return twip.montecarlo(mine, 24, perturb={"phi0": twip.Normal(std=0.03)}, seed=4, progress=False, **kw)


def _bad_samples(result):
    return set(np.flatnonzero(np.abs(result.drawn("phi0")) > LIMIT).tolist())


@pytest.mark.parametrize("kind, reason", [(RaisesOnBigTilt, "ValueError"), (NanOnBigTilt, "NonFiniteError")])
@pytest.mark.parametrize("threads", [1, 2])
def test_a_failing_controller_is_recorded_per_sample_and_counted_invalid(kind, reason, threads):
    r = _sweep(kind, on_error="record", threads=threads)
    bad = _bad_samples(r)
    assert 0 < len(bad) < r.n, "the draw must have failing and passing samples"
    assert set(r.errors) == bad
    assert set(np.flatnonzero(~r.valid).tolist()) == bad
    for i in bad:
        assert r.errors[i].startswith(reason), r.errors[i]
    if kind is RaisesOnBigTilt:
        assert all("beyond my table" in r.errors[i] for i in bad)
    s = r.summary()
    assert s["invalid"] == len(bad)
    assert s["invalid_reasons"] == {f"the controller failed: {reason}": len(bad)}
    # The fall rate is over the samples that ran.
    assert r.fall_rate == np.mean(r.metrics["fell"][r.valid])


def test_recorded_failures_survive_a_checkpoint(tmp_path):
    first = _sweep(RaisesOnBigTilt, on_error="record", checkpoint=tmp_path, shard_size=5)
    again = _sweep(RaisesOnBigTilt, on_error="record", checkpoint=tmp_path, shard_size=5)
    assert again.errors == first.errors and first.errors


def test_resuming_with_stop_refuses_the_shards_a_record_run_wrote(tmp_path):
    _sweep(RaisesOnBigTilt, on_error="record", checkpoint=tmp_path, shard_size=5)
    with pytest.raises(twip.InvalidParameterError, match="differs in: on_error"):
        _sweep(RaisesOnBigTilt, checkpoint=tmp_path, shard_size=5)


def test_by_default_a_failing_controller_stops_the_sweep_naming_the_sample():
    with pytest.raises(twip.ControllerFailedError, match=r"sample \d+: the controller failed \(ValueError") as info:
        _sweep(RaisesOnBigTilt, threads=1)
    r = _sweep(RaisesOnBigTilt, on_error="record", threads=1)
    assert info.value.index == min(_bad_samples(r))  # samples run in order on one worker
    assert "beyond my table" in info.value.message
    with pytest.raises(twip.ControllerFailedError) as info:
        _sweep(NanOnBigTilt, threads=2)
    assert info.value.index in _bad_samples(r)
    with pytest.raises(twip.InvalidParameterError, match="on_error = 'skip'"):
        _sweep(Balancer, on_error="skip")


class ExitsOnBigTilt(Balancer):
    def update(self, t, y, ref):
        if t == 0 and abs(y[0]) > LIMIT:
            import os

            os._exit(3)  # as a crash in an extension module ends the worker
        return super().update(t, y, ref)


def test_a_worker_that_dies_is_reported_with_its_sample_and_exit_code():
    # It was "a sweep worker process ended without a reply (killed, or out of memory)",
    # naming no sample.
    with pytest.raises(RuntimeError, match=r"^sample (\d+): the sweep's worker process ended without a reply "
                                           r"\(exit code 3\)") as info:
        _sweep(ExitsOnBigTilt, threads=2)
    index = int(info.value.args[0].split(":")[0].split()[1])
    assert index in _bad_samples(_sweep(RaisesOnBigTilt, on_error="record", threads=1))


class WithPeriod(Balancer):
    def __init__(self, gains, period):
        super().__init__(gains, 0.005)
        self.period = period


@pytest.mark.parametrize("period", [0.02, 0.1, 0, -0.005, math.nan, "5ms", True, None])
def test_a_controller_period_that_conflicts_with_the_rig_is_refused(period):
    sc = scenarios.get("flat-lqr-sim", t_final=0.2)
    mine = WithPeriod(sc.controller.gains, period)
    realism = twip.Realism.thesis_like()
    assert realism.control_period == 0.005
    with pytest.raises(twip.InvalidParameterError, match=r"controller\.period = "):
        twip.simulate(sc.model, mine, sc.x0, sc.t_final, sc.dt, reference=sc.reference, realism=realism)
    with pytest.raises(twip.InvalidParameterError, match=r"controller\.period = "):
        twip.montecarlo(sc.replace(controller=mine), 4, progress=False, realism=realism)
    with pytest.raises(twip.InvalidParameterError, match=r"controller\.period = "):  # without a rig too
        twip.simulate(sc.model, mine, sc.x0, sc.t_final, sc.dt, reference=sc.reference, control_period=0.005)


def test_a_controller_period_that_agrees_with_the_rig_is_used():
    sc = scenarios.get("flat-lqr-sim", t_final=0.2)
    calls = []

    class Counting(Balancer):
        def update(self, t, y, ref):
            calls.append(t)
            return super().update(t, y, ref)

    realism = twip.Realism.thesis_like()
    twip.simulate(sc.model, Counting(sc.controller.gains, 0.005), sc.x0, 0.2, sc.dt, reference=sc.reference,
                  realism=realism)
    assert len(calls) == 40 and calls[1] == pytest.approx(0.005)
    calls.clear()  # a rig without a loop period of its own runs at the controller's
    twip.simulate(sc.model, Counting(sc.controller.gains, 0.01), sc.x0, 0.2, sc.dt, reference=sc.reference,
                  realism=twip.Realism(imu=twip.Imu()))
    assert len(calls) == 20 and calls[1] == pytest.approx(0.01)
