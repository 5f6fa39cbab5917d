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
pub(crate) enum NumberError {
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
pub(crate) fn scan(bytes: &[u8]) -> Result<(f64, usize), NumberError> {
    scan_at(bytes, 0)
}

/// [`scan`] for the number that starts at `at` in `line`; returns the value and the index in
/// `line` where the number ends. Seeing the whole line lets short numbers near its end be read
/// eight bytes at a time too.
#[inline(always)]
pub(crate) fn scan_at(line: &[u8], at: usize) -> Result<(f64, usize), NumberError> {
    scan_from::<true>(line, at)
}

/// [`scan_at`] for a caller that reads the line again with the general rules unless the byte
/// after the number is a space or the line's end: the test for a second point or a sign glued
/// to the number (a typo [`scan_at`] reports) is left to it, since such a byte is neither.
#[inline(always)]
pub(crate) fn scan_before_space(line: &[u8], at: usize) -> Result<(f64, usize), NumberError> {
    scan_from::<false>(line, at)
}

#[inline(always)]
fn scan_from<const TEST_GLUED: bool>(line: &[u8], at: usize) -> Result<(f64, usize), NumberError> {
    // The sign is read from the number's own window: most numbers have none, and a negative
    // one (a retraction) takes a second window, past the sign.
    let found = match window(line, at) {
        Some(w) if w as u8 != b'-' => eight::<TEST_GLUED>(line, at, w),
        Some(_) => window(line, at + 1)
            .and_then(|w| eight::<TEST_GLUED>(line, at + 1, w))
            .map(|(value, end)| (-value, end)),
        None => None,
    };
    match found {
        Some(number) => Ok(number),
        None => scan_any(&line[at..]).map(|(value, used)| (value, at + used)),
    }
}

/// 10^0 ..= 10^7, for joining an integer part to a fraction of up to seven digits.
const POW10_INT: [u64; 8] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000];

const ONES: u64 = 0x0101_0101_0101_0101;
const HIGH_BITS: u64 = 0x8080_8080_8080_8080;

/// Reads `digits? (. digits?)?` with 1 to 7 digits, all within the 8 bytes from `start` (`w`,
/// as [`window`] reads them), in a
/// few register operations instead of a loop per digit (SWAR: SIMD within a register). Most
/// numbers slicers write fit (`142.303`, `2.43766`, `.04235`, `1800`). Anything else (longer,
/// glued to a second point or a sign when `TEST_GLUED`, no digits) is `None` and goes through
/// [`scan_any`].
#[inline(always)]
fn eight<const TEST_GLUED: bool>(line: &[u8], start: usize, w: u64) -> Option<(f64, usize)> {
    // Byte k of `w` is line[start + k]; XOR with '0' maps digits to 0..=9.
    let mut t = w ^ (ONES * u64::from(b'0'));
    let non_digit = non_digits(t);
    // Bit 8k + 7 is set for the first non-digit byte k; shifts count bits, eight per byte.
    let first_bit = non_digit.trailing_zeros();
    if first_bit == 64 {
        return None;
    }
    let first_shift = first_bit & !7;
    // Bits the digits take (eight each), digits after the point, and where the number ends.
    let (digit_bits, frac_digits, end_shift) = if (w >> first_shift) as u8 == b'.' {
        // The next non-digit after the point: clear the point's bit, the lowest one set. None
        // in the window: the number fills it (`17.70252`) if the byte after is no digit.
        let after_point = non_digit & (non_digit - 1);
        let stop_shift = if after_point != 0 {
            after_point.trailing_zeros() & !7
        } else if !line.get(start + 8).is_some_and(u8::is_ascii_digit) {
            64
        } else {
            return long_fraction::<TEST_GLUED>(line, start, first_bit / 8, t);
        };
        // Close the gap of the point: the bytes above it move down one.
        let below = (1u64 << first_shift) - 1;
        t = (t & below) | ((t >> 8) & !below);
        (stop_shift - 8, (stop_shift - first_shift) / 8 - 1, stop_shift)
    } else {
        (first_shift, 0, first_shift)
    };
    let end = start + (end_shift / 8) as usize;
    if digit_bits == 0 || (TEST_GLUED && line.get(end).is_some_and(|&b| is_glued(b))) {
        return None;
    }
    // Keep the digits, most significant first in byte 0, padded with leading zeros to eight.
    let mantissa = eight_digits(t << (64 - digit_bits));
    // At most seven fraction digits here; the mask spares a bounds check.
    Some((mantissa as f64 / POW10[(frac_digits & 7) as usize], end))
}

