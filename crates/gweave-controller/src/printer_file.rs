//! The printer's file (`firmware/printer.toml` and its siblings): the one options type of the
//! firmware's build-time settings, read here into [`Settings`] for every user. (Feature `std`.)
//!
//! The firmware's build script (`firmware/ramps/build.rs`, also the Cortex-M build's) reads the
//! file with [`read`] and writes the result into the image as Rust constants
//! ([`PrinterFile::to_rust`]); the host (the virtual printer's tests, anything that wants the
//! board's settings) reads the same file with the same function, so the keys, their ranges and
//! their defaults ([`Settings::DEFAULT`]) are declared once, in [`KEYS`].
//!
//! The file is a small subset of TOML (sections, `key = value` with numbers, strings, booleans
//! and flat arrays), read by hand so that the firmware's build needs no parser crate. Every key
//! is checked against [`KEYS`]: an unknown key, a wrong type or a value out of range is an
//! error naming the line.

use std::format;
use std::string::{String, ToString};
use std::vec::Vec;

use crate::rotary::{Rotary, RotaryFeed};
use crate::settings::{Pid, Settings};

/// A value as written in the file.
#[derive(Debug, Clone, PartialEq)]
enum Value {
    Number(f64),
    Text(String),
    Bool(bool),
    List(Vec<Value>),
}

/// What a key holds and which field of [`Settings`] it sets.
pub enum Kind {
    /// One float, within `min..=max`.
    Float {
        /// The field.
        field: fn(&mut Settings) -> &mut f32,
        /// Lowest value allowed.
        min: f64,
        /// Highest value allowed.
        max: f64,
    },
    /// A float per entry (as many as the field has), each within `min..=max`.
    Floats {
        /// The field.
        field: fn(&mut Settings) -> &mut [f32],
        /// Lowest value allowed.
        min: f64,
        /// Highest value allowed.
        max: f64,
    },
    /// Booleans per axis or motor (`min` to `max` of them, the rest false), stored as the
    /// bits of a byte.
    Bits {
        /// The field.
        field: fn(&mut Settings) -> &mut u8,
        /// Fewest entries.
        min: usize,
        /// Most entries.
        max: usize,
    },
    /// Small integers, one per entry, each one of `allowed`.
    Bytes {
        /// The field.
        field: fn(&mut Settings) -> &mut [u8],
        /// The values allowed.
        allowed: &'static [u8],
    },
    /// `[Kp, Ki, Kd]` of a [`Pid`], each within 0..=10 000.
    Pid {
        /// The field.
        field: fn(&mut Settings) -> &mut Pid,
    },
    /// The order of X, Y and Z as a string (`"ZYX"`), stored as axis indices.
    AxisOrder {
        /// The field.
        field: fn(&mut Settings) -> &mut [u8; 3],
    },
    /// A board's fact or a choice of words, read by hand in [`read`]: `baud`, `layout`,
    /// `mixing_inputs`, the rotary axis' `feed` and `invert_dir`.
    Board,
}

