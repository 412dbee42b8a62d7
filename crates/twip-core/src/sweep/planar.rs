//! Sweeps of the 3-DOF tracking scenarios: each sample a perturbed robot and initial
//! state on the flat [`PlanarModel`], the tracker designed once for the nominal robot,
//! [`TrackingMetrics`] kept. Draws are the 2-DOF sweeps' ([`super::draw`]'s), so
//! sample `i` comes from `Philox::new(seed, i)` here too. A sample runs alone on the
//! general runner ([`run_planar_sample`]: any tracker, with or without realism) or with 15
//! others on the planar lane kernels ([`run_planar_lane_samples`], and through the realism
//! rig [`run_planar_rig_lane_samples`]: the PID and sliding-mode trackers), where it agrees
//! with the former to rounding.
use crate::control::{Controller, Reference};
use crate::hardware::realism::Realism;
use crate::model::dynamics::Halt;
use crate::model::planar::{PlanarModel, PlanarState};
use crate::model::terrain::Terrain;
use crate::model::terrain_model::TerrainModel;
use crate::sim::runner::{simulate_until, Outcome, SimConfig};
use crate::control::trajectory::{Path, PlanarRef};
use crate::sim::metrics::DrivePeaks;
use crate::sim::tracking_metrics::{TrackingMetrics, TrackingSummary};
use crate::{RobotParams, TwipError};

use alloc::vec::Vec;

use super::block::{self, FeedForwardLanes, LaneLaw, LanePath, Planar, TerrainLanes};
use super::terrain::SweepTerrain;
use super::lanes::LANES;
use super::rig::RealismOf;
use super::{draw_values, finish, fresh, sweep_metrics, Perturbation, SweepMetrics, Target};

/// Samples per parallel block: one. A tracking run is 10⁴–10⁵ steps, so a task per
/// sample costs nothing, balances the threads and reports progress per sample.
pub const BLOCK: usize = 1;

/// The unperturbed robot and initial state `[x, y, psi, phi, phi_dot, v, omega]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarNominal {
    pub params: RobotParams<f64>,
    pub x0: PlanarState<f64>,
}

/// One sample's robot and initial state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarSample {
    pub index: u64,
    pub params: RobotParams<f64>,
    pub x0: PlanarState<f64>,
}

/// Checks a perturbation for the planar model on flat ground: the spread, a RobotParams
/// field or one of the 7 state entries; the slope and the heading are refused (they need a
/// terrain plane: [`super::terrain::SweepTerrain::validate`]).
pub fn validate(p: &Perturbation) -> Result<(), TwipError> {
    p.validate_spread()?;
    let name = match p.target {
        Target::Slope => "slope",
        Target::Heading => "heading",
        _ => return p.validate_target(7),
    };
    Err(TwipError::InvalidParameter {
        name,
        value: p.spread.high(),
        reason: "cannot be perturbed in a 3-DOF (tracking) sweep on flat ground: give the model a terrain plane (PlanarModel(..., terrain=Terrain.plane(slope, uphill_heading)))",
    })
}

/// Draws sample `index` (perturbations validated by [`validate`]).
pub fn draw(nominal: &PlanarNominal, perturbations: &[Perturbation], seed: u64, index: u64) -> PlanarSample {
    draw_on(nominal, [0.0; 2], perturbations, seed, index).0
}

/// Draws sample `index` on ground of nominal `[slope, uphill heading]`: the sample and its
/// drawn ground.
pub(crate) fn draw_on(nominal: &PlanarNominal, ground: [f64; 2], perturbations: &[Perturbation], seed: u64, index: u64) -> (PlanarSample, [f64; 2]) {
    let (params, ground, x0) = draw_values(&nominal.params, ground, &nominal.x0, perturbations, seed, index);
    (PlanarSample { index, params, x0 }, ground)
}

