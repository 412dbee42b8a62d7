//! The batch both envs are: N robots of one spec, each with its own key (seed, episode),
//! [`LANES`] robots a block, one block per task, on the ideal lanes or through their rigs on
//! the rig's lanes (the sweep's, each lane at its own step); what differs between the envs
//! (model, lanes, rig, draw) is their [`EnvKind`].
use alloc::boxed::Box;
use alloc::sync::Arc;
use alloc::vec::Vec;

use nalgebra::SVector;
use rayon::prelude::*;

use super::robot::{advance_block, advance_rig, oom, LanePlant, Period, RigBlock};
use crate::hardware::realism::Realism;
use crate::hardware::settle::SETTLE_LANES;
use crate::model::params::RobotParams;
use crate::sweep::lanes::{Lanes, LANES};
use crate::sweep::rig::noise_seed;
use crate::TwipError;

/// The rig a robot with these parameters gets (pushes and a force act at its own centre
/// of mass); its seed and stream are set per episode.
pub type RealismFor = Arc<dyn Fn(&RobotParams<f64>) -> Result<Realism<f64>, TwipError> + Send + Sync>;

/// A robot of a batch for one key: its parameters, model and initial state.
pub(crate) struct Drawn<M, const NX: usize> {
    pub params: RobotParams<f64>,
    pub model: M,
    pub x0: SVector<f64, NX>,
}

/// An env's spec: what its robots are (`NX` states, `NU` inputs) and how a key draws one.
/// Crate-private, as the lanes' plants are: a batch is made of one of the specs here.
pub(crate) trait EnvKind<const NX: usize, const NU: usize>: Send + Sync {
    /// A robot's model, as the lanes and the rig take it.
    type Model: Copy + Send + Sync;
    /// [`LANES`] robots on the ideal plant.
    type Plants: LanePlant<State = [Lanes; NX], Input = [Lanes; NU]> + Send + Sync;
    /// [`LANES`] robots through their rigs.
    type RigLanes: RigBlock<Model = Self::Model, State = [Lanes; NX], State1 = [f64; NX], Drive = [Lanes; NU]>;

    /// The plant step, steps per period and fall limit.
    fn period(&self) -> Period;
    /// None: the ideal plant.
    fn realism(&self) -> Option<&RealismFor>;
    /// The perturbations and the nominal model, checked.
    fn validate(&self) -> Result<(), TwipError>;
    /// The nominal robot's model.
    fn nominal(&self) -> Result<Self::Model, TwipError>;
    /// The robot of key (seed, episode) (`sweep::draw`'s); an error if its model is refused.
    fn draw(&self, key: (u64, u64)) -> Result<Drawn<Self::Model, NX>, TwipError>;
    fn plants(models: &[Self::Model; LANES]) -> Self::Plants;
    /// Lane `l` of `plants` set to `model`'s (a robot started anew), the others' as they are.
    fn set_plant(plants: &mut Self::Plants, l: usize, model: &Self::Model);
    /// What every robot at time `t` [s] in its episode shares (Track-v0: the path's
    /// reference; `()` when nothing is), which the batch makes once per control period
    /// count ([`Envs::at_period`]).
    type AtTime: Copy + Send + Sync;
    fn at_time(&self, t: f64) -> Self::AtTime;
    fn rig(realism: &Realism<f64>, model: &Self::Model, dt: f64) -> Result<<Self::RigLanes as RigBlock>::Rig, TwipError>;
}

/// [`LANES`] robots on the ideal plant.
struct IdealBlock<K: EnvKind<NX, NU>, const NX: usize, const NU: usize> {
    plants: K::Plants,
    x: [Lanes; NX],
}

/// [`LANES`] robots through their rigs, each lane at its own plant step since its episode
/// began; the largest duty (counts) each lane's driver takes (None: the input is the model's).
struct RigRobots<K: EnvKind<NX, NU>, const NX: usize, const NU: usize> {
    lanes: K::RigLanes,
    steps: [usize; LANES],
    pwm_max: [Option<f64>; LANES],
}

enum Robots<K: EnvKind<NX, NU>, const NX: usize, const NU: usize> {
    Ideal(Vec<IdealBlock<K, NX, NU>>),
    Rig(Vec<RigRobots<K, NX, NU>>),
}

