"""Fall-rate maps: how robust is each controller family, on the real robot, to the slope,
mass, centre of mass and friction errors it was not designed for?

One sweep per map: the two perturbed quantities are drawn uniformly over the map's
range, every sample is one closed-loop run of the scenario with the thesis's robot in
the loop (twip.Realism.thesis_like(): 5 ms loop with one period of delay, MPU-6050
noise and biases through a complementary filter, 700 CPR encoders, the L298P's 2 V drop
and 2 A limit on 11.1 V, the GB37 gearheads' friction and 1 degree of backlash), and the
samples are binned on a grid; a cell's colour is the
fraction that fell. The controllers are designed on the nominal robot and never see
the error. With --ideal the 2-DOF maps are run on the ideal robot (no realism) instead,
and every cell is 0: the limits of the motor driver and the noisy, delayed feedback are
what draw the boundary.

- slope-mass: the flat-ground designs (flat-*-sim) on slopes of 0-30 deg, body mass
  +-50 %: the motor driver runs out of current and voltage to hold the slope.
- com-friction: the 15 deg slope designs (slope-*-sim), centre-of-mass height +-50 %,
  ground friction 0-2x nominal: with less damping than designed for, the delayed,
  quantised loop on the slope stops settling.
- tracking: the 3-DOF trackers (PID, sliding mode + fuzzy) on two laps of the circle,
  centre-of-mass height and body mass +-90 %, on the thesis-like robot too. They
  hardly fall on this map (PID never; sliding mode + fuzzy in 0.2 % of 1500 runs,
  measured with the defaults), so the cells show the
  mean of the largest distance from the path during the second lap instead.

Run:  .venv/bin/python examples/robustness_heatmaps.py [--n 6000] [--bins 15] [--out robustness] [--ideal]
(31-33 s on 2 cores with the defaults: 4 sweeps of 6000 runs of 10 s, 2 of 1500 of two laps;
--ideal runs the 4 sweeps of the 2-DOF maps only, without realism, and names the files *_ideal.png)
"""
import argparse
import math
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import twip
import twip.scenarios

MAPS = {
    # name: (x perturbation, y perturbation, {label: scenario}); a perturbation is
    # (name, distribution, axis label, scale to the plotted unit or None for % error)
    "slope-mass": (
        ("slope", twip.Uniform(low=0.0, high=math.radians(30)), "slope [deg]", math.degrees(1)),
        ("m_body", twip.Uniform(rel=0.5), "body mass error [%]", None),
        {"LQR": "flat-lqr-sim", "fuzzy": "flat-fuzzy-sim"},
    ),
    "com-friction": (
        ("com_height", twip.Uniform(rel=0.5), "centre-of-mass height error [%]", None),
        ("mu_ground", twip.Uniform(rel=1.0), "ground friction error [%]", None),
        {"LQR": "slope-lqr-sim", "fuzzy": "slope-fuzzy-sim"},
    ),
    "tracking": (
        ("com_height", twip.Uniform(rel=0.9), "centre-of-mass height error [%]", None),
        ("m_body", twip.Uniform(rel=0.9), "body mass error [%]", None),
        {"PID": "circle-pid", "SMC + fuzzy": "circle-smc-fuzzy"},
    ),
}
# What a cell shows: the fraction that fell, or (tracking) a metric's mean over the cell.
CELL = {"tracking": ("max_path_error_settled", "largest path error in the second lap [m]", 1000.0)}
TRACKING_SAMPLES, TRACKING_BINS = 1500, 12  # 3-DOF runs are slower: fewer, larger cells
REALISM = twip.Realism.thesis_like()


def relative(values, nominal):
    return 100.0 * (values / nominal - 1.0)


