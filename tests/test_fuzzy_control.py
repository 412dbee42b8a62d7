"""Fuzzy adaptive backstepping + PD (thesis 4.1.2, 4.2.1): the scenarios, adaptation,
the position improvement, parity with the reference, errors."""
import math

import numpy as np
import pytest

import twip
import twip.reference as ref
import twip.reference.fuzzy as rf
import twip.scenarios as scenarios
from twip.reference.control import SpeedSchedule as RefSchedule
from twip.reference.control import simulate as ref_simulate
from twip.scenarios.fuzzy import SET_CHOICES, KI_FLAT, KI_SLOPE, compare_table, mismatched, sets_of, stop_errors
from conftest import rel_diff

SPEED = math.radians(180)


def weights(r):
    return np.column_stack([r.internals[f"S{k}"] for k in range(1, 10)])


def cruise_windows(sc, settle=5.0):
    """(start, end) of the constant-speed part of each moving leg, `settle` s after it starts."""
    radius = sc.model.params.wheel_radius
    t, at, out = 0.0, 0.0, []
    for goal, speed, hold in sc.reference.legs:
        duration = abs(goal - at) / speed
        if duration > settle:
            out.append((t + settle, t + duration))
        t += duration + hold
        at = goal
    return out or [(settle, sc.t_final)]


@pytest.mark.parametrize("name", ["slope-fuzzy", "flat-fuzzy", "slope-fuzzy-sim", "flat-fuzzy-sim"])
def test_thesis_gains_keep_it_up_hold_the_pitch_and_track_the_speed(name):
    sc = scenarios.get(name)
    r = sc.run()
    assert r.outcome == "completed"
    pitch_error = np.degrees(np.abs(r.states[:, 0] - r.internals["phi_s"]))
    assert np.all(pitch_error[r.t > 0.5] < 5.0), "pitch within 5 deg of phi_s once caught"
    worst_speed = 0.0
    for start, end in cruise_windows(sc):
        window = (r.t >= start) & (r.t < end)
        speed_ref = r.reference("theta_dot")[window]
        worst_speed = max(worst_speed, np.max(np.abs(r.states[window, 3] - speed_ref) / np.abs(speed_ref)))
    assert worst_speed < 0.05, "wheel speed within 5 % of the reference once settled"
    m = r.metrics
    msg = (f"{name}: mean |pitch err| {math.degrees(m['mean_abs_pitch_error']):.3f} deg, mean |speed err| "
           f"{math.degrees(m['mean_abs_speed_error']):.1f} deg/s, worst cruise speed err {100 * worst_speed:.1f} %, "
           f"pitch settles in {m['pitch_settling_time']:.2f} s (thesis ~{sc.thesis.get('pitch_settling_time', '-')} s), "
           f"peak |u| {m['peak_abs_input']:.2f} A")
    if "goals" in sc.thesis:
        msg += f", short of the goal at the end of each hold by {np.round(100 * stop_errors(sc, r), 2)} cm"
    print(msg)


def test_adaptive_weights_stay_bounded_over_two_minutes():
    for name in ("slope-fuzzy-sim", "flat-fuzzy-sim"):
        r = scenarios.get(name, period=5e-3, t_final=120.0).run(record_every=10)
        assert r.outcome == "completed"
        s = np.abs(weights(r))
        first, last = s[r.t < 60].max(), s[r.t >= 60].max()
        print(f"{name}: max |S| {first:.2f} in the first minute, {last:.2f} in the second; "
              f"V2 at the end {r.internals['V2'][-1]:.3g}")
        assert np.all(np.isfinite(s)) and first < 50 and last <= first


