//! The words of one line, all checked before the machine sees any.
//!
//! A G-code line is a command word (`G1`, `M104`, `T0`) followed by parameter words, each a
//! letter and usually a number: `G1 X10 Y-2.5 F3000`. Spaces between words are optional
//! (`G1X10Y20`); letters may be lower case. As GRBL's parser does (`gnea/grbl:grbl/gcode.c`),
//! the whole line is read and checked first (every number well formed, no letter twice, no
//! byte G-code does not have), and only a line that passed changes anything: `G1 X10 Y1.2.3`
//! does not move X and then fail.

use super::number;

/// A command word: its letter (`G`, `M` or `T`) and number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Command {
    /// `b'G'`, `b'M'` or `b'T'`.
    pub letter: u8,
    /// The number after it.
    pub code: u16,
}

/// Why a line is not G-code the machine can read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WordError {
    /// The line does not start with a `G`, `M` or `T` word with a whole number.
    NoCommand,
    /// At this byte (0-based column): a byte that is not a letter, a number or a space, a
    /// malformed number, or a letter already given.
    BadWord(u8),
}

/// The parameters of a line: for each letter A-Z, whether it was given, and its value if it
/// was given one. A letter alone (`G28 X`) is given without a value: Marlin's `seen` but not
/// its `seenval`, so `G1 Z` moves nothing and `M104 S` sets nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Words {
    /// The command.
    pub command: Command,
    seen: u32,
    /// The letters given with a number.
    valued: u32,
    values: [f32; 26],
}

impl Words {
    /// Reads a whole line (line number and checksum already removed).
    pub fn parse(line: &[u8]) -> Result<Words, WordError> {
        let mut i = skip_spaces(line, 0);
        let letter = line.get(i).map(u8::to_ascii_uppercase);
        let command = match letter {
            Some(l @ (b'G' | b'M' | b'T')) => match line.get(i + 1..).and_then(whole_number) {
                Some((code, used)) => {
                    i += 1 + used;
                    Command { letter: l, code }
                }
                None => return Err(WordError::NoCommand),
            },
            _ => return Err(WordError::NoCommand),
        };
        let mut words = Words { command, seen: 0, valued: 0, values: [0.0; 26] };
        loop {
            i = skip_spaces(line, i);
            let Some(&b) = line.get(i) else { break };
            let bad = WordError::BadWord(i.min(255) as u8);
            if !b.is_ascii_alphabetic() {
                return Err(bad);
            }
            let index = usize::from(b.to_ascii_uppercase() - b'A');
            if words.seen & (1 << index) != 0 {
                return Err(bad);
            }
            words.seen |= 1 << index;
            i += 1;
            match line.get(i) {
                Some(c) if c.is_ascii_alphabetic() || *c == b' ' => {}
                None => {}
                Some(_) => {
                    let Some((value, used)) = number::parse(&line[i..]) else {
                        return Err(WordError::BadWord(i.min(255) as u8));
                    };
                    words.values[index] = value;
                    words.valued |= 1 << index;
                    i += used;
                }
            }
        }
        Ok(words)
    }

    /// Whether `letter` (upper case) was given.
    pub fn has(&self, letter: u8) -> bool {
        letter.is_ascii_uppercase() && self.seen & (1 << (letter - b'A')) != 0
    }

    /// The value of `letter` (upper case), if given with one.
    pub fn get(&self, letter: u8) -> Option<f32> {
        (letter.is_ascii_uppercase() && self.valued & (1 << (letter - b'A')) != 0)
            .then(|| self.values[usize::from(letter - b'A')])
    }
}

fn skip_spaces(line: &[u8], mut i: usize) -> usize {
    while line.get(i) == Some(&b' ') {
        i += 1;
    }
    i
}

/// A command's number: digits only, at most 65535, and not followed by a point
/// (`G1.5` is not a command this machine has).
fn whole_number(bytes: &[u8]) -> Option<(u16, usize)> {
    let digits = bytes.iter().take_while(|b| b.is_ascii_digit()).count();
    if digits == 0 || digits > 5 || bytes.get(digits) == Some(&b'.') {
        return None;
    }
    let n = bytes[..digits].iter().fold(0u32, |n, &b| n * 10 + u32::from(b - b'0'));
    u16::try_from(n).ok().map(|n| (n, digits))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_move_reads_with_or_without_spaces() {
        for line in [&b"G1 X10 Y-2.5 F3000"[..], b"g1x10y-2.5f3000", b"G01  X10 Y-2.5   F3000"] {
            let w = Words::parse(line).unwrap();
            assert_eq!(w.command, Command { letter: b'G', code: 1 });
            assert_eq!((w.get(b'X'), w.get(b'Y'), w.get(b'F')), (Some(10.0), Some(-2.5), Some(3000.0)));
            assert_eq!(w.get(b'Z'), None);
        }
    }

    /// Regression (a breaking session: `G1 Z` drove Z to 0, into the bed, and `M104 S` switched
    /// the hotend off: a letter alone read as 0): a letter alone is given, without a value, as
    /// Marlin's `seen` without `seenval`.
    #[test]
    fn a_letter_alone_is_given_without_a_value() {
        let w = Words::parse(b"G28 X Y").unwrap();
        assert!(w.has(b'X') && w.has(b'Y') && !w.has(b'Z'));
        assert_eq!(w.get(b'X'), None);
        let w = Words::parse(b"G1 Z X0").unwrap();
        assert_eq!((w.has(b'Z'), w.get(b'Z'), w.get(b'X')), (true, None, Some(0.0)));
    }

    #[test]
    fn the_whole_line_is_checked_first() {
        assert_eq!(Words::parse(b"G1 X10 Y1.2.3"), Err(WordError::BadWord(11)));
        assert_eq!(Words::parse(b"G1 X10 X20"), Err(WordError::BadWord(7)));
        assert_eq!(Words::parse(b"G1 X10 #"), Err(WordError::BadWord(7)));
        assert_eq!(Words::parse(b"G1 X-"), Err(WordError::BadWord(4)));
        assert_eq!(Words::parse(b"G1 X\xff"), Err(WordError::BadWord(4)));
        assert_eq!(Words::parse(b"\x00\x01garbage"), Err(WordError::NoCommand));
        assert_eq!(Words::parse(b"X10"), Err(WordError::NoCommand));
        assert_eq!(Words::parse(b"G1.5 X1"), Err(WordError::NoCommand));
        assert_eq!(Words::parse(b"M99999"), Err(WordError::NoCommand));
    }
}
