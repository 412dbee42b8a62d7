"""The hand-written type stub python/twip/_core.pyi matches the compiled module."""
import subprocess
import sys

import pytest


def test_stub_matches_the_native_module():
    pytest.importorskip("mypy")
    run = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "twip._core", "--ignore-disjoint-bases"],
        capture_output=True, text=True, timeout=300,
    )
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
