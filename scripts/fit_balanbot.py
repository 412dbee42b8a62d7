"""Fits RobotParams.balanbot() to what the thesis publishes.

The thesis gives no robot parameters, but its results pin some:
  * flat-plane LQR with Q = diag(100, 1, 1, 1), R = 480 gives K = [-11, -1.7, -0.05, -0.045];
  * on a 15 deg slope at 250 deg/s the desired pitch from (4.12) is 12.5 deg.
The integral gain is sqrt(Q_zz / R) whatever the robot (docs/errata.md), so three gains
and one pitch constrain the robot. Eight parameters are free; a prior from the chapter 2
hardware (docs/parameters.md) picks the most plausible robot among those that fit.

Run:  .venv/bin/python scripts/fit_balanbot.py   (prints the fit and the table for the docs)
      .venv/bin/python scripts/fit_balanbot.py --coulomb   (the refit with gearhead friction:
      the no-load current read as Coulomb friction, twip.Friction.gb37(), so the viscous
      mu_bearing loses its no-load prior; docs/parameters.md, "Gearhead friction")
"""
import math
import sys

import numpy as np
from scipy.optimize import least_squares

import twip

K_PUBLISHED = np.array([-11.0, -1.7, -0.05, -0.045])
PHI_S_PUBLISHED = 12.5  # deg, (4.12) at 15 deg, 250 deg/s

# name: (prior estimate, relative uncertainty of the prior, lower bound, upper bound)
PRIOR = {
    "m_body": (0.85, 0.10, 0.6, 1.4),
    "m_wheels": (0.080, 0.25, 0.04, 0.2),
    "torque_constant": (9.9e-3, 0.10, 7e-3, 1.3e-2),
    "com_height": (0.06, 0.5, 0.02, 0.2),
    "i_body": (3.0e-3, 0.5, 5e-4, 2e-2),
    "i_motor": (4.0e-6, 1.0, 1e-7, 4e-5),
    "mu_bearing": (0.0115, 0.5, 1e-4, 0.05),
    "mu_ground": (2.0e-3, 1.0, 1e-5, 0.05),
}
# With the no-load torque taken as Coulomb friction (twip.Friction.gb37()), nothing in the
# data sheet is left for the bearing's viscous part: a weak prior of a tenth of it.
COULOMB_MU_BEARING_PRIOR = (0.00115, 2.0, 1e-5, 0.05)
NAMES = list(PRIOR)
PRIOR_WEIGHT = 0.01  # small: the published numbers dominate, the prior breaks ties


def predict(p: "twip.RobotParams"):
    flat = twip.SlopeModel(p, 0.0)
    gains = twip.LqrController.design(flat, math.radians(180), [100, 1, 1, 1], 480, point="thesis").gains
    slope = twip.SlopeModel(p, math.radians(15))
    x_s, _ = slope.equilibrium(math.radians(250), linear=True)
    return gains, math.degrees(x_s[0])


def params_of(z):
    return twip.RobotParams.balanbot().replace(**dict(zip(NAMES, np.exp(z))))


def residuals(z):
    gains, phi_s = predict(params_of(z))
    fit = np.concatenate([gains[:3] / K_PUBLISHED[:3] - 1.0, [(phi_s - PHI_S_PUBLISHED) / PHI_S_PUBLISHED]])
    prior = [(zi - math.log(PRIOR[n][0])) / PRIOR[n][1] for zi, n in zip(z, NAMES)]
    return np.concatenate([fit, PRIOR_WEIGHT * np.array(prior)])


def main():
    if "--coulomb" in sys.argv[1:]:
        PRIOR["mu_bearing"] = COULOMB_MU_BEARING_PRIOR
    lo = np.log([PRIOR[n][2] for n in NAMES])
    hi = np.log([PRIOR[n][3] for n in NAMES])
    z0 = np.log([PRIOR[n][0] for n in NAMES])
    sol = least_squares(residuals, z0, bounds=(lo, hi), xtol=1e-14, ftol=1e-14)
    p = params_of(sol.x)
    gains, phi_s = predict(p)
    print("fitted parameters (prior -> fit):")
    for n, zi in zip(NAMES, sol.x):
        print(f"  {n:16s} {PRIOR[n][0]:.4g} -> {math.exp(zi):.4g}")
    print("\n| quantity | published | twip | difference |\n|---|---|---|---|")
    for i, name in enumerate(["k_phi", "k_phi_dot", "k_theta_dot", "k_z"]):
        print(f"| {name} | {K_PUBLISHED[i]} | {gains[i]:.4f} | {100 * (gains[i] / K_PUBLISHED[i] - 1):+.2f} % |")
    print(f"| phi_s (4.12), 15 deg, 250 deg/s | {PHI_S_PUBLISHED} deg | {phi_s:.3f} deg | {phi_s - PHI_S_PUBLISHED:+.3f} deg |")
    x_s, _ = twip.SlopeModel(p, math.radians(15)).equilibrium(math.radians(250))
    print(f"| phi_s nonlinear (4.42 corrected) | 12.5 deg | {math.degrees(x_s[0]):.3f} deg | {math.degrees(x_s[0]) - 12.5:+.3f} deg |")
    print("\nRust constant (paste into crates/twip-core/src/model/params.rs BALANBOT):")
    for n in twip.RobotParams.fields:
        print(f"    {getattr(p, n)!r:<24}// {n}")


if __name__ == "__main__":
    main()
