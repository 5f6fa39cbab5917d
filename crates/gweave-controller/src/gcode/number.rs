//! Decimal numbers, read by hand.
//!
//! `str::parse::<f32>` is exact for every input, and for that it carries a table of powers of
//! ten that takes about 10 KB of RAM on an AVR (constants live in RAM there). G-code numbers
//! are short decimals (`-12.345`, `3000`, `.4`), so this reader collects at most 9 significant
//! digits into an integer and divides by a power of ten once: the result is the float nearest
//! to the decimal or one unit in the last place away, a few nanometres on a bed.

/// Powers of ten an `f32` holds exactly (up to 10^10).
const POW10: [f32; 11] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// Significant digits kept; further fraction digits are below the float's precision anyway.
const MAX_DIGITS: u32 = 9;

/// Reads a number at the start of `bytes`: an optional sign, digits, an optional point and
/// digits, at least one digit in all (`-5`, `+.5`, `3.`, `12.50`). Returns the value and the
/// bytes used, or `None` when there is no number or it has more than 9 digits before the point
/// (nothing on a printer is a billion of anything).
pub fn parse(bytes: &[u8]) -> Option<(f32, usize)> {
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
    let mut mantissa: u32 = 0;
    let mut kept: u32 = 0; // significant digits in `mantissa`
    let mut int_digits = 0;
    let mut frac_digits: usize = 0; // fraction digits in `mantissa`
    let mut any_digit = false;
    let mut after_point = false;
    while let Some(&b) = bytes.get(i) {
        match b {
            b'0'..=b'9' => {
                any_digit = true;
                if !after_point {
                    int_digits += 1;
                    if int_digits > MAX_DIGITS {
                        return None;
                    }
                }
                // Fraction digits past 10^-10 are dropped (POW10's end): nothing on a printer
                // is that small.
                if kept < MAX_DIGITS && !(after_point && frac_digits == POW10.len() - 1) {
                    mantissa = mantissa * 10 + u32::from(b - b'0');
                    if mantissa != 0 {
                        kept += 1;
                    }
                    if after_point {
                        frac_digits += 1;
                    }
                }
            }
            b'.' if !after_point => after_point = true,
            _ => break,
        }
        i += 1;
    }
    if !any_digit {
        return None;
    }
    let magnitude = mantissa as f32 / POW10[frac_digits];
    Some((if negative { -magnitude } else { magnitude }, i))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(text: &str) -> Option<f32> {
        parse(text.as_bytes()).map(|(v, _)| v)
    }

    #[test]
    fn decimals_read_as_the_nearest_float() {
        for text in
            ["0", "1", "-5", "12.5", "0.013", "-0.0125", "199.9999", "3000", "93.0", "123456789", "0.000001"]
        {
            let want: f32 = text.parse().unwrap();
            let got = value(text).unwrap();
            assert!((got - want).abs() <= want.abs() * 1.2e-7, "{text}: {got} vs {want}");
        }
        assert_eq!(value(".4"), Some(0.4));
        assert_eq!(value("+3."), Some(3.0));
        assert_eq!(value("-0"), Some(-0.0));
    }

    #[test]
    fn a_number_ends_at_the_first_byte_not_its_own() {
        assert_eq!(parse(b"10Y20"), Some((10.0, 2)));
        assert_eq!(parse(b"1.5.5"), Some((1.5, 3)));
        assert_eq!(parse(b"-X"), None);
        assert_eq!(parse(b"."), None);
        assert_eq!(parse(b""), None);
        assert_eq!(parse(b"1234567890"), None);
        // Many fraction digits are read, only the first nine count.
        assert_eq!(parse(b"0.1234567891234"), Some((0.12345679, 15)));
        assert_eq!(parse(b"0.00000000001"), Some((0.0, 13)));
    }
}
