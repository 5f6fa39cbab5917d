//! The gweave virtual printer.
pub mod heater;
pub mod thermistor;
