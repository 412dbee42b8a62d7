//! `twip/Balance-v0`'s robots: N 2-DOF robots (slope model) advanced one control period
//! per step, on the ideal plant or through each robot's own rig.
//!
//! - Ideal plant: the sweep's lanes ([`Plants::rk4`], [`LANES`] robots a block, one block
//!   per task), so a lane agrees with `runner::simulate` to rounding and is bit for bit the
//!   same on every CPU copy, thread count and block neighbour. The observation is the state.
//! - Rig: each robot's [`SlopeRig`] (`Realism::build`: the very plant, sensors and delay a
//!   run uses) on the rig sweep's lanes ([`RigLanes`], each lane at its own step), stepped
//!   as `runner::run_loop` steps a rig between two controller updates, so a robot agrees
//!   with `twip.simulate` through that rig to rounding (the lanes fuse multiply-adds) and
//!   is bit for bit the same on every CPU copy, thread count and block neighbour. The
//!   action is the plant's input (the PWM duty with a motor driver, rounded and saturated
//!   as the firmware writes it; else the lumped current); the observation the sensors' reading.
use alloc::vec::Vec;

use nalgebra::Vector4;

use super::batch::{Drawn, EnvKind, Envs, RealismFor};
use super::robot::{LanePlant, Period, RigBlock};
use crate::hardware::realism::{Realism, SlopeRig};
use crate::model::slope::SlopeModel;
use crate::sweep::block::{Plants, RigLanes};
use crate::sweep::lanes::{Lanes, LANES};
use crate::sweep::{draw, Nominal, Perturbation};
use crate::TwipError;

/// What every robot of a batch shares.
#[derive(Clone)]
pub struct BalanceSpec {
    /// The nominal robot, slope and initial state the draws perturb.
    pub nominal: Nominal,
    /// Drawn per episode, in order, from `Philox::new(seed, episode)` (`sweep::draw`).
    pub perturbations: Vec<Perturbation>,
    /// None: the ideal plant.
    pub realism: Option<RealismFor>,
    /// The plant step [s].
    pub dt: f64,
    /// Plant steps per control period (env step).
    pub substeps: usize,
    /// |φ| beyond which a robot has fallen [rad].
    pub fall_limit: f64,
}

impl LanePlant for Plants {
    type State = [Lanes; 4];
    type Input = [Lanes; 1];
    const PITCH: usize = 0;

    #[inline(always)]
    fn rk4_lanes(&self, x: &[Lanes; 4], u: &[Lanes; 1], dt: f64, live: &[bool; LANES], next: &mut [Lanes; 4]) {
        self.rk4_unreduced_into(x, &self.pitch_sin_cos(x), &u[0], dt, live, next, #[inline(always)] |next| *next = self.rk4(x, &u[0], dt));
    }
}

impl EnvKind<4, 1> for BalanceSpec {
    type Model = SlopeModel<f64>;
    type Plants = Plants;
    type RigLanes = RigLanes;

    fn period(&self) -> Period {
        Period { dt: self.dt, substeps: self.substeps, pitch: 0, fall_limit: self.fall_limit }
    }

    fn realism(&self) -> Option<&RealismFor> {
        self.realism.as_ref()
    }

    fn validate(&self) -> Result<(), TwipError> {
        for p in &self.perturbations {
            p.validate()?;
        }
        self.nominal().map(|_| ())
    }

    fn nominal(&self) -> Result<SlopeModel<f64>, TwipError> {
        SlopeModel::new(self.nominal.params, self.nominal.slope)
    }

    fn draw(&self, key: (u64, u64)) -> Result<Drawn<SlopeModel<f64>, 4>, TwipError> {
        let sample = draw(&self.nominal, &self.perturbations, key.0, key.1);
        Ok(Drawn { params: sample.params, model: SlopeModel::new(sample.params, sample.slope)?, x0: sample.x0 })
    }

    fn plants(models: &[SlopeModel<f64>; LANES]) -> Plants {
        Plants::new(&models.map(|m| m.coefficients()))
    }

    fn set_plant(plants: &mut Plants, l: usize, model: &SlopeModel<f64>) {
        plants.set_lane(l, &model.coefficients());
    }

    /// Balance-v0's observation depends on nothing but the robot.
    type AtTime = ();
    fn at_time(&self, _: f64) {}