/// Every key the file may have: `(section, key, kind)`.
pub const KEYS: &[(&str, &str, Kind)] = &[
    ("board", "baud", Kind::Board),
    ("board", "layout", Kind::Board),
    ("board", "mixing_inputs", Kind::Board),
    ("motion", "steps_per_mm", Kind::Floats { field: |s| &mut s.steps_per_mm, min: 1.0, max: 10_000.0 }),
    ("motion", "max_feed_mm_s", Kind::Floats { field: |s| &mut s.max_feed_mm_s, min: 0.1, max: 1_000.0 }),
    (
        "motion",
        "max_accel_mm_s2",
        Kind::Floats { field: |s| &mut s.max_accel_mm_s2, min: 1.0, max: 100_000.0 },
    ),
    (
        "motion",
        "print_accel_mm_s2",
        Kind::Float { field: |s| &mut s.print_accel_mm_s2, min: 1.0, max: 100_000.0 },
    ),
    (
        "motion",
        "retract_accel_mm_s2",
        Kind::Float { field: |s| &mut s.retract_accel_mm_s2, min: 1.0, max: 100_000.0 },
    ),
    (
        "motion",
        "travel_accel_mm_s2",
        Kind::Float { field: |s| &mut s.travel_accel_mm_s2, min: 1.0, max: 100_000.0 },
    ),
    (
        "motion",
        "junction_deviation_mm",
        Kind::Float { field: |s| &mut s.junction_deviation_mm, min: 0.001, max: 0.5 },
    ),
    ("motion", "travel_mm", Kind::Floats { field: |s| &mut s.travel_mm, min: 0.0, max: 2_000.0 }),
    ("motion", "homing_feed_mm_s", Kind::Floats { field: |s| &mut s.homing_feed_mm_s, min: 0.0, max: 300.0 }),
    ("motion", "homing_order", Kind::AxisOrder { field: |s| &mut s.homing_order }),
    ("motion", "homing_bump_mm", Kind::Floats { field: |s| &mut s.homing_bump_mm, min: 0.0, max: 50.0 }),
    // X, Y, Z, E0, then the E1 socket's motor (a second extruder, a mixing input) and AUX-2's.
    ("motion", "invert_dir", Kind::Bits { field: |s| &mut s.invert_dir, min: 4, max: crate::MOTORS }),
    ("motion", "endstop_inverting", Kind::Bits { field: |s| &mut s.endstop_inverting, min: 3, max: 3 }),
    ("heaters", "thermistor", Kind::Bytes { field: |s| &mut s.thermistor, allowed: &[0, 1] }),
    ("heaters", "hotend_pid", Kind::Pid { field: |s| &mut s.hotend_pid }),
    ("heaters", "max_temp_c", Kind::Floats { field: |s| &mut s.max_temp_c, min: 0.0, max: 400.0 }),
    ("heaters", "extrude_min_c", Kind::Float { field: |s| &mut s.extrude_min_c, min: 0.0, max: 400.0 }),
    ("motion", "extrude_max_mm", Kind::Float { field: |s| &mut s.extrude_max_mm, min: 0.0, max: 10_000.0 }),
    // The rotary axis A on the E1 socket (docs/firmware.md, "Rotary"): steps per degree of the
    // mandrel, its speed and acceleration limits, and what F means on a move that turns it.
    (
        "rotary",
        "steps_per_deg",
        Kind::Float { field: |s| &mut s.rotary.steps_per_deg, min: 0.01, max: 1_000.0 },
    ),
    (
        "rotary",
        "max_feed_deg_s",
        Kind::Float { field: |s| &mut s.rotary.max_feed_deg_s, min: 0.1, max: 10_000.0 },
    ),
    (
        "rotary",
        "max_accel_deg_s2",
        Kind::Float { field: |s| &mut s.rotary.max_accel_deg_s2, min: 1.0, max: 1_000_000.0 },
    ),
    ("rotary", "feed", Kind::Board),
    ("rotary", "invert_dir", Kind::Board),
];

/// A's motor is the fifth (E1's socket): bit `1 << 4` of the DIR bits.
const A_DIR_BIT: u8 = 1 << 4;

/// What a printer file sets: the board's serial speed and drivers, and the core's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrinterFile {
    /// The serial line's speed, baud: 250 000 or 115 200.
    pub baud: u32,
    /// The driver sockets the step interrupt runs, 4 to 7: X, Y, Z, E0, then a mixing hotend's
    /// other inputs or the rotary axis on E1's socket.
    pub drivers: usize,
    /// The core's settings ([`Settings::DEFAULT`] where the file says nothing).
    pub settings: Settings,
}

/// A printer file that cannot be read, at its line (1-based; 0: the file as a whole).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PrinterFileError {
    /// The line.
    pub line: usize,
    /// What is wrong with it.
    pub message: String,
}

