//! Writing binary G-code: text in, blocks out. The text is cut into G-code blocks of at most
//! [`BLOCK`] bytes at line ends, each compressed with heatshrink (window 12, lookahead 4: what
//! PrusaSlicer writes for Prusa's printers) and stored without MeatPack encoding, so every byte
//! of G-code comes back as written; every block gets its CRC32.
//!
//! The metadata of a binary input ([`Preamble`]) is carried over: its thumbnails as they were
//! stored, its metadata from the text the transform wrote. A transform's text of such an input
//! starts and ends with the metadata rendered as comments ([`super::text`]); they are found and
//! taken out of the G-code again, with the printer and print values the transform may have
//! updated (filament used, times). A text input gets the metadata PrusaSlicer would give it: the
//! producer (gweave), its PrusaSlicer settings block (`; prusaslicer_config = begin` .. `end`,
//! taken out of the G-code) as the slicer metadata, and printer and print metadata from those
//! settings and the footer's figures ([`summary`]; the footer stays in the G-code too).
//!
//! The file's order puts the print metadata before the G-code, but the updated values are known
//! only at the end of the text, so the G-code blocks are spooled to an unnamed temporary file
//! (removed by the system whatever happens) and copied after the metadata at the end. Memory:
//! one block and the metadata rendering held back at the end.

use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};

use super::super::heatshrink;
use super::{file_header, summary, text, Block, Compression, Header, Kind, Metadata, Preamble};

/// The largest G-code block written (libbgcode's own limit, 65535 bytes).
pub(crate) const BLOCK: usize = 65535;
/// The end of a text input held back for its settings block (PrusaSlicer's is 10 to 100 KB).
const SETTINGS_HOLD: usize = 1 << 20;
/// Lines a transform may put before the rendered metadata are searched this far.
const HEAD_SLACK: usize = 64 * 1024;

/// Text written as binary G-code into `out`, on [`Writer::finish`].
pub struct Writer<W: Write> {
    out: W,
    carried: Option<Preamble>,
    /// Text not yet cut into blocks.
    pending: Vec<u8>,
    /// Bytes the start must gather before the rendered metadata is looked for; 0 once done.
    head_window: usize,
    /// Bytes held back at the end, where the rendered print metadata and settings may be.
    hold: usize,
    printer: Option<Metadata>,
    spool: BufWriter<File>,
    packed: Vec<u8>,
}

impl<W: Write> Writer<W> {
    /// A writer into `out`, carrying over the metadata of a binary input if given.
    pub fn new(out: W, carried: Option<Preamble>) -> io::Result<Writer<W>> {
        let (head_window, hold) = match &carried {
            Some(p) => (text::prefix(p).len() + HEAD_SLACK, text::suffix(p).len()),
            None => (0, SETTINGS_HOLD),
        };
        Ok(Writer {
            out,
            carried,
            pending: Vec::with_capacity(BLOCK + hold + (1 << 16)),
            head_window,
            hold,
            printer: None,
            spool: BufWriter::with_capacity(1 << 16, tempfile::tempfile()?),
            packed: Vec::with_capacity(BLOCK),
        })
    }

    /// The writer it writes into.
    pub fn get_ref(&self) -> &W {
        &self.out
    }

    /// Takes the rendered metadata out of the start of the text, once enough is gathered.
    fn head(&mut self) {
        self.head_window = 0;
        if let Some((printer, range)) =
            self.carried.as_ref().and_then(|p| text::find_prefix(&self.pending, p))
        {
            self.pending.drain(range);
            self.printer = Some(printer);
        }
    }

    /// Writes out whole blocks, keeping `hold` bytes back (all of it when `last`).
    fn cut(&mut self, last: bool) -> io::Result<()> {
        let keep = if last { 0 } else { self.hold };
        while self.pending.len() > keep && (last || self.pending.len() > BLOCK + keep) {
            let avail = self.pending.len() - keep;
            let window = &self.pending[..avail.min(BLOCK)];
            // At a line end, so that no line is split between blocks; a line longer than a block
            // is (libbgcode's converter would end each piece with a newline).
            let end = match memchr::memrchr(b'\n', window) {
                Some(i) => i + 1,
                None => window.len(),
            };
            self.packed.clear();
            heatshrink::encode(
                &self.pending[..end],
                heatshrink::Params { window_bits: 12, lookahead_bits: 4 },
                &mut self.packed,
            );
            let header = Header {
                kind: Kind::GCode,
                compression: Compression::Heatshrink12,
                uncompressed: end as u32,
                stored: self.packed.len() as u32,
            };
            let mut hasher = crc32fast::Hasher::new();
            let head = header.to_bytes();
            hasher.update(&head);
            hasher.update(&[0, 0]);
            hasher.update(&self.packed);
            self.spool.write_all(&head)?;
            self.spool.write_all(&[0, 0])?;
            self.spool.write_all(&self.packed)?;
            self.spool.write_all(&hasher.finalize().to_le_bytes())?;
            self.pending.drain(..end);
        }
        Ok(())
    }