    fn rig(realism: &Realism<f64>, model: &SlopeModel<f64>, dt: f64) -> Result<SlopeRig<f64>, TwipError> {
        realism.build(model, dt)
    }
}

impl RigBlock for RigLanes {
    type Model = SlopeModel<f64>;
    type Rig = SlopeRig<f64>;
    type State = [Lanes; 4];
    type State1 = [f64; 4];
    type Drive = [Lanes; 1];

    fn start(built: Vec<Option<(SlopeModel<f64>, SlopeRig<f64>)>>, x0: [[f64; 4]; LANES], dt: f64, period: f64) -> Result<Option<Self>, TwipError> {
        RigLanes::start(built, x0, dt, period)
    }

    fn settle(robots: &mut [(&mut SlopeRig<f64>, [f64; 4])], period: f64) {
        RigLanes::settle(robots, period);
    }

    fn restart(&mut self, l: usize, model: SlopeModel<f64>, rig: SlopeRig<f64>, x0: [f64; 4]) {
        RigLanes::restart(self, l, model, rig, x0);
    }

    fn hold_drive(&mut self, drive: &[Lanes; 1]) {
        self.context.hold_drive(&drive[0]);
    }

    #[inline(always)]
    fn step_at<const COPY: u8>(&mut self, ks: &[usize; LANES]) -> [Lanes; 4] {
        let mut next = [[0.0; LANES]; 4];
        RigLanes::step_at::<COPY>(self, ks, &mut next);
        next
    }

    fn state(&self) -> &[Lanes; 4] {
        &self.context.x
    }

    fn state_mut(&mut self) -> &mut [Lanes; 4] {
        &mut self.context.x
    }

    #[inline(always)]
    fn read_at(&mut self, ts: &Lanes) {
        RigLanes::read_at(self, ts);
    }

    fn reading(&self) -> &[Lanes; 4] {
        self.context.reading()
    }
}

/// N balancing robots of one [`BalanceSpec`], each with its own key (seed, episode).
pub type BalanceEnvs = Envs<BalanceSpec, 4, 1>;

/// Balance-v0's default reward's weights and wheel-speed reference
/// (`twip.envs.balance.DEFAULT_REWARD`, `speed_ref` [rad/s]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceReward {
    pub alive: f64,
    pub upright: f64,
    pub tracking: f64,
    pub effort: f64,
    pub speed_ref: f64,
}

impl BalanceReward {
    /// The reward of a step that ends in the true state `x` under `action` over `bound`:
    /// alive − upright·φ² − tracking·(θ̇ − θ̇_ref)² − effort·(action / bound)². Evaluated
    /// as NumPy evaluates `BalanceSettings.rewards` column by column (a square is a product,
    /// the terms taken off left to right, nothing fused), so the same bits as NumPy's.
    #[inline]
    pub fn of(&self, x: &[f64; 4], action: f64, bound: f64) -> f64 {
        let sq = |v: f64| v * v;
        self.alive - self.upright * sq(x[0]) - self.tracking * sq(x[3] - self.speed_ref) - self.effort * sq(action / bound)
    }

    /// Every robot's reward into `out` from its true state (rows of 4 in `states`) and its
    /// action (one each in `actions`).
    pub fn rewards_into(&self, states: &[f64], actions: &[f64], bound: f64, out: &mut [f64]) -> Result<(), TwipError> {
        let n = out.len();
        if actions.len() != n {
            return Err(TwipError::Shape { name: "actions", expected: (n, 1), got: (actions.len(), 1) });
        }
        if states.len() != n * 4 {
            return Err(TwipError::Shape { name: "states", expected: (n, 4), got: (states.len() / 4, 4 + states.len() % 4) });
        }
        for ((r, x), &a) in out.iter_mut().zip(states.chunks_exact(4)).zip(actions) {
            *r = self.of(x.try_into().expect("rows of 4"), a, bound);
        }
        Ok(())
    }
}

