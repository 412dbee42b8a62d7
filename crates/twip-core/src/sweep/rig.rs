//! Sweep samples run through the realism rig (sensors, estimator, motor driver, delay,
//! disturbances) instead of the ideal loop.
//!
//! Noise keys: sample `i` of a sweep with seed `s` draws its sensor noise from the
//! stream `(noise_seed(s), i)` (`Sfc64`). The realism's own `seed` and `stream` are
//! replaced, so a sample is reproducible from (sweep seed, index) alone and two sweep
//! seeds give different noise. `noise_seed` is a bijection that moves the key away from
//! `s` itself, so the noise is not the very stream the perturbations were drawn from.
use super::block::{run_rig_block, LaneLaw, Slope};
use super::lanes::LANES;
use super::{draw, finish, fresh, Nominal, Perturbation, Sample, SampleMetrics, SweepMetrics};
use crate::TwipError;
use crate::control::Controller;
use crate::sim::metrics::SlopeMetrics;
use crate::hardware::realism::Realism;
use crate::control::reference::{SpeedRef, SpeedSchedule};
use crate::sim::runner::SimConfig;
use crate::model::slope::SlopeModel;
use crate::model::params::RobotParams;

/// The sensor-noise key of a sweep with seed `sweep_seed` (splitmix64's finaliser of
/// the seed xor a constant: one-to-one, and never the perturbation key in practice).
pub fn noise_seed(sweep_seed: u64) -> u64 {
    let mut z = sweep_seed ^ 0x6e6f_6973_6520_6b65; // "noise ke"
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The realism a sample's robot gets, set up for the sweep ([`for_sweep`]). The rig's parts
/// are every sample's alike, but pushes and a force may act at each robot's own centre of
/// mass. An error makes the sample invalid.
pub type RealismOf<'a> = &'a dyn Fn(&RobotParams<f64>) -> Result<Realism<f64>, TwipError>;

/// `realism` set up for a sweep with seed `sweep_seed`: the noise key is
/// [`noise_seed`]`(sweep_seed)`; [`run_rig_sample`] sets the stream to the sample index.
pub fn for_sweep(realism: &Realism<f64>, sweep_seed: u64) -> Realism<f64> {
    Realism { seed: noise_seed(sweep_seed), stream: 0, ..*realism }
}

/// Runs one sample through the rig `realism` builds for its robot, noise stream
/// `sample.index` (key: `realism.seed`, see [`for_sweep`]). The controller is a reset
/// copy of the prototype, whose period should already be the realism's loop period.
/// An invalid robot (or a rig it cannot have) gives [`SampleMetrics::INVALID`]; `None`
/// when `should_stop` said so.
pub fn run_rig_sample<C>(
    prototype: &C,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    sample: &Sample,
    realism: &Realism<f64>,
    should_stop: &dyn Fn() -> bool,
) -> Option<SampleMetrics>
where
    C: Controller<f64, 4, 1, Reference = SpeedRef<f64>> + Clone,
{
    let Ok(model) = SlopeModel::new(sample.params, sample.slope) else {
        return Some(SampleMetrics::INVALID);
    };
    let Ok(mut rig) = realism.with_stream(sample.index).build(&model, config.dt) else {
        return Some(SampleMetrics::INVALID);
    };
    let mut metrics = SlopeMetrics::new(model);
    let run = rig.simulate(&mut fresh(prototype), reference, &sample.x0, config, &mut metrics, should_stop);
    finish(run, config.dt, |fell, t_end, steps| SampleMetrics::from_summary(&metrics.summary(), fell, t_end, steps))
}

/// Runs the samples `indices` of a sweep, each through the rig of its robot's realism
/// (`realism_of`, set up by [`for_sweep`]) on lanes, [`LANES`] at a time (`block::run_rig_block`):
/// each sample agrees with [`run_rig_sample`] to rounding. `Ok(None)` when `should_stop`
/// said so.
#[allow(clippy::too_many_arguments)]
pub fn run_rig_lane_samples<C: LaneLaw<Shape = Slope> + Clone>(
    law: &C,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    nominal: &Nominal,
    perturbations: &[Perturbation],
    seed: u64,
    indices: core::ops::Range<u64>,
    realism_of: RealismOf<'_>,
    should_stop: &dyn Fn() -> bool,
) -> Result<Option<alloc::vec::Vec<SampleMetrics>>, TwipError> {
    let mut out = alloc::vec::Vec::with_capacity((indices.end - indices.start) as usize);
    let mut start = indices.start;
    while start < indices.end {
        let end = (start + LANES as u64).min(indices.end);
        let samples: alloc::vec::Vec<Sample> = (start..end).map(|i| draw(nominal, perturbations, seed, i)).collect();
        let Some(block) = run_rig_block(law.clone(), reference, config, &samples, realism_of, should_stop)? else {
            return Ok(None);
        };
        out.extend_from_slice(&block[..samples.len()]);
        start = end;
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::lqr::{design, DesignPoint, LqrController};
    use crate::model::params::RobotParams;
    use crate::sweep::{draw, run_slope_sample, Nominal, Perturbation, Spread, Target};
    use crate::control::reference::SpeedRef;
    use crate::control::Controller;
    use alloc::vec::Vec;
    use nalgebra::{Matrix4, Vector4};

    fn setup(period: f64) -> (LqrController<f64>, SpeedSchedule<f64>, SimConfig<f64>, Nominal) {
        let params = RobotParams::balanbot();
        let model = SlopeModel::new(params, 0.0).unwrap();
        let speed = 180f64.to_radians();
        let q = Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
        let d = design(&model, speed, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
        let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, period).unwrap();
        let schedule = SpeedSchedule::constant(speed).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 2.0, fall_limit: 1.0 };
        (ctrl, schedule, config, Nominal { params, slope: 0.0, x0: Vector4::zeros() })
    }

    fn spread() -> [Perturbation; 3] {
        [
            Perturbation { target: Target::Param(0), spread: Spread::Normal { mean: 0.83, std: 0.8, low: -1.0, high: 2.0 } },
            Perturbation { target: Target::Slope, spread: Spread::Uniform { low: 0.0, high: 0.2 } },
            Perturbation { target: Target::Initial(0), spread: Spread::Uniform { low: -0.3, high: 0.3 } },
        ]
    }

    /// The ideal rig is the ideal loop, bit for bit, invalid and fallen samples included.
    #[test]
    fn ideal_realism_equals_the_general_runner() {
        let (ctrl, schedule, config, nominal) = setup(5e-3);
        let ideal = for_sweep(&Realism::ideal(), 3);
        let never = || false;
        let mut invalid = 0;
        for i in 0..12 {
            let sample = draw(&nominal, &spread(), 3, i);
            let plain = run_slope_sample(&ctrl, &schedule, &config, &sample, &never).unwrap();
            let rig = run_rig_sample(&ctrl, &schedule, &config, &sample, &ideal, &never).unwrap();
            assert_eq!(format!("{rig:?}"), format!("{plain:?}"), "sample {i}");
            invalid += !rig.valid as usize;
        }
        assert!(invalid > 0 && invalid < 12, "some drawn robots should be invalid ({invalid})");
    }

    /// A sample's noise is its own: the same alone or after others, different for
    /// another index or another sweep seed with the very same robot.
    #[test]
    fn thesis_like_noise_belongs_to_the_sample() {
        let (ctrl, schedule, config, nominal) = setup(5e-3);
        let realism = for_sweep(&Realism::thesis_like(), 5);
        let never = || false;
        let sample = |i| crate::sweep::Sample { index: i, params: nominal.params, slope: 0.05, x0: nominal.x0 };
        let run = |s: &crate::sweep::Sample, r: &Realism<f64>| {
            format!("{:?}", run_rig_sample(&ctrl, &schedule, &config, s, r, &never).unwrap())
        };
        let alone = run(&sample(17), &realism);
        for i in 0..3 {
            run(&sample(i), &realism);
        }
        assert_eq!(run(&sample(17), &realism), alone);
        assert!(alone.contains("valid: true"), "{alone}");
        assert_ne!(run(&sample(18), &realism), alone, "another index, other noise");
        assert_ne!(run(&sample(17), &for_sweep(&Realism::thesis_like(), 6)), alone, "another sweep seed, other noise");
        assert_ne!(noise_seed(5), 5);
    }

    /// The worst relative difference between a lane through the rig and the rig's run of
    /// its robot over `t_final`, among 35 robots that stay up; every robot (some invalid,
    /// some falling) ends the same way at the same step.
    fn rig_lanes_agree<L, C>(law: &L, prototype: &C, realism: &Realism<f64>, t_final: f64) -> f64
    where
        L: LaneLaw<Shape = Slope> + Clone,
        C: Controller<f64, 4, 1, Reference = SpeedRef<f64>> + Clone,
    {
        rig_lanes_agree_per_robot(law, prototype, &|_| *realism, &spread(), t_final)
    }

    /// [`rig_lanes_agree`] with each robot's own realism (`realism_of` its parameters), the
    /// robots drawn from `spread`.
    fn rig_lanes_agree_per_robot<L, C>(law: &L, prototype: &C, realism_of: &dyn Fn(&RobotParams<f64>) -> Realism<f64>, spread: &[Perturbation], t_final: f64) -> f64
    where
        L: LaneLaw<Shape = Slope> + Clone,
        C: Controller<f64, 4, 1, Reference = SpeedRef<f64>> + Clone,
    {
        let (_, schedule, mut config, nominal) = setup(5e-3);
        config.t_final = t_final;
        let swept = |p: &RobotParams<f64>| for_sweep(&realism_of(p), 7);
        let never = || false;
        // A full block and a partial one: in a debug build the blocks are most of the time.
        let n = LANES as u64 + 3;
        let lanes = run_rig_lane_samples(law, &schedule, &config, &nominal, spread, 3, 0..n, &|p| Ok(swept(p)), &never).unwrap().unwrap();
        let (mut worst, mut fell, mut invalid) = (0.0f64, 0, 0);
        for (i, got) in lanes.iter().enumerate() {
            let sample = draw(&nominal, spread, 3, i as u64);
            let expected = run_rig_sample(prototype, &schedule, &config, &sample, &swept(&sample.params), &never).unwrap();
            assert_eq!((got.valid, got.fell, got.steps), (expected.valid, expected.fell, expected.steps), "sample {i}");
            assert!(got.t_end == expected.t_end || !got.valid, "sample {i}");
            for (a, b) in [
                (got.mean_abs_pitch_error, expected.mean_abs_pitch_error),
                (got.mean_abs_speed_error, expected.mean_abs_speed_error),
                (got.final_position_error, expected.final_position_error),
                (got.peak_abs_input, expected.peak_abs_input),
                (got.peak_current, expected.peak_current),
                (got.peak_command, expected.peak_command),
                (got.saturation_share, expected.saturation_share),
            ] {
                // A falling robot's last moments diverge at the open-loop rate (as the
                // ideal lanes' test, the bound is for the robots that stay up).
                if (a.is_nan() && b.is_nan()) || got.fell {
                    continue;
                }
                worst = worst.max((a - b).abs() / b.abs().max(1e-9));
            }
            // A settling time is a step's time: rounding may move it by one step at most.
            for (a, b) in [
                (got.pitch_settling_time, expected.pitch_settling_time),
                (got.speed_settling_time, expected.speed_settling_time),
            ] {
                assert!((a - b).abs() <= config.dt * 1.000001 || (a.is_nan() && b.is_nan()), "sample {i}: {a} vs {b}");
            }
            fell += got.fell as usize;
            invalid += !got.valid as usize;
        }
        assert!(invalid > 0 && fell + invalid < n as usize, "fell {fell}, invalid {invalid}");
        worst
    }

    fn lanes() -> (crate::sweep::block::LqrLanes, LqrController<f64>, crate::sweep::block::FuzzyLanes, crate::control::fuzzy::FuzzyController<f64>) {
        use crate::control::fuzzy::FuzzyController;
        use crate::sweep::block::{FuzzyLanes, LqrLanes};
        let (lqr, ..) = setup(5e-3);
        let fuzzy = FuzzyController::thesis_flat(SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap(), 5e-3).unwrap();
        (LqrLanes::new(&lqr), lqr, FuzzyLanes::new(&fuzzy), fuzzy)
    }

    /// Every part a lane runs whose output is not quantised: over 10 s a lane stays
    /// within 1e-12 of the rig's run (relative; the worst is printed).
    #[test]
    fn a_rig_lane_agrees_with_the_rig_run_to_rounding_over_ten_seconds() {
        use crate::hardware::imu::ImuSettings;
        use crate::hardware::tilt::TiltEstimator;
        use crate::model::friction::Friction;
        let (lqr_lanes, lqr, fuzzy_lanes, fuzzy) = lanes();
        let unquantised = ImuSettings { quantise: false, ..ImuSettings::thesis_like() };
        let first = Realism {
            imu: Some(unquantised),
            delay: true,
            control_period: Some(5e-3),
            friction: Some(Realism::thesis_like_friction()),
            // The estimators settle at rest first, each lane's its own.
            settle: Some(0.5),
            ..Realism::ideal()
        };
        let second = Realism { estimator: TiltEstimator::kalman(), delay: false, friction: Some(Friction::gb37()), ..first };
        let gaussian = crate::sweep::tests::with_gaussians(&fuzzy);
        let gaussian_lanes = crate::sweep::block::FuzzyLanes::new(&gaussian);
        for (name, realism) in [("noisy IMU, delay, stick band", first), ("Kalman, slip friction", second)] {
            let lqr_worst = rig_lanes_agree(&lqr_lanes, &lqr, &realism, 10.0);
            let fuzzy_worst = rig_lanes_agree(&fuzzy_lanes, &fuzzy, &realism, 10.0);
            let gaussian_worst = rig_lanes_agree(&gaussian_lanes, &gaussian, &realism, 10.0);
            println!("{name}: worst relative difference over 10 s: LQR {lqr_worst:e}, fuzzy {fuzzy_worst:e}, Gaussian sets {gaussian_worst:e}");
            for worst in [lqr_worst, fuzzy_worst, gaussian_worst] {
                assert!(worst <= 1e-12 && worst > 0.0, "{name}: {worst:e}");
            }
        }
    }

    /// Pushes are each lane's rig's, applied between steps as in the run, and a constant
    /// force adds its generalised forces in the lanes' RK4 as in the run's: pushed at 1 s and
    /// 2 s, pulled, or both, a lane agrees with the run to rounding over 3 s. (Longer, a
    /// robot the pushes leave at the stick band's edge is as sensitive as a quantised rig:
    /// fuzzy, pushes at 2 s and 6 s, one robot's mean |pitch error| after 10 s differs by
    /// 3.0e-2 from the lane and by 1.6e-3 from the run with its initial pitch nudged by
    /// 1e-16, both 1e-12 after 5 s.)
    #[test]
    fn a_pushed_or_pulled_rig_lane_agrees_with_the_rig_run() {
        use crate::hardware::disturbance::{Force, Push, Pushes};
        use crate::hardware::imu::ImuSettings;
        let (lqr_lanes, lqr, fuzzy_lanes, fuzzy) = lanes();
        let pushes = Pushes::new(&[Push { t: 1.0, impulse: 0.3, height: 0.1 }, Push { t: 2.0, impulse: -0.25, height: 0.05 }]).unwrap();
        let pushed = Realism {
            imu: Some(ImuSettings { quantise: false, ..ImuSettings::thesis_like() }),
            delay: true,
            control_period: Some(5e-3),
            friction: Some(Realism::thesis_like_friction()),
            pushes,
            ..Realism::ideal()
        };
        let force = Force { horizontal: 0.4, vertical: -1.5, height: 0.08 };
        let pulled = Realism { pushes: Pushes::none(), force, ..pushed };
        let both = Realism { force, ..pushed };
        for (name, realism) in [("pushed", pushed), ("pulled", pulled), ("pushed and pulled", both)] {
            let lqr_worst = rig_lanes_agree(&lqr_lanes, &lqr, &realism, 3.0);
            let fuzzy_worst = rig_lanes_agree(&fuzzy_lanes, &fuzzy, &realism, 3.0);
            println!("{name}: worst relative difference over 3 s: LQR {lqr_worst:e}, fuzzy {fuzzy_worst:e}");
            for worst in [lqr_worst, fuzzy_worst] {
                assert!(worst <= 1e-12 && worst > 0.0, "{name}: {worst:e}");
            }
        }
        // The force acts: the pulled robots settle elsewhere.
        let (_, schedule, config, nominal) = setup(5e-3);
        let run = |r: &Realism<f64>| run_rig_lane_samples(&lqr_lanes, &schedule, &config, &nominal, &spread(), 3, 0..4, &|_| Ok(for_sweep(r, 7)), &|| false).unwrap().unwrap();
        assert_ne!(run(&pushed)[1].mean_abs_pitch_error, run(&both)[1].mean_abs_pitch_error);
    }

    /// Pushes and a force at each robot's own centre of mass (what `twip.Push` without a
    /// height means): each lane's rig pushes and pulls its robot where its robot's is, as
    /// the run of that robot does, with centres of mass ±30 % apart.
    #[test]
    fn pushes_and_forces_at_each_robots_own_height_agree_with_its_run() {
        use crate::hardware::disturbance::{Force, Push, Pushes};
        use crate::hardware::imu::ImuSettings;
        let (lqr_lanes, lqr, fuzzy_lanes, fuzzy) = lanes();
        let com = crate::model::params::FIELD_NAMES.iter().position(|&f| f == "com_height").unwrap();
        let mut spread = spread().to_vec();
        let nominal_com = RobotParams::<f64>::balanbot().com_height;
        spread.push(Perturbation { target: Target::Param(com), spread: Spread::Uniform { low: 0.7 * nominal_com, high: 1.3 * nominal_com } });
        let at_com = |p: &RobotParams<f64>| Realism {
            imu: Some(ImuSettings { quantise: false, ..ImuSettings::thesis_like() }),
            control_period: Some(5e-3),
            pushes: Pushes::new(&[Push { t: 0.5, impulse: 0.3, height: p.com_height }]).unwrap(),
            force: Force { horizontal: 0.4, vertical: -1.5, height: p.com_height },
            ..Realism::ideal()
        };
        let lqr_worst = rig_lanes_agree_per_robot(&lqr_lanes, &lqr, &at_com, &spread, 2.0);
        let fuzzy_worst = rig_lanes_agree_per_robot(&fuzzy_lanes, &fuzzy, &at_com, &spread, 2.0);
        println!("at each robot's height: worst relative difference over 2 s: LQR {lqr_worst:e}, fuzzy {fuzzy_worst:e}");
        for worst in [lqr_worst, fuzzy_worst] {
            assert!(worst <= 1e-12 && worst > 0.0, "{worst:e}");
        }
    }

    /// A realism per robot may move pushes and forces, not the rig's parts, which the lanes
    /// share: a robot given another IMU is refused with its sample's index, not run on the
    /// block's first.
    #[test]
    fn robots_given_other_rig_parts_are_refused() {
        let (lqr_lanes, ..) = lanes();
        let (_, schedule, config, nominal) = setup(5e-3);
        let heavy = |p: &RobotParams<f64>| p.m_body > 0.83;
        let realism_of = |p: &RobotParams<f64>| {
            let r = if heavy(p) { Realism::thesis_like() } else { Realism { imu: None, ..Realism::thesis_like() } };
            Ok(for_sweep(&r, 7))
        };
        // The first valid robot (a negative mass is invalid, its sample skipped) and the
        // first valid one of the other kind after it.
        let robot = |i| SlopeModel::new(draw(&nominal, &spread(), 3, i).params, 0.0).ok().map(|m| heavy(m.params()));
        let first = (0..16).find_map(robot).unwrap();
        let first_other = (0..16).find(|&i| robot(i) == Some(!first));
        let got = run_rig_lane_samples(&lqr_lanes, &schedule, &config, &nominal, &spread(), 3, 0..16, &realism_of, &|| false);
        match got {
            Err(crate::TwipError::InvalidParameter { name: "realism_of", value, .. }) => assert_eq!(Some(value as u64), first_other),
            other => panic!("should be refused: {other:?}"),
        }
    }

    /// With quantised outputs (the IMU's registers, the encoders' counts, the duty's whole
    /// counts) the feedback does not see a difference below one count, so two roundings drift
    /// apart at the open-loop pendulum's rate until a count flips (~2-4 s here): the rig's
    /// own run does the same against itself with its initial state nudged by 1e-16
    /// (measured: 1.2e-11 after 2 s, 2.4e-8 after 3 s, 2.7e-2 after 6 s). Backlash's flank
    /// contacts are such events too (fuzzy, unquantised rig with backlash, sample 13 over
    /// 10 s: the run 0.2429, the run nudged by 1e-16 0.2504, the lane 0.2373 mean |pitch
    /// error|). So a lane agrees with the run to rounding over 1 s, and over 10 s the two are
    /// equally likely outcomes: the same falls, and sample means within a percent.
    #[test]
    fn a_quantised_rig_lane_agrees_over_one_second_and_in_distribution_over_ten() {
        use crate::hardware::disturbance::{Force, Push, Pushes};
        use crate::hardware::driver::MotorDriver;
        let (lqr_lanes, lqr, fuzzy_lanes, fuzzy) = lanes();
        let thesis_like = Realism::thesis_like();
        let no_backlash = Realism { backlash: None, ..thesis_like };
        let steady = Realism { motor: Some(MotorDriver::gb37y3530()), ..no_backlash };
        let pushes = Pushes::new(&[Push { t: 0.5, impulse: 0.3, height: 0.1 }]).unwrap();
        let force = Force { horizontal: 0.4, vertical: -1.5, height: 0.08 };
        let pushed = Realism { pushes, force, ..thesis_like };
        // Without backlash the lanes skip the per-lane work between steps unless a push acts;
        // with it, while the trains are engaged (held current or inductive winding).
        let pushed_no_backlash = Realism { pushes, ..no_backlash };
        let held = Realism { motor: None, ..thesis_like };
        let steady_backlash = Realism { motor: steady.motor, ..thesis_like };
        let cases = [
            ("thesis-like", thesis_like),
            ("thesis-like, held current", held),
            ("thesis-like, no backlash", no_backlash),
            ("steady winding", steady),
            ("steady winding, backlash", steady_backlash),
            ("thesis-like, pushed and pulled", pushed),
            ("no backlash, pushed", pushed_no_backlash),
        ];
        for (name, realism) in cases {
            let lqr_worst = rig_lanes_agree(&lqr_lanes, &lqr, &realism, 1.0);
            let fuzzy_worst = rig_lanes_agree(&fuzzy_lanes, &fuzzy, &realism, 1.0);
            println!("{name}: worst relative difference over 1 s: LQR {lqr_worst:e}, fuzzy {fuzzy_worst:e}");
            // Rounding only: from the settled start the fuzzy law's run without backlash
            // reached 1.6e-12 (a lane without the settle is degrees off). An impact located
            // within its step divides by the rotor's travel over the step, which scales a
            // rounding up where that travel is short (held current, fuzzy: 5.1e-12).
            for worst in [lqr_worst, fuzzy_worst] {
                assert!(worst <= 1e-11 && worst > 0.0, "{name}: {worst:e}");
            }
        }
        let (_, schedule, mut config, nominal) = setup(5e-3);
        config.t_final = 10.0;
        let realism = for_sweep(&thesis_like, 7);
        let n = 48;
        let lanes = run_rig_lane_samples(&lqr_lanes, &schedule, &config, &nominal, &spread(), 3, 0..n, &|_| Ok(realism), &|| false).unwrap().unwrap();
        let runs: Vec<_> = (0..n).map(|i| run_rig_sample(&lqr, &schedule, &config, &draw(&nominal, &spread(), 3, i), &realism, &|| false).unwrap()).collect();
        let falls = |m: &[SampleMetrics]| m.iter().filter(|s| s.fell).count();
        assert_eq!(falls(&lanes), falls(&runs));
        let mean = |m: &[SampleMetrics], f: fn(&SampleMetrics) -> f64| {
            let kept: Vec<f64> = m.iter().filter(|s| s.valid && !s.fell).map(f).collect();
            kept.iter().sum::<f64>() / kept.len() as f64
        };
        type Metric = (&'static str, fn(&SampleMetrics) -> f64);
        let metrics: [Metric; 3] = [
            ("mean_abs_pitch_error", |s| s.mean_abs_pitch_error),
            ("mean_abs_speed_error", |s| s.mean_abs_speed_error),
            ("final_position_error", |s| s.final_position_error),
        ];
        for (metric, f) in metrics {
            let (a, b) = (mean(&lanes, f), mean(&runs, f));
            println!("{metric}: lanes {a:e}, runs {b:e}");
            assert!((a - b).abs() <= 0.01 * b.abs(), "{metric}: lanes {a:e} vs runs {b:e}");
        }
    }

    /// Slope changes along the path: each lane picks its piece of the ground at every stage
    /// by its distance travelled, as the run's plant does; over 3 s the robots cross three
    /// changes, and a lane agrees with the run to rounding (the quantised thesis-like rig over 1 s).
    #[test]
    fn a_rig_lane_on_changing_slopes_agrees_with_the_rig_run() {
        use crate::hardware::disturbance::SlopeProfile;
        use crate::hardware::imu::ImuSettings;
        let (lqr_lanes, lqr, fuzzy_lanes, fuzzy) = lanes();
        let hills = SlopeProfile::new(0.0, &[(0.02, 0.04), (0.08, -0.03), (0.15, 0.0)]).unwrap();
        let unquantised = Realism {
            imu: Some(ImuSettings { quantise: false, ..ImuSettings::thesis_like() }),
            delay: true,
            control_period: Some(5e-3),
            friction: Some(Realism::thesis_like_friction()),
            slope_profile: hills,
            ..Realism::ideal()
        };
        let thesis_like = Realism { slope_profile: hills, ..Realism::thesis_like() };
        // Two changes: the lanes' loops that pick among a few (`FEW_CHANGES`), not all.
        let ramp = Realism { slope_profile: SlopeProfile::new(0.0, &[(0.02, 0.04), (0.08, -0.03)]).unwrap(), ..unquantised };
        for (name, realism, t_final) in [("unquantised", unquantised, 3.0), ("thesis-like", thesis_like, 1.0), ("two changes, unquantised", ramp, 3.0)] {
            let lqr_worst = rig_lanes_agree(&lqr_lanes, &lqr, &realism, t_final);
            let fuzzy_worst = rig_lanes_agree(&fuzzy_lanes, &fuzzy, &realism, t_final);
            println!("{name} on changing slopes: worst relative difference over {t_final} s: LQR {lqr_worst:e}, fuzzy {fuzzy_worst:e}");
            for worst in [lqr_worst, fuzzy_worst] {
                assert!(worst <= 1e-12 && worst > 0.0, "{name}: {worst:e}");
            }
        }
        // The robots reach the changes, and the slopes act.
        let (_, schedule, mut config, nominal) = setup(5e-3);
        config.t_final = 3.0;
        let run = |r: &Realism<f64>| run_rig_lane_samples(&lqr_lanes, &schedule, &config, &nominal, &spread(), 3, 0..4, &|_| Ok(for_sweep(r, 7)), &|| false).unwrap().unwrap();
        let (hilly, flat) = (run(&unquantised), run(&Realism { slope_profile: SlopeProfile::constant(0.0), ..unquantised }));
        // (Sample 0 climbs past them: 0.148 against 0.103 flat, mean |pitch error|.)
        assert!((0..4).any(|i| hilly[i].valid && hilly[i].mean_abs_pitch_error != flat[i].mean_abs_pitch_error));
    }

    /// The rig's own errors about the robot are the sample's, not the sweep's.
    #[test]
    fn a_robot_the_rig_cannot_take_is_invalid() {
        let (ctrl, schedule, config, nominal) = setup(5e-3);
        let mut params = nominal.params;
        params.m_body = -1.0;
        let s = crate::sweep::Sample { index: 0, params, slope: 0.0, x0: nominal.x0 };
        let m = run_rig_sample(&ctrl, &schedule, &config, &s, &Realism::thesis_like(), &|| false).unwrap();
        assert!(!m.valid && m.t_end.is_nan());
    }
}
