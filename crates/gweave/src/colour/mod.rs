//! Colour science for mixing extruders.
pub mod delta_e;
pub mod lab;
pub mod srgb;