def test_phi_s_follows_the_reference_speed(balanbot):
    sc = scenarios.get("slope-fuzzy")
    r = sc.run()
    ctrl = sc.controller
    speeds = r.reference("theta_dot")
    # Internals are held between updates (5 ms = 5 steps): compare at the update samples.
    at_updates = slice(0, -1, 5)
    expected = [ctrl.steady_pitch(v) for v in speeds[at_updates]]
    np.testing.assert_allclose(r.internals["phi_s"][at_updates], expected, rtol=1e-14)
    values = np.unique(np.round(np.degrees(r.internals["phi_s"]), 9))
    print(f"phi_s over slope-fuzzy: {np.round(values, 3)} deg (up, stopped, down)")
    assert len(values) == 3
    assert ctrl.steady_pitch(0.0) < ctrl.steady_pitch(SPEED)
    assert abs(math.degrees(ctrl.steady_pitch(SPEED)) - 12.5) < 0.5


@pytest.mark.parametrize("name,ki", [("slope-fuzzy", KI_SLOPE), ("flat-fuzzy", KI_FLAT)])
def test_integral_term_stops_within_a_centimetre(name, ki):
    before = scenarios.get(name)
    after = scenarios.get(name, ki=ki)
    errs = {}
    for label, sc in (("thesis", before), (f"ki = {ki}", after)):
        r = sc.run()
        assert r.outcome == "completed"
        errs[label] = stop_errors(sc, r)
        print(f"{name} ({label}): short of the goal by {np.round(100 * errs[label], 2)} cm at the end of each hold, "
              f"final position error {100 * r.metrics['final_position_error']:.2f} cm")
    assert np.all(np.abs(errs[f"ki = {ki}"]) < 0.01)


@pytest.mark.parametrize("name", ["slope-fuzzy"])
def test_ki_is_tuned_for_the_five_second_holds(name):
    """docs/scenarios.md: a smaller |ki| leaves the robot short of the far goal, a larger one overshoots."""
    first = {}
    for ki in (-0.003, KI_SLOPE, -0.005, -0.01):
        sc = scenarios.get(name, ki=ki)
        r = sc.run()
        assert r.outcome == "completed"
        stops = 100 * stop_errors(sc, r)
        first[ki] = stops[0]
        print(f"{name}, ki = {ki}: stops {stops[0]:.1f} / {stops[1]:.1f} cm")
        assert np.all(np.abs(stops) < 3.0)
    assert first[-0.003] > first[KI_SLOPE] > first[-0.005] > 0 > first[-0.01]


def _errors(name, **options):
    """(mean |pitch error| [deg], mean |speed error| [deg/s], stops [cm]) of a completed run."""
    sc = scenarios.get(name, **options)
    r = sc.run()
    assert r.outcome == "completed", (name, options)
    m = r.metrics
    return math.degrees(m["mean_abs_pitch_error"]), math.degrees(m["mean_abs_speed_error"]), 100 * stop_errors(sc, r)


def test_the_results_do_not_hinge_on_the_fuzzy_sets():
    """Prints docs/scenarios.md's table of sets (`-s`): every choice completes both experiments with
    errors near the default's."""
    default = {n: _errors(n) for n in ("slope-fuzzy", "flat-fuzzy")}
    print("\n| sets (φ core/foot, φ̇ core/foot) | slope: pitch [°], speed [°/s], stops [cm] | flat: same |")
    for label in SET_CHOICES:
        sets = sets_of(label)
        cells = []
        for name in ("slope-fuzzy", "flat-fuzzy"):
            pitch, speed, stops = _errors(name, sets=sets)
            cells.append(f"{pitch:.3f}, {speed:.1f}, {stops[0]:.1f} / {stops[1]:.1f}")
            if "default" in label:
                assert (pitch, speed) == default[name][:2] and np.array_equal(stops, default[name][2])
            assert abs(pitch / default[name][0] - 1) < 0.25 and abs(speed / default[name][1] - 1) < 0.25, label
            assert np.all(np.abs(stops) < 12.0), label
        print(f"| {label} | {cells[0]} | {cells[1]} |")


