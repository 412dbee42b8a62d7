//! Monte Carlo robustness sweeps: many closed-loop runs of one scenario, each with its
//! own perturbed robot, slope and initial state (3-DOF tracking: [`planar`]).
//!
//! Sample `i` draws its perturbations from its own counter-based stream
//! (`Philox::new(seed, i)`), so a sweep gives the same numbers on any number of threads
//! and any sample can be replayed alone. A sample keeps its metrics, not its trajectory.
extern crate alloc;

use nalgebra::{SVector, Vector4};

use crate::control::Controller;
use crate::sim::metrics::{SlopeMetrics, SlopeSummary};
use crate::model::params::RobotParams;
use crate::control::reference::{SpeedRef, SpeedSchedule};
use crate::rng::Philox;
use crate::sim::runner::{simulate_until, Outcome, SimConfig};
use crate::model::slope::SlopeModel;
use crate::TwipError;

pub mod lanes;
pub mod block;
#[cfg(feature = "parallel")]
pub mod parallel;
pub mod planar;
pub mod terrain;
pub mod rig;

/// What a perturbation changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// A `RobotParams` field, by its index in `params::FIELD_NAMES`.
    Param(usize),
    /// The slope angle [rad] (3-DOF: the terrain's plane's steepest slope).
    Slope,
    /// The uphill heading [rad] of a 3-DOF sweep's terrain plane.
    Heading,
    /// An entry of the initial state.
    Initial(usize),
}

/// How a perturbed value is drawn (absolute values; the Python layer resolves relative
/// spreads against the nominal value). Draws are clamped into `[low, high]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spread {
    Uniform { low: f64, high: f64 },
    Normal { mean: f64, std: f64, low: f64, high: f64 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perturbation {
    pub target: Target,
    pub spread: Spread,
}

/// The largest |z| a standard normal draw takes (Box–Muller: sqrt(-2 ln 2^-53)).
pub const NORMAL_REACH: f64 = 8.571_674_348_652_905;

impl Perturbation {
    /// Checks the spread (finite, ordered, non-negative width) and the target, for the
    /// 2-DOF sweeps (a 4-entry initial state).
    pub fn validate(&self) -> Result<(), TwipError> {
        self.validate_spread()?;
        if self.target == Target::Heading {
            return Err(TwipError::InvalidParameter {
                name: "heading",
                value: self.spread.high(),
                reason: "cannot be perturbed in a 2-DOF sweep: the slope model has no heading (a 3-DOF scenario on a terrain plane has)",
            });
        }
        self.validate_target(4)
    }

    pub(crate) fn validate_spread(&self) -> Result<(), TwipError> {
        let bad = |name, value, reason| Err(TwipError::InvalidParameter { name, value, reason });
        match self.spread {
            Spread::Uniform { low, high } => {
                if !(low.is_finite() && high.is_finite()) {
                    return bad("low/high", if low.is_finite() { high } else { low }, "must be finite");
                }
                if high < low {
                    return bad("high", high, "must be >= low (a negative width)");
                }
                if !(high - low).is_finite() {
                    return bad("high", high, "high - low overflows: the draws would be infinite");
                }
            }
            Spread::Normal { mean, std, low, high } => {
                if !mean.is_finite() {
                    return bad("mean", mean, "must be finite");
                }
                if !(std.is_finite() && std >= 0.0) {
                    return bad("std", std, "must be finite and >= 0");
                }
                if !(mean.abs() + NORMAL_REACH * std).is_finite() {
                    return bad("std", std, "mean +- 8.57 std overflows: the draws would be infinite");
                }
                if high < low || low.is_nan() || high.is_nan() {
                    return bad("high", high, "bounds must satisfy low <= high");
                }
            }
        }
        Ok(())
    }

    /// `states`: the entries of the model's initial state.
    pub(crate) fn validate_target(&self, states: usize) -> Result<(), TwipError> {
        let bad = |value: usize, reason| Err(TwipError::InvalidParameter { name: "target", value: value as f64, reason });
        match self.target {
            Target::Param(i) if i >= crate::model::params::FIELD_NAMES.len() => bad(i, "no RobotParams field with this index"),
            Target::Initial(i) if i >= states => bad(i, "no initial-state entry with this index"),
            _ => Ok(()),
        }
    }
}

impl Spread {
    /// The largest value a draw can take (a uniform's high end; a normal's clamp, or its
    /// mean + `NORMAL_REACH` std when that is nearer).
    pub fn high(&self) -> f64 {
        match *self {
            Spread::Uniform { high, .. } => high,
            Spread::Normal { mean, std, low, high } => (mean + NORMAL_REACH * std).min(high).max(low),
        }
    }

    /// The smallest value a draw can take.
    pub fn low(&self) -> f64 {
        match *self {
            Spread::Uniform { low, .. } => low,
            Spread::Normal { mean, std, low, high } => (mean - NORMAL_REACH * std).max(low).min(high),
        }
    }
}

impl Perturbation {
    fn draw(&self, rng: &mut Philox) -> f64 {
        match self.spread {
            Spread::Uniform { low, high } => low + (high - low) * rng.uniform::<f64>(),
            Spread::Normal { mean, std, low, high } => (mean + std * rng.normal::<f64>()).clamp(low, high),
        }
    }
}

/// The unperturbed scenario a sweep starts from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nominal {
    pub params: RobotParams<f64>,
    pub slope: f64,
    pub x0: Vector4<f64>,
}

