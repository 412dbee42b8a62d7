//! The fast path of a realism sweep: [`LANES`] samples at once through the 2-DOF rig, for
//! every law on lanes ([`LaneLaw`] of the [`Slope`] shape) and every realism: the slope model with its gearhead
//! friction, backlash, a constant force and slope changes along the path (each lane picks
//! its piece of the ground at every stage), pushes (each lane's rig's, between steps).
//!
//! The loop is the one closed loop (`sim::closed_loop`: the ideal lanes' and the runner's), with
//! the rig's lanes as its plant ([`RigPlant`] on [`RigLanes`], which step the rig's parts and
//! the plant on `Fused` lanes; noise stream = sample index) and the ideal 2-DOF lanes'
//! metrics ([`SlopeLanes`]) as its observer. So a lane
//! agrees with `sweep::rig::run_rig_sample` to rounding, and is bit for bit the same on
//! every CPU, thread count and block neighbour.
use super::closed_loop::{closed_loop, Plant};
use super::rig_lanes::RigLanes;
use super::law::update_out_of_line;
use super::{multiversioned, BlockResult, LaneLaw, Slope, SlopeLanes};
use crate::control::reference::{SpeedRef, SpeedSchedule};
use crate::model::dynamics::Halt;
use crate::hardware::disturbance::{Force, Pushes};
use crate::hardware::realism::Realism;
use crate::model::slope::SlopeModel;
use crate::sim::runner::SimConfig;
use crate::sweep::lanes::{Lanes, LANES};
use crate::sweep::rig::RealismOf;
use crate::sweep::{Sample, SampleMetrics, SweepMetrics};
use crate::{RobotParams, TwipError};
use alloc::vec::Vec;

/// Each of a block's samples' model and rig, the rig built by `build` from the realism
/// its robot gets (`realism_of`, with the noise stream = the sample's index), from
/// `samples`' (index, robot, model: None when the sample is invalid). None where the
/// sample is invalid, its realism an error or its robot cannot have the rig: an idle lane.
/// The lanes share the first rig's kinds (friction, drive, play, delay): only where pushes
/// and a force act may differ between robots, else the block is an error. On the heap: 16
/// rigs are ~100 KB, which a worker thread's stack need not hold.
pub(super) fn block_rigs<M, R>(
    samples: impl Iterator<Item = (u64, RobotParams<f64>, Option<M>)>,
    realism_of: RealismOf<'_>,
    build: impl Fn(&Realism<f64>, &M) -> Result<R, TwipError>,
) -> Result<Vec<Option<(M, R)>>, TwipError> {
    let parts = |r: &Realism<f64>| Realism { pushes: Pushes::none(), force: Force::none(), ..*r };
    let mut shared: Option<Realism<f64>> = None;
    let mut built = Vec::with_capacity(LANES);
    for (index, params, model) in samples {
        let Some(model) = model else {
            built.push(None);
            continue;
        };
        let Ok(realism) = realism_of(&params) else {
            built.push(None);
            continue;
        };
        if *shared.get_or_insert(parts(&realism)) != parts(&realism) {
            let reason = "gave the robot of the sample with this index other rig parts than its block's: only pushes and a force may differ";
            return Err(TwipError::InvalidParameter { name: "realism_of", value: index as f64, reason });
        }
        built.push(build(&realism.with_stream(index), &model).ok().map(|rig| (model, rig)));
    }
    Ok(built)
}

multiversioned! {
    /// Runs up to [`LANES`] samples through the rig each one's realism builds for its
    /// robot (`realism_of`; noise stream = the sample's index; see `sweep::rig::for_sweep`
    /// for the key), with `controller`'s law. `should_stop` is asked every
    /// `runner::STOP_CHECK_STEPS` steps; `Ok(None)` means it said yes before the block was done.
    pub fn run_rig_block, rig_block_avx512, rig_block_avx2, rig_block_baseline = rig_block<C: LaneLaw<Shape = Slope>; const COPY>(
        controller: C,
        reference: &SpeedSchedule<f64>,
        config: &SimConfig<f64>,
        samples: &[Sample],
        realism_of: RealismOf<'_>,
        should_stop: &dyn Fn() -> bool,
    ) -> BlockResult
}

#[inline(always)]
fn rig_block<C: LaneLaw<Shape = Slope>, const COPY: u8>(
    mut controller: C,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    samples: &[Sample],
    realism_of: RealismOf<'_>,
    should_stop: &dyn Fn() -> bool,
) -> BlockResult {
    assert!(samples.len() <= LANES, "a block holds at most {LANES} samples");
    let (n, per_update) = config.steps(controller.period())?;
    let dt = config.dt;
    let samples_models = samples.iter().map(|s| {
        let model = s.x0.iter().all(|v| v.is_finite()).then(|| SlopeModel::new(s.params, s.slope).ok()).flatten();
        (s.index, s.params, model)
    });
    let built = block_rigs(samples_models, realism_of, |realism, model| realism.build(model, dt))?;
    let active: [bool; LANES] = core::array::from_fn(|l| built.get(l).is_some_and(Option::is_some));
    let x0 = core::array::from_fn(|l| if active[l] { samples[l].x0.into() } else { [0.0; 4] });
    let Some(mut rig) = RigLanes::start(built, x0, dt, dt * per_update as f64)? else {
        return Ok(Some([SampleMetrics::INVALID; LANES]));
    };
    let models = rig.models;
    let (mut plant_phi_s, mut metrics) = SlopeLanes::metrics(&models, reference, &rig.context.x);
    metrics.efficiency = rig.context.efficiencies();
    let observer = SlopeLanes::new(&models, &mut metrics, &mut plant_phi_s, reference);
    Ok(closed_loop::<C, _, _, 4, COPY>(&mut controller, RigPlant(&mut rig), observer, active, (n, per_update), config, should_stop))
}

