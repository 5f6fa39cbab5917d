//! Reading a binary G-code file block by block, as a stream of text ([`Reader`] is a
//! [`Read`]): the metadata rendered first (`super::text::prefix`), then each G-code block
//! checked (CRC32), decompressed (deflate, heatshrink), decoded (MeatPack) and stripped of the
//! empty lines libbgcode's converter leaves out, then the print and slicer metadata. Memory:
//! one block, its decoded text, and the metadata.

use std::io::{self, Read, Seek, SeekFrom};

use super::super::{heatshrink, meatpack};
use super::{
    invalid, read_full, text, Block, Compression, Header, Kind, Metadata, Preamble, Thumbnail, MAGIC,
    MAX_BLOCK, MAX_PREAMBLE, MAX_SLICER_BLOCKS, MAX_THUMBNAILS,
};

/// A binary G-code file read as text.
pub struct Reader<R> {
    inner: R,
    preamble: Preamble,
    /// Text ready to be read, from `pos`.
    buf: Vec<u8>,
    pos: usize,
    /// The next G-code block's header, already read; `None` after the last.
    next: Option<Located>,
    suffix_done: bool,
    /// 1-based number of the next block, and the byte offset of the next header.
    block: u32,
    offset: u64,
    scratch: Vec<u8>,
    decoded: Vec<u8>,
}

/// A block header with its number and offset, for messages.
#[derive(Clone, Copy)]
struct Located {
    header: Header,
    number: u32,
    offset: u64,
}

impl<R: Read> Reader<R> {
    /// Reads the file header and every block before the G-code (`inner` starts at the magic).
    pub fn new(inner: R) -> io::Result<Reader<R>> {
        let mut r = Reader {
            inner,
            preamble: Preamble::default(),
            buf: Vec::new(),
            pos: 0,
            next: None,
            suffix_done: false,
            block: 1,
            offset: 10,
            scratch: Vec::new(),
            decoded: Vec::new(),
        };
        r.preamble.checksum = r.file_header()?;
        let mut seen_printer = false;
        // Bytes of the blocks kept so far (stored or decoded, the larger), held to MAX_PREAMBLE.
        let mut kept: u64 = 0;
        loop {
            let Some(at) = r.header()? else {
                return Err(invalid("the file ends before its first G-code block".into()));
            };
            let order_error = |what: &str| {
                Err(invalid(format!(
                    "block {} ({} at byte {}) is out of order: {what}",
                    at.number,
                    at.header.kind.name(),
                    at.offset
                )))
            };
            match at.header.kind {
                Kind::GCode if !seen_printer => return order_error("no printer metadata before it"),
                Kind::GCode => {
                    r.next = Some(at);
                    break;
                }
                Kind::FileMetadata if r.block != 2 => return order_error("file metadata must come first"),
                Kind::PrinterMetadata if seen_printer => {
                    return order_error("a second printer metadata block")
                }
                Kind::Thumbnail | Kind::PrintMetadata | Kind::SlicerMetadata if !seen_printer => {
                    return order_error("no printer metadata before it")
                }
                Kind::Thumbnail if r.preamble.thumbnails.len() == MAX_THUMBNAILS => {
                    return at.refuse(format!("more than {MAX_THUMBNAILS} thumbnails"))
                }
                Kind::SlicerMetadata if r.preamble.slicer.len() == MAX_SLICER_BLOCKS => {
                    return at.refuse(format!("more than {MAX_SLICER_BLOCKS} slicer metadata blocks"))
                }
                _ => {}
            }
            // Checked from the header, before the block is read or inflated.
            kept += u64::from(at.header.uncompressed.max(at.header.stored));
            if kept > MAX_PREAMBLE {
                return at.refuse(format!(
                    "the blocks before the G-code would hold {kept} bytes, more than the limit of {} MiB",
                    MAX_PREAMBLE >> 20
                ));
            }
            let block = r.block_data(at)?;
            match at.header.kind {
                Kind::Thumbnail => {
                    let p = &block.params;
                    let field = |i: usize| u16::from_le_bytes([p[i], p[i + 1]]);
                    let (format, width, height) = (field(0), field(2), field(4));
                    r.preamble.thumbnails.push(Thumbnail { block, format, width, height });
                }
                kind => {
                    let meta = Metadata::parse(&r.decoded, block.encoding()).map_err(|e| at.error(e))?;
                    match kind {
                        Kind::FileMetadata => r.preamble.file = Some(meta),
                        Kind::PrinterMetadata => {
                            r.preamble.printer = meta;
                            seen_printer = true;
                        }
                        Kind::PrintMetadata => r.preamble.print = meta,
                        _ => r.preamble.slicer.push(meta),
                    }
                }
            }
        }
        r.buf = text::prefix(&r.preamble);
        Ok(r)
    }

