//! Streaming line reader: a fixed buffer refilled from any `Read`, lines handed out as slices of
//! it, so memory is bounded by the buffer whatever the file and whatever its bytes.
//!
//! A line ends at `\n`, `\r\n` or a lone `\r`, as Marlin reads a line (it ends a command at
//! either byte). A line longer than [`MAX_LINE`] is handed out in pieces ([`Part`]), never
//! held whole.

use std::io::{self, Read};

use super::encoding::{refuse_utf16, ENCODING_HEAD};

/// One line as it is in the file, or a piece of a line longer than [`MAX_LINE`].
#[derive(Debug, Clone, Copy)]
pub struct RawLine<'a> {
    /// The content, without the line ending.
    pub bytes: &'a [u8],
    /// The line ending exactly as written: `b"\n"`, `b"\r\n"`, `b"\r"`, or empty for a last line
    /// without one (and for every piece of a long line but its last).
    pub eol: &'a [u8],
    /// 1-based line number in the file (the same for every piece of a long line).
    pub number: u64,
    /// Byte offset of the line's (or the piece's) first byte in the file.
    pub offset: u64,
    /// A whole line, or which piece of a longer one.
    pub part: Part,
    /// See [`RawLine::with_lookahead`].
    ahead: &'a [u8],
}

/// Whether a [`RawLine`] is a whole line. A line longer than [`MAX_LINE`] comes as pieces:
/// copying them in order gives the line back, byte for byte; nothing should parse them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// A whole line, of at most [`MAX_LINE`] bytes.
    Whole,
    /// A piece of a longer line, without a line ending; more pieces follow.
    Piece,
    /// The last piece of a longer line (perhaps the only one, if it all came at once), with
    /// the line's ending. `len`: the whole line's length in bytes, line ending excluded.
    Last {
        /// The whole line's length in bytes, line ending excluded.
        len: u64,
    },
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

/// The longest line handed out whole, in bytes, line ending excluded. Firmware reads far less
/// (Marlin's `MAX_CMD_SIZE` is 96 bytes) and the longest lines slicers write are settings
/// comments of a few KiB (a start G-code kept on one line): 256 KiB is generous for any real
/// file, and it bounds what one line may cost (the lexer lists at most one word per two bytes).
/// A longer line comes in pieces ([`Part`]): copied through by a lenient copy, reported as
/// malformed otherwise.
pub const MAX_LINE: usize = 256 << 10;

const CHUNK: usize = 1 << 20;

/// Bit i set where byte i of the 16 is a `\n` or a `\r`: two comparisons of all 16 with SSE2
/// (part of the x86-64 architecture), a loop elsewhere.
#[inline(always)]
fn line_ends16(chunk: &[u8; 16]) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_or_si128, _mm_set1_epi8,
        };
        // SAFETY: SSE2 is always present on x86-64, and `chunk` holds the 16 bytes the
        // unaligned load reads.
        unsafe {
            let bytes = _mm_loadu_si128(chunk.as_ptr().cast());
            let lf = _mm_cmpeq_epi8(bytes, _mm_set1_epi8(b'\n' as i8));
            let cr = _mm_cmpeq_epi8(bytes, _mm_set1_epi8(b'\r' as i8));
            _mm_movemask_epi8(_mm_or_si128(lf, cr)) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    chunk.iter().enumerate().fold(0, |m, (i, &b)| m | u32::from(b == b'\n' || b == b'\r') << i)
}

/// Finds the first `\n` or `\r`. G-code lines are a few dozen bytes, so the generic `memchr2`
/// (a call, a dispatch and an alignment prologue before its loop) costs more than the search:
/// the first 256 bytes are tested 16 at a time inline, and only longer lines go to `memchr2`.
#[inline(always)]
pub(crate) fn find_line_end(haystack: &[u8]) -> Option<usize> {
    let mut i = 0;
    while let Some(chunk) = haystack.get(i..i + 16) {
        let mask = line_ends16(chunk.try_into().expect("16 bytes"));
        if mask != 0 {
            return Some(i + mask.trailing_zeros() as usize);
        }
        i += 16;
        if i == 256 {
            break;
        }
    }
    memchr::memchr2(b'\n', b'\r', &haystack[i..]).map(|at| i + at)
}

