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
//! use gweave::range::{OutOfRange, Range};
//! use gweave::settings::{CheckRanges, Table};
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
use std::io::{self, Read};
use std::path::Path;

use serde::de::{self, Deserialize, Deserializer, Visitor};

use crate::range::{short, OutOfRange, Quantity, Range};

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
    pub fn check<T: Quantity>(&self, key: &str, value: T, range: Range<T>) -> Result<(), OutOfRange> {
        // `[motion.corners] junction_deviation_mm`, as TOML writes the table's header.
        let name = if self.path.is_empty() { key.to_owned() } else { format!("[{}] {key}", self.path) };
        range.check(&name, value).map(|_| ())
    }

    /// [`Table::check`] for an optional key: absent is fine.
    pub fn check_opt<T: Quantity>(
        &self,
        key: &str,
        value: Option<T>,
        range: Range<T>,
    ) -> Result<(), OutOfRange> {
        value.map_or(Ok(()), |v| self.check(key, v, range))
    }

    /// [`Table::check`] for a count (or any integer key), printed whole (`9223372036854775807`,
    /// not `9.223372036854776e18`).
    pub fn count(&self, key: &str, value: impl Into<u64>, range: Range) -> Result<(), OutOfRange> {
        let value = value.into();
        self.check(key, value as f64, range).map_err(|e| OutOfRange { value: value.to_string(), ..e })
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

/// Largest settings file read (a profile, a job, an `M503` report, a thermistor table): the
/// shipped profiles are 1 to 3 KiB, a mix profile at its ceiling of 4 096 mixes about 160 KiB.
/// The TOML reader keeps every value with its text and place, about 170 bytes of memory for
/// each 2-byte value of an array (`[0,0,0,...]`), so 256 KiB of settings may take 22 MiB; a
/// larger file (or `--machine /dev/zero`) is refused after this many bytes instead.
pub const MAX_FILE_BYTES: u64 = 256 << 10;

/// The text of the settings file at `path`, refused past [`MAX_FILE_BYTES`] (read no further:
/// the path may name an endless device or pipe).
pub fn read_text(path: &Path) -> io::Result<String> {
    let mut text = String::new();
    std::fs::File::open(path)?.take(MAX_FILE_BYTES + 1).read_to_string(&mut text)?;
    if text.len() as u64 > MAX_FILE_BYTES {
        let message = format!("larger than the limit of {} KiB for a settings file", MAX_FILE_BYTES >> 10);
        return Err(io::Error::new(io::ErrorKind::InvalidData, message));
    }
    Ok(text)
}

/// Longest source line a TOML error quotes, in characters: the reader quotes the whole
/// offending line, which may be a 50 MB value.
const MESSAGE_LINE_CHARS: usize = 120;
/// Longest other line of a TOML error: the list of a table's keys an unknown key gets (a few
/// hundred characters) stays whole, a wrong-typed 50 MB string value does not.
const MESSAGE_TEXT_CHARS: usize = 1_000;

/// The TOML reader's message for `e`, with any number of more than 20 digits (serde prints
/// the float `1e308` of an integer key in full) written short, as [`short`] does, the quoted
/// source line and its `^^^` marks cut to 120 characters around the error's column and any other
/// line to its first 1 000 (`MESSAGE_LINE_CHARS`, `MESSAGE_TEXT_CHARS`).
pub fn toml_message(e: &toml::de::Error) -> String {
    let text = e.to_string();
    // "TOML parse error at line 3, column 14"
    let column = text
        .lines()
        .next()
        .and_then(|l| l.rsplit_once("column "))
        .and_then(|(_, c)| c.trim().parse::<usize>().ok())
        .unwrap_or(1);
    let from = column.saturating_sub(1 + MESSAGE_LINE_CHARS / 2);
    let mut out: String = text.lines().map(|l| cut_line(l, from) + "\n").collect();
    if !text.ends_with('\n') {
        out.pop();
    }
    short_numbers(&out)
}

/// `line` of a TOML message cut: a quoted source line (`3 | key = ...`) or its marks
/// (`  |    ^^^`) to [`MESSAGE_LINE_CHARS`] from character `from` of the source, others to
/// their first [`MESSAGE_TEXT_CHARS`].
fn cut_line(line: &str, from: usize) -> String {
    let quoted =
        line.split_once("| ").filter(|(gutter, _)| gutter.bytes().all(|b| b == b' ' || b.is_ascii_digit()));
    let (head, body, from, most) = match quoted {
        Some((gutter, source)) => (format!("{gutter}| "), source, from, MESSAGE_LINE_CHARS),
        None => (String::new(), line, 0, MESSAGE_TEXT_CHARS),
    };
    let total = body.chars().count();
    if total <= most {
        return line.to_owned();
    }
    let kept: String = body.chars().skip(from).take(most).collect();
    let before = if from > 0 { "..." } else { "" };
    let after = if from + most < total { "..." } else { "" };
    // The marks' line is spaces up to the column: it keeps its alignment under the source line.
    let before = if body.bytes().all(|b| b == b' ' || b == b'^') && from > 0 { "   " } else { before };
    format!("{head}{before}{kept}{after}")
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
            Ok(v) if len > 20 => out.push_str(&short(v)),
            _ => out.push_str(number),
        }
        rest = &run[len..];
    }
    out.push_str(rest);
    out
}

