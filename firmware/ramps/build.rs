//! Reads the printer's settings (`../printer.toml`, or the file `GWEAVE_PRINTER` names, such as
//! `../printer-mixing.toml` for `make firmware`'s mixing image) at build time and writes them
//! as Rust constants into `$OUT_DIR/printer.rs`, which `src/main.rs` includes.
//!
//! The file is a small subset of TOML (sections, `key = value` with numbers, strings, booleans
//! and flat arrays), read here by hand so that the firmware build needs no parser crate. Every
//! key is checked against the table below: an unknown key, a wrong type or a value out of
//! range stops the build, naming the line.

use std::fmt::Write as _;

/// A value as written in the file.
#[derive(Debug, Clone)]
enum Value {
    Number(f64),
    Text(String),
    Bool(bool),
    List(Vec<Value>),
}

/// What a key holds and which Rust field it sets.
enum Kind {
    /// One float of `Settings`, within a range.
    Float { field: &'static str, min: f64, max: f64 },
    /// A float per entry (`len` of them) of `Settings`, within a range.
    Floats { field: &'static str, len: usize, min: f64, max: f64 },
    /// Booleans per axis, stored as the bits of a byte.
    Bits { field: &'static str, len: usize },
    /// Small integers of `Settings`, one per entry.
    Bytes { field: &'static str, len: usize, allowed: &'static [u8] },
    /// `[Kp, Ki, Kd]` of a `Pid`.
    Pid { field: &'static str },
    /// The order of X, Y and Z as a string (`"ZYX"`), stored as axis indices.
    AxisOrder { field: &'static str },
    /// Handled by hand below (board keys).
    Board,
}

/// Every key the file may have: `(section, key, kind)`.
const KEYS: &[(&str, &str, Kind)] = &[
    ("board", "baud", Kind::Board),
    ("board", "layout", Kind::Board),
    ("board", "mixing_inputs", Kind::Board),
    ("motion", "steps_per_mm", Kind::Floats { field: "steps_per_mm", len: 4, min: 1.0, max: 10_000.0 }),
    ("motion", "max_feed_mm_s", Kind::Floats { field: "max_feed_mm_s", len: 4, min: 0.1, max: 1_000.0 }),
    (
        "motion",
        "max_accel_mm_s2",
        Kind::Floats { field: "max_accel_mm_s2", len: 4, min: 1.0, max: 100_000.0 },
    ),
    ("motion", "print_accel_mm_s2", Kind::Float { field: "print_accel_mm_s2", min: 1.0, max: 100_000.0 }),
    ("motion", "retract_accel_mm_s2", Kind::Float { field: "retract_accel_mm_s2", min: 1.0, max: 100_000.0 }),
    ("motion", "travel_accel_mm_s2", Kind::Float { field: "travel_accel_mm_s2", min: 1.0, max: 100_000.0 }),
    ("motion", "junction_deviation_mm", Kind::Float { field: "junction_deviation_mm", min: 0.001, max: 0.5 }),
    ("motion", "travel_mm", Kind::Floats { field: "travel_mm", len: 4, min: 0.0, max: 2_000.0 }),
    ("motion", "homing_feed_mm_s", Kind::Floats { field: "homing_feed_mm_s", len: 4, min: 0.0, max: 300.0 }),
    ("motion", "homing_order", Kind::AxisOrder { field: "homing_order" }),
    ("motion", "homing_bump_mm", Kind::Floats { field: "homing_bump_mm", len: 4, min: 0.0, max: 50.0 }),
    ("motion", "invert_dir", Kind::Bits { field: "invert_dir", len: 4 }),
    ("motion", "endstop_inverting", Kind::Bits { field: "endstop_inverting", len: 3 }),
    ("heaters", "thermistor", Kind::Bytes { field: "thermistor", len: 3, allowed: &[0, 1] }),
    ("heaters", "hotend_pid", Kind::Pid { field: "hotend_pid" }),
    ("heaters", "max_temp_c", Kind::Floats { field: "max_temp_c", len: 3, min: 0.0, max: 400.0 }),
    // The rotary axis A on the E1 socket (docs/firmware.md, "Rotary"): steps per degree of the
    // mandrel, its speed and acceleration limits, and what F means on a move that turns it.
    ("rotary", "steps_per_deg", Kind::Float { field: "rotary.steps_per_deg", min: 0.01, max: 1_000.0 }),
    ("rotary", "max_feed_deg_s", Kind::Float { field: "rotary.max_feed_deg_s", min: 0.1, max: 10_000.0 }),
    (
        "rotary",
        "max_accel_deg_s2",
        Kind::Float { field: "rotary.max_accel_deg_s2", min: 1.0, max: 1_000_000.0 },
    ),
    ("rotary", "feed", Kind::Board),
    ("rotary", "invert_dir", Kind::Board),
];

/// The file read when `GWEAVE_PRINTER` names none, relative to `firmware/`.
const DEFAULT_PRINTER: &str = "printer.toml";

fn main() {
    if std::env::var("CARGO_CFG_TARGET_ARCH").as_deref() == Ok("avr") {
        // avr-libc's float arithmetic (libm.a: `__mulsf3`, `__addsf3`, `__divsf3`, ...,
        // hand-written AVR assembly) before Rust's `compiler_builtins`, whose portable versions
        // (weak symbols, so libm's win) multiply through 64-bit integers: about 8 times slower
        // on the 8-bit chip, and the main loop then planned a line in 17 ms (docs/firmware.md,
        // "Where the main loop's time goes").
        println!("cargo::rustc-link-lib=m");
    }
    println!("cargo::rerun-if-env-changed=GWEAVE_PRINTER");
    let name = std::env::var("GWEAVE_PRINTER").unwrap_or_else(|_| DEFAULT_PRINTER.to_string());
    let path = format!("{}/../{name}", env!("CARGO_MANIFEST_DIR"));
    println!("cargo::rerun-if-changed={path}");
    let text =
        std::fs::read_to_string(&path).unwrap_or_else(|e| fail(&name, 0, &format!("cannot read it: {e}")));
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    // Written aside, then renamed over: a reader never sees half a file, and a target folder
    // seeded by hard links from another keeps the other's copy.
    let (tmp, dest) = (format!("{out}/printer.rs.tmp"), format!("{out}/printer.rs"));
    std::fs::write(&tmp, generate(&name, &text)).expect("OUT_DIR is writable");
    std::fs::rename(&tmp, &dest).expect("OUT_DIR is writable");
}

/// Stop the build with a message naming the file and line.
fn fail(file: &str, line: usize, msg: &str) -> ! {
    eprintln!("firmware/{file}:{line}: {msg}");
    std::process::exit(1);
}

/// The Rust source of the settings in `text`.
fn generate(file: &str, text: &str) -> String {
    let fail = |line: usize, msg: &str| -> ! { fail(file, line, msg) };
    let mut baud = 250_000u32;
    let mut hotends = 1u8;
    let mut mixing_inputs = 0u8;
    // The [rotary] section's keys, gathered into one `Rotary` after the file is read.
    let mut rotary: Vec<(&str, String)> = Vec::new();
    let mut rotary_line = 0;
    let mut invert_dir: Option<u8> = None;
    let mut fields = String::new();
    let mut section = String::new();
    let mut seen: Vec<(String, String)> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let line = strip_comment(raw).trim();
        if line.is_empty() {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = name.trim().to_string();
            if !KEYS.iter().any(|(s, _, _)| *s == section) {
                fail(
                    n,
                    &format!("unknown section [{section}] (known: [board], [motion], [heaters], [rotary])"),
                );
            }
            continue;
        }
        let Some((key, value)) = line.split_once('=') else { fail(n, "expected `key = value`") };
        let key = key.trim();
        let value =
            parse_value(value.trim()).unwrap_or_else(|| fail(n, &format!("cannot read the value of {key}")));
        let Some((_, static_key, kind)) = KEYS.iter().find(|(s, k, _)| *s == section && *k == key) else {
            let known: Vec<&str> =
                KEYS.iter().filter(|(s, _, _)| *s == section).map(|(_, k, _)| *k).collect();
            fail(n, &format!("unknown key {key} in [{section}] (known: {})", known.join(", ")));
        };
        if seen.contains(&(section.clone(), key.to_string())) {
            fail(n, &format!("{key} is set twice"));
        }
        seen.push((section.clone(), key.to_string()));
        if section == "rotary" {
            rotary_line = n;
            rotary.push(rotary_value(file, n, static_key, kind, &value));
            continue;
        }
        match kind {
            Kind::Board if key == "baud" => match value {
                Value::Number(b) if b == 250_000.0 || b == 115_200.0 => baud = b as u32,
                _ => fail(n, "baud is 250000 or 115200"),
            },
            Kind::Board if key == "mixing_inputs" => match value {
                // 0: a plain extruder; 2 to 4 inputs of a mixing hotend (E0, E1 on the
                // extruder sockets, E2, E3 on AUX-2).
                Value::Number(k) if [0.0, 2.0, 3.0, 4.0].contains(&k) => mixing_inputs = k as u8,
                _ => fail(n, "mixing_inputs is 0 (no mixing hotend), 2, 3 or 4"),
            },
            Kind::Board => match value {
                Value::Text(t) if t == "EFB" => hotends = 1,
                Value::Text(t) if t == "EEB" => hotends = 2,
                _ => fail(n, "layout is \"EFB\" or \"EEB\""),
            },
            Kind::Float { field, min, max } => {
                let v = number(file, n, key, &value, *min, *max);
                let _ = writeln!(fields, "    {field}: {v:?},");
            }
            Kind::Floats { field, len, min, max } => {
                let vs: Vec<String> = list(file, n, key, &value, *len)
                    .iter()
                    .map(|v| format!("{:?}", number(file, n, key, v, *min, *max)))
                    .collect();
                let _ = writeln!(fields, "    {field}: [{}],", vs.join(", "));
            }
            Kind::Bits { field, len } => {
                let mut bits = 0u8;
                for (axis, v) in list(file, n, key, &value, *len).iter().enumerate() {
                    match v {
                        Value::Bool(true) => bits |= 1 << axis,
                        Value::Bool(false) => {}
                        _ => fail(n, &format!("{key} holds true or false per axis")),
                    }
                }
                if *field == "invert_dir" {
                    // Written at the end, with the rotary axis' bit.
                    invert_dir = Some(bits);
                } else {
                    let _ = writeln!(fields, "    {field}: {bits:#06b},");
                }
            }
            Kind::Bytes { field, len, allowed } => {
                let vs: Vec<String> = list(file, n, key, &value, *len)
                    .iter()
                    .map(|v| match v {
                        Value::Number(x) if allowed.iter().any(|&a| f64::from(a) == *x) => format!("{x}"),
                        _ => fail(n, &format!("{key} entries are one of {allowed:?}")),
                    })
                    .collect();
                let _ = writeln!(fields, "    {field}: [{}],", vs.join(", "));
            }
            Kind::AxisOrder { field } => {
                let order = match &value {
                    Value::Text(t) => t.clone(),
                    _ => fail(n, &format!("{key} is a string such as \"ZYX\"")),
                };
                let mut sorted: Vec<char> = order.chars().collect();
                sorted.sort_unstable();
                if sorted != ['X', 'Y', 'Z'] {
                    fail(n, &format!("{key} names X, Y and Z once each, such as \"ZYX\""));
                }
                let axes: Vec<String> =
                    order.chars().map(|c| ((c as u8 - b'X') as usize).to_string()).collect();
                let _ = writeln!(fields, "    {field}: [{}],", axes.join(", "));
            }
            Kind::Pid { field } => {
                let g: Vec<f64> = list(file, n, key, &value, 3)
                    .iter()
                    .map(|v| number(file, n, key, v, 0.0, 10_000.0))
                    .collect();
                let _ = writeln!(
                    fields,
                    "    {field}: gweave_controller::settings::Pid {{ kp: {:?}, ki: {:?}, kd: {:?} }},",
                    g[0], g[1], g[2]
                );
            }
        }
    }
    // The drivers the step interrupt runs: X, Y, Z, E0, and the other inputs of a mixing hotend,
    // or the rotary axis on E1's socket.
    let mut drivers = 4 + usize::from(mixing_inputs.max(1)) - 1;
    if !rotary.is_empty() {
        if mixing_inputs > 0 {
            fail(rotary_line, "a rotary axis turns the E1 socket's motor, which a mixing hotend uses");
        }
        if std::env::var_os("CARGO_FEATURE_ROTARY").is_none() {
            fail(rotary_line, "[rotary] needs the build's feature `rotary` (`--features rotary`)");
        }
        let Some((_, steps)) = rotary.iter().find(|(k, _)| *k == "steps_per_deg") else {
            fail(rotary_line, "[rotary] needs steps_per_deg")
        };
        let mut fields_a = format!("steps_per_deg: {steps}, ");
        for key in ["max_feed_deg_s", "max_accel_deg_s2", "feed"] {
            if let Some((_, v)) = rotary.iter().find(|(k, _)| *k == key) {
                let _ = write!(fields_a, "{key}: {v}, ");
            }
        }
        let _ = writeln!(
            fields,
            "    rotary: gweave_controller::rotary::Rotary {{ {fields_a}..gweave_controller::rotary::Rotary::NONE }},"
        );
        if rotary.iter().any(|(k, v)| *k == "invert_dir" && v == "true") {
            // A's motor is the fifth (E1's socket): bit 1 << 4 of the DIR bits.
            invert_dir = Some(invert_dir.unwrap_or(0) | 1 << 4);
        }
        drivers = 5;
    }
    if let Some(bits) = invert_dir {
        let _ = writeln!(fields, "    invert_dir: {bits:#07b},");
    }
    format!(
        "// Generated by build.rs from firmware/{file}: edit that file, not this one.\n\
         use gweave_controller::Settings;\n\n\
         /// The serial line's speed, baud.\n\
         pub const BAUD: u32 = {baud};\n\n\
         /// The driver sockets used, in the order X, Y, Z, E0, E1, E2, E3.\n\
         pub const DRIVERS: usize = {drivers};\n\n\
         /// The printer's settings (the controller's defaults where the file says nothing).\n\
         #[allow(clippy::needless_update)]\n\
         pub const SETTINGS: Settings = Settings {{\n    hotends: {hotends},\n    mixing_inputs: {mixing_inputs},\n{fields}    ..Settings::DEFAULT\n}};\n"
    )
}

/// A `[rotary]` key's value as the Rust expression of its `Rotary` field (`invert_dir`: `true`
/// or `false`, applied to the DIR bits by the caller).
fn rotary_value(
    file: &str,
    n: usize,
    key: &'static str,
    kind: &Kind,
    value: &Value,
) -> (&'static str, String) {
    let text = match (kind, value) {
        (Kind::Float { min, max, .. }, _) => format!("{:?}", number(file, n, key, value, *min, *max)),
        (_, Value::Text(t)) if key == "feed" && t == "nist" => {
            "gweave_controller::rotary::RotaryFeed::Nist".into()
        }
        (_, Value::Text(t)) if key == "feed" && t == "combined" => {
            "gweave_controller::rotary::RotaryFeed::Combined".into()
        }
        (_, Value::Bool(b)) if key == "invert_dir" => b.to_string(),
        _ if key == "feed" => fail(file, n, "feed is \"nist\" or \"combined\""),
        _ => fail(file, n, &format!("{key} is true or false")),
    };
    (key, text)
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

fn number(file: &str, line: usize, key: &str, value: &Value, min: f64, max: f64) -> f64 {
    let fail = |line: usize, msg: &str| -> ! { fail(file, line, msg) };
    match value {
        Value::Number(v) if (min..=max).contains(v) => *v,
        Value::Number(v) => fail(line, &format!("{key}: {v} is outside {min}..={max}")),
        _ => fail(line, &format!("{key} holds numbers")),
    }
}

fn list<'a>(file: &str, line: usize, key: &str, value: &'a Value, len: usize) -> &'a [Value] {
    match value {
        Value::List(items) if items.len() == len => items,
        _ => fail(file, line, &format!("{key} is a list of {len} values")),
    }
}