impl core::fmt::Display for PrinterFileError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for PrinterFileError {}

/// Reads a printer file's text.
pub fn read(text: &str) -> Result<PrinterFile, PrinterFileError> {
    let mut file = PrinterFile { baud: 250_000, drivers: 4, settings: Settings::DEFAULT };
    let s = &mut file.settings;
    let mut rotary_line = None;
    let mut eeb_line = None;
    let mut rotary_invert = false;
    let mut section = String::new();
    let mut seen: Vec<(String, String)> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let fail = |message: String| PrinterFileError { line: n, message };
        let line = strip_comment(raw).trim();
        if line.is_empty() {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = name.trim().to_string();
            if !KEYS.iter().any(|(s, _, _)| *s == section) {
                return Err(fail(format!(
                    "unknown section [{section}] (known: [board], [motion], [heaters], [rotary])"
                )));
            }
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(fail("expected `key = value`".into()));
        };
        let key = key.trim();
        let value =
            parse_value(value.trim()).ok_or_else(|| fail(format!("cannot read the value of {key}")))?;
        let Some((_, _, kind)) = KEYS.iter().find(|(s, k, _)| *s == section && *k == key) else {
            let known: Vec<&str> =
                KEYS.iter().filter(|(s, _, _)| *s == section).map(|(_, k, _)| *k).collect();
            return Err(fail(format!("unknown key {key} in [{section}] (known: {})", known.join(", "))));
        };
        if seen.contains(&(section.clone(), key.to_string())) {
            return Err(fail(format!("{key} is set twice")));
        }
        seen.push((section.clone(), key.to_string()));
        if section == "rotary" {
            rotary_line = Some(n);
        }
        match kind {
            Kind::Board => match (key, value) {
                ("baud", Value::Number(b)) if b == 250_000.0 || b == 115_200.0 => file.baud = b as u32,
                ("baud", _) => return Err(fail("baud is 250000 or 115200".into())),
                // 0: a plain extruder; 2 to 4 inputs of a mixing hotend (E0, E1 on the extruder
                // sockets, E2, E3 on AUX-2).
                ("mixing_inputs", Value::Number(k)) if [0.0, 2.0, 3.0, 4.0].contains(&k) => {
                    s.mixing_inputs = k as u8
                }
                ("mixing_inputs", _) => {
                    return Err(fail("mixing_inputs is 0 (no mixing hotend), 2, 3 or 4".into()))
                }
                ("layout", Value::Text(t)) if t == "EFB" => s.hotends = 1,
                ("layout", Value::Text(t)) if t == "EEB" => {
                    s.hotends = 2;
                    eeb_line = Some(n);
                }
                ("layout", _) => return Err(fail("layout is \"EFB\" or \"EEB\"".into())),
                ("feed", Value::Text(t)) if t == "nist" => s.rotary.feed = RotaryFeed::Nist,
                ("feed", Value::Text(t)) if t == "combined" => s.rotary.feed = RotaryFeed::Combined,
                ("feed", _) => return Err(fail("feed is \"nist\" or \"combined\"".into())),
                (_, Value::Bool(b)) => rotary_invert = b,
                _ => return Err(fail(format!("{key} is true or false"))),
            },
            Kind::Float { field, min, max } => {
                *field(s) = number(key, &value, *min, *max).map_err(fail)? as f32
            }
            Kind::Floats { field, min, max } => {
                let values = field(s);
                let items = list(key, &value, values.len()).map_err(fail)?;
                for (v, item) in values.iter_mut().zip(items) {
                    *v = number(key, item, *min, *max).map_err(fail)? as f32;
                }
            }
            Kind::Bits { field, min, max } => {
                let mut bits = 0u8;
                for (axis, v) in list_of(key, &value, *min, *max).map_err(fail)?.iter().enumerate() {
                    match v {
                        Value::Bool(true) => bits |= 1 << axis,
                        Value::Bool(false) => {}
                        _ => return Err(fail(format!("{key} holds true or false per axis"))),
                    }
                }
                *field(s) = bits;
            }
            Kind::Bytes { field, allowed } => {
                let values = field(s);
                let items = list(key, &value, values.len()).map_err(fail)?;
                for (v, item) in values.iter_mut().zip(items) {
                    *v = match item {
                        Value::Number(x) if allowed.iter().any(|&a| f64::from(a) == *x) => *x as u8,
                        _ => return Err(fail(format!("{key} entries are one of {allowed:?}"))),
                    };
                }
            }
            Kind::AxisOrder { field } => {
                let Value::Text(order) = &value else {
                    return Err(fail(format!("{key} is a string such as \"ZYX\"")));
                };
                let mut sorted: Vec<char> = order.chars().collect();
                sorted.sort_unstable();
                if sorted != ['X', 'Y', 'Z'] {
                    return Err(fail(format!("{key} names X, Y and Z once each, such as \"ZYX\"")));
                }
                for (slot, c) in field(s).iter_mut().zip(order.bytes()) {
                    *slot = c - b'X';
                }
            }
            Kind::Pid { field } => {
                let items = list(key, &value, 3).map_err(fail)?;
                let mut g = [0.0f32; 3];
                for (g, item) in g.iter_mut().zip(items) {
                    *g = number(key, item, 0.0, 10_000.0).map_err(fail)? as f32;
                }
                *field(s) = Pid { kp: g[0], ki: g[1], kd: g[2] };
            }
        }
    }
    // The drivers the step interrupt runs: X, Y, Z, E0, and the other inputs of a mixing hotend,
    // or the second extruder or the rotary axis on E1's socket.
    file.drivers = 4 + usize::from(s.mixing_inputs.max(s.hotends).max(1)) - 1;
    if let (Some(line), true) = (eeb_line, s.mixing_inputs > 0) {
        let message = "an EEB board's second extruder is on the E1 socket, which a mixing hotend uses";
        return Err(PrinterFileError { line, message: message.into() });
    }
    if let Some(line) = rotary_line {
        let fail = |message: &str| PrinterFileError { line, message: message.into() };
        if s.mixing_inputs > 0 {
            return Err(fail("a rotary axis turns the E1 socket's motor, which a mixing hotend uses"));
        }
        if s.hotends == 2 {
            return Err(fail(
                "a rotary axis turns the E1 socket's motor, which an EEB board's second extruder uses",
            ));
        }
        if s.rotary.steps_per_deg == Rotary::NONE.steps_per_deg {
            return Err(fail("[rotary] needs steps_per_deg"));
        }
        if rotary_invert {
            s.invert_dir |= A_DIR_BIT;
        }
        file.drivers = 5;
    }
    Ok(file)
}

