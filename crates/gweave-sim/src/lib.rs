//! The gweave virtual printer.
pub mod kinematics;
pub mod limits;
pub mod planner;
pub mod stepper;
