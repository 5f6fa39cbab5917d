//! The gweave virtual printer.
pub mod finish;
pub mod inkjet;
pub mod interp;
pub mod link;
pub mod motion;
pub mod plot;
pub mod profile;
pub mod thermal;