impl PrinterFile {
    /// Whether the file has a rotary axis (a build without the feature `rotary` refuses it).
    pub fn has_rotary(&self) -> bool {
        self.settings.rotary != Rotary::NONE
    }

    /// The file as the Rust constants a firmware image includes: `BAUD`, `DRIVERS` and
    /// `SETTINGS` (every field written out: a float as its shortest exact literal).
    pub fn to_rust(&self, file_name: &str) -> String {
        let s = &self.settings;
        let Pid { kp, ki, kd } = s.hotend_pid;
        let Rotary { steps_per_deg, max_feed_deg_s, max_accel_deg_s2, feed } = s.rotary;
        let c = "gweave_controller";
        format!(
            "// Generated by build.rs from firmware/{file_name}: edit that file, not this one.\n\
             use {c}::Settings;\n\n\
             /// The serial line's speed, baud.\n\
             pub const BAUD: u32 = {baud};\n\n\
             /// The driver sockets used, in the order X, Y, Z, E0, E1, E2, E3.\n\
             pub const DRIVERS: usize = {drivers};\n\n\
             /// The printer's settings (the controller's defaults where the file says nothing).\n\
             pub const SETTINGS: Settings = Settings {{\n    \
             steps_per_mm: {:?},\n    max_feed_mm_s: {:?},\n    max_accel_mm_s2: {:?},\n    \
             print_accel_mm_s2: {:?},\n    retract_accel_mm_s2: {:?},\n    travel_accel_mm_s2: {:?},\n    \
             junction_deviation_mm: {:?},\n    travel_mm: {:?},\n    homing_feed_mm_s: {:?},\n    \
             homing_order: {:?},\n    homing_bump_mm: {:?},\n    invert_dir: {:#09b},\n    \
             endstop_inverting: {:#05b},\n    hotends: {},\n    thermistor: {:?},\n    \
             hotend_pid: {c}::settings::Pid {{ kp: {kp:?}, ki: {ki:?}, kd: {kd:?} }},\n    \
             extrude_min_c: {:?},\n    extrude_max_mm: {:?},\n    max_temp_c: {:?},\n    mixing_inputs: {},\n    inkjet_heads: {},\n    \
             rotary: {c}::rotary::Rotary {{ steps_per_deg: {steps_per_deg:?}, max_feed_deg_s: {max_feed_deg_s:?}, \
             max_accel_deg_s2: {max_accel_deg_s2:?}, feed: {c}::rotary::RotaryFeed::{feed:?} }},\n}};\n",
            s.steps_per_mm,
            s.max_feed_mm_s,
            s.max_accel_mm_s2,
            s.print_accel_mm_s2,
            s.retract_accel_mm_s2,
            s.travel_accel_mm_s2,
            s.junction_deviation_mm,
            s.travel_mm,
            s.homing_feed_mm_s,
            s.homing_order,
            s.homing_bump_mm,
            s.invert_dir,
            s.endstop_inverting,
            s.hotends,
            s.thermistor,
            s.extrude_min_c,
            s.extrude_max_mm,
            s.max_temp_c,
            s.mixing_inputs,
            s.inkjet_heads,
            baud = self.baud,
            drivers = self.drivers,
        )
    }
}