/// The keys a `#[derive(Deserialize)]` struct reads, in the order of its fields: the list its
/// unknown-key errors give. A table that holds the keys of two types (mix's `[purge]`) sorts
/// its keys with it, without naming them a second time.
pub fn keys_of<'de, T: Deserialize<'de>>() -> &'static [&'static str] {
    T::deserialize(KeysProbe).err().map_or(&[], |keys| keys.0)
}

/// A deserializer that only asks a struct for its keys: serde's derive names them all when it
/// reads a struct ([`Deserializer::deserialize_struct`]); the probe answers with an "error"
/// carrying them.
struct KeysProbe;

#[derive(Debug)]
struct Keys(&'static [&'static str]);

impl fmt::Display for Keys {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "keys {:?}", self.0)
    }
}

impl std::error::Error for Keys {}

impl de::Error for Keys {
    fn custom<M: fmt::Display>(_: M) -> Self {
        Keys(&[])
    }
}

impl<'de> Deserializer<'de> for KeysProbe {
    type Error = Keys;

    fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Keys> {
        Err(Keys(&[]))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        _: V,
    ) -> Result<V::Value, Keys> {
        Err(Keys(fields))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf option
        unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier ignored_any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_of_a_struct_are_its_fields_in_order() {
        #[derive(serde::Deserialize)]
        #[allow(dead_code)]
        struct Spot {
            x_mm: f64,
            y_mm: Option<f64>,
            #[serde(skip)]
            z_mm: f64,
        }
        assert_eq!(keys_of::<Spot>(), ["x_mm", "y_mm"]);
        assert!(keys_of::<f64>().is_empty());
    }

    /// Regression: the reader quoted the whole offending line, so a 50 MB value printed itself.
    #[test]
    fn reader_messages_quote_a_window_of_a_long_line() {
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct Bed {
            x_mm: f64,
        }
        let long = "y".repeat(100_000);
        let e = toml::from_str::<Bed>(&format!("x_mm = 1\nname = \"{long}")).unwrap_err();
        let message = toml_message(&e);
        assert!(message.len() < 600, "{} bytes: {message}", message.len());
        let lines: Vec<&str> = message.lines().collect();
        assert_eq!(lines[0], "TOML parse error at line 2, column 100009");
        // The quoted line shows the end where the error is, the marks stay under it.
        assert!(lines[2].starts_with("2 | ...yyy") && lines[2].len() <= "2 | ...".len() + 120, "{message}");
        assert_eq!(lines[3].find('^'), lines[2].rfind('y').map(|i| i + 1), "{message}");
        let e = toml::from_str::<Bed>(&format!("x_mm = \"{long}\"")).unwrap_err();
        let last = toml_message(&e).lines().last().unwrap().to_owned();
        assert!(last.starts_with("invalid type: string \"yyy") && last.ends_with("yyy..."), "{last}");
        assert_eq!(last.chars().count(), 1_003);
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
        let err =
            Table::root().sub("homing").each("bump_mm", &[1.0, -1.0], crate::range::LEN_MM).unwrap_err();
        assert_eq!(err.to_string(), "[homing] bump_mm[1] = -1 is out of range: 0 to 10000 mm");
        assert!(Table::root().check("x", 10_000.0, crate::range::LEN_MM).is_ok(), "the range is closed");
        assert!(Table::root().check_opt("x", None, crate::range::LEN_MM).is_ok());
    }
}