/// A number whose fraction runs past the first eight bytes (`19.25233`, `123.45678`): the
/// fraction is read from a second window just past the point and joined to the integer part.
#[inline(always)]
fn long_fraction<const TEST_GLUED: bool>(
    line: &[u8],
    start: usize,
    int_digits: u32,
    t: u64,
) -> Option<(f64, usize)> {
    let frac_at = start + int_digits as usize + 1;
    let w = window(line, frac_at)?;
    let tf = w ^ (ONES * u64::from(b'0'));
    let frac_digits = non_digits(tf).trailing_zeros() / 8;
    // At most 7 + 7 digits: the mantissa stays below 10^14 < 2^53, exact.
    if frac_digits == 8 || frac_digits == 0 {
        return None;
    }
    if TEST_GLUED && is_glued((w >> (8 * frac_digits)) as u8) {
        return None;
    }
    let int = if int_digits == 0 { 0 } else { eight_digits(t << (8 * (8 - int_digits))) };
    let frac = eight_digits(tf << (8 * (8 - frac_digits)));
    let mantissa = int * POW10_INT[frac_digits as usize] + frac;
    Some(((mantissa as i64) as f64 / POW10[frac_digits as usize], frac_at + frac_digits as usize))
}

/// The high bit of every byte of `t` (digits XOR '0') that is not a digit: a digit is below 10
/// after the XOR, so adding 0x76 (0x80 - 10) to a byte's low 7 bits sets its high bit otherwise.
#[inline(always)]
fn non_digits(t: u64) -> u64 {
    (((t & !HIGH_BITS) + ONES * 0x76) | t) & HIGH_BITS
}

/// A second point or a sign right after a number: a typo that [`scan_any`] reports.
#[inline(always)]
fn is_glued(next: u8) -> bool {
    matches!(next, b'.' | b'+' | b'-')
}

/// The 8 bytes of `line` from `start`, as a little-endian word; past the end of the line the
/// bytes read as 0 (not a digit, so a number ends there). `None` for lines under 8 bytes.
#[inline(always)]
fn window(line: &[u8], start: usize) -> Option<u64> {
    if let Some(bytes) = line.get(start..start + 8) {
        return Some(u64::from_le_bytes(bytes.try_into().ok()?));
    }
    let len = line.len();
    if start >= len {
        return None;
    }
    let last: [u8; 8] = line.get(len.checked_sub(8)?..)?.try_into().ok()?;
    Some(u64::from_le_bytes(last) >> (8 * (start + 8 - len)))
}

/// Eight decimal digits (byte 0 the most significant, each 0..=9) to their value: pairs, then
/// fours, then all eight, each step one multiply that adds neighbours at their weights.
#[inline(always)]
fn eight_digits(t: u64) -> u64 {
    let pairs = t.wrapping_mul(10).wrapping_add(t >> 8);
    let low = (pairs & 0x0000_00FF_0000_00FF).wrapping_mul(100 + (1_000_000 << 32));
    let high = ((pairs >> 16) & 0x0000_00FF_0000_00FF).wrapping_mul(1 + (10_000 << 32));
    low.wrapping_add(high) >> 32
}

/// Every number [`eight`] leaves: signs, long numbers, and the errors.
#[cold]
#[inline(never)]
fn scan_any(bytes: &[u8]) -> Result<(f64, usize), NumberError> {
    let (negative, start) = match bytes.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    let d = Decimal::read(bytes, start);
    if d.int_digits + d.frac_digits == 0 {
        return Err(no_digits(&bytes[d.end..], d.end > 0 || bytes.first() == Some(&b'.')));
    }
    // A second point or sign glued to the number is a typo, not the start of another word.
    if d.is_glued(bytes) {
        return Err(NumberError::Malformed);
    }
    if d.is_long() {
        return scan_slow(bytes, negative, start);
    }
    Ok((d.value(negative), d.end))
}

/// The digits of `digits? (. digits?)?` read as one integer mantissa, and where they end.
struct Decimal {
    mantissa: u64,
    int_digits: usize,
    frac_digits: usize,
    end: usize,
}