/// The line without its `#` comment (a `#` inside a string is kept).
fn strip_comment(line: &str) -> &str {
    let mut in_string = false;
    for (i, c) in line.char_indices() {
        match c {
            '"' => in_string = !in_string,
            '#' if !in_string => return &line[..i],
            _ => {}
        }
    }
    line
}

fn parse_value(text: &str) -> Option<Value> {
    if let Some(inner) = text.strip_prefix('[').and_then(|t| t.strip_suffix(']')) {
        let items = inner.split(',').map(str::trim).filter(|s| !s.is_empty());
        return items.map(parse_value).collect::<Option<Vec<_>>>().map(Value::List);
    }
    if let Some(inner) = text.strip_prefix('"').and_then(|t| t.strip_suffix('"')) {
        return Some(Value::Text(inner.to_string()));
    }
    match text {
        "true" => Some(Value::Bool(true)),
        "false" => Some(Value::Bool(false)),
        _ => text.replace('_', "").parse::<f64>().ok().filter(|v| v.is_finite()).map(Value::Number),
    }
}

fn number(key: &str, value: &Value, min: f64, max: f64) -> Result<f64, String> {
    match value {
        Value::Number(v) if (min..=max).contains(v) => Ok(*v),
        Value::Number(v) => Err(format!("{key}: {v} is outside {min}..={max}")),
        _ => Err(format!("{key} holds numbers")),
    }
}

fn list<'a>(key: &str, value: &'a Value, len: usize) -> Result<&'a [Value], String> {
    list_of(key, value, len, len)
}

