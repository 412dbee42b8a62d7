"""Does designing the slope LQR at its own period, with the rig's one-period delay in the
model, keep more robots up on the thesis-like rig?

Three designs of the `slope-lqr` controller with the thesis's weights (4.25), all run by the
same 4-gain law at 5 ms: the thesis's continuous LQR (the default), the discrete design at
the controller period (`discrete=True`: zero-order hold, the integrator as the controller
runs it, dlqr), and the discrete design that also models the one-period command delay of
`twip.Realism.thesis_like()` (`delay=True`: the best 4 gains on the delayed model, see
docs/dare.md). Each is swept over the same robots and the same noise (same seed), with
m_body, com_height, i_body and mu_bearing drawn uniformly within +-X % (X from --rel).

Run:  .venv/bin/python examples/discrete_lqr_delay.py [--n 2000] [--rel 0.3 0.2 0.1]
"""
import argparse
import math
import time

import numpy as np

import twip
import twip.scenarios as scenarios
from twip.scenarios.lqr import THESIS_WEIGHTS

PERTURBED = ("m_body", "com_height", "i_body", "mu_bearing")
DESIGNS = {"continuous (thesis)": {}, "discrete": {"discrete": True}, "discrete + delay": {"discrete": True, "delay": True}}


def designs(scenario):
    model, (q, r) = scenario.controller.model, THESIS_WEIGHTS
    speed, period = math.radians(250), scenario.controller.period
    for name, options in DESIGNS.items():
        yield name, twip.LqrController.design(model, speed, q, r, period=period, **options)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--rel", type=float, nargs="+", default=[0.3, 0.2, 0.1])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    base = scenarios.get("slope-lqr")
    realism = twip.Realism.thesis_like()
    for name, ctrl in designs(base):
        print(f"{name:20s} gains {np.array2string(ctrl.gains, precision=4)}")
    for rel in args.rel:
        perturb = {p: twip.Uniform(rel=rel) for p in PERTURBED}
        for name, ctrl in designs(base):
            start = time.perf_counter()
            sweep = twip.montecarlo(base.replace(controller=ctrl), args.n, perturb=perturb, realism=realism,
                                    seed=args.seed, progress=False)
            lo, hi = sweep.fall_rate_interval()
            print(f"+-{rel:.0%} {name:20s} fall rate {sweep.fall_rate:7.2%} (95 %: {lo:.2%}-{hi:.2%}), "
                  f"{args.n} runs in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
