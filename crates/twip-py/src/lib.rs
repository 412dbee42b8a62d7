//! `twip._core`: the Python bindings of twip-core. Conversions and error mapping only.
//! Grouped as the core is: `model/`, `control/`, `hardware/`, `sim/`, `sweep/`, `sysid`,
//! with the shared conversions, errors and settings beside them.
use pyo3::prelude::*;

mod control;
mod convert;
mod discrete;
mod envs;
mod errors;
mod ffi;
mod hardware;
mod interrupt;
mod linalg;
mod model;
mod settings;
mod sim;
mod sweep;
mod sysid;

use control::{fuzzy, lqr, schedule, tracking, trajectory};
use hardware::{motor, realism};
use model::{friction, models, params};
use sim::{simulate, simulate_planar};
use sweep::planar as sweep_planar;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    sweep::check_kernel_copy()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    linalg::register(m)?;
    discrete::register(m)?;
    m.add_class::<params::PyRobotParams>()?;
    m.add_class::<models::PySlopeModel>()?;
    m.add_class::<models::PyPlanarModel>()?;
    m.add_class::<crate::model::terrain::PyTerrain>()?;
    m.add_class::<friction::PyFriction>()?;
    m.add_function(wrap_pyfunction!(models::rk4_step, m)?)?;
    m.add_class::<schedule::PySpeedSchedule>()?;
    m.add_class::<lqr::PyLqrController>()?;
    m.add_class::<fuzzy::PyTrapezoid>()?;
    m.add_class::<fuzzy::PyTriangle>()?;
    m.add_class::<fuzzy::PyGaussian>()?;
    m.add_class::<fuzzy::PyFuzzyBasis>()?;
    m.add_class::<fuzzy::PyFuzzyController>()?;
    m.add_function(wrap_pyfunction!(simulate::simulate_raw, m)?)?;
    realism::register(m)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_raw, m)?)?;
    m.add_function(wrap_pyfunction!(sysid::sysid_shoot, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_draw, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_noise_seed, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::check_sweep_model, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::sweep_kernel, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::kernel_copy, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::available_kernel_copies, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::use_kernel_copy, m)?)?;
    m.add("DEFAULT_FALL_LIMIT", twip_core::sim::runner::DEFAULT_FALL_LIMIT)?;
    m.add("MAX_THREADS", twip_core::sweep::parallel::MAX_THREADS)?;
    m.add("NORMAL_REACH", twip_core::sweep::NORMAL_REACH)?;
    m.add_function(wrap_pyfunction!(sweep::controller_fingerprint, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_planar::sweep_planar_raw, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_planar::sweep_planar_draw, m)?)?;
    m.add_class::<trajectory::PyCircle>()?;
    m.add_class::<trajectory::PyLine>()?;
    m.add_class::<trajectory::PyFigureEight>()?;
    m.add_class::<trajectory::PyWaypoints>()?;
    m.add_class::<motor::PyDcMotor>()?;
    m.add_class::<tracking::PyPidTracker>()?;
    m.add_class::<tracking::PySmcTracker>()?;
    m.add_class::<crate::control::grade::PyGradeFeedForward>()?;
    m.add_function(wrap_pyfunction!(simulate_planar::simulate_planar_raw, m)?)?;
    m.add_function(wrap_pyfunction!(ffi::ffi_record, m)?)?;
    m.add_function(wrap_pyfunction!(ffi::ffi_firmware, m)?)?;
    m.add_class::<envs::balance::PyBalanceBatch>()?;
    m.add_class::<envs::track::PyTrackBatch>()?;
    m.add("FFI_HEADER", ffi::HEADER)?;
    m.add("FFI_SOURCE_DIR", ffi::SOURCE_DIR)?;
    Ok(())
}
