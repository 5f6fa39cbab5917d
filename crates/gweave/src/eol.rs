//! The one line emitter of the transforms: lines they write come out with the file's own line
//! endings (a CRLF file stays CRLF), and are counted (purge-shift reports output line numbers).
//!
//! A transform composes new text with `\n` and hands it over; the emitter ends each line with
//! the ending it learned from the lines read ([`Eol::learn`]), except the last, which takes the
//! ending of the line it replaces (none after the last line of a file that has none): after a
//! `\r\n` line, `G92 E0\nG1 X1\n` replacing a last line without an ending is written
//! `G92 E0\r\nG1 X1` (`a_crlf_files_new_text_is_crlf`). Private to the engine: the front ends
//! call the transforms, which write through it.

use std::io::{self, Write};

use crate::gcode::reader::RawLine;

/// A line read and its ending, one slice: the reader hands out the content followed by its
/// ending and more ([`RawLine::with_lookahead`]), so a line copied as it is costs one write,
/// not two.
#[inline]
pub(crate) fn with_ending<'a>(line: &RawLine<'a>) -> &'a [u8] {
    &line.with_lookahead()[..line.bytes.len() + line.eol.len()]
}

/// Writes lines with the file's line endings, counting them.
#[derive(Debug, Clone)]
pub(crate) struct Eol {
    /// The ending of the last line read that had one (`\n` before any).
    eol: Vec<u8>,
    lines: u64,
}

impl Default for Eol {
    fn default() -> Self {
        Eol { eol: b"\n".to_vec(), lines: 0 }
    }
}

impl Eol {
    /// Learns the file's line ending from a line read (a line without one teaches nothing).
    pub(crate) fn learn(&mut self, eol: &[u8]) {
        if !eol.is_empty() && eol != self.eol.as_slice() {
            self.eol.clear();
            self.eol.extend_from_slice(eol);
        }
    }

    /// The file's line ending.
    pub(crate) fn get(&self) -> &[u8] {
        &self.eol
    }

    /// Lines written so far.
    pub(crate) fn lines(&self) -> u64 {
        self.lines
    }

    /// One line, as read or as composed, with its own ending.
    pub(crate) fn line(&mut self, out: &mut dyn Write, bytes: &[u8], eol: &[u8]) -> io::Result<()> {
        self.lines += 1;
        out.write_all(bytes)?;
        out.write_all(eol)
    }

    /// One line and its own ending, as one slice.
    #[inline]
    pub(crate) fn whole_line(&mut self, out: &mut dyn Write, line_with_eol: &[u8]) -> io::Result<()> {
        self.lines += 1;
        out.write_all(line_with_eol)
    }

    /// `\n`-separated `text` (a final `\n` is optional): the file's ending after each line,
    /// `last_eol` after the last. Empty text writes nothing.
    pub(crate) fn text(&mut self, out: &mut dyn Write, text: &[u8], last_eol: &[u8]) -> io::Result<()> {
        if text.is_empty() {
            return Ok(());
        }
        let body = text.strip_suffix(b"\n").unwrap_or(text);
        let mut lines = body.split(|&b| b == b'\n').peekable();
        while let Some(l) = lines.next() {
            self.lines += 1;
            out.write_all(l)?;
            out.write_all(if lines.peek().is_some() { &self.eol } else { last_eol })?;
        }
        Ok(())
    }

    /// [`Eol::text`] ending every line, the last too, with the file's ending.
    pub(crate) fn block(&mut self, out: &mut dyn Write, text: &[u8]) -> io::Result<()> {
        let eol = self.eol.clone();
        self.text(out, text, &eol)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_take_the_learned_ending_and_the_last_its_own() {
        let mut eol = Eol::default();
        let mut out = Vec::new();
        eol.block(&mut out, b"a\nb").unwrap();
        eol.learn(b"\r\n");
        eol.block(&mut out, b"x\ny").unwrap();
        eol.learn(b"\r\n");
        eol.learn(b"");
        eol.text(&mut out, b"c\nd\n", b"\n").unwrap();
        eol.line(&mut out, b"e", b"").unwrap();
        assert_eq!(out, b"a\nb\nx\r\ny\r\nc\r\nd\ne");
        assert_eq!(eol.lines(), 7);
    }

    #[test]
    fn a_line_with_its_ending_is_the_line_and_its_ending() {
        let text = b"G1 X1 E2\r\nG1 X2\n\n;last";
        let mut reader = crate::gcode::reader::LineReader::new(&text[..]);
        let mut copied = Vec::new();
        while let Some(line) = reader.next_line().unwrap() {
            assert_eq!(with_ending(&line), [line.bytes, line.eol].concat());
            copied.extend_from_slice(with_ending(&line));
        }
        assert_eq!(copied, text);
    }

    #[test]
    fn a_crlf_files_new_text_is_crlf() {
        let mut eol = Eol::default();
        eol.learn(b"\r\n");
        let mut out = Vec::new();
        eol.text(&mut out, b"G92 E0\nG1 X1\n", b"").unwrap();
        assert_eq!((out.as_slice(), eol.lines()), (&b"G92 E0\r\nG1 X1"[..], 2));
    }
}
