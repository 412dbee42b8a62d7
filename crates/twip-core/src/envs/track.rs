//! `twip/Track-v0`'s robots: N 3-DOF robots (the planar model) following one path, each
//! from its own start, advanced one control period per step, on the ideal plant or
//! through each robot's own 3-DOF rig.
//!
//! - Ideal plant: the planar sweep's lanes (`sweep::block::planar`'s plants, [`LANES`]
//!   robots a block, one block per task); the action is the two wheel torques [N m].
//! - Rig: each robot's [`PlanarRig`] (`Realism::build_planar`), stepped as the runner steps
//!   it; the action is the plant's input (the two duties with a motor driver, rounded and
//!   saturated as the firmware writes them; else the torques); the observation is built
//!   from the sensors' reading (dead-reckoned pose, encoder heading, tilt estimate, gyros).
//!
//! The observation ([`TRACK_OBS`] entries) is the path error in the robot's frame at the
//! lane's own time since its episode began, then the pitch and the speeds, then the
//! reference's speeds: `[e_along, e_lateral, e_psi, φ, φ̇, v, ω, v_ref, ω_ref]`.
use alloc::vec::Vec;

use super::batch::{Drawn, EnvKind, Envs, RealismFor};
use super::robot::{LanePlant, Period};
use crate::control::trajectory::{PlanarRef, Trajectory};
use crate::control::Reference;
use crate::hardware::planar_rig::{PlanarActuator, PlanarPlant, PlanarRig, PlanarSensors};
use crate::hardware::realism::Realism;
use crate::model::planar::{PlanarModel, PlanarState};
use crate::sweep::block::PlanarPlants;
use crate::sweep::lanes::{Lanes, LANES};
use crate::sweep::planar::{draw, validate, PlanarNominal};
use crate::sweep::Perturbation;
use crate::TwipError;

/// Entries of a Track-v0 observation.
pub const TRACK_OBS: usize = 9;

/// What every robot of a tracking batch shares.
#[derive(Clone)]
pub struct TrackSpec {
    /// The nominal robot and initial state `[x, y, psi, phi, phi_dot, v, omega]` the draws
    /// perturb.
    pub nominal: PlanarNominal,
    /// Drawn per episode, in order, from `Philox::new(seed, episode)` (`sweep::planar::draw`).
    pub perturbations: Vec<Perturbation>,
    /// None: the ideal plant.
    pub realism: Option<RealismFor>,
    /// The path every robot follows, from its episode's start.
    pub path: Trajectory<f64>,
    /// The plant step [s], plant steps per control period, |φ| beyond which a robot fell.
    pub dt: f64,
    pub substeps: usize,
    pub fall_limit: f64,
}

impl LanePlant for PlanarPlants {
    type State = [Lanes; 7];
    type Input = [Lanes; 2];
    const PITCH: usize = 3;

    #[inline(always)]
    fn rk4_lanes(&self, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64) -> [Lanes; 7] {
        self.rk4(x, u, dt)
    }
}

impl EnvKind<7, 2> for TrackSpec {
    type Model = PlanarModel<f64>;
    type Plants = PlanarPlants;
    type RigPlant = PlanarPlant<f64>;
    type RigSensors = PlanarSensors<f64>;
    type RigActuator = PlanarActuator<f64>;

    fn period(&self) -> Period {
        Period { dt: self.dt, substeps: self.substeps, pitch: 3, fall_limit: self.fall_limit }
    }

    fn realism(&self) -> Option<&RealismFor> {
        self.realism.as_ref()
    }

    fn validate(&self) -> Result<(), TwipError> {
        for p in &self.perturbations {
            validate(p)?;
        }
        self.nominal().map(|_| ())
    }

    fn nominal(&self) -> Result<PlanarModel<f64>, TwipError> {
        PlanarModel::new(self.nominal.params)
    }

    fn draw(&self, key: (u64, u64)) -> Result<Drawn<PlanarModel<f64>, 7>, TwipError> {
        let sample = draw(&self.nominal, &self.perturbations, key.0, key.1);
        Ok(Drawn { params: sample.params, model: PlanarModel::new(sample.params)?, x0: sample.x0 })
    }

    fn plants(models: &[PlanarModel<f64>; LANES]) -> PlanarPlants {
        PlanarPlants::new(models)
    }

    fn rig(realism: &Realism<f64>, model: &PlanarModel<f64>, dt: f64) -> Result<PlanarRig<f64>, TwipError> {
        realism.build_planar(model, dt)
    }
}