    /// Writes the file: header, metadata, thumbnails, then the spooled G-code blocks. Returns
    /// the writer it wrote into.
    pub fn finish(mut self) -> io::Result<W> {
        if self.head_window > 0 {
            self.head();
        }
        let mut p = match self.carried.take() {
            Some(p) => p,
            None => {
                let settings = text::take_settings(&mut self.pending);
                let (printer, print) = summary::of_text(&settings, &self.pending);
                Preamble {
                    checksum: true,
                    file: Some(Metadata {
                        json: false,
                        items: vec![("Producer".into(), format!("gweave {}", env!("CARGO_PKG_VERSION")))],
                    }),
                    printer,
                    print,
                    slicer: vec![settings],
                    ..Preamble::default()
                }
            }
        };
        if let Some((print, start)) = text::find_suffix(&self.pending, &p) {
            self.pending.truncate(start);
            p.print = print;
        }
        if let Some(printer) = self.printer.take() {
            p.printer = printer;
        }
        self.cut(true)?;
        let mut spool = self.spool.into_inner().map_err(io::IntoInnerError::into_error)?;
        let out = &mut self.out;
        out.write_all(&file_header(true))?;
        let mut blocks: Vec<Block> = Vec::new();
        if let Some(file) = &p.file {
            blocks.push(file.to_block(Kind::FileMetadata));
        }
        blocks.push(p.printer.to_block(Kind::PrinterMetadata));
        blocks.extend(p.thumbnails.iter().map(|t| t.block.clone()));
        blocks.push(p.print.to_block(Kind::PrintMetadata));
        blocks.extend(p.slicer.iter().map(|m| m.to_block(Kind::SlicerMetadata)));
        for b in &blocks {
            out.write_all(&b.to_bytes(true))?;
        }
        spool.seek(SeekFrom::Start(0))?;
        io::copy(&mut spool, out)?;
        Ok(self.out)
    }
}

impl<W: Write> Write for Writer<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.pending.extend_from_slice(buf);
        if self.head_window > 0 {
            if self.pending.len() < self.head_window {
                return Ok(buf.len());
            }
            self.head();
        }
        self.cut(false)?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::read::Reader;
    use super::*;
    use std::io::Read;

    fn read_back(bytes: &[u8]) -> (Vec<u8>, Preamble) {
        let mut r = Reader::new(bytes).unwrap();
        let mut text = Vec::new();
        r.read_to_end(&mut text).unwrap();
        (text, r.preamble().clone())
    }

    /// Text to binary and back: the G-code comes back byte for byte (but empty lines, which
    /// binary G-code does not keep), across many blocks, after gweave's minimal metadata.
    #[test]
    fn text_round_trips_through_blocks() {
        let gcode: Vec<u8> =
            (0..20_000).flat_map(|i| format!("G1 X{i}.5 Y{} E0.01 ; c\n\n", i % 97).into_bytes()).collect();
        let mut w = Writer::new(Vec::new(), None).unwrap();
        for chunk in gcode.chunks(7777) {
            w.write_all(chunk).unwrap();
        }
        let bytes = w.finish().unwrap();
        assert_eq!(&bytes[..4], b"GCDE");
        let (text, p) = read_back(&bytes);
        let expected = [
            format!("; generated by gweave {}\n\n\n\n", env!("CARGO_PKG_VERSION")).into_bytes(),
            gcode
                .split(|&b| b == b'\n')
                .filter(|l| !l.is_empty())
                .flat_map(|l| [l, b"\n"].concat())
                .collect(),
            b"\n\n; prusaslicer_config = begin\n; prusaslicer_config = end\n\n".to_vec(),
        ]
        .concat();
        assert!(text == expected, "{}", String::from_utf8_lossy(&text[..200]));
        // And again: the binary input's metadata is carried, not rendered into the G-code twice.
        let mut w = Writer::new(Vec::new(), Some(p.clone())).unwrap();
        w.write_all(&text).unwrap();
        let again = w.finish().unwrap();
        assert_eq!(read_back(&again), (text, p));
    }
}