/// One sample's robot, slope and initial state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub index: u64,
    pub params: RobotParams<f64>,
    pub slope: f64,
    pub x0: Vector4<f64>,
}

/// Draws sample `index`: the perturbations in their given order from stream `index`.
pub fn draw(nominal: &Nominal, perturbations: &[Perturbation], seed: u64, index: u64) -> Sample {
    let (params, [slope, _], x0) = draw_values(&nominal.params, [nominal.slope, 0.0], &nominal.x0, perturbations, seed, index);
    Sample { index, params, slope, x0 }
}

/// The draw of both sweep families (any state size): the perturbations in their given
/// order from `Philox::new(seed, index)` over the nominal values. A target past the end
/// of the fields or the state draws its number but changes nothing (`validate` refuses it).
/// `ground`: the slope and the (3-DOF) uphill heading.
pub(crate) fn draw_values<const NX: usize>(
    params: &RobotParams<f64>,
    ground: [f64; 2],
    x0: &SVector<f64, NX>,
    perturbations: &[Perturbation],
    seed: u64,
    index: u64,
) -> (RobotParams<f64>, [f64; 2], SVector<f64, NX>) {
    let mut rng = Philox::new(seed, index);
    let mut values = params.to_array();
    let [mut slope, mut heading] = ground;
    let mut x0 = *x0;
    for p in perturbations {
        let v = p.draw(&mut rng);
        let slot = match p.target {
            Target::Param(i) => values.get_mut(i),
            Target::Slope => Some(&mut slope),
            Target::Heading => Some(&mut heading),
            Target::Initial(i) => x0.as_mut_slice().get_mut(i),
        };
        if let Some(slot) = slot {
            *slot = v;
        }
    }
    (RobotParams::from_array(&values), [slope, heading], x0)
}

/// What the bindings lay out as columns of a sweep's result: flags, step count and the
/// float metrics by name (`NAMES[i]` is `value(i)`), so each family names its own.
/// Implemented by this module's `sweep_metrics!`.
pub trait SweepMetrics: Copy + Send {
    /// The float columns, "t_end" first.
    const NAMES: &'static [&'static str];
    /// A sample whose robot was invalid: nothing run, every float NaN.
    const INVALID: Self;
    fn valid(&self) -> bool;
    fn fell(&self) -> bool;
    fn steps(&self) -> u64;
    /// Column `i` of [`Self::NAMES`] (NaN past the end).
    fn value(&self, i: usize) -> f64;
}

/// Implements [`SweepMetrics`] for a struct of `valid`, `fell`, `steps` and the float
/// fields listed, in column order. The column names are the field names, and a float
/// field left out of the list fails to compile (in `INVALID`), so the two cannot drift.
macro_rules! sweep_metrics {
    ($ty:ty { $($field:ident),+ $(,)? }) => {
        impl $crate::sweep::SweepMetrics for $ty {
            const NAMES: &'static [&'static str] = &[$(stringify!($field)),+];
            const INVALID: Self = Self { valid: false, fell: false, steps: 0, $($field: f64::NAN),+ };

            fn valid(&self) -> bool {
                self.valid
            }

            fn fell(&self) -> bool {
                self.fell
            }

            fn steps(&self) -> u64 {
                self.steps
            }

            fn value(&self, i: usize) -> f64 {
                [$(self.$field),+].get(i).copied().unwrap_or(f64::NAN)
            }
        }
    };
}
pub(crate) use sweep_metrics;

