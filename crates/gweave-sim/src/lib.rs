//! The gweave virtual printer.
pub mod autotune;
pub mod control;
pub mod estimate;
pub mod heater;
pub mod inkjet;
pub mod kinematics;
pub mod limits;
pub mod planner;
pub mod protection;
pub mod pty;
pub mod serial;
pub mod stepper;
pub mod tcp;
pub mod thermal;
pub mod thermistor;
pub mod transport;
