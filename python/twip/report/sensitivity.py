"""How much our numbers depend on what the thesis does not publish: each claim that rests on
unpublished choices is rerun over the joint box of them (report.joint: a Sobol sample with
twip's default run counted, then a search toward the box's faces for the low and the high),
and its row gets `sensitivity = {"choices": {name: [low, high] or [alternatives]}, "low",
"high", "holds": share of the sampled runs, "runs", "searched", "detail": [...]}`.
The ranges, and why each is plausible, are the module's constants."""
from __future__ import annotations

from typing import Callable, Dict, Optional, Sequence

from twip import scenarios
from twip.report.experiments import FRICTIONS, TABLE_5_1_RUNS, scenario_on, table_5_1_row
from twip.report.joint import Among, Box, Span, search
from twip.scenarios.fuzzy import SET_CHOICES, sets_of

#: The go-and-back run's waits [s] at the far goal and at home (the thesis shows a hold but
#: gives no length, except slope-lqr's "5 seconds"; twip's 5 s each). 3-7 s spans what its
#: figures could show.
HOLD = Span(3.0, 7.0, 5.0)
SETTLE = Span(3.0, 7.0, 5.0)
#: The control loop's period [s] of every experiment and tracker: the thesis does not state its
#: Arduino loop; 2-10 ms spans what an Uno's loop with an MPU-6050 read takes.
PERIOD = Span(0.002, 0.01, 0.005, step=0.001)  # whole 1 ms RK4 steps
#: The fuzzy adaptation gain Γ (unpublished): from barely moving to about as fast as the PD.
GAMMA = Span(0.005, 1.0, 0.02, log=True)
#: The weights' leakage σ [1/s] (unpublished), over the range docs/scenarios.md scans.
SIGMA = Span(0.01, 0.2, 0.05, log=True)
#: The fuzzy sets of Figs 4.4/4.5 (drawn without numbers): scenarios.fuzzy.SET_CHOICES.
SETS = Among(tuple(SET_CHOICES))
#: The sliding-mode trackers' unpublished gains (errata T4): the kinematic k1, k2, k3 and the
#: pitch gain k_φ of λ1 = −k_φ φ (4.74), from half to double twip's k1 = k2 = 2, k3 = 4,
#: k_φ = 2. λ1's form is published, so it is not varied: the scenarios run with twip's
#: correction of it (errata T8), Table 5.2's conclusion is judged with the thesis's own.
SMC_GAINS = {"k1": Span(1.0, 4.0, 2.0, log=True), "k2": Span(1.0, 4.0, 2.0, log=True),
             "k3": Span(2.0, 8.0, 4.0, log=True), "k_phi": Span(1.0, 4.0, 2.0, log=True)}
#: Gearhead friction on the plant (report.experiments.FRICTIONS): none, the GB37's no-load
#: torque split beside balanbot()'s fitted viscous bearing, and all of it as Coulomb friction
#: on the robot refitted for it.
FRICTION = Among(FRICTIONS)
#: Settling bands (a measurement of the same run): the report's 2 %, the textbook 5 %, and
#: 1 % to 0.2 %, where a curve meets its line on a plot like the thesis's. The pitch's keeps
#: its 0.25° floor.
BANDS = {"2 %": 0.02, "5 %": 0.05, "1 %": 0.01, "0.5 %": 0.005, "0.2 %": 0.002}
BAND = Among(tuple(BANDS))
#: Sobol points per joint box (a power of 2), besides twip's default run: (full, quick) for
#: the 2-DOF runs and for the 3-DOF trackers (each some 5x dearer).
SAMPLES = {False: 16, True: 4}
PLANAR_SAMPLES = {False: 8, True: 2}
SEED = 62


def _table_5_1_box(surface: str, controller: str) -> Box:
    """The unpublished choices of one Table 5.1 row's experiment."""
    box: Box = {"settle [s]": SETTLE, "loop period [s]": PERIOD}
    if controller != "lqr":  # the LQR's holds are published: 5 s on the slope, none on the flat
        box = {"hold [s]": HOLD, **box}
    if controller == "fuzzy":
        box.update({"gamma": GAMMA, "sigma": SIGMA, "sets": SETS})
    box["gearhead friction"] = FRICTION
    return box


