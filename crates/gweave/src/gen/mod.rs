//! Generators that write G-code from images and meshes.
//!
//! Binder-jet (inkjet) raster printing: a [`printhead::PrintheadProfile`] describes the
//! cartridge, [`bitmap`] loads 1-bit layer images, [`sl1`] reads PrusaSlicer SLA archives,
//! [`stl`] and [`slice_raster`] turn a mesh into layer images, and [`raster`] writes the
//! `M700`/`M578` G-code; [`raster_job`] runs a whole job (inputs to a timed, atomically written
//! file) for the CLI and Python alike.

mod band;
pub mod bitmap;
mod gcode_text;
pub(crate) mod image_files;
pub mod printhead;
pub mod raster;
pub mod raster_job;
pub mod recoat;
pub mod sl1;
pub mod slice_raster;
pub mod stl;
mod sweep;