/// N robots of one spec `K`, each with its own key (seed, episode).
#[allow(private_bounds)]
pub struct Envs<K: EnvKind<NX, NU>, const NX: usize, const NU: usize> {
    spec: K,
    n: usize,
    keys: Vec<(u64, u64)>,
    /// Control periods since each lane's episode began.
    periods: Vec<u64>,
    /// [`EnvKind::at_time`] after k control periods, k = 0.. up to the most any lane has
    /// run (at most [`AT_PERIODS`]): what the lanes at the same k share, made once.
    at_periods: Vec<K::AtTime>,
    robots: Robots<K, NX, NU>,
    /// Shared with [`Envs::in_one_trip`]'s caller, which holds the batch meanwhile.
    pool: Arc<rayon::ThreadPool>,
}

impl<K: EnvKind<NX, NU>, const NX: usize, const NU: usize> IdealBlock<K, NX, NU> {
    /// `robot` in lane `j`.
    fn put(&mut self, j: usize, robot: Started<K, NX, NU>) {
        let Started::Ideal(model, x0) = robot else { unreachable!("a batch's robots are all ideal or all through a rig") };
        K::set_plant(&mut self.plants, j, &model);
        for i in 0..NX {
            self.x[i][j] = x0[i];
        }
    }
}

impl<K: EnvKind<NX, NU>, const NX: usize, const NU: usize> RigRobots<K, NX, NU> {
    /// `robot` (settled) in lane `j`.
    fn put(&mut self, j: usize, robot: Started<K, NX, NU>) {
        let Started::Rig(model, rig, x0, pwm_max) = robot else { unreachable!("a batch's robots are all ideal or all through a rig") };
        self.lanes.restart(j, model, *rig, x0);
        (self.steps[j], self.pwm_max[j]) = (0, pwm_max);
    }
}

/// Most control periods whose [`EnvKind::at_time`] a batch keeps (Track-v0's references:
/// 1.8 MB, 164 s at the default 5 ms); a lane past them has its own made each time. The
/// tests' builds keep few, so that lanes run past them.
pub(crate) const AT_PERIODS: usize = if cfg!(test) { 64 } else { 1 << 15 };

/// Fewer ideal robots than this are started anew on the thread that resets them: not worth
/// a trip to the threads.
const IDEAL_MADE_HERE: usize = 256;

/// Lanes a task of [`Envs::rows_into`] fills: enough that a task outweighs handing it out.
const ROWS_A_TASK: usize = 512;

/// `v` with room for `n` items, or the named error.
fn reserved<T>(n: usize) -> Result<Vec<T>, TwipError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| oom(n * core::mem::size_of::<T>()))?;
    Ok(v)
}

/// A lane's next robot, made apart from the batch so that many can be made at once.
enum Started<K: EnvKind<NX, NU>, const NX: usize, const NU: usize> {
    Ideal(K::Model, SVector<f64, NX>),
    /// Its model, rig, initial state and driver's largest duty. The rig is boxed: unboxed,
    /// every `Started` (an ideal robot's too) was the size of a rig (kilobytes of IMU state),
    /// and moving the new robots through a reset was 5 % of Track-v0's ideal step (`memmove`).
    Rig(K::Model, Box<<K::RigLanes as RigBlock>::Rig>, [f64; NX], Option<f64>),
}

/// The robot of `spec` for `key`: its model and initial state, and its rig, with `settle`
/// settled at rest there (which costs as much as many steps: robots are made side by side).
fn make<K: EnvKind<NX, NU>, const NX: usize, const NU: usize>(spec: &K, key: (u64, u64), settle: bool) -> Result<Started<K, NX, NU>, TwipError> {
    let Drawn { params, model, x0 } = spec.draw(key)?;
    for (index, &value) in x0.iter().enumerate() {
        if !value.is_finite() {
            return Err(TwipError::NonFinite { name: "x0", index, value });
        }
    }
    let Some(realism_for) = spec.realism() else { return Ok(Started::Ideal(model, x0)) };
    let realism = Realism { seed: noise_seed(key.0), stream: key.1, ..realism_for(&params)? };
    let pwm_max = realism.motor.map(|m| m.motor(&params)).transpose()?.map(|m| m.pwm_max());
    let p = spec.period();
    let mut rig = K::rig(&realism, &model, p.dt)?;
    if settle {
        K::RigLanes::settle(&mut [(&mut rig, x0.into())], seconds(&p));
    }
    Ok(Started::Rig(model, Box::new(rig), x0.into(), pwm_max))
}

/// The control period [s].
fn seconds(p: &Period) -> f64 {
    p.dt * p.substeps as f64
}

