"""Which copy of the sweeps' lane kernels runs: AVX-512, AVX2 or baseline (the numbers are
the same on every copy, the speed is not). Chosen per process; the choice is kept in the
environment variable ``TWIP_KERNEL_COPY``, which the processes started afterwards inherit,
and ``import twip`` applies it there."""
from __future__ import annotations

import os

from twip import _core

ENV = "TWIP_KERNEL_COPY"


def use_kernel_copy(name: str | None) -> str:
    """Makes the sweeps of this process, and of the processes it starts from now on, run
    the lane kernels' copy `name` ("avx512", "avx2" or "baseline"; None: the widest this CPU
    has), to measure what a CPU without the wider instructions gets. Returns the copy that
    now runs. An unknown name, a copy this CPU has no instructions for, or one this build
    does not hold (`twip.available_kernel_copies()`), is refused with
    `twip.InvalidParameterError`, and nothing changes."""
    copy = _core.use_kernel_copy(name)
    if name is None:
        os.environ.pop(ENV, None)
    else:
        os.environ[ENV] = copy
    return copy


def apply_environment() -> None:
    """Runs the copy ``TWIP_KERNEL_COPY`` names, if it is set and not empty (``import twip``
    calls this); a bad value is refused with an error that names the variable."""
    name = os.environ.get(ENV)
    if not name:
        return
    try:
        _core.use_kernel_copy(name)
    except _core.InvalidParameterError as e:
        raise _core.InvalidParameterError(f"environment variable {ENV}={name!r}: {e}") from None