def _options(values: dict) -> dict:
    """scenarios.get's options for a point of a box (the friction and band are not options)."""
    names = {"hold [s]": "hold", "settle [s]": "settle", "loop period [s]": "period", "gamma": "gamma",
             "sigma": "sigma"}
    out = {names[k]: v for k, v in values.items() if k in names}
    if "sets" in values:
        out["sets"] = sets_of(values["sets"])
    gains = {k: v for k, v in values.items() if k in SMC_GAINS}
    if gains:
        out["gains"] = gains
    return out


def table_5_1(judge: Callable[[str, str, str, float], bool], quick: bool) -> Dict[str, dict]:
    """Table 5.1's rows, each over the joint box of its own experiment's choices, and the
    "fuzzy better than LQR" conclusions over the union of both boxes: {claim id: sensitivity}.
    `judge(controller, surface, metric, ours)` says whether a row's claim holds."""
    out: Dict[str, dict] = {}
    for surface, controller in TABLE_5_1_RUNS:
        cid = f"table-5.1/{controller}-{surface}"

        def evaluate(values, surface=surface, controller=controller):
            r = table_5_1_row(surface, controller, friction=values["gearhead friction"], **_options(values))
            ok = r["outcome"] == "completed"
            return {m: (r[key] if ok else None, ok and judge(controller, surface, m, r[key]))
                    for m, key in (("pitch", "pitch_error_deg"), ("speed", "speed_error_deg_s"))}

        for metric, entry in search(_table_5_1_box(surface, controller), evaluate, ("pitch", "speed"),
                                    SAMPLES[quick], SEED, extremes=not quick).items():
            out[f"{cid}/{metric}"] = entry
    for surface in ("flat", "slope"):
        out[f"table-5.1/fuzzy-beats-lqr-{surface}"] = fuzzy_beats_lqr(surface, quick)
    return out


def fuzzy_beats_lqr(surface: str, quick: bool) -> dict:
    """Table 5.1's "fuzzy better than LQR" on `surface` over the union of both rows' boxes
    (each controller's own choices, one gearhead friction for both): its number is
    fuzzy_margin, searched for the low and the high like every other claim's."""
    lqr_box, fuzzy_box = _table_5_1_box(surface, "lqr"), _table_5_1_box(surface, "fuzzy")
    box = {**{f"LQR {k}": v for k, v in lqr_box.items() if k != "gearhead friction"},
           **{f"fuzzy {k}": v for k, v in fuzzy_box.items() if k != "gearhead friction"},
           "gearhead friction": FRICTION}

    def better(values):
        rows = {}
        for controller in ("lqr", "fuzzy"):
            prefix = "LQR " if controller == "lqr" else "fuzzy "
            own = {k[len(prefix):]: v for k, v in values.items() if k.startswith(prefix)}
            rows[controller] = table_5_1_row(surface, controller, friction=values["gearhead friction"], **_options(own))
        margin = fuzzy_margin(rows["lqr"], rows["fuzzy"])
        return {"better": (margin, margin is not None and margin > 1.0)}

    entry = search(box, better, ("better",), SAMPLES[quick], SEED, extremes=not quick)["better"]
    entry["measure"] = FUZZY_MARGIN
    return entry


#: What the "fuzzy better than LQR" conclusions' sensitivity numbers are.
FUZZY_MARGIN = "LQR's error over fuzzy's, the smaller of the two columns (above 1: fuzzy better in both)"


def fuzzy_margin(lqr: dict, fuzzy: dict) -> Optional[float]:
    """How far fuzzy beats LQR in two Table 5.1 rows (table_5_1_row's) of one surface: LQR's
    mean |error| over fuzzy's in the column where that is smaller (FUZZY_MARGIN); fuzzy is
    better in both columns exactly when it is above 1. None when either run fell."""
    if not lqr["outcome"] == fuzzy["outcome"] == "completed":
        return None
    return min(lqr[k] / fuzzy[k] if fuzzy[k] > 0 else float("inf") for k in ("pitch_error_deg", "speed_error_deg_s"))


def _box(name: str, claimed: Sequence[str], settling: Sequence[str]) -> Box:
    """The unpublished choices scenario `name`'s claims (`claimed`) depend on."""
    have = scenarios.options(name)
    box: Box = {}
    if "hold" in have:
        if name != "slope-lqr":  # its hold is the thesis's ("for 5 seconds")
            box["hold [s]"] = HOLD
        box["settle [s]"] = SETTLE
    if "period" in have and not name.endswith("-sim"):  # the "-sim" runs are the thesis's simulations (1 ms)
        box["loop period [s]"] = PERIOD
    if "gamma" in have:
        box.update({"gamma": GAMMA, "sigma": SIGMA, "sets": SETS})
    if "pitch_offset" in have:
        box.update(SMC_GAINS)
    if not name.endswith("-sim"):  # the thesis's simulations model only viscous friction
        box["gearhead friction"] = FRICTION
    if any(k in settling for k in claimed):
        box["settling band"] = BAND
    return box