/// The rig robots of lanes `first..` (at most [`LANES`]) for keys (l, 0), started at rest.
fn rig_block<K: EnvKind<NX, NU>, const NX: usize, const NU: usize>(spec: &K, first: usize, n: usize) -> Result<RigRobots<K, NX, NU>, TwipError> {
    let (mut built, mut x0, mut pwm_max) = (Vec::new(), [[0.0; NX]; LANES], [None; LANES]);
    for j in 0..LANES.min(n - first) {
        // `start` settles the sensors itself.
        let Started::Rig(model, rig, x, max) = make::<K, NX, NU>(spec, ((first + j) as u64, 0), false)? else {
            unreachable!("a spec with a realism makes rig robots")
        };
        built.push(Some((model, *rig)));
        (x0[j], pwm_max[j]) = (x, max);
    }
    let p = spec.period();
    let Some(mut lanes) = K::RigLanes::start(built, x0, p.dt, seconds(&p))? else {
        unreachable!("a block has at least one robot")
    };
    // The firmware's first read, at t = 0: the first observation.
    lanes.read_at(&[0.0; LANES]);
    Ok(RigRobots { lanes, steps: [0; LANES], pwm_max })
}

#[allow(private_bounds)]
impl<K: EnvKind<NX, NU>, const NX: usize, const NU: usize> Envs<K, NX, NU> {
    /// `n` robots, lane i keyed (i, 0) until it is reset with a seed of its own.
    pub fn new(spec: K, n: usize, threads: usize) -> Result<Self, TwipError> {
        let keys = super::robot::keys(n)?;
        spec.period().validate()?;
        spec.validate()?;
        let pool = Arc::new(super::pool(threads)?);
        let robots = match spec.realism() {
            None => {
                let blocks = n.div_ceil(LANES);
                let mut v = reserved::<IdealBlock<K, NX, NU>>(blocks)?;
                let models = [spec.nominal()?; LANES];
                v.extend((0..blocks).map(|_| IdealBlock { plants: K::plants(&models), x: [[0.0; LANES]; NX] }));
                Robots::Ideal(v)
            }
            Some(_) => {
                let mut v = reserved::<RigRobots<K, NX, NU>>(n.div_ceil(LANES))?;
                let made: Result<Vec<_>, _> = pool.install(|| (0..n).step_by(LANES).collect::<Vec<_>>().into_par_iter().map(|first| rig_block(&spec, first, n)).collect());
                v.extend(made?);
                Robots::Rig(v)
            }
        };
        let mut periods = reserved(n)?;
        periods.resize(n, 0);
        let mut at_periods = reserved(1)?;
        at_periods.push(spec.at_time(0.0));
        let mut envs = Self { spec, n, keys, periods, at_periods, robots, pool };
        if !envs.has_rig() {
            for l in 0..n {
                envs.start(l, (l as u64, 0))?;
            }
        }
        Ok(envs)
    }

