//! Marlin's line numbers and checksums: how a host notices a byte lost or flipped on the wire.
//!
//! A host may send `N<n> <command>*<checksum>`, the checksum being the XOR of every byte before
//! the `*` (from the `N` on), in decimal: `N1 G28*18`. The firmware remembers the last line
//! number it took; a numbered line is checked, in Marlin's order
//! (`MarlinFirmware/Marlin:Marlin/src/gcode/queue.cpp`, strings from `core/language.h`):
//! 1. its number must be the last one + 1, unless the line holds `M110` (which sets the number);
//! 2. if it has a `*`, the checksum must match;
//! 3. it must have a `*`.
//!
//! A failed check answers `Error:<what>, Last Line: <last>`, `Resend: <last + 1>`, `ok`
//! ([`LineError::message`]; the machine prints them), and the line is not run. Lines without a
//! number are not checked.

/// Why a numbered line was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineError {
    /// The number is not the last one + 1.
    LineNumber,
    /// The checksum does not match the line.
    Checksum,
    /// A numbered line without a checksum.
    NoChecksum,
}

impl LineError {
    /// Marlin's text, which the host recognises, before the last line number.
    pub fn message(self) -> &'static [u8] {
        match self {
            LineError::LineNumber => b"Error:Line Number is not Last Line Number+1, Last Line: ",
            LineError::Checksum => b"Error:checksum mismatch, Last Line: ",
            LineError::NoChecksum => b"Error:No Checksum with line number, Last Line: ",
        }
    }
}

/// A line that passed the checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Checked<'a> {
    /// Its line number, if it had one: the new last line number.
    pub number: Option<i32>,
    /// The command, without the line number and the checksum.
    pub body: &'a [u8],
}

/// The number at the start of `bytes` (digits only; none reads 0; an overlong number saturates,
/// as C's `strtol` does).
pub fn leading_number(bytes: &[u8]) -> u32 {
    let mut n: u32 = 0;
    for &b in bytes.iter().take_while(|b| b.is_ascii_digit()) {
        // Compared rather than `saturating_mul`, whose overflow check is a 64-bit multiply on
        // an AVR.
        if n > (u32::MAX - 9) / 10 {
            return u32::MAX;
        }
        n = n * 10 + u32::from(b - b'0');
    }
    n
}

/// The line number of a line starting with `N`, if it does (used also for lines refused before
/// the checks, to ask for them again), and the bytes it takes after the `N`. It may be negative:
/// printcore starts a print with `N-1 M110 N-1*125`, so that the next line is `N0`. Numbers past
/// the `i32` range saturate.
pub fn line_number(line: &[u8]) -> Option<(i32, usize)> {
    let [b'N', rest @ ..] = line else { return None };
    let (negative, digits) = match rest {
        [b'-', digits @ ..] => (true, digits),
        _ => (false, rest),
    };
    let magnitude = leading_number(digits).min(i32::MAX as u32) as i32;
    let used = usize::from(negative) + digits.iter().take_while(|b| b.is_ascii_digit()).count();
    Some((if negative { -magnitude } else { magnitude }, used))
}

/// Checks `line` against the last line number taken.
pub fn check(line: &[u8], last: i32) -> Result<Checked<'_>, LineError> {
    let Some((number, used)) = line_number(line) else {
        // Unnumbered: a trailing checksum, if any, is ignored.
        let end = line.iter().position(|&b| b == b'*').unwrap_or(line.len());
        return Ok(Checked { number: None, body: trim(&line[..end]) });
    };
    let is_m110 = line.windows(4).any(|w| w == b"M110");
    if !is_m110 && number != last.wrapping_add(1) {
        return Err(LineError::LineNumber);
    }
    let Some(star) = line.iter().rposition(|&b| b == b'*') else {
        return Err(LineError::NoChecksum);
    };
    let sum = line[..star].iter().fold(0u8, |acc, &b| acc ^ b);
    let written = &line[star + 1..];
    if written.is_empty() || leading_number(written) != u32::from(sum) {
        return Err(LineError::Checksum);
    }
    Ok(Checked { number: Some(number), body: trim(&line[1 + used..star]) })
}

fn trim(mut bytes: &[u8]) -> &[u8] {
    while let [b' ', rest @ ..] = bytes {
        bytes = rest;
    }
    while let [rest @ .., b' '] = bytes {
        bytes = rest;
    }
    bytes
}

/// `line` framed with a line number and checksum as a host sends it: `N1 G28*18`. For tests
/// and for hosts written in Rust; returns the bytes written into `out`.
pub fn frame(number: u32, command: &[u8], out: &mut [u8]) -> usize {
    let mut r = crate::serial::out::Reply::new();
    r.s(b"N").u32(number).s(b" ").s(command);
    let sum = r.as_bytes().iter().fold(0u8, |acc, &b| acc ^ b);
    r.s(b"*").u32(u32::from(sum));
    let n = r.as_bytes().len().min(out.len());
    out[..n].copy_from_slice(&r.as_bytes()[..n]);
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hosts_framing_checks_out() {
        let mut buf = [0u8; 64];
        let n = frame(1, b"G28", &mut buf);
        assert_eq!(&buf[..n], b"N1 G28*18");
        let n = frame(0, b"M110 N0", &mut buf);
        assert_eq!(&buf[..n], b"N0 M110 N0*125");
        assert_eq!(check(b"N1 G28*18", 0), Ok(Checked { number: Some(1), body: b"G28" }));
    }

    #[test]
    fn checks_run_in_marlins_order() {
        // Wrong number first, even with a wrong checksum.
        assert_eq!(check(b"N3 G28*99", 1), Err(LineError::LineNumber));
        assert_eq!(check(b"N2 G28*99", 1), Err(LineError::Checksum));
        assert_eq!(check(b"N2 G28*", 1), Err(LineError::Checksum));
        assert_eq!(check(b"N2 G28", 1), Err(LineError::NoChecksum));
        // M110 takes any number.
        assert_eq!(check(b"N0 M110 N0*125", 41), Ok(Checked { number: Some(0), body: b"M110 N0" }));
        assert_eq!(check(b"G28", 41), Ok(Checked { number: None, body: b"G28" }));
        assert_eq!(leading_number(b"99999999999"), u32::MAX);
        // printcore's first line.
        assert_eq!(check(b"N-1 M110 N-1*125", 41), Ok(Checked { number: Some(-1), body: b"M110 N-1" }));
        assert_eq!(line_number(b"N99999999999 G1"), Some((i32::MAX, 11)));
    }
}