/// What a tracking sweep keeps of one sample; the names of `simulate_planar_raw`'s metrics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlanarSampleMetrics {
    /// False when the drawn robot or initial state was invalid; nothing was run.
    pub valid: bool,
    pub fell: bool,
    /// When the run ended (t_final, or the fall).
    pub t_end: f64,
    pub mean_abs_x_error: f64,
    pub mean_abs_y_error: f64,
    pub mean_abs_x_error_settled: f64,
    pub mean_abs_y_error_settled: f64,
    pub max_path_error_settled: f64,
    pub mean_abs_pitch: f64,
    pub peak_abs_torque: f64,
    pub peak_current: f64,
    pub peak_torque: f64,
    pub peak_command: f64,
    pub saturation_share: f64,
    /// 1 when the run ended "lifted" (a wheel's normal force went negative; on terrain),
    /// else 0; such a run counts as fallen too.
    pub lifted: f64,
    /// 1 when the run ended "off_terrain" (off a grid), else 0; counted as fallen too.
    pub off_terrain: f64,
    pub steps: u64,
}

impl PlanarSampleMetrics {
    /// A valid sample's metrics from its run's summary and how the run ended.
    pub fn from_summary(s: &TrackingSummary<f64>, peaks: DrivePeaks<f64>, fell: bool, t_end: f64, steps: u64) -> Self {
        Self {
            valid: true,
            fell,
            t_end,
            mean_abs_x_error: s.mean_abs_x_error,
            mean_abs_y_error: s.mean_abs_y_error,
            mean_abs_x_error_settled: s.mean_abs_x_error_settled,
            mean_abs_y_error_settled: s.mean_abs_y_error_settled,
            max_path_error_settled: s.max_path_error_settled,
            mean_abs_pitch: s.mean_abs_pitch,
            peak_abs_torque: s.peak_abs_torque,
            peak_current: peaks.current,
            peak_torque: peaks.torque,
            peak_command: peaks.command,
            saturation_share: peaks.saturation_share,
            lifted: 0.0,
            off_terrain: 0.0,
            steps,
        }
    }

    /// These metrics with how the run ended marked ("lifted", "off_terrain").
    pub fn ended(self, outcome: &Outcome<f64>) -> Self {
        self.halted(match outcome {
            Outcome::Lifted { .. } => Some(Halt::Lifted),
            Outcome::OffTerrain { .. } => Some(Halt::OffTerrain),
            _ => None,
        })
    }

    /// These metrics marked with what halted the run, if anything did.
    pub fn halted(self, halt: Option<Halt>) -> Self {
        let is = |b: bool| if b { 1.0 } else { 0.0 };
        Self { lifted: is(halt == Some(Halt::Lifted)), off_terrain: is(halt == Some(Halt::OffTerrain)), ..self }
    }
}

sweep_metrics!(PlanarSampleMetrics {
    t_end,
    mean_abs_x_error,
    mean_abs_y_error,
    mean_abs_x_error_settled,
    mean_abs_y_error_settled,
    max_path_error_settled,
    mean_abs_pitch,
    peak_abs_torque,
    peak_current,
    peak_torque,
    peak_command,
    saturation_share,
    lifted,
    off_terrain,
});

/// Runs one sample: a reset copy of the prototype tracker (designed for the nominal
/// robot) on the sample's robot along `path`; "_settled" metrics from `settle` [s].
/// With `realism` (set up by `rig::for_sweep`) it runs through the 3-DOF rig with the
/// noise stream `sample.index`, as the 2-DOF sweeps do. An invalid robot (or a rig it
/// cannot have) gives [`PlanarSampleMetrics::INVALID`]; `None` when `should_stop` said so.
#[allow(clippy::too_many_arguments)]
pub fn run_planar_sample<C, P>(
    prototype: &C,
    path: &P,
    config: &SimConfig<f64>,
    sample: &PlanarSample,
    settle: f64,
    realism: Option<&Realism<f64>>,
    should_stop: &dyn Fn() -> bool,
) -> Option<PlanarSampleMetrics>
where
    C: Controller<f64, 7, 2, Reference = PlanarRef<f64>> + Clone,
    P: Reference<f64, Sample = PlanarRef<f64>> + Path<f64> + Copy,
{
    run_sample_on(prototype, path, config, sample, None, settle, realism, should_stop)
}