/// The length of the line ending at `data[at]` (a `\n` or `\r`): 2 for `\r\n`, else 1.
/// `None`: a `\r` is the last byte of `data`, and the input goes on (a `\n` may follow).
#[inline(always)]
fn eol_len(data: &[u8], at: usize, eof: bool) -> Option<usize> {
    match data.get(at + 1) {
        _ if data[at] == b'\n' => Some(1),
        Some(b'\n') => Some(2),
        Some(_) => Some(1),
        None => eof.then_some(1),
    }
}

/// The line of `content` bytes from `buf[from]`, then `eol` bytes of line ending (at most 2,
/// fewer than [`LOOKAHEAD`]; `buf` readable [`LOOKAHEAD`] bytes past the content).
#[inline(always)]
fn line_at(
    buf: &[u8],
    from: usize,
    content: usize,
    eol: usize,
    number: u64,
    offset: u64,
    part: Part,
) -> RawLine<'_> {
    // One slice, checked once: every part below is cut from it at offsets the compiler sees
    // are within it.
    let ahead = &buf[from..][..content + LOOKAHEAD];
    RawLine {
        bytes: &ahead[..content],
        eol: &ahead[content..content + eol],
        number,
        offset,
        part,
        ahead: &ahead[..content + LOOKAHEAD],
    }
}

/// Zero bytes the line reader keeps past the data it has read: [`LOOKAHEAD`] for every line,
/// and as many as the first look for a line's end reads at once ([`line_end_in_head`]).
const PAD: usize = 32;

/// Finds a `\n` or `\r` in the 32 bytes from `start`, the length of most G-code lines, with two
/// [`line_ends16`] and no test of where the data ends: the reader's zero padding ([`PAD`]) past
/// its data holds neither. `None`: no line ends there (a long line, or the data has run out).
#[inline(always)]
fn line_end_in_head(buf: &[u8], start: usize) -> Option<usize> {
    let head: &[u8; PAD] = buf.get(start..start + PAD)?.try_into().ok()?;
    let (low, high) = head.split_at(16);
    let mask = line_ends16(low.try_into().ok()?) | line_ends16(high.try_into().ok()?) << 16;
    (mask != 0).then(|| mask.trailing_zeros() as usize)
}

/// Reads lines from `R` without ever holding more than one chunk (1 MiB): a line longer than
/// [`MAX_LINE`] is handed out in pieces. The buffer keeps 32 zero bytes past the data read
/// (`PAD`), so that every line has at least [`LOOKAHEAD`] readable bytes after its content.
/// UTF-16 text is refused on the first read (`refuse_utf16`).
pub struct LineReader<R> {
    inner: R,
    buf: Vec<u8>,
    start: usize,
    end: usize,
    eof: bool,
    number: u64,
    offset: u64,
    /// Bytes handed out so far of a line longer than [`MAX_LINE`], while its pieces come.
    long: Option<u64>,
    /// [`MAX_LINE`], smaller in tests.
    max_line: usize,
}

impl<R: Read> LineReader<R> {
    /// Lines of `inner`, numbered from 1.
    pub fn new(inner: R) -> Self {
        LineReader {
            inner,
            buf: vec![0; CHUNK + PAD],
            start: 0,
            end: 0,
            eof: false,
            number: 0,
            offset: 0,
            long: None,
            max_line: MAX_LINE,
        }
    }

    /// Bytes handed out so far.
    pub fn position(&self) -> u64 {
        self.offset
    }