def scenario_claims(judge: Callable, measure: Callable, keys: Sequence[str], quick: bool,
                    settling: Sequence[str] = (), names: Optional[Sequence[str]] = None) -> Dict[str, dict]:
    """Every scenario's run-based claims (`keys`) over the joint box of the unpublished
    choices its runs depend on (`_box`); its settling claims (`settling`) also over the band
    they are measured at: `judge(sc, key, ours)`, `measure(sc, key, run, band=None)` as in
    report.claims. `names`: only these scenarios (default every one)."""
    from twip import _core
    from twip.report.claims import MEASURES, one_number

    out = {}
    for name in scenarios.names() if names is None else names:
        base = scenarios.get(name)
        claimed = [k for k in base.thesis if k in keys]
        box = _box(name, claimed, settling)
        if not claimed or not box:
            continue
        planar = isinstance(base.model, _core.PlanarModel)
        ran: Dict[tuple, tuple] = {}  # the settling band is a measurement: one run serves every band

        def evaluate(values, name=name, claimed=claimed, planar=planar, ran=ran):
            run_values = {k: v for k, v in values.items() if k != "settling band"}
            key = tuple(sorted((k, str(v)) for k, v in run_values.items()))
            if key not in ran:
                sc = scenario_on(name, run_values.get("gearhead friction", FRICTIONS[0]), **_options(run_values))
                ran[key] = (sc, sc.run(record_every=10 if planar else 1))
            sc, r = ran[key]
            done = r.outcome == "completed"
            result = {}
            for k in claimed:
                band = BANDS[values["settling band"]] if k in settling and "settling band" in values else None
                ours = measure(sc, k, r) if band is None or band == BANDS["2 %"] else measure(sc, k, r, band=band)
                result[k] = (one_number(sc, k, ours) if done else None, done and judge(sc, k, ours))
            return result

        n = (PLANAR_SAMPLES if planar else SAMPLES)[quick]
        for k, entry in search(box, evaluate, claimed, n, SEED, extremes=not quick).items():
            if k in MEASURES:
                entry["measure"] = MEASURES[k]
            out[f"{name}/{k}"] = entry
    return out


#: Table 5.2's conclusion's unpublished choices (λ1's form is published: not among them).
TABLE_5_2_BOX: Box = {**SMC_GAINS, "loop period [s]": PERIOD, "gearhead friction": FRICTION}


def smc_versus_pid(ratio_of: Callable[[list], Optional[float]], laps: int, quick: bool = False) -> Dict[str, dict]:
    """Table 5.2's conclusion (PID error / sliding-mode error ≥ 2) with the thesis's λ1 (4.74)
    over the joint box of the sliding-mode tracker's unpublished gains k1, k2, k3, k_φ, the
    loop period (both trackers') and gearhead friction on the plants, over tracking.compare's
    plants; the PID, whose gains are published, is run once per period and friction."""
    from twip.report.experiments import robot
    from twip.scenarios import tracking

    pid: Dict[tuple, list] = {}

    def rows(name, values, params, friction):
        gains = {k: v for k, v in values.items() if k in SMC_GAINS}
        return tracking.compare(params=params, laps=laps, pitch_offset=False, friction=friction, trackers=(name,),
                                period=values["loop period [s]"], smc_gains=gains or None)

    def evaluate(values):
        params, friction = robot(values["gearhead friction"])
        key = (values["loop period [s]"], values["gearhead friction"])
        if key not in pid:
            pid[key] = rows("circle-pid", values, params, friction)
        ratio = ratio_of(pid[key] + rows("circle-smc-fuzzy", values, params, friction))
        return {"ratio": (ratio, ratio is not None and ratio >= 2.0)}  # None: a tracker fell, it does not hold

    entry = search(TABLE_5_2_BOX, evaluate, ("ratio",), PLANAR_SAMPLES[quick], SEED, extremes=not quick)["ratio"]
    return {"table-5.2/smc-beats-pid": entry}
