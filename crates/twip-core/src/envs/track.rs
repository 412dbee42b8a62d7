//! `twip/Track-v0`'s robots: N 3-DOF robots (the planar model) following one path, each
//! from its own start, advanced one control period per step, on the ideal plant or
//! through each robot's own 3-DOF rig.
//!
//! - Ideal plant: the planar sweep's lanes (`sweep::block::planar`'s plants, [`LANES`]
//!   robots a block, one block per task); the action is the two wheel torques [N m].
//! - Rig: each robot's [`PlanarRig`] (`Realism::build_planar`) on the 3-DOF rig sweep's
//!   lanes ([`PlanarRigLanes`], each lane at its own step), stepped as the runner steps a
//!   rig, so a robot agrees with `twip.simulate` through it to rounding (the lanes fuse
//!   multiply-adds); the action is the plant's input (the two duties with a motor driver, rounded and
//!   saturated as the firmware writes them; else the torques); the observation is built
//!   from the sensors' reading (dead-reckoned pose, encoder heading, tilt estimate, gyros).
//!
//! The observation ([`TRACK_OBS`] entries) is the path error in the robot's frame at the
//! lane's own time since its episode began, then the pitch and the speeds, then the
//! reference's speeds: `[e_along, e_lateral, e_psi, φ, φ̇, v, ω, v_ref, ω_ref]`.
use alloc::vec::Vec;

use super::batch::{Drawn, EnvKind, Envs, RealismFor};
use super::robot::{LanePlant, Period, RigBlock};
use crate::control::trajectory::{PlanarRef, Trajectory};
use crate::control::Reference;
use crate::hardware::planar_rig::PlanarRig;
use crate::hardware::realism::Realism;
use crate::model::planar::{PlanarModel, PlanarState};
use crate::sweep::block::{PlanarPlants, PlanarRigLanes};
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

    /// The sweeps' shifted step where the live lanes allow (`PlanarPlants::rk4_shifted_into`),
    /// else `PlanarPlants::rk4`'s arithmetic on every lane, each body two lanes (l and
    /// l + LANES/2): two independent chains of dependent operations (each RK4 stage waits
    /// on the last one's divisions) that the CPU overlaps, as the 2-DOF block's RK4 does.
    #[inline(always)]
    fn rk4_lanes(&self, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64, live: &[bool; LANES], next: &mut [Lanes; 7]) {
        self.rk4_shifted_into(x, u, dt, live, next, #[inline(always)] |out| {
            const HALF: usize = LANES / 2;
            for l in 0..HALF {
                let (a, b) = (self.rk4_lane(x, u, l, dt), self.rk4_lane(x, u, l + HALF, dt));
                for i in 0..7 {
                    out[i][l] = a[i].0;
                    out[i][l + HALF] = b[i].0;
                }
            }
        });
    }
}

impl EnvKind<7, 2> for TrackSpec {
    type Model = PlanarModel<f64>;
    type Plants = PlanarPlants;
    type RigLanes = PlanarRigLanes;

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

    fn set_plant(plants: &mut PlanarPlants, l: usize, model: &PlanarModel<f64>) {
        plants.set_lane(l, model);
    }

    /// The path's reference: every robot follows the path from its episode's start.
    type AtTime = PlanarRef<f64>;
    fn at_time(&self, t: f64) -> PlanarRef<f64> {
        self.path.sample(t)
    }

    fn rig(realism: &Realism<f64>, model: &PlanarModel<f64>, dt: f64) -> Result<PlanarRig<f64>, TwipError> {
        realism.build_planar(model, dt)
    }
}

impl RigBlock for PlanarRigLanes {
    type Model = PlanarModel<f64>;
    type Rig = PlanarRig<f64>;
    type State = [Lanes; 7];
    type State1 = [f64; 7];
    type Drive = [Lanes; 2];

    fn start(built: Vec<Option<(PlanarModel<f64>, PlanarRig<f64>)>>, x0: [[f64; 7]; LANES], dt: f64, period: f64) -> Result<Option<Self>, TwipError> {
        PlanarRigLanes::start(built, x0, dt, period, None)
    }

    fn settle(robots: &mut [(&mut PlanarRig<f64>, [f64; 7])], period: f64) {
        PlanarRigLanes::settle(robots, period);
    }

    fn restart(&mut self, l: usize, model: PlanarModel<f64>, rig: PlanarRig<f64>, x0: [f64; 7]) {
        PlanarRigLanes::restart(self, l, model, rig, x0);
    }

    fn hold_drive(&mut self, drive: &[Lanes; 2]) {
        self.context.hold_drive(drive);
    }

    #[inline(always)]
    fn step_at<const COPY: u8>(&mut self, ks: &[usize; LANES]) -> [Lanes; 7] {
        let mut next = [[0.0; LANES]; 7];
        PlanarRigLanes::step_at::<COPY>(self, ks, &mut next);
        next
    }

    fn state(&self) -> &[Lanes; 7] {
        &self.context.x
    }

    fn state_mut(&mut self) -> &mut [Lanes; 7] {
        &mut self.context.x
    }

