//! Sweep samples run through the realism rig (sensors, estimator, motor driver, delay,
//! disturbances) instead of the ideal loop.
//!
//! Noise keys: sample `i` of a sweep with seed `s` draws its sensor noise from the
//! Philox stream `(noise_seed(s), i)`. The realism's own `seed` and `stream` are
//! replaced, so a sample is reproducible from (sweep seed, index) alone and two sweep
//! seeds give different noise. `noise_seed` is a bijection that moves the key away from
//! `s` itself, so the noise is not the very stream the perturbations were drawn from.
use super::{finish, fresh, Sample, SampleMetrics, SweepMetrics};
use crate::control::Controller;
use crate::sim::metrics::SlopeMetrics;
use crate::hardware::realism::Realism;
use crate::control::reference::{SpeedRef, SpeedSchedule};
use crate::sim::runner::SimConfig;
use crate::model::slope::SlopeModel;

/// The sensor-noise key of a sweep with seed `sweep_seed` (splitmix64's finaliser of
/// the seed xor a constant: one-to-one, and never the perturbation key in practice).
pub fn noise_seed(sweep_seed: u64) -> u64 {
    let mut z = sweep_seed ^ 0x6e6f_6973_6520_6b65; // "noise ke"
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::lqr::{design, DesignPoint, LqrController};
    use crate::model::params::RobotParams;
    use crate::sweep::{draw, run_slope_sample, Nominal, Perturbation, Spread, Target};
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
