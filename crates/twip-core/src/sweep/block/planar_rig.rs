//! The fast path of a 3-DOF tracking sweep through the realism rig: [`LANES`] samples at
//! once through the planar rig (`Realism::build_planar`), for the trackers with a law on
//! lanes ([`LaneLaw`] of the [`Planar`] shape: PID, sliding mode).
//!
//! The loop is the one closed loop (`sim::closed_loop`: the ideal lanes' and the runner's), with
//! the rig's lanes as its plant ([`PlanarRigPlant`] on [`PlanarRigLanes`], which step the
//! rig's parts and the plant) and the ideal 3-DOF lanes' metrics (`Tracking`) as its
//! observer. So a lane
//! agrees with `sweep::planar::run_planar_sample` to rounding, and is bit for bit the same
//! on every CPU, thread count and block neighbour.
use super::closed_loop::{closed_loop, Plant};
use super::law::{update_out_of_line, LaneLaw, Planar};
use super::planar::{BlockGround, LanePath, Tracking};
use super::planar_rig_lanes::PlanarRigLanes;
use super::planar_terrain::{FeedForwardLanes, TerrainLanes};
use super::rig::block_rigs;
use super::multiversioned;
use crate::control::trajectory::PlanarRef;
use crate::model::dynamics::Halt;
use crate::model::planar::PlanarModel;
use crate::model::terrain::Terrain;
use crate::sim::runner::SimConfig;
use crate::sweep::lanes::{Lanes, LANES};
use crate::sweep::planar::{PlanarSample, PlanarSampleMetrics};
use crate::sweep::rig::RealismOf;
use crate::sweep::SweepMetrics;
use crate::TwipError;
use alloc::vec::Vec;

type BlockResult = Result<Option<[PlanarSampleMetrics; LANES]>, TwipError>;

/// A block's terrains, one per sample (None: one no draw should give), and the tracker's
/// grade feed-forward, if any.
pub type BlockTerrain<'a> = Option<(&'a [Option<Terrain<f64>>], Option<FeedForwardLanes>)>;

multiversioned! {
    /// Runs up to [`LANES`] samples through the 3-DOF rig each one's realism builds for
    /// its robot (`realism_of`; noise stream = the sample's index; see
    /// `sweep::rig::for_sweep` for the key), with `controller`'s law along `path`
    /// ("_settled" metrics from `settle` [s]). `should_stop` is asked every
    /// `runner::STOP_CHECK_STEPS` steps; `Ok(None)` means it said yes before the block was done.
    /// On `terrain` (None: flat ground): each sample's terrain (None: one no draw should give;
    /// the lane is invalid, as when its start is off its terrain) and the tracker's grade
    /// feed-forward, if any: each rig built on its sample's terrain
    /// (`Realism::build_planar_on`), the lanes' plants, IMUs and "lifted"/"off_terrain" ends
    /// as the ideal lanes' on terrain ([`TerrainLanes`]). A runtime choice inside the flat
    /// kernel's instances: the flat rig keeps its code and its bits.
    pub fn run_planar_rig_block, planar_rig_avx512, planar_rig_avx2, planar_rig_baseline = planar_rig_block<C: LaneLaw<Shape = Planar>, P: LanePath; const COPY>(
        controller: C,
        path: &P,
        config: &SimConfig<f64>,
        samples: &[PlanarSample],
        settle: f64,
        realism_of: RealismOf<'_>,
        should_stop: &dyn Fn() -> bool,
        terrain: BlockTerrain<'_>,
    ) -> BlockResult
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn planar_rig_block<C: LaneLaw<Shape = Planar>, P: LanePath, const COPY: u8>(
    mut controller: C,
    path: &P,
    config: &SimConfig<f64>,
    samples: &[PlanarSample],
    settle: f64,
    realism_of: RealismOf<'_>,
    should_stop: &dyn Fn() -> bool,
    terrain: BlockTerrain<'_>,
) -> BlockResult {
    assert!(samples.len() <= LANES, "a block holds at most {LANES} samples");
    let (n, per_update) = config.steps(controller.period())?;
    let dt = config.dt;
    let ground = terrain.map(|(terrains, feed)| TerrainLanes::new(samples, terrains, feed));
    let samples_models = samples.iter().enumerate().map(|(l, s)| {
        let valid = s.x0.iter().all(|v| v.is_finite()) && ground.as_ref().is_none_or(|g| g.valid(l));
        let model = valid.then(|| PlanarModel::new(s.params).ok()).flatten();
        (s.index, s.params, model.map(|m| (m, terrain.and_then(|(t, _)| t[l].as_ref()))))
    });
    let built = block_rigs(samples_models, realism_of, |realism, (model, on)| realism.build_planar_on(model, *on, dt))?;
    let built: Vec<_> = built.into_iter().map(|b| b.map(|((model, _), rig)| (model, rig))).collect();
    let active: [bool; LANES] = core::array::from_fn(|l| built.get(l).is_some_and(Option::is_some));
    let x0 = core::array::from_fn(|l| if active[l] { samples[l].x0.into() } else { [0.0; 7] });
    let Some(mut rig) = PlanarRigLanes::start(built, x0, dt, dt * per_update as f64, ground.clone())? else {
        return Ok(Some([PlanarSampleMetrics::INVALID; LANES]));
    };
    let models = rig.models;
    let mut observer = Tracking::new(&models, path, settle);
    observer.metrics.efficiency = rig.context.efficiencies();
    let plant = PlanarRigPlant { rig: &mut rig, feed: ground.as_ref() };
    Ok(closed_loop::<C, _, _, 7, COPY>(&mut controller, plant, observer, active, (n, per_update), config, should_stop))
}

/// The 3-DOF rig's lanes as the closed loop's plant, as the 2-DOF rig's (`rig::RigPlant`):
/// on terrain, the tracker fed forward from what the firmware reads (`feed`, as a run's
/// `GradeFeedForward`) and the lanes halted as the rig's `halted` ends a run.
struct PlanarRigPlant<'a> {
    rig: &'a mut PlanarRigLanes,
    feed: Option<&'a TerrainLanes>,
}

