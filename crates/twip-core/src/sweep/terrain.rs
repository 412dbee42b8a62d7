//! Sweeps of the 3-DOF tracking scenarios on terrain (docs/terrain.md): each sample a
//! perturbed robot and initial state as on flat ground ([`super::planar`]), and on a
//! terrain plane whose slope and uphill heading may be drawn too ([`Target::Slope`],
//! [`Target::Heading`]), from the same stream `Philox::new(seed, i)` in the given order.
//! A sample runs on the general runner: the terrain model, or the 3-DOF rig on it; its
//! controller is built for the sample's own terrain, so a grade feed-forward
//! (`GradeFeedForward`) feeds the drawn plane's grade forward.
use crate::control::trajectory::{Path, PlanarRef};
use crate::control::{Controller, Reference};
use crate::hardware::realism::Realism;
use crate::model::terrain::Terrain;
use crate::sim::runner::SimConfig;
use crate::TwipError;

use super::planar::{draw_on, run_sample_on, PlanarNominal, PlanarSample, PlanarSampleMetrics};
use super::{Perturbation, SweepMetrics, Target};

/// A sweep's terrain, as what its slope and heading axes redraw.
#[derive(Clone, Debug, PartialEq)]
pub enum SweepTerrain {
    /// `Terrain::plane(slope, uphill_heading)`: both axes redraw it.
    Plane { slope: f64, uphill_heading: f64 },
    /// `Terrain::ramp(slope, uphill_heading, start, blend)`: both axes redraw its plane.
    Ramp { slope: f64, uphill_heading: f64, start: f64, blend: f64 },
    /// Any other terrain (bumps, a grid): it has no plane to redraw.
    Fixed(Terrain<f64>),
}

impl SweepTerrain {
    /// The nominal [slope, uphill heading] [rad] (NaN for a terrain without a plane).
    pub fn ground(&self) -> [f64; 2] {
        match *self {
            SweepTerrain::Plane { slope, uphill_heading } | SweepTerrain::Ramp { slope, uphill_heading, .. } => [slope, uphill_heading],
            SweepTerrain::Fixed(_) => [f64::NAN; 2],
        }
    }

    /// This terrain with its plane at `ground` = [slope, uphill heading] (a fixed terrain as it is).
    pub fn at(&self, [slope, heading]: [f64; 2]) -> Result<Terrain<f64>, TwipError> {
        match *self {
            SweepTerrain::Plane { .. } => Terrain::plane(slope, heading),
            SweepTerrain::Ramp { start, blend, .. } => Terrain::ramp(slope, heading, start, blend),
            SweepTerrain::Fixed(ref t) => Ok(t.clone()),
        }
    }

    /// Checks a perturbation of a sweep on this terrain: as on flat ground
    /// ([`super::planar::validate`]), and a slope or heading axis only on a terrain with a
    /// plane, the slope's every draw in [0, π/2).
    pub fn validate(&self, p: &Perturbation) -> Result<(), TwipError> {
        p.validate_spread()?;
        let bad = |name, value, reason| Err(TwipError::InvalidParameter { name, value, reason });
        let name = match p.target {
            Target::Slope => "slope",
            Target::Heading => "heading",
            _ => return p.validate_target(7),
        };
        if let SweepTerrain::Fixed(_) = self {
            return bad(name, p.spread.high(), "can be perturbed only on a terrain with a plane (PlanarModel(..., terrain=Terrain.plane(...)) or Terrain.ramp); this ground (bumps, a grid) has no plane to redraw");
        }
        if p.target == Target::Slope {
            let (low, high) = (p.spread.low(), p.spread.high());
            if !(low >= 0.0) {
                return bad("slope", low, "a draw can reach it: every slope drawn must be in [0, pi/2) rad (give low=0)");
            }
            if !(high < core::f64::consts::FRAC_PI_2) {
                return bad("slope", high, "a draw can reach it: every slope drawn must be in [0, pi/2) rad (a slope of 90 degrees or more is a wall)");
            }
        }
        Ok(())
    }
}

