"""The RAM a sliding-mode tracker takes in a firmware, for its 3 x 3, 5 x 5 and 7 x 7 grids.

    python scripts/smc_ram.py

Exports circle-smc-fuzzy with the thesis's 3 x 3 trapezoids, the fuzzy-sets study's 5 x 5
Gaussians and 7 x 7 triangles, builds the host library as `make check` does, and compiles
a probe against each export that prints what the C side holds (`sizeof` the state and the
configuration) and the deepest stack `twip_smc_init` and `twip_smc_update` reach. The stack
is measured by painting: a region below the caller's frame is filled with a pattern, the
call is made from the same depth, and the bytes it overwrote are counted (to within the
probe's own frame, a few dozen bytes). x86-64 code: an 8-bit or Thumb-2 target differs.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import twip
from twip import scenarios
from twip.firmware import export

PROBE = r"""
#include <stdio.h>
#include "twip_config.h"

#define PAINT 65536
static TwipSmc state;

__attribute__((noinline)) static void paint(void) {
    volatile unsigned char region[PAINT];
    for (int i = 0; i < PAINT; ++i) region[i] = 0xA5;
}

/* The bytes of the painted region, from its deep end, that a call has overwritten. */
__attribute__((noinline)) static int touched(void) {
    volatile unsigned char region[PAINT];
    int i = 0;
    while (i < PAINT && region[i] == 0xA5) ++i;
    return PAINT - i;
}

__attribute__((noinline)) static int do_init(void) { return twip_smc_init(&state, &twip_controller_config); }

__attribute__((noinline)) static int do_update(void) {
    const float y[7] = {0.02f, 0.01f, 0.1f, 0.03f, -0.1f, 0.1f, 0.2f};
    TwipPlanarRef r = {0.0f, 0.0f, 0.0f, 0.3f, 0.5f, 0.0f, 0.0f};
    float u[2];
    return twip_smc_update(&state, 0.0f, y, &r, u);
}

int main(void) {
    paint();
    int baseline = touched();  /* the probe's own frames */
    paint();
    if (do_init() != TWIP_OK) return 2;
    int init = touched();
    paint();
    if (do_update() != TWIP_OK) return 2;
    int update = touched();
    printf("%d %d %d %d %d\n", TWIP_ABI_VERSION, (int)sizeof(TwipSmc), (int)sizeof(TwipSmcConfig),
           init - baseline, update - baseline);
    return 0;
}
"""


def grids():
    phi5, phi7 = [-0.3, -0.15, 0.0, 0.15, 0.3], [-0.45, -0.3, -0.15, 0.0, 0.15, 0.3, 0.45]
    omega7 = [-1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5]
    yield "3 x 3 trapezoids (thesis)", None, None
    yield ("5 x 5 Gaussians", twip.FuzzyBasis.grid("gaussian", [phi5, [-1.0, -0.5, 0.0, 0.5, 1.0]], [0.075, 0.25]),
           twip.FuzzyBasis.grid("gaussian", [phi5, [-2.0, -1.0, 0.0, 1.0, 2.0]], [0.075, 0.5]))
    yield ("7 x 7 triangles", twip.FuzzyBasis.grid("triangle", [phi7, omega7]),
           twip.FuzzyBasis.grid("triangle", [phi7, [2 * w for w in omega7]]))


def main() -> int:
    print(f"{'grids':<28} {'sizeof(TwipSmc)':>16} {'sizeof(TwipSmcConfig)':>22} {'init stack':>11} {'update stack':>13}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, yaw, pitch in grids():
            sc = scenarios.get("circle-smc-fuzzy")
            if yaw is not None:
                sc = sc.replace(controller=sc.controller.replace(yaw_sets=yaw, pitch_sets=pitch))
            out = Path(tmp) / name.split()[0]
            source = Path(export(sc, out, replay_seconds=0.1)["source"])
            (out / "probe.c").write_text(PROBE)
            subprocess.run(["make", "-s", "-C", str(out), "lib"], check=True)
            # Where the exported Makefile builds the library (its CARGO_TARGET_DIR default).
            target = Path(os.environ.get("CARGO_TARGET_DIR") or source / ".." / ".." / "target").resolve()
            lib = str(target / "release" / "libtwip_ffi.a")
            subprocess.run(["cc", "-O2", "-std=c11", "probe.c", "twip_config.c", lib, "-lpthread", "-ldl", "-lm",
                            "-o", "probe"], cwd=out, check=True)
            _, state, config, init, update = subprocess.run(["./probe"], cwd=out, capture_output=True, text=True,
                                                            check=True).stdout.split()
            print(f"{name:<28} {state:>16} {config:>22} {init:>11} {update:>13}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
