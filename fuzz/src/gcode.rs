//! The G-code target: any bytes, read as a file. Every line goes through the line reader, the
//! lexer and the machine state, as `gweave cat --lenient` runs them, and the copy written back
//! must be the input, byte for byte. Nothing may panic, whatever the bytes.

use std::io::{self, Read, Write};

use gweave::gcode::flavour::flavour_in;
use gweave::gcode::reader::{ChunkReader, LineReader, RawLine};
use gweave::gcode::state::StateOptions;
use gweave::test_support::read_lenient;
use gweave::{keep, Ctx, Identity, Pass, Step};

/// Runs `bytes` through the reader, lexer and state three ways, and checks each copy. An input
/// may be refused (an encoding the reader does not read), but then the same way however it is
/// read.
pub fn check(bytes: &[u8]) {
    // The options the file's own flavour comment gives, as a run from a file reads them: the
    // fuzzer reaches the Klipper, RepRapFirmware and LinuxCNC rules by writing the comment.
    let options = StateOptions::default().resolved(None, flavour_in(bytes).as_deref());

    // `gweave cat`: plain moves lexed lean, the input read in one piece.
    let mut cat = Identity::default();
    let whole = copy(bytes, &options, &mut cat);
    // Every word of every line listed, and the input handed over a few bytes at a time as a pipe
    // may, so that lines straddle the reader's refills.
    let trickle = Trickle { rest: bytes, step: 1 + bytes.len() % 7 };
    let listed = copy(trickle, &options, &mut ListingCopy);
    match (whole, listed) {
        (Some(whole), Some(listed)) => {
            assert_eq!(whole, bytes, "cat changed the bytes");
            assert_eq!(listed, bytes, "copy with words listed changed the bytes");
            assert_eq!(cat.report.bytes, bytes.len() as u64, "cat counted another size");
        }
        (None, None) => {}
        (whole, _) => {
            let refused_when = if whole.is_some() { "a few bytes at a time" } else { "in one piece" };
            panic!("refused only when read {refused_when}")
        }
    }

    // The estimator reads the same file in chunks: it must cut the same lines.
    assert_eq!(chunk_lines(bytes), reader_lines(bytes), "chunked and streamed lines differ");
}

/// What `pass` writes for `input`, read leniently (malformed lines are copied as written);
/// `None` if reading failed.
fn copy(input: impl Read, options: &StateOptions, pass: &mut impl Pass) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    read_lenient(input, options.clone(), pass, &mut out).ok().map(|_| out)
}

/// Copies every line, as [`Identity`] does, but asks for the words of plain moves too, so that the
/// lexer's full listing runs on them.
struct ListingCopy;

impl Pass for ListingCopy {
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
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

/// Adds `line` to `lines`. A line too long to be handed out whole may come in pieces that share
/// its number; they are joined, since the two readers need not cut it at the same places.
fn push(lines: &mut Vec<Line>, line: &RawLine<'_>) {
    match lines.last_mut() {
        Some((content, eol, number, _)) if *number == line.number => {
            content.extend_from_slice(line.bytes);
            *eol = line.eol.to_vec();
        }
        _ => lines.push((line.bytes.to_vec(), line.eol.to_vec(), line.number, line.offset)),
    }
}

/// The lines [`LineReader`] cuts; `None` if it refuses the input.
fn reader_lines(bytes: &[u8]) -> Option<Vec<Line>> {
    let mut reader = LineReader::new(bytes);
    let mut lines = Vec::new();
    while let Some(line) = reader.next_line().ok()? {
        push(&mut lines, &line);
    }
    Some(lines)
}

/// The lines [`ChunkReader`] cuts; `None` if it refuses the input.
fn chunk_lines(bytes: &[u8]) -> Option<Vec<Line>> {
    let mut reader = ChunkReader::new(bytes);
    let mut lines = Vec::new();
    while let Some(chunk) = reader.next_chunk(Vec::new()).ok()? {
        let mut chunk_lines = chunk.lines(lines.last().map_or(0, |line: &Line| line.2));
        while let Some(line) = chunk_lines.next_line() {
            push(&mut lines, &line);
        }
    }
    Some(lines)
}
