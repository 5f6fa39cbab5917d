//! Decimal numbers as G-code writes them: reading without allocation, writing in a chosen format.
//!
//! Reading uses Clinger's fast path: a decimal `m * 10^-k` with an integer mantissa `m < 2^53`
//! and `k <= 22` is rounded exactly by one IEEE division, because both `m` and `10^k` are exact
//! doubles. That covers every number a slicer writes; anything longer falls back to the standard
//! library's correctly rounded parser, so the result is always the nearest double.

use serde::{Deserialize, Serialize};

/// Exact powers of ten representable as `f64` (10^0 ..= 10^22).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Why the bytes after a word letter are not a number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NumberError {
    /// No digits at all (`X` followed by a space or another letter).
    Empty,
    /// Digits, then something a number cannot contain (`1..2`, `1.2.3`, `-+1`).
    Malformed,
    /// `nan`, `inf` or `infinity`, which firmware would read as garbage.
    NotFinite,
}

/// Scans a G-code number at the start of `bytes`: `[+-]? digits? (. digits?)?` with at least one
/// digit. Returns the value and how many bytes it used. Exponents are not G-code and end the
/// number (the `e` is then the next word's letter, as firmware reads it).
#[inline]
pub fn scan(bytes: &[u8]) -> Result<(f64, usize), NumberError> {
    let mut i = 0;
    let negative = match bytes.first() {
        Some(b'-') => {
            i = 1;
            true
        }
        Some(b'+') => {
            i = 1;
            false
        }
        _ => false,
    };
    let mut mantissa: u64 = 0;
    let mut digits = 0usize;
    let mut frac_digits = 0usize;
    let mut exact = true;
    while let Some(&b) = bytes.get(i) {
        if b.is_ascii_digit() {
            if mantissa < (1 << 53) / 10 {
                mantissa = mantissa * 10 + u64::from(b - b'0');
            } else {
                exact = false;
            }
            digits += 1;
            i += 1;
        } else {
            break;
        }
    }
    if bytes.get(i) == Some(&b'.') {
        i += 1;
        while let Some(&b) = bytes.get(i) {
            if b.is_ascii_digit() {
                if mantissa < (1 << 53) / 10 {
                    mantissa = mantissa * 10 + u64::from(b - b'0');
                    frac_digits += 1;
                } else if b != b'0' {
                    exact = false;
                }
                digits += 1;
                i += 1;
            } else {
                break;
            }
        }
    }
    if digits == 0 {
        let rest = &bytes[i..];
        let word_end = rest
            .iter()
            .position(|b| !b.is_ascii_alphabetic())
            .unwrap_or(rest.len());
        let word = &rest[..word_end];
        return Err(
            if word.eq_ignore_ascii_case(b"nan")
                || word.eq_ignore_ascii_case(b"inf")
                || word.eq_ignore_ascii_case(b"infinity")
            {
                NumberError::NotFinite
            } else if i > 0 || rest.first() == Some(&b'.') {
                NumberError::Malformed
            } else {
                NumberError::Empty
            },
        );
    }
    // A second point or sign glued to the number is a typo, not the start of another word.
    if matches!(bytes.get(i), Some(b'.' | b'+' | b'-')) {
        return Err(NumberError::Malformed);
    }
    let value = if exact && frac_digits < POW10.len() {
        mantissa as f64 / POW10[frac_digits]
    } else {
        // Slow path: more than 15-16 significant digits. Let std round it correctly.
        let text = std::str::from_utf8(&bytes[..i]).map_err(|_| NumberError::Malformed)?;
        text.parse::<f64>()
            .map_err(|_| NumberError::Malformed)?
            .abs()
    };
    Ok((if negative { -value } else { value }, i))
}

/// How new numbers are written: fixed decimals, trailing zeros trimmed, optionally without the
/// leading zero (`.4`, as PrusaSlicer writes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NumberFormat {
    /// Decimals for positions (X Y Z A B C, I J R), mm.
    pub position_decimals: u8,
    /// Decimals for extrusion (E), mm of filament.
    pub extrusion_decimals: u8,
    /// Decimals for feed rates (F), mm/min.
    pub feed_decimals: u8,
    /// Drop trailing zeros (`1.500` -> `1.5`, `2.000` -> `2`).
    pub trim_zeros: bool,
    /// Drop the zero before the point (`0.4` -> `.4`).
    pub drop_leading_zero: bool,
}

