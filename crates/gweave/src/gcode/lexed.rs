//! Lines read and lexed on a thread of their own, ahead of the thread that follows the machine
//! state: the work of a line splits about in half between the two (reading the file and the
//! lexer on one side, the modal state and the pass on the other), so on two cores a pass that
//! reads (`stats`, `check`) takes about the time of the slower half instead of the sum.
//!
//! The reading thread cuts the input into [`Chunk`]s of whole lines ([`ChunkReader`]) and lexes
//! them in [`Batch`]es of at most [`BATCH`] lines; the other takes each batch's lines up again
//! from the same chunk ([`Chunk::lines_from`]) beside their blocks and lengths (so that it does
//! not search for each line's end again: about 40 instructions a line). At most [`DEPTH`] batches
//! wait between the two, and chunks and block buffers go back to the reading thread once used:
//! memory stays bounded whatever the file.

use std::io::{self, Read};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Arc;

use super::lexer::{parse_line, parse_line_lean};
use super::line::Block;
use super::reader::{Chunk, ChunkLines, ChunkReader, Part, RawLine};

/// Lines in a batch: the hand-over costs a few thousand instructions, a thousandth of a batch's
/// lexing, and the blocks of a batch (about 200 bytes each) stay within a few hundred KiB.
pub const BATCH: usize = 2048;
/// Batches lexed ahead of their use.
pub const DEPTH: usize = 4;

/// Lexed lines: the chunk they are in, where the first starts, and a block for each (in file
/// order; a line longer than [`MAX_LINE`](super::reader::MAX_LINE) has a cleared block).
pub struct Batch {
    chunk: Arc<Chunk>,
    at: usize,
    before: u64,
    blocks: Vec<Block>,
    /// Each line's length and ending ([`pack`]), [`LONG`] for a line longer than
    /// [`MAX_LINE`](super::reader::MAX_LINE) (which the taker reads as the chunk gives it).
    ends: Vec<u32>,
    len: usize,
    /// The chunk's last batch: the chunk can go back to the reading thread after it.
    last: bool,
}

/// A line's length and the length of its ending (0 to 2) in one word: a whole line is at most
/// [`MAX_LINE`](super::reader::MAX_LINE) (2^18) bytes long.
#[inline(always)]
fn pack(content: usize, eol: usize) -> u32 {
    ((content as u32) << 2) | eol as u32
}

/// What [`Batch::ends`] holds for a line that is not whole (longer than the reader holds).
const LONG: u32 = u32::MAX;

impl Batch {
    /// The batch's lines, as [`ChunkLines`] gives them, and their blocks.
    pub fn lines(&self) -> (BatchLines<'_>, &[Block]) {
        (BatchLines::of(&self.chunk, self.at, self.before, &self.ends[..self.len]), &self.blocks[..self.len])
    }

    /// [`Batch::lines`] with blocks the reader may take (they are cleared before reuse).
    pub fn lines_mut(&mut self) -> (BatchLines<'_>, &mut [Block]) {
        let lines = BatchLines::of(&self.chunk, self.at, self.before, &self.ends[..self.len]);
        (lines, &mut self.blocks[..self.len])
    }
}

/// A batch's lines, cut where the lexing thread found their ends.
pub struct BatchLines<'a> {
    lines: ChunkLines<'a>,
    ends: std::slice::Iter<'a, u32>,
}

impl<'a> BatchLines<'a> {
    fn of(chunk: &'a Chunk, at: usize, before: u64, ends: &'a [u32]) -> Self {
        BatchLines { lines: chunk.lines_from(at, before), ends: ends.iter() }
    }

    /// The next line, as [`ChunkLines::next_line`] gives it; `None` at the batch's end.
    #[inline(always)]
    pub fn next_line(&mut self) -> Option<RawLine<'a>> {
        match *self.ends.next()? {
            LONG => self.lines.next_line(),
            packed => Some(self.lines.next_known((packed >> 2) as usize, (packed & 3) as usize)),
        }
    }
}

/// The receiving end: batches in file order, then the end of the input or its first error.
pub struct Lexed {
    batches: Receiver<io::Result<Batch>>,
    spare_chunks: SyncSender<Vec<u8>>,
    spare_blocks: SyncSender<(Vec<Block>, Vec<u32>)>,
}

impl Lexed {
    /// The next batch; `None` at the end of the input.
    pub fn next_batch(&mut self) -> Option<io::Result<Batch>> {
        self.batches.recv().ok()
    }

    /// Hands a used batch's buffers back to the reading thread.
    pub fn recycle(&mut self, batch: Batch) {
        // Full channels or a finished reader: the buffer is dropped instead.
        let _ = self.spare_blocks.try_send((batch.blocks, batch.ends));
        if batch.last {
            if let Ok(chunk) = Arc::try_unwrap(batch.chunk) {
                let _ = self.spare_chunks.try_send(chunk.into_buffer());
            }
        }
    }
}

