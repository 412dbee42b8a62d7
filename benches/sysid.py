"""System identification's speed: four parameters of the Balanbot (m_body, com_height,
i_body, mu_bearing, 15-25 % off) from a 12 s log at 1 kHz (12 001 samples), target under
2 s. Cases: exact states; states with measurement noise; the thesis-like rig's raw
sensors (PWM in; gyro, accelerometer and encoder out; its driver's inductance and current
limit, IMU and encoder, without the gearheads' friction and backlash, which the fit's model
does not have: docs/sysid.md's case, so that the largest error printed means something).
Each fit is timed `--repeats` times
after one warm-up; printed: the median and the range, in s, and the iterations.

Run:  .venv/bin/python benches/sysid.py [--repeats 5]   (after `make build`)
"""
import argparse
import statistics
import time

import numpy as np

import twip
from twip.sysid import Sensors, identify

FREE = ["m_body", "com_height", "i_body", "mu_bearing"]
TRUE = twip.RobotParams.balanbot().replace(m_body=0.8301 * 1.2, com_height=0.04943 * 0.8, i_body=0.004994 * 1.25,
                                           mu_bearing=0.01066 * 1.15)


def logs():
    sc = twip.scenarios.get("flat-lqr")
    model = twip.SlopeModel(TRUE, 0.0)
    run = twip.simulate(model, sc.controller, [0.05, 0, 0, 0], 12.0, dt=1e-3, reference=sc.reference)
    exact = run.to_log()
    rng = np.random.default_rng(0)
    noise = {"phi": 0.002, "phi_dot": 0.02, "theta": 0.005, "theta_dot": 0.05}
    noisy = exact.with_signals(**{k: getattr(exact, k) + rng.normal(0, s, len(exact)) for k, s in noise.items()})
    realism = twip.Realism.thesis_like().replace(friction=None, backlash=None)
    raw = twip.simulate(model, sc.controller, [0.05, 0, 0, 0], 12.0, dt=1e-3, reference=sc.reference,
                        realism=realism).to_log()
    return {"exact states": (exact, {}), "noisy states": (noisy, {}),
            "thesis-like rig, raw sensors": (raw, {"driver": realism.motor, "sensors": Sensors.of(realism)})}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print(f"twip.identify, 4 parameters, 12 s at 1 kHz; median (min-max) of {args.repeats} fits")
    for name, (log, options) in logs().items():
        fit = identify(log, twip.RobotParams.balanbot(), FREE, **options)  # warm-up
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            fit = identify(log, twip.RobotParams.balanbot(), FREE, **options)
            times.append(time.perf_counter() - start)
        worst = max(abs(fit.values[n] / TRUE.to_dict()[n] - 1) for n in FREE)
        print(f"  {name:<30} {statistics.median(times):6.2f} s ({min(times):.2f}-{max(times):.2f}), "
              f"{fit.iterations} iterations, largest error {worst:.2%}")


if __name__ == "__main__":
    main()
