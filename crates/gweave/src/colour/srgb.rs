//! 8-bit sRGB colours in the `#RRGGBB` notation, and their way into the colour spaces of the
//! `palette` crate.
//!
//! sRGB values as written in files are *gamma encoded*; physics (light adding up, pigments
//! absorbing) happens on *linear* values. The transfer curve (IEC 61966-2-1), the sRGB <-> CIE
//! XYZ matrices (D65) and CIELAB (CIE 15:2004) are `palette`'s; gweave keeps the notation: hex
//! strings as configs and reports write them, parsed strictly (six digits), serialised as text.
//!
//! Bytes go through `f64` both ways, with the exact curve: `palette`'s shortcuts for `u8` are
//! tables, from `u8` off the IEC curve by up to 1.4e-8 (3.9e-6 in L*, enough to move the
//! fitted spectra of `pigments` off their colours), and to `u8` through `f32` accurate to 0.6
//! of a byte. A CIELAB colour outside the sRGB gamut becomes the nearest byte of each linear
//! channel clamped to `[0, 1]`.

use std::fmt;
use std::str::FromStr;

use palette::convert::FromColorUnclamped;
use palette::{LinSrgb, Srgb};
use serde::{Deserialize, Serialize};

use super::Lab;

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

impl From<Srgb8> for LinSrgb<f64> {
    /// Linear light: the transfer curve undone.
    fn from(c: Srgb8) -> Self {
        Srgb::new(c.r, c.g, c.b).into_format::<f64>().into_linear()
    }
}

impl From<Srgb8> for Lab {
    fn from(c: Srgb8) -> Self {
        Lab::from_color_unclamped(LinSrgb::from(c))
    }
}

impl From<Lab> for Srgb8 {
    /// The nearest 8-bit colour, clamped when outside the sRGB gamut (see the module docs).
    fn from(lab: Lab) -> Self {
        let linear = LinSrgb::<f64>::from_color_unclamped(lab);
        let c = Srgb::<f64>::from_linear(linear).into_format::<u8>();
        Self::new(c.red, c.green, c.blue)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(lab: Lab, l: f64, a: f64, b: f64, tol: f64) {
        assert!(
            (lab.l - l).abs() < tol && (lab.a - a).abs() < tol && (lab.b - b).abs() < tol,
            "{lab:?} != ({l}, {a}, {b})"
        );
    }

    #[test]
    fn parses_and_formats_hex() {
        assert_eq!(Srgb8::parse_hex("#FF88aa").unwrap(), Srgb8::new(255, 136, 170));
        assert_eq!(Srgb8::parse_hex("00ff01").unwrap(), Srgb8::new(0, 255, 1));
        assert_eq!(Srgb8::new(255, 136, 170).to_hex(), "#ff88aa");
        for bad in ["", "#", "#12345", "#1234567", "#gg0000", "#+12345", "#ÿ1234", "#fff"] {
            assert!(Srgb8::parse_hex(bad).is_err(), "{bad:?} accepted");
        }
    }

    #[test]
    fn transfer_curve_values() {
        // Mid grey 128 is 21.6 % linear light; byte 10 is on the curve's straight part.
        assert!((LinSrgb::from(Srgb8::new(128, 128, 128)).green - 0.215_861).abs() < 1e-6);
        assert!((LinSrgb::from(Srgb8::new(10, 10, 10)).red - 10.0 / 255.0 / 12.92).abs() < 1e-12);
    }

    #[test]
    fn known_lab_values() {
        // Reference values: B. Lindbloom's calculator, sRGB, D65, no adaptation.
        let lab = |r, g, b| Lab::from(Srgb8::new(r, g, b));
        close(lab(255, 255, 255), 100.0, 0.0, 0.0, 0.01);
        close(lab(0, 0, 0), 0.0, 0.0, 0.0, 1e-9);
        close(lab(255, 0, 0), 53.2408, 80.0925, 67.2032, 0.01);
        close(lab(0, 255, 0), 87.7347, -86.1827, 83.1793, 0.01);
        close(lab(0, 0, 255), 32.2970, 79.1875, -107.8602, 0.01);
        close(lab(128, 128, 128), 53.5850, 0.0, 0.0, 0.01);
    }

    #[test]
    fn srgb_lab_round_trip_is_exact_on_bytes() {
        for v in 0..=255u8 {
            let c = Srgb8::new(v, 255 - v, v / 2);
            assert_eq!(Srgb8::from(Lab::from(c)), c);
        }
        for r in (0..=255u8).step_by(15) {
            for g in (0..=255u8).step_by(17) {
                for b in (0..=255u8).step_by(5) {
                    let c = Srgb8::new(r, g, b);
                    assert_eq!(Srgb8::from(Lab::from(c)), c);
                }
            }
        }
    }

    #[test]
    fn out_of_gamut_colours_clamp() {
        assert_eq!(Srgb8::from(Lab::new(120.0, 0.0, 0.0)), Srgb8::new(255, 255, 255));
        assert_eq!(Srgb8::from(Lab::new(-5.0, 0.0, 0.0)), Srgb8::new(0, 0, 0));
        // A red more saturated than sRGB's: red full, green and blue at zero.
        assert_eq!(Srgb8::from(Lab::new(53.0, 120.0, 90.0)), Srgb8::new(255, 0, 0));
    }
}
