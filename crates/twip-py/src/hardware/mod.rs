//! The robot's hardware around the plant: the motor, and the realism rig settings.
pub mod motor;
pub mod realism;
