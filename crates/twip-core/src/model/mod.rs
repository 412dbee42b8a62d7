//! The plant: the robot's parameters, the 2-DOF slope and 3-DOF planar models, the
//! dynamics trait, the one integrator (RK4) and the maths kernels they share.
pub mod dynamics;
pub mod friction;
pub mod integrate;
pub mod lane;
pub mod math;
pub mod params;
pub mod planar;
pub mod slope;
pub mod terrain;
pub mod terrain_model;
