"""Whether every lane kernel in the installed wheel aligns its stack frame to a cache line.

The lane kernels keep their lanes' arrays on the stack and move them 64 bytes at a time. Where
the compiler does not realign the frame, those loads and stores straddle two cache lines: the
LQR kernel ran ~1.13x slower that way until e231aa1 aligned the plants' coefficients (and with
them the frame). This reads the machine code (`nm`, `objdump` from binutils; x86-64 only): each copy
of each kernel (AVX-512, AVX2, baseline) must start by rounding its stack pointer down to a
multiple of 64 or 32 bytes. Prints one line per kernel; exits 1 if any does not.

Run:  .venv/bin/python benches/kernel_frames.py
"""
import re
import shutil
import subprocess
import sys

import twip._core

KERNEL = re.compile(r"^([0-9a-f]+) [tT] (twip_core::sweep::block::\S+_(?:avx512|avx2|baseline))$")
# LLVM's realignment: `and $-64, %rsp` (or -32) in the prologue.
REALIGN = re.compile(r"and\s+\$0xffffffffffffff(?:c0|e0),%rsp")
PROLOGUE_BYTES = 64


def kernels(so):
    listing = subprocess.run(["nm", "-C", so], capture_output=True, text=True, check=True).stdout
    return [(int(m[1], 16), m[2]) for m in map(KERNEL.match, listing.splitlines()) if m]


def realigns(so, address):
    code = subprocess.run(["objdump", "-d", "--no-show-raw-insn", f"--start-address={address}",
                           f"--stop-address={address + PROLOGUE_BYTES}", so],
                          capture_output=True, text=True, check=True).stdout
    return bool(REALIGN.search(code))


def main():
    if not (shutil.which("nm") and shutil.which("objdump")):
        sys.exit("kernel_frames: needs nm and objdump (binutils)")
    so = twip._core.__file__
    found = kernels(so)
    if not found:
        sys.exit(f"kernel_frames: no lane kernels found in {so} (not x86-64, or stripped?)")
    bad = 0
    for address, name in sorted(found, key=lambda k: k[1]):
        ok = realigns(so, address)
        bad += not ok
        print(f"{'aligned  ' if ok else 'UNALIGNED'} {name} @ {address:#x}")
    print(f"{len(found) - bad} of {len(found)} kernel copies align their frame ({so})")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
