//! 8-bit sRGB colours, the `#RRGGBB` notation, and the sRGB transfer curve.
//!
//! sRGB values as written in files are *gamma encoded*; physics (light adding up,
//! pigments absorbing) happens on *linear* values. The transfer curve is the
//! piecewise one from IEC 61966-2-1:
//!
//! ```text
//!   linear = c / 12.92                     if c <= 0.04045
//!   linear = ((c + 0.055) / 1.055)^2.4     otherwise
//! ```
//!
//! and its inverse with the threshold `0.0031308` on the linear side.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// Why a `#RRGGBB` string was rejected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HexColourError {
    /// Not six hex digits (after an optional leading `#`).
    #[error("colour {0:?} is not of the form #RRGGBB")]
    Format(String),
}

/// An 8-bit, gamma-encoded sRGB colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, Serialize)]
#[serde(try_from = "String", into = "String")]
pub struct Srgb8 {
    /// Red, 0 to 255.
    pub r: u8,
    /// Green, 0 to 255.
    pub g: u8,
    /// Blue, 0 to 255.
    pub b: u8,
}

/// A linear-light sRGB colour, each channel nominally in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearRgb {
    pub r: f64,
    pub g: f64,
    pub b: f64,
}

/// Encoded channel in `[0, 1]` to linear light (IEC 61966-2-1).
pub fn decode_channel(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light in `[0, 1]` to an encoded channel (IEC 61966-2-1).
pub fn encode_channel(l: f64) -> f64 {
    if l <= 0.003_130_8 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// Encoded `[0, 1]` value to the nearest byte, clamping out-of-range values.
fn to_byte(c: f64) -> u8 {
    // `as` saturates and maps NaN to 0, so no input can overflow.
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

impl Srgb8 {
    /// The colour with channels `r`, `g`, `b`.
    pub const fn new(r: u8, g: u8, b: u8) -> Self {
        Self { r, g, b }
    }

    /// Parse `#RRGGBB` (the `#` may be left out, digits in either case).
    pub fn parse_hex(s: &str) -> Result<Self, HexColourError> {
        let digits = s.strip_prefix('#').unwrap_or(s);
        let bad = || HexColourError::Format(s.to_owned());
        if digits.len() != 6 || !digits.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(bad());
        }
        let byte = |i: usize| u8::from_str_radix(&digits[i..i + 2], 16).map_err(|_| bad());
        Ok(Self::new(byte(0)?, byte(2)?, byte(4)?))
    }

    /// `#rrggbb`, lower case.
    pub fn to_hex(self) -> String {
        self.to_string()
    }

    /// The linear-light RGB of this colour (the sRGB transfer curve undone).
    pub fn to_linear(self) -> LinearRgb {
        let ch = |v: u8| decode_channel(f64::from(v) / 255.0);
        LinearRgb { r: ch(self.r), g: ch(self.g), b: ch(self.b) }
    }

    /// Nearest 8-bit colour; channels outside `[0, 1]` are clamped (out of the sRGB gamut).
    pub fn from_linear(c: LinearRgb) -> Self {
        Self::new(to_byte(encode_channel(c.r)), to_byte(encode_channel(c.g)), to_byte(encode_channel(c.b)))
    }
}

impl fmt::Display for Srgb8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#{:02x}{:02x}{:02x}", self.r, self.g, self.b)
    }
}

impl FromStr for Srgb8 {
    type Err = HexColourError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse_hex(s)
    }
}

impl From<Srgb8> for String {
    fn from(c: Srgb8) -> String {
        c.to_string()
    }
}

impl TryFrom<String> for Srgb8 {
    type Error = HexColourError;
    fn try_from(s: String) -> Result<Self, Self::Error> {
        Self::parse_hex(&s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_formats_hex() {
        assert_eq!(Srgb8::parse_hex("#FF88aa").unwrap(), Srgb8::new(255, 136, 170));
        assert_eq!(Srgb8::parse_hex("00ff01").unwrap(), Srgb8::new(0, 255, 1));
        assert_eq!(Srgb8::new(255, 136, 170).to_hex(), "#ff88aa");
        for bad in ["", "#", "#12345", "#1234567", "#gg0000", "#+12345", "#ÿ1234"] {
            assert!(Srgb8::parse_hex(bad).is_err(), "{bad:?} accepted");
        }
    }

    #[test]
    fn transfer_curve_values() {
        // Mid grey 128 is 21.6 % linear light; 0.04045 is the curve's joint.
        assert!((Srgb8::new(128, 128, 128).to_linear().g - 0.215_861).abs() < 1e-6);
        assert!((decode_channel(0.04045) - 0.003_130_8).abs() < 1e-7);
        assert!((encode_channel(0.5) - 0.735_357).abs() < 1e-6);
    }

    #[test]
    fn every_byte_round_trips_through_linear() {
        for v in 0..=255u8 {
            let c = Srgb8::new(v, 255 - v, v / 2);
            assert_eq!(Srgb8::from_linear(c.to_linear()), c);
        }
    }

    #[test]
    fn out_of_gamut_linear_values_clamp() {
        let c = LinearRgb { r: -0.2, g: 1.7, b: f64::NAN };
        assert_eq!(Srgb8::from_linear(c), Srgb8::new(0, 255, 0));
    }
}
