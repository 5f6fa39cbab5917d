//! The options of `gweave raster` and `gweave.raster()`, declared once ([`crate::options`]):
//! the printhead, how pixels become binder, where and how the head moves, how the print is
//! timed, and the nozzle test pattern written instead of layers.
//!
//! ```
//! use gweave::gen::raster_job::RasterOptions;
//! use gweave::options::{JobOptions, Spelling, Value};
//! let mut o = RasterOptions::default();
//! assert_eq!((o.threshold, o.density, o.pattern_columns), (0.5, 1, 4));
//! let dialect = RasterOptions::spec("dialect").unwrap();
//! o.set(dialect, Value::Text("reprap".into())).unwrap();
//! assert_eq!(o.header(), "--dialect reprapfirmware");
//! let err = o.set(dialect, Value::Text("klipper".into())).unwrap_err();
//! assert_eq!(
//!     err.spelled(Spelling::Keyword),
//!     "dialect: klipper has no inkjet fire command: marlin (M700) or reprapfirmware (M578)"
//! );
//! ```

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use super::super::raster::{FireOrder, DENSITY, HEADS, PATTERN_COLUMNS, THRESHOLD};
use crate::firmware::Firmware;
use crate::options::Shape;
use crate::range::{DPI, FEED_MM_MIN, LAYER_HEIGHT_MM, PIXEL_MM, POSITION_MM};

crate::word_option!(FireOrder);
crate::text_option!(FireDialect);

/// A firmware with an inkjet fire command (`M700` on Marlin hpc6602, `M578` on
/// RepRapFirmware), by its name or an older one (`reprap`): the only firmwares a raster can be
/// written for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FireDialect(pub Firmware);

impl FromStr for FireDialect {
    type Err = String;
    fn from_str(word: &str) -> Result<Self, String> {
        let firmware = word.parse::<Firmware>().map_err(|e| e.to_string())?;
        match firmware.inkjet_fire_code() {
            Some(_) => Ok(FireDialect(firmware)),
            None => {
                Err(format!("{firmware} has no inkjet fire command: marlin (M700) or reprapfirmware (M578)"))
            }
        }
    }
}

impl fmt::Display for FireDialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

crate::job_options! {
    /// What a raster job is given besides its layer images (or `.sl1`).
    pub struct RasterOptions for "raster" {
        /// Printhead profile (TOML; default: HP C6602, 12 nozzles at 96 dpi, one head).
        head: Option<PathBuf> = Shape::new("PROFILE.toml"),
        /// Write for this inkjet machine (a profile file or a built-in name: binder-jet,
        /// inkjet-c6602): its printhead, its powder recoat and its canvas origin, as `gweave sim
        /// --machine` checks them. Instead of --head.
        machine: Option<PathBuf> = Shape::new("TOML|NAME").conflicts(&["head"]),
        /// Fraction of full scale at or above which a pixel gets binder.
        threshold: f64 = Shape::new("0..1").range(THRESHOLD) => 0.5,
        /// Dark pixels get binder (black-on-white drawings, as in the binder-jet seed's BMPs).
        invert: bool = Shape::new(""),
        /// The images' first row is the far edge (+Y up, as pictures are drawn); default: the first
        /// row is printed at the lowest Y, as `gweave slice-raster` writes them.
        flip_y: bool = Shape::new(""),
        /// Print every pass left to right (default: serpentine).
        one_way: bool = Shape::new(""),
        /// Fire `after` the move onto each column (`G1`, `M400`, `M700`), or `before` the move to
        /// the next one as the binder-jet seed writes it (`M700`, `M400`, `G1`).
        fire_order: FireOrder = Shape::new("FIRE_ORDER"),
        /// Fires per pixel (binder saturation).
        density: u32 = Shape::new("N").whole(DENSITY) => 1,
        /// Bed position of the image corner, mm [default: the machine's canvas origin, else 20,20].
        origin: Option<[f64; 2]> = Shape::new("X,Y").range(POSITION_MM),
        /// Layer thickness, mm (default: the .sl1's own, else 0.1).
        layer_height: Option<f64> = Shape::new("MM").range(LAYER_HEIGHT_MM),
        /// Pixel size of the images, mm; they are resampled to the nozzle pitch [default: 25.4/--dpi,
        /// else one pixel per nozzle pitch, or the .sl1's own].
        pixel_mm: Option<f64> = Shape::new("MM").range(PIXEL_MM).conflicts(&["dpi"]),
        /// Resolution of the images, dots per inch (pixel = 25.4 / D mm) [default: the nozzle pitch's].
        dpi: Option<f64> = Shape::new("D").range(DPI),
        /// Heads to use (the profile's offsets; missing heads get zero offsets) [default: one per
        /// --channels entry, else 1].
        heads: Option<u32> = Shape::new("N").whole(HEADS),
        /// One image channel per head, e.g. `r,b` (r, g, b, luma) [default: luma, one head].
        channels: Option<String> = Shape::new("LIST"),
        /// G-code between layers (powder recoat); `{layer}` and `{z}` are replaced.
        recoat: Option<PathBuf> = Shape::new("FILE"),
        /// G-code before the first layer.
        start: Option<PathBuf> = Shape::new("FILE"),
        /// G-code after the last layer.
        end: Option<PathBuf> = Shape::new("FILE"),
        /// Fire command dialect: marlin (`M700 P S`, Marlin hpc6602) or reprapfirmware (`M578 P
        /// S`; `reprap` still accepted) [default: the profile's].
        dialect: Option<FireDialect> = Shape::new("DIALECT"),
        /// Carriage feed rate, mm/min [default: 3000].
        feed: Option<f64> = Shape::new("MM_MIN").range(FEED_MM_MIN),
        /// Estimate time from the path at the feed rate instead of running the planner (faster).
        fast_estimate: bool = Shape::new(""),
        /// Write a nozzle test pattern instead (each nozzle address fired alone, in order).
        test_pattern: bool = Shape::new(""),
        /// Columns per nozzle in the test pattern.
        pattern_columns: u32 = Shape::new("N").whole(PATTERN_COLUMNS) => 4,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--dialect` / `dialect=` take a firmware's name and its older spellings, and only the
    /// firmwares that fire (was the CLI's own parser, `raster_dialect_takes_the_spelling_and_the_old_ones`).
    #[test]
    fn the_dialect_takes_the_spellings_of_a_firmware_that_fires() {
        let rrf = Firmware::RepRapFirmware;
        for (word, want) in [
            ("marlin", Firmware::Marlin),
            ("reprapfirmware", rrf),
            ("reprap", rrf),
            ("rep_rap_firmware", rrf),
        ] {
            assert_eq!(word.parse::<FireDialect>(), Ok(FireDialect(want)), "{word}");
        }
        assert_eq!(FireDialect(rrf).to_string(), "reprapfirmware", "written back by its name");
        for word in ["klipper", "linuxcnc", "mach3"] {
            assert!(
                word.parse::<FireDialect>().unwrap_err().contains("has no inkjet fire command"),
                "{word}"
            );
        }
        assert!("duet".parse::<FireDialect>().unwrap_err().starts_with("unknown firmware \"duet\""));
    }
}
