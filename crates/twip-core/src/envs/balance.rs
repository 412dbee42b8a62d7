//! `twip/Balance-v0`'s robots: N 2-DOF robots (slope model) advanced one control period
//! per step, on the ideal plant or through each robot's own rig.
//!
//! - Ideal plant: the sweep's lanes ([`Plants::rk4`], [`LANES`] robots a block, one block
//!   per task), so a lane agrees with `runner::simulate` to rounding and is bit for bit the
//!   same on every CPU copy, thread count and block neighbour. The observation is the state.
//! - Rig: each robot's [`SlopeRig`] (`Realism::build`: the very plant, sensors and delay a
//!   run uses), stepped as `runner::run_loop` steps it between two controller updates, so
//!   a robot agrees with `twip.simulate` through that rig bit for bit. The action is the
//!   plant's input (the PWM duty with a motor driver, rounded and saturated as the
//!   firmware writes it; else the lumped current); the observation the sensors' reading.
use alloc::vec::Vec;

use nalgebra::Vector4;

use super::batch::{Drawn, EnvKind, Envs, RealismFor};
use super::robot::{LanePlant, Period};
use crate::hardware::realism::{BalanceSensors, RealActuator, RealPlant, Realism, SlopeRig};
use crate::model::slope::SlopeModel;
use crate::sweep::block::Plants;
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
    fn rk4_lanes(&self, x: &[Lanes; 4], u: &[Lanes; 1], dt: f64) -> [Lanes; 4] {
        self.rk4(x, &u[0], dt)
    }
}

impl EnvKind<4, 1> for BalanceSpec {
    type Model = SlopeModel<f64>;
    type Plants = Plants;
    type RigPlant = RealPlant<f64>;
    type RigSensors = BalanceSensors<f64>;
    type RigActuator = RealActuator<f64>;

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

    fn rig(realism: &Realism<f64>, model: &SlopeModel<f64>, dt: f64) -> Result<SlopeRig<f64>, TwipError> {
        realism.build(model, dt)
    }
}

/// N balancing robots of one [`BalanceSpec`], each with its own key (seed, episode).
pub type BalanceEnvs = Envs<BalanceSpec, 4, 1>;

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

    /// Replays actions as a controller of the one runner.
    struct Replay(Vec<f64>, usize);

    impl Controller<f64, 4, 1> for Replay {
        type Reference = crate::control::reference::SpeedRef<f64>;
        fn reset(&mut self) {
            self.1 = 0;
        }
        fn period(&self) -> f64 {
            5e-3
        }
        fn update(&mut self, _: f64, _: &Vector4<f64>, _: &Self::Reference) -> SVector<f64, 1> {
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

    /// A lane's run is the runner's with the same inputs: to rounding on the ideal plant's
    /// lanes, bit for bit through the rig (the same objects, stepped alike).
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
            for k in 0..400 {
                let a = ctrl.update(k as f64 * 5e-3, &envs.observation(2), &r)[0];
                actions.push(a);
                envs.step(&[0.0, 0.0, a], &mut fell).unwrap();
                assert!(!fell[2]);
                states.push(envs.state(2));
            }
            let config = SimConfig::new(1e-3, 2.0, Some(0.5));
            let mut seen = States(Vec::new());
            let mut replay = Replay(actions, 0);
            match &realism {
                None => {
                    crate::sim::runner::simulate(&model, &mut replay, &SpeedSchedule::constant(0.0).unwrap(), &spec.nominal.x0, &config, &mut seen).unwrap();
                }
                Some(f) => {
                    let mut rig = Realism { seed: noise_seed(2), ..f(model.params()).unwrap() }.build(&model, 1e-3).unwrap();
                    rig.simulate(&mut replay, &SpeedSchedule::constant(0.0).unwrap(), &spec.nominal.x0, &config, &mut seen, || false).unwrap();
                }
            }
            for (k, x) in states.iter().enumerate() {
                let want = seen.0[5 * (k + 1)];
                let err = (x - want).amax();
                if realism.is_some() {
                    assert_eq!(*x, want, "rig, period {k}");
                } else {
                    // Fused lanes against the runner's separate roundings, replayed open
                    // loop: the upright's unstable pole grows the ~1e-16 differences.
                    assert!(err < 1e-10, "ideal, period {k}: {err}");
                }
            }
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
