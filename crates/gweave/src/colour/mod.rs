//! Colour science for mixing extruders.
pub mod delta_e;
pub mod dialect;
mod font;
pub mod lab;
pub mod mix;
pub mod mixing;
pub mod palette;
pub mod purge;
pub mod solve;
pub mod srgb;
pub mod swatch;
