//! Streaming line reader: a fixed buffer refilled from any `Read`, lines handed out as slices of
//! it, so memory is bounded by the buffer plus the longest line, whatever the file size.

use std::io::{self, Read};

/// One line as it is in the file.
#[derive(Debug, Clone, Copy)]
pub struct RawLine<'a> {
    /// The content, without the line ending.
    pub bytes: &'a [u8],
    /// The line ending exactly as written: `b"\n"`, `b"\r\n"`, or empty for a last line without one.
    pub eol: &'a [u8],
    /// 1-based line number in the file.
    pub number: u64,
    /// Byte offset of the line's first byte in the file.
    pub offset: u64,
    /// See [`RawLine::with_lookahead`].
    ahead: &'a [u8],
}

impl<'a> RawLine<'a> {
    /// The content followed by at least [`LOOKAHEAD`] more bytes, for readers that load a fixed
    /// number of bytes at a time: the line ending and what comes after it in the buffer, or
    /// zeros past the end of the input. The byte right after the content is never a digit, so a
    /// number read from here stops where the line does.
    #[inline]
    pub fn with_lookahead(&self) -> &'a [u8] {
        self.ahead
    }
}

/// Bytes readable past the end of every line's content.
pub const LOOKAHEAD: usize = 8;

const CHUNK: usize = 1 << 20;

/// Finds the `\n` that ends a line. G-code lines are a few dozen bytes, so the generic
/// `memchr` (a call, a dispatch and an alignment prologue before its 64-byte loop) costs more
/// than the search: on x86-64 the first 256 bytes are tested 16 at a time inline, with SSE2
/// (part of the architecture), and only longer lines go to `memchr`.
#[inline(always)]
fn find_newline(haystack: &[u8]) -> Option<usize> {
    #[allow(unused_mut)]
    let mut i = 0;
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8};
        while let Some(chunk) = haystack.get(i..i + 16) {
            // SAFETY: SSE2 is always present on x86-64, and `chunk` holds the 16 bytes the
            // unaligned load reads.
            let mask = unsafe {
                let bytes = _mm_loadu_si128(chunk.as_ptr().cast());
                _mm_movemask_epi8(_mm_cmpeq_epi8(bytes, _mm_set1_epi8(b'\n' as i8)))
            };
            if mask != 0 {
                return Some(i + mask.trailing_zeros() as usize);
            }
            i += 16;
            if i == 256 {
                break;
            }
        }
    }
    memchr::memchr(b'\n', &haystack[i..]).map(|at| i + at)
}

/// Reads lines from `R` without ever holding more than one chunk (1 MiB) plus the longest line.
/// The buffer keeps [`LOOKAHEAD`] zero bytes past the data read, so that every line has that many
/// readable bytes after its content.
pub struct LineReader<R> {
    inner: R,
    buf: Vec<u8>,
    start: usize,
    end: usize,
    eof: bool,
    number: u64,
    offset: u64,
}

impl<R: Read> LineReader<R> {
    pub fn new(inner: R) -> Self {
        LineReader {
            inner,
            buf: vec![0; CHUNK + LOOKAHEAD],
            start: 0,
            end: 0,
            eof: false,
            number: 0,
            offset: 0,
        }
    }

    /// Bytes handed out so far.
    pub fn position(&self) -> u64 {
        self.offset
    }

