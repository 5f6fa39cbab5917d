//! Rotary (lathe-type) printing: a nozzle over a turning mandrel.
//!
//! The machine has three motion axes: one **axial** axis along the mandrel (default `X`), one
//! **rotary** axis that turns it (default `A`, in degrees, or a linear `Y` that the firmware
//! treats as millimetres of circumference), and one **radial** axis that lifts the nozzle off the
//! mandrel surface (default `Z`, with `Z = 0` the nozzle touching the mandrel).
//!
//! - [`cylinder`]: the machine maths as pure functions: the feed-rate conventions (the trap of
//!   rotary printing), the flat-to-cylinder unwrap mapping, chord subdivision, the seam.
//! - [`emit`]: the move writer shared by the generators: fixed decimals, absolute or relative E,
//!   F converted per convention from the rounded coordinates the firmware will actually see.
//! - `helical`: helical unwrapping of a flat part (no weld line) and the check that a part is
//!   not wider than the circumference.
//! - [`helix`]: seam-free helical tubes and custom helical paths (cones, variable pitch).
//! - [`wrap`]: the streaming pass that prints a flat-sliced part onto the mandrel.
//! - [`preview`]: any rotary program read back as the machine runs it, and drawn in 3D.
//! - [`options`]: the options of both jobs (the CLI's flags, Python's keywords), declared once,
//!   and laid over the TOML settings.
//! - [`surface`]: `gweave stats` of a rotary program, lengths and extents on the mandrel.
//! - [`report`]: both jobs end to end (write, read back, draw, report) for the CLI and Python.
//!
//! ```
//! use gweave::rotary::{helix::TubeParams, cylinder::RotaryConfig};
//! let mut params = TubeParams::new(RotaryConfig::new(20.0));
//! params.length_mm = 5.0;
//! params.layers = 2;
//! let mut out = Vec::new();
//! params.write_gcode(&mut out).unwrap();
//! let text = String::from_utf8(out).unwrap();
//! assert!(text.starts_with("; gweave rotary tube"));
//!
//! // A flat part onto a mandrel of 60 mm circumference: Y15 is a quarter turn. The 18.03 mm
//! // move at 20 mm/s takes 0.9014 s; under the NIST convention F is the X speed in it.
//! use gweave::rotary::wrap::{wrap_bytes, WrapConfig};
//! let mut config = WrapConfig::new(RotaryConfig::new(60.0 / std::f64::consts::PI));
//! config.chord_tolerance_mm = 0.0; // one line per flat move
//! let out = wrap_bytes(config, b"G1 X10 Y15 F1200\n").unwrap();
//! let text = String::from_utf8(out).unwrap();
//! assert!(text.starts_with("; gweave rotary wrap: mandrel 19.09"), "the header names the machine");
//! assert!(text.ends_with("\nG92 A0.000\nG1 X10.000 A90.000 F665.640\n"));
//! ```

pub mod cylinder;
pub mod emit;
pub(crate) mod helical;
pub mod helix;
pub mod options;
pub mod preview;
pub mod report;
mod setup;
pub mod surface;
pub mod wrap;

use thiserror::Error;

/// Everything that can go wrong in the rotary module.
#[derive(Debug, Error)]
pub enum RotaryError {
    /// A configuration value is out of range or inconsistent.
    #[error("invalid rotary setting `{key}`: {reason}")]
    Config {
        /// The TOML key (or G-code word) of the offending setting.
        key: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// The part is wider than the mandrel's circumference and overlap was not allowed: no
    /// setting of the user's is wrong, the part and the mandrel do not fit (the reason says by
    /// how much, and the two ways out).
    #[error("the part does not fit round the mandrel: {0}")]
    WiderThanMandrel(String),
    /// No mandrel diameter: neither the options (a CLI flag, a Python keyword) nor the settings
    /// file give one; named as neither front end spells it.
    #[error(
        "no mandrel diameter: give one ({}), or a config file with [machine] mandrel_diameter_mm",
        cylinder::MANDREL_DIAMETER_MM
    )]
    NoMandrel,
    /// A setting outside its physical range.
    #[error(transparent)]
    Range(#[from] crate::range::OutOfRange),
    /// The TOML text could not be read (unknown key, wrong type, syntax).
    #[error("rotary config: {0}")]
    Toml(String),
    /// A profile function returned a value that cannot be printed.
    #[error("{what} profile gave {value} at axial {axial_mm} mm; it must be finite and > 0")]
    Profile {
        /// `pitch` or `radius`.
        what: &'static str,
        /// Where along the mandrel it was evaluated.
        axial_mm: f64,
        /// The value it returned.
        value: f64,
    },
    /// A point lies on or below the mandrel axis (radius <= 0).
    #[error("radius {radius_mm} mm is not above the mandrel axis")]
    BelowAxis {
        /// The offending radius.
        radius_mm: f64,
    },
    /// A path would need more points than the safety limit (runaway parameters).
    #[error("the path needs more than {limit} points; check the length, layers, pitch and chord tolerance")]
    TooManyPoints {
        /// The limit that was hit.
        limit: usize,
    },
    /// One flat move would wrap into more chords than the safety limit: an arc of kilometres,
    /// or a move of thousands of turns round the mandrel.
    #[error("the move wraps into more than {limit} chords on the mandrel; check its length (an arc's radius) and the chord tolerance")]
    TooManyChords {
        /// The limit that was hit.
        limit: usize,
    },
    /// A move was asked for before the machine's position was established.
    #[error("a move was written before the machine's position was known")]
    UnknownPosition,
    /// The core engine failed (reading, syntax), or a line could not be wrapped
    /// ([`crate::Error::Pass`], its source the line's [`RotaryError`]).
    #[error(transparent)]
    Engine(#[from] crate::Error),
    /// Writing the output failed.
    #[error("writing G-code: {0}")]
    Io(#[from] std::io::Error),
}

impl From<toml::de::Error> for RotaryError {
    fn from(e: toml::de::Error) -> Self {
        RotaryError::Toml(crate::settings::toml_message(&e))
    }
}

/// Shorthand for results of this module.
pub type Result<T, E = RotaryError> = std::result::Result<T, E>;

/// Checks `[table] key = value` against its range (see [`crate::settings`]).
pub(crate) fn in_range<T: crate::range::Quantity>(
    table: &str,
    key: &str,
    value: T,
    range: crate::range::Range<T>,
) -> Result<()> {
    Ok(crate::settings::Table::root().sub(table).check(key, value, range)?)
}

/// Checks that `value` is finite.
pub(crate) fn finite(key: &'static str, value: f64) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(RotaryError::Config { key, reason: format!("must be finite, got {value}") })
    }
}