    #[inline(always)]
    fn read_at(&mut self, ts: &Lanes) {
        PlanarRigLanes::read_at(self, ts);
    }

    fn reading(&self) -> &[Lanes; 7] {
        self.context.reading()
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

/// Track-v0's default reward's weights (`twip.envs.track.DEFAULT_REWARD`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackReward {
    pub alive: f64,
    pub upright: f64,
    pub tracking: f64,
    pub heading: f64,
    pub effort: f64,
}

impl TrackReward {
    /// The reward of a step that ends at the true observation `o` under `action`, each
    /// action over `bound`: alive − upright·φ² − tracking·(e_along² + e_lateral²) −
    /// heading·e_psi² − effort·mean((action / bound)²). Evaluated as NumPy evaluates the
    /// formula column by column (a square is a product, the mean of two their sum over 2,
    /// the terms taken off left to right, nothing fused), so the same bits as NumPy's.
    #[inline]
    pub fn of(&self, o: &[f64; TRACK_OBS], action: [f64; 2], bound: f64) -> f64 {
        let sq = |v: f64| v * v;
        let effort = (sq(action[0] / bound) + sq(action[1] / bound)) / 2.0;
        self.alive - self.upright * sq(o[3]) - self.tracking * (sq(o[0]) + sq(o[1])) - self.heading * sq(o[2]) - self.effort * effort
    }