def test_unpublished_adaptation_choices_account_for_the_settling_gaps():
    """The report's reasons for slope-fuzzy-sim's settling: with twip's σ and Γ the speed keeps
    a steady offset above the 2 % band, which a smaller leak σ or gain Γ removes (with the same
    kd/kp), and twip's fuzzy sets settle the pitch faster than the thesis's 1.5 s where the
    narrow or wide sets do not. The thesis publishes none of σ, Γ or the sets."""
    from twip.report.claims import settles_about

    def run(**options):
        r = scenarios.get("slope-fuzzy-sim", **options).run()
        last = r.t >= r.t[-1] - 1.0
        offset = np.mean(r.states[last, 3]) / np.mean(r.reference("theta_dot")[last]) - 1
        return r.metrics["speed_settling_time"], r.metrics["pitch_settling_time"], offset, r.t[-1]

    speed, pitch, offset, t_end = run()
    print(f"twip's choices: speed never settles ({100 * offset:+.2f} % at the end), pitch {pitch:.3f} s")
    assert speed == pytest.approx(t_end) and 0.02 < offset < 0.03
    assert not settles_about(1.5, pitch)
    for options in ({"sigma": 0.01}, {"gamma": 0.005}):
        speed, _, offset, _ = run(**options)
        print(f"{options}: speed settles in {speed:.3f} s ({100 * offset:+.2f} % at the end)")
        assert settles_about(5.0, speed) and abs(offset) < 0.01
    for label in ("narrow 0.05/0.15, 0.25/1", "wide 0.2/0.6, 1/4"):
        _, pitch, _, _ = run(sets=sets_of(label))
        print(f"sets {label}: pitch settles in {pitch:.3f} s")
        assert settles_about(1.5, pitch)


def test_gamma_sigma_scan():
    """Prints docs/scenarios.md's γ/σ scan (`-s`): slope-fuzzy pitch, speed, stops · flat-fuzzy pitch,
    speed. Faster adaptation (smaller γ) holds the slope's pitch tighter and slows the flat's speed loop."""
    sigmas, gammas = (0.01, 0.05, 0.2), (0.005, 0.02, 0.05, 0.2, 1.0)
    slope_pitch, flat_speed = np.zeros((len(gammas), len(sigmas))), np.zeros((len(gammas), len(sigmas)))
    print("\n| γ \\ σ | " + " | ".join(str(x) for x in sigmas) + " |")
    for i, gamma in enumerate(gammas):
        cells = []
        for j, sigma in enumerate(sigmas):
            p, v, stops = _errors("slope-fuzzy", gamma=gamma, sigma=sigma)
            fp, fv, _ = _errors("flat-fuzzy", gamma=gamma, sigma=sigma)
            slope_pitch[i, j], flat_speed[i, j] = p, fv
            cells.append(f"{p:.2f}, {v:.0f}, {stops[0]:.1f}/{stops[1]:.1f} · {fp:.2f}, {fv:.0f}")
        print(f"| {gamma} | " + " | ".join(cells) + " |")
    assert np.all(np.diff(slope_pitch, axis=0) > 0)
    assert np.all(flat_speed[0] > flat_speed[3])


def test_without_integral_the_slope_load_creeps_the_robot_uphill(balanbot):
    """The sigma-modification slowly hands the slope load from S to kp e: over minutes
    the robot creeps to e = u_s / kp. The integral term holds it."""
    plant = twip.SlopeModel(balanbot, math.radians(15))
    x0, _ = plant.equilibrium(0.0)
    hold = twip.SpeedSchedule([(0.75 / balanbot.wheel_radius, SPEED, 0.0)])
    drift = {}
    for ki in (0.0, KI_SLOPE):
        ctrl = twip.FuzzyController.thesis_slope(plant, ki=ki)
        r = twip.simulate(plant, ctrl, x0, 200.0, 1e-3, reference=hold, record_every=100)
        drift[ki] = 100 * r.metrics["final_position_error"]
    print(f"after 200 s holding 0.75 m on 15 deg: short by {drift[0.0]:.1f} cm (thesis), {drift[KI_SLOPE]:.2f} cm (ki)")
    assert drift[0.0] < -10 and abs(drift[KI_SLOPE]) < 1.0