/// What a sweep keeps of one sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleMetrics {
    /// False when the drawn robot was invalid (e.g. a negative mass); nothing was run.
    pub valid: bool,
    pub fell: bool,
    /// When the run ended (t_final, or the fall).
    pub t_end: f64,
    pub mean_abs_pitch_error: f64,
    pub mean_abs_speed_error: f64,
    pub pitch_settling_time: f64,
    pub speed_settling_time: f64,
    pub final_position_error: f64,
    pub peak_abs_input: f64,
    pub peak_current: f64,
    pub peak_torque: f64,
    pub peak_command: f64,
    pub saturation_share: f64,
    pub steps: u64,
}

impl SampleMetrics {
    /// A valid sample's metrics from its run's summary and how the run ended (`fell`: it
    /// fell or diverged, and never settled: [`SlopeSummary::ended_early`]).
    pub fn from_summary(s: &SlopeSummary<f64>, fell: bool, t_end: f64, steps: u64) -> Self {
        let s = if fell { s.ended_early(t_end) } else { *s };
        Self {
            valid: true,
            fell,
            t_end,
            mean_abs_pitch_error: s.mean_abs_pitch_error,
            mean_abs_speed_error: s.mean_abs_speed_error,
            pitch_settling_time: s.pitch_settling_time,
            speed_settling_time: s.speed_settling_time,
            final_position_error: s.final_position_error,
            peak_abs_input: s.peak_abs_input,
            peak_current: s.peak_current,
            peak_torque: s.peak_torque,
            peak_command: s.peak_command,
            saturation_share: s.saturation_share,
            steps,
        }
    }
}

sweep_metrics!(SampleMetrics {
    t_end,
    mean_abs_pitch_error,
    mean_abs_speed_error,
    pitch_settling_time,
    speed_settling_time,
    final_position_error,
    peak_abs_input,
    peak_current,
    peak_torque,
    peak_command,
    saturation_share,
});

/// A reset copy of a sweep's controller, designed once on the nominal robot.
pub(crate) fn fresh<C: Controller<f64, NX, NU> + Clone, const NX: usize, const NU: usize>(prototype: &C) -> C {
    let mut controller = prototype.clone();
    controller.reset();
    controller
}

/// A sample's metrics from its run: `M::INVALID` when the run refused the drawn robot or
/// state, `None` when `should_stop` ended it, else `make(fell, t_end, steps)` (a
/// diverged run counts as fallen; a completed one ends at `dt * steps`).
pub(crate) fn finish<M: SweepMetrics>(
    run: Result<(Outcome<f64>, usize), TwipError>,
    dt: f64,
    make: impl FnOnce(bool, f64, u64) -> M,
) -> Option<M> {
    let Ok((outcome, steps)) = run else {
        return Some(M::INVALID);
    };
    if let Outcome::Interrupted { .. } = outcome {
        return None;
    }
    let (fell, t_end) = outcome.ended_early().map_or((false, dt * steps as f64), |t| (true, t));
    Some(make(fell, t_end, steps as u64))
}

/// Runs one sample with any 2-DOF controller (the general path; LQR has a faster one in
/// [`block`]). The controller is a copy of the prototype, reset: designed once on
/// the nominal robot, as a robustness study asks. `None` when `should_stop` said so.
pub fn run_slope_sample<C>(
    prototype: &C,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    sample: &Sample,
    should_stop: &dyn Fn() -> bool,
) -> Option<SampleMetrics>
where
    C: Controller<f64, 4, 1, Reference = SpeedRef<f64>> + Clone,
{
    let Ok(plant) = SlopeModel::new(sample.params, sample.slope) else {
        return Some(SampleMetrics::INVALID);
    };
    let mut metrics = SlopeMetrics::new(plant);
    let run = simulate_until(&plant, &mut fresh(prototype), reference, &sample.x0, config, &mut metrics, should_stop);
    finish(run, config.dt, |fell, t_end, steps| SampleMetrics::from_summary(&metrics.summary(), fell, t_end, steps))
}