    /// What came before the G-code: metadata and thumbnails.
    pub fn preamble(&self) -> &Preamble {
        &self.preamble
    }

    /// Checks the magic and version; returns whether blocks carry a CRC32.
    fn file_header(&mut self) -> io::Result<bool> {
        let mut h = [0u8; 10];
        if read_full(&mut self.inner, &mut h)? < h.len() || &h[..4] != MAGIC {
            return Err(invalid("not a binary G-code file (no GCDE header)".into()));
        }
        let version = u32::from_le_bytes([h[4], h[5], h[6], h[7]]);
        if version != super::VERSION {
            return Err(invalid(format!("binary G-code version {version} is not supported (only 1)")));
        }
        match u16::from_le_bytes([h[8], h[9]]) {
            0 => Ok(false),
            1 => Ok(true),
            c => Err(invalid(format!("unknown checksum type {c} in the file header"))),
        }
    }

    /// The next block's header, `None` at the end of the file.
    fn header(&mut self) -> io::Result<Option<Located>> {
        let (number, offset) = (self.block, self.offset);
        let mut h = [0u8; 12];
        let n = read_full(&mut self.inner, &mut h[..8])?;
        if n == 0 {
            return Ok(None);
        }
        let truncated = |got: usize, of: usize| {
            invalid(format!("block {number} (at byte {offset}) is truncated: the file ends {got} bytes into its {of}-byte header"))
        };
        if n < 8 {
            return Err(truncated(n, 8));
        }
        let field = |i: usize| u16::from_le_bytes([h[i], h[i + 1]]);
        let kind = Kind::from_u16(field(0)).ok_or_else(|| {
            invalid(format!("block {number} (at byte {offset}) has an unknown type {}", field(0)))
        })?;
        let compression = Compression::from_u16(field(2)).ok_or_else(|| {
            invalid(format!(
                "block {number} ({} at byte {offset}) has an unknown compression {}",
                kind.name(),
                field(2)
            ))
        })?;
        let uncompressed = u32::from_le_bytes([h[4], h[5], h[6], h[7]]);
        let mut stored = uncompressed;
        let mut len = 8;
        if compression != Compression::None {
            let got = read_full(&mut self.inner, &mut h[8..12])?;
            if got < 4 {
                return Err(truncated(8 + got, 12));
            }
            stored = u32::from_le_bytes([h[8], h[9], h[10], h[11]]);
            len = 12;
        }
        let at = Located { header: Header { kind, compression, uncompressed, stored }, number, offset };
        if uncompressed > MAX_BLOCK || stored > MAX_BLOCK {
            return Err(at.error(invalid(format!(
                "its size ({} bytes) is larger than the limit of {} MiB for a block",
                uncompressed.max(stored),
                MAX_BLOCK >> 20
            ))));
        }
        self.block += 1;
        self.offset += len as u64;
        Ok(Some(at))
    }