/// [`run_planar_sample`] on `terrain` (None: flat ground), a run that ended "lifted" or
/// "off_terrain" marked so.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_sample_on<C, P>(
    prototype: &C,
    path: &P,
    config: &SimConfig<f64>,
    sample: &PlanarSample,
    terrain: Option<Terrain<f64>>,
    settle: f64,
    realism: Option<&Realism<f64>>,
    should_stop: &dyn Fn() -> bool,
) -> Option<PlanarSampleMetrics>
where
    C: Controller<f64, 7, 2, Reference = PlanarRef<f64>> + Clone,
    P: Reference<f64, Sample = PlanarRef<f64>> + Path<f64> + Copy,
{
    let Ok(plant) = PlanarModel::new(sample.params) else {
        return Some(PlanarSampleMetrics::INVALID);
    };
    let mut metrics = TrackingMetrics::new(*path, settle);
    let run = match (realism, terrain) {
        (None, None) => simulate_until(&plant, &mut fresh(prototype), path, &sample.x0, config, &mut metrics, should_stop),
        (None, Some(t)) => simulate_until(&TerrainModel::new(plant, t), &mut fresh(prototype), path, &sample.x0, config, &mut metrics, should_stop),
        (Some(r), t) => {
            let Ok(mut rig) = r.with_stream(sample.index).build_planar_on(&plant, t.as_ref(), config.dt) else {
                return Some(PlanarSampleMetrics::INVALID);
            };
            rig.simulate(&mut fresh(prototype), path, &sample.x0, config, &mut metrics, should_stop)
        }
    };
    let outcome = run.as_ref().ok().map(|(o, _)| *o);
    finish(run, config.dt, |fell, t_end, steps| {
        let m = PlanarSampleMetrics::from_summary(&metrics.summary(), metrics.drive_peaks(&sample.params), fell, t_end, steps);
        outcome.map_or(m, |o| m.ended(&o))
    })
}

/// Runs samples `indices` of a tracking sweep on lanes ([`block::run_planar_block`], for
/// trackers with a [`LaneLaw`] of the [`Planar`] shape): [`LANES`] at a time, each lane agreeing with
/// [`run_planar_sample`] to rounding. On flat ground, or on `terrain` (each sample's robot,
/// start and ground drawn by [`super::terrain::draw`]) with the grade's feed-forward or
/// without: there each lane agrees with [`super::terrain::run_terrain_sample`] to rounding,
/// "lifted" and "off_terrain" included. `Ok(None)` when `should_stop` said so.
#[allow(clippy::too_many_arguments)]
pub fn run_planar_lane_samples<C: LaneLaw<Shape = Planar> + Clone, P: LanePath>(
    law: &C,
    path: &P,
    config: &SimConfig<f64>,
    nominal: &PlanarNominal,
    perturbations: &[Perturbation],
    seed: u64,
    indices: core::ops::Range<u64>,
    settle: f64,
    should_stop: &dyn Fn() -> bool,
    terrain: Option<(&SweepTerrain, Option<FeedForwardLanes>)>,
) -> Result<Option<Vec<PlanarSampleMetrics>>, TwipError> {
    let Some((terrain, feed)) = terrain else {
        return in_blocks(indices, |i| draw(nominal, perturbations, seed, i), |samples| block::run_planar_block(law.clone(), path, config, samples, settle, should_stop, &block::Flat));
    };
    in_blocks(indices, |i| super::terrain::draw(nominal, terrain, perturbations, seed, i), |drawn| {
        let (samples, grounds) = on_their_grounds(terrain, drawn);
        block::run_planar_block(law.clone(), path, config, &samples, settle, should_stop, &TerrainLanes::new(&samples, &grounds, feed))
    })
}