def test_adaptation_learns_the_slope_load_in_the_nominal_case():
    on, off = scenarios.get("slope-fuzzy"), scenarios.get("slope-fuzzy", adapt=False)
    r_on, r_off = on.run(), off.run()
    assert np.all(weights(r_off) == 0.0)
    for key in ("mean_abs_pitch_error", "mean_abs_speed_error"):
        print(f"slope-fuzzy {key}: adaptation on {r_on.metrics[key]:.4f}, off {r_off.metrics[key]:.4f}")
        assert r_on.metrics[key] < 0.7 * r_off.metrics[key]
    stop_on, stop_off = stop_errors(on, r_on), stop_errors(off, r_off)
    print(f"stops: on {np.round(100 * stop_on, 2)} cm, off {np.round(100 * stop_off, 2)} cm")
    assert np.max(np.abs(stop_on)) < 0.2 * np.max(np.abs(stop_off))


def test_with_a_wrong_model_adaptation_pins_the_pitch_to_the_wrong_phi_s(balanbot):
    """A finding, not a wish: with the plant's body +-20 % the controller's phi_s (4.42) is
    not where the plant can stand still; the adaptive law integrates z2 and holds the pitch
    there, so the robot runs off further than with adaptation off (docs/scenarios.md)."""
    for case in ("all +20 %", "all -20 %"):
        plant = mismatched(balanbot, case)
        off = scenarios.get("slope-fuzzy", params=plant, controller_params=balanbot, adapt=False)
        on = scenarios.get("slope-fuzzy", params=plant, controller_params=balanbot)
        r_on, r_off = on.run(), off.run()
        s_on, s_off = r_on.metrics["mean_abs_speed_error"], r_off.metrics["mean_abs_speed_error"]
        print(f"slope-fuzzy, plant {case}: mean |speed err| on {math.degrees(s_on):.0f} deg/s, off "
              f"{math.degrees(s_off):.0f} deg/s; stops on {np.round(100 * stop_errors(on, r_on))} cm, "
              f"off {np.round(100 * stop_errors(off, r_off))} cm")
        assert r_on.outcome == r_off.outcome == "completed"
        assert s_on > 1.5 * s_off


def test_compare_table_nominal_fuzzy_beats_lqr():
    rows = compare_table(cases=["nominal"])
    by = {(r["surface"], r["controller"]): r for r in rows}
    for surface in ("flat", "slope"):
        f, q = by[(surface, "fuzzy")], by[(surface, "lqr")]
        print(f"{surface}: LQR {q['pitch_error_deg']:.3f} deg, {q['speed_error_deg_s']:.1f} deg/s; "
              f"fuzzy {f['pitch_error_deg']:.3f} deg, {f['speed_error_deg_s']:.1f} deg/s")
        assert f["pitch_error_deg"] < q["pitch_error_deg"] and f["speed_error_deg_s"] < q["speed_error_deg_s"]


def test_internals_and_v2(balanbot):
    sc = scenarios.get("flat-fuzzy-sim", period=5e-3)
    r = sc.run()
    names = [f"xi{k}" for k in range(1, 10)] + [f"S{k}" for k in range(1, 10)] + ["z2", "e1", "phi_s", "V2", "e", "e_int"]
    assert list(r.internals) == names == sc.controller.internal_names
    xi = np.column_stack([r.internals[f"xi{k}"] for k in range(1, 10)])
    np.testing.assert_allclose(xi[1:].sum(axis=1), 1.0, atol=1e-14)
    s = weights(r)
    i = r.internals
    v2 = 0.5 * i["e1"] ** 2 + 0.5 * i["z2"] ** 2 + 0.5 * sc.controller.gamma * np.sum(s * s, axis=1)
    np.testing.assert_allclose(i["V2"], v2, rtol=1e-12, atol=1e-15)
    # z2 = phi_dot + k1 e1 at each update (5 ms = 5 steps).
    k = slice(0, -1, 5)
    np.testing.assert_allclose(i["z2"][k], r.states[k, 1] + sc.controller.k1 * i["e1"][k], rtol=1e-12, atol=1e-15)


