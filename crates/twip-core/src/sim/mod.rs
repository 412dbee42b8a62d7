//! The closed-loop runner, its logs and the metrics it accumulates while it runs.
#[cfg(feature = "alloc")]
pub mod log;
pub(crate) mod closed_loop;
pub(crate) mod drive_metrics;
pub(crate) mod held;
pub mod metrics;
pub mod runner;
pub mod tracking_metrics;

/// Names a summary's metrics once: `NAMES` and `named()` (name, value) pairs from one field
/// list, so the bindings and the sweeps read every metric's name from here.
macro_rules! named_metrics {
    ($ty:ident { $($field:ident),+ $(,)? }) => {
        impl<T: Copy> $ty<T> {
            pub const NAMES: &'static [&'static str] = &[$(stringify!($field)),+];

            /// (name, value) of every metric, in [`Self::NAMES`]' order.
            pub fn named(&self) -> [(&'static str, T); [$(stringify!($field)),+].len()] {
                [$((stringify!($field), self.$field)),+]
            }
        }
    };
}
pub(crate) use named_metrics;
