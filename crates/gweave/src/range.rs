//! Physical ranges of numeric settings, and ceilings of the sizes computed from them.
//!
//! Every number a user gives (a flag or a TOML key) has a [`Range`] stated once, beside the
//! setting it bounds, and checked by both paths: the CLI's value parser (before anything is
//! read) and the library config's `validate`. A value outside its range is refused with the
//! setting's name and the range, never clamped: `1e308 mm` is a typo, and a generator fed it
//! would run until the disk is full.
//!
//! In-range settings can still multiply into an absurd size (a 1 km part at 25 400 dpi), so a
//! generator also checks what it is about to allocate or write against a [`Ceiling`] before it
//! starts: [`MAX_LAYERS`] layers, [`MAX_IMAGE_SIDE_PX`] pixels per image side.
//!
//! ```
//! use gweave::range::Range;
//! const DIAMETER_MM: Range<f64> = Range::new(1.0, 1000.0, "mm");
//! assert_eq!(DIAMETER_MM.check("--mandrel-diameter", 30.0).unwrap(), 30.0);
//! let err = DIAMETER_MM.check("--mandrel-diameter", 1e-9).unwrap_err();
//! assert_eq!(err.to_string(), "--mandrel-diameter 1e-9 is out of range: 1 to 1000 mm");
//! let err = DIAMETER_MM.check("mandrel_diameter_mm", 1e308).unwrap_err();
//! assert_eq!(err.to_string(), "mandrel_diameter_mm = 1e308 is out of range: 1 to 1000 mm");
//! ```

use std::fmt;

/// Most layers a generator writes (slice-raster images, raster layers, tube layers).
pub const MAX_LAYERS: u64 = 100_000;
/// Most pixels on each side of a generated image (20 000 px: 2 m at 254 dpi, 400 MB of RGB).
pub const MAX_IMAGE_SIDE_PX: u64 = 20_000;

// Physical quantities several commands share. Generous for any real machine, tight enough that
// nothing computed from them overflows or runs away.

/// Filament diameter (1.75, 2.85 and 3 mm filaments, with room either side).
pub const FILAMENT_DIAMETER_MM: Range = Range::new(0.5, 5.0, "mm");
/// Layer thickness.
pub const LAYER_HEIGHT_MM: Range = Range::new(0.001, 10.0, "mm");
/// A feed rate in G-code's unit (`F` words): 100 000 mm/min is 1.7 m/s, beyond any printer.
pub const FEED_MM_MIN: Range = Range::new(1.0, 100_000.0, "mm/min");
/// A linear speed (about the span of [`FEED_MM_MIN`]).
pub const SPEED_MM_S: Range = Range::new(0.01, 1_000.0, "mm/s");
/// A linear acceleration.
pub const ACCEL_MM_S2: Range = Range::new(0.001, 1_000_000.0, "mm/s²");
/// A heater target or limit (0: off; hotends top out near 500 °C).
pub const TEMPERATURE_C: Range = Range::new(0.0, 500.0, "°C");
/// A position on the bed or machine (an origin, a tower corner, a height), either side of 0.
pub const POSITION_MM: Range = Range::new(-10_000.0, 10_000.0, "mm");
/// A length on or around a printer: 10 m covers the largest gantry.
pub const LEN_MM: Range = Range::new(0.0, 10_000.0, "mm");
/// A length that must not be zero (a size, a diameter, a travel).
pub const SIZE_MM: Range = Range::new(0.001, 10_000.0, "mm");
/// A machine's bed size along one axis.
pub const BED_SIZE_MM: Range = Range::new(1.0, 10_000.0, "mm");
/// Motor steps per mm (or per degree).
pub const STEPS_PER_UNIT: Range = Range::new(0.001, 1_000_000.0, "steps/unit");
/// A PWM value as `M106 S` (a fan) and `M42 S` (a pin) write it: 0 off, 255 full (Marlin's 8-bit PWM).
pub const PWM: Range = Range::new(0.0, 255.0, "");
/// A time constant or period of the firmware, 0 to a day.
pub const PERIOD_S: Range = Range::new(0.0, 86_400.0, "s");
/// A period that must not be zero (a loop must advance its clock).
pub const TICK_S: Range = Range::new(0.001, 3_600.0, "s");
/// A fraction.
pub const FRACTION: Range = Range::new(0.0, 1.0, "");
/// An angle of one turn or less either way.
pub const ANGLE_DEG: Range = Range::new(-360.0, 360.0, "°");
/// Image resolution, from coarse inkjets to the finest photopolymer masks; [`PIXEL_MM`] is the
/// same span as a pixel size (`25.4 / dpi`).
pub const DPI: Range = Range::new(10.0, 10_000.0, "dpi");
/// Pixel size (the same span as [`DPI`]).
pub const PIXEL_MM: Range = Range::new(0.00254, 2.54, "mm");
/// A layer number as a file counts them (0-based).
pub const LAYER_NUMBER: Range<u32> = Range::new(0, 1_000_000, "");
/// Purge per colour change, mm of filament (1 m: far beyond any real purge).
pub const PURGE_MM: Range = Range::new(0.0, 1_000.0, "mm");
/// Purge per colour change as a volume (1000 mm of 3 mm filament is 7 069 mm3).
pub const PURGE_MM3: Range = Range::new(0.0, 10_000.0, "mm3");
/// A bead's cross-section, mm² (Klipper's `max_extrude_cross_section`: 0.64 for a 0.4 mm
/// nozzle by default; MMU setups raise it to 50 for their ramming).
pub const CROSS_SECTION_MM2: Range = Range::new(0.001, 1_000.0, "mm²");