impl Plant for PlanarRigPlant<'_> {
    type Shape = Planar;

    #[inline(always)]
    fn state(&self) -> &[Lanes; 7] {
        &self.rig.context.x
    }

    #[inline(always)]
    fn state_mut(&mut self) -> &mut [Lanes; 7] {
        &mut self.rig.context.x
    }

    /// The law out of line (`update_out_of_line`), as the 2-DOF rig's.
    #[inline(always)]
    fn update<C: LaneLaw<Shape = Planar>, const COPY: u8>(&mut self, controller: &mut C, state: &mut C::State, t: f64, r: &PlanarRef<f64>, u: &mut [Lanes; 2]) {
        let y = self.rig.read(t);
        match self.feed {
            None => update_out_of_line::<C, COPY>(controller, state, y, r, u),
            Some(g) => g.update::<C, COPY>(controller, state, y, r, u),
        }
    }

    #[inline(always)]
    fn apply(&mut self, t: f64, u: &[Lanes; 2]) -> [bool; LANES] {
        self.rig.context.apply(t, u)
    }

    #[inline(always)]
    fn command<'s>(&'s self, _: &'s [Lanes; 2]) -> &'s [Lanes; 2] {
        self.rig.context.command()
    }

    #[inline(always)]
    fn step<const COPY: u8>(&mut self, k: usize, _: &[Lanes; 2], _: f64, drive: impl FnOnce(&[Lanes; 2], &[bool; LANES]), next: &mut [Lanes; 7]) {
        let delivered = self.rig.step::<COPY>(k, next);
        drive(&delivered, self.rig.context.beyond());
    }

    #[inline(always)]
    fn halts<const COPY: u8>(&self, next: &[Lanes; 7], _: &[Lanes; 2]) -> Option<[Option<Halt>; LANES]> {
        self.rig.halts::<COPY>(next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::pid::PidTracker;
    use crate::control::trajectory::{Circle, Direction};
    use crate::hardware::disturbance::Force;
    use crate::hardware::motor::DcMotor;
    use crate::hardware::realism::Realism;
    use crate::model::friction::Friction;
    use crate::model::planar::PlanarState;
    use crate::sweep::block::PidLanes;
    use crate::RobotParams;
    use alloc::format;
    use alloc::vec::Vec;

    /// Every compiled copy of the kernel gives the same bits (the baseline one through
    /// libm's fma), for the thesis-like rig with and without backlash, with a constant
    /// force, with slip friction and with windings without inductance; both outcomes.
    #[test]
    fn every_copy_gives_the_same_bits() {
        let nominal = RobotParams::balanbot();
        let law = PidLanes::new(&PidTracker::table_4_1(&nominal, DcMotor::gb37y3530(), 0.005).unwrap());
        let force = Force { horizontal: 0.3, vertical: -0.5, height: 0.05 };
        let thesis = Realism::thesis_like();
        let no_inductance = crate::hardware::driver::MotorDriver { inductance: 0.0, ..thesis.motor.unwrap() };
        let kinds = [
            thesis,
            Realism { backlash: None, ..thesis },
            Realism { force, ..thesis },
            Realism { friction: Some(Friction::gb37()), ..thesis },
            Realism { motor: Some(no_inductance), ..thesis },
        ];
        for realism in kinds {
            same_bits_on_every_copy(&law, &realism);
        }
    }

    fn same_bits_on_every_copy(law: &PidLanes, realism: &Realism<f64>) {
        same_bits_on_every_copy_on(law, realism, |_| None, "fell: true");
    }

    /// [`same_bits_on_every_copy`] on the terrains and feed-forward `ground_of` gives the
    /// block's samples (which it may change), some ending as `ending` says.
    #[allow(clippy::type_complexity)]
    fn same_bits_on_every_copy_on(
        law: &PidLanes,
        realism: &Realism<f64>,
        ground_of: impl Fn(&mut [PlanarSample]) -> Option<(Vec<Option<Terrain<f64>>>, Option<FeedForwardLanes>)>,
        ending: &str,
    ) {
        let (circle, config, mut samples) = block();
        let realism = crate::sweep::rig::for_sweep(realism, 5);
        let ground = ground_of(&mut samples);
        let ground = ground.as_ref().map(|(t, feed)| (t.as_slice(), *feed));
        let never = || false;
        let realism_of = |_: &RobotParams<f64>| Ok(realism);
        let base = format!("{:?}", planar_rig_baseline(law.clone(), &circle, &config, &samples, 1.0, &realism_of, &never, ground).unwrap());
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { planar_rig_avx2(law.clone(), &circle, &config, &samples, 1.0, &realism_of, &never, ground) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX2 copy");
            }
            if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { planar_rig_avx512(law.clone(), &circle, &config, &samples, 1.0, &realism_of, &never, ground) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX-512 copy");
            }
        }
        assert!(base.contains(ending) && base.contains("fell: false"), "want both outcomes: {base}");
    }

    /// A block's path, run and robots: the circle for 2 s, each lane's robot with its centre
    /// of mass higher and its start tilted further than the last (some fall, some do not).
    fn block() -> (Circle<f64>, SimConfig<f64>, Vec<PlanarSample>) {
        let circle = Circle::from_origin(0.6, 0.2, Direction::CounterClockwise).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 2.0, fall_limit: 0.5 };
        let samples = (0..LANES as u64)
            .map(|i| {
                let mut params = RobotParams::balanbot();
                params.com_height *= 0.6 + 0.05 * i as f64;
                let mut x0 = PlanarState::zeros();
                x0[3] = 0.04 * i as f64;
                PlanarSample { index: i, params, x0 }
            })
            .collect();
        (circle, config, samples)
    }

    /// On flat ground the lanes work out the wheels' speeds for the gear play and the
    /// encoders side by side, and skip the play's step where its trains stay engaged; on
    /// terrain each lane's rig does it all: on level planes (any uphill heading) the two give
    /// the same bits, for the thesis-like rig with and without play, pushed and without
    /// inductance, on the widest copy this CPU runs.
    #[test]
    fn flat_ground_is_level_terrain_bit_for_bit() {
        use crate::hardware::disturbance::Push;
        let nominal = RobotParams::balanbot();
        let law = PidLanes::new(&PidTracker::table_4_1(&nominal, DcMotor::gb37y3530(), 0.005).unwrap());
        let (circle, config, samples) = block();
        let level: Vec<_> = (0..LANES).map(|i| Terrain::plane(0.0, 0.7 * i as f64).ok()).collect();
        let thesis = Realism::thesis_like();
        let no_inductance = crate::hardware::driver::MotorDriver { inductance: 0.0, ..thesis.motor.unwrap() };
        let pushed = Realism { pushes: crate::hardware::disturbance::Pushes::new(&[Push { t: 0.3, impulse: 0.02, height: 0.1 }]).unwrap(), ..thesis };
        let never = || false;
        for realism in [thesis, Realism { backlash: None, ..thesis }, Realism { motor: Some(no_inductance), ..thesis }, pushed] {
            let realism = crate::sweep::rig::for_sweep(&realism, 5);
            let realism_of = |_: &RobotParams<f64>| Ok(realism);
            let run = |ground| format!("{:?}", run_planar_rig_block(law.clone(), &circle, &config, &samples, 1.0, &realism_of, &never, ground).unwrap());
            let flat = run(None);
            assert_eq!(flat, run(Some((level.as_slice(), None))), "{realism:?}");
            assert!(flat.contains("fell: false"), "{flat}");
        }
    }

    /// On terrain too (each lane its own plane, the grade fed forward, half the lanes across
    /// steep planes turning hard; bumps; a grid some leave), for the thesis-like rig with and
    /// without backlash and with windings without inductance: every copy the same bits, lanes
    /// lifting and leaving the grid among them.
    #[test]
    fn every_copy_gives_the_same_bits_on_terrain() {
        use crate::control::grade::GradeFeedForward;
        use crate::model::terrain_model::TerrainModel;
        let nominal = RobotParams::balanbot();
        let motor = DcMotor::gb37y3530();
        let pid = PidTracker::table_4_1(&nominal, motor, 0.005).unwrap();
        let law = PidLanes::new(&pid);
        let flat = TerrainModel::new(PlanarModel::new(nominal).unwrap(), Terrain::flat());
        let feed = FeedForwardLanes::new(&GradeFeedForward::new(pid, flat, Some(motor)));
        let planes = |samples: &mut [PlanarSample]| {
            let terrains: Vec<_> = (0..samples.len()).map(|i| Terrain::plane(0.04 * i as f64, 0.7 * i as f64).ok()).collect();
            for (i, s) in samples.iter_mut().enumerate().filter(|(i, _)| i % 2 == 1) {
                (s.x0[2], s.x0[5], s.x0[6]) = (0.7 * i as f64 + core::f64::consts::FRAC_PI_2, 1.5, -8.0);
            }
            Some((terrains, Some(feed)))
        };
        let thesis = Realism::thesis_like();
        let no_inductance = crate::hardware::driver::MotorDriver { inductance: 0.0, ..thesis.motor.unwrap() };
        for realism in [thesis, Realism { backlash: None, ..thesis }, Realism { motor: Some(no_inductance), ..thesis }] {
            same_bits_on_every_copy_on(&law, &realism, planes, "lifted: 1.0");
        }
        let bumps = |samples: &mut [PlanarSample]| Some((alloc::vec![Terrain::bumps(0.03, 0.4).ok(); samples.len()], None));
        same_bits_on_every_copy_on(&law, &thesis, bumps, "fell: true");
        // A grid around the start, which the circle leaves.
        let xs: Vec<f64> = (0..6).map(|i| -0.3 + 0.1 * i as f64).collect();
        let z: Vec<f64> = xs.iter().flat_map(|x| xs.iter().map(move |y| 0.02 * (5.0 * x).sin() * (4.0 * y).cos())).collect();
        let grid = Terrain::Grid(alloc::sync::Arc::new(crate::model::terrain::Grid::new(xs.clone(), xs, &z).unwrap()));
        let off = |samples: &mut [PlanarSample]| Some((alloc::vec![Some(grid.clone()); samples.len()], Some(feed)));
        same_bits_on_every_copy_on(&law, &thesis, off, "off_terrain: 1.0");
    }
}