def test_g1_is_the_models_input_column(balanbot):
    model = twip.SlopeModel(balanbot, math.radians(15))
    ctrl = twip.FuzzyController.thesis_slope(model)
    reference = rf.FuzzyController(ref.SlopeModel(balanbot, model.slope), 10, 13, -0.01, -0.09)
    for phi in (-0.4, 0.0, 0.21, 0.8):
        x = np.array([phi, 0.1, 0.0, 2.0])
        column = (model.deriv(x, 1.0) - model.deriv(x, 0.0))[1]
        assert ctrl.g1(phi) == pytest.approx(column, rel=1e-12)
        assert ctrl.g1(phi) == pytest.approx(reference.g1(phi), rel=1e-13)  # (4.32)-(4.35) arrangement
        assert ctrl.g1(phi) < 0


def run_both(balanbot, slope, legs, t_final, rust_ctrl, ref_ctrl):
    model = twip.SlopeModel(balanbot, slope)
    r = twip.simulate(model, rust_ctrl, np.zeros(4), t_final, 1e-3, reference=twip.SpeedSchedule(legs))
    t, xs, us, ins = ref_simulate(ref.SlopeModel(balanbot, slope), ref_ctrl, np.zeros(4), t_final, 1e-3,
                                  RefSchedule(legs), internals=True)
    assert xs.shape == r.states.shape
    return rel_diff(r.states, xs), rel_diff(weights(r), ins[:, 9:18]), rel_diff(r.inputs[:, 0], us), r, ins


def test_closed_loop_run_matches_reference(balanbot):
    """The whole slope-fuzzy run (with the integral term, so every state is exercised)."""
    sc = scenarios.get("slope-fuzzy", ki=KI_SLOPE)
    ref_ctrl = rf.FuzzyController(ref.SlopeModel(balanbot, sc.model.slope), 10, 13, -0.01, -0.09,
                                  gamma=sc.controller.gamma, sigma=sc.controller.sigma, ki=KI_SLOPE, period=0.005)
    dx, ds, du, r, ins = run_both(balanbot, sc.model.slope, sc.reference.legs, sc.t_final, sc.controller, ref_ctrl)
    print(f"closed-loop slope-fuzzy, Rust vs reference: states {dx:.1e}, S(t) {ds:.1e}, u {du:.1e}")
    assert max(dx, ds, du) < 1e-9
    allr = np.column_stack([r.internals[n] for n in ref_ctrl.internal_names])
    np.testing.assert_allclose(allr, ins, rtol=1e-9, atol=1e-9)


def test_closed_loop_parity_with_custom_sets_and_initial_weights(balanbot):
    sets_rust = [[twip.Gaussian(-0.3, 0.15), twip.Triangle(-0.3, 0.0, 0.3), twip.Gaussian(0.3, 0.15)],
                 [twip.Trapezoid(-math.inf, -math.inf, -2, -0.5), twip.Triangle(-2, 0, 2), twip.Trapezoid(0.5, 2, math.inf, math.inf)]]
    sets_ref = [[rf.Gaussian(-0.3, 0.15), rf.Triangle(-0.3, 0.0, 0.3), rf.Gaussian(0.3, 0.15)],
                [rf.Trapezoid(-math.inf, -math.inf, -2, -0.5), rf.Triangle(-2, 0, 2), rf.Trapezoid(0.5, 2, math.inf, math.inf)]]
    s0 = np.linspace(-1, 1, 9)
    model = twip.SlopeModel(balanbot, 0.0)
    rust = twip.FuzzyController(model, 30, 33, -0.1, -0.9, gamma=0.05, sigma=0.1, sets=sets_rust, period=0.002, s0=s0)
    reference = rf.FuzzyController(ref.SlopeModel(balanbot, 0.0), 30, 33, -0.1, -0.9, gamma=0.05, sigma=0.1,
                                   sets=sets_ref, period=0.002, s0=s0)
    legs = [(0.5 / balanbot.wheel_radius, SPEED, 1.0), (0.0, SPEED, 0.0)]
    dx, ds, du, r, _ = run_both(balanbot, 0.0, legs, 6.0, rust, reference)
    print(f"closed-loop flat, Gaussian/triangle sets, S0 != 0: states {dx:.1e}, S(t) {ds:.1e}, u {du:.1e}")
    assert max(dx, ds, du) < 1e-9
    np.testing.assert_array_equal(weights(r)[0], s0)