    /// The next line, or `None` at the end of the input.
    #[inline(always)]
    pub fn next_line(&mut self) -> io::Result<Option<RawLine<'_>>> {
        // Most lines end within the first look, at a `\n`, a `\r\n` or a lone `\r`. A line end
        // found there is before `end` (past it lie only zeros); the test stays as the guard of
        // that rule. A `\r` at the end of the data goes the long way. So does the rest of a
        // long line: its pieces take all the data read, up to a last `\r`.
        let from = self.start;
        if let Some(len) = line_end_in_head(&self.buf, from) {
            let at = from + len;
            if at < self.end {
                let eol = match self.buf[at] {
                    b'\n' => 1,
                    _ if self.buf[at + 1] == b'\n' => 2,
                    // A lone `\r`; one at the end of the data may be half of a `\r\n`.
                    _ if at + 1 < self.end => 1,
                    _ => return self.next_line_searching(),
                };
                debug_assert!(self.long.is_none(), "a long line's piece left data in the buffer");
                self.start = at + eol;
                self.number += 1;
                let offset = self.offset;
                self.offset += (len + eol) as u64;
                return Ok(Some(line_at(&self.buf, from, len, eol, self.number, offset, Part::Whole)));
            }
        }
        self.next_line_searching()
    }

    /// The bytes read and not yet handed out: the next lines, as far as the buffer holds them
    /// (perhaps none, or a line's start only: reading the next line reads more). Empty while a
    /// long line's pieces are handed out. For a reader that compares them with another file's
    /// at once and then passes over the lines it knows ([`LineReader::skip_line`]).
    #[inline]
    pub fn unread(&self) -> &[u8] {
        match self.long {
            Some(_) => &[],
            None => &self.buf[self.start..self.end],
        }
    }

    /// Passes over the next line, as [`LineReader::next_line`] would hand it out, without
    /// looking for its end: the caller knows it, having compared [`LineReader::unread`] with a
    /// line of another file. `len`: the line's length with its ending, which is `\n` or
    /// `\r\n` (its content holds no `\r` or `\n`). `false`, and nothing passed over, if the
    /// unread bytes are fewer, or `len` is 0, or the `len`-th is not a `\n`.
    #[inline]
    pub fn skip_line(&mut self, len: usize) -> bool {
        if len == 0 || len > self.unread().len() || self.buf[self.start + len - 1] != b'\n' {
            return false;
        }
        self.start += len;
        self.number += 1;
        self.offset += len as u64;
        true
    }

    /// [`LineReader::next_line`] for a line the first look did not end: a long one, one ended
    /// by a lone `\r`, or one that needs more data read.
    #[inline(never)]
    fn next_line_searching(&mut self) -> io::Result<Option<RawLine<'_>>> {
        loop {
            let data = &self.buf[self.start..self.end];
            // Where the data stops being this line's: its end, or all of it (but a last `\r`,
            // which may be half of a `\r\n`).
            let content = match find_line_end(data) {
                Some(at) => match eol_len(data, at, self.eof) {
                    Some(eol) => return Ok(Some(self.emit(at, eol))),
                    None => at,
                },
                None if self.eof => {
                    if data.is_empty() && self.long.is_none() {
                        return Ok(None);
                    }
                    return Ok(Some(self.emit(data.len(), 0)));
                }
                None => data.len(),
            };
            if content > 0 && (self.long.is_some() || content > self.max_line) {
                return Ok(Some(self.piece(content)));
            }
            self.refill()?;
        }
    }

    /// Hands out the `content` bytes from `start` and the `eol` after them as a line, or as
    /// the last piece of a long one (every line longer than [`MAX_LINE`] ends with one).
    fn emit(&mut self, content: usize, eol: usize) -> RawLine<'_> {
        let part = match self.long.take() {
            Some(before) => Part::Last { len: before + content as u64 },
            None => {
                self.number += 1;
                // Whole in the buffer but long all the same: no piece before the last.
                if content > self.max_line {
                    Part::Last { len: content as u64 }
                } else {
                    Part::Whole
                }
            }
        };
        self.hand_out(content, eol, part)
    }

    /// Hands out the `content` bytes from `start` as a piece of a line longer than
    /// [`MAX_LINE`].
    fn piece(&mut self, content: usize) -> RawLine<'_> {
        let before = *self.long.get_or_insert_with(|| {
            self.number += 1;
            0
        });
        self.long = Some(before + content as u64);
        self.hand_out(content, 0, Part::Piece)
    }

    #[inline(always)]
    fn hand_out(&mut self, content: usize, eol: usize, part: Part) -> RawLine<'_> {
        let from = self.start;
        self.start += content + eol;
        let offset = self.offset;
        self.offset += (content + eol) as u64;
        // `start <= end`, and the buffer holds PAD >= LOOKAHEAD bytes past `end`.
        line_at(&self.buf, from, content, eol, self.number, offset, part)
    }

    /// Moves the unread tail to the front and reads more. The tail is shorter than
    /// [`MAX_LINE`] (a longer one is handed out in pieces first), so the buffer never grows.
    #[inline(never)]
    fn refill(&mut self) -> io::Result<()> {
        let first = self.offset == 0 && self.end == 0 && !self.eof;
        if self.start > 0 {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
            self.buf[self.end..self.end + PAD].fill(0);
        }
        let room = self.buf.len() - PAD;
        debug_assert!(self.end < room);
        loop {
            match self.inner.read(&mut self.buf[self.end..room]) {
                Ok(0) => {
                    self.eof = true;
                    break;
                }
                Ok(n) => {
                    self.end += n;
                    // What an earlier read left past the new end must not read as a number
                    // or a line's end.
                    self.buf[self.end..self.end + PAD].fill(0);
                    // The first bytes tell the encoding: read all it looks at before any line.
                    if !first || self.end >= ENCODING_HEAD {
                        break;
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            }
        }
        if first {
            refuse_utf16(&self.buf[..self.end])?;
        }
        Ok(())
    }
}

/// Whole lines read ahead of their use, possibly on another thread ([`ChunkReader`]), followed
/// by [`LOOKAHEAD`] zero bytes; or one line longer than [`MAX_LINE`], skipped.
#[derive(Debug)]
pub struct Chunk {
    buf: Vec<u8>,
    len: usize,
    offset: u64,
    /// The length of the skipped long line (line ending excluded); `buf` holds its ending.
    long: Option<u64>,
}

impl Chunk {
    /// The chunk's lines; `before` is the number of lines in the chunks before it.
    pub fn lines(&self, before: u64) -> ChunkLines<'_> {
        self.lines_from(0, before)
    }

    /// The chunk's lines from byte `at`, where a line starts (0, or a [`ChunkLines::position`]
    /// of its lines); `before` is the number of lines before that one in the file. A reader
    /// can so take a chunk's lines up in batches, and another take the same batches up again.
    pub fn lines_from(&self, at: usize, before: u64) -> ChunkLines<'_> {
        let start = at.min(self.len);
        ChunkLines {
            buf: &self.buf,
            start,
            end: self.len,
            number: before,
            offset: self.offset + start as u64,
            long: if start == 0 { self.long } else { None },
        }
    }

    /// The bytes of the chunk's lines (none for a skipped long line).
    pub fn bytes(&self) -> &[u8] {
        if self.long.is_some() {
            return &[];
        }
        &self.buf[..self.len]
    }

    /// The buffer, to be handed back to [`ChunkReader::next_chunk`].
    pub fn into_buffer(self) -> Vec<u8> {
        self.buf
    }
}