/// N tracking robots of one [`TrackSpec`], each with its own key (seed, episode).
pub type TrackEnvs = Envs<TrackSpec, 7, 2>;

/// The observation of a robot whose (measured or true) state is `y`, the reference `r`.
pub fn observe(y: &PlanarState<f64>, r: &PlanarRef<f64>) -> [f64; TRACK_OBS] {
    let (dx, dy) = (r.x - y[0], r.y - y[1]);
    let (s, c) = y[2].sin_cos();
    [c * dx + s * dy, c * dy - s * dx, r.psi - y[2], y[3], y[4], y[5], y[6], r.v, r.omega]
}

impl Envs<TrackSpec, 7, 2> {
    /// The path's reference for lane `l` now.
    fn reference(&self, l: usize) -> PlanarRef<f64> {
        self.spec().path.sample(self.time(l))
    }

    /// Lane `l`'s observation: from the sensors' last reading through a rig, else the state.
    pub fn observation(&self, l: usize) -> [f64; TRACK_OBS] {
        observe(&self.measured(l), &self.reference(l))
    }

    /// Lane `l`'s observation as the true state gives it (what the reward weighs).
    pub fn true_observation(&self, l: usize) -> [f64; TRACK_OBS] {
        observe(&self.state(l), &self.reference(l))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::rig::noise_seed;
    use crate::control::pid::PidTracker;
    use crate::control::trajectory::{Circle, Direction};
    use crate::control::Controller;
    use crate::hardware::motor::DcMotor;
    use crate::model::params::RobotParams;
    use crate::sim::runner::{Observer, SimConfig};
    use crate::sweep::{Spread, Target};
    use alloc::sync::Arc;
    use nalgebra::SVector;

    fn circle() -> Trajectory<f64> {
        Trajectory::Circle(Circle::from_origin(0.6, 0.2, Direction::CounterClockwise).unwrap())
    }

    fn spec(realism: Option<RealismFor>) -> TrackSpec {
        let params = RobotParams::balanbot();
        TrackSpec {
            nominal: PlanarNominal { params, x0: PlanarState::zeros() },
            perturbations: alloc::vec![
                Perturbation { target: Target::Initial(3), spread: Spread::Uniform { low: -0.05, high: 0.05 } },
                Perturbation { target: Target::Param(0), spread: Spread::Uniform { low: 0.9 * params.m_body, high: 1.1 * params.m_body } },
            ],
            realism,
            path: circle(),
            dt: 1e-3,
            substeps: 5,
            fall_limit: 0.5,
        }
    }

    /// A crude balancing action from the observation (each lane its own).
    fn act(o: &[f64; TRACK_OBS]) -> [f64; 2] {
        let a = 2.0 * o[3] + 0.2 * o[4] - 0.05 * o[0];
        [a + 0.01 * o[1], a - 0.01 * o[1]]
    }

    fn rollout(spec: &TrackSpec, n: usize, threads: usize, steps: usize) -> Vec<[f64; 7]> {
        let mut envs = TrackEnvs::new(spec.clone(), n, threads).unwrap();
        for l in 0..n {
            envs.reset(l, Some(100 + l as u64)).unwrap();
        }
        let (mut out, mut fell) = (Vec::new(), alloc::vec![false; n]);
        for _ in 0..steps {
            let actions: Vec<f64> = (0..n).flat_map(|l| act(&envs.observation(l))).collect();
            envs.step(&actions, &mut fell).unwrap();
            out.extend((0..n).map(|l| <[f64; 7]>::from(envs.state(l))));
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
            let mut alone = TrackEnvs::new(spec.clone(), 1, 1).unwrap();
            alone.reset(0, Some(105)).unwrap();
            let mut fell = [false];
            for k in 0..40 {
                alone.step(&act(&alone.observation(0)), &mut fell).unwrap();
                assert_eq!(<[f64; 7]>::from(alone.state(0)), one[k * 37 + 5], "step {k}");
            }
        }
    }

    /// Replays actions as a tracker of the one runner.
    struct Replay(Vec<[f64; 2]>, usize);

    impl Controller<f64, 7, 2> for Replay {
        type Reference = PlanarRef<f64>;
        fn reset(&mut self) {
            self.1 = 0;
        }
        fn period(&self) -> f64 {
            5e-3
        }
        fn update(&mut self, _: f64, _: &PlanarState<f64>, _: &PlanarRef<f64>) -> SVector<f64, 2> {
            self.1 += 1;
            SVector::<f64, 2>::from(self.0[self.1 - 1])
        }
        fn internals(&self) -> &[f64] {
            &[]
        }
        fn internal_names(&self) -> &'static [&'static str] {
            &[]
        }
    }

