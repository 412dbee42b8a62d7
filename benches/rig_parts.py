"""What each part of the thesis-like rig costs a sweep's lanes, side by side in one run.

flat-lqr-sim (10 s at dt = 1 ms) swept over perturbed robots (as benches/families.py) on one
thread, through `twip.Realism.thesis_like()`, then with one part taken out at a time (its
`replace(part=None)`; the IMU also sampled 5x less often, unquantised, and with its widest
filter), then with the gearheads' friction and play both out, and through a rig
of nothing but its 5 ms loop and one-period delay; beside the LQR lanes without a rig.
`--repeats` rounds, each running every row once in turn; printed: M sample-steps per CPU-second
(median over the rounds) and the ratio to the LQR lanes in the same round (median and range),
against which the issue states the rig's target (>= 0.3x).

Run:  .venv/bin/python benches/rig_parts.py [--samples 512] [--repeats 2] [--kernel-copy avx2]
"""
import argparse
import statistics
import time

import twip

PERTURB = {"m_body": twip.Uniform(rel=0.2), "com_height": twip.Uniform(rel=0.1), "i_body": twip.Uniform(rel=0.2)}


def rows():
    """(label, realism or None for the LQR lanes)."""
    rig = twip.Realism.thesis_like()
    return [
        ("LQR lanes, no rig", None),
        ("thesis-like rig", rig),
        ("  without IMU", rig.replace(imu=None)),
        ("  IMU sampled at 200 Hz, not 1 kHz", rig.replace(imu=rig.imu.replace(sample_rate=200.0))),
        ("  IMU registers not quantised", rig.replace(imu=rig.imu.replace(quantise=False))),
        ("  IMU's DLPF at its widest, 260 Hz", rig.replace(imu=rig.imu.replace(dlpf_hz=260.0))),
        ("  without encoders", rig.replace(encoder_cpr=None)),
        ("  without motor driver", rig.replace(motor=None)),
        ("  without gearhead friction", rig.replace(friction=None)),
        ("  without backlash", rig.replace(backlash=None)),
        ("  without friction and backlash", rig.replace(friction=None, backlash=None)),
        ("5 ms loop and delay alone", twip.Realism(control_period=5e-3, delay=True)),
    ]


def rate(scenario, realism, samples):
    """M sample-steps per CPU-second of one sweep on one thread."""
    start = time.process_time()
    result = twip.montecarlo(scenario, samples, perturb=PERTURB, seed=1, progress=False, threads=1, realism=realism)
    return result.steps / (time.process_time() - start) / 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=512, help="rig samples per row (the LQR lanes run 4x as many)")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--kernel-copy", default=None, help="avx512, avx2 or baseline (default: the widest this CPU runs)")
    args = parser.parse_args()
    print(f"kernel copy: {twip.use_kernel_copy(args.kernel_copy)}")
    scenario = twip.scenarios.get("flat-lqr-sim", t_final=10.0)
    table = rows()
    rate(scenario, None, 16)  # warm-up
    rates = {label: [] for label, _ in table}
    ratios = {label: [] for label, _ in table}
    for _ in range(args.repeats):
        lqr = None
        for label, realism in table:
            r = rate(scenario, realism, args.samples * (4 if realism is None else 1))
            lqr = r if realism is None else lqr
            rates[label].append(r)
            ratios[label].append(r / lqr)
    print(f"{'row':38s} {'M sample-steps/CPU-s':>21s} {'x LQR lanes (range)':>22s}")
    for label, _ in table:
        ratio = ratios[label]
        print(f"{label:38s} {statistics.median(rates[label]):21.2f} "
              f"{statistics.median(ratio):10.3f} ({min(ratio):.3f}-{max(ratio):.3f})")


if __name__ == "__main__":
    main()