impl Envs<BalanceSpec, 4, 1> {
    /// Lane `l`'s observation: the state (ideal plant) or the sensors' last reading.
    pub fn observation(&self, l: usize) -> Vector4<f64> {
        self.measured(l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::params::RobotParams;
    use crate::sweep::rig::noise_seed;
    use alloc::sync::Arc;
    use crate::control::lqr::{design, DesignPoint, LqrController};
    use crate::control::reference::SpeedSchedule;
    use crate::control::{Controller, Reference};
    use crate::sim::runner::{Observer, SimConfig};
    use crate::sweep::{Spread, Target};
    use nalgebra::{Matrix4, SVector};

    fn spec(realism: Option<RealismFor>) -> BalanceSpec {
        let params = RobotParams::balanbot();
        BalanceSpec {
            nominal: Nominal { params, slope: 0.05, x0: Vector4::new(0.0, 0.0, 0.0, 0.0) },
            perturbations: alloc::vec![
                Perturbation { target: Target::Initial(0), spread: Spread::Uniform { low: -0.1, high: 0.1 } },
                Perturbation { target: Target::Param(0), spread: Spread::Uniform { low: 0.9 * params.m_body, high: 1.1 * params.m_body } },
            ],
            realism,
            dt: 1e-3,
            substeps: 5,
            fall_limit: 0.5,
        }
    }

    /// States of every lane over `steps` steps, each lane's action a function of its own
    /// observation, on `threads` threads.
    fn rollout(spec: &BalanceSpec, n: usize, threads: usize, steps: usize) -> Vec<[f64; 4]> {
        let mut envs = BalanceEnvs::new(spec.clone(), n, threads).unwrap();
        for l in 0..n {
            envs.reset(l, Some(100 + l as u64)).unwrap();
        }
        let mut out = Vec::new();
        let mut fell = alloc::vec![false; n];
        for _ in 0..steps {
            let actions: Vec<f64> = (0..n).map(|l| 8.0 * envs.observation(l)[0] + 0.5 * envs.observation(l)[1]).collect();
            envs.step(&actions, &mut fell).unwrap();
            out.extend((0..n).map(|l| <[f64; 4]>::from(envs.state(l))));
        }
        out
    }

    #[test]
    fn same_bits_on_any_thread_count_and_batch_size() {
        let rig: RealismFor = Arc::new(|_: &RobotParams<f64>| Ok(Realism::thesis_like()));
        for realism in [None, Some(rig)] {
            let spec = spec(realism);
            let one = rollout(&spec, 37, 1, 40);
            assert_eq!(one, rollout(&spec, 37, 3, 40));
            // Lane 5 alone (seeded as lane 5 was) is lane 5 of the batch.
            let mut alone = BalanceEnvs::new(spec.clone(), 1, 1).unwrap();
            alone.reset(0, Some(105)).unwrap();
            let mut fell = [false];
            for k in 0..40 {
                let o = alone.observation(0);
                alone.step(&[8.0 * o[0] + 0.5 * o[1]], &mut fell).unwrap();
                assert_eq!(<[f64; 4]>::from(alone.state(0)), one[k * 37 + 5], "step {k}");
            }
        }
    }

    /// A robot started anew mid-run, its IMU's clock out of phase with its neighbours' (a
    /// 2 ms sample period in 5 ms control periods: a lane's samples fall at other steps, its
    /// normals at another place), is bit for bit the single env started with its seed; and a
    /// lane started anew with the key it had is the lane as the batch started it.
    #[test]
    fn a_lane_started_apart_is_the_single_env() {
        use crate::hardware::imu::ImuSettings;
        let imu = ImuSettings { sample_period: 2e-3, ..ImuSettings::thesis_like() };
        let rig: RealismFor = Arc::new(move |_: &RobotParams<f64>| Ok(Realism { imu: Some(imu), ..Realism::thesis_like() }));
        let spec = spec(Some(rig));
        let act = |o: Vector4<f64>| 300.0 * o[0] + 20.0 * o[1];
        let actions = |envs: &BalanceEnvs| (0..envs.len()).map(|l| act(envs.observation(l))).collect::<Vec<f64>>();
        let (n, mut fell) = (21, alloc::vec![false; 21]);
        let (mut batch, mut as_started) = (BalanceEnvs::new(spec.clone(), n, 2).unwrap(), BalanceEnvs::new(spec.clone(), n, 1).unwrap());
        batch.reset(3, Some(3)).unwrap();
        for k in 0..7 {
            assert_eq!(<[f64; 4]>::from(batch.observation(3)), <[f64; 4]>::from(as_started.observation(3)), "period {k}");
            let a = actions(&batch);
            batch.step(&a, &mut fell).unwrap();
            as_started.step(&a, &mut fell).unwrap();
            assert_eq!(<[f64; 4]>::from(batch.state(3)), <[f64; 4]>::from(as_started.state(3)), "period {k}");
        }
        batch.reset(5, Some(105)).unwrap();
        let mut alone = BalanceEnvs::new(spec.clone(), 1, 1).unwrap();
        alone.reset(0, Some(105)).unwrap();
        let mut fell_alone = [false];
        for k in 0..60 {
            assert_eq!(<[f64; 4]>::from(batch.observation(5)), <[f64; 4]>::from(alone.observation(0)), "period {k}");
            let a = actions(&batch);
            batch.step(&a, &mut fell).unwrap();
            alone.step(&[a[5]], &mut fell_alone).unwrap();
            assert_eq!(<[f64; 4]>::from(batch.state(5)), <[f64; 4]>::from(alone.state(0)), "period {k}");
            assert_eq!(fell[5], fell_alone[0]);
        }
    }

    /// Resetting many lanes at once (their robots made side by side) is resetting them one
    /// by one: the same keys and bits, a lane named twice started twice, and a lane past the
    /// end stopping the resets there.
    #[test]
    fn reset_many_is_reset_one_by_one() {
        let rig: RealismFor = Arc::new(|_: &RobotParams<f64>| Ok(Realism::thesis_like()));
        for realism in [None, Some(rig)] {
            let spec = spec(realism);
            let mut fell = alloc::vec![false; 20];
            let (mut many, mut one) = (BalanceEnvs::new(spec.clone(), 20, 2).unwrap(), BalanceEnvs::new(spec.clone(), 20, 1).unwrap());
            let lanes = [3, 7, 0, 19];
            many.reset_many(&lanes, Some(&[11, 12, 13, 14])).unwrap();
            many.reset_many(&[7, 2, 7], None).unwrap();
            let past = many.reset_many(&[1, 25, 4], None);
            assert!(matches!(past, Err(TwipError::InvalidParameter { name: "lane", .. })), "{past:?}");
            for (l, seed) in lanes.into_iter().zip(11..) {
                one.reset(l, Some(seed)).unwrap();
            }
            for l in [7, 2, 7, 1] {
                one.reset(l, None).unwrap();
            }
            assert_eq!(many.key(4), (4, 0));
            assert_eq!(many.key(7), (12, 2));
            for _ in 0..30 {
                let actions: Vec<f64> = (0..20).map(|l| 8.0 * one.observation(l)[0] + 0.5 * one.observation(l)[1]).collect();
                many.step(&actions, &mut fell).unwrap();
                one.step(&actions, &mut fell).unwrap();
            }
            for l in 0..20 {
                assert_eq!(many.key(l), one.key(l));
                assert_eq!(<[f64; 4]>::from(many.state(l)), <[f64; 4]>::from(one.state(l)), "lane {l}");
                assert_eq!(<[f64; 4]>::from(many.observation(l)), <[f64; 4]>::from(one.observation(l)), "lane {l}");
            }
            assert!(matches!(many.reset_many(&[1, 2], Some(&[5])), Err(TwipError::InvalidParameter { name: "seeds", .. })));
        }
    }

    /// Replays actions as a controller of the one runner (and keeps what it was shown).
    struct Replay(Vec<f64>, usize, Vec<Vector4<f64>>);

    impl Controller<f64, 4, 1> for Replay {
        type Reference = crate::control::reference::SpeedRef<f64>;
        fn reset(&mut self) {
            self.1 = 0;
        }
        fn period(&self) -> f64 {
            5e-3
        }
        fn update(&mut self, _: f64, y: &Vector4<f64>, _: &Self::Reference) -> SVector<f64, 1> {
            self.2.push(*y);
            self.1 += 1;
            SVector::<f64, 1>::new(self.0[self.1 - 1])
        }
        fn internals(&self) -> &[f64] {
            &[]
        }
        fn internal_names(&self) -> &'static [&'static str] {
            &[]
        }
    }

    struct States(Vec<Vector4<f64>>);
    impl<S> Observer<f64, 4, 1, S> for States {
        fn observe(&mut self, _: f64, x: &Vector4<f64>, _: &SVector<f64, 1>, _: &S, _: &[f64]) {
            self.0.push(*x);
        }
    }

    /// A lane's run is the runner's with the same inputs, to rounding: the lanes fuse
    /// multiply-adds where the runner rounds twice, on the ideal plant and through the rig.
    #[test]
    fn a_lane_is_the_runners_run() {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.05).unwrap();
        let q = Matrix4::from_diagonal(&Vector4::new(10.0, 10.0, 1.0, 1.0));
        let d = design(&model, 0.0, &q, 100.0, DesignPoint::OperatingPoint).unwrap();
        let lqr = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 5e-3).unwrap();
        let rig: RealismFor = Arc::new(|_: &RobotParams<f64>| Ok(Realism { motor: None, ..Realism::thesis_like() }));
        for realism in [None, Some(rig)] {
            let mut spec = spec(realism.clone());
            spec.perturbations.clear();
            spec.nominal.x0 = Vector4::new(0.05, 0.0, 0.0, 0.0);
            let mut envs = BalanceEnvs::new(spec.clone(), 3, 2).unwrap();
            let mut ctrl = lqr;
            ctrl.reset();
            let (mut actions, mut states) = (Vec::new(), Vec::new());
            let r = SpeedSchedule::constant(0.0).unwrap().sample(0.0);
            let mut fell = [false; 3];
            let first_observation = envs.observation(2);
            for k in 0..400 {
                let a = ctrl.update(k as f64 * 5e-3, &envs.observation(2), &r)[0];
                actions.push(a);
                envs.step(&[0.0, 0.0, a], &mut fell).unwrap();
                assert!(!fell[2]);
                states.push(envs.state(2));
            }
            let config = SimConfig::new(1e-3, 2.0, Some(0.5));
            let mut seen = States(Vec::new());
            let mut replay = Replay(actions, 0, Vec::new());
            match &realism {
                None => {
                    crate::sim::runner::simulate(&model, &mut replay, &SpeedSchedule::constant(0.0).unwrap(), &spec.nominal.x0, &config, &mut seen).unwrap();
                }
                Some(f) => {
                    let mut rig = Realism { seed: noise_seed(2), ..f(model.params()).unwrap() }.build(&model, 1e-3).unwrap();
                    rig.simulate(&mut replay, &SpeedSchedule::constant(0.0).unwrap(), &spec.nominal.x0, &config, &mut seen, || false).unwrap();
                }
            }
            let mut worst: f64 = 0.0;
            for (k, x) in states.iter().enumerate() {
                let want = seen.0[5 * (k + 1)];
                let err = (x - want).amax();
                worst = worst.max(err);
                // Fused lanes against the runner's separate roundings, replayed open
                // loop: the upright's unstable pole grows the ~1e-16 differences.
                assert!(err < 1e-10, "{}, period {k}: {err}", if realism.is_some() { "rig" } else { "ideal" });
            }
            // The first observation is the firmware's first read at t = 0 (through the rig:
            // the sensors' reading, not zeros).
            let first = (first_observation - replay.2[0]).amax();
            assert!(first < 1e-9 && first_observation != Vector4::zeros(), "first observation {first_observation:?} against {:?}", replay.2[0]);
            // Measured (worst over 400 periods): 6.1e-12 ideal, 3.3e-12 through the rig.
            std::println!("{}: worst {worst:e}", if realism.is_some() { "rig" } else { "ideal" });
        }
    }

    #[test]
    fn bad_input_is_refused_and_changes_nothing() {
        assert!(matches!(BalanceEnvs::new(spec(None), 0, 1), Err(TwipError::InvalidParameter { name: "num_envs", .. })));
        let mut envs = BalanceEnvs::new(spec(None), 4, 1).unwrap();
        let before = envs.state(1);
        let mut fell = [false; 4];
        assert!(matches!(envs.step(&[0.0; 3], &mut fell), Err(TwipError::Shape { .. })));
        assert!(matches!(envs.step(&[0.0, f64::NAN, 0.0, 0.0], &mut fell), Err(TwipError::NonFinite { name: "action", index: 1, .. })));
        assert_eq!(envs.state(1), before);
    }
}
