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

/// Bit i set where byte i of the 16 is a `\n`: one comparison of all 16 with SSE2 (part of the
/// x86-64 architecture), a loop elsewhere.
#[inline(always)]
fn newlines16(chunk: &[u8; 16]) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8};
        // SAFETY: SSE2 is always present on x86-64, and `chunk` holds the 16 bytes the
        // unaligned load reads.
        unsafe {
            let bytes = _mm_loadu_si128(chunk.as_ptr().cast());
            _mm_movemask_epi8(_mm_cmpeq_epi8(bytes, _mm_set1_epi8(b'\n' as i8))) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    chunk.iter().enumerate().fold(0, |m, (i, &b)| m | u32::from(b == b'\n') << i)
}

/// Finds the `\n` that ends a line. G-code lines are a few dozen bytes, so the generic
/// `memchr` (a call, a dispatch and an alignment prologue before its 64-byte loop) costs more
/// than the search: the first 256 bytes are tested 16 at a time inline, and only longer lines
/// go to `memchr`.
#[inline(always)]
fn find_newline(haystack: &[u8]) -> Option<usize> {
    let mut i = 0;
    while let Some(chunk) = haystack.get(i..i + 16) {
        let mask = newlines16(chunk.try_into().expect("16 bytes"));
        if mask != 0 {
            return Some(i + mask.trailing_zeros() as usize);
        }
        i += 16;
        if i == 256 {
            break;
        }
    }
    memchr::memchr(b'\n', &haystack[i..]).map(|at| i + at)
}

/// The line `buf[from..to]` (`to` past its `\n`, if any; `buf` readable [`LOOKAHEAD`] bytes past
/// `to`), numbered after `number` and starting at file offset `offset`; advances both.
#[inline(always)]
fn raw_line<'a>(buf: &'a [u8], from: usize, to: usize, number: &mut u64, offset: &mut u64) -> RawLine<'a> {
    let len = to - from;
    let content_len = match &buf[from..to] {
        [.., b'\r', b'\n'] => len - 2,
        [.., b'\n'] => len - 1,
        _ => len,
    };
    *number += 1;
    let at = *offset;
    *offset += len as u64;
    let ahead = &buf[from..from + content_len + LOOKAHEAD];
    let whole = &ahead[..len];
    RawLine { bytes: &whole[..content_len], eol: &whole[content_len..], number: *number, offset: at, ahead }
}

/// Zero bytes the line reader keeps past the data it has read: [`LOOKAHEAD`] for every line,
/// and as many as the first look for a line's end reads at once ([`newline_in_head`]).
const PAD: usize = 32;

/// Finds a `\n` in the 32 bytes from `start`, the length of most G-code lines, with two
/// [`newlines16`] and no test of where the data ends: the reader's zero padding ([`PAD`]) past its
/// data holds no `\n`. `None`: no line ends there (a long line, or the data has run out).
#[inline(always)]
fn newline_in_head(buf: &[u8], start: usize) -> Option<usize> {
    let head: &[u8; PAD] = buf.get(start..start + PAD)?.try_into().ok()?;
    let (low, high) = head.split_at(16);
    let mask = newlines16(low.try_into().ok()?) | newlines16(high.try_into().ok()?) << 16;
    (mask != 0).then(|| mask.trailing_zeros() as usize)
}

/// Reads lines from `R` without ever holding more than one chunk (1 MiB) plus the longest line.
/// The buffer keeps 32 zero bytes past the data read (`PAD`), so that every line has at least
/// [`LOOKAHEAD`] readable bytes after its content.
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
        LineReader { inner, buf: vec![0; CHUNK + PAD], start: 0, end: 0, eof: false, number: 0, offset: 0 }
    }

    /// Bytes handed out so far.
    pub fn position(&self) -> u64 {
        self.offset
    }

    /// The next line, or `None` at the end of the input.
    #[inline(always)]
    pub fn next_line(&mut self) -> io::Result<Option<RawLine<'_>>> {
        // Most lines end within the first look. A `\n` found there is before `end` (past it
        // lie only zeros); the test stays as the guard of that rule.
        let from = self.start;
        if let Some(len) = newline_in_head(&self.buf, from) {
            if from + len < self.end {
                self.start = from + len + 1;
                return Ok(Some(self.ended_line(from, len)));
            }
        }
        self.next_line_searching()
    }

    /// The line from `from` whose `\n` is `len` bytes on.
    #[inline(always)]
    fn ended_line(&mut self, from: usize, len: usize) -> RawLine<'_> {
        // One slice, checked once: every part below is cut from it at offsets the compiler
        // sees are within it.
        let line = &self.buf[from..][..len + 1 + LOOKAHEAD];
        let content = if len > 0 && line[len - 1] == b'\r' { len - 1 } else { len };
        self.number += 1;
        let at = self.offset;
        self.offset += len as u64 + 1;
        RawLine {
            bytes: &line[..content],
            eol: &line[content..len + 1],
            number: self.number,
            offset: at,
            ahead: &line[..content + LOOKAHEAD],
        }
    }

    /// [`LineReader::next_line`] for a line the first look did not end: a long one, or one that
    /// needs more data read.
    #[inline(never)]
    fn next_line_searching(&mut self) -> io::Result<Option<RawLine<'_>>> {
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
    #[inline(always)]
    fn emit(&mut self, from: usize, to: usize) -> RawLine<'_> {
        // `to <= end`, and the buffer holds PAD >= LOOKAHEAD bytes past `end`.
        raw_line(&self.buf, from, to, &mut self.number, &mut self.offset)
    }

    /// Moves the unread tail to the front, grows the buffer if one line fills it, and reads more.
    #[inline(never)]
    fn refill(&mut self) -> io::Result<()> {
        if self.start > 0 {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
            self.buf[self.end..self.end + PAD].fill(0);
        }
        if self.end + PAD == self.buf.len() {
            self.buf.resize((self.buf.len() - PAD) * 2 + PAD, 0);
        }
        let room = self.buf.len() - PAD;
        loop {
            match self.inner.read(&mut self.buf[self.end..room]) {
                Ok(0) => {
                    self.eof = true;
                    return Ok(());
                }
                Ok(n) => {
                    self.end += n;
                    // What an earlier read left past the new end must not read as a number
                    // or a line's end.
                    self.buf[self.end..self.end + PAD].fill(0);
                    return Ok(());
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            }
        }
    }
}

