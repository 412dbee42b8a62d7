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

/// The most threads a sweep starts: more is a mistake (starting 10 000 took 80 s); a
/// cluster goes through Dask.
pub const MAX_THREADS: usize = 1024;

/// Runs samples `range` in blocks of `block`, with `threads` threads (0 = all cores, at
/// most [`MAX_THREADS`]).
/// `run_block` gets the sample indices of one block and a stop check, and returns their
/// metrics (of either sweep family) in order, `Ok(None)` if it stopped early, or an error:
/// then the other workers stop too and the run's result is an error (the first in sample
/// order of the blocks that ran; which ran depends on the threads), never samples left
/// "not run" as if stopped. Samples of blocks not finished when `progress.stop` was set
/// are `None`.
pub fn run<M, F>(
    range: Range<u64>,
    block: usize,
    threads: usize,
    progress: &Progress,
    run_block: F,
) -> Result<Vec<Option<M>>, TwipError>
where
    M: Clone + Send,
    F: Fn(Range<u64>, &dyn Fn() -> bool) -> Result<Option<Vec<M>>, TwipError> + Sync,
{
    if threads > MAX_THREADS {
        return Err(TwipError::InvalidParameter { name: "threads", value: threads as f64, reason: "at most 1024 threads (0: all cores)" });
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|_| TwipError::InvalidParameter { name: "threads", value: threads as f64, reason: "could not start a thread pool" })?;
    let block = block.max(1) as u64;
    // Sized by the caller's sample count: reserved fallibly (an error, not an abort), and
    // before the run, so that a count too large fails at once, not when the work is done.
    let count = (range.end - range.start) as usize;
    let mut results = Vec::new();
    results
        .try_reserve_exact(count)
        .map_err(|_| TwipError::OutOfMemory { name: "n", bytes: (count as u64).saturating_mul(core::mem::size_of::<Option<M>>() as u64) })?;
    let mut starts: Vec<u64> = Vec::new();
    starts
        .try_reserve_exact(((range.end - range.start) / block + 1) as usize)
        .map_err(|_| TwipError::OutOfMemory { name: "n", bytes: (range.end - range.start) / block * 8 })?;
    starts.extend((range.start..range.end).step_by(block as usize));
    let blocks: Vec<Result<Option<Vec<M>>, TwipError>> = pool.install(|| {
        // One task per block (`with_max_len(1)`): rayon otherwise halves the blocks only
        // until there are about twice as many pieces as threads (more where one is stolen)
        // and runs each piece whole, so the last can run alone (a profile of a 20,000-sample
        // fuzzy sweep on two cores: one thread for the last 0.19 of 1.59 s). Measured CPU
        // time / wall time of such sweeps, three in a process: fuzzy 1.93-1.97 -> 1.96-1.98, LQR
        // 1.90-1.91 -> 1.93-1.97.
        starts
            .par_iter()
            .with_max_len(1)
            .map(|&start| {
                if progress.stop.load(Ordering::Relaxed) {
                    return Ok(None);
                }
                let indices = start..(start + block).min(range.end);
                let stop = || progress.stop.load(Ordering::Relaxed);
                let Some(out) = run_block(indices.clone(), &stop).inspect_err(|_| progress.stop.store(true, Ordering::Relaxed))? else {
                    return Ok(None);
                };
                debug_assert_eq!(out.len() as u64, indices.end - indices.start);
                progress.done.fetch_add(out.len(), Ordering::Relaxed);
                Ok(Some(out))
            })
            .collect()
    });
    let blocks: Vec<Option<Vec<M>>> = blocks.into_iter().collect::<Result<_, _>>()?;
    for (b, start) in blocks.into_iter().zip(&starts) {
        let len = ((start + block).min(range.end) - start) as usize;
        match b {
            Some(metrics) => results.extend(metrics.into_iter().map(Some)),
            None => results.extend(core::iter::repeat_n(None, len)),
        }
    }
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec::Vec;

    type Blocks = Result<Option<Vec<f64>>, TwipError>;

    /// Each sample's index as its metric; blocks starting at `at` fail.
    fn failing_at(at: &'static [u64]) -> impl Fn(Range<u64>, &dyn Fn() -> bool) -> Blocks + Sync {
        move |r: Range<u64>, _: &dyn Fn() -> bool| {
            if at.contains(&r.start) {
                return Err(TwipError::InvalidParameter { name: "block", value: r.start as f64, reason: "fails in this test" });
            }
            Ok(Some(r.map(|i| i as f64).collect()))
        }
    }

    /// A block's error is the run's and it stops the other workers: never samples left
    /// "not run" as if a stop had been asked. One thread runs the blocks in order, so the
    /// first failing block's error is the one; more threads may reach the later one first.
    #[test]
    fn a_blocks_error_is_the_runs() {
        for threads in [1, 2, 4] {
            let progress = Progress::default();
            match run(0..1000, 10, threads, &progress, failing_at(&[300, 700])) {
                Err(TwipError::InvalidParameter { name: "block", value, .. }) => {
                    assert!(value == 300.0 || (threads > 1 && value == 700.0), "{threads} threads: block {value}")
                }
                other => panic!("{threads} threads: want a failing block's error, got {other:?}"),
            }
            assert!(progress.stop.load(Ordering::Relaxed), "{threads} threads: the workers were asked to stop");
        }
    }

    /// More than [`MAX_THREADS`] is an error naming the count and the limit, before any
    /// thread starts.
    #[test]
    fn too_many_threads_is_an_error_naming_the_limit() {
        match run(0..10, 1, MAX_THREADS + 1, &Progress::default(), failing_at(&[])) {
            Err(TwipError::InvalidParameter { name: "threads", value, reason }) => {
                assert_eq!(value, (MAX_THREADS + 1) as f64);
                assert!(reason.contains(&std::format!("{MAX_THREADS}")), "{reason}");
            }
            other => panic!("want a threads error, got {other:?}"),
        }
        assert!(run(0..10, 1, MAX_THREADS, &Progress::default(), failing_at(&[])).is_ok());
    }

    /// A block that stopped early leaves its samples `None`; the others keep their places.
    #[test]
    fn a_stopped_block_is_none_and_the_rest_in_place() {
        let got = run(0..95, 10, 2, &Progress::default(), |r: Range<u64>, _: &dyn Fn() -> bool| {
            Ok((r.start != 20).then(|| r.map(|i| i as f64).collect::<Vec<f64>>()))
        })
        .unwrap();
        assert_eq!(got.len(), 95);
        for (i, v) in got.iter().enumerate() {
            assert_eq!(*v, (!(20..30).contains(&i)).then_some(i as f64), "sample {i}");
        }
    }
}
