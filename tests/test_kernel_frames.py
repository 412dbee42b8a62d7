"""What keeps the lane kernels fast and that no other test would notice, since the bits stay
the same: their stack frames are aligned to a cache line (`benches/kernel_frames.py` reads the
wheel's machine code; misaligned, the LQR kernel swept ~1.13x slower), no vector copy of a
kernel reaches baseline code that multiply-adds in software (`benches/kernel_calls.py`; the
3-DOF lanes on terrain ran ~45 % of their instructions so), and the release profile that
builds the wheel keeps one codegen unit with fat LTO (Cargo.toml's comment has the cost of
more units)."""
import platform
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benches" / "kernel_frames.py"
CALLS = ROOT / "benches" / "kernel_calls.py"
X86_BINUTILS = pytest.mark.skipif(
    platform.machine() not in ("x86_64", "AMD64") or not all(shutil.which(tool) for tool in ("nm", "objdump", "readelf")),
    reason="reads x86-64 machine code with binutils' nm, objdump and readelf")


def test_the_release_profile_keeps_one_codegen_unit_and_fat_lto():
    release = tomllib.loads((ROOT / "Cargo.toml").read_text())["profile"]["release"]
    assert (release.get("codegen-units"), release.get("lto")) == (1, "fat")


@X86_BINUTILS
def test_every_lane_kernel_aligns_its_frame():
    done = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr


@X86_BINUTILS
def test_no_vector_kernel_copy_reaches_a_software_fma():
    done = subprocess.run([sys.executable, str(CALLS)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
