//! What both envs' batches step: a block of [`LANES`] robots on an ideal lane plant, and
//! one robot through its own rig, each for one control period under a held action.
use nalgebra::SVector;

use crate::hardware::realism::Rig;
use crate::model::integrate::rk4_step_from_k1;
use crate::sim::runner::{Plant, Sensor};
use crate::sweep::block::multiversioned;
use crate::sweep::lanes::{Lanes, LANES};
use crate::TwipError;

/// A lane plant the ideal kernel advances: the 2-DOF sweep's or the 3-DOF one's.
pub trait LanePlant {
    /// The state, one array of lanes per entry.
    type State: Copy + AsRef<[Lanes]> + AsMut<[Lanes]>;
    /// The inputs, one array of lanes per input.
    type Input;
    /// The state entry of the pitch φ (the fall test).
    const PITCH: usize;
    fn rk4_lanes(&self, x: &Self::State, u: &Self::Input, dt: f64) -> Self::State;
}

multiversioned! {
    /// Advances a block of robots `steps` plant steps under the inputs `u`; returns the
    /// lanes that fell (or diverged). A lane that falls keeps its first state past the
    /// limit (a non-finite one is not taken) and moves no more.
    pub fn advance_block, advance_block_avx512, advance_block_avx2, advance_block_baseline = advance<P: LanePlant>(
        plants: &P,
        x: &mut P::State,
        u: &P::Input,
        steps: usize,
        dt: f64,
        fall_limit: f64,
    ) -> [bool; LANES]
}

#[inline(always)]
fn advance<P: LanePlant>(plants: &P, x: &mut P::State, u: &P::Input, steps: usize, dt: f64, fall_limit: f64) -> [bool; LANES] {
    let mut alive = [true; LANES];
    for _ in 0..steps {
        let next = plants.rk4_lanes(x, u, dt);
        let (next, x) = (next.as_ref(), x.as_mut());
        for l in 0..LANES {
            let finite = next.iter().all(|entry| entry[l].is_finite());
            let take = alive[l] & finite;
            for (xi, ni) in x.iter_mut().zip(next) {
                xi[l] = if take { ni[l] } else { xi[l] };
            }
            alive[l] = take & (next[P::PITCH][l].abs() <= fall_limit);
        }
    }
    alive.map(|a| !a)
}

/// One robot through its rig between two controller updates.
pub struct RigRobot<P, S, A, const NX: usize, const NU: usize> {
    pub rig: Rig<P, S, A>,
    pub x: SVector<f64, NX>,
    /// The input applied over this period, and the one waiting (a delayed rig's).
    u: SVector<f64, NU>,
    pending: SVector<f64, NU>,
    /// The sensors' reading at the last update (reading moves the estimator).
    pub reading: SVector<f64, NX>,
    pub steps: u64,
    /// Largest duty (counts) with a motor driver; None: the input is the model's.
    pwm_max: Option<f64>,
}

/// How a rig robot's period runs: the plant step, steps per period, the fall test.
#[derive(Clone, Copy, Debug)]
pub struct Period {
    pub dt: f64,
    pub substeps: usize,
    pub pitch: usize,
    pub fall_limit: f64,
}

impl Period {
    pub fn validate(&self) -> Result<(), TwipError> {
        let bad = |name, value: f64, reason| Err(TwipError::InvalidParameter { name, value, reason });
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return bad("dt", self.dt, "must be finite and > 0");
        }
        if self.substeps == 0 {
            return bad("substeps", 0.0, "must be >= 1 (the control period is substeps * dt)");
        }
        if !(self.fall_limit.is_finite() && self.fall_limit > 0.0) {
            return bad("fall_limit", self.fall_limit, "must be finite and > 0");
        }
        Ok(())
    }
}

/// The error a batch too large to allocate gives.
pub(super) fn oom(bytes: usize) -> TwipError {
    TwipError::OutOfMemory { name: "num_envs", bytes: bytes as u64 }
}

/// Most robots in one batch: 2^24 (16.7 M), checked before anything is allocated.
pub const MAX_ENVS: usize = 1 << 24;

/// `num_envs` checked, and the keys (lane i: (i, 0)) allocated.
pub(super) fn keys(n: usize) -> Result<alloc::vec::Vec<(u64, u64)>, TwipError> {
    if n == 0 || n > MAX_ENVS {
        return Err(TwipError::InvalidParameter { name: "num_envs", value: n as f64, reason: "must be in 1..=16777216" });
    }
    let mut keys = alloc::vec::Vec::new();
    keys.try_reserve_exact(n).map_err(|_| oom(n * 16))?;
    keys.extend((0..n as u64).map(|i| (i, 0)));
    Ok(keys)
}

impl<P: Plant<f64, NX, NU>, S: Sensor<f64, NX>, A, const NX: usize, const NU: usize> RigRobot<P, S, A, NX, NU> {
    /// The rig at rest in `x0`: its sensors settle (reads every `period`), sample the
    /// initial state and are read once, as `Rig::simulate` does before its first update.
    pub fn start(mut rig: Rig<P, S, A>, x0: SVector<f64, NX>, pwm_max: Option<f64>, period: f64) -> Self {
        let u = SVector::<f64, NU>::zeros();
        rig.sensors.settle(&x0, period);
        rig.sensors.sample(0.0, &x0, &rig.plant.deriv(&x0, &u));
        rig.sensors.shaft_offsets(rig.plant.shaft_offsets());
        let reading = rig.sensors.read(0.0, &x0);
        Self { rig, x: x0, u, pending: u, reading, steps: 0, pwm_max }
    }

    /// One control period under `action` (`run_loop`'s steps between two updates, then the
    /// next update's read); whether the robot fell (or diverged: its last finite state kept).
    pub fn step(&mut self, action: &[f64], p: Period) -> bool {
        let drive = SVector::<f64, NU>::from_fn(|i, _| match self.pwm_max {
            Some(max) => action[i].round().clamp(-max, max),
            None => action[i],
        });
        if self.rig.delay {
            self.u = self.pending;
            self.pending = drive;
        } else {
            self.u = drive;
        }
        let (dt, u) = (p.dt, self.u);
        let (plant, sensors) = (&mut self.rig.plant, &mut self.rig.sensors);
        let mut fell = false;
        for _ in 0..p.substeps {
            let t = dt * self.steps as f64;
            sensors.shaft_offsets(plant.shaft_offsets());
            let k1 = plant.between_steps_with_derivative(t, dt, &mut self.x, &u).unwrap_or_else(|| plant.deriv(&self.x, &u));
            sensors.sample(t, &self.x, &k1);
            let next = rk4_step_from_k1(&*plant, &self.x, &u, dt, &k1);
            plant.step_ended(&next);
            self.steps += 1;
            if !next.iter().all(|v| v.is_finite()) {
                fell = true;
                break;
            }
            self.x = next;
            if self.x[p.pitch].abs() > p.fall_limit {
                fell = true;
                break;
            }
        }
        // The sensors are read after a fall too: a final observation is a reading.
        sensors.shaft_offsets(plant.shaft_offsets());
        self.reading = sensors.read(dt * self.steps as f64, &self.x);
        fell
    }
}
