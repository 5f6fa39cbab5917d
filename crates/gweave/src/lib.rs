//! gweave: a lossless, streaming G-code engine for unconventional 3D printers.

pub mod rotary;
