//! Ranges of settings-file values: one mechanism for every profile loader (machine, mix,
//! printhead, purge-shift, rotary).
//!
//! Each numeric key of a profile has a physical range (a temperature between 0 and 500 °C, a
//! length between 0 and 10 m...). A type read from TOML implements [`CheckRanges`]: it checks
//! its own keys through a [`Table`], which knows where in the file the type sits, and hands the
//! table of each nested type to that type. A value outside its range, NaN or infinite is an
//! [`OutOfRange`] that names the table, the key, the value and the range; the CLI adds the
//! file: `printer.toml: [thermal.hotend_protection] max_temp_c = 1e308 is out of range: 0 to 500 °C`.
//!
//! Unknown keys are refused by serde (`deny_unknown_fields`) before any range is checked.
//!
//! ```
//! use gweave::settings::{CheckRanges, OutOfRange, Range, Table};
//!
//! struct Bed { x_mm: f64 }
//! impl CheckRanges for Bed {
//!     fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
//!         t.check("x_mm", self.x_mm, Range::new(1.0, 10_000.0, "mm"))
//!     }
//! }
//! let err = Bed { x_mm: 1e308 }.check_ranges(&Table::root().sub("bed")).unwrap_err();
//! assert_eq!(err.to_string(), "[bed] x_mm = 1e308 is out of range: 1 to 10000 mm");
//! ```

use std::fmt;

/// The closed interval `[min, max]` a key may take, in `unit`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// Smallest allowed value.
    pub min: f64,
    /// Largest allowed value.
    pub max: f64,
    /// The unit printed after the range (`"mm"`, `"°C"`, `""` for a plain number).
    pub unit: &'static str,
}

impl Range {
    /// The range `[min, max]` in `unit`.
    pub const fn new(min: f64, max: f64, unit: &'static str) -> Self {
        Self { min, max, unit }
    }

    /// Whether `value` is a finite number inside the range.
    pub fn contains(&self, value: f64) -> bool {
        value.is_finite() && (self.min..=self.max).contains(&value)
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} to {}", Num(self.min), Num(self.max))?;
        if !self.unit.is_empty() {
            write!(f, " {}", self.unit)?;
        }
        Ok(())
    }
}

/// Ranges shared by many keys. A key with its own physical limits states its own range.
pub mod ranges {
    use super::Range;

    /// A temperature a heater can be asked for or protected at (hotends top out near 500 °C).
    pub const TEMP_C: Range = Range::new(0.0, 500.0, "°C");
    /// A length on or around a printer: 10 m covers the largest gantry.
    pub const LEN_MM: Range = Range::new(0.0, 10_000.0, "mm");
    /// A length that must not be zero (a size, a diameter, a travel).
    pub const SIZE_MM: Range = Range::new(0.001, 10_000.0, "mm");
    /// A position on the bed, either side of the origin.
    pub const POS_MM: Range = Range::new(-10_000.0, 10_000.0, "mm");
    /// A linear speed.
    pub const SPEED_MM_S: Range = Range::new(0.001, 10_000.0, "mm/s");
    /// A linear speed in G-code's unit (`F` words).
    pub const FEED_MM_MIN: Range = Range::new(0.06, 600_000.0, "mm/min");
    /// A linear acceleration.
    pub const ACCEL_MM_S2: Range = Range::new(0.001, 1_000_000.0, "mm/s²");
    /// Motor steps per mm (or per degree).
    pub const STEPS_PER_UNIT: Range = Range::new(0.001, 1_000_000.0, "steps/unit");
    /// A time constant or period of the firmware, 0 to a day.
    pub const PERIOD_S: Range = Range::new(0.0, 86_400.0, "s");
    /// A period that must not be zero (a loop must advance its clock).
    pub const TICK_S: Range = Range::new(0.001, 3_600.0, "s");
    /// A fraction.
    pub const FRACTION: Range = Range::new(0.0, 1.0, "");
    /// Printer resolution: from coarse inkjets to the finest photopolymer masks.
    pub const DPI: Range = Range::new(1.0, 10_000.0, "dpi");
    /// An angle of one turn or less either way.
    pub const ANGLE_DEG: Range = Range::new(-360.0, 360.0, "°");
}

/// A value outside its [`Range`], or not a number: where it is, what it is, what it may be.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{table}{key} = {} is out of range: {range}", Num(*.value))]
pub struct OutOfRange {
    /// `[motion.steps] ` (empty for a top-level key).
    pub table: TableName,
    /// The key, with an index for an array element (`feed_mm_s[1]`).
    pub key: String,
    /// The value found.
    pub value: f64,
    /// The range it must be in.
    pub range: Range,
}

/// A table's dotted path, printed as TOML writes its header (`[motion.corners] `), or nothing
/// for the top level.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TableName(pub String);

impl fmt::Display for TableName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            Ok(())
        } else {
            write!(f, "[{}] ", self.0)
        }
    }
}

