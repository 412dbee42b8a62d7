//! The runs: `simulate` for either model, the controller dispatch and the result dict.
pub mod dispatch;
pub(crate) mod drive;
pub mod run_result;
pub mod simulate;
pub mod simulate_planar;