impl Default for NumberFormat {
    fn default() -> Self {
        NumberFormat {
            position_decimals: 3,
            extrusion_decimals: 5,
            feed_decimals: 0,
            trim_zeros: true,
            drop_leading_zero: false,
        }
    }
}

impl NumberFormat {
    /// Decimals to use for a word letter.
    pub fn decimals_for(&self, letter: u8) -> u8 {
        match letter.to_ascii_uppercase() {
            b'E' => self.extrusion_decimals,
            b'F' => self.feed_decimals,
            _ => self.position_decimals,
        }
    }

    /// Appends `value` with `decimals` places to `out`. Never writes `-0`.
    pub fn write(&self, out: &mut Vec<u8>, value: f64, decimals: u8) {
        use std::io::Write;
        let start = out.len();
        // `write!` into a Vec cannot fail.
        let _ = write!(out, "{:.*}", decimals as usize, value);
        if self.trim_zeros && decimals > 0 {
            while out.last() == Some(&b'0') {
                out.pop();
            }
            if out.last() == Some(&b'.') {
                out.pop();
            }
        }
        if &out[start..] == b"-0" {
            out.truncate(start);
            out.push(b'0');
        }
        if self.drop_leading_zero {
            let body = if out.get(start) == Some(&b'-') {
                start + 1
            } else {
                start
            };
            if out.get(body) == Some(&b'0') && out.get(body + 1) == Some(&b'.') {
                out.remove(body);
            }
        }
    }

    /// Appends a word such as `X12.5` (letter, then the value in this format).
    pub fn write_word(&self, out: &mut Vec<u8>, letter: u8, value: f64) {
        out.push(letter);
        self.write(out, value, self.decimals_for(letter));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scans_slicer_numbers() {
        assert_eq!(scan(b"10"), Ok((10.0, 2)));
        assert_eq!(scan(b"-2.5Y"), Ok((-2.5, 4)));
        assert_eq!(scan(b".4 "), Ok((0.4, 2)));
        assert_eq!(scan(b"+3."), Ok((3.0, 3)));
        assert_eq!(scan(b"0.0125"), Ok((0.0125, 6)));
        assert_eq!(scan(b"754.09214"), Ok((754.09214, 9)));
    }

    #[test]
    fn rejects_what_is_not_a_number() {
        assert_eq!(scan(b" 1"), Err(NumberError::Empty));
        assert_eq!(scan(b""), Err(NumberError::Empty));
        assert_eq!(scan(b"1..2"), Err(NumberError::Malformed));
        assert_eq!(scan(b"-"), Err(NumberError::Malformed));
        assert_eq!(scan(b"NaN"), Err(NumberError::NotFinite));
        assert_eq!(scan(b"-inf"), Err(NumberError::NotFinite));
        assert_eq!(scan(b"1.2.3"), Err(NumberError::Malformed));
    }

    #[test]
    fn long_numbers_round_like_std() {
        let text = "3.14159265358979323846264338327950288";
        assert_eq!(
            scan(text.as_bytes()).unwrap().0,
            text.parse::<f64>().unwrap()
        );
        let text = "123456789012345678901234";
        assert_eq!(
            scan(text.as_bytes()).unwrap().0,
            text.parse::<f64>().unwrap()
        );
    }

    #[test]
    fn writes_in_format() {
        let f = NumberFormat::default();
        let mut out = Vec::new();
        f.write_word(&mut out, b'X', 10.0);
        out.push(b' ');
        f.write_word(&mut out, b'E', 0.123456);
        out.push(b' ');
        f.write_word(&mut out, b'Y', -0.0001);
        out.push(b' ');
        f.write_word(&mut out, b'F', 1800.4);
        assert_eq!(out, b"X10 E0.12346 Y0 F1800");
        let prusa = NumberFormat {
            drop_leading_zero: true,
            ..f
        };
        let mut out = Vec::new();
        prusa.write_word(&mut out, b'E', -0.4);
        assert_eq!(out, b"E-.4");
    }

    proptest::proptest! {
        #[test]
        fn scan_matches_std_for_plain_decimals(int in 0u32..100000, frac in 0u32..100000, neg: bool) {
            let text = format!("{}{}.{:05}", if neg { "-" } else { "" }, int, frac);
            let (value, used) = scan(text.as_bytes()).unwrap();
            proptest::prop_assert_eq!(used, text.len());
            proptest::prop_assert_eq!(value, text.parse::<f64>().unwrap());
        }
    }
}
