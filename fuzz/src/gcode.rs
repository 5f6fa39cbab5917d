//! The G-code target: any bytes, read as a file. Every line goes through the line reader, the
//! lexer and the machine state, as `gweave cat --lenient` runs them, and the copy written back
//! must be the input, byte for byte. Nothing may panic, whatever the bytes.

use std::io::{self, Read, Write};
use std::path::Path;

use gweave::gcode::flavour::flavour_in;
use gweave::gcode::reader::{ChunkReader, LineReader, RawLine};
use gweave::gcode::state::StateOptions;
use gweave::pass::{drive_reader, keep, Ctx, Identity, Pass, Quiet, Strictness};

/// Runs `bytes` through the reader, lexer and state three ways, and checks each copy.
pub fn check(bytes: &[u8]) {
    // The options the file's own flavour comment gives, as a run from a file reads them: the
    // fuzzer reaches the Klipper, RepRapFirmware and LinuxCNC rules by writing the comment.
    let options = StateOptions::default().for_flavour(flavour_in(bytes).as_deref());

    // `gweave cat`: plain moves lexed lean, the input read in one piece.
    let mut cat = Identity::default();
    assert_eq!(copy(bytes, &options, &mut cat), bytes, "cat changed the bytes");
    assert_eq!(cat.report.bytes, bytes.len() as u64, "cat counted another size");

    // Every word of every line listed, and the input handed over a few bytes at a time as a pipe
    // may, so that lines straddle the reader's refills.
    let trickle = Trickle { rest: bytes, step: 1 + bytes.len() % 7 };
    assert_eq!(copy(trickle, &options, &mut ListingCopy), bytes, "copy with words listed changed the bytes");

    // The estimator reads the same file in chunks: it must cut the same lines.
    assert_eq!(chunk_lines(bytes), reader_lines(bytes), "chunked and streamed lines differ");
}

/// What `pass` writes for `input`, read leniently (malformed lines are copied as written).
fn copy(input: impl Read, options: &StateOptions, pass: &mut impl Pass) -> Vec<u8> {
    let mut out = Vec::new();
    drive_reader(input, Path::new("fuzz"), options.clone(), Strictness::Lenient, &mut Quiet, pass, &mut out)
        .expect("reading from memory cannot fail");
    out
}

/// Copies every line, as [`Identity`] does, but asks for the words of plain moves too, so that the
/// lexer's full listing runs on them.
struct ListingCopy;

impl Pass for ListingCopy {
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> io::Result<()> {
        keep(ctx, out)
    }
}

/// Hands out its bytes `step` at a time.
struct Trickle<'a> {
    rest: &'a [u8],
    step: usize,
}

impl Read for Trickle<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.step.min(buf.len()).min(self.rest.len());
        buf[..n].copy_from_slice(&self.rest[..n]);
        self.rest = &self.rest[n..];
        Ok(n)
    }
}

/// A line as a reader hands it out: content, ending, number and offset.
type Line = (Vec<u8>, Vec<u8>, u64, u64);

fn owned(line: &RawLine<'_>) -> Line {
    (line.bytes.to_vec(), line.eol.to_vec(), line.number, line.offset)
}

fn reader_lines(bytes: &[u8]) -> Vec<Line> {
    let mut reader = LineReader::new(bytes);
    let mut lines = Vec::new();
    while let Some(line) = reader.next_line().expect("reading from memory cannot fail") {
        lines.push(owned(&line));
    }
    lines
}

fn chunk_lines(bytes: &[u8]) -> Vec<Line> {
    let mut reader = ChunkReader::new(bytes);
    let mut lines = Vec::new();
    while let Some(chunk) = reader.next_chunk(Vec::new()).expect("reading from memory cannot fail") {
        let mut chunk_lines = chunk.lines(lines.len() as u64);
        while let Some(line) = chunk_lines.next_line() {
            lines.push(owned(&line));
        }
    }
    lines
}