/// Metrics of samples `indices` with LQR, via the lane kernel, blocks of [`lanes::LANES`].
/// `None` when `should_stop` said so before all were done.
#[allow(clippy::too_many_arguments)]
pub fn run_lqr_samples(
    controller: &crate::control::lqr::LqrController<f64>,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    nominal: &Nominal,
    perturbations: &[Perturbation],
    seed: u64,
    indices: core::ops::Range<u64>,
    should_stop: &dyn Fn() -> bool,
) -> Result<Option<alloc::vec::Vec<SampleMetrics>>, TwipError> {
    let law = block::LqrLanes::new(controller);
    run_lane_samples(&law, reference, config, nominal, perturbations, seed, indices, should_stop)
}

/// Metrics of samples `indices` with any law on lanes ([`block::LaneLaw`]: LQR,
/// [`block::FuzzyLanes`]), blocks of [`lanes::LANES`]. `None` when `should_stop` said
/// so before all were done.
#[allow(clippy::too_many_arguments)]
pub fn run_lane_samples<C: block::LaneLaw<Shape = block::Slope> + Clone>(
    law: &C,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    nominal: &Nominal,
    perturbations: &[Perturbation],
    seed: u64,
    indices: core::ops::Range<u64>,
    should_stop: &dyn Fn() -> bool,
) -> Result<Option<alloc::vec::Vec<SampleMetrics>>, TwipError> {
    let mut out = alloc::vec::Vec::with_capacity((indices.end - indices.start) as usize);
    let mut start = indices.start;
    while start < indices.end {
        let end = (start + lanes::LANES as u64).min(indices.end);
        let samples: alloc::vec::Vec<Sample> = (start..end).map(|i| draw(nominal, perturbations, seed, i)).collect();
        let Some(block) = block::run_block(law.clone(), reference, config, &samples, should_stop)? else {
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
    use crate::control::fuzzy::FuzzyController;
    use crate::control::lqr::{design, DesignPoint, LqrController};
    use nalgebra::Matrix4;

    fn setup(slope: f64) -> (LqrController<f64>, SpeedSchedule<f64>, SimConfig<f64>, Nominal) {
        let params = RobotParams::balanbot();
        let model = SlopeModel::new(params, slope).unwrap();
        let q = Matrix4::from_diagonal(&Vector4::new(10.0, 10.0, 1.0, 1.0));
        let d = design(&model, 4.0, &q, 1000.0, DesignPoint::OperatingPoint).unwrap();
        let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 0.005).unwrap();
        let schedule = SpeedSchedule::new(&[crate::control::reference::Leg { goal: 20.0, speed: 4.0, hold: 1.0 }]).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 8.0, fall_limit: 0.6 };
        (ctrl, schedule, config, Nominal { params, slope, x0: Vector4::zeros() })
    }

    fn spread() -> [Perturbation; 3] {
        [
            Perturbation { target: Target::Param(8), spread: Spread::Uniform { low: 0.02, high: 0.09 } },
            Perturbation { target: Target::Param(0), spread: Spread::Normal { mean: 0.83, std: 0.8, low: -1.0, high: 2.0 } },
            Perturbation { target: Target::Initial(0), spread: Spread::Uniform { low: -0.7, high: 0.7 } },
        ]
    }

    /// Both families' laws on lanes, and their prototypes for the general runner.
    fn families(slope: f64) -> (block::LqrLanes, LqrController<f64>, block::FuzzyLanes, FuzzyController<f64>) {
        let (lqr, _, _, nominal) = setup(slope);
        let model = SlopeModel::new(nominal.params, slope).unwrap();
        let fuzzy = FuzzyController::thesis_slope(model, 0.005).unwrap();
        (block::LqrLanes::new(&lqr), lqr, block::FuzzyLanes::new(&fuzzy), fuzzy)
    }

    /// `fuzzy` with sets that are not all trapezoids: Gaussians beside a triangle for the
    /// pitch, Gaussians alone for its rate (their e^x is the lanes' polynomial on lanes).
    pub(crate) fn with_gaussians(fuzzy: &FuzzyController<f64>) -> FuzzyController<f64> {
        use crate::control::fuzzy_basis::{Membership, ThesisBasis};
        let g = |mean, sigma| Membership::gaussian(mean, sigma).unwrap();
        let sets = [[g(-0.3, 0.15), Membership::triangle(-0.3, 0.0, 0.3).unwrap(), g(0.3, 0.15)], [g(-1.5, 1.0), g(0.0, 1.0), g(1.5, 1.0)]];
        let basis = ThesisBasis::new(sets).unwrap();
        FuzzyController::new(*fuzzy.model(), fuzzy.gains(), fuzzy.adaptation(), basis, fuzzy.period()).unwrap()
    }

    /// `fuzzy` with an n × n grid of `kind` sets over φ ±0.3 rad and φ̇ ±2 rad/s (the
    /// sized law, not the 3 × 3 one).
    pub(crate) fn with_grid(fuzzy: &FuzzyController<f64>, kind: crate::control::fuzzy_grid::SetKind, n: usize) -> FuzzyController<f64> {
        use crate::control::fuzzy_grid::{FuzzyGrid, SetKind};
        let centres = |half: f64| (0..n).map(|j| -half + 2.0 * half * j as f64 / (n - 1) as f64).collect::<Vec<_>>();
        let (phi, rate) = (centres(0.3), centres(2.0));
        let widths = |w: f64| if kind == SetKind::Triangle { vec![] } else { vec![w; n] };
        let (w_phi, w_rate) = match kind {
            SetKind::Gaussian => (widths(0.3 / (n - 1) as f64), widths(2.0 / (n - 1) as f64)),
            _ => (widths(0.1 / (n - 1) as f64), widths(0.5 / (n - 1) as f64)),
        };
        let grid = FuzzyGrid::regular(kind, [&phi, &rate], [&w_phi, &w_rate]).unwrap();
        FuzzyController::new(*fuzzy.model(), fuzzy.gains(), fuzzy.adaptation(), grid, fuzzy.period()).unwrap()
    }

    /// The grids the lane tests add to the thesis's sets: 5 × 5 Gaussians, 5 × 5 trapezoids
    /// (the sized law's two kinds of sets), 7 × 7 triangles (the capacity).
    pub(crate) fn grids(fuzzy: &FuzzyController<f64>) -> [FuzzyController<f64>; 3] {
        use crate::control::fuzzy_grid::SetKind;
        [with_grid(fuzzy, SetKind::Gaussian, 5), with_grid(fuzzy, SetKind::Trapezoid, 5), with_grid(fuzzy, SetKind::Triangle, 7)]
    }

    /// A law's lanes agree with the general runner to rounding (they fuse multiply-adds),
    /// fallen and invalid samples included, and a block does not depend on its
    /// neighbours: a sample replayed alone gives the same bits.
    fn lanes_agree_with_the_runner<L, C>(law: &L, prototype: &C)
    where
        L: block::LaneLaw<Shape = block::Slope> + Clone,
        C: Controller<f64, 4, 1, Reference = SpeedRef<f64>> + Clone,
    {
        let (_, schedule, config, nominal) = setup(0.2);
        let spread = spread();
        let never = || false;
        let block = run_lane_samples(law, &schedule, &config, &nominal, &spread, 9, 0..20, &never).unwrap().unwrap();
        let (mut fell, mut invalid) = (0, 0);
        for (i, got) in block.iter().enumerate() {
            let sample = draw(&nominal, &spread, 9, i as u64);
            let expected = run_slope_sample(prototype, &schedule, &config, &sample, &never).unwrap();
            assert_eq!((got.valid, got.fell, got.steps), (expected.valid, expected.fell, expected.steps), "sample {i}");
            let pairs = [
                (got.t_end, expected.t_end),
                (got.mean_abs_pitch_error, expected.mean_abs_pitch_error),
                (got.mean_abs_speed_error, expected.mean_abs_speed_error),
                (got.final_position_error, expected.final_position_error),
                (got.peak_abs_input, expected.peak_abs_input),
                (got.peak_current, expected.peak_current),
                (got.peak_command, expected.peak_command),
                (got.saturation_share, expected.saturation_share),
            ];
            for (a, b) in pairs {
                let close = (a - b).abs() <= 1e-11 * b.abs().max(1e-6) || (a.is_nan() && b.is_nan());
                assert!(close, "sample {i}: lanes {a:e} vs runner {b:e}");
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
        assert!(fell > 0 && fell < 20, "the spread should make some robots fall ({fell})");
        assert!(invalid > 0, "a negative mass should be reported invalid");
        // Replayed alone, a sample sits in lane 0 of a block of its own: the first robot that
        // stood, fell and was refused, and the last (in the second, partial block). Each
        // replay is a whole block, so all 20 would be most of this test's time in debug.
        let first = |kind: &dyn Fn(&SampleMetrics) -> bool| block.iter().position(|m| kind(m)).unwrap();
        let replayed = [first(&|m| m.valid && !m.fell), first(&|m| m.fell), first(&|m| !m.valid), block.len() - 1];
        for i in replayed {
            let alone = run_lane_samples(law, &schedule, &config, &nominal, &spread, 9, i as u64..i as u64 + 1, &never)
                .unwrap()
                .unwrap();
            assert_eq!(format!("{:?}", alone[0]), format!("{:?}", block[i]), "sample {i} replayed alone");
        }
    }

    #[test]
    fn lane_kernel_agrees_with_the_general_runner() {
        let (lqr_lanes, lqr, fuzzy_lanes, fuzzy) = families(0.2);
        lanes_agree_with_the_runner(&lqr_lanes, &lqr);
        lanes_agree_with_the_runner(&fuzzy_lanes, &fuzzy);
        let gaussian = with_gaussians(&fuzzy);
        lanes_agree_with_the_runner(&block::FuzzyLanes::new(&gaussian), &gaussian);
        for grid in grids(&fuzzy) {
            lanes_agree_with_the_runner(&block::FuzzyLanes::new(&grid), &grid);
        }
    }

    /// Over 10 s a lane stays within 1e-12 of the run of its robot (relative; the worst
    /// is printed): the same source, rounded once instead of twice per multiply-add.
    fn within_rounding_over_ten_seconds<L, C>(law: &L, prototype: &C) -> f64
    where
        L: block::LaneLaw<Shape = block::Slope> + Clone,
        C: Controller<f64, 4, 1, Reference = SpeedRef<f64>> + Clone,
    {
        let (_, schedule, mut config, nominal) = setup(0.2);
        config.t_final = 10.0;
        let spread = [
            Perturbation { target: Target::Param(0), spread: Spread::Uniform { low: 0.6, high: 1.0 } },
            Perturbation { target: Target::Initial(0), spread: Spread::Uniform { low: -0.2, high: 0.2 } },
        ];
        let never = || false;
        let lanes = run_lane_samples(law, &schedule, &config, &nominal, &spread, 3, 0..16, &never).unwrap().unwrap();
        let mut worst: f64 = 0.0;
        for (i, got) in lanes.iter().enumerate() {
            let expected = run_slope_sample(prototype, &schedule, &config, &draw(&nominal, &spread, 3, i as u64), &never).unwrap();
            assert!(got.valid && !got.fell && !expected.fell, "sample {i} should stay up");
            for (a, b) in [
                (got.mean_abs_pitch_error, expected.mean_abs_pitch_error),
                (got.mean_abs_speed_error, expected.mean_abs_speed_error),
                (got.final_position_error, expected.final_position_error),
                (got.peak_abs_input, expected.peak_abs_input),
            ] {
                worst = worst.max((a - b).abs() / b.abs());
            }
        }
        worst
    }

    #[test]
    fn a_lane_agrees_with_the_runner_to_rounding_over_ten_seconds() {
        let (lqr_lanes, lqr, fuzzy_lanes, fuzzy) = families(0.2);
        let gaussian = with_gaussians(&fuzzy);
        let [g5, t5, tri7] = grids(&fuzzy);
        for (family, worst) in [
            ("lqr", within_rounding_over_ten_seconds(&lqr_lanes, &lqr)),
            ("fuzzy", within_rounding_over_ten_seconds(&fuzzy_lanes, &fuzzy)),
            ("fuzzy, Gaussian sets", within_rounding_over_ten_seconds(&block::FuzzyLanes::new(&gaussian), &gaussian)),
            ("fuzzy, 5 x 5 Gaussians", within_rounding_over_ten_seconds(&block::FuzzyLanes::new(&g5), &g5)),
            ("fuzzy, 5 x 5 trapezoids", within_rounding_over_ten_seconds(&block::FuzzyLanes::new(&t5), &t5)),
            ("fuzzy, 7 x 7 triangles", within_rounding_over_ten_seconds(&block::FuzzyLanes::new(&tri7), &tri7)),
        ] {
            println!("{family}: worst relative difference over 10 s: {worst:e}");
            assert!(worst <= 1e-12, "{family}: worst relative difference {worst:e}");
        }
    }

    /// A run that fell or diverged never settled: both settling times are its end, on lanes
    /// and in the runner alike. Before, a diverged run's (whose last state is not finite
    /// and not observed) read as settled at 0 when it blew up at the first step.
    #[test]
    fn a_run_that_falls_or_diverges_never_settled() {
        let (lqr, schedule, config, nominal) = setup(0.0);
        let never = || false;
        // Gains that overflow the input: the state is not finite after the first step.
        let wild = LqrController::new(lqr.gains().map(|g| g * 1e306), *lqr.model(), DesignPoint::OperatingPoint, 0.005).unwrap();
        let tilted = Nominal { x0: Vector4::new(0.1, 0.0, 0.0, 0.0), ..nominal };
        let run = simulate_until(lqr.model(), &mut wild.clone(), &schedule, &tilted.x0, &config, &mut (), &never);
        assert!(matches!(run, Ok((Outcome::Diverged { .. }, 1))), "{run:?}");
        for (name, got) in [
            ("lanes", run_lqr_samples(&wild, &schedule, &config, &tilted, &[], 1, 0..1, &never).unwrap().unwrap()[0]),
            ("runner", run_slope_sample(&wild, &schedule, &config, &draw(&tilted, &[], 1, 0), &never).unwrap()),
        ] {
            assert!(got.fell && got.t_end == config.dt, "{name}: {got:?}");
            assert_eq!((got.pitch_settling_time, got.speed_settling_time), (got.t_end, got.t_end), "{name}");
        }
        // Robots that fall: the same, lane and runner.
        let lanes = run_lqr_samples(&lqr, &schedule, &config, &nominal, &spread(), 7, 0..64, &never).unwrap().unwrap();
        let mut fell = 0;
        for (i, got) in lanes.iter().enumerate().filter(|(_, m)| m.valid && m.fell) {
            let expected = run_slope_sample(&lqr, &schedule, &config, &draw(&nominal, &spread(), 7, i as u64), &never).unwrap();
            for m in [got, &expected] {
                assert_eq!((m.pitch_settling_time, m.speed_settling_time), (m.t_end, m.t_end), "sample {i}");
            }
            fell += 1;
        }
        assert!(fell > 0, "the spread should make some robots fall");
    }

    #[test]
    fn bad_spreads_are_named() {
        let p = Perturbation { target: Target::Slope, spread: Spread::Uniform { low: 1.0, high: 0.0 } };
        assert!(matches!(p.validate(), Err(TwipError::InvalidParameter { name: "high", .. })));
        let p = Perturbation { target: Target::Slope, spread: Spread::Normal { mean: 0.0, std: -1.0, low: -1.0, high: 1.0 } };
        assert!(matches!(p.validate(), Err(TwipError::InvalidParameter { name: "std", .. })));
        // Finite, but the draws would overflow to inf.
        let p = Perturbation { target: Target::Slope, spread: Spread::Uniform { low: -1e308, high: 1e308 } };
        assert!(matches!(p.validate(), Err(TwipError::InvalidParameter { name: "high", .. })));
        let p = Perturbation { target: Target::Slope, spread: Spread::Normal { mean: 0.0, std: 1e308, low: -1.0, high: 1.0 } };
        assert!(matches!(p.validate(), Err(TwipError::InvalidParameter { name: "std", .. })));
    }

    #[test]
    fn the_normal_reach_is_the_largest_draw() {
        use nalgebra::ComplexField;
        // The smallest 1 - U the generator gives is 2^-53.
        let reach = ComplexField::sqrt(-2.0 * ComplexField::ln(1.0 / (1u64 << 53) as f64));
        assert!((NORMAL_REACH - reach).abs() < 1e-14, "{reach}");
    }
}