/// Draws sample `index` on `terrain` (perturbations checked by [`SweepTerrain::validate`]):
/// the sample and its terrain, with the drawn [slope, uphill heading].
pub fn draw(nominal: &PlanarNominal, terrain: &SweepTerrain, perturbations: &[Perturbation], seed: u64, index: u64) -> (PlanarSample, [f64; 2]) {
    draw_on(nominal, terrain.ground(), perturbations, seed, index)
}

/// Runs one sample on its terrain `terrain.at(ground)`: `controller_on` builds the
/// tracker for that terrain (designed once on the nominal robot; reset here), the plant
/// is the terrain model of the sample's robot, through the 3-DOF rig on it with `realism`
/// (set up by `rig::for_sweep`: noise stream = the sample's index). An invalid robot, a
/// terrain no draw should give, or an initial contact point off the terrain gives
/// [`PlanarSampleMetrics::INVALID`]; `None` when `should_stop` said so. A run that ended
/// "lifted" or "off_terrain" is marked so (and counts as fallen).
#[allow(clippy::too_many_arguments)]
pub fn run_terrain_sample<C, P>(
    controller_on: impl FnOnce(&Terrain<f64>) -> C,
    path: &P,
    config: &SimConfig<f64>,
    sample: &PlanarSample,
    terrain: &SweepTerrain,
    ground: [f64; 2],
    settle: f64,
    realism: Option<&Realism<f64>>,
    should_stop: &dyn Fn() -> bool,
) -> Option<PlanarSampleMetrics>
where
    C: Controller<f64, 7, 2, Reference = PlanarRef<f64>> + Clone,
    P: Reference<f64, Sample = PlanarRef<f64>> + Path<f64> + Copy,
{
    let Ok(ground) = terrain.at(ground) else {
        return Some(PlanarSampleMetrics::INVALID);
    };
    if !ground.contains(sample.x0[0], sample.x0[1]) {
        return Some(PlanarSampleMetrics::INVALID);
    }
    run_sample_on(&controller_on(&ground), path, config, sample, Some(ground), settle, realism, should_stop)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::grade::GradeFeedForward;
    use crate::control::pid::PidTracker;
    use crate::control::trajectory::Circle;
    use crate::hardware::motor::DcMotor;
    use crate::model::planar::{PlanarModel, PlanarState};
    use crate::model::terrain_model::TerrainModel;
    use crate::sim::tracking_metrics::TrackingMetrics;
    use crate::sim::runner::{simulate, Outcome};
    use crate::sweep::block::{FeedForwardLanes, LaneLaw, Planar};
    use crate::sweep::lanes::LANES;
    use crate::sweep::planar::run_planar_lane_samples;
    use crate::sweep::Spread;

    /// The flat sweep's tracker, circle and robot, over 3 s.
    fn setup() -> (PidTracker<f64>, Circle<f64>, SimConfig<f64>, PlanarNominal) {
        let (pid, circle, config, nominal) = crate::sweep::planar::tests::setup();
        (pid, circle, SimConfig { t_final: 3.0, ..config }, nominal)
    }

    fn axes() -> [Perturbation; 3] {
        [
            Perturbation { target: Target::Param(0), spread: Spread::Uniform { low: 0.6, high: 1.1 } },
            Perturbation { target: Target::Slope, spread: Spread::Uniform { low: 0.0, high: 0.35 } },
            Perturbation { target: Target::Heading, spread: Spread::Uniform { low: -3.2, high: 3.2 } },
        ]
    }

    /// A sample on a drawn plane is a direct run of its robot on `Terrain::plane` of the drawn
    /// slope and heading with the feed-forward of that plane, bit for bit; the draws of the
    /// shared axes are the flat sweep's; the drawn ground spreads over the axes' ranges.
    #[test]
    fn a_sample_is_a_direct_run_on_its_drawn_plane() {
        let (pid, circle, config, nominal) = setup();
        let terrain = SweepTerrain::Plane { slope: 0.1, uphill_heading: 0.0 };
        let axes = axes();
        for p in &axes {
            terrain.validate(p).unwrap();
        }
        let flat = nominal.params;
        let with_ff = |t: &Terrain<f64>| GradeFeedForward::new(pid, TerrainModel::new(PlanarModel::new(flat).unwrap(), t.clone()), Some(DcMotor::gb37y3530()));
        let mut slopes = alloc::vec::Vec::new();
        for i in 0..6 {
            let (sample, ground) = draw(&nominal, &terrain, &axes, 9, i);
            assert_eq!(sample, crate::sweep::planar::draw(&nominal, &axes[..1], 9, i), "the mass is drawn first, as on flat ground");
            slopes.push(ground[0]);
            assert!((0.0..0.35).contains(&ground[0]) && (-3.2..3.2).contains(&ground[1]), "{ground:?}");
            let got = run_terrain_sample(with_ff, &circle, &config, &sample, &terrain, ground, 2.0, None, &|| false).unwrap();
            let plane = Terrain::plane(ground[0], ground[1]).unwrap();
            let model = TerrainModel::new(PlanarModel::new(sample.params).unwrap(), plane.clone());
            let mut direct = TrackingMetrics::new(circle, 2.0);
            let (outcome, steps) = simulate(&model, &mut with_ff(&plane), &circle, &sample.x0, &config, &mut direct).unwrap();
            assert_eq!((got.steps, got.fell), (steps as u64, outcome != Outcome::Completed), "sample {i}");
            assert_eq!(got.max_path_error_settled.to_bits(), direct.summary().max_path_error_settled.to_bits(), "sample {i}");
            assert_eq!(got.mean_abs_pitch.to_bits(), direct.summary().mean_abs_pitch.to_bits(), "sample {i}");
        }
        assert!(slopes.iter().any(|&s| s > 0.2) && slopes.iter().any(|&s| s < 0.15), "{slopes:?}");
    }

    /// A hard turn across a steep drawn plane lifts a wheel: the sample is marked "lifted"
    /// (and fallen), as the runner's outcome says.
    #[test]
    fn a_lifted_run_is_marked() {
        let (pid, _, config, nominal) = setup();
        // Heading across a 0.5 rad plane, turning hard at speed (as the terrain model's own
        // test `a_hard_turn_lifts_a_wheel`).
        let x0 = PlanarState::from([0.0, 0.0, core::f64::consts::FRAC_PI_2, 0.0, 0.0, 1.5, -8.0]);
        let nominal = PlanarNominal { x0, ..nominal };
        let terrain = SweepTerrain::Plane { slope: 0.5, uphill_heading: 0.0 };
        let (sample, ground) = draw(&nominal, &terrain, &[], 1, 0);
        let line = crate::control::trajectory::Line::new([0.0, 0.0], 0.0, 0.1).unwrap();
        let plane = terrain.at(ground).unwrap();
        let model = TerrainModel::new(PlanarModel::new(sample.params).unwrap(), plane);
        let mut direct = TrackingMetrics::new(line, 0.0);
        let (outcome, _) = simulate(&model, &mut pid.clone(), &line, &sample.x0, &config, &mut direct).unwrap();
        assert!(matches!(outcome, Outcome::Lifted { .. }), "{outcome:?}");
        let got = run_terrain_sample(|_| pid, &line, &config, &sample, &terrain, ground, 0.0, None, &|| false).unwrap();
        assert!(got.fell && got.lifted == 1.0 && got.off_terrain == 0.0, "{got:?}");
    }

    /// The lanes of a sweep on `terrain` (each sample's robot, initial state and ground drawn
    /// from `axes`) against each sample's run: the same validity, outcome ("lifted",
    /// "off_terrain" included), steps and end, every metric within 1e-12 relative (as on flat
    /// ground); returns the worst difference and how many samples (ran, fell, lifted, off).
    fn lanes_against_the_runs<C, L>(controller_on: impl Fn(&Terrain<f64>) -> C, law: &L, feed: Option<FeedForwardLanes>, terrain: &SweepTerrain, axes: &[Perturbation], x0: PlanarState<f64>, t_final: f64) -> (f64, [usize; 4])
    where
        C: Controller<f64, 7, 2, Reference = PlanarRef<f64>> + Clone,
        L: LaneLaw<Shape = Planar> + Clone,
    {
        rig_lanes_against_the_runs(controller_on, law, feed, terrain, axes, x0, t_final, None)
    }

    /// [`lanes_against_the_runs`] through the rig of `realism` (set up for the sweep, each
    /// sample its own noise stream), or without one.
    #[allow(clippy::too_many_arguments)]
    fn rig_lanes_against_the_runs<C, L>(
        controller_on: impl Fn(&Terrain<f64>) -> C,
        law: &L,
        feed: Option<FeedForwardLanes>,
        terrain: &SweepTerrain,
        axes: &[Perturbation],
        x0: PlanarState<f64>,
        t_final: f64,
        realism: Option<&Realism<f64>>,
    ) -> (f64, [usize; 4])
    where
        C: Controller<f64, 7, 2, Reference = PlanarRef<f64>> + Clone,
        L: LaneLaw<Shape = Planar> + Clone,
    {
        let (_, circle, config, nominal) = setup();
        let config = SimConfig { t_final, ..config };
        let nominal = PlanarNominal { x0, ..nominal };
        let never = || false;
        let n = LANES as u64 + 5;
        let realism = realism.map(|r| crate::sweep::rig::for_sweep(r, 7));
        let lanes = match &realism {
            None => run_planar_lane_samples(law, &circle, &config, &nominal, axes, 5, 0..n, 1.0, &never, Some((terrain, feed))),
            Some(r) => crate::sweep::planar::run_planar_rig_lane_samples(law, &circle, &config, &nominal, axes, 5, 0..n, 1.0, &|_| Ok(*r), &never, Some((terrain, feed))),
        };
        let lanes = lanes.unwrap().unwrap();
        let (mut worst, mut counts) = (0.0f64, [0; 4]);
        for i in 0..n {
            let (sample, ground) = draw(&nominal, terrain, axes, 5, i);
            let one = run_terrain_sample(&controller_on, &circle, &config, &sample, terrain, ground, 1.0, realism.as_ref(), &never).unwrap();
            let got = lanes[i as usize];
            let ending = |m: &PlanarSampleMetrics| format!("{:?}", (m.valid, m.fell, m.steps, m.lifted, m.off_terrain));
            assert_eq!(ending(&got), ending(&one), "sample {i}");
            if !one.valid {
                continue;
            }
            counts = [counts[0] + 1, counts[1] + one.fell as usize, counts[2] + (one.lifted == 1.0) as usize, counts[3] + (one.off_terrain == 1.0) as usize];
            worst = worst.max(crate::sweep::planar::tests::worst_difference(&got, &one, i));
        }
        (worst, counts)
    }

    /// A 0.8 m x 0.35 m height map of gentle waves, which robots drive off.
    fn small_grid() -> SweepTerrain {
        let xs: alloc::vec::Vec<f64> = (0..9).map(|i| -0.4 + 0.1 * i as f64).collect();
        let ys: alloc::vec::Vec<f64> = (0..6).map(|j| -0.3 + 0.07 * j as f64).collect();
        let z: alloc::vec::Vec<f64> = xs.iter().flat_map(|x| ys.iter().map(move |y| 0.02 * (5.0 * x).sin() * (4.0 * y).cos())).collect();
        SweepTerrain::Fixed(Terrain::Grid(alloc::sync::Arc::new(crate::model::terrain::Grid::new(xs, ys, &z).unwrap())))
    }

    /// Bumps 3 cm high, of 0.5 m wavelength.
    fn wave_bumps() -> SweepTerrain {
        SweepTerrain::Fixed(Terrain::bumps(0.03, 0.5).unwrap())
    }

    /// A lane on terrain agrees with the run of its sample to rounding, on drawn planes with
    /// and without the grade's feed-forward (PID, fuzzy sliding mode), on a drawn ramp, over
    /// bumps, and on a grid it drives off; lanes lift on steep planes turning hard.
    #[test]
    fn a_lane_on_terrain_agrees_with_the_run_to_rounding() {
        use crate::sweep::block::{PidLanes, SmcLanes};
        use crate::sweep::planar::tests::{smc, spread};
        let (pid, _, _, nominal) = setup();
        let motor = Some(DcMotor::gb37y3530());
        let flat_model = || TerrainModel::new(PlanarModel::new(nominal.params).unwrap(), Terrain::flat());
        let ff_pid = GradeFeedForward::new(pid, flat_model(), motor);
        let ff_smc = GradeFeedForward::new(smc(true), flat_model(), motor);
        let plane = SweepTerrain::Plane { slope: 0.1, uphill_heading: 0.0 };
        let ramp = SweepTerrain::Ramp { slope: 0.1, uphill_heading: 0.0, start: 0.05, blend: 0.1 };
        let [m_body, com, pitch] = spread();
        let drawn = [m_body, pitch, axes()[1], axes()[2]];
        let zero = PlanarState::zeros();
        let (pid_lanes, smc_lanes) = (PidLanes::new(&pid), SmcLanes::new(&smc(true)).unwrap());
        let (grid, bumps) = (small_grid(), wave_bumps());
        // Across steep planes (0.3-0.5 rad) at speed, turning hard: some lift.
        let hard = PlanarState::from([0.0, 0.0, core::f64::consts::FRAC_PI_2, 0.0, 0.0, 1.5, -8.0]);
        let steep = [Perturbation { target: Target::Slope, spread: Spread::Uniform { low: 0.3, high: 0.5 } }, Perturbation { target: Target::Initial(6), spread: Spread::Uniform { low: -9.0, high: 0.0 } }];
        let cases = [
            ("pid, drawn planes", lanes_against_the_runs(|_| pid, &pid_lanes, None, &plane, &drawn, zero, 4.0)),
            ("pid + feed-forward, drawn planes", lanes_against_the_runs(|t| ff_pid.on(t.clone()), &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &plane, &drawn, zero, 4.0)),
            ("smc-fuzzy + feed-forward, drawn planes", lanes_against_the_runs(|t| ff_smc.on(t.clone()), &smc_lanes, Some(FeedForwardLanes::new(&ff_smc)), &plane, &drawn, zero, 4.0)),
            ("pid + feed-forward, drawn ramps", lanes_against_the_runs(|t| ff_pid.on(t.clone()), &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &ramp, &drawn, zero, 4.0)),
            ("smc-fuzzy, bumps", lanes_against_the_runs(|_| smc(true), &smc_lanes, None, &bumps, &[m_body, com], zero, 4.0)),
            ("pid + feed-forward, a grid driven off", lanes_against_the_runs(|t| ff_pid.on(t.clone()), &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &grid, &[m_body, pitch], zero, 4.0)),
            ("pid, steep planes turning hard", lanes_against_the_runs(|_| pid, &pid_lanes, None, &plane, &steep, hard, 1.0)),
        ];
        for (name, (worst, [ran, fell, lifted, off])) in cases {
            std::println!("{name}: worst relative difference {worst:e}; {ran} ran, {fell} fell, {lifted} lifted, {off} off the terrain");
            assert!(worst <= 1e-12 && worst > 0.0, "{name}: worst relative difference {worst:e}");
            assert!(ran > 10 && (fell < ran || lifted > 0), "{name}: {ran} ran, {fell} fell");
        }
        let counts = |i: usize| cases[i].1 .1;
        assert!(counts(0)[1] > 0 && counts(5)[3] > 0 && counts(6)[2] > 0, "want falls, a grid's edge and lifts: {:?}", cases.map(|c| c.1 .1));
    }

    /// Through the 3-DOF rig (its parts whose output is not quantised), a lane on terrain
    /// agrees with its sample's rig run on that terrain to rounding (1e-12 relative, as the
    /// flat rig's lanes), the same cases as the ideal lanes': drawn planes with the grade's
    /// feed-forward and without (PID, fuzzy sliding mode), a drawn ramp, bumps, a grid driven
    /// off ("off_terrain") and steep planes turning hard ("lifted"); and with backlash, pushes
    /// and a body force, driven through the bridge (windings with and without inductance).
    #[test]
    fn a_rig_lane_on_terrain_agrees_with_the_rig_run_to_rounding() {
        use crate::hardware::disturbance::{Force, Push, Pushes};
        use crate::sweep::block::{PidLanes, SmcLanes};
        use crate::sweep::planar::tests::{smc, spread};
        let (pid, _, _, nominal) = setup();
        let motor = Some(DcMotor::gb37y3530());
        let flat_model = || TerrainModel::new(PlanarModel::new(nominal.params).unwrap(), Terrain::flat());
        let ff_pid = GradeFeedForward::new(pid, flat_model(), motor);
        let ff_smc = GradeFeedForward::new(smc(true), flat_model(), motor);
        let first = crate::sweep::planar::tests::unquantised_rig();
        let pushes = Pushes::new(&[Push { t: 0.5, impulse: 0.05, height: 0.1 }, Push { t: 2.0, impulse: -0.04, height: 0.05 }]).unwrap();
        let force = Force { horizontal: 0.1, vertical: -0.5, height: 0.08 };
        let geared = Realism { backlash: Realism::thesis_like().backlash, pushes, force, ..first };
        let thesis_drive = Realism::thesis_like().motor.unwrap();
        let inductive = Realism { motor: Some(thesis_drive), ..geared };
        let steady = Realism { motor: Some(crate::hardware::driver::MotorDriver { inductance: 0.0, ..thesis_drive }), ..geared };
        let plane = SweepTerrain::Plane { slope: 0.1, uphill_heading: 0.0 };
        let ramp = SweepTerrain::Ramp { slope: 0.1, uphill_heading: 0.0, start: 0.05, blend: 0.1 };
        let [m_body, com, pitch] = spread();
        let drawn = [m_body, pitch, axes()[1], axes()[2]];
        let zero = PlanarState::zeros();
        let (pid_lanes, smc_lanes) = (PidLanes::new(&pid), SmcLanes::new(&smc(true)).unwrap());
        let (grid, bumps) = (small_grid(), wave_bumps());
        let hard = PlanarState::from([0.0, 0.0, core::f64::consts::FRAC_PI_2, 0.0, 0.0, 1.5, -8.0]);
        let steep = [Perturbation { target: Target::Slope, spread: Spread::Uniform { low: 0.3, high: 0.5 } }, Perturbation { target: Target::Initial(6), spread: Spread::Uniform { low: -9.0, high: 0.0 } }];
        let ff = |t: &Terrain<f64>| ff_pid.on(t.clone());
        // Pushed and pulled, the robots hold on gentler planes (up to 0.15 rad).
        let gentle = [m_body, Perturbation { target: Target::Slope, spread: Spread::Uniform { low: 0.0, high: 0.15 } }, axes()[2]];
        let cases = [
            ("pid, drawn planes", rig_lanes_against_the_runs(|_| pid, &pid_lanes, None, &plane, &drawn, zero, 4.0, Some(&first))),
            ("pid + feed-forward, drawn planes", rig_lanes_against_the_runs(ff, &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &plane, &drawn, zero, 4.0, Some(&first))),
            ("smc-fuzzy + feed-forward, drawn planes", rig_lanes_against_the_runs(|t| ff_smc.on(t.clone()), &smc_lanes, Some(FeedForwardLanes::new(&ff_smc)), &plane, &drawn, zero, 4.0, Some(&first))),
            ("pid + feed-forward, drawn ramps", rig_lanes_against_the_runs(ff, &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &ramp, &drawn, zero, 4.0, Some(&first))),
            ("smc-fuzzy, bumps", rig_lanes_against_the_runs(|_| smc(true), &smc_lanes, None, &bumps, &[m_body, com], zero, 4.0, Some(&first))),
            ("pid + feed-forward, a grid driven off", rig_lanes_against_the_runs(ff, &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &grid, &[m_body, pitch], zero, 4.0, Some(&first))),
            ("pid, steep planes turning hard", rig_lanes_against_the_runs(|_| pid, &pid_lanes, None, &plane, &steep, hard, 1.0, Some(&first))),
            ("backlash, pushes, a force: pid + feed-forward, drawn planes", rig_lanes_against_the_runs(ff, &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &plane, &gentle, zero, 3.0, Some(&geared))),
            ("inductive windings: pid + feed-forward, drawn planes", rig_lanes_against_the_runs(ff, &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &plane, &gentle, zero, 1.0, Some(&inductive))),
            ("windings without inductance: pid + feed-forward, drawn planes", rig_lanes_against_the_runs(ff, &pid_lanes, Some(FeedForwardLanes::new(&ff_pid)), &plane, &gentle, zero, 1.0, Some(&steady))),
            ("backlash, inductive windings: steep planes turning hard", rig_lanes_against_the_runs(|_| pid, &pid_lanes, None, &plane, &steep, hard, 1.0, Some(&inductive))),
        ];
        for (name, (worst, [ran, fell, lifted, off])) in cases {
            std::println!("rig, {name}: worst relative difference {worst:e}; {ran} ran, {fell} fell, {lifted} lifted, {off} off the terrain");
            assert!(worst <= 1e-12 && worst > 0.0, "{name}: worst relative difference {worst:e}");
            assert!(ran > 10 && (fell < ran || lifted > 0), "{name}: {ran} ran, {fell} fell");
        }
        let counts = |i: usize| cases[i].1 .1;
        assert!(counts(0)[1] > 0 && counts(5)[3] > 0 && counts(6)[2] > 0 && counts(10)[2] > 0, "want falls, a grid's edge and lifts: {:?}", cases.map(|c| c.1 .1));
    }

    /// Bad axes are refused by name: a slope that can reach 90° or below 0, a slope or
    /// heading axis on a terrain without a plane.
    #[test]
    fn bad_axes_are_refused_by_name() {
        let name = |r: Result<(), TwipError>| match r {
            Err(TwipError::InvalidParameter { name, .. }) => name,
            other => panic!("{other:?}"),
        };
        let plane = SweepTerrain::Plane { slope: 0.1, uphill_heading: 0.0 };
        let slope = |spread| Perturbation { target: Target::Slope, spread };
        assert_eq!(name(plane.validate(&slope(Spread::Uniform { low: 0.0, high: 1.6 }))), "slope");
        assert_eq!(name(plane.validate(&slope(Spread::Uniform { low: -0.1, high: 0.2 }))), "slope");
        // A normal's reach: unclamped, mean ± 8.57 std passes 0.
        assert_eq!(name(plane.validate(&slope(Spread::Normal { mean: 0.1, std: 0.05, low: f64::NEG_INFINITY, high: f64::INFINITY }))), "slope");
        plane.validate(&slope(Spread::Normal { mean: 0.1, std: 0.05, low: 0.0, high: 0.3 })).unwrap();
        let bumps = SweepTerrain::Fixed(Terrain::bumps(0.04, 1.0).unwrap());
        assert_eq!(name(bumps.validate(&Perturbation { target: Target::Heading, spread: Spread::Uniform { low: 0.0, high: 1.0 } })), "heading");
        assert_eq!(name(bumps.validate(&slope(Spread::Uniform { low: 0.0, high: 0.1 }))), "slope");
        bumps.validate(&axes()[0]).unwrap();
        assert_eq!(name(crate::sweep::planar::validate(&axes()[2])), "heading");
        assert_eq!(name(Perturbation { target: Target::Heading, spread: Spread::Uniform { low: 0.0, high: 1.0 } }.validate()), "heading");
    }
}