/// Whole lines read ahead of their use, possibly on another thread ([`ChunkReader`]), followed
/// by [`LOOKAHEAD`] zero bytes.
#[derive(Debug)]
pub struct Chunk {
    buf: Vec<u8>,
    len: usize,
    offset: u64,
}

impl Chunk {
    /// The chunk's lines; `before` is the number of lines in the chunks before it.
    pub fn lines(&self, before: u64) -> ChunkLines<'_> {
        ChunkLines { buf: &self.buf, start: 0, end: self.len, number: before, offset: self.offset }
    }

    /// The bytes of the chunk's lines.
    pub fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// The buffer, to be handed back to [`ChunkReader::next_chunk`].
    pub fn into_buffer(self) -> Vec<u8> {
        self.buf
    }
}

/// The lines of a [`Chunk`], as [`LineReader`] gives them.
pub struct ChunkLines<'a> {
    buf: &'a [u8],
    start: usize,
    end: usize,
    number: u64,
    offset: u64,
}

impl<'a> ChunkLines<'a> {
    /// The next line, or `None` at the end of the chunk.
    #[inline(always)]
    pub fn next_line(&mut self) -> Option<RawLine<'a>> {
        if self.start == self.end {
            return None;
        }
        let from = self.start;
        self.start = match find_newline(&self.buf[from..self.end]) {
            Some(nl) => from + nl + 1,
            None => self.end,
        };
        Some(raw_line(self.buf, from, self.start, &mut self.number, &mut self.offset))
    }

    /// Lines handed out so far, counting those before the chunk.
    pub fn number(&self) -> u64 {
        self.number
    }
}

/// Cuts `R` into [`Chunk`]s of whole lines of about 1 MiB (more for a longer line), so that
/// one thread can read while another parses. Buffers are reused: each call takes one back.
pub struct ChunkReader<R> {
    inner: R,
    /// The start of a line that the last chunk could not end.
    carry: Vec<u8>,
    offset: u64,
    eof: bool,
}

impl<R: Read> ChunkReader<R> {
    pub fn new(inner: R) -> Self {
        Self { inner, carry: Vec::new(), offset: 0, eof: false }
    }

    /// The next chunk, read into `buf` (whose contents are dropped); `None` at the end.
    pub fn next_chunk(&mut self, mut buf: Vec<u8>) -> io::Result<Option<Chunk>> {
        buf.clear();
        buf.append(&mut self.carry);
        let mut want = CHUNK.max(buf.len() * 2);
        let len = loop {
            self.fill(&mut buf, want)?;
            // The scan from the end stops at the chunk's last line ending.
            match memchr::memrchr(b'\n', &buf) {
                Some(nl) => {
                    self.carry.extend_from_slice(&buf[nl + 1..]);
                    break nl + 1;
                }
                None if self.eof => break buf.len(),
                // One line longer than the chunk: read on.
                None => want = buf.len() * 2,
            }
        };
        if len == 0 {
            return Ok(None);
        }
        buf.truncate(len);
        buf.resize(len + LOOKAHEAD, 0);
        let offset = self.offset;
        self.offset += len as u64;
        Ok(Some(Chunk { buf, len, offset }))
    }

