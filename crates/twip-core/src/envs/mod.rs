//! Reinforcement-learning environments: many robots stepped together, one control period
//! per step, the action held over it (zero-order hold, RK4 at the plant step inside).
//!
//! Each robot is its own lane with its own key (seed, episode): its robot, slope and
//! initial state are the sweep's draw for that key (`sweep::draw`), its rig's noise the
//! stream `episode` under `sweep::rig::noise_seed(seed)`. A lane never reads another, so
//! the numbers are the same on any thread count and next to any neighbours.
pub mod balance;
mod batch;
mod robot;
pub mod track;

pub use balance::{BalanceEnvs, BalanceReward, BalanceSpec};
pub use batch::{Envs, RealismFor};
pub use robot::{Period, MAX_ENVS};
pub use track::{TrackEnvs, TrackReward, TrackSpec, TRACK_OBS};

use crate::TwipError;

/// A thread pool of `threads` workers (0: one per core).
pub(crate) fn pool(threads: usize) -> Result<rayon::ThreadPool, TwipError> {
    if threads > crate::sweep::parallel::MAX_THREADS {
        return Err(TwipError::InvalidParameter { name: "threads", value: threads as f64, reason: "at most 1024 threads (0: all cores)" });
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|_| TwipError::InvalidParameter { name: "threads", value: threads as f64, reason: "could not start a thread pool" })
}