/// [`list`] of `min` to `max` values.
fn list_of<'a>(key: &str, value: &'a Value, min: usize, max: usize) -> Result<&'a [Value], String> {
    match value {
        Value::List(items) if (min..=max).contains(&items.len()) => Ok(items),
        _ if min == max => Err(format!("{key} is a list of {min} values")),
        _ => Err(format!("{key} is a list of {min} to {max} values")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_printer_file_is_the_cores_defaults() {
        let file = read(include_str!("../../../firmware/printer.toml")).unwrap();
        assert_eq!(file, PrinterFile { baud: 250_000, drivers: 4, settings: Settings::DEFAULT });
    }

    #[test]
    fn the_mixing_rotary_and_eeb_files_set_their_machines() {
        let mixing = read(include_str!("../../../firmware/printer-mixing.toml")).unwrap();
        assert_eq!((mixing.drivers, mixing.settings.mixing_inputs), (7, 4));
        let rotary = read(include_str!("../../../firmware/printer-rotary.toml")).unwrap();
        assert_eq!(rotary.drivers, 5);
        assert!(rotary.has_rotary() && rotary.settings.rotary.steps_per_deg > 0.0);
        let eeb = read(include_str!("../../../firmware/printer-eeb.toml")).unwrap();
        // The second extruder's driver, on the E1 socket, is stepped.
        assert_eq!((eeb.settings.hotends, eeb.drivers), (2, 5));
    }

    #[test]
    fn a_bad_file_is_refused_at_its_line() {
        let err = |text: &str| read(text).unwrap_err();
        assert_eq!(err("[motion]\nsteps_per_mm = [80, 80, 400]\n").line, 2);
        assert_eq!(
            err("[motion]\n\njunction_deviation_mm = 2\n").message,
            "junction_deviation_mm: 2 is outside 0.001..=0.5"
        );
        assert_eq!(
            err("[motors]\n").message,
            "unknown section [motors] (known: [board], [motion], [heaters], [rotary])"
        );
        assert_eq!(err("[board]\nbaud = 9600\n").message, "baud is 250000 or 115200");
        assert_eq!(err("[board]\nmixing_inputs = 2\n[rotary]\nsteps_per_deg = 10\n").line, 4);
        assert_eq!(
            err("[heaters]\nthermistor = [1, 5, 1]\n").message,
            "thermistor entries are one of [0, 1]"
        );
        // A fifth direction for the E1 socket's motor (EEB's second extruder); not eight.
        let eeb =
            read("[board]\nlayout = \"EEB\"\n[motion]\ninvert_dir = [false, false, false, true, false]\n");
        assert_eq!(eeb.unwrap().settings.invert_dir, 0b0_1000);
        let e1 = read("[motion]\ninvert_dir = [false, false, false, false, true]\n").unwrap();
        assert_eq!(e1.settings.invert_dir, 0b1_0000);
        assert_eq!(
            err("[motion]\ninvert_dir = [true, true, true, true, true, true, true, true]\n").message,
            "invert_dir is a list of 4 to 7 values"
        );
        // Two users of the E1 socket.
        assert_eq!(err("[board]\nlayout = \"EEB\"\nmixing_inputs = 2\n").line, 2);
        assert_eq!(err("[board]\nlayout = \"EEB\"\n[rotary]\nsteps_per_deg = 10\n").line, 4);
        assert_eq!(err("[motion]\nhoming_order = \"XXZ\"\n").line, 2);
        assert_eq!(
            err("[motion]\ntravel_mm = [1, 2, 3, 4]\ntravel_mm = [1, 2, 3, 4]\n").message,
            "travel_mm is set twice"
        );
    }

    #[test]
    fn the_generated_constants_write_every_field() {
        let mut file = read(include_str!("../../../firmware/printer-rotary.toml")).unwrap();
        file.settings.junction_deviation_mm = 1e-7;
        let rust = file.to_rust("printer-rotary.toml");
        assert!(rust.contains("pub const DRIVERS: usize = 5;"), "{rust}");
        assert!(rust.contains("junction_deviation_mm: 1e-7,"), "{rust}");
        assert!(rust.contains("feed: gweave_controller::rotary::RotaryFeed::"), "{rust}");
    }
}