    /// Reads the block's parameters, data and checksum; checks the checksum; leaves the
    /// decompressed data in `self.decoded`. Returns the block as stored.
    fn block_data(&mut self, at: Located) -> io::Result<Block> {
        let h = at.header;
        let mut params = vec![0u8; h.kind.params_len()];
        let mut data = std::mem::take(&mut self.scratch);
        data.resize(h.stored as usize, 0);
        let crc_len = if self.preamble.checksum { 4 } else { 0 };
        let total = params.len() + data.len() + crc_len;
        let mut got = read_full(&mut self.inner, &mut params)?;
        if got == params.len() {
            got += read_full(&mut self.inner, &mut data)?;
        }
        let mut crc = [0u8; 4];
        if got == params.len() + data.len() {
            got += read_full(&mut self.inner, &mut crc[..crc_len])?;
        }
        if got < total {
            return Err(at.error(invalid(format!("truncated: the file ends {got} bytes into its {total}"))));
        }
        self.offset += total as u64;
        if self.preamble.checksum {
            let mut hasher = crc32fast::Hasher::new();
            hasher.update(&h.to_bytes());
            hasher.update(&params);
            hasher.update(&data);
            let (stored, computed) = (u32::from_le_bytes(crc), hasher.finalize());
            if stored != computed {
                return Err(at.error(invalid(format!(
                    "checksum mismatch (stored {stored:08x}, computed {computed:08x}): the file is damaged"
                ))));
            }
        }
        // Thumbnails are stored as they are (libbgcode reads their data without decompressing).
        if h.kind != Kind::Thumbnail {
            decompress(&data, h, &mut self.decoded).map_err(|e| at.error(e))?;
        }
        Ok(Block { header: h, params, data })
    }

    /// Decodes the next G-code block into `buf`, or the suffix after the last.
    fn refill(&mut self) -> io::Result<()> {
        let mut buf = std::mem::take(&mut self.buf);
        buf.clear();
        let done = self.next_text(&mut buf);
        self.buf = buf;
        self.pos = 0;
        done
    }

    /// Appends the next G-code block's text to `out`, or the suffix after the last.
    fn next_text(&mut self, out: &mut Vec<u8>) -> io::Result<()> {
        let Some(at) = self.next.take() else {
            if !self.suffix_done {
                self.suffix_done = true;
                out.extend(text::suffix(&self.preamble));
            }
            return Ok(());
        };
        let block = self.block_data(at)?;
        // Decoded straight into `out` (its room kept from block to block), the dropped lines
        // taken out in place.
        let start = out.len();
        match block.encoding() {
            0 if start == 0 => std::mem::swap(out, &mut self.decoded),
            0 => out.extend_from_slice(&self.decoded),
            1 | 2 => meatpack::decode(&self.decoded, out),
            e => return Err(at.error(invalid(format!("unknown G-code encoding {e}")))),
        }
        drop_empty_lines(out, start);
        self.scratch = block.data;
        self.next = match self.header()? {
            Some(next) if next.header.kind == Kind::GCode => Some(next),
            Some(other) => {
                return Err(
                    other.error(invalid("only G-code blocks may follow the first G-code block".into()))
                )
            }
            None => None,
        };
        Ok(())
    }
}

/// The decoding thread's source (`super::super::ahead`): each block's text appended to the
/// chunk it fills, without going through a buffer of the reader's own.
impl<R: Read> super::super::ahead::Text for Reader<R> {
    fn text_into(&mut self, out: &mut Vec<u8>) -> io::Result<usize> {
        let start = out.len();
        if self.pos < self.buf.len() {
            // The metadata's text, rendered when the file was opened.
            out.extend_from_slice(&self.buf[self.pos..]);
            self.pos = self.buf.len();
        }
        while out.len() == start && !(self.next.is_none() && self.suffix_done) {
            self.next_text(out)?;
        }
        Ok(out.len() - start)
    }
}

impl Located {
    /// The file refused at this block, saying why.
    fn refuse<T>(&self, why: String) -> io::Result<T> {
        Err(self.error(invalid(why)))
    }

    fn error(&self, e: io::Error) -> io::Error {
        io::Error::new(
            e.kind(),
            format!("block {} ({} at byte {}): {e}", self.number, self.header.kind.name(), self.offset),
        )
    }
}