/// What the reading thread runs ([`Lexer::run`]).
pub struct Lexer<R> {
    input: R,
    list_words: bool,
    batches: SyncSender<io::Result<Batch>>,
    spare_chunks: Receiver<Vec<u8>>,
    spare_blocks: Receiver<(Vec<Block>, Vec<u32>)>,
}

/// A lexer of `input` and the receiver of its batches. `list_words`: plain moves with their
/// words listed ([`parse_line`]; otherwise [`parse_line_lean`]). Run [`Lexer::run`] on a thread
/// of its own: it returns at the end of the input, after its first error (passed on), or as
/// soon as the [`Lexed`] is dropped.
pub fn lexer<R: Read>(input: R, list_words: bool) -> (Lexer<R>, Lexed) {
    let (batches, receiver) = sync_channel(DEPTH);
    // Spares: more than can be in use at once, so that the reading thread rarely allocates.
    let (spare_chunks, chunks_back) = sync_channel(DEPTH + 2);
    let (spare_blocks, blocks_back) = sync_channel(DEPTH + 2);
    let lexer = Lexer { input, list_words, batches, spare_chunks: chunks_back, spare_blocks: blocks_back };
    (lexer, Lexed { batches: receiver, spare_chunks, spare_blocks })
}

impl<R: Read> Lexer<R> {
    /// Reads and lexes the whole input (see [`lexer`]).
    pub fn run(self) {
        if self.list_words {
            self.run_as::<true>();
        } else {
            self.run_as::<false>();
        }
    }