def cell_map(scenario, xp, yp, n, seed, bins, metric=None, realism=REALISM):
    """Per cell: the fraction of runs that fell, or the mean of `metric`."""
    (xname, xdist, _, xscale), (yname, ydist, _, yscale) = xp, yp
    planar = metric is not None
    options = {"laps": 2.0} if planar else {"t_final": 10.0}
    result = twip.montecarlo(scenario, n, perturb={xname: xdist, yname: ydist}, seed=seed,
                             options=options, realism=realism, progress=False)
    nominal = twip.RobotParams.balanbot().to_dict()
    xs, ys = [], []
    for i in range(result.n):
        params, slope, _ = result.sample(i)
        values = {**params.to_dict(), "slope": slope}
        xs.append(values[xname])
        ys.append(values[yname])
    xs, ys = np.array(xs), np.array(ys)
    xs = xs * xscale if xscale else relative(xs, nominal[xname])
    ys = ys * yscale if yscale else relative(ys, nominal[yname])
    total, xe, ye = np.histogram2d(xs, ys, bins=bins)
    if planar:
        ok = result.valid & ~result.metrics["fell"]
        summed, _, _ = np.histogram2d(xs[ok], ys[ok], bins=[xe, ye], weights=result.metrics[metric][ok])
        count, _, _ = np.histogram2d(xs[ok], ys[ok], bins=[xe, ye])
        with np.errstate(invalid="ignore"):
            return summed / count, xe, ye, result
    fell = result.metrics["fell"] | ~result.valid
    falls, _, _ = np.histogram2d(xs[fell], ys[fell], bins=[xe, ye])
    with np.errstate(invalid="ignore"):
        return falls / total, xe, ye, result


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=6_000, help="samples per map and controller")
    ap.add_argument("--bins", type=int, default=15)
    ap.add_argument("--out", default="robustness", help="folder for the PNG files")
    ap.add_argument("--ideal", action="store_true",
                    help="the 2-DOF fall maps on the ideal robot (no realism); the tracking map is skipped")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    for map_name, (xp, yp, controllers) in MAPS.items():
        if args.ideal and map_name in CELL:
            continue  # the --ideal comparison is for the fall maps
        fig, axes = plt.subplots(1, len(controllers), figsize=(5.2 * len(controllers), 4.4), constrained_layout=True)
        metric, label_of_cell, unit = CELL.get(map_name, (None, "fraction of runs that fell", 1.0))
        n = min(args.n, TRACKING_SAMPLES) if metric else args.n
        bins = min(args.bins, TRACKING_BINS) if metric else args.bins
        realism = None if args.ideal else REALISM
        cells = {label: cell_map(scenario, xp, yp, n, seed=1, bins=bins, metric=metric, realism=realism)
                 for label, scenario in controllers.items()}
        top = 1.0 if metric is None else unit * max(np.nanmax(c[0]) for c in cells.values())
        for ax, (label, scenario) in zip(np.atleast_1d(axes), controllers.items()):
            value, xe, ye, result = cells[label]
            mesh = ax.pcolormesh(xe, ye, unit * value.T, vmin=0, vmax=top, cmap="magma_r")
            ax.set(xlabel=xp[2], ylabel=yp[2], title=f"{label} ({scenario}): fall rate {result.fall_rate:.1%}")
            print(f"{map_name} {label}: {result.n} samples, fall rate {result.fall_rate:.3f} "
                  f"(cells {unit * np.nanmin(value):.3g}-{unit * np.nanmax(value):.3g}), {result.elapsed:.1f} s, "
                  f"{result.steps / result.elapsed / 1e6:.1f} M sample-steps/s")
        fig.colorbar(mesh, ax=axes, label=label_of_cell.replace("[m]", "[mm]") if metric else label_of_cell)
        hardware = ("thesis-like robot: 5 ms loop + delay, MPU-6050 noise, encoders,\n"
                    "L298P 2 A / 11.1 V, GB37 friction, 1° backlash")
        fig.suptitle("ideal robot (no realism)" if args.ideal else
                     f"{hardware}; second lap of the circle" if metric else hardware)
        path = out / f"{'tracking_error' if metric else 'fall_rate'}_{map_name}{'_ideal' if args.ideal else ''}.png"
        fig.savefig(path, dpi=110)
        print(f"wrote {path}")
    print(f"total {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
