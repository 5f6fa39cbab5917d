//! Pictures as pixels, below every module that draws: the one rasteriser (`raster`:
//! `tiny-skia`), the embedded font ([`text`]) and the one PNG writer (`png_file`).
//!
//! Previews and rotary pictures (`render/`), mix calibration swatches (`colour::swatch`), layer
//! masks (`gen::bitmap`) and the simulator's charts all draw and encode through here, so a
//! picture gweave writes has one anti-aliasing, one typeface and one encoder.

pub(crate) mod png_file;
pub(crate) mod raster;
pub mod text;

pub use png_file::{decode, encode, write_png, Pixels};
pub use raster::{Image, Painter};