/// The lines of a [`Chunk`], as [`LineReader`] gives them. A line longer than [`MAX_LINE`]
/// comes as one [`Part::Last`] with no bytes: chunks are for readers that parse, not copy.
pub struct ChunkLines<'a> {
    buf: &'a [u8],
    start: usize,
    end: usize,
    number: u64,
    offset: u64,
    long: Option<u64>,
}

impl<'a> ChunkLines<'a> {
    /// The next line when the lexing thread has found its end already
    /// ([`Batch`](super::lexed::Batch)): a whole line of `content` bytes and an ending of `eol`
    /// (0 to 2), as [`ChunkLines::next_line`] gives it, without searching for its end again.
    #[inline(always)]
    pub fn next_known(&mut self, content: usize, eol: usize) -> RawLine<'a> {
        let from = self.start;
        self.number += 1;
        self.start += content + eol;
        let offset = self.offset;
        self.offset += (content + eol) as u64;
        line_at(self.buf, from, content, eol, self.number, offset, Part::Whole)
    }

    /// The next line, or `None` at the end of the chunk.
    #[inline(always)]
    pub fn next_line(&mut self) -> Option<RawLine<'a>> {
        if self.start == self.end && self.long.is_none() {
            return None;
        }
        let from = self.start;
        let data = &self.buf[from..self.end];
        let (content, eol) = match find_line_end(data) {
            // A chunk ends at a line's end, so a last `\r` is a lone one.
            Some(at) => (at, eol_len(data, at, true).unwrap_or(1)),
            None => (data.len(), 0),
        };
        self.number += 1;
        self.start += content + eol;
        let offset = self.offset;
        // A skipped long line (its ending alone in the chunk), or a long line within the chunk:
        // handed out as LineReader ends one, without its content.
        match self.long.take().or((content > MAX_LINE).then_some(content as u64)) {
            Some(len) => {
                self.offset += len + eol as u64;
                Some(line_at(self.buf, from + content, 0, eol, self.number, offset, Part::Last { len }))
            }
            None => {
                self.offset += (content + eol) as u64;
                Some(line_at(self.buf, from, content, eol, self.number, offset, Part::Whole))
            }
        }
    }

    /// Lines handed out so far, counting those before the chunk.
    pub fn number(&self) -> u64 {
        self.number
    }

    /// Where the next line starts in the chunk, for [`Chunk::lines_from`].
    pub fn position(&self) -> usize {
        self.start
    }
}