/// Runs samples `indices` of a tracking sweep, each through the 3-DOF rig of its robot's
/// realism (`realism_of`, set up by [`for_sweep`](super::rig::for_sweep): noise stream =
/// the sample's index), on lanes ([`block::run_planar_rig_block`], for trackers with a
/// [`LaneLaw`] of the [`Planar`] shape): [`LANES`] at a time, each lane agreeing with [`run_planar_sample`]
/// with that realism to rounding. On flat ground, or on `terrain` as
/// [`run_planar_lane_samples`]: there each lane agrees with
/// [`super::terrain::run_terrain_sample`] through the rig to rounding, "lifted" and
/// "off_terrain" included. `Ok(None)` when `should_stop` said so.
#[allow(clippy::too_many_arguments)]
pub fn run_planar_rig_lane_samples<C: LaneLaw<Shape = Planar> + Clone, P: LanePath>(
    law: &C,
    path: &P,
    config: &SimConfig<f64>,
    nominal: &PlanarNominal,
    perturbations: &[Perturbation],
    seed: u64,
    indices: core::ops::Range<u64>,
    settle: f64,
    realism_of: RealismOf<'_>,
    should_stop: &dyn Fn() -> bool,
    terrain: Option<(&SweepTerrain, Option<FeedForwardLanes>)>,
) -> Result<Option<Vec<PlanarSampleMetrics>>, TwipError> {
    let Some((terrain, feed)) = terrain else {
        return in_blocks(indices, |i| draw(nominal, perturbations, seed, i), |samples| {
            block::run_planar_rig_block(law.clone(), path, config, samples, settle, realism_of, should_stop, None)
        });
    };
    in_blocks(indices, |i| super::terrain::draw(nominal, terrain, perturbations, seed, i), |drawn| {
        let (samples, grounds) = on_their_grounds(terrain, drawn);
        block::run_planar_rig_block(law.clone(), path, config, &samples, settle, realism_of, should_stop, Some((&grounds, feed)))
    })
}

/// A block's samples drawn on `terrain` and each one's ground (None: one no draw should give).
#[allow(clippy::type_complexity)]
fn on_their_grounds(terrain: &SweepTerrain, drawn: &[(PlanarSample, [f64; 2])]) -> (Vec<PlanarSample>, Vec<Option<Terrain<f64>>>) {
    (drawn.iter().map(|d| d.0).collect(), drawn.iter().map(|d| terrain.at(d.1).ok()).collect())
}

