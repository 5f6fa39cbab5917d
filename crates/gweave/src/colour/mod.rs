//! Colour science for mixing extruders: which filament ratios print which colour,
//! and how to tell the firmware.
//!
//! - `srgb`: `#RRGGBB`, and its way into the `palette` crate's colour spaces. The sRGB transfer
//!   curve, CIE XYZ (D65), CIELAB ([`Lab`]) and CIEDE2000 ([`Ciede2000`], how different two
//!   colours look) are `palette`'s; what is gweave's own is the pigment model below.
//! - `mix`: `Mix`, validated and normalised ratios per input.
//! - `spectrum`: the CIE 1931 observer and D65 on a 380-730 nm grid; reflectance -> sRGB.
//! - `reflectance`: the smoothest reflectance spectrum of an sRGB colour (Burns' LHTSS).
//! - `mixing`: `MixingModel`, the colour a mix of given filaments prints
//!   (two-constant Kubelka-Munk on spectra, like pigments).
//! - `predict`: a mix's predicted colour as `#rrggbb` and CIELAB (`gweave mix --predict`).
//! - `solve`: the mix whose predicted colour is nearest a target.
//! - `pigments`: the default filaments (`CMYW_FILAMENTS`) and their fitted reflectance spectra.
//! - `named_mixes`: the mixing post-processor seed's (`docs/seeds.md`) 17 named CMY(K) colours
//!   plus user mixes from TOML (its `Palette`; not the `palette` crate).
//! - `dialect`: Marlin `M163`/`M164`/`M165` and RepRapFirmware `M563`/`M567`
//!   lines from a mix, and `MixingState` following those commands in a stream.
//! - `shape`: a filament's spectral shape, how its spectrum departs from the smoothest one.
//! - `fit`: filament colours, strengths and shapes from measured calibration swatches.
//! - `purge`: purge volume between two colours, and the washout of a mixing chamber.
//! - `swatch`: a palette as a PNG chart.
//!
//! ```
//! use gweave::colour::{dialect, named_mixes, pigments, solve, MixingModel, Srgb8};
//!
//! // E0 cyan, E1 magenta, E2 yellow, E3 white.
//! let model = MixingModel::new(&pigments::CMYW_FILAMENTS).unwrap();
//! let pink = solve::solve(&model, "#ff88aa".parse::<Srgb8>().unwrap());
//! assert!(!pink.out_of_gamut);
//!
//! // The seed's "Green" with 30 % of a second material on E3, as virtual tool 1.
//! let green = named_mixes::Palette::seed().resolve("green", &model).unwrap().mix;
//! let lines = dialect::marlin_m163_m164(
//!     &green.with_material2(0.3, 3).unwrap(),
//!     1,
//!     dialect::Decimals::new(2).unwrap(),
//! );
//! assert_eq!(lines, ["M163 S0 P0.35", "M163 S1 P0", "M163 S2 P0.35", "M163 S3 P0.3", "M164 S1"]);
//! ```
#[cfg(test)]
mod ciede2000_sharma;
pub mod dialect;
pub mod fit;
#[cfg(test)]
mod fit_reference;
pub(crate) mod mix;
pub(crate) mod mixing;
pub mod named_mixes;
pub mod pigments;
pub mod predict;
pub(crate) mod purge;
pub(crate) mod reflectance;
pub(crate) mod shape;
pub mod solve;
pub(crate) mod spectrum;
pub(crate) mod srgb;
pub mod swatch;

/// CIELAB relative to D65 (the sRGB white), in `f64`: `l` 0 (black) to 100 (white), `a`
/// green (-) to red (+), `b` blue (-) to yellow (+).
pub type Lab = ::palette::Lab<::palette::white_point::D65, f64>;

pub use ::palette::color_difference::Ciede2000;
pub use mix::{Mix, MixError};
pub use mixing::MixingModel;
pub use srgb::Srgb8;