    /// Reads until `buf` holds `want` bytes or the input ends (into the spare capacity: the
    /// bytes are not zeroed first).
    fn fill(&mut self, buf: &mut Vec<u8>, want: usize) -> io::Result<()> {
        let need = want.saturating_sub(buf.len());
        if (&mut self.inner).take(need as u64).read_to_end(buf)? < need {
            self.eof = true;
        }
        Ok(())
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

    /// Each line's text and ending: `\n`, `\r\n` or `\r\r\n` by its number, none after the last
    /// one unless `last_eol`.
    fn joined(lines: &[(String, u8)], last_eol: bool) -> impl Iterator<Item = (&[u8], &'static [u8])> {
        lines.iter().enumerate().map(move |(i, (text, eol))| {
            let ending: &'static [u8] = if i + 1 < lines.len() || last_eol {
                [&b"\n"[..], b"\r\n", b"\r\r\n"][*eol as usize]
            } else {
                b""
            };
            (text.as_bytes(), ending)
        })
    }

    proptest::proptest! {
        /// The line reader gives every line with its ending as written, numbered and placed,
        /// however the input arrives: lines short enough for its first look for the end and
        /// longer ones, ends falling at the edge of what has been read so far.
        #[test]
        fn lines_come_whole_in_any_pieces(
            lines in proptest::collection::vec(("[ -~]{0,70}", 0..3u8), 0..60),
            last_eol in proptest::bool::ANY,
            step in 1usize..80,
        ) {
            let (mut input, mut want) = (Vec::new(), Vec::new());
            for (text, eol) in joined(&lines, last_eol) {
                // The line's content keeps a `\r` that is not right before its `\n`.
                let (content, ending) = match eol { b"\r\r\n" => ([text, b"\r"].concat(), &b"\r\n"[..]), e => (text.to_vec(), e) };
                if !(content.is_empty() && ending.is_empty()) {
                    want.push((content, ending.to_vec(), want.len() as u64 + 1, input.len() as u64));
                }
                input.extend_from_slice(text);
                input.extend_from_slice(eol);
            }
            let mut got = Vec::new();
            let mut r = LineReader::new(Trickle(&input, step));
            while let Some(l) = r.next_line().unwrap() {
                proptest::prop_assert!(l.with_lookahead().len() >= l.bytes.len() + LOOKAHEAD);
                got.push((l.bytes.to_vec(), l.eol.to_vec(), l.number, l.offset));
            }
            proptest::prop_assert_eq!(got, want);
        }

        /// Chunks give the lines, numbers and offsets of the line reader, each with its
        /// look-ahead bytes, for any input read in any pieces.
        #[test]
        fn chunks_give_the_same_lines(
            lines in proptest::collection::vec(("[ -~]{0,40}", 0..3u8), 0..60),
            last_eol in proptest::bool::ANY,
            step in 1usize..50,
        ) {
            let input: Vec<u8> = joined(&lines, last_eol).flat_map(|(text, eol)| [text, eol].concat()).collect();
            let mut want = Vec::new();
            let mut r = LineReader::new(&input[..]);
            while let Some(l) = r.next_line().unwrap() {
                want.push((l.bytes.to_vec(), l.eol.to_vec(), l.number, l.offset));
            }
            let mut got = Vec::new();
            let mut chunks = ChunkReader::new(Trickle(&input, step));
            let mut buf = Vec::new();
            let mut number = 0;
            while let Some(chunk) = chunks.next_chunk(std::mem::take(&mut buf)).unwrap() {
                let mut lines = chunk.lines(number);
                while let Some(l) = lines.next_line() {
                    // What follows the line ending may differ (the next line, or zeros at a chunk's end).
                    let ahead = l.with_lookahead();
                    proptest::prop_assert!(ahead.len() >= l.bytes.len() + LOOKAHEAD);
                    let whole = [l.bytes, l.eol].concat();
                    proptest::prop_assert_eq!(&ahead[..whole.len()], whole.as_slice());
                    got.push((l.bytes.to_vec(), l.eol.to_vec(), l.number, l.offset));
                }
                number = lines.number();
                buf = chunk.into_buffer();
            }
            proptest::prop_assert_eq!(got, want);
        }
    }

    #[test]
    fn chunks_hold_whole_lines_however_long() {
        let mut input = vec![b'x'; CHUNK * 3 + 7];
        input.push(b'\n');
        input.extend_from_slice(b"G1\nG2");
        let mut chunks = ChunkReader::new(&input[..]);
        let first = chunks.next_chunk(Vec::new()).unwrap().unwrap();
        assert_eq!(first.bytes().len(), input.len() - 2);
        let second = chunks.next_chunk(first.into_buffer()).unwrap().unwrap();
        assert_eq!(second.bytes(), b"G2");
        let mut lines = second.lines(2);
        assert_eq!((lines.next_line().unwrap().number, lines.next_line().is_none()), (3, true));
        assert!(chunks.next_chunk(second.into_buffer()).unwrap().is_none());
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
