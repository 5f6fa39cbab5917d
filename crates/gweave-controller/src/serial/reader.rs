//! Bytes from the host into lines, in bounded memory.
//!
//! As Marlin's serial reader (`Marlin/src/gcode/queue.cpp`): `\n` and `\r` both end a line;
//! `;` starts a comment that runs to the end of the line and is dropped; spaces at the ends are
//! dropped; an empty line (or a comment alone) is no line at all. Unlike Marlin, a line longer
//! than [`MAX_LINE`] is not cut and run (`G1 X10 Y20` cut could read `G1 X10 Y2`): it is kept
//! marked [`Line::too_long`], with its first bytes so that its line number can still be read,
//! and the machine refuses it whole.
//!
//! Complete lines wait in a queue of [`LINE_QUEUE`]; when it is full, [`LineReader::push`]
//! refuses the byte that would end one more line and the board keeps it for later (the host
//! waits for `ok`s anyway, so this happens only when a host sends ahead).

use crate::limits::{LINE_QUEUE, MAX_LINE};

/// One line from the host, comment and surrounding spaces removed.
#[derive(Clone, Copy)]
pub struct Line {
    bytes: [u8; MAX_LINE],
    len: u8,
    /// The line had more than [`MAX_LINE`] bytes; [`Line::bytes`] holds the first ones.
    pub too_long: bool,
}

impl Line {
    const EMPTY: Line = Line { bytes: [0; MAX_LINE], len: 0, too_long: false };

    /// The line's bytes (the first [`MAX_LINE`] if it was too long).
    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }
}

/// The line being received and the complete lines waiting.
pub struct LineReader {
    current: Line,
    in_comment: bool,
    queue: [Line; LINE_QUEUE],
    first: u8,
    count: u8,
}

impl Default for LineReader {
    fn default() -> Self {
        LineReader::new()
    }
}

impl LineReader {
    /// Nothing received yet.
    pub const fn new() -> Self {
        LineReader {
            current: Line::EMPTY,
            in_comment: false,
            queue: [Line::EMPTY; LINE_QUEUE],
            first: 0,
            count: 0,
        }
    }

    /// Takes one byte from the host. Returns `false`, keeping nothing, when the byte would end a
    /// line and the queue is full: offer it again after [`LineReader::pop`].
    pub fn push(&mut self, byte: u8) -> bool {
        match byte {
            b'\n' | b'\r' => {
                let line = &mut self.current;
                while line.len > 0 && line.bytes[usize::from(line.len) - 1] == b' ' {
                    line.len -= 1;
                }
                if line.len > 0 || line.too_long {
                    if usize::from(self.count) == LINE_QUEUE {
                        return false;
                    }
                    let slot = (usize::from(self.first) + usize::from(self.count)) % LINE_QUEUE;
                    self.queue[slot] = *line;
                    self.count += 1;
                }
                self.current = Line::EMPTY;
                self.in_comment = false;
            }
            b';' => self.in_comment = true,
            _ if self.in_comment => {}
            // Leading spaces (and tabs, as spaces) are dropped.
            b' ' | b'\t' if self.current.len == 0 => {}
            _ => {
                let line = &mut self.current;
                if usize::from(line.len) < MAX_LINE {
                    line.bytes[usize::from(line.len)] = if byte == b'\t' { b' ' } else { byte };
                    line.len += 1;
                } else {
                    line.too_long = true;
                }
            }
        }
        true
    }

    /// The oldest complete line, if any, removed from the queue.
    pub fn pop(&mut self) -> Option<Line> {
        if self.count == 0 {
            return None;
        }
        let line = self.queue[usize::from(self.first)];
        self.first = ((usize::from(self.first) + 1) % LINE_QUEUE) as u8;
        self.count -= 1;
        Some(line)
    }

    /// Drops the complete lines waiting (Marlin flushes its input after a line error: the lines
    /// sent after a bad one are sent again after `Resend:`).
    pub fn flush(&mut self) {
        self.count = 0;
    }

    /// Whether a complete line waits.
    pub fn has_line(&self) -> bool {
        self.count > 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn lines(input: &[u8]) -> Vec<(Vec<u8>, bool)> {
        let mut r = LineReader::new();
        let mut out = Vec::new();
        for &b in input {
            while !r.push(b) {
                out.push(r.pop().unwrap());
            }
        }
        while let Some(l) = r.pop() {
            out.push(l);
        }
        out.iter().map(|l| (l.bytes().to_vec(), l.too_long)).collect()
    }

    #[test]
    fn lines_end_at_cr_or_lf_and_lose_comments_and_outer_spaces() {
        let got = lines(b"G28\r\n  G1 X1 ; move\n;only a comment\n\n\tM105\t\r");
        assert_eq!(got, [(b"G28".to_vec(), false), (b"G1 X1".to_vec(), false), (b"M105".to_vec(), false)]);
    }

    #[test]
    fn a_kilobyte_line_is_marked_too_long_and_keeps_its_start() {
        let mut input = b"N7 G1 X".to_vec();
        input.extend([b'1'; 1024]);
        input.extend(b"\nM105\n");
        let got = lines(&input);
        assert_eq!(got.len(), 2);
        assert!(got[0].1);
        assert_eq!(got[0].0.len(), MAX_LINE);
        assert!(got[0].0.starts_with(b"N7 G1 X111"));
        assert_eq!(got[1], (b"M105".to_vec(), false));
    }

    #[test]
    fn a_full_queue_refuses_the_byte_that_ends_a_line() {
        let mut r = LineReader::new();
        for _ in 0..LINE_QUEUE {
            assert!(r.push(b'G') && r.push(b'\n'));
        }
        assert!(r.push(b'M'));
        assert!(!r.push(b'\n'));
        assert_eq!(r.pop().map(|l| l.bytes().to_vec()), Some(b"G".to_vec()));
        assert!(r.push(b'\n'));
    }
}