impl Decimal {
    #[inline(always)]
    fn read(bytes: &[u8], start: usize) -> Decimal {
        let mut mantissa: u64 = 0;
        let int_digits = digits(&bytes[start..], &mut mantissa);
        let mut end = start + int_digits;
        let mut frac_digits = 0;
        if bytes.get(end) == Some(&b'.') {
            end += 1;
            frac_digits = digits(&bytes[end..], &mut mantissa);
            end += frac_digits;
        }
        Decimal { mantissa, int_digits, frac_digits, end }
    }

    /// Over 15 digits the mantissa may not be exact (or may have wrapped).
    #[inline(always)]
    fn is_long(&self) -> bool {
        self.int_digits + self.frac_digits > 15
    }

    /// Followed by a second point or a sign: a typo, not the start of another word.
    #[inline(always)]
    fn is_glued(&self, bytes: &[u8]) -> bool {
        bytes.get(self.end).is_some_and(|&b| is_glued(b))
    }

    /// At most 15 digits: the mantissa is below 2^53, exact, and one division rounds correctly.
    #[inline(always)]
    fn value(&self, negative: bool) -> f64 {
        let value = (self.mantissa as i64) as f64 / POW10[self.frac_digits];
        if negative {
            -value
        } else {
            value
        }
    }
}

/// Accumulates the leading ASCII digits of `bytes` into `mantissa` (wrapping: callers with more
/// than 15 digits take the slow path) and returns how many there were.
#[inline(always)]
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
    // Over 309 digits the nearest double is infinity, which no machine can reach.
    if !value.is_finite() {
        return Err(NumberError::NotFinite);
    }
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

/// Decimals G-code numbers are written with: an f64 holds about 15 significant digits, so 9
/// places leave 6 for the integer part.
const DECIMALS: crate::range::Range = crate::range::Range::new(0.0, 9.0, "decimals");

