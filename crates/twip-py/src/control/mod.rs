//! Controllers and what they follow: LQR, fuzzy, the trackers, users' own controllers, speed schedules and trajectories.
pub mod fuzzy;
pub mod grade;
pub mod lqr;
pub mod schedule;
pub mod tracking;
pub mod trajectory;
pub mod user_controller;
