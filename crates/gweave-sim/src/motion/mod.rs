//! Motion.
pub mod estimate;
pub mod kinematics;
pub mod limits;
pub mod marlin_limits;
pub mod planner;
pub(crate) mod rounding;
pub mod slicer_limits;
pub mod speed_trace;
pub mod stepper;
