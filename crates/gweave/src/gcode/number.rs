//! Decimal numbers as G-code writes them: reading without allocation, writing in a chosen format.
//!
//! Reading uses Clinger's fast path: a decimal `m * 10^-k` with an integer mantissa `m < 2^53`
//! and `k <= 22` is rounded exactly by one IEEE division, because both `m` and `10^k` are exact
//! doubles. That covers every number a slicer writes; anything longer falls back to the standard
//! library's correctly rounded parser, so the result is always the nearest double.

use serde::{Deserialize, Serialize};

/// Exact powers of ten representable as `f64` (10^0 ..= 10^22).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18,
    1e19, 1e20, 1e21, 1e22,
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
    let (negative, start) = match bytes.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    let mut mantissa: u64 = 0;
    let int_digits = digits(&bytes[start..], &mut mantissa);
    let mut i = start + int_digits;
    let mut frac_digits = 0;
    if bytes.get(i) == Some(&b'.') {
        i += 1;
        frac_digits = digits(&bytes[i..], &mut mantissa);
        i += frac_digits;
    }
    if int_digits + frac_digits == 0 {
        return Err(no_digits(&bytes[i..], i > 0 || bytes.first() == Some(&b'.')));
    }
    // A second point or sign glued to the number is a typo, not the start of another word.
    if matches!(bytes.get(i), Some(b'.' | b'+' | b'-')) {
        return Err(NumberError::Malformed);
    }
    if int_digits + frac_digits > 15 {
        return scan_slow(bytes, negative, start);
    }
    // At most 15 digits: the mantissa is below 2^53, exact, and one division rounds correctly.
    let value = (mantissa as i64) as f64 / POW10[frac_digits];
    Ok((if negative { -value } else { value }, i))
}

/// Accumulates the leading ASCII digits of `bytes` into `mantissa` (wrapping: callers with more
/// than 15 digits take the slow path) and returns how many there were.
#[inline]
fn digits(bytes: &[u8], mantissa: &mut u64) -> usize {
    let mut n = 0;
    for &b in bytes {
        let d = b.wrapping_sub(b'0');
        if d >= 10 {
            break;
        }
        *mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
        n += 1;
    }
    n
}

/// Numbers with long digit runs: let std round them correctly.
#[cold]
fn scan_slow(bytes: &[u8], negative: bool, start: usize) -> Result<(f64, usize), NumberError> {
    let mut i = start;
    while bytes.get(i).is_some_and(u8::is_ascii_digit) {
        i += 1;
    }
    if bytes.get(i) == Some(&b'.') {
        i += 1;
        while bytes.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
    }
    if matches!(bytes.get(i), Some(b'.' | b'+' | b'-')) {
        return Err(NumberError::Malformed);
    }
    let text = std::str::from_utf8(&bytes[start..i]).map_err(|_| NumberError::Malformed)?;
    let value: f64 = text.parse().map_err(|_| NumberError::Malformed)?;
    Ok((if negative { -value } else { value }, i))
}

/// Classifies a word value without digits: `nan`/`inf`, a lone sign or point, or nothing.
#[cold]
fn no_digits(rest: &[u8], had_sign_or_point: bool) -> NumberError {
    let word_end = rest.iter().position(|b| !b.is_ascii_alphabetic()).unwrap_or(rest.len());
    let word = &rest[..word_end];
    if word.eq_ignore_ascii_case(b"nan")
        || word.eq_ignore_ascii_case(b"inf")
        || word.eq_ignore_ascii_case(b"infinity")
    {
        NumberError::NotFinite
    } else if had_sign_or_point {
        NumberError::Malformed
    } else {
        NumberError::Empty
    }
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
        // A negative value that rounds to zero prints as `-0` or `-0.000`: drop the sign.
        if out.get(start) == Some(&b'-') && out[start + 1..].iter().all(|&b| b == b'0' || b == b'.') {
            out.remove(start);
        }
        if self.drop_leading_zero {
            let body = if out.get(start) == Some(&b'-') { start + 1 } else { start };
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
        assert_eq!(scan(text.as_bytes()).unwrap().0, text.parse::<f64>().unwrap());
        let text = "123456789012345678901234";
        assert_eq!(scan(text.as_bytes()).unwrap().0, text.parse::<f64>().unwrap());
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
        let fixed = NumberFormat { trim_zeros: false, ..f };
        let mut out = Vec::new();
        fixed.write_word(&mut out, b'Z', -0.0001);
        assert_eq!(out, b"Z0.000");
        let prusa = NumberFormat { drop_leading_zero: true, ..f };
        let mut out = Vec::new();
        prusa.write_word(&mut out, b'E', -0.4);
        assert_eq!(out, b"E-.4");
    }

    #[test]
    fn digit_runs_of_every_length() {
        for int_len in 0..12 {
            for frac_len in 0..12 {
                if int_len + frac_len == 0 {
                    continue;
                }
                let int: String = (0..int_len).map(|k| char::from(b'1' + (k % 9) as u8)).collect();
                let frac: String = (0..frac_len).map(|k| char::from(b'9' - (k % 9) as u8)).collect();
                for text in [format!("{int}.{frac} "), format!("-{int}.{frac}X"), format!("{int}.{frac}")] {
                    let body = text.trim_end_matches([' ', 'X']);
                    let expected: f64 = body.parse().unwrap();
                    assert_eq!(scan(text.as_bytes()), Ok((expected, body.len())), "{text:?}");
                }
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn scan_matches_std_for_any_decimal(text in "[+-]?[0-9]{0,20}(\\.[0-9]{0,20})?") {
            let digits = text.bytes().filter(u8::is_ascii_digit).count();
            let result = scan(text.as_bytes());
            if digits == 0 {
                proptest::prop_assert!(result.is_err());
            } else {
                let expected: f64 = text.trim_start_matches('+').parse().unwrap();
                proptest::prop_assert_eq!(result, Ok((expected, text.len())));
            }
        }

        #[test]
        fn scan_matches_std_for_plain_decimals(int in 0u32..100000, frac in 0u32..100000, neg: bool) {
            let text = format!("{}{}.{:05}", if neg { "-" } else { "" }, int, frac);
            let (value, used) = scan(text.as_bytes()).unwrap();
            proptest::prop_assert_eq!(used, text.len());
            proptest::prop_assert_eq!(value, text.parse::<f64>().unwrap());
        }
    }
}