/// Where in the file a type's keys are: the checker handed to [`CheckRanges::check_ranges`].
#[derive(Debug, Clone, Default)]
pub struct Table {
    path: String,
}

impl Table {
    /// The top level of the file.
    pub fn root() -> Self {
        Self::default()
    }

    /// The nested table `name` (dotted paths allowed: `motion.corners`).
    pub fn sub(&self, name: &str) -> Self {
        let path = if self.path.is_empty() { name.to_owned() } else { format!("{}.{name}", self.path) };
        Self { path }
    }

    /// Element `index` of an array of tables (`[[thermal.hotends]]`), named `thermal.hotends[1]`.
    pub fn item(&self, index: usize) -> Self {
        Self { path: format!("{}[{index}]", self.path) }
    }

    /// `key = value` must be a finite number in `range`.
    pub fn check(&self, key: &str, value: f64, range: Range) -> Result<(), OutOfRange> {
        if range.contains(value) {
            Ok(())
        } else {
            Err(OutOfRange { table: TableName(self.path.clone()), key: key.to_owned(), value, range })
        }
    }

    /// [`Table::check`] for an optional key: absent is fine.
    pub fn check_opt(&self, key: &str, value: Option<f64>, range: Range) -> Result<(), OutOfRange> {
        value.map_or(Ok(()), |v| self.check(key, v, range))
    }

    /// [`Table::check`] for a count (or any integer key).
    pub fn count(&self, key: &str, value: impl Into<u64>, range: Range) -> Result<(), OutOfRange> {
        self.check(key, value.into() as f64, range)
    }

    /// [`Table::check`] for every element of an array key, naming the element (`key[2]`).
    pub fn each(&self, key: &str, values: &[f64], range: Range) -> Result<(), OutOfRange> {
        values.iter().enumerate().try_for_each(|(i, &v)| self.check(&format!("{key}[{i}]"), v, range))
    }
}

/// A settings type whose numeric keys have ranges.
pub trait CheckRanges {
    /// Check every numeric key, and the keys of every nested table, of `self` found at `table`.
    fn check_ranges(&self, table: &Table) -> Result<(), OutOfRange>;
}

/// A number as a person writes it: `0.013`, `500`, `1e308` (never 309 digits), `nan`, `inf`.
#[derive(Debug, Clone, Copy)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_nan() {
            f.write_str("nan")
        } else if v.is_infinite() {
            f.write_str(if v > 0.0 { "inf" } else { "-inf" })
        } else if v == 0.0 || (1e-4..1e9).contains(&v.abs()) {
            write!(f, "{v}")
        } else {
            write!(f, "{v:e}")
        }
    }
}

/// The TOML reader's message for `e`, with any number of more than 20 digits (serde prints
/// the float `1e308` of an integer key in full) written short, as [`Num`] does.
pub fn toml_message(e: &toml::de::Error) -> String {
    short_numbers(&e.to_string())
}

fn short_numbers(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find(|c: char| c.is_ascii_digit()) {
        out.push_str(&rest[..start]);
        let run = &rest[start..];
        let len = run.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(run.len());
        let number = &run[..len];
        match number.parse::<f64>() {
            Ok(v) if len > 20 => out.push_str(&Num(v).to_string()),
            _ => out.push_str(number),
        }
        rest = &run[len..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_print_short() {
        let shown = [1e308, -1e308, 0.013, 500.0, f64::NAN, f64::NEG_INFINITY, 1e-9, -1.0, 0.0]
            .map(|v| Num(v).to_string());
        assert_eq!(shown, ["1e308", "-1e308", "0.013", "500", "nan", "-inf", "1e-9", "-1", "0"]);
    }

    #[test]
    fn long_numbers_in_reader_messages_are_shortened() {
        let long = format!("invalid type: floating point `1{}.0`, expected u32 at line 3", "0".repeat(308));
        assert_eq!(short_numbers(&long), "invalid type: floating point `1e308`, expected u32 at line 3");
    }

    #[test]
    fn out_of_range_names_table_key_value_and_range() {
        let t = Table::root().sub("thermal").sub("hotends").item(1);
        let err = t.check("power_w", f64::NAN, Range::new(0.1, 5000.0, "W")).unwrap_err();
        assert_eq!(err.to_string(), "[thermal.hotends[1]] power_w = nan is out of range: 0.1 to 5000 W");
        let err = Table::root().check("mixing_inputs", 100.0, Range::new(0.0, 16.0, "")).unwrap_err();
        assert_eq!(err.to_string(), "mixing_inputs = 100 is out of range: 0 to 16");
        let err = Table::root().sub("homing").each("bump_mm", &[1.0, -1.0], ranges::LEN_MM).unwrap_err();
        assert_eq!(err.to_string(), "[homing] bump_mm[1] = -1 is out of range: 0 to 10000 mm");
        assert!(Table::root().check("x", 10_000.0, ranges::LEN_MM).is_ok(), "the range is closed");
        assert!(Table::root().check_opt("x", None, ranges::LEN_MM).is_ok());
    }
}
