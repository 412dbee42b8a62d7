"""The lane kernels' stack frames are aligned to a cache line (`benches/kernel_frames.py` reads
the wheel's machine code). Misaligned, the LQR kernel swept ~1.13x slower with the same bits, so
no other test would notice."""
import platform
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benches" / "kernel_frames.py"


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64") or not (shutil.which("nm") and shutil.which("objdump")),
                    reason="reads x86-64 machine code with binutils' nm and objdump")
def test_every_lane_kernel_aligns_its_frame():
    done = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