impl<R: Read> Read for Reader<R> {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        while self.pos == self.buf.len() {
            if self.next.is_none() && self.suffix_done {
                return Ok(0);
            }
            self.refill()?;
        }
        let n = out.len().min(self.buf.len() - self.pos);
        out[..n].copy_from_slice(&self.buf[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

/// Decompresses a block's data into `out` (replacing what it held), which must come to the
/// header's uncompressed size.
fn decompress(data: &[u8], h: Header, out: &mut Vec<u8>) -> io::Result<()> {
    let expected = h.uncompressed as usize;
    match h.compression {
        Compression::None => {
            out.clear();
            out.extend_from_slice(data);
        }
        Compression::Deflate => {
            out.clear();
            let mut z = flate2::read::ZlibDecoder::new(data);
            out.reserve(expected);
            (&mut z)
                .take(expected as u64 + 1)
                .read_to_end(out)
                .map_err(|e| invalid(format!("deflate data: {e}")))?;
            // Read one byte past the header's size and no further (a bomb is not inflated to
            // find how far it goes): past it, the data decodes to more.
            if out.len() > expected {
                return Err(invalid(format!(
                    "deflate data decodes to more than the {expected} bytes its header says"
                )));
            }
            if out.len() < expected {
                return Err(invalid(format!(
                    "deflate data decodes to {} bytes, not the {expected} its header says",
                    out.len()
                )));
            }
        }
        Compression::Heatshrink11 | Compression::Heatshrink12 => {
            let window_bits = if h.compression == Compression::Heatshrink11 { 11 } else { 12 };
            heatshrink::decode(data, heatshrink::Params { window_bits, lookahead_bits: 4 }, expected, out)?;
        }
    }
    Ok(())
}

/// Takes out of `text[from..]` (a block's text) the lines libbgcode's converter drops: empty,
/// blank (spaces and tabs), or a `;` with nothing but blanks after it. A last line without a
/// newline gets one. Runs of kept lines move at once, and only after a dropped line: most lines
/// start with a letter and are kept where they are, skipped by [`next_line_that_may_go`]
/// without being looked at one by one.
fn drop_empty_lines(text: &mut Vec<u8>, from: usize) {
    let blank = |b: u8| b == b' ' || b == b'\t';
    let len = text.len();
    // Kept bytes end at `write`; the run of kept lines not yet moved starts at `run`.
    let (mut write, mut run, mut start) = (from, from, from);
    while start < len {
        if !may_go(text[start]) {
            match next_line_that_may_go(&text[start..len]) {
                Some(i) => start += i,
                None => break,
            }
        }
        let end = memchr::memchr(b'\n', &text[start..]).map_or(len, |i| start + i);
        let line = &text[start..end];
        let dropped = match line.first() {
            Some(&c) if c != b' ' && c != b'\t' && c != b';' => false,
            _ => match line.iter().position(|&b| !blank(b)) {
                None => true,
                Some(i) => line[i] == b';' && line[i + 1..].iter().all(|&b| blank(b)),
            },
        };
        if dropped {
            if run != write {
                text.copy_within(run..start, write);
            }
            write += start - run;
            run = end + 1;
        }
        start = end + 1;
    }
    let ends_line = text[from..].last() == Some(&b'\n');
    if run < len {
        if run != write {
            text.copy_within(run..len, write);
        }
        write += len - run;
        text.truncate(write);
        if !ends_line {
            text.push(b'\n');
        }
    } else {
        text.truncate(write);
    }
}

/// Whether a line starting with `first` may be one [`drop_empty_lines`] takes out: a blank, a
/// `;`, or the newline of an empty line.
fn may_go(first: u8) -> bool {
    matches!(first, b' ' | b'\t' | b';' | b'\n')
}

/// Where the first line after the first newline of `text` that may go ([`may_go`]) starts.
/// One line in twenty may (most of them comments, which stay), a line is some 25 bytes: the
/// text is looked at 32 bytes at a time, each byte with the one after it, in a loop the
/// compiler turns into vector compares (a call to find each line's newline cost twice as much).
fn next_line_that_may_go(text: &[u8]) -> Option<usize> {
    const AT_ONCE: usize = 32;
    let mut i = 0;
    while i + AT_ONCE < text.len() {
        let here: &[u8; AT_ONCE] = text[i..i + AT_ONCE].try_into().expect("32 bytes");
        let next: &[u8; AT_ONCE] = text[i + 1..][..AT_ONCE].try_into().expect("32 bytes");
        // Every byte that lets a line go is below `<` (tab, newline, space, `;`; digits and
        // some signs too, looked at again below). No early exit and no `&&`, so that the loop
        // is vectorised.
        let mut any = false;
        for (&c, &first) in here.iter().zip(next) {
            any |= (c == b'\n') & (first < b'<');
        }
        if any {
            break;
        }
        i += AT_ONCE;
    }
    let rest = &text[i..];
    rest.iter().zip(&rest[1..]).position(|(&c, &first)| c == b'\n' && may_go(first)).map(|k| i + k + 1)
}

/// The last `want` bytes of the text of a binary G-code file, reading only the G-code blocks
/// at its end: the block headers are walked with seeks, then blocks are decoded from the last
/// one back until enough text is found.
pub fn tail<R: Read + Seek>(mut inner: R, want: usize) -> io::Result<Vec<u8>> {
    let mut reader = Reader::new(&mut inner)?;
    let suffix = text::suffix(&reader.preamble);
    // Walk: remember the last G-code blocks, skip each body. A block's text is at least its
    // decoded size (MeatPack only packs) less the empty lines dropped, so the blocks holding the
    // last `2 * want` decoded bytes give the tail; the ones before are forgotten as the walk
    // goes, which keeps memory constant per block (10 million empty blocks took 474 MB here).
    let mut blocks = std::collections::VecDeque::new();
    let mut last_bytes: u64 = 0;
    let crc_len: u64 = if reader.preamble.checksum { 4 } else { 0 };
    let mut next = reader.next.take();
    while let Some(at) = next {
        // An empty block has no text to give.
        if at.header.uncompressed > 0 {
            blocks.push_back(at);
            last_bytes += u64::from(at.header.uncompressed);
        }
        while let Some(first) = blocks.front() {
            let without = last_bytes - u64::from(first.header.uncompressed);
            if without < 2 * want as u64 {
                break;
            }
            last_bytes = without;
            blocks.pop_front();
        }
        let skip = at.header.kind.params_len() as u64 + u64::from(at.header.stored) + crc_len;
        reader.inner.seek(SeekFrom::Current(skip as i64))?;
        reader.offset += skip;
        next = reader.header()?;
    }
    let mut parts: Vec<Vec<u8>> = vec![suffix];
    let mut have = parts[0].len();
    for at in blocks.iter().rev() {
        if have >= want {
            break;
        }
        let header_len = at.header.to_bytes().len() as u64;
        reader.inner.seek(SeekFrom::Start(at.offset + header_len))?;
        reader.next = Some(*at);
        reader.suffix_done = true;
        reader.refill()?;
        have += reader.buf.len();
        parts.push(std::mem::take(&mut reader.buf));
    }
    let text: Vec<u8> = parts.into_iter().rev().flatten().collect();
    Ok(text[text.len().saturating_sub(want)..].to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_lines_go_as_libbgcode_drops_them() {
        let mut text = b"G1 X1\n\n  \t\n;\n ;  \n; kept\r\n\r\nG1 Y2".to_vec();
        drop_empty_lines(&mut text, 0);
        assert_eq!(text, b"G1 X1\n; kept\r\n\r\nG1 Y2\n");
        for (text, kept) in [(&b"\n\nG1\n"[..], &b"G1\n"[..]), (b"G1\n;\n", b"G1\n"), (b"", b""), (b" ", b"")]
        {
            let mut t = text.to_vec();
            drop_empty_lines(&mut t, 0);
            assert_eq!(t, kept);
        }
        // A block's text after another's: only its own lines are looked at, and its last line
        // gets a newline even when the text before ends with one.
        let mut text = b"G1 X1\n\n;\n".to_vec();
        text.extend_from_slice(b"\n;\nG1 Y2");
        drop_empty_lines(&mut text, 9);
        assert_eq!(text, b"G1 X1\n\n;\nG1 Y2\n");
        let mut text = b"G1 X1\n".to_vec();
        drop_empty_lines(&mut text, 6);
        assert_eq!(text, b"G1 X1\n");
    }

    /// Regression (B2): a heatshrink block whose header gave fewer bytes than its data decodes
    /// to was cut at the header's size without a word. Both compressions refuse a size the data
    /// does not decode to, either way, naming what it decodes to (heatshrink counts the rest of
    /// its tokens; deflate is read one byte past the size, no further).
    #[test]
    fn b2_a_size_the_data_does_not_decode_to_is_refused_both_ways() {
        use std::io::Write;
        let text = b"G1 X10.5 Y20 E0.4\n".repeat(50);
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&text).unwrap();
        let deflated = z.finish().unwrap();
        let mut packed = Vec::new();
        heatshrink::encode(&text, heatshrink::Params { window_bits: 12, lookahead_bits: 4 }, &mut packed);
        let n = text.len() as u32;
        let cases = [
            (
                Compression::Deflate,
                &deflated,
                0,
                "deflate data decodes to more than the 0 bytes its header says",
            ),
            (
                Compression::Deflate,
                &deflated,
                n - 1,
                "deflate data decodes to more than the 899 bytes its header says",
            ),
            (
                Compression::Deflate,
                &deflated,
                n + 1,
                "deflate data decodes to 900 bytes, not the 901 its header says",
            ),
            (
                Compression::Heatshrink12,
                &packed,
                0,
                "heatshrink data decodes to 900 bytes, not the 0 its header says",
            ),
            (
                Compression::Heatshrink12,
                &packed,
                n - 1,
                "heatshrink data decodes to 900 bytes, not the 899 its header says",
            ),
            (
                Compression::Heatshrink12,
                &packed,
                n + 1,
                "heatshrink data decodes to 900 bytes, not the 901 its header says",
            ),
        ];
        for (compression, data, uncompressed, message) in cases {
            let h = Header { kind: Kind::GCode, compression, uncompressed, stored: data.len() as u32 };
            let err = decompress(data, h, &mut Vec::new()).unwrap_err();
            assert_eq!(err.to_string(), message);
        }
        for (compression, data) in [(Compression::Deflate, &deflated), (Compression::Heatshrink12, &packed)] {
            let h = Header { kind: Kind::GCode, compression, uncompressed: n, stored: data.len() as u32 };
            let mut out = Vec::new();
            decompress(data, h, &mut out).unwrap();
            assert!(out == text);
        }
    }

    /// libbgcode's rule a line at a time: a line goes when, past its leading blanks, it is
    /// empty or a `;` followed by blanks only; every kept line ends with a newline.
    fn kept_lines(text: &[u8]) -> Vec<u8> {
        let blank = |b: &u8| *b == b' ' || *b == b'\t';
        let mut out = Vec::new();
        for line in text.split_inclusive(|&b| b == b'\n') {
            let body = line.strip_suffix(b"\n").unwrap_or(line);
            let rest: Vec<u8> = body.iter().copied().skip_while(|b| blank(b)).collect();
            let goes = rest.is_empty() || (rest[0] == b';' && rest[1..].iter().all(blank));
            if !goes {
                out.extend_from_slice(body);
                out.push(b'\n');
            }
        }
        out
    }

    /// Text mostly of letters and digits (long runs of lines no one looks at), with now and
    /// then the bytes that make a line go.
    fn lines() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        let byte = prop_oneof![
            20 => proptest::sample::select(b"G1X0.5".to_vec()),
            3 => Just(b'\n'),
            1 => proptest::sample::select(b" \t;\r".to_vec()),
        ];
        proptest::collection::vec(byte, 0..600)
    }

    proptest::proptest! {
        #[test]
        fn drops_the_lines_libbgcode_drops(held in lines(), text in lines()) {
            let mut all = [held.as_slice(), &text].concat();
            drop_empty_lines(&mut all, held.len());
            proptest::prop_assert_eq!(all, [held, kept_lines(&text)].concat());
        }
    }
}