/// The 2-DOF rig's lanes as the closed loop's plant: the law reads the sensors and its
/// command goes through each lane's actuator (`RigLanes`, which keeps the state and all that
/// carries over between steps), the metrics observe the command the plants get and what the
/// drivers deliver.
struct RigPlant<'a>(&'a mut RigLanes);

impl Plant for RigPlant<'_> {
    type Shape = Slope;

    #[inline(always)]
    fn state(&self) -> &[Lanes; 4] {
        &self.0.context.x
    }

    #[inline(always)]
    fn state_mut(&mut self) -> &mut [Lanes; 4] {
        &mut self.0.context.x
    }

    /// The law out of line (once per law and copy): it runs once per control period here,
    /// and inlined it grew this kernel's optimiser time.
    #[inline(always)]
    fn update<C: LaneLaw<Shape = Slope>, const COPY: u8>(&mut self, controller: &mut C, state: &mut C::State, t: f64, r: &SpeedRef<f64>, u: &mut Lanes) {
        update_out_of_line::<C, COPY>(controller, state, self.0.read(t), r, u);
    }

    #[inline(always)]
    fn apply(&mut self, t: f64, u: &Lanes) -> [bool; LANES] {
        self.0.context.apply(t, u)
    }

    #[inline(always)]
    fn command<'s>(&'s self, _: &'s Lanes) -> &'s Lanes {
        self.0.context.command()
    }

    #[inline(always)]
    fn step<const COPY: u8>(&mut self, k: usize, _: &Lanes, _: f64, drive: impl FnOnce(&Lanes, &[bool; LANES]), next: &mut [Lanes; 4]) {
        let delivered = self.0.step::<COPY>(k, next);
        drive(&delivered, self.0.context.beyond());
    }

    #[inline(always)]
    fn halts<const COPY: u8>(&self, _: &[Lanes; 4], _: &Lanes) -> Option<[Option<Halt>; LANES]> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::lqr::{design, DesignPoint, LqrController};
    use crate::model::params::RobotParams;
    use crate::sweep::block::LqrLanes;
    use alloc::format;
    use alloc::vec::Vec;
    use nalgebra::{Matrix4, Vector4};

    /// Every compiled copy of the rig's kernel gives the same bits (the baseline one
    /// through libm's fma), for the thesis-like rig with and without backlash, with a
    /// constant force, with slope changes and with slip friction, both outcomes.
    #[test]
    fn every_copy_gives_the_same_bits() {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
        let q = Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
        let d = design(&model, 3.0, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
        let law = LqrLanes::new(&LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 5e-3).unwrap());
        let force = crate::hardware::disturbance::Force { horizontal: 0.1, vertical: -0.5, height: 0.05 };
        let slopes = |changes: &[(f64, f64)]| crate::hardware::disturbance::SlopeProfile::new(0.05, changes).unwrap();
        // Two changes take the loops for a few (`FEW_CHANGES`), three those for all.
        let (ramp, hills) = (slopes(&[(0.02, 0.08), (0.08, 0.0)]), slopes(&[(0.02, 0.08), (0.08, 0.0), (0.15, -0.02)]));
        let kinds = [
            Realism::thesis_like(),
            Realism { backlash: None, ..Realism::thesis_like() },
            Realism { force, ..Realism::thesis_like() },
            Realism { slope_profile: ramp, ..Realism::thesis_like() },
            Realism { slope_profile: hills, ..Realism::thesis_like() },
            // The slip law alone: its tanh on lanes is `math::tanh_fused`.
            Realism { friction: Some(crate::model::friction::Friction::gb37()), ..Realism::thesis_like() },
        ];
        for realism in kinds {
            same_bits_on_every_copy(&law, &realism);
        }
    }

    fn same_bits_on_every_copy(law: &LqrLanes, realism: &Realism<f64>) {
        let schedule = SpeedSchedule::constant(3.0).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 2.0, fall_limit: 0.6 };
        let realism = crate::sweep::rig::for_sweep(realism, 5);
        let samples: Vec<Sample> = (0..LANES as u64)
            .map(|i| {
                let mut params = RobotParams::balanbot();
                params.com_height *= 0.6 + 0.05 * i as f64;
                Sample { index: i, params, slope: 0.05, x0: Vector4::new(0.03 * i as f64, 0.0, 0.0, 0.0) }
            })
            .collect();
        let never = || false;
        let realism_of = |_: &RobotParams<f64>| Ok(realism);
        let base = format!("{:?}", rig_block_baseline(law.clone(), &schedule, &config, &samples, &realism_of, &never).unwrap());
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { rig_block_avx2(law.clone(), &schedule, &config, &samples, &realism_of, &never) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX2 copy");
            }
            if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { rig_block_avx512(law.clone(), &schedule, &config, &samples, &realism_of, &never) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX-512 copy");
            }
        }
        assert!(base.contains("fell: true") && base.contains("fell: false"), "want both outcomes: {base}");
    }
}
