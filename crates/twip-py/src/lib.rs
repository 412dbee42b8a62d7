//! `twip._core`: the Python bindings of twip-core. Conversions and error mapping only.
use pyo3::prelude::*;

mod control;
mod convert;
mod errors;
mod linalg;
mod models;
mod params;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    linalg::register(m)?;
    m.add_class::<params::PyRobotParams>()?;
    m.add_class::<models::PySlopeModel>()?;
    m.add_class::<models::PyPlanarModel>()?;
    m.add_function(wrap_pyfunction!(models::rk4_step, m)?)?;
    m.add_class::<control::PySpeedSchedule>()?;
    m.add_class::<control::PyLqrController>()?;
    m.add_function(wrap_pyfunction!(control::simulate_raw, m)?)?;
    Ok(())
}
