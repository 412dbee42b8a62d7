"""The 3-DOF model on terrain (docs/terrain.md): twip.Terrain, PlanarModel(..., terrain=),
checked against the sympy derivation and the pure-Python reference."""
import math
import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

import twip
from twip import reference
from twip.reference import terrain as ref_terrain

GRID_X = np.linspace(-2.0, 2.0, 9)
GRID_Y = np.linspace(-1.5, 1.5, 7)
GRID_Z = 0.08 * np.sin(1.3 * GRID_X)[:, None] * np.cos(0.9 * GRID_Y)[None, :] + 0.05 * GRID_X[:, None]

TERRAINS = {
    "plane": ((0.2, 0.7), "plane"),
    "steep plane": ((1.0, -2.0), "plane"),
    "ramp": ((0.15, -0.4, 0.1, 0.5), "ramp"),
    "bumps": ((0.06, 1.3), "bumps"),
    "grid": ((GRID_X, GRID_Y, GRID_Z), "grid"),
}


def both(name):
    args, kind = TERRAINS[name]
    return getattr(twip.Terrain, kind)(*args), getattr(ref_terrain.Terrain, kind)(*args)


def states(n, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        x = rng.uniform(-1.0, 1.0, 7)
        x[3] *= 0.8
        yield x, rng.uniform(-0.3, 0.3, 2)


def test_the_sympy_derivation_gives_twips_closed_form():
    """Lagrange–d'Alembert in the ground plane's frame, every body in 3-D (sympy), against
    the mass matrix, forces and normal forces twip implements."""
    pytest.importorskip("sympy")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
    try:
        import derive_terrain
    finally:
        sys.path.pop(0)
    out = derive_terrain.derive()
    assert derive_terrain.check(out) == dict.fromkeys(("M", "f", "normal_sum", "normal_diff"), True)
    # The zero test can fail: one wrong term in each part is found, and only there.
    import sympy as sp
    s = out["syms"]
    for key, wrong in [
        ("M", sp.diag(0, 0, s["M_b"] * s["l"] ** 2 * sp.sin(s["phi"]) ** 2 * sp.cos(s["chi"]) ** 2)),
        ("f", sp.Matrix([0, s["M_b"] * s["g"] * sp.sin(s["beta"]) * sp.sin(s["chi"]), 0])),
        ("normal_sum", s["M_b"] * s["l"] * sp.cos(2 * s["phi"]) * s["phidot"] ** 2),
        ("normal_diff", s["I_wa"] * s["v"] * s["omega"] * sp.cos(2 * s["chi"]) / s["b"]),
    ]:
        mine = derive_terrain.closed_form(s)
        mine[key] = mine[key] + wrong
        assert derive_terrain.check(out, mine) == {k: k != key for k in mine}, key


@pytest.mark.parametrize("name", sorted(TERRAINS))
def test_terrain_heights_and_gradients_match_the_reference(name):
    mine, ref = both(name)
    for x, y in np.random.default_rng(1).uniform(-1.4, 1.4, (40, 2)):
        assert mine.local(x, y) == pytest.approx(ref.local(x, y), rel=1e-12, abs=1e-14)


@pytest.mark.parametrize("name", sorted(TERRAINS))
@pytest.mark.parametrize("friction", [None, "gb37"])
def test_terrain_model_matches_the_reference(name, friction):
    """Derivative, energy and normal forces against the reference, which builds the frame
    from 3-D vectors and the equations by Kane's method with the weights tilted."""
    mine_t, ref_t = both(name)
    params = twip.RobotParams.balanbot()
    fr = twip.Friction.gb37() if friction else None
    m = twip.PlanarModel(params, friction=fr, terrain=mine_t)
    r = reference.PlanarModel(params, friction=reference.planar.Friction.of(fr) if fr else None, terrain=ref_t)
    for x, u in states(40):
        d, dr = m.deriv(x, u), r.deriv(x, u)
        assert d == pytest.approx(dr, rel=2e-6, abs=2e-6), (x, d - dr)
        # The reference's delta' is a central difference: the kinetic energy agrees to its error
        # (with omega = 0 to rounding).
        assert m.energy(x) == pytest.approx(r.energy(x), rel=1e-9, abs=1e-9)
        assert m.normal_forces(x, u) == pytest.approx(r.normal_forces(x, u), rel=1e-6, abs=1e-6)


def test_level_ground_is_the_flat_model_bitwise():
    flat = twip.PlanarModel(twip.RobotParams.balanbot())
    level = twip.PlanarModel(twip.RobotParams.balanbot(), terrain=twip.Terrain.plane(0.0, 1.0))
    for x, u in states(50, seed=2):
        assert np.array_equal(level.deriv(x, u), flat.deriv(x, u))
        assert level.energy(x) == flat.energy(x)
        assert np.array_equal(twip.rk4_step(level, x, u, 1e-3), twip.rk4_step(flat, x, u, 1e-3))


def test_facing_uphill_is_the_slope_model():
    """Same rest pitch and equilibrium torque as the 2-DOF slope model, and the (phi, v)
    rows of its derivative, at any uphill heading."""
    p = twip.RobotParams.balanbot()
    for slope, heading in [(0.26, 0.0), (0.1, 2.0)]:
        m = twip.PlanarModel(p, terrain=twip.Terrain.plane(slope, heading))
        two = twip.SlopeModel(p, slope)
        xs, us = two.equilibrium(0.0)
        x = np.array([0.3, -0.2, heading, xs[0], 0.0, 0.0, 0.0])
        torque = p.gear_ratio * p.torque_constant * us / 2
        assert np.abs(m.deriv(x, [torque, torque])).max() < 1e-12
        for x, u in states(20, seed=3):
            x[2], x[6] = heading, 0.0
            current = 2 * u[0] / (p.gear_ratio * p.torque_constant)
            d = m.deriv(x, [u[0], u[0]])
            ds = two.deriv([x[3], x[4], 0.0, x[5] / p.wheel_radius], current)
            assert d[4] == pytest.approx(ds[1], rel=1e-12, abs=1e-12)
            assert d[5] == pytest.approx(p.wheel_radius * ds[3], rel=1e-12, abs=1e-12)


def test_across_the_slope_at_rest_and_upright_it_does_not_move():
    for slope in (0.1, 0.5, 1.2):
        m = twip.PlanarModel(twip.RobotParams.balanbot(), terrain=twip.Terrain.plane(slope, 0.4))
        for side in (-1, 1):
            x = [0.0, 0.0, 0.4 + side * math.pi / 2, 0.0, 0.0, 0.0, 0.0]
            assert np.abs(m.deriv(x, [0.0, 0.0])).max() < 1e-13


def energy_drift(terrain, seconds=10.0, dt=1e-3):
    p = twip.RobotParams.balanbot().replace(mu_bearing=0.0, mu_ground=0.0)
    m = twip.PlanarModel(p, terrain=terrain)
    x = np.array([0.1, 0.05, 0.3, 0.3, 0.5, 0.4, 2.0])
    e0 = m.energy(x)
    worst = 0.0
    for _ in range(int(round(seconds / dt))):
        x = twip.rk4_step(m, x, [0.0, 0.0], dt)
        worst = max(worst, abs(m.energy(x) - e0))
    return worst, e0


def test_energy_is_conserved_on_a_plane_without_friction():
    worst, e0 = energy_drift(twip.Terrain.plane(0.3, 1.0))
    assert worst < 1e-8 * abs(e0)


def test_curvature_breaks_the_energy_balance_by_its_own_size():
    """On curved ground the local plane's turning is left out: the energy error shrinks
    with the bumps' height (docs/terrain.md gives the numbers)."""
    high, _ = energy_drift(twip.Terrain.bumps(0.04, 1.0), seconds=4.0)
    low, _ = energy_drift(twip.Terrain.bumps(0.01, 1.0), seconds=4.0)
    assert low < high / 2.5, (low, high)


class Idle:
    """A Python controller that commands nothing."""
    period = 0.005

    def update(self, t, y, ref):
        return [0.0, 0.0]


def test_a_hard_turn_across_a_steep_slope_ends_the_run_lifted():
    """Turning right hard across a 0.5 rad slope (uphill +x, heading +y): the uphill (right)
    wheel's normal force is negative and the run ends "lifted" after its first step, never
    going on silently; a slow turn does not."""
    m = twip.PlanarModel(twip.RobotParams.balanbot(), terrain=twip.Terrain.plane(0.5, 0.0))
    hard = [0.0, 0.0, math.pi / 2, 0.0, 0.0, 1.5, -8.0]
    n_r, n_l = m.normal_forces(hard, [0.0, 0.0])
    assert n_r < 0.0 < n_l
    result = twip.simulate(m, Idle(), x0=hard, t_final=1.0, reference=twip.Line(0.1))
    assert result.outcome == "lifted" and len(result.t) == 2, (result.outcome, len(result.t))
    slow = twip.simulate(m, Idle(), x0=[0.0, 0.0, math.pi / 2, 0.0, 0.0, 0.1, -0.1], t_final=0.05,
                         reference=twip.Line(0.1))
    assert slow.outcome == "completed"


def test_driving_off_the_grid_is_a_named_outcome_and_error():
    m = twip.PlanarModel(twip.RobotParams.balanbot(), terrain=twip.Terrain.grid(GRID_X, GRID_Y, np.zeros((9, 7))))
    with pytest.raises(twip.OffTerrainError, match="off the terrain"):
        m.deriv([2.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0])
    with pytest.raises(twip.OffTerrainError):
        twip.rk4_step(m, [1.9999, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 0.0], 1e-3)
    result = twip.simulate(m, Idle(), x0=[1.9, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0], t_final=1.0, reference=twip.Line(0.1))
    assert result.outcome == "off_terrain"
    assert result.states[-1][0] > GRID_X[-1] >= result.states[-2][0]


@pytest.mark.parametrize("call, name", [
    (lambda: twip.Terrain.plane(math.pi / 2), "slope"),
    (lambda: twip.Terrain.plane(float("nan")), "slope"),
    (lambda: twip.Terrain.ramp(1.6), "slope"),
    (lambda: twip.Terrain.ramp(0.1, blend=-1.0), "blend"),
    (lambda: twip.Terrain.bumps(0.1, 0.0), "wavelength"),
    (lambda: twip.Terrain.grid([0.0, 0.0, 1.0], [0.0, 1.0], np.zeros((3, 2))), "x"),
    (lambda: twip.Terrain.grid([0.0, 1.0], [1.0, 0.0], np.zeros((2, 2))), "y"),
    (lambda: twip.Terrain.grid([0.0, 1.0], [0.0, 1.0], [[0.0, float("nan")], [0.0, 0.0]]), "z"),
])
def test_bad_terrains_get_named_errors(call, name):
    with pytest.raises(twip.InvalidParameterError, match=f"invalid {name} ="):
        call()


def test_bad_grid_shapes_are_shape_errors():
    with pytest.raises(twip.ShapeError, match="z has shape"):
        twip.Terrain.grid([0.0, 1.0], [0.0, 1.0, 2.0], np.zeros((3, 2)))


def test_terrain_models_pickle():
    for name in TERRAINS:
        t, _ = both(name)
        m = twip.PlanarModel(twip.RobotParams.balanbot(), terrain=t)
        back = pickle.loads(pickle.dumps(m))
        x = np.array([0.3, -0.2, 0.4, 0.1, 0.2, 0.3, 0.4])
        assert np.array_equal(back.deriv(x, [0.1, 0.0]), m.deriv(x, [0.1, 0.0]))


def test_what_runs_on_flat_ground_only_refuses_a_terrain():
    m = twip.PlanarModel(twip.RobotParams.balanbot(), terrain=twip.Terrain.plane(0.1))
    with pytest.raises(twip.InvalidParameterError, match="flat ground only"):
        twip.SmcTracker(m)
    twip._core.check_sweep_model(m)  # sweeps run on terrain (tests/test_terrain_sweep.py)