def test_control_period_override_and_repr(balanbot):
    sc = scenarios.get("flat-fuzzy-sim")
    r = sc.run(control_period=0.01, t_final=3.0)
    assert r.outcome == "completed"
    assert np.all(r.internals["e1"][1:10] == r.internals["e1"][1])  # held for 10 steps
    c = sc.controller
    assert (c.k1, c.k2, c.kp, c.kd, c.ki, c.adapt) == (30.0, 33.0, -0.1, -0.9, 0.0, True)
    assert repr(c).startswith("FuzzyController(") and "k1=30.0, k2=33.0" in repr(c)
    assert c.basis.n_rules == 9 and c.model.slope == 0.0 and c.period == 1e-3


def test_errors_name_the_parameter(balanbot):
    model = twip.SlopeModel(balanbot, 0.0)
    good = dict(k1=30, k2=33, kp=-0.1, kd=-0.9)
    for name, bad in [("k1", 0.0), ("k1", -1.0), ("k2", 0.0), ("k2", -3.0), ("kp", math.nan), ("ki", math.inf)]:
        with pytest.raises(twip.InvalidParameterError, match=f"invalid {name} ="):
            twip.FuzzyController(model, **{**good, name: bad})
    for name, bad in [("gamma", 0.0), ("gamma", -1.0), ("sigma", 0.0), ("sigma", -0.1), ("period", 0.0)]:
        with pytest.raises(twip.InvalidParameterError, match=f"invalid {name} ="):
            twip.FuzzyController(model, **good, **{name: bad})
    with pytest.raises(twip.InvalidParameterError, match="adapt=False"):
        twip.FuzzyController(model, **good, gamma=0.0)
    with pytest.raises(twip.InvalidParameterError, match="sigma \\* period"):
        twip.FuzzyController(model, **good, sigma=500.0)
    # Adaptation off is explicit and keeps S at s0.
    assert not twip.FuzzyController(model, **good, adapt=False).adapt
    with pytest.raises(twip.ShapeError, match="sets"):
        twip.FuzzyController(model, **good, sets=[[twip.Triangle(-1, 0, 1)] * 3])
    with pytest.raises(twip.ShapeError, match="s0"):
        twip.FuzzyController(model, **good, s0=np.zeros(8))
    with pytest.raises(twip.NonFiniteError, match="s0"):
        twip.FuzzyController(model, **good, s0=[math.nan] + [0.0] * 8)
    with pytest.raises(twip.NonFiniteError, match=r"^phi\[0\] = NaN"):  # was NaN
        twip.FuzzyController(model, **good).g1(math.nan)
    ctrl = twip.FuzzyController(model, **good)
    with pytest.raises(twip.InvalidParameterError, match="control_period"):
        twip.simulate(model, ctrl, np.zeros(4), 1.0, 1e-3, control_period=0.0025)
    with pytest.raises(twip.NoEquilibriumError):
        twip.simulate(model, ctrl, np.zeros(4), 1.0, 1e-3, reference=twip.SpeedSchedule.constant(1e5))
