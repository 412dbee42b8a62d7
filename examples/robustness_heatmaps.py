"""Fall-rate maps: how robust is each controller family to the slope, mass, centre of
mass and friction errors it was not designed for?

One sweep per map: the two perturbed quantities are drawn uniformly over the map's
range, every sample is one closed-loop run of the scenario, and the samples are binned
on a grid; a cell's colour is the fraction that fell. The controllers are designed on
the nominal robot (RobotParams.balanbot(), flat ground) and never see the error.

Run:  .venv/bin/python examples/robustness_heatmaps.py [--n 20000] [--out robustness]
"""
import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import twip
import twip.scenarios

MAPS = {
    # name: (x perturbation, y perturbation, axis labels, scale to the plotted unit)
    "slope-mass": (
        ("slope", twip.Uniform(low=0.0, high=math.radians(30)), "slope [deg]", math.degrees(1)),
        ("m_body", twip.Uniform(rel=0.5), "body mass error [%]", None),
    ),
    "com-friction": (
        ("com_height", twip.Uniform(rel=0.5), "centre-of-mass height error [%]", None),
        ("mu_ground", twip.Uniform(low=0.0, high=0.05), "ground friction [N m s/rad]", 1.0),
    ),
}
CONTROLLERS = {"LQR": "flat-lqr-sim", "fuzzy": "flat-fuzzy-sim"}


def relative(values, nominal):
    return 100.0 * (values / nominal - 1.0)


def fall_map(scenario, xp, yp, n, seed, bins):
    (xname, xdist, _, xscale), (yname, ydist, _, yscale) = xp, yp
    result = twip.montecarlo(scenario, n, perturb={xname: xdist, yname: ydist}, seed=seed,
                             options={"t_final": 10.0})
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
    fell = result.metrics["fell"] | ~result.valid
    total, xe, ye = np.histogram2d(xs, ys, bins=bins)
    falls, _, _ = np.histogram2d(xs[fell], ys[fell], bins=[xe, ye])
    with np.errstate(invalid="ignore"):
        return falls / total, xe, ye, result


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=20_000, help="samples per map and controller")
    ap.add_argument("--bins", type=int, default=20)
    ap.add_argument("--out", default="robustness", help="folder for the PNG files")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for map_name, (xp, yp) in MAPS.items():
        fig, axes = plt.subplots(1, len(CONTROLLERS), figsize=(5.2 * len(CONTROLLERS), 4.4), constrained_layout=True)
        for ax, (label, scenario) in zip(np.atleast_1d(axes), CONTROLLERS.items()):
            rate, xe, ye, result = fall_map(scenario, xp, yp, args.n, seed=1, bins=args.bins)
            mesh = ax.pcolormesh(xe, ye, rate.T, vmin=0, vmax=1, cmap="magma_r")
            ax.set(xlabel=xp[2], ylabel=yp[2], title=f"{label} ({scenario}): fall rate {result.fall_rate:.1%}")
            print(f"{map_name} {label}: {result.n} samples, fall rate {result.fall_rate:.3f}, "
                  f"{result.steps / result.elapsed / 1e6:.1f} M sample-steps/s")
        fig.colorbar(mesh, ax=axes, label="fraction of runs that fell")
        path = out / f"fall_rate_{map_name}.png"
        fig.savefig(path, dpi=110)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