/// Where the last whole line of `buf` ends (past its ending), `None` if none does. A `\r` that
/// is the last byte is not known to end a line until the input ends (a `\n` may follow).
fn last_line_end(buf: &[u8], eof: bool) -> Option<usize> {
    let at = memchr::memrchr2(b'\n', b'\r', buf)?;
    if buf[at] == b'\r' && at + 1 == buf.len() && !eof {
        return memchr::memrchr2(b'\n', b'\r', &buf[..at]).map(|before| before + 1);
    }
    Some(at + 1)
}

/// Cuts `R` into [`Chunk`]s of whole lines of about 1 MiB, so that one thread can read while
/// another parses. Buffers are reused: each call takes one back. A line longer than
/// [`MAX_LINE`] is read through without being held, and comes as a chunk of its own.
pub struct ChunkReader<R> {
    inner: R,
    /// The start of a line that the last chunk could not end.
    carry: Vec<u8>,
    offset: u64,
    eof: bool,
}

impl<R: Read> ChunkReader<R> {
    /// Chunks of whole lines of `inner`.
    pub fn new(inner: R) -> Self {
        Self { inner, carry: Vec::new(), offset: 0, eof: false }
    }

    /// The next chunk, read into `buf` (whose contents are dropped); `None` at the end.
    pub fn next_chunk(&mut self, mut buf: Vec<u8>) -> io::Result<Option<Chunk>> {
        let first = self.offset == 0 && self.carry.is_empty();
        let carry = self.carry.len();
        // Enough that a line ends within it unless it is longer than MAX_LINE.
        let want = CHUNK.max(carry + MAX_LINE);
        // A buffer handed back is read into as it is, its bytes overwritten: only room it
        // lacks is zeroed (`read_to_end` zeroes all its spare room before reading, a memset of
        // the whole chunk each time). A new buffer is allocated zeroed (`calloc`: fresh pages
        // from the kernel are zero already), not grown and then cleared byte by byte.
        if buf.is_empty() {
            buf = vec![0; want + LOOKAHEAD];
        } else if buf.len() < want + LOOKAHEAD {
            buf.resize(want + LOOKAHEAD, 0);
        }
        buf[..carry].copy_from_slice(&self.carry);
        self.carry.clear();
        let end = self.read_into(&mut buf[..want], carry)?;
        if first {
            refuse_utf16(&buf[..end])?;
        }
        let len = match last_line_end(&buf[..end], self.eof) {
            Some(len) => len,
            None if self.eof => end,
            // No line ends in more than MAX_LINE bytes.
            None => {
                buf.truncate(end);
                return self.skip_long_line(buf).map(Some);
            }
        };
        if len == 0 {
            return Ok(None);
        }
        self.carry.extend_from_slice(&buf[len..end]);
        buf[len..len + LOOKAHEAD].fill(0);
        let offset = self.offset;
        self.offset += len as u64;
        Ok(Some(Chunk { buf, len, offset, long: None }))
    }

