//! The robot and its models: parameters, the 2-DOF and 3-DOF models, gearhead friction.
pub mod friction;
pub mod models;
pub mod params;
pub mod terrain;
