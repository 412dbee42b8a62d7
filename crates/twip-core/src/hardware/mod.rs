//! The robot's hardware around the plant: DC motor and motor driver, gearbox backlash, the IMU and tilt
//! estimators, encoders, disturbances, and the realism rig that puts them in the loop.
pub mod backlash;
pub mod disturbance;
pub mod driver;
pub mod encoder;
pub mod imu;
pub mod motor;
pub mod planar_rig;
pub mod realism;
pub mod rig_plant;
pub mod settle;
pub mod tilt;