    struct States(Vec<PlanarState<f64>>);
    impl<S> Observer<f64, 7, 2, S> for States {
        fn observe(&mut self, _: f64, x: &PlanarState<f64>, _: &SVector<f64, 2>, _: &S, _: &[f64]) {
            self.0.push(*x);
        }
    }

    /// A lane's run is the runner's with the same inputs, the PID tracker closing the loop
    /// on the env: to rounding on the ideal plant's lanes, bit for bit through the rig.
    #[test]
    fn a_lane_is_the_runners_run() {
        let params = RobotParams::balanbot();
        let model = PlanarModel::new(params).unwrap();
        let pid = PidTracker::table_4_1(&params, DcMotor::gb37y3530(), 0.005).unwrap();
        let rig: RealismFor = Arc::new(|_: &RobotParams<f64>| Ok(Realism { motor: None, ..Realism::thesis_like() }));
        let path = circle();
        for realism in [None, Some(rig)] {
            let mut spec = spec(realism.clone());
            spec.perturbations.clear();
            spec.nominal.x0[3] = 0.03;
            let mut envs = TrackEnvs::new(spec.clone(), 3, 2).unwrap();
            let mut ctrl = pid.clone();
            ctrl.reset();
            let (mut actions, mut states) = (Vec::new(), Vec::new());
            let mut fell = [false; 3];
            for k in 0..600 {
                // The tracker sees what the env's lane sees: the state or the reading.
                let y = envs.measured(2);
                let a = ctrl.update(k as f64 * 5e-3, &y, &path.sample(k as f64 * 5e-3));
                actions.push([a[0], a[1]]);
                envs.step(&[0.0, 0.0, 0.0, 0.0, a[0], a[1]], &mut fell).unwrap();
                assert!(!fell[2], "period {k}");
                states.push(envs.state(2));
            }
            let config = SimConfig::new(1e-3, 3.0, Some(0.5));
            let mut seen = States(Vec::new());
            let mut replay = Replay(actions, 0);
            match &realism {
                None => {
                    crate::sim::runner::simulate(&model, &mut replay, &path, &spec.nominal.x0, &config, &mut seen).unwrap();
                }
                Some(f) => {
                    let mut rig = Realism { seed: noise_seed(2), ..f(&params).unwrap() }.build_planar(&model, 1e-3).unwrap();
                    rig.simulate(&mut replay, &path, &spec.nominal.x0, &config, &mut seen, || false).unwrap();
                }
            }
            for (k, x) in states.iter().enumerate() {
                let want = seen.0[5 * (k + 1)];
                if realism.is_some() {
                    assert_eq!(*x, want, "rig, period {k}");
                } else {
                    let err = (x - want).amax();
                    assert!(err < 1e-9, "ideal, period {k}: {err}");
                }
            }
        }
    }

    #[test]
    fn the_observation_is_the_path_error_in_the_robots_frame() {
        let r = PlanarRef { x: 1.0, y: 2.0, psi: 0.5, v: 0.3, omega: 0.1, ..Default::default() };
        // Facing +y from (1, 1): the reference is 1 m straight ahead.
        let y = PlanarState::from([1.0, 1.0, core::f64::consts::FRAC_PI_2, 0.1, 0.2, 0.3, 0.4]);
        let o = observe(&y, &r);
        assert!((o[0] - 1.0).abs() < 1e-15 && o[1].abs() < 1e-15, "{o:?}");
        assert_eq!(&o[2..], &[0.5 - core::f64::consts::FRAC_PI_2, 0.1, 0.2, 0.3, 0.4, 0.3, 0.1]);
    }

    #[test]
    fn bad_input_is_refused_and_changes_nothing() {
        assert!(matches!(TrackEnvs::new(spec(None), 0, 1), Err(TwipError::InvalidParameter { name: "num_envs", .. })));
        let mut envs = TrackEnvs::new(spec(None), 4, 1).unwrap();
        let before = envs.state(1);
        let mut fell = [false; 4];
        assert!(matches!(envs.step(&[0.0; 7], &mut fell), Err(TwipError::Shape { .. })));
        let mut a = [0.0; 8];
        a[3] = f64::NAN;
        assert!(matches!(envs.step(&a, &mut fell), Err(TwipError::NonFinite { name: "action", index: 3, .. })));
        assert_eq!(envs.state(1), before);
        assert_eq!(envs.time(1), 0.0);
    }
}