/// A number as a person reads it: plain for ordinary magnitudes, `1e308` / `1e-9` for the rest,
/// so that no message prints a 309-digit number.
pub fn short(v: f64) -> String {
    let a = v.abs();
    if v.is_nan() {
        // As TOML spells it, which is where most such values come from.
        "nan".into()
    } else if v == 0.0 || !v.is_finite() || (1e-4..1e9).contains(&a) {
        // Rust prints the shortest text that reads back as `v`: 0.001, 2.54, 25400, as the
        // user typed it. A computed value (a volume turned into a length) would print all of
        // its 17 digits: those keep 6 significant ones.
        let text = format!("{v}");
        if text.len() <= 12 {
            return text;
        }
        let decimals = (5 - a.log10().floor() as i32).max(0) as usize;
        let rounded = format!("{v:.decimals$}");
        if rounded.contains('.') {
            rounded.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            rounded
        }
    } else {
        format!("{v:e}")
    }
}

/// A computed count (possibly huge, infinite or NaN), whole while it is short enough to read.
pub fn count(v: f64) -> String {
    if v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        short(v)
    }
}

/// A number type a [`Range`] can bound.
pub trait Quantity: Copy + PartialOrd + Send + Sync + 'static {
    /// The value as [`short`] writes it.
    fn short(self) -> String;
    /// The value is zero.
    fn is_zero(self) -> bool;
}

impl Quantity for f64 {
    fn short(self) -> String {
        short(self)
    }
    fn is_zero(self) -> bool {
        self == 0.0
    }
}

impl Quantity for f32 {
    fn short(self) -> String {
        short(f64::from(self))
    }
    fn is_zero(self) -> bool {
        self == 0.0
    }
}

macro_rules! integer_quantity {
    ($($t:ty),*) => {$(
        impl Quantity for $t {
            fn short(self) -> String {
                self.to_string()
            }
            fn is_zero(self) -> bool {
                self == 0
            }
        }
    )*};
}
integer_quantity!(u16, u32, u64, usize, i32, i64);

/// The values a setting may take: `min..=max` in `unit`, and 0 too when [`Range::or_zero`]
/// says 0 means "off" (a chord tolerance of 0: no chords).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range<T = f64> {
    /// Smallest value allowed.
    pub min: T,
    /// Largest value allowed.
    pub max: T,
    /// Unit shown after the range (`mm`, `dpi`, `C`), empty for counts.
    pub unit: &'static str,
    /// 0 is accepted as well (it switches the feature off).
    pub zero: bool,
}

impl<T: Quantity> Range<T> {
    /// `min..=max` in `unit`, without zero.
    pub const fn new(min: T, max: T, unit: &'static str) -> Self {
        Range { min, max, unit, zero: false }
    }

    /// The same range, with 0 accepted too.
    pub const fn or_zero(self) -> Self {
        Range { zero: true, ..self }
    }

    /// In range (NaN never is).
    pub fn contains(&self, v: T) -> bool {
        (v >= self.min && v <= self.max) || (self.zero && v.is_zero())
    }

    /// `v`, or an error naming `name` (a flag such as `--dpi`, or a TOML key) and the range.
    pub fn check(&self, name: &str, v: T) -> Result<T, OutOfRange> {
        if self.contains(v) {
            Ok(v)
        } else {
            Err(OutOfRange { name: name.to_owned(), value: v.short(), range: self.to_string() })
        }
    }
}