    pub fn len(&self) -> usize {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    pub fn spec(&self) -> &K {
        &self.spec
    }

    /// Whether the robots run through a rig.
    pub fn has_rig(&self) -> bool {
        matches!(self.robots, Robots::Rig(_))
    }

    /// Lane `l`'s key (seed, episode).
    pub fn key(&self, l: usize) -> (u64, u64) {
        self.keys[l]
    }

    /// Lane `l`'s time in its episode [s].
    pub fn time(&self, l: usize) -> f64 {
        self.time_after(self.periods[l])
    }

    /// The time [s] after `k` control periods.
    fn time_after(&self, k: u64) -> f64 {
        let p = self.spec.period();
        k as f64 * p.substeps as f64 * p.dt
    }

    /// [`EnvKind::at_time`] at lane `l`'s time: made once per period count.
    pub(crate) fn at_period(&self, l: usize) -> K::AtTime {
        let k = self.periods[l];
        match self.at_periods.get(k as usize) {
            Some(&shared) => shared,
            None => self.spec.at_time(self.time_after(k)),
        }
    }

    /// Starts lane `l`'s next episode: with `seed`, episode 0 of that seed; else the next
    /// episode of its seed. On an error (a draw the model refuses) the lane is unchanged.
    pub fn reset(&mut self, l: usize, seed: Option<u64>) -> Result<(), TwipError> {
        if l >= self.n {
            return Err(TwipError::InvalidParameter { name: "lane", value: l as f64, reason: "past the last robot" });
        }
        let (s, e) = self.keys[l];
        self.start(l, seed.map_or((s, e.wrapping_add(1)), |s| (s, 0)))
    }

    /// Starts the next episode of each lane of `lanes` in turn, as [`Self::reset`] one by one
    /// would (`seeds`: one per lane, or None), with the new robots made side by side on the
    /// batch's threads: a rig's start (its estimator's settle) costs as much as many steps.
    /// On an error the lanes before the failing one are reset, it and those after unchanged.
    pub fn reset_many(&mut self, lanes: &[usize], seeds: Option<&[u64]>) -> Result<(), TwipError> {
        if let Some(s) = seeds.filter(|s| s.len() != lanes.len()) {
            return Err(TwipError::InvalidParameter { name: "seeds", value: s.len() as f64, reason: "one seed per lane reset" });
        }
        let mut sorted = reserved::<usize>(lanes.len())?;
        sorted.extend_from_slice(lanes);
        sorted.sort_unstable();
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            // A lane reset twice starts two episodes in turn: one by one.
            return lanes.iter().enumerate().try_for_each(|(i, &l)| self.reset(l, seeds.map(|s| s[i])));
        }
        let mut keys = reserved::<(u64, u64)>(lanes.len())?;
        let mut past_the_end = None;
        for (i, &l) in lanes.iter().enumerate() {
            if l >= self.n {
                past_the_end = Some(TwipError::InvalidParameter { name: "lane", value: l as f64, reason: "past the last robot" });
                break;
            }
            let (s, e) = self.keys[l];
            keys.push(seeds.map_or((s, e.wrapping_add(1)), |s| (s[i], 0)));
        }
        let Self { spec, n, keys: lane_keys, periods, robots, pool, .. } = self;
        let (spec, period, blocks) = (&*spec, seconds(&spec.period()), n.div_ceil(LANES));
        // Each robot made, settled and put in its lane: the robots up to the first one
        // refused, each block's side by side.
        // Ideal robots are a draw and a model each, about a microsecond: few of them are made
        // on this thread, not handed to the pool.
        let here = matches!(robots, Robots::Ideal(_)) && keys.len() < IDEAL_MADE_HERE;
        let mut run = || -> Option<TwipError> {
            let one = |&key| make::<K, NX, NU>(spec, key, false);
            let mut made: Vec<_> = if here { keys.iter().map(one).collect() } else { keys.par_iter().map(one).collect() };
            if let Robots::Rig(_) = robots {
                // The rigs' settles, side by side a set of the settle's lanes at a time (a
                // task each, which the threads share out evenly).
                made.par_chunks_mut(SETTLE_LANES).for_each(|robots| {
                    let mut rigs: Vec<_> = robots.iter_mut().filter_map(|r| if let Ok(Started::Rig(_, rig, x0, _)) = r { Some((&mut **rig, *x0)) } else { None }).collect();
                    K::RigLanes::settle(&mut rigs, period);
                });
            }
            let mut per_block: Vec<Vec<(usize, Started<K, NX, NU>)>> = (0..blocks).map(|_| Vec::new()).collect();
            let mut refused = None;
            for ((&l, &key), robot) in lanes.iter().zip(&keys).zip(made) {
                match robot {
                    Ok(robot) => {
                        (lane_keys[l], periods[l]) = (key, 0);
                        per_block[l / LANES].push((l % LANES, robot));
                    }
                    Err(e) => {
                        refused = Some(e);
                        break;
                    }
                }
            }
            match robots {
                Robots::Ideal(blocks) => blocks.iter_mut().zip(per_block).for_each(|(block, robots)| robots.into_iter().for_each(|(j, r)| block.put(j, r))),
                // A rig robot's restart (its lanes' plants made anew, its IMUs' first sample).
                Robots::Rig(blocks) => blocks.par_iter_mut().zip(per_block).for_each(|(block, robots)| robots.into_iter().for_each(|(j, r)| block.put(j, r))),
            }
            refused
        };
        // One trip to the threads for all of it, or none: a trip costs ~10-15 us of CPU (the
        // threads woken and waited for), and three trips were ~45 us a reset of no lanes.
        let refused = if here { run() } else { pool.install(run) };
        refused.or(past_the_end).map_or(Ok(()), Err)
    }

    /// Lane `l`'s robot and initial state for `key`, and its state set.
    fn start(&mut self, l: usize, key: (u64, u64)) -> Result<(), TwipError> {
        let robot = make::<K, NX, NU>(&self.spec, key, true)?;
        let (b, j) = (l / LANES, l % LANES);
        match &mut self.robots {
            Robots::Ideal(blocks) => blocks[b].put(j, robot),
            Robots::Rig(blocks) => blocks[b].put(j, robot),
        }
        (self.keys[l], self.periods[l]) = (key, 0);
        Ok(())
    }

    /// `f(self)` on the batch's threads, in one trip: the steps, resets and rows it asks for
    /// run there as they come (a call into the pool from one of its own threads runs in
    /// place), not each a trip of its own that wakes the threads and waits for them.
    pub fn in_one_trip<R: Send>(&mut self, f: impl FnOnce(&mut Self) -> R + Send) -> R {
        let pool = Arc::clone(&self.pool);
        pool.install(|| f(self))
    }

