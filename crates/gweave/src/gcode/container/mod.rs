//! How G-code is stored: plain text, gzip (`.gcode.gz`), or Prusa's binary G-code (`.bgcode`),
//! read from a file or from standard input (`-`). Every command opens its G-code input through
//! [`open`] and writes through [`Encoder`] (by way of `writer::Output`), so every command, the
//! CLI and Python read and write all of them alike.
//!
//! An input's container is told by its first bytes, not its name: gzip's `1f 8b`, binary
//! G-code's `GCDE`; anything else is text. An output's container is told by its name:
//! `*.gz` is written compressed, `*.bgcode` as binary G-code ([`Container::of_output`]).
//! Everything is streamed: gzip through flate2, binary G-code one block at a time, decoded on a
//! thread of its own (`ahead`).

pub(crate) mod ahead;
pub mod bgcode;
pub(crate) mod heatshrink;
pub(crate) mod meatpack;
pub(crate) mod spool;

use std::io::{self, BufReader, Read, Seek, SeekFrom, Write};
use std::path::Path;

use flate2::read::MultiGzDecoder;
use flate2::write::GzEncoder;

/// How a G-code text is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Container {
    /// Plain text.
    #[default]
    Text,
    /// Gzip-compressed text (`.gcode.gz`).
    Gzip,
    /// Prusa's binary G-code (`.bgcode`).
    Bgcode,
}

impl Container {
    /// The container of stored bytes that start with `head`.
    pub(crate) fn sniff(head: &[u8]) -> Container {
        if head.starts_with(&[0x1f, 0x8b]) {
            Container::Gzip
        } else if head.starts_with(bgcode::MAGIC) {
            Container::Bgcode
        } else {
            Container::Text
        }
    }

    /// The container an output named `path` is written in: `.gz` gzip, `.bgcode` binary.
    pub fn of_output(path: &Path) -> Container {
        match path.extension().map(|e| e.to_ascii_lowercase()) {
            Some(e) if e == "gz" => Container::Gzip,
            Some(e) if e == "bgcode" => Container::Bgcode,
            _ => Container::Text,
        }
    }
}

/// A G-code input opened for reading its text.
pub struct Input {
    /// The text's length when known without reading it (plain text), for progress.
    pub text_len: Option<u64>,
    reader: Box<dyn Read + Send + Sync>,
    /// The opening thread's run, checked before every read (a stopped run reads no more).
    stop: Option<crate::interrupt::Token>,
}

impl Read for Input {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if let Some(stop) = &self.stop {
            stop.check()?;
        }
        self.reader.read(buf)
    }
}

/// Opens `path` (`-` for standard input) as G-code text, whatever its container.
pub fn open(path: &Path) -> io::Result<Input> {
    let (mut raw, container) = sniffed(path)?;
    let (text_len, reader): (_, Box<dyn Read + Send + Sync>) = match container {
        Container::Text => (Some(raw.size()?), Box::new(raw)),
        Container::Gzip => (None, Box::new(Gunzip::new(raw))),
        Container::Bgcode => {
            raw.seek(SeekFrom::Start(0))?;
            let reader = bgcode::read::Reader::new(BufReader::with_capacity(1 << 16, raw))?;
            (None, Box::new(ahead::Ahead::new(reader)))
        }
    };
    Ok(Input { text_len, reader, stop: crate::interrupt::Token::current() })
}

/// A gzip file's text: its members one after the other (as `gzip -d` reads them), and bytes
/// after the last member that do not start another one are an error that says so (flate2 calls
/// them an "invalid gzip header", which sends the user looking at the start of the file).
struct Gunzip {
    inner: MultiGzDecoder<BufReader<spool::Raw>>,
    /// Text bytes given out so far: an error after some is not the file's own header.
    out: u64,
}

impl Gunzip {
    fn new(raw: spool::Raw) -> Gunzip {
        Gunzip { inner: MultiGzDecoder::new(BufReader::with_capacity(1 << 16, raw)), out: 0 }
    }
}

impl Read for Gunzip {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.inner.read(buf) {
            Ok(n) => {
                self.out += n as u64;
                Ok(n)
            }
            Err(e) if self.out > 0 && e.to_string().contains("invalid gzip header") => Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "trailing data after the gzip stream ({} bytes of text read): bytes that are not \
                     gzip follow its end; the file is damaged or had something appended",
                    self.out
                ),
            )),
            Err(e) => Err(e),
        }
    }
}