impl<T: Quantity> fmt::Display for Range<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.zero {
            write!(f, "0 or ")?;
        }
        write!(f, "{} to {}", self.min.short(), self.max.short())?;
        if !self.unit.is_empty() {
            write!(f, " {}", self.unit)?;
        }
        Ok(())
    }
}

/// A setting outside its [`Range`], written as the user wrote it: `--dpi 5` on the command
/// line, `dpi = 5` in a settings file (`[head] dpi = 5`, see `settings::Table`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{name}{} {value} is out of range: {range}", if name.starts_with('-') { "" } else { " =" })]
pub struct OutOfRange {
    /// The flag or key.
    pub name: String,
    /// The value, as [`short`] writes it.
    pub value: String,
    /// The allowed range with its unit.
    pub range: String,
}

/// The most of something a generator makes, e.g. [`MAX_LAYERS`] layers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ceiling {
    /// The most allowed.
    pub limit: u64,
    /// What is counted, plural: `layers`, `pixels per image side`.
    pub what: &'static str,
}

impl Ceiling {
    /// At most `limit` of `what`.
    pub const fn new(limit: u64, what: &'static str) -> Self {
        Ceiling { limit, what }
    }

    /// `needed` (computed in floating point, so it may be huge, infinite or NaN) as a count,
    /// or an error saying what would be made, how many, and why (`because`, e.g. "a 1000 mm
    /// tall part at 0.001 mm per layer").
    pub fn check(&self, needed: f64, because: impl FnOnce() -> String) -> Result<u64, TooLarge> {
        if needed.is_finite() && needed <= self.limit as f64 {
            Ok(needed.max(0.0) as u64)
        } else {
            Err(TooLarge { what: self.what, needed: count(needed), limit: self.limit, because: because() })
        }
    }
}

/// A computed size past its [`Ceiling`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{because} needs {needed} {what}, more than the limit of {limit}")]
pub struct TooLarge {
    /// What is counted, plural.
    pub what: &'static str,
    /// How many were needed, as text (it may be infinite).
    pub needed: String,
    /// The most allowed.
    pub limit: u64,
    /// What needed them, e.g. "a 1000 mm tall part at 0.001 mm per layer".
    pub because: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_and_tiny_numbers_print_short() {
        assert_eq!(short(1e308), "1e308");
        assert_eq!(short(-1e-300), "-1e-300");
        assert_eq!(short(25400.0), "25400");
        assert_eq!(short(0.001), "0.001");
        assert_eq!(short(50929.58178940651), "50929.6");
        assert_eq!(short(0.12345678901234), "0.123457");
        assert_eq!(short(-1.5), "-1.5");
        assert_eq!(short(f64::INFINITY), "inf");
        assert_eq!(short(f64::NAN), "nan");
    }

    #[test]
    fn ranges_refuse_nan_and_accept_their_ends() {
        let r = Range::new(0.001, 10.0, "mm");
        assert!(r.contains(0.001) && r.contains(10.0));
        assert!(!r.contains(f64::NAN) && !r.contains(0.0) && !r.contains(f64::INFINITY));
        let off = r.or_zero();
        assert!(off.contains(0.0) && !off.contains(1e-12));
        assert_eq!(off.to_string(), "0 or 0.001 to 10 mm");
        let n = Range::new(1u32, 100_000, "");
        assert_eq!(
            n.check("--layers", 1_000_000_000).unwrap_err().to_string(),
            "--layers 1000000000 is out of range: 1 to 100000"
        );
    }

    #[test]
    fn a_ceiling_refuses_infinite_and_huge_counts() {
        let layers = Ceiling::new(MAX_LAYERS, "layers");
        assert_eq!(layers.check(12.0, String::new).unwrap(), 12);
        let e = layers.check(1e6, || "a 100 m tall part at 0.1 mm".into()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "a 100 m tall part at 0.1 mm needs 1000000 layers, more than the limit of 100000"
        );
        let e = layers.check(1e300, || "a speck at 1e300 mm".into()).unwrap_err();
        assert_eq!(e.to_string(), "a speck at 1e300 mm needs 1e300 layers, more than the limit of 100000");
        assert!(layers.check(f64::INFINITY, String::new).is_err());
        assert!(layers.check(f64::NAN, String::new).is_err());
    }
}