/// The samples `indices`, each drawn by `draw`, run `run_block` by block of [`LANES`].
fn in_blocks<D>(
    indices: core::ops::Range<u64>,
    draw: impl Fn(u64) -> D,
    run_block: impl Fn(&[D]) -> Result<Option<[PlanarSampleMetrics; LANES]>, TwipError>,
) -> Result<Option<Vec<PlanarSampleMetrics>>, TwipError> {
    let mut out = Vec::with_capacity((indices.end - indices.start) as usize);
    let mut start = indices.start;
    while start < indices.end {
        let end = (start + LANES as u64).min(indices.end);
        let samples: Vec<D> = (start..end).map(&draw).collect();
        let Some(block) = run_block(&samples)? else {
            return Ok(None);
        };
        out.extend_from_slice(&block[..samples.len()]);
        start = end;
    }
    Ok(Some(out))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::hardware::motor::DcMotor;
    use crate::sim::runner::Outcome;
    use crate::control::pid::PidTracker;
    use crate::sim::runner::simulate;
    use crate::control::trajectory::{Circle, Direction};
    use crate::sweep::block::{PidLanes, SmcLanes};
    use crate::sweep::Spread;

    pub(crate) fn setup() -> (PidTracker<f64>, Circle<f64>, SimConfig<f64>, PlanarNominal) {
        let params = RobotParams::balanbot();
        let ctrl = PidTracker::table_4_1(&params, DcMotor::gb37y3530(), 0.005).unwrap();
        let circle = Circle::from_origin(0.6, core::f64::consts::PI * params.wheel_radius, Direction::CounterClockwise).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 4.0, fall_limit: 60f64.to_radians() };
        (ctrl, circle, config, PlanarNominal { params, x0: PlanarState::zeros() })
    }

    /// m_body (field 0) may go negative (an invalid robot); com_height (8) up to 5x;
    /// the initial pitch (state 3) up to ±0.6 rad, which some survive.
    /// A rig whose outputs are not quantised (a lane and its run then agree to rounding):
    /// the thesis-like IMU unquantised, the loop's delay, a 5 ms period, the thesis-like
    /// gearhead friction, and the estimators settled at rest first, each lane's its own.
    pub(crate) fn unquantised_rig() -> Realism<f64> {
        use crate::hardware::imu::ImuSettings;
        Realism {
            imu: Some(ImuSettings { quantise: false, ..ImuSettings::thesis_like() }),
            delay: true,
            control_period: Some(5e-3),
            friction: Some(Realism::thesis_like_friction()),
            settle: Some(0.5),
            ..Realism::ideal()
        }
    }

    pub(crate) fn spread() -> [Perturbation; 3] {
        [
            Perturbation { target: Target::Param(0), spread: Spread::Normal { mean: 0.83, std: 0.6, low: -1.0, high: 2.0 } },
            Perturbation { target: Target::Param(8), spread: Spread::Uniform { low: 0.02, high: 0.4 } },
            Perturbation { target: Target::Initial(3), spread: Spread::Uniform { low: -0.6, high: 0.6 } },
        ]
    }

    /// The sweep's sample equals a direct run of the same robot, bit for bit.
    #[test]
    fn a_sample_equals_a_direct_run_of_its_robot() {
        let (ctrl, circle, config, nominal) = setup();
        let spread = spread();
        let never = || false;
        let (mut fell, mut invalid, mut ran) = (0, 0, 0);
        for i in 0..12 {
            let sample = draw(&nominal, &spread, 5, i);
            let got = run_planar_sample(&ctrl, &circle, &config, &sample, 2.0, None, &never).unwrap();
            fell += got.fell as usize;
            let Ok(plant) = PlanarModel::new(sample.params) else {
                assert_eq!(format!("{got:?}"), format!("{:?}", PlanarSampleMetrics::INVALID), "sample {i}");
                invalid += 1;
                continue;
            };
            let mut direct = TrackingMetrics::new(circle, 2.0);
            let (outcome, steps) = simulate(&plant, &mut ctrl.clone(), &circle, &sample.x0, &config, &mut direct).unwrap();
            let s = direct.summary();
            assert_eq!(got.steps, steps as u64, "sample {i}");
            assert_eq!(got.fell, outcome != Outcome::Completed, "sample {i}");
            let expected = [
                s.mean_abs_x_error,
                s.mean_abs_y_error,
                s.mean_abs_x_error_settled,
                s.mean_abs_y_error_settled,
                s.max_path_error_settled,
                s.mean_abs_pitch,
                s.peak_abs_torque,
            ];
            for (k, e) in expected.iter().enumerate() {
                assert_eq!(got.value(k + 1).to_bits(), e.to_bits(), "sample {i}, {}", PlanarSampleMetrics::NAMES[k + 1]);
            }
            ran += 1;
        }
        assert!(ran > 0 && invalid > 0, "{ran} ran, {invalid} invalid");
        assert!(fell > 0 && fell < ran, "the spread should make some robots fall ({fell} of {ran})");
    }

    /// Same draws as the 2-DOF sweep for the shared targets; the slope is refused by name.
    #[test]
    fn draws_are_the_2dof_draws_and_slope_is_refused() {
        let (_, _, _, nominal) = setup();
        let spread = spread();
        let flat = super::super::Nominal { params: nominal.params, slope: 0.0, x0: nalgebra::Vector4::zeros() };
        let shared = &spread[..2];
        for i in 0..8 {
            assert_eq!(draw(&nominal, shared, 3, i).params, super::super::draw(&flat, shared, 3, i).params);
        }
        let slope = Perturbation { target: Target::Slope, spread: Spread::Uniform { low: 0.0, high: 0.1 } };
        assert!(matches!(validate(&slope), Err(TwipError::InvalidParameter { name: "slope", .. })));
        let past = Perturbation { target: Target::Initial(7), spread: Spread::Uniform { low: 0.0, high: 0.1 } };
        assert!(matches!(validate(&past), Err(TwipError::InvalidParameter { name: "target", .. })));
        assert!(validate(&spread[2]).is_ok());
    }

    #[cfg(feature = "parallel")]
    #[test]
    fn one_and_two_threads_give_the_same_bits() {
        use crate::sweep::parallel::{run, Progress};
        use crate::sweep::rig::for_sweep;
        let (ctrl, circle, config, nominal) = setup();
        let spread = spread();
        let real = for_sweep(&Realism::thesis_like(), 5);
        for realism in [None, Some(&real)] {
            let sweep = |threads| {
                run(0..6, BLOCK, threads, &Progress::default(), |range, stop| {
                    Ok(range.map(|i| run_planar_sample(&ctrl, &circle, &config, &draw(&nominal, &spread, 5, i), 2.0, realism, stop)).collect())
                })
                .unwrap()
            };
            assert_eq!(format!("{:?}", sweep(1)), format!("{:?}", sweep(2)));
        }
    }

    /// A realism sample is a direct rig run with the sample's own noise stream, bit for
    /// bit; another sample's stream gives other numbers.
    #[test]
    fn a_realism_sample_is_a_rig_run_with_its_own_stream() {
        use crate::sweep::rig::for_sweep;
        let (ctrl, circle, config, nominal) = setup();
        let real = for_sweep(&Realism::thesis_like(), 5);
        let sample = draw(&nominal, &[], 5, 3);
        let got = run_planar_sample(&ctrl, &circle, &config, &sample, 2.0, Some(&real), &|| false).unwrap();
        let plant = PlanarModel::new(sample.params).unwrap();
        let mut direct = TrackingMetrics::new(circle, 2.0);
        let mut rig = real.with_stream(3).build_planar(&plant, config.dt).unwrap();
        rig.simulate(&mut ctrl.clone(), &circle, &sample.x0, &config, &mut direct, || false).unwrap();
        assert_eq!(got.max_path_error_settled.to_bits(), direct.summary().max_path_error_settled.to_bits());
        let other = run_planar_sample(&ctrl, &circle, &config, &draw(&nominal, &[], 5, 4), 2.0, Some(&real), &|| false).unwrap();
        assert_ne!(got.max_path_error_settled, other.max_path_error_settled, "same robot, other noise stream");
        let ideal = run_planar_sample(&ctrl, &circle, &config, &sample, 2.0, None, &|| false).unwrap();
        assert_ne!(got.max_path_error_settled, ideal.max_path_error_settled);
    }

    /// The thesis's sliding-mode tracker, with or without its fuzzy adaptation.
    pub(crate) fn smc(fuzzy: bool) -> crate::control::smc::SmcTracker<f64> {
        use crate::control::smc::{Adaptation, SmcGains, SmcOptions, SmcTracker};
        let model = PlanarModel::new(RobotParams::balanbot()).unwrap();
        let unit = DcMotor::<f64>::gb37y3530().torque_per_count();
        let adaptation = if fuzzy { Some(Adaptation::default()) } else { None };
        SmcTracker::new(SmcGains::thesis(unit), SmcOptions::default(), model, Some(DcMotor::gb37y3530()), adaptation, 0.005)
            .unwrap()
    }

    /// A lane agrees with the scalar runner of its robot to rounding over 10 s (the lanes'
    /// multiply-adds are fused), keeping every outcome and count: the worst relative
    /// difference of any metric over the samples.
    fn lanes_against_the_runner<C, L>(ctrl: &C, law: &L) -> f64
    where
        C: Controller<f64, 7, 2, Reference = PlanarRef<f64>> + Clone,
        L: LaneLaw<Shape = Planar> + Clone,
    {
        rig_lanes_against_the_runner(ctrl, law, None, 10.0)
    }

    /// [`lanes_against_the_runner`] through the rig of `realism` (set up for the sweep,
    /// each sample its own noise stream), or without one, over `t_final`.
    fn rig_lanes_against_the_runner<C, L>(ctrl: &C, law: &L, realism: Option<&Realism<f64>>, t_final: f64) -> f64
    where
        C: Controller<f64, 7, 2, Reference = PlanarRef<f64>> + Clone,
        L: LaneLaw<Shape = Planar> + Clone,
    {
        let (_, circle, _, nominal) = setup();
        let config = SimConfig { dt: 1e-3, t_final, fall_limit: 60f64.to_radians() };
        let spread = spread();
        let never = || false;
        // A full block and a partial one: in a debug build the blocks are most of the time.
        let n = LANES as u64 + 3;
        let realism = realism.map(|r| crate::sweep::rig::for_sweep(r, 7));
        let lanes = match &realism {
            None => run_planar_lane_samples(law, &circle, &config, &nominal, &spread, 5, 0..n, 2.0, &never, None),
            Some(r) => run_planar_rig_lane_samples(law, &circle, &config, &nominal, &spread, 5, 0..n, 2.0, &|_| Ok(*r), &never, None),
        };
        let lanes = lanes.unwrap().unwrap();
        let (mut worst, mut ran, mut fell) = (0.0f64, 0, 0);
        for i in 0..n {
            let one = run_planar_sample(ctrl, &circle, &config, &draw(&nominal, &spread, 5, i), 2.0, realism.as_ref(), &never).unwrap();
            let got = lanes[i as usize];
            assert_eq!((got.valid, got.fell, got.steps), (one.valid, one.fell, one.steps), "sample {i}");
            if !one.valid {
                continue;
            }
            (ran, fell) = (ran + 1, fell + one.fell as usize);
            worst = worst.max(worst_difference(&got, &one, i));
        }
        assert!(ran > 10 && fell > 0 && fell < ran, "{ran} ran, {fell} fell");
        worst
    }

    /// The largest relative difference of a lane's metrics `got` from its run's `one` (sample
    /// `i`), which end at the same time and are NaN together.
    pub(crate) fn worst_difference(got: &PlanarSampleMetrics, one: &PlanarSampleMetrics, i: u64) -> f64 {
        assert_eq!(got.t_end, one.t_end, "sample {i}");
        let mut worst = 0.0f64;
        for k in 0..PlanarSampleMetrics::NAMES.len() {
            let (a, b) = (got.value(k), one.value(k));
            if a.is_nan() || b.is_nan() {
                assert!(a.is_nan() && b.is_nan(), "sample {i} {}: {a} vs {b}", PlanarSampleMetrics::NAMES[k]);
                continue;
            }
            worst = worst.max((a - b).abs() / b.abs().max(1e-300));
        }
        worst
    }

    /// The fuzzy tracker with 5 × 5 trapezoid grids (the lanes' sized law).
    pub(crate) fn smc_5x5() -> crate::control::smc::SmcTracker<f64> {
        use crate::control::fuzzy_grid::{FuzzyGrid, SetKind};
        let phi = [-0.3, -0.15, 0.0, 0.15, 0.3];
        let grid = |rate: [f64; 5], w: f64| FuzzyGrid::regular(SetKind::Trapezoid, [&phi, &rate], [&[0.03; 5], &[w; 5]]).unwrap();
        smc(true).with_bases(grid([-1.0, -0.5, 0.0, 0.5, 1.0], 0.1), grid([-2.0, -1.0, 0.0, 1.0, 2.0], 0.2)).unwrap()
    }

    #[test]
    fn a_lane_agrees_with_the_runner_to_rounding_over_ten_seconds() {
        let (pid, _, _, _) = setup();
        let laws = [
            ("pid", lanes_against_the_runner(&pid, &PidLanes::new(&pid))),
            ("smc", lanes_against_the_runner(&smc(false), &SmcLanes::new(&smc(false)).unwrap())),
            ("smc-fuzzy", lanes_against_the_runner(&smc(true), &SmcLanes::new(&smc(true)).unwrap())),
            ("smc-fuzzy, 5 x 5 trapezoids", lanes_against_the_runner(&smc_5x5(), &SmcLanes::new(&smc_5x5()).unwrap())),
        ];
        for (name, worst) in laws {
            std::println!("{name}: worst relative difference {worst:e}");
            assert!(worst <= 1e-12, "{name}: worst relative difference {worst:e}");
            assert!(worst > 0.0, "{name}: fused lanes should differ from the plain runner by rounding");
        }
    }

    /// Through the rig (its parts whose output is not quantised), a lane stays within
    /// 1e-12 of the rig's run over 10 s (relative; the worst is printed), for every law on
    /// lanes; with backlash, a force and pushes too over 3 s, and driven through the
    /// bridge (windings with and without inductance) over 1 s; the same not pushed.
    #[test]
    fn a_rig_lane_agrees_with_the_rig_run_to_rounding() {
        use crate::hardware::disturbance::{Force, Push, Pushes};
        use crate::hardware::tilt::TiltEstimator;
        use crate::model::friction::Friction;
        let first = unquantised_rig();
        let second = Realism { estimator: TiltEstimator::kalman(), delay: false, friction: Some(Friction::gb37()), ..first };
        let pushes = Pushes::new(&[Push { t: 1.0, impulse: 0.3, height: 0.1 }, Push { t: 2.0, impulse: -0.25, height: 0.05 }]).unwrap();
        let force = Force { horizontal: 0.4, vertical: -1.5, height: 0.08 };
        let geared = Realism { backlash: Realism::thesis_like().backlash, pushes, force, ..first };
        // Driven through the bridge, a rig feels rounding more: the run itself, its initial
        // pitch nudged by one ulp, differs by ~3e-9 after 3 s (through the duty's counts).
        let thesis_drive = Realism::thesis_like().motor.unwrap();
        let inductive = Realism { motor: Some(thesis_drive), ..geared };
        let steady = Realism { motor: Some(crate::hardware::driver::MotorDriver { inductance: 0.0, ..thesis_drive }), ..geared };
        // Never pushed, a lane skips the work between steps while its trains are engaged.
        let unpushed = [geared, inductive, steady].map(|r| Realism { pushes: Pushes::none(), ..r });
        let (pid, ..) = setup();
        let (pid_lanes, smc_lanes, fuzzy_lanes) = (PidLanes::new(&pid), SmcLanes::new(&smc(false)).unwrap(), SmcLanes::new(&smc(true)).unwrap());
        // (Through the Kalman filter's rig, or pushed and pulled, the sliding-mode trackers
        // let every robot of the spread fall, which tests only the outcome: PID there.)
        let all = [
            ("noisy IMU, delay, stick band: pid", rig_lanes_against_the_runner(&pid, &pid_lanes, Some(&first), 10.0)),
            ("noisy IMU, delay, stick band: smc", rig_lanes_against_the_runner(&smc(false), &smc_lanes, Some(&first), 10.0)),
            ("noisy IMU, delay, stick band: smc-fuzzy", rig_lanes_against_the_runner(&smc(true), &fuzzy_lanes, Some(&first), 10.0)),
            ("Kalman, slip friction: pid", rig_lanes_against_the_runner(&pid, &pid_lanes, Some(&second), 10.0)),
            ("backlash, pushes, a force: pid", rig_lanes_against_the_runner(&pid, &pid_lanes, Some(&geared), 3.0)),
            ("backlash, pushes, a force, inductive windings: pid", rig_lanes_against_the_runner(&pid, &pid_lanes, Some(&inductive), 1.0)),
            ("backlash, pushes, a force, windings without inductance: pid", rig_lanes_against_the_runner(&pid, &pid_lanes, Some(&steady), 1.0)),
            ("backlash, a force, not pushed: pid", rig_lanes_against_the_runner(&pid, &pid_lanes, Some(&unpushed[0]), 3.0)),
            ("backlash, a force, inductive windings, not pushed: pid", rig_lanes_against_the_runner(&pid, &pid_lanes, Some(&unpushed[1]), 1.0)),
            ("backlash, a force, windings without inductance, not pushed: pid", rig_lanes_against_the_runner(&pid, &pid_lanes, Some(&unpushed[2]), 1.0)),
        ];
        for (name, worst) in all {
            std::println!("{name}: worst relative difference {worst:e}");
            assert!(worst <= 1e-12 && worst > 0.0, "{name}: worst relative difference {worst:e}");
        }
    }
}
