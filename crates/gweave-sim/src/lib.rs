//! The gweave virtual printer.
pub mod estimate;
pub mod kinematics;
pub mod limits;
pub mod planner;
pub mod stepper;
