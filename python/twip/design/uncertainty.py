"""The uncertainty a design is judged under: a scenario for a robot (a RobotParams or a
sysid `Fit`, whose covariance becomes perturbations), the sweep seeds of the tuning and
held-out sets, and the evaluation of a scenario over a sample set."""
from __future__ import annotations

import math
from typing import Mapping, Optional

import numpy as np

from twip import _core, checks
from twip.distributions import Normal

_bad = _core.InvalidParameterError

#: A Fit's parameters are drawn within this many standard deviations of the fitted value.
FIT_REACH = 3.0


def scipy_seed(seed: int) -> dict:
    """SciPy's seeding keyword (rng= since SciPy 1.15, seed= before it) with a fresh
    generator of `seed`: the same stream on either, for any seed below 2**64."""
    import scipy

    major, minor = (int(x) for x in scipy.__version__.split(".")[:2])
    return {"rng" if (major, minor) >= (1, 15) else "seed": np.random.default_rng(seed)}


def held_out_seed(seed: int) -> int:
    """The sweep seed of the held-out robots: another counter-based key than `seed`'s, so
    other robots and other noise."""
    return int(np.random.SeedSequence([seed, 59]).generate_state(1, np.uint64)[0])


def positive_int(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
        raise _bad(f"{name} = {value!r}: must be a positive integer")
    return int(value)


def clamped_variance(reach: float) -> float:
    """The variance of a standard normal draw clamped to ±`reach`: 1 − 2cφ(c) + (c² − 1)·P(|Z| > c)."""
    tail = math.erfc(reach / math.sqrt(2))
    return 1 - 2 * reach * math.exp(-reach**2 / 2) / math.sqrt(2 * math.pi) + (reach**2 - 1) * tail


def fit_perturbations(fit) -> dict:
    """{field: Normal} from a Fit's covariance Σ, clamped to ±FIT_REACH std, drawn
    independently. Independent draws with the fit's own variances would have covariance
    diag(Σ), narrower than Σ along a correlated combination; so each variance is widened to
    its row sum d_i = Σ_j |Σ_ij| (diag(d) − Σ is diagonally dominant, hence positive
    semidefinite) and divided by the clamp's variance (clamped_variance): the set spreads the
    robots at least as wide as the fit in every direction (a conservative set). A singular
    covariance (a parameter or a combination the log did not determine) is refused."""
    cov = np.asarray(fit.covariance, float)
    names = list(fit.names)
    fields = set(_core.RobotParams.fields)
    if not fit.converged:
        raise _bad(f"robot: the Fit did not converge ({fit.message}); its covariance bounds nothing")
    if not np.all(np.isfinite(cov)):
        bad = [n for n, s in zip(names, np.diag(cov)) if not math.isfinite(s)]
        raise _bad(f"robot: the Fit's covariance is singular: the log did not determine {', '.join(bad)}; "
                   "fit them from a richer run or hold them fixed")
    std = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(std, std)
    eig = np.linalg.eigvalsh(corr) if len(names) else np.array([1.0])
    if not (np.all(std > 0) and eig.min() > 1e-10 * eig.max()):
        raise _bad(f"robot: the Fit's covariance of {', '.join(names)} is singular (smallest normalised "
                   f"eigenvalue {eig.min():.3g}): a combination of them is undetermined")
    widened = np.sqrt(np.abs(cov).sum(axis=1) / clamped_variance(FIT_REACH))
    out = {}
    for name, s in zip(names, widened):
        if name not in fields:
            raise _bad(f"robot: the Fit's free parameter '{name}' is not a RobotParams field; tune takes the "
                       "uncertainty of the robot's parameters only")
        mean = fit.values[name]
        low, high = mean - FIT_REACH * s, mean + FIT_REACH * s
        if low <= 0 < mean:
            raise _bad(f"robot: the Fit's {name} = {mean:g} ± {s:g} (std) reaches zero within {FIT_REACH:g} std: "
                       "too uncertain to design for")
        out[name] = Normal(std=float(s), low=low, high=high)
    return out


def scenario_for(scenario, robot=None, perturb: Optional[Mapping] = None):
    """(Scenario, perturb) for `scenario` (a name or a Scenario) on `robot` (None, a
    RobotParams, or a Fit whose covariance adds perturbations)."""
    from twip import scenarios
    from twip.sysid import Fit

    checks.of_type("scenario", scenario, (str, scenarios.Scenario), "a scenario name or a twip.scenarios.Scenario")
    checks.of_type("robot", robot, (_core.RobotParams, Fit, type(None)), "a twip.RobotParams, a twip.Fit or None")
    perturb = dict(checks.of_type("perturb", perturb or {}, Mapping, "a dict {name: twip.Uniform or twip.Normal}"))
    params = robot
    if isinstance(robot, Fit):
        extra = fit_perturbations(robot)
        both = sorted(set(extra) & set(perturb))
        if both:
            raise _bad(f"perturb: {', '.join(both)} also come from the Fit's covariance; give each once")
        perturb.update(extra)
        params = robot.robot
    if isinstance(scenario, str):
        return scenarios.get(scenario, params=params), perturb
    if params is not None:
        raise _bad("robot= goes with a scenario name (the scenario is built for it), not a Scenario object")
    return scenario, perturb


def sweep(sc, n, perturb, seed, realism, threads):
    """One sample set's sweep of `sc`: the same robots and noise for every controller
    (sample i depends on (seed, i) alone)."""
    from twip.sweep import montecarlo

    return montecarlo(sc, n, perturb=perturb, seed=seed, realism=realism, threads=threads, progress=False)
