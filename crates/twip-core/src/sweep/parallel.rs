//! Runs the samples of a sweep on a pool of threads, in blocks, in any order, and puts
//! each result at its sample's place: the output does not depend on the thread count.
//! A shared flag stops the work between blocks (Ctrl-C); a counter reports progress.
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::TwipError;

/// Shared between the workers and whoever watches them.
#[derive(Debug, Default)]
pub struct Progress {
    /// Samples finished so far.
    pub done: AtomicUsize,
    /// Set to ask the workers to stop before their next block.
    pub stop: AtomicBool,
}

/// Runs samples `range` in blocks of `block`, with `threads` threads (0 = all cores).
/// `run_block` gets the sample indices of one block and a stop check, and returns their
/// metrics (of either sweep family) in order, or `None` if it stopped early. Samples of
/// blocks not finished when `progress.stop` was set are `None`.
pub fn run<M, F>(
    range: Range<u64>,
    block: usize,
    threads: usize,
    progress: &Progress,
    run_block: F,
) -> Result<Vec<Option<M>>, TwipError>
where
    M: Clone + Send,
    F: Fn(Range<u64>, &dyn Fn() -> bool) -> Option<Vec<M>> + Sync,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|_| TwipError::InvalidParameter { name: "threads", value: threads as f64, reason: "could not start a thread pool" })?;
    let block = block.max(1) as u64;
    let mut starts: Vec<u64> = Vec::new();
    starts
        .try_reserve_exact(((range.end - range.start) / block + 1) as usize)
        .map_err(|_| TwipError::OutOfMemory { name: "n", bytes: (range.end - range.start) / block * 8 })?;
    starts.extend((range.start..range.end).step_by(block as usize));
    let blocks: Vec<Option<Vec<M>>> = pool.install(|| {
        starts
            .par_iter()
            .map(|&start| {
                if progress.stop.load(Ordering::Relaxed) {
                    return None;
                }
                let indices = start..(start + block).min(range.end);
                let stop = || progress.stop.load(Ordering::Relaxed);
                let out = run_block(indices.clone(), &stop)?;
                debug_assert_eq!(out.len() as u64, indices.end - indices.start);
                progress.done.fetch_add(out.len(), Ordering::Relaxed);
                Some(out)
            })
            .collect()
    });
    // Sized by the caller's sample count: reserved fallibly (an error, not an abort).
    let count = (range.end - range.start) as usize;
    let mut results = Vec::new();
    results
        .try_reserve_exact(count)
        .map_err(|_| TwipError::OutOfMemory { name: "n", bytes: (count as u64).saturating_mul(core::mem::size_of::<Option<M>>() as u64) })?;
    for (b, start) in blocks.into_iter().zip(&starts) {
        let len = ((start + block).min(range.end) - start) as usize;
        match b {
            Some(metrics) => results.extend(metrics.into_iter().map(Some)),
            None => results.extend(core::iter::repeat_n(None, len)),
        }
    }
    Ok(results)
}
