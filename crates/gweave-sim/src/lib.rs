//! The gweave virtual printer.
pub mod inkjet;
