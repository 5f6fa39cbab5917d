//! The gweave virtual printer.
pub mod autotune;
pub mod control;
pub mod heater;
pub mod protection;
pub mod thermal;
pub mod thermistor;
