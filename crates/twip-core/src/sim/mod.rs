//! The closed-loop runner, its logs and the metrics it accumulates while it runs.
#[cfg(feature = "alloc")]
pub mod log;
pub mod metrics;
pub mod runner;
pub mod tracking_metrics;
