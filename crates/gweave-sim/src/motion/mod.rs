//! Motion: what Marlin's `module/` folder calls the planner and the stepper, and what Klipper's
//! `toolhead.py` and `kinematics/cartesian.py` do, on a simulated clock.
//!
//! A requested move ([`kinematics`]: Cartesian, the length is the XYZ distance) goes to the
//! lookahead [`planner`], which gives it a trapezoidal speed profile under the machine's limits
//! ([`limits`], Marlin-only parts in [`marlin_limits`], a slicer's own in [`slicer_limits`]):
//! Marlin's `planner.cpp` (junction deviation or classic jerk, whole motor steps), Klipper's
//! `toolhead.py` (square corner velocity, minimum cruise ratio) or constant speed. The
//! [`stepper`] counts the exact motor steps of each block (Marlin's `stepper.cpp` Bresenham
//! order, E split across a mixing hotend's inputs). The [`estimate`] drives all of it from a file
//! for a print time; [`speed_trace`] keeps the planned speed over time for the chart.
pub(crate) mod estimate;
pub(crate) mod kinematics;
pub(crate) mod limits;
pub(crate) mod marlin_limits;
pub(crate) mod planner;
pub(crate) mod rounding;
pub(crate) mod slicer_limits;
pub(crate) mod speed_trace;
pub(crate) mod stepper;