    /// `row(self, l)` of every lane `l` into `out` (`W` values a lane, lane after lane), on
    /// the batch's threads: the numbers one by one would give (each row its own).
    pub fn rows_into<const W: usize>(&self, out: &mut [f64], row: impl Fn(&Self, usize) -> [f64; W] + Sync) -> Result<(), TwipError> {
        if out.len() != W * self.n {
            return Err(TwipError::Shape { name: "rows", expected: (self.n, W), got: (out.len() / W.max(1), W) });
        }
        self.pool.install(|| {
            out.par_chunks_mut(W * ROWS_A_TASK).enumerate().for_each(|(c, rows)| {
                for (i, r) in rows.chunks_exact_mut(W).enumerate() {
                    r.copy_from_slice(&row(self, c * ROWS_A_TASK + i));
                }
            })
        });
        Ok(())
    }

    /// Lane `l`'s true state.
    pub fn state(&self, l: usize) -> SVector<f64, NX> {
        match &self.robots {
            Robots::Ideal(blocks) => {
                let (b, j) = (l / LANES, l % LANES);
                SVector::from_fn(|i, _| blocks[b].x[i][j])
            }
            Robots::Rig(blocks) => SVector::from_fn(|i, _| blocks[l / LANES].lanes.state()[i][l % LANES]),
        }
    }

    /// Lane `l`'s state as its controller sees it: the state (ideal plant) or the sensors'
    /// last reading.
    pub fn measured(&self, l: usize) -> SVector<f64, NX> {
        match &self.robots {
            Robots::Ideal(_) => self.state(l),
            Robots::Rig(blocks) => SVector::from_fn(|i, _| blocks[l / LANES].lanes.reading()[i][l % LANES]),
        }
    }

    /// One control period of every robot under `actions` (`NU` per robot, robot after
    /// robot); `fell[l]`: lane l fell (or diverged) during it. Every action must be finite
    /// (else nothing moves).
    pub fn step(&mut self, actions: &[f64], fell: &mut [bool]) -> Result<(), TwipError> {
        if actions.len() != NU * self.n || fell.len() != self.n {
            let got = if fell.len() != self.n { (fell.len(), NU) } else { (actions.len() / NU, NU + actions.len() % NU) };
            return Err(TwipError::Shape { name: "actions", expected: (self.n, NU), got });
        }
        if let Some(index) = actions.iter().position(|a| !a.is_finite()) {
            return Err(TwipError::NonFinite { name: "action", index, value: actions[index] });
        }
        let period = self.spec.period();
        let n = self.n;
        match &mut self.robots {
            Robots::Ideal(blocks) => self.pool.install(|| {
                blocks.par_iter_mut().zip(fell.par_chunks_mut(LANES)).enumerate().for_each(|(b, (block, fell))| {
                    let start = b * LANES;
                    let mut u = [[0.0; LANES]; NU];
                    for l in start..(start + LANES).min(n) {
                        for (i, ui) in u.iter_mut().enumerate() {
                            ui[l - start] = actions[NU * l + i];
                        }
                    }
                    let out = advance_block(&block.plants, &mut block.x, &u, period.substeps, period.dt, period.fall_limit);
                    fell.copy_from_slice(&out[..fell.len()]);
                })
            }),
            Robots::Rig(blocks) => self.pool.install(|| {
                blocks.par_iter_mut().zip(fell.par_chunks_mut(LANES)).enumerate().for_each(|(b, (block, fell))| {
                    let start = b * LANES;
                    // The action as the plants take it: a duty rounded and saturated as the
                    // firmware writes it, or the model's input.
                    let mut drive = [[0.0; LANES]; NU];
                    for l in start..(start + LANES).min(n) {
                        for (i, di) in drive.iter_mut().enumerate() {
                            let a = actions[NU * l + i];
                            di[l - start] = block.pwm_max[l - start].map_or(a, |max| a.round().clamp(-max, max));
                        }
                    }
                    block.lanes.hold_drive(&drive);
                    let out = advance_rig(&mut block.lanes, &mut block.steps, period);
                    fell.copy_from_slice(&out[..fell.len()]);
                })
            }),
        }
        for p in &mut self.periods {
            *p += 1;
        }
        // No lane has run more periods than the batch has stepped: one more entry at most.
        let k = self.at_periods.len();
        if k < AT_PERIODS && self.periods.iter().any(|&p| p as usize >= k) && self.at_periods.try_reserve(1).is_ok() {
            let shared = self.spec.at_time(self.time_after(k as u64));
            self.at_periods.push(shared);
        }
        Ok(())
    }
}