    /// Every robot's reward into `out` from its true observation (rows of [`TRACK_OBS`]
    /// in `observations`) and its action (rows of 2 in `actions`).
    pub fn rewards_into(&self, observations: &[f64], actions: &[f64], bound: f64, out: &mut [f64]) -> Result<(), TwipError> {
        let n = out.len();
        if actions.len() != n * 2 {
            return Err(TwipError::Shape { name: "actions", expected: (n, 2), got: (actions.len() / 2, 2 + actions.len() % 2) });
        }
        if observations.len() != n * TRACK_OBS {
            return Err(TwipError::Shape { name: "observations", expected: (n, TRACK_OBS), got: (observations.len() / TRACK_OBS, TRACK_OBS + observations.len() % TRACK_OBS) });
        }
        for ((r, o), a) in out.iter_mut().zip(observations.chunks_exact(TRACK_OBS)).zip(actions.chunks_exact(2)) {
            *r = self.of(o.try_into().expect("rows of TRACK_OBS"), [a[0], a[1]], bound);
        }
        Ok(())
    }
}

impl Envs<TrackSpec, 7, 2> {
    /// The path's reference for lane `l` now (made once per period count).
    fn reference(&self, l: usize) -> PlanarRef<f64> {
        self.at_period(l)
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

    /// Each lane's observation holds the path's reference at the lane's own time (made once
    /// per period count): lanes started anew at other times, and a lane past the periods the
    /// batch keeps; ideal and through the rig.
    #[test]
    fn the_reference_is_the_paths_at_each_lanes_own_time() {
        let rig: RealismFor = Arc::new(|_: &RobotParams<f64>| Ok(Realism::thesis_like()));
        for realism in [None, Some(rig)] {
            let mut envs = TrackEnvs::new(spec(realism), 3, 1).unwrap();
            let mut fell = [false; 3];
            let periods = super::super::batch::AT_PERIODS + 20;
            for k in 0..periods {
                envs.step(&[0.0; 6], &mut fell).unwrap();
                if k % 7 == 3 {
                    envs.reset(1, None).unwrap();
                }
                for l in 0..3 {
                    let want = observe(&envs.measured(l), &envs.spec().path.sample(envs.time(l)));
                    assert_eq!(envs.observation(l).map(f64::to_bits), want.map(f64::to_bits), "lane {l}, period {k}");
                }
            }
            assert_eq!(envs.time(0), periods as f64 * 5.0 * 1e-3);
        }
    }

    /// The rows a batch fills on its threads are the lanes' one by one, on any thread count
    /// (1000 robots: two tasks of rows and a part); a buffer of the wrong length is refused.
    #[test]
    fn rows_filled_on_the_threads_are_the_lanes_rows() {
        let rig: RealismFor = Arc::new(|_: &RobotParams<f64>| Ok(Realism::thesis_like()));
        for realism in [None, Some(rig)] {
            for threads in [1, 3] {
                let n = if realism.is_some() { 40 } else { 1000 };
                let mut envs = TrackEnvs::new(spec(realism.clone()), n, threads).unwrap();
                let mut fell = alloc::vec![false; n];
                let actions: Vec<f64> = (0..n).flat_map(|l| act(&envs.observation(l))).collect();
                envs.step(&actions, &mut fell).unwrap();
                let mut out = alloc::vec![f64::NAN; n * TRACK_OBS];
                envs.rows_into(&mut out, |e, l| e.observation(l)).unwrap();
                let want: Vec<f64> = (0..n).flat_map(|l| envs.observation(l)).collect();
                assert_eq!(out, want);
                let mut states = alloc::vec![f64::NAN; n * 7];
                envs.rows_into(&mut states, |e, l| <[f64; 7]>::from(e.state(l))).unwrap();
                assert_eq!(states, (0..n).flat_map(|l| <[f64; 7]>::from(envs.state(l))).collect::<Vec<f64>>());
                assert!(matches!(envs.rows_into(&mut out[1..], |e, l| e.observation(l)), Err(TwipError::Shape { name: "rows", .. })));
            }
        }
    }

    /// A robot started anew mid-run, its IMUs' clock out of phase with its neighbours' (a
    /// 2 ms sample period in 5 ms control periods), is bit for bit the single env started
    /// with its seed; and a lane started anew with the key it had is the lane as the batch
    /// started it.
    #[test]
    fn a_lane_started_apart_is_the_single_env() {
        use crate::hardware::imu::ImuSettings;
        let imu = ImuSettings { sample_period: 2e-3, ..ImuSettings::thesis_like() };
        let rig: RealismFor = Arc::new(move |_: &RobotParams<f64>| Ok(Realism { imu: Some(imu), ..Realism::thesis_like() }));
        let spec = spec(Some(rig));
        let duties = |o: &[f64; TRACK_OBS]| act(o).map(|a| 150.0 * a);
        let actions = |envs: &TrackEnvs| (0..envs.len()).flat_map(|l| duties(&envs.observation(l))).collect::<Vec<f64>>();
        let (n, mut fell) = (21, alloc::vec![false; 21]);
        let (mut batch, mut as_started) = (TrackEnvs::new(spec.clone(), n, 2).unwrap(), TrackEnvs::new(spec.clone(), n, 1).unwrap());
        batch.reset(3, Some(3)).unwrap();
        for k in 0..7 {
            assert_eq!(batch.observation(3), as_started.observation(3), "period {k}");
            let a = actions(&batch);
            batch.step(&a, &mut fell).unwrap();
            as_started.step(&a, &mut fell).unwrap();
            assert_eq!(<[f64; 7]>::from(batch.state(3)), <[f64; 7]>::from(as_started.state(3)), "period {k}");
        }
        batch.reset(5, Some(105)).unwrap();
        let mut alone = TrackEnvs::new(spec.clone(), 1, 1).unwrap();
        alone.reset(0, Some(105)).unwrap();
        let mut fell_alone = [false];
        for k in 0..60 {
            assert_eq!(batch.observation(5), alone.observation(0), "period {k}");
            let a = actions(&batch);
            batch.step(&a, &mut fell).unwrap();
            alone.step(&a[10..12], &mut fell_alone).unwrap();
            assert_eq!(<[f64; 7]>::from(batch.state(5)), <[f64; 7]>::from(alone.state(0)), "period {k}");
            assert_eq!(fell[5], fell_alone[0]);
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
    /// on the env: to rounding (the lanes fuse multiply-adds), on the ideal plant's lanes
    /// and through the rig.
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
            // Replayed open loop, the upright's unstable pole grows the roundings: measured,
            // the worst over 600 periods is 4.0e-10 on the ideal plant, and through the rig
            // (whose play and stick band pass them on) 1.0e-9 by period 511, 1.5e-8 by 600.
            let bound = if realism.is_some() { 1e-7 } else { 1e-9 };
            let mut worst: f64 = 0.0;
            for (k, x) in states.iter().enumerate() {
                let want = seen.0[5 * (k + 1)];
                let err = (x - want).amax();
                worst = worst.max(err);
                assert!(err < bound, "{}, period {k}: {err}", if realism.is_some() { "rig" } else { "ideal" });
            }
            std::println!("{}: worst {worst:e}", if realism.is_some() { "rig" } else { "ideal" });
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

    /// The reward's terms on a worked example, and the rows' shapes checked.
    #[test]
    fn the_reward_is_its_terms() {
        let w = TrackReward { alive: 1.0, upright: 10.0, tracking: 10.0, heading: 1.0, effort: 0.1 };
        let o = [0.3, -0.4, 0.2, 0.1, 9.0, 9.0, 9.0, 9.0, 9.0];
        // 1 − 10·0.01 − 10·(0.09 + 0.16) − 0.04 − 0.1·(0.25 + 1)/2
        let want = 1.0 - 0.1 - 2.5 - 0.04 - 0.0625;
        assert!((w.of(&o, [0.5, -1.0], 1.0) - want).abs() < 1e-12);
        assert_eq!(w.of(&o, [1.0, -2.0], 2.0), w.of(&o, [0.5, -1.0], 1.0));
        let mut out = [0.0; 2];
        let rows: Vec<f64> = o.iter().chain(&o).copied().collect();
        w.rewards_into(&rows, &[0.5, -1.0, 0.0, 0.0], 1.0, &mut out).unwrap();
        assert_eq!(out, [w.of(&o, [0.5, -1.0], 1.0), w.of(&o, [0.0, 0.0], 1.0)]);
        assert!(matches!(w.rewards_into(&rows, &[0.0; 3], 1.0, &mut out), Err(TwipError::Shape { name: "actions", .. })));
        assert!(matches!(w.rewards_into(&rows[1..], &[0.0; 4], 1.0, &mut out), Err(TwipError::Shape { name: "observations", .. })));
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