    /// The next line, or `None` at the end of the input.
    #[inline]
    pub fn next_line(&mut self) -> io::Result<Option<RawLine<'_>>> {
        loop {
            if let Some(nl) = find_newline(&self.buf[self.start..self.end]) {
                let line_start = self.start;
                let nl = line_start + nl;
                self.start = nl + 1;
                return Ok(Some(self.emit(line_start, nl + 1)));
            }
            if self.eof {
                if self.start == self.end {
                    return Ok(None);
                }
                let line_start = self.start;
                self.start = self.end;
                return Ok(Some(self.emit(line_start, self.end)));
            }
            self.refill()?;
        }
    }

    /// Builds the line for `buf[from..to]` (`to` is past the `\n`, if any) and advances counters.
    #[inline]
    fn emit(&mut self, from: usize, to: usize) -> RawLine<'_> {
        let whole = &self.buf[from..to];
        let content_len = match whole {
            [.., b'\r', b'\n'] => whole.len() - 2,
            [.., b'\n'] => whole.len() - 1,
            _ => whole.len(),
        };
        self.number += 1;
        let offset = self.offset;
        self.offset += whole.len() as u64;
        // `to <= end`, and the buffer holds LOOKAHEAD bytes past `end`.
        let ahead = &self.buf[from..from + content_len + LOOKAHEAD];
        let whole = &ahead[..to - from];
        RawLine {
            bytes: &whole[..content_len],
            eol: &whole[content_len..],
            number: self.number,
            offset,
            ahead,
        }
    }

    /// Moves the unread tail to the front, grows the buffer if one line fills it, and reads more.
    #[inline(never)]
    fn refill(&mut self) -> io::Result<()> {
        if self.start > 0 {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
            self.buf[self.end..self.end + LOOKAHEAD].fill(0);
        }
        if self.end + LOOKAHEAD == self.buf.len() {
            self.buf.resize((self.buf.len() - LOOKAHEAD) * 2 + LOOKAHEAD, 0);
        }
        let room = self.buf.len() - LOOKAHEAD;
        loop {
            match self.inner.read(&mut self.buf[self.end..room]) {
                Ok(0) => {
                    self.eof = true;
                    return Ok(());
                }
                Ok(n) => {
                    self.end += n;
                    // What an earlier read left past the new end must not read as a number.
                    self.buf[self.end..self.end + LOOKAHEAD].fill(0);
                    return Ok(());
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn collect(input: &[u8]) -> Vec<(Vec<u8>, Vec<u8>)> {
        let mut r = LineReader::new(input);
        let mut out = Vec::new();
        while let Some(l) = r.next_line().unwrap() {
            out.push((l.bytes.to_vec(), l.eol.to_vec()));
        }
        out
    }

    #[test]
    fn keeps_line_endings_exactly() {
        let lines = collect(b"G1 X1\r\nG1 X2\n\nlast");
        assert_eq!(lines[0], (b"G1 X1".to_vec(), b"\r\n".to_vec()));
        assert_eq!(lines[1], (b"G1 X2".to_vec(), b"\n".to_vec()));
        assert_eq!(lines[2], (b"".to_vec(), b"\n".to_vec()));
        assert_eq!(lines[3], (b"last".to_vec(), b"".to_vec()));
        assert_eq!(lines.len(), 4);
        assert!(collect(b"").is_empty());
        assert_eq!(collect(b"\r").len(), 1);
    }

    #[test]
    fn finds_the_newline_at_every_offset() {
        for len in 0..600 {
            let mut text = vec![b'x'; len];
            assert_eq!(find_newline(&text), None);
            text.push(b'\n');
            text.extend_from_slice(b"tail\n");
            assert_eq!(find_newline(&text), Some(len), "line of {len} bytes");
        }
    }

    /// Hands out its bytes a few at a time, as a pipe may.
    struct Trickle<'a>(&'a [u8], usize);

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let n = self.1.min(buf.len()).min(self.0.len());
            buf[..n].copy_from_slice(&self.0[..n]);
            self.0 = &self.0[n..];
            Ok(n)
        }
    }

    #[test]
    fn every_line_has_its_lookahead() {
        // Long lines then a short last one without a line ending: the buffer is compacted over
        // digits, which must not show past the last line's content.
        let mut input = Vec::new();
        for i in 0..3000 {
            input.extend_from_slice(format!("G1 X{i}.123456789 Y987654321\n").as_bytes());
        }
        input.extend_from_slice(b"G1 X1");
        for step in [1, 3, 7, 4096, CHUNK] {
            let mut r = LineReader::new(Trickle(&input, step));
            let mut last = Vec::new();
            while let Some(l) = r.next_line().unwrap() {
                let ahead = l.with_lookahead();
                assert!(ahead.len() >= l.bytes.len() + LOOKAHEAD);
                assert_eq!(&ahead[..l.bytes.len() + l.eol.len()], [l.bytes, l.eol].concat().as_slice());
                assert!(!ahead[l.bytes.len()].is_ascii_digit(), "step {step}, line {}", l.number);
                last = ahead[l.bytes.len()..l.bytes.len() + LOOKAHEAD].to_vec();
            }
            assert_eq!(last, [0; LOOKAHEAD], "step {step}");
        }
    }

    #[test]
    fn lines_longer_than_the_buffer() {
        let mut input = vec![b'x'; CHUNK * 3 + 7];
        input.push(b'\n');
        input.extend_from_slice(b"G1\n");
        let lines = collect(&input);
        assert_eq!(lines[0].0.len(), CHUNK * 3 + 7);
        assert_eq!(lines[1].0, b"G1");
    }
}