/// Opens the raw input and tells its container, positioned at the start.
fn sniffed(path: &Path) -> io::Result<(spool::Raw, Container)> {
    let mut raw = spool::open(path)?;
    let mut head = [0u8; 4];
    let mut n = 0;
    while n < head.len() {
        match raw.read(&mut head[n..])? {
            0 => break,
            k => n += k,
        }
    }
    raw.seek(SeekFrom::Start(0))?;
    Ok((raw, Container::sniff(&head[..n])))
}

/// The first `head` and the last `tail` bytes of the text of `path` (all of a shorter text in
/// `.0`, the tail then starting where the head ended), where slicers name the flavour and
/// write their settings. Plain text is read at both ends; binary G-code decodes only its last
/// blocks; gzip has to be decompressed through to its end.
pub fn ends(path: &Path, head: usize, tail: usize) -> io::Result<(Vec<u8>, Vec<u8>)> {
    let (mut raw, container) = sniffed(path)?;
    let mut first = Vec::with_capacity(head);
    match container {
        Container::Text => {
            let len = raw.size()?;
            (&mut raw).take(head as u64).read_to_end(&mut first)?;
            let start = len.saturating_sub(tail as u64).max(first.len() as u64);
            let mut last = Vec::new();
            if start < len {
                raw.seek(SeekFrom::Start(start))?;
                raw.take(tail as u64).read_to_end(&mut last)?;
            }
            Ok((first, last))
        }
        Container::Gzip => {
            let mut z = Gunzip::new(raw);
            (&mut z).take(head as u64).read_to_end(&mut first)?;
            // A ring of twice the tail, compacted when full.
            let mut last: Vec<u8> = Vec::with_capacity(2 * tail);
            let mut buf = vec![0u8; 1 << 16];
            loop {
                let n = z.read(&mut buf)?;
                if n == 0 {
                    break;
                }
                last.extend_from_slice(&buf[..n]);
                if last.len() > 2 * tail {
                    last.drain(..last.len() - tail);
                }
            }
            let keep = last.len().min(tail);
            Ok((first, last.split_off(last.len() - keep)))
        }
        Container::Bgcode => {
            let mut reader = bgcode::read::Reader::new(BufReader::new(&mut raw))?;
            (&mut reader).take(head as u64).read_to_end(&mut first)?;
            drop(reader);
            raw.seek(SeekFrom::Start(0))?;
            let last = bgcode::read::tail(BufReader::new(raw), tail)?;
            // A short text: its tail is already (partly) in the head.
            Ok((first, last))
        }
    }
}

/// The metadata and thumbnails of `path` if it is binary G-code, to carry into an output.
pub fn preamble(path: &Path) -> io::Result<Option<bgcode::Preamble>> {
    let (raw, container) = sniffed(path)?;
    if container != Container::Bgcode {
        return Ok(None);
    }
    Ok(Some(bgcode::read::Reader::new(BufReader::new(raw))?.preamble().clone()))
}

/// Text written into `W` in a container.
pub enum Encoder<W: Write> {
    /// Written as plain text.
    Text(W),
    /// Compressed with gzip.
    Gzip(GzEncoder<W>),
    /// Written as binary G-code blocks.
    Bgcode(Box<bgcode::write::Writer<W>>),
}

impl<W: Write> Encoder<W> {
    /// An encoder into `out`; a binary output carries `carried` (a binary input's metadata).
    pub fn new(container: Container, out: W, carried: Option<bgcode::Preamble>) -> io::Result<Encoder<W>> {
        Ok(match container {
            Container::Text => Encoder::Text(out),
            Container::Gzip => Encoder::Gzip(GzEncoder::new(out, flate2::Compression::default())),
            Container::Bgcode => Encoder::Bgcode(Box::new(bgcode::write::Writer::new(out, carried)?)),
        })
    }

    /// Ends the container (gzip's trailer, binary G-code's blocks); returns the writer.
    pub fn finish(self) -> io::Result<W> {
        match self {
            Encoder::Text(w) => Ok(w),
            Encoder::Gzip(z) => z.finish(),
            Encoder::Bgcode(b) => b.finish(),
        }
    }
}

impl<W: Write> Write for Encoder<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Encoder::Text(w) => w.write(buf),
            Encoder::Gzip(z) => z.write(buf),
            Encoder::Bgcode(b) => b.write(buf),
        }
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match self {
            Encoder::Text(w) => w.write_all(buf),
            Encoder::Gzip(z) => z.write_all(buf),
            Encoder::Bgcode(b) => b.write_all(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Encoder::Text(w) => w.flush(),
            Encoder::Gzip(z) => z.flush(),
            Encoder::Bgcode(b) => b.flush(),
        }
    }
}
