"""Whether any vector copy of a lane kernel in the installed wheel reaches the software fma.

Each lane kernel is compiled once per x86-64 copy (AVX-512, AVX2 with FMA, baseline). A function
the kernel calls out of line is not part of that copy: it is compiled for the baseline, where
`f64::mul_add` has no instruction and becomes a call of compiler-builtins' `fma` function (which
picks the FMA instruction at run time where the CPU has it: 8 instructions and a call per
multiply-add, in a loop that can then not be vectorised). The bits stay the same (both round
once), so no other test notices; the time does not. Closures the compiler chose not to inline
did this to the 3-DOF lanes on terrain: their RK4 stages and each step's normal forces made
~45 % of the kernel's instructions, in and around those calls (`callgrind`, 37th session).

This reads the machine code (`nm`, `objdump`, `readelf` from binutils; x86-64 only): from every
AVX2 and AVX-512 copy, the functions reached through direct calls (not entering another copy),
and which of them call `fma` (directly, or through the global offset table). Prints each such
function with the copies it is reached from; exits 1 if there is any, but for the rig lanes'
`start`, which runs once per block of robots, not per step, and is kept one function for the
build's time (`rig_lanes.rs` says why).

Run:  .venv/bin/python benches/kernel_calls.py
"""
import re
import shutil
import subprocess
import sys
from collections import defaultdict

import twip._core

# A vector copy of a kernel, or the wrapper a kernel runs its out-of-line parts in.
VECTOR_COPY = re.compile(r"^twip_core::.*(?:::|_)(avx512|avx2)$")
LABEL = re.compile(r"^([0-9a-f]+) <(.+)>:$")
DIRECT_CALL = re.compile(r"\t(?:call|jmp)\s+([0-9a-f]+) <")
# objdump's note of the address a %rip-relative operand reads: `# ac6e80 <...>`.
SLOT_OPERAND = re.compile(r"\(%rip\)[^#]*#\s*([0-9a-f]+)\b")
ONCE_PER_BLOCK = {
    "twip_core::sweep::block::rig_lanes::RigLanes::start",
    "twip_core::sweep::block::planar_rig_lanes::PlanarRigLanes::start",
}


def software_fma(so):
    """The address of the software `fma` and of every slot the code loads it from."""
    symbols = subprocess.run(["nm", so], capture_output=True, text=True, check=True).stdout
    addresses = {int(line.split()[0], 16) for line in symbols.splitlines() if line.split()[-1:] == ["fma"]}
    relocations = subprocess.run(["readelf", "-rW", so], capture_output=True, text=True, check=True).stdout
    slots = set()
    for line in relocations.splitlines():
        fields = line.split()
        if len(fields) >= 4 and fields[2] == "R_X86_64_RELATIVE" and int(fields[3], 16) in addresses:
            slots.add(int(fields[0], 16))
        elif len(fields) >= 5 and fields[2] in ("R_X86_64_GLOB_DAT", "R_X86_64_JUMP_SLOT") and fields[4].split("@")[0] == "fma":
            slots.add(int(fields[0], 16))
    return addresses, slots


def functions(so):
    """Each function's start address, name and instructions."""
    listing = subprocess.run(["objdump", "-d", "--no-show-raw-insn", "-C", so], capture_output=True, text=True, check=True).stdout
    names, body, current = {}, defaultdict(list), None
    for line in listing.splitlines():
        label = LABEL.match(line)
        if label:
            current = int(label[1], 16)
            names[current] = label[2]
        elif current is not None and line.startswith(" "):
            body[current].append(line)
    return names, body


def calls_fma(lines, addresses, slots):
    for line in lines:
        call = DIRECT_CALL.search(line)
        # Or a call through a slot, or a load of it into a register to call later.
        slot = SLOT_OPERAND.search(line)
        if (call and int(call[1], 16) in addresses) or (slot and int(slot[1], 16) in slots):
            return True
    return False


def main():
    if not all(shutil.which(tool) for tool in ("nm", "objdump", "readelf")):
        sys.exit("kernel_calls: needs nm, objdump and readelf (binutils)")
    so = twip._core.__file__
    addresses, slots = software_fma(so)
    names, body = functions(so)
    copies = {a: copy[1] for a, n in names.items() if (copy := VECTOR_COPY.match(n))}
    if not copies:
        sys.exit(f"kernel_calls: no vector kernel copies found in {so} (not x86-64, or stripped?)")
    bad = {}
    for root, copy in copies.items():
        seen, stack = {root}, [root]
        while stack:
            for line in body[stack.pop()]:
                call = DIRECT_CALL.search(line)
                callee = int(call[1], 16) if call else None
                if callee in names and callee not in seen and callee not in copies:
                    seen.add(callee)
                    stack.append(callee)
        for f in seen:
            if calls_fma(body[f], addresses, slots):
                bad.setdefault(f, set()).add(copy)
    failing = 0
    for f, found_in in sorted(bad.items(), key=lambda item: names[item[0]]):
        allowed = names[f] in ONCE_PER_BLOCK
        failing += not allowed
        print(f"{'allowed, once per block:' if allowed else 'SOFTWARE FMA'} {names[f]} (reached from the {', '.join(sorted(found_in))} copies)")
    print(f"{failing} functions reached from {len(copies)} vector kernel copies call the software fma, the once-per-block starts aside ({so})")
    sys.exit(1 if failing else 0)


if __name__ == "__main__":
    main()