    fn run_as<const LIST_WORDS: bool>(self) {
        let mut chunks = ChunkReader::new(self.input);
        let mut before = 0u64;
        loop {
            let buffer = self.spare_chunks.try_recv().unwrap_or_default();
            let chunk = match chunks.next_chunk(buffer) {
                Ok(Some(chunk)) => Arc::new(chunk),
                Ok(None) => return,
                Err(e) => {
                    let _ = self.batches.send(Err(e));
                    return;
                }
            };
            let mut at = 0;
            loop {
                let (mut blocks, mut ends) = self.spare_blocks.try_recv().unwrap_or_default();
                let mut lines = chunk.lines_from(at, before);
                let mut len = 0;
                while len < BATCH {
                    let Some(line) = lines.next_line() else { break };
                    if blocks.len() == len {
                        blocks.push(Block::default());
                        ends.push(LONG);
                    }
                    let block = &mut blocks[len];
                    ends[len] = match line.part {
                        Part::Whole => pack(line.bytes.len(), line.eol.len()),
                        _ => LONG,
                    };
                    match line.part {
                        Part::Whole if LIST_WORDS => parse_line(&line, block),
                        Part::Whole => parse_line_lean(&line, block),
                        // Not lexed: the driver reports it by its length.
                        _ => block.clear(),
                    }
                    len += 1;
                }
                let batch = Batch { chunk: Arc::clone(&chunk), at, before, blocks, ends, len, last: false };
                (at, before) = (lines.position(), lines.number());
                if len < BATCH {
                    // The chunk's last batch takes this thread's hold on it, so that the driver
                    // can hand its buffer back.
                    drop(chunk);
                    if self.batches.send(Ok(Batch { last: true, ..batch })).is_err() {
                        return;
                    }
                    break;
                }
                if self.batches.send(Ok(batch)).is_err() {
                    return;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::io::{self, Read, Write};
    use std::path::Path;

    use crate::gcode::reader::{Part, RawLine, MAX_LINE};
    use crate::gcode::state::{State, StateOptions};
    use crate::pass::{
        drive_reader, scan_ahead, Ctx, Flow, Pass, PassError, Progress, Reading, Step, Strictness,
    };

    /// Everything a pass is shown, line by line, and the progress reported last.
    #[derive(Default)]
    struct Record {
        seen: Vec<String>,
        stop_at: Option<u64>,
        reads_words: bool,
    }

    impl Pass for Record {
        fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
            let line = &ctx.line;
            self.seen.push(format!(
                "{} {} {:?} {:?} {:?} {:?} {:?}",
                line.number, line.offset, line.bytes, line.eol, ctx.block, ctx.effect, ctx.state.pos
            ));
            Ok(if self.stop_at == Some(line.number) { Flow::Stop } else { Flow::Continue })
        }

        fn long_line(&mut self, piece: &RawLine<'_>, _out: &mut dyn Write) -> Result<(), PassError> {
            if let Part::Last { len } = piece.part {
                self.seen.push(format!("long line {} of {len} bytes", piece.number));
            }
            Ok(())
        }

        fn finish(&mut self, state: &State, _out: &mut dyn Write) -> Result<(), PassError> {
            self.seen.push(format!("finish {state:?}"));
            Ok(())
        }

        fn reads_words(&self) -> bool {
            self.reads_words
        }
    }

    #[derive(Default)]
    struct LastAdvance(u64);
    impl Progress for LastAdvance {
        fn advance(&mut self, done_bytes: u64) {
            self.0 = done_bytes;
        }
    }

    /// What a pass is shown by each driver, as text (or the error's), and the last progress.
    fn both<R: Read + Send>(
        input: impl Fn() -> R,
        strictness: Strictness,
        template: impl Fn() -> Record,
    ) -> [(Result<Vec<String>, String>, u64); 2] {
        let path = Path::new("t.gcode");
        let options = StateOptions::default();
        let (mut one, mut two) = (template(), template());
        let (mut p1, mut p2) = (LastAdvance::default(), LastAdvance::default());
        let reading =
            Reading { options: options.clone(), strictness, progress: Some(&mut p1), ..Reading::new(path) };
        let r1 = drive_reader(input(), reading, &mut one, &mut io::sink());
        let r2 = scan_ahead(input(), path, options, strictness, &mut p2, &mut two);
        let shown = |r: crate::Result<State>, rec: Record| r.map(|_| rec.seen).map_err(|e| e.to_string());
        [(shown(r1, one), p1.0), (shown(r2, two), p2.0)]
    }

    /// Every line of the real fixtures, in batches and chunks, is shown to the pass as the
    /// one-thread driver shows it: bytes, offsets, blocks (words listed or not), effects, state.
    #[test]
    fn lexed_ahead_shows_a_pass_what_the_line_reader_does() {
        for file in [
            "prusaslicer/pr_bunny_3tool_rel.gcode",
            "prusaslicer/pr_sphere_rrf_fwretract.gcode",
            "prusaslicer/pr_box_mach3.gcode",
            "cura/cura_dual.gcode",
        ] {
            let text =
                std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(file))
                    .unwrap();
            for reads_words in [false, true] {
                let [one, two] =
                    both(|| &text[..], Strictness::Lenient, || Record { reads_words, ..Default::default() });
                assert!(one.0.as_ref().is_ok_and(|seen| seen.len() > 2 * super::BATCH), "{file}");
                assert!(one == two, "{file}, words listed: {reads_words}");
                assert_eq!(two.1, text.len() as u64, "{file}: the last progress is the whole file");
            }
        }
    }

    /// Awkward endings and a line longer than MAX_LINE: a lenient pass is shown its length at the
    /// same line number, a strict run is refused there; a malformed line refuses a strict run at
    /// the same line and column; a pass that stops ends the run at the same line.
    #[test]
    fn long_lines_errors_and_stops_are_where_the_line_reader_has_them() {
        let mut text = b"G1 X1 \t\r\n\n;\xff\xfe odd\r\nG1 X2\rG1 X3\n".to_vec();
        text.extend(std::iter::repeat_n(b'A', MAX_LINE + 10));
        text.extend_from_slice(b"\r\nG1 X4\nno newline at end");
        for strictness in [Strictness::Lenient, Strictness::Strict] {
            let [one, two] = both(|| &text[..], strictness, Record::default);
            assert!(one == two, "{strictness:?}: {one:?}");
        }
        let [one, _] = both(|| &text[..], Strictness::Lenient, Record::default);
        assert!(one.0.unwrap().contains(&format!("long line 6 of {} bytes", MAX_LINE + 10)));
        let malformed = b"G1 X1\nG1 X2\nG1 X1..2 Y3\nG1 X4\n";
        let [one, two] = both(|| &malformed[..], Strictness::Strict, Record::default);
        assert_eq!(one.0, Err("t.gcode:3:5: malformed number after 'X'".to_owned()));
        assert!(one == two);
        let many: Vec<u8> = (0..10_000).flat_map(|i| format!("G1 X{i}\n").into_bytes()).collect();
        let [one, two] =
            both(|| &many[..], Strictness::Strict, || Record { stop_at: Some(5000), ..Default::default() });
        assert_eq!(one.0.as_ref().map(Vec::len), Ok(5001));
        assert!(one == two);
    }

    /// A read that fails is the run's error, after the lines before it are read.
    #[test]
    fn a_failing_read_is_the_runs_error() {
        struct Failing;
        impl Read for Failing {
            fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
                Err(io::Error::new(io::ErrorKind::InvalidData, "block 3: checksum mismatch"))
            }
        }
        let text = b"G1 X1\nG1 X2\n";
        let [one, two] = both(|| (&text[..]).chain(Failing), Strictness::Lenient, Record::default);
        assert_eq!(one.0, Err("t.gcode: block 3: checksum mismatch".to_owned()));
        assert_eq!(one.0, two.0);
    }
}
