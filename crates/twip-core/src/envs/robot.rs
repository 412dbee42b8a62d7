//! What both envs' batches step: a block of [`LANES`] robots on an ideal lane plant or
//! through their rigs on the rig's lanes, for one control period under a held action.
use crate::sweep::block::multiversioned;
use crate::sweep::lanes::{mask, Lanes, LANES};
use crate::TwipError;

/// A lane plant the ideal kernel advances: the 2-DOF sweep's or the 3-DOF one's.
pub trait LanePlant {
    /// The state, one array of lanes per entry.
    type State: Copy + AsRef<[Lanes]> + AsMut<[Lanes]>;
    /// The inputs, one array of lanes per input.
    type Input;
    /// The state entry of the pitch φ (the fall test).
    const PITCH: usize;
    /// One RK4 step on every lane, into `next`; only the `live` lanes' new states count (the
    /// sweeps' fast step, checked over them).
    fn rk4_lanes(&self, x: &Self::State, u: &Self::Input, dt: f64, live: &[bool; LANES], next: &mut Self::State);
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
    // Lane by lane, each lane's entries in turn: one loop over the lanes whose body the
    // compiler makes vector instructions across them, as the RK4 loop. Written entry by entry
    // (a loop over the lanes for each entry) with `bool` flags, the AVX-512 copy tested and
    // selected with gathers and scalar moves: a third of Track-v0's period (`perf annotate`).
    let mut alive = [u64::MAX; LANES];
    // Each step's new state, written in place (as the sweeps' loop keeps it).
    let mut next = *x;
    for _ in 0..steps {
        plants.rk4_lanes(x, u, dt, &alive.map(|a| a != 0), &mut next);
        let (next, x) = (next.as_ref(), x.as_mut());
        for l in 0..LANES {
            let mut take = alive[l];
            for entry in next {
                take &= mask(entry[l].is_finite());
            }
            for (xi, ni) in x.iter_mut().zip(next) {
                xi[l] = f64::from_bits((ni[l].to_bits() & take) | (xi[l].to_bits() & !take));
            }
            alive[l] = take & mask(next[P::PITCH][l].abs() <= fall_limit);
        }
    }
    alive.map(|a| a == 0)
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

/// A block of [`LANES`] robots through their rigs, the rig's lanes (the 2-DOF or the
/// 3-DOF one's), each lane at its own step: its robot is started anew apart from the others.
pub trait RigBlock: Sized + Send + Sync {
    type Model: Copy + Send;
    type Rig: Send;
    /// The state (one array of lanes per entry), one lane's, and the plants' input (one
    /// array of lanes per input).
    type State: Copy + AsRef<[Lanes]> + AsMut<[Lanes]>;
    type State1;
    type Drive;
    /// The rigs `built` (None: an idle lane) at rest in `x0[l]`, plant steps of `dt`,
    /// control periods of `period` [s] (the estimators settle on them).
    fn start(built: Vec<Option<(Self::Model, Self::Rig)>>, x0: [Self::State1; LANES], dt: f64, period: f64) -> Result<Option<Self>, TwipError>;
    /// Each rig's sensors settled at rest in its `x0` (reads every `period` [s]), as `start`
    /// settles a lane's: apart from the block, many robots side by side.
    fn settle(robots: &mut [(&mut Self::Rig, Self::State1)], period: f64);
    /// Lane `l` runs `rig` ([`Self::settle`]d) from rest in `x0`, as `start` starts a lane.
    fn restart(&mut self, l: usize, model: Self::Model, rig: Self::Rig, x0: Self::State1);
    /// The input held from now on (a period late with a delay).
    fn hold_drive(&mut self, drive: &Self::Drive);
    /// One plant step, lane l at its step `ks[l]`; the state after it (`state` moves only
    /// where the caller takes it).
    fn step_at<const COPY: u8>(&mut self, ks: &[usize; LANES]) -> Self::State;
    fn state(&self) -> &Self::State;
    fn state_mut(&mut self) -> &mut Self::State;
    /// The sensors' reading, lane l at its time `ts[l]`, kept for [`Self::reading`].
    fn read_at(&mut self, ts: &Lanes);
    fn reading(&self) -> &Self::State;
}

multiversioned! {
    /// One control period of a block of rig robots under the input held: `substeps` plant
    /// steps, lane l from its step `steps[l]` (advanced), then the sensors' read; returns
    /// the lanes that fell (or diverged). A lane that falls keeps its first state past the
    /// limit (a non-finite one is not taken: its last finite state stays) and moves no more
    /// this period, as `runner::run_loop` stops there.
    pub fn advance_rig, advance_rig_avx512, advance_rig_avx2, advance_rig_baseline = advance_rig_block<R: RigBlock; const COPY>(
        lanes: &mut R,
        steps: &mut [usize; LANES],
        period: Period,
    ) -> [bool; LANES]
}

#[inline(always)]
fn advance_rig_block<R: RigBlock, const COPY: u8>(lanes: &mut R, steps: &mut [usize; LANES], period: Period) -> [bool; LANES] {
    let mut alive = [true; LANES];
    for _ in 0..period.substeps {
        let before = *lanes.state();
        let next = lanes.step_at::<COPY>(steps);
        let (next, x) = (next.as_ref(), lanes.state_mut().as_mut());
        for l in 0..LANES {
            if !alive[l] {
                // Fallen: what the step did between steps is undone too.
                for (xi, bi) in x.iter_mut().zip(before.as_ref()) {
                    xi[l] = bi[l];
                }
                continue;
            }
            steps[l] += 1;
            let finite = next.iter().all(|entry| entry[l].is_finite());
            for (xi, ni) in x.iter_mut().zip(next) {
                xi[l] = if finite { ni[l] } else { xi[l] };
            }
            alive[l] = finite && next[period.pitch][l].abs() <= period.fall_limit;
        }
    }
    lanes.read_at(&steps.map(|k| period.dt * k as f64));
    alive.map(|a| !a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::params::RobotParams;
    use crate::model::planar::PlanarModel;
    use crate::sweep::block::PlanarPlants;

    /// Every kernel copy of the ideal block's period gives the same states and falls, bit
    /// for bit: lanes that stay up, lanes that fall (their pitch past the limit) and a lane
    /// whose input is not finite; each robot its own.
    #[test]
    fn every_copy_gives_the_same_bits() {
        let models: [PlanarModel<f64>; LANES] = core::array::from_fn(|l| {
            let mut params = RobotParams::balanbot();
            params.com_height *= 0.8 + 0.03 * l as f64;
            PlanarModel::new(params).unwrap()
        });
        let plants = PlanarPlants::new(&models);
        // Every fourth lane starts past the limit (falls at once), every fourth at rest upright
        // under no input (never falls), the others leaning and pushed; lane 6's input is NaN.
        let x0: [Lanes; 7] = core::array::from_fn(|i| {
            core::array::from_fn(|l| match (l % 4, i) {
                (0, 3) => 0.6,
                (1, _) => 0.0,
                (_, 3) => 0.03 * l as f64 - 0.24,
                _ => 0.01 * (i + l) as f64,
            })
        });
        let mut u: [Lanes; 2] = core::array::from_fn(|w| core::array::from_fn(|l| if l % 4 == 1 { 0.0 } else { 0.002 * l as f64 - 0.01 * w as f64 }));
        u[1][6] = f64::NAN;
        let period = |run: &dyn Fn(&mut [Lanes; 7]) -> [bool; LANES]| {
            let mut x = x0;
            let falls: alloc::vec::Vec<[bool; LANES]> = (0..200).map(|_| run(&mut x)).collect();
            (x.map(|lanes| lanes.map(f64::to_bits)), falls)
        };
        let base = period(&|x| advance_block_baseline(&plants, x, &u, 5, 1e-3, 0.5));
        let fell: [bool; LANES] = core::array::from_fn(|l| base.1.iter().any(|f| f[l]));
        assert!(fell[6] && fell.iter().any(|&f| !f) && fell.iter().filter(|&&f| f).count() > 1, "want both outcomes: {fell:?}");
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                assert!(period(&|x| unsafe { advance_block_avx2(&plants, x, &u, 5, 1e-3, 0.5) }) == base, "AVX2 copy");
            }
            if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
                assert!(period(&|x| unsafe { advance_block_avx512(&plants, x, &u, 5, 1e-3, 0.5) }) == base, "AVX-512 copy");
            }
        }
    }
}