impl crate::settings::CheckRanges for NumberFormat {
    fn check_ranges(&self, t: &crate::settings::Table) -> Result<(), crate::range::OutOfRange> {
        t.count("position_decimals", self.position_decimals, DECIMALS)?;
        t.count("extrusion_decimals", self.extrusion_decimals, DECIMALS)?;
        t.count("feed_decimals", self.feed_decimals, DECIMALS)
    }
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
        if !write_fixed(out, value, decimals) {
            // `write!` into a Vec cannot fail.
            let _ = write!(out, "{:.*}", decimals as usize, value);
        }
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

/// Appends `value` with `decimals` places as `format!("{:.*}", decimals, value)` does, when an
/// integer scaling gives the same digits; returns false (nothing written) when it may not.
///
/// The standard formatting rounds the exact binary value, which costs about 1 700 instructions
/// a number when its fast method gives up (a mix's purge moves: 4 000 numbers on the guard's
/// input, 4 % of its work), against about 60 here. `value` x 10^`decimals` is one rounded
/// multiplication, off the exact product by at most half a unit in its last place; rounding
/// it to the nearest integer gives the exact value's rounding unless the product lies within
/// that error of a half, which is left to the standard formatting, as are values too large
/// for the integer and more decimals than a G-code word carries.
fn write_fixed(out: &mut Vec<u8>, value: f64, decimals: u8) -> bool {
    const POW10: [f64; 10] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];
    let Some(&scale) = POW10.get(usize::from(decimals)) else { return false };
    let scaled = value.abs() * scale;
    // Below 2^52 every integer and half is a double; NaN and infinity are not finite.
    if !scaled.is_finite() || scaled >= 4.0e15 {
        return false;
    }
    let floor = scaled.floor();
    let error = scaled * f64::EPSILON;
    if (scaled - floor - 0.5).abs() <= error {
        return false;
    }
    let units = (floor + if scaled - floor > 0.5 { 1.0 } else { 0.0 }) as u64;
    if value.is_sign_negative() {
        out.push(b'-');
    }
    let one = scale as u64;
    let mut digits = [0u8; 20];
    let whole = units / one;
    let mut at = digits.len();
    let mut rest = whole;
    loop {
        at -= 1;
        digits[at] = b'0' + (rest % 10) as u8;
        rest /= 10;
        if rest == 0 {
            break;
        }
    }
    out.extend_from_slice(&digits[at..]);
    if decimals > 0 {
        out.push(b'.');
        let mut fraction = units % one;
        let start = out.len();
        out.resize(start + usize::from(decimals), b'0');
        for d in out[start..].iter_mut().rev() {
            *d = b'0' + (fraction % 10) as u8;
            fraction /= 10;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The integer scaling writes what the standard formatting writes, to the byte: on values
    /// near halves at every number of decimals (where the product's rounding matters), on
    /// negative zero and on numbers of every magnitude.
    #[test]
    fn fixed_decimals_are_the_standard_formatting() {
        let mut values =
            vec![0.0, -0.0, 0.5, 1.5, 2.5, -2.5, 0.125, 0.0625, 1.005, 2.675, 1e15, 4.1e15, 123.4565];
        for i in 0..20_000 {
            let x = f64::from(i) * 0.000_5 - 3.0;
            values.extend([x, x * 97.3, x / 7.0, x * 1e6 + 0.5]);
        }
        for &v in &values {
            for decimals in 0..=11u8 {
                let mut ours = Vec::new();
                if write_fixed(&mut ours, v, decimals) {
                    let std = format!("{:.*}", usize::from(decimals), v);
                    assert_eq!(String::from_utf8(ours).unwrap(), std, "{v:e} with {decimals} decimals");
                }
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn fixed_decimals_are_the_standard_formatting_anywhere(v in proptest::num::f64::ANY, decimals in 0u8..12) {
            let mut ours = Vec::new();
            if write_fixed(&mut ours, v, decimals) {
                proptest::prop_assert_eq!(String::from_utf8(ours).unwrap(), format!("{:.*}", usize::from(decimals), v));
            }
        }
    }

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
        // Digits past the largest double round to infinity: not a number a machine can reach.
        let huge = "9".repeat(400);
        assert_eq!(scan(huge.as_bytes()), Err(NumberError::NotFinite));
        assert_eq!(scan(format!("-{huge}.5").as_bytes()), Err(NumberError::NotFinite));
        let largest = format!("{}", f64::MAX);
        assert_eq!(scan(largest.as_bytes()), Ok((f64::MAX, largest.len())));
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

    #[test]
    fn numbers_near_the_end_of_a_line_and_past_eight_bytes() {
        let line = b"G1 X142.303 Y-175.1 E19.25233 F1234567.1234567 Z.5";
        for (at, value, end) in
            [(4, 142.303, 11), (13, -175.1, 19), (21, 19.25233, 29), (31, 1234567.1234567, 46), (48, 0.5, 50)]
        {
            assert_eq!(scan_at(line, at), Ok((value, end)), "at {at}");
        }
        assert_eq!(scan_at(b"X1", 1), Ok((1.0, 2)));
        assert_eq!(scan_at(b"G1 X1234567.", 4), Ok((1234567.0, 12)));
    }

    proptest::proptest! {
        /// The eight-byte reader gives what the general rules give, for any bytes at any place.
        #[test]
        fn scan_at_agrees_with_the_general_rules(prefix in "[ XG0-9.]{0,10}", number in "[+-]?[0-9]{0,17}(\\.[0-9]{0,17})?", suffix in "[ .+-X0-9]{0,3}") {
            let line = format!("{prefix}{number}{suffix}");
            let at = prefix.len();
            let general = scan_any(&line.as_bytes()[at..]).map(|(v, used)| (v, at + used));
            proptest::prop_assert_eq!(scan_at(line.as_bytes(), at), general);
        }

        /// What the plain-motion path relies on: wherever the lighter scan ends at a space or
        /// at the line's end, the full scan gives the same number.
        #[test]
        fn scan_before_space_agrees_where_a_space_follows(prefix in "[ XG0-9.]{0,10}", number in "[+-]?[0-9]{0,17}(\\.[0-9]{0,17})?", suffix in "[ .+-X0-9]{0,3}") {
            let line = format!("{prefix}{number}{suffix}");
            let at = prefix.len();
            if let Ok((value, end)) = scan_before_space(line.as_bytes(), at) {
                if matches!(line.as_bytes().get(end), None | Some(b' ')) {
                    proptest::prop_assert_eq!(scan_at(line.as_bytes(), at), Ok((value, end)));
                }
            }
        }

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
