//! The gweave virtual printer.
pub mod autotune;
pub mod control;
pub mod estimate;
pub mod heater;
pub mod inkjet;
pub mod interp;
pub mod kinematics;
pub mod limits;
pub mod planner;
pub mod plot;
pub mod profile;
pub mod protection;
pub mod stepper;
pub mod thermal;
pub mod thermistor;