    /// Reads on to the end of the line that `buf` starts (with no line end in it but perhaps
    /// a last `\r`), keeping only what follows it.
    fn skip_long_line(&mut self, mut buf: Vec<u8>) -> io::Result<Chunk> {
        let mut len = 0u64;
        let mut pending_cr = false;
        let (ending, rest): (&[u8], usize) = loop {
            if pending_cr {
                break if buf.first() == Some(&b'\n') { (b"\r\n", 1) } else { (b"\r", 0) };
            }
            match memchr::memchr2(b'\n', b'\r', &buf) {
                Some(at) if buf[at] == b'\r' && at + 1 == buf.len() && !self.eof => {
                    len += at as u64;
                    pending_cr = true;
                }
                Some(at) => {
                    len += at as u64;
                    break match (buf[at], buf.get(at + 1)) {
                        (b'\n', _) => (b"\n", at + 1),
                        (_, Some(b'\n')) => (b"\r\n", at + 2),
                        _ => (b"\r", at + 1),
                    };
                }
                None if self.eof => {
                    len += buf.len() as u64;
                    break (b"", buf.len());
                }
                None => len += buf.len() as u64,
            }
            buf.clear();
            self.fill(&mut buf, CHUNK)?;
        };
        self.carry.extend_from_slice(&buf[rest..]);
        buf.clear();
        buf.extend_from_slice(ending);
        buf.resize(ending.len() + LOOKAHEAD, 0);
        let offset = self.offset;
        self.offset += len + ending.len() as u64;
        Ok(Chunk { buf, len: ending.len(), offset, long: Some(len) })
    }

    /// Reads into `buf` after its first `filled` bytes until it is full or the input ends;
    /// returns how many bytes it holds.
    fn read_into(&mut self, buf: &mut [u8], mut filled: usize) -> io::Result<usize> {
        while filled < buf.len() {
            match self.inner.read(&mut buf[filled..]) {
                Ok(0) => {
                    self.eof = true;
                    break;
                }
                // A reader that claims more than it was given room for is taken at its room.
                Ok(n) => filled = (filled + n).min(buf.len()),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        Ok(filled)
    }

    /// Reads until `buf` holds `want` bytes or the input ends (for a long line, which is rare:
    /// `read_to_end` zeroes the spare room first).
    fn fill(&mut self, buf: &mut Vec<u8>, want: usize) -> io::Result<()> {
        let need = want.saturating_sub(buf.len());
        if (&mut self.inner).take(need as u64).read_to_end(buf)? < need {
            self.eof = true;
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "reader_tests.rs"]
mod tests;
