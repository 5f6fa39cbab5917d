//! One streaming shape for every command: read a line, parse it, advance the machine state, and
//! hand the line with its state to a [`Pass`], which writes what should come out. A pass that
//! needs lookahead keeps its own bounded buffer of [`OwnedLine`]s and says how large it may grow.
//!
//! A pass answers each line with a [`Step`]: [`Flow::Continue`], [`Flow::Stop`] (it has seen
//! enough: the driver reads no further and calls [`Pass::finish`]), or a [`PassError`]. The
//! pass does not know the file: the driver names it, with the line (and the column, when the
//! pass gives one), in [`Error::Pass`]. The set-up of a run (input, output, strictness,
//! flavour) is the [`Run`](crate::run::Run) builder's.

use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::error::{Error, Result};
use crate::gcode::diag::{Finding, Severity};
use crate::gcode::lexed;
use crate::gcode::lexer::{parse_line, parse_line_lean};
use crate::gcode::line::Block;
use crate::gcode::reader::{LineReader, Part, RawLine};
use crate::gcode::state::{Effect, State, StateOptions};
use crate::malformed::{is_malformed, Malformed};

pub use crate::malformed::Strictness;

/// A line with everything known about it, after its effect on the state.
pub struct Ctx<'a> {
    /// The line as read, with its ending and number.
    pub line: RawLine<'a>,
    /// What the line says.
    pub block: &'a Block,
    /// What the line did to the machine.
    pub effect: &'a Effect,
    /// The machine state after the line.
    pub state: &'a State,
}

/// What the driver does after a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// Read the next line.
    Continue,
    /// Read no further: the pass has what it needs. [`Pass::finish`] is still called.
    Stop,
}

/// Why a pass could not go on.
#[derive(Debug, thiserror::Error)]
pub enum PassError {
    /// Writing the output failed (the driver names the output).
    #[error(transparent)]
    Write(#[from] io::Error),
    /// The pass cannot handle the line it was given (the driver names the file and the line).
    #[error("{source}")]
    Refused {
        /// 1-based column of the cause on the line, when the pass knows it.
        column: Option<u32>,
        /// The pass's own error.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

impl PassError {
    /// The pass refuses the line for `reason`, a typed error of its own: the caller gets it back
    /// from [`Error::Pass`] with `downcast_ref`.
    pub fn refuse(reason: impl std::error::Error + Send + Sync + 'static) -> Self {
        PassError::Refused { column: None, source: Box::new(reason) }
    }
}

/// What a pass answers for one line.
pub type Step = std::result::Result<Flow, PassError>;

/// Something that watches or rewrites a stream of lines. Every method has a default, so a
/// read-only pass implements only what it needs.
pub trait Pass {
    /// Sees one line; writes what should be output for it (by default, the line unchanged).
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        keep(ctx, out)
    }

    /// Sees a piece of a line longer than [`MAX_LINE`](crate::gcode::reader::MAX_LINE) ([`Part`]), in a lenient run (a
    /// strict one stops at such a line). The line is not parsed and leaves the state as it
    /// was. By default the piece is written unchanged, so that a copy keeps the line byte for
    /// byte without ever holding it whole.
    fn long_line(&mut self, piece: &RawLine<'_>, out: &mut dyn Write) -> Result<(), PassError> {
        out.write_all(piece.bytes)?;
        Ok(out.write_all(piece.eol)?)
    }

    /// Called after the last line (or after [`Flow::Stop`]).
    fn finish(&mut self, _state: &State, _out: &mut dyn Write) -> Result<(), PassError> {
        Ok(())
    }

    /// Whether the pass reads [`Block::words`] of plain moves (`G0`/`G1` with only X, Y, Z, E
    /// and F numbers). `false`: those lines come with their numbers in [`Block::plain`] and no
    /// words listed ([`parse_line_lean`]), which is faster; the machine state is the same.
    fn reads_words(&self) -> bool {
        true
    }
}

/// A pass behind a `&mut` is a pass (a runner wraps the caller's pass without taking it).
impl<P: Pass + ?Sized> Pass for &mut P {
    #[inline]
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        (**self).line(ctx, out)
    }

    fn long_line(&mut self, piece: &RawLine<'_>, out: &mut dyn Write) -> Result<(), PassError> {
        (**self).long_line(piece, out)
    }

    fn finish(&mut self, state: &State, out: &mut dyn Write) -> Result<(), PassError> {
        (**self).finish(state, out)
    }

    fn reads_words(&self) -> bool {
        (**self).reads_words()
    }
}

/// Writes a line exactly as it was read.
#[inline]
pub fn keep(ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
    out.write_all(ctx.line.bytes)?;
    out.write_all(ctx.line.eol)?;
    Ok(Flow::Continue)
}

/// A line copied out of the reader's buffer, for passes that hold lines back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct OwnedLine {
    /// The line, without its ending.
    pub bytes: Vec<u8>,
    /// The line's ending (`\n`, `\r\n` or none).
    pub eol: Vec<u8>,
    /// The line number, from 1.
    pub number: u64,
}

impl OwnedLine {
    /// A copy of `line`.
    pub(crate) fn from_raw(line: &RawLine<'_>) -> Self {
        OwnedLine { bytes: line.bytes.to_vec(), eol: line.eol.to_vec(), number: line.number }
    }
}

/// A pass that counts the malformed lines its inner pass sees (an error-level diagnostic, or a
/// line longer than [`MAX_LINE`](crate::gcode::reader::MAX_LINE)).
#[derive(Debug, Default)]
pub(crate) struct Counting<P> {
    /// The inner pass.
    pub pass: P,
    /// The malformed lines it saw.
    pub malformed: Malformed,
}

impl<P> Counting<P> {
    /// Counting for `pass`.
    pub(crate) fn new(pass: P) -> Self {
        Counting { pass, malformed: Malformed::default() }
    }
}

impl<P: Pass> Pass for Counting<P> {
    #[inline]
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        if is_malformed(ctx.block) {
            self.malformed.add(ctx.line.number);
        }
        self.pass.line(ctx, out)
    }

    fn long_line(&mut self, piece: &RawLine<'_>, out: &mut dyn Write) -> Result<(), PassError> {
        if let Part::Last { .. } = piece.part {
            self.malformed.add(piece.number);
        }
        self.pass.long_line(piece, out)
    }

    fn finish(&mut self, state: &State, out: &mut dyn Write) -> Result<(), PassError> {
        self.pass.finish(state, out)
    }

    fn reads_words(&self) -> bool {
        self.pass.reads_words()
    }
}

/// Reports progress in bytes; the CLI draws a bar with it.
pub trait Progress {
    /// The input is `bytes` long.
    fn set_len(&mut self, _bytes: u64) {}
    /// `done_bytes` of the input are read.
    fn advance(&mut self, _done_bytes: u64) {}
    /// Work after reading begins (a preview's drawing), `len` units long; from now on
    /// [`Progress::advance`] counts these units, not bytes.
    fn stage(&mut self, _name: &'static str, _len: u64) {}
}

/// No progress reporting.
pub struct Quiet;
impl Progress for Quiet {}

/// One input read through a pass: what names it in errors, how its lines are read, and who
/// hears of the progress. [`Reading::new`] is a strict reading with the default options, no
/// output and no progress; the fields are public to change what differs:
/// `Reading { strictness: Strictness::Lenient, ..Reading::new(path) }`.
pub(crate) struct Reading<'a> {
    /// The input's name in errors (`<path>:<line>:<column>: ...`).
    pub path: &'a Path,
    /// The name write errors show; `<path> (output)` without one.
    pub output: Option<&'a Path>,
    /// The machine state's options, fixed for the file (its firmware, ...).
    pub options: StateOptions,
    /// Whether a malformed line stops the reading or is counted and passed over.
    pub strictness: Strictness,
    /// Told how far the reading is; none: nobody.
    pub progress: Option<&'a mut dyn Progress>,
}

impl<'a> Reading<'a> {
    /// `path` read strictly, with the default state options, no output and no progress.
    pub(crate) fn new(path: &'a Path) -> Reading<'a> {
        Reading {
            path,
            output: None,
            options: StateOptions::default(),
            strictness: Strictness::Strict,
            progress: None,
        }
    }
}

/// The loop itself, over any reader (files, in-memory text in tests and Python). Generic over
/// the pass, so that a pass known at the call (`stats`) has its per-line code inlined into the
/// loop; `&mut dyn Pass` works as well. Outside this crate, [`crate::run::Run`] opens the file,
/// resolves its firmware and calls this.
pub(crate) fn drive_reader<P: Pass + ?Sized>(
    input: impl Read,
    reading: Reading<'_>,
    pass: &mut P,
    out: &mut dyn Write,
) -> Result<State> {
    let Reading { path, output, options, strictness, progress } = reading;
    let out_name = output.map_or_else(|| output_name(path), Path::to_path_buf);
    let mut quiet = Quiet;
    let progress = progress.unwrap_or(&mut quiet);
    let driver = Driver { path, out_name, strictness, progress, next_report: 0 };
    let state = State::new(options);
    if pass.reads_words() || state.reads_words() {
        driver.drive::<true, P>(LineReader::new(input), state, pass, out)
    } else {
        driver.drive::<false, P>(LineReader::new(input), state, pass, out)
    }
}

/// [`drive_reader`] for a pass that writes nothing, with the input read and lexed on a second
/// thread ([`crate::gcode::lexed`]): what `stats`, `check` and the previews read. The pass sees
/// the same lines, blocks and states, but for a line longer than
/// [`MAX_LINE`](crate::gcode::reader::MAX_LINE), which comes as one [`Part::Last`] without its
/// bytes (a pass that copies long lines has an output, and [`drive_reader`]).
pub(crate) fn scan_ahead<P: Pass + ?Sized>(
    input: impl Read + Send,
    path: &Path,
    options: StateOptions,
    strictness: Strictness,
    progress: &mut dyn Progress,
    pass: &mut P,
) -> Result<State> {
    let driver = Driver { path, out_name: output_name(path), strictness, progress, next_report: 0 };
    let state = State::new(options);
    let (lexer, lexed) = lexed::lexer(input, pass.reads_words() || state.reads_words());
    std::thread::scope(|scope| {
        scope.spawn(move || lexer.run());
        // The receiver is dropped when this returns, which ends the lexer early after an
        // error or a pass that stops.
        driver.drive_lexed(lexed, state, pass, &mut io::sink())
    })
}

/// What the loop reports to, and how it treats malformed lines.
struct Driver<'a> {
    path: &'a Path,
    /// The name write errors show.
    out_name: PathBuf,
    strictness: Strictness,
    progress: &'a mut dyn Progress,
    /// The offset at which progress is next reported.
    next_report: u64,
}

impl Driver<'_> {
    /// Every line through the state and the pass; `LIST_WORDS`: plain moves with their words
    /// listed ([`Pass::reads_words`]).
    fn drive<const LIST_WORDS: bool, P: Pass + ?Sized>(
        mut self,
        mut reader: LineReader<impl Read>,
        mut state: State,
        pass: &mut P,
        out: &mut dyn Write,
    ) -> Result<State> {
        let mut block = Block::default();
        while let Some(line) = reader.next_line().map_err(|e| Error::io(self.path, e))? {
            if line.part != Part::Whole {
                self.long_line(&line, pass, out)?;
                continue;
            }
            if LIST_WORDS {
                parse_line(&line, &mut block);
            } else {
                parse_line_lean(&line, &mut block);
            }
            if self.line(line, &block, &mut state, pass, out)? == Flow::Stop {
                break;
            }
        }
        self.finish(reader.position(), &state, pass, out)?;
        Ok(state)
    }

    /// [`Driver::drive`] over lines lexed on another thread.
    fn drive_lexed<P: Pass + ?Sized>(
        mut self,
        mut lexed: lexed::Lexed,
        mut state: State,
        pass: &mut P,
        out: &mut dyn Write,
    ) -> Result<State> {
        let mut position = 0;
        'batches: while let Some(batch) = lexed.next_batch() {
            let batch = batch.map_err(|e| Error::io(self.path, e))?;
            let (mut lines, blocks) = batch.lines();
            for block in blocks {
                // The batch holds a block for each of its lines: never `None`.
                let Some(line) = lines.next_line() else { break };
                position = line.offset + (line.bytes.len() + line.eol.len()) as u64;
                if let Part::Last { len } = line.part {
                    position += len;
                    self.long_line(&line, pass, out)?;
                    continue;
                }
                if self.line(line, block, &mut state, pass, out)? == Flow::Stop {
                    break 'batches;
                }
            }
            lexed.recycle(batch);
        }
        self.finish(position, &state, pass, out)?;
        Ok(state)
    }

    /// A pass's error, named: its output for a write, the input's line for a refusal.
    fn named(&self, e: PassError, line: Option<u64>) -> Error {
        match e {
            PassError::Write(e) => Error::io(&self.out_name, e),
            PassError::Refused { column, source } => {
                Error::Pass { path: self.path.to_path_buf(), line, column, source }
            }
        }
    }

    /// A line longer than [`MAX_LINE`](crate::gcode::reader::MAX_LINE), or a piece of one: a
    /// lenient run hands it to the pass, a strict one refuses it with its length.
    fn long_line<P: Pass + ?Sized>(
        &self,
        line: &RawLine<'_>,
        pass: &mut P,
        out: &mut dyn Write,
    ) -> Result<()> {
        match (self.strictness, line.part) {
            (Strictness::Lenient, _) => {
                pass.long_line(line, out).map_err(|e| self.named(e, Some(line.number)))
            }
            (Strictness::Strict, Part::Last { len }) => Err(Error::Syntax {
                path: self.path.to_path_buf(),
                line: line.number,
                column: 1,
                finding: Finding::LineTooLong { len },
            }),
            // Read through, to give the line's length.
            (Strictness::Strict, _) => Ok(()),
        }
    }

    /// One whole line, lexed into `block`, through the state and the pass.
    #[inline(always)]
    fn line<P: Pass + ?Sized>(
        &mut self,
        line: RawLine<'_>,
        block: &Block,
        state: &mut State,
        pass: &mut P,
        out: &mut dyn Write,
    ) -> Result<Flow> {
        if self.strictness == Strictness::Strict {
            if let Some(d) = block.diagnostics.iter().find(|d| d.finding.severity() == Severity::Error) {
                return Err(Error::Syntax {
                    path: self.path.to_path_buf(),
                    line: line.number,
                    column: d.column,
                    finding: d.finding.clone(),
                });
            }
        }
        state.apply(line.bytes, block);
        let (offset, number) = (line.offset, line.number);
        let flow = pass
            .line(&Ctx { line, block, effect: &state.effect, state }, out)
            .map_err(|e| self.named(e, Some(number)))?;
        if offset >= self.next_report {
            self.progress.advance(offset);
            self.next_report = offset + (4 << 20);
        }
        Ok(flow)
    }

    /// The end of the input (or of the pass), `position` bytes read.
    fn finish<P: Pass + ?Sized>(
        &mut self,
        position: u64,
        state: &State,
        pass: &mut P,
        out: &mut dyn Write,
    ) -> Result<()> {
        // What the pass refuses at the end belongs to no line of its own.
        pass.finish(state, out).map_err(|e| self.named(e, None))?;
        self.progress.advance(position);
        Ok(())
    }
}

fn output_name(input: &Path) -> PathBuf {
    let mut p = input.as_os_str().to_owned();
    p.push(" (output)");
    PathBuf::from(p)
}

/// The identity pass: what `gweave cat` runs. It copies every line as read and counts them.
#[derive(Debug, Default)]
pub struct Identity {
    /// What was copied.
    pub report: CopyReport,
}

/// What [`Identity`] copied.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct CopyReport {
    /// Lines copied.
    pub lines: u64,
    /// Bytes copied, line endings included (the size of the input).
    pub bytes: u64,
    /// Lines with an error (a malformed word, a bad checksum, a line longer than
    /// [`MAX_LINE`](crate::gcode::reader::MAX_LINE)...), copied as written. Only a
    /// [`Strictness::Lenient`] run gets past one; a strict run stops at the first.
    #[serde(flatten)]
    pub malformed: Malformed,
}

impl Pass for Identity {
    fn reads_words(&self) -> bool {
        false
    }

    // Inlined into the loop: without the hint the compiler stopped inlining it once the loop
    // grew the long-line branch (+54 instructions a line for `cat`).
    #[inline(always)]
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        let r = &mut self.report;
        r.lines += 1;
        r.bytes += (ctx.line.bytes.len() + ctx.line.eol.len()) as u64;
        if is_malformed(ctx.block) {
            r.malformed.add(ctx.line.number);
        }
        keep(ctx, out)
    }

    fn long_line(&mut self, piece: &RawLine<'_>, out: &mut dyn Write) -> Result<(), PassError> {
        let r = &mut self.report;
        r.bytes += (piece.bytes.len() + piece.eol.len()) as u64;
        if let Part::Last { .. } = piece.part {
            r.lines += 1;
            r.malformed.add(piece.number);
        }
        out.write_all(piece.bytes)?;
        Ok(out.write_all(piece.eol)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn identity(input: &[u8]) -> (Vec<u8>, CopyReport) {
        try_identity(input).unwrap()
    }

    fn try_identity(input: &[u8]) -> Result<(Vec<u8>, CopyReport)> {
        let (mut out, mut pass) = (Vec::new(), Identity::default());
        let reading = Reading { strictness: Strictness::Lenient, ..Reading::new(Path::new("t")) };
        drive_reader(input, reading, &mut pass, &mut out)?;
        Ok((out, pass.report))
    }

    #[test]
    fn identity_is_byte_exact_on_awkward_input() {
        let input = b"G1 X1 \t\r\n\n;\xff\xfe odd\r\nG1X1..2\n  \nno newline at end";
        let (out, report) = identity(input);
        assert_eq!(out, input);
        let expected = CopyReport {
            lines: 6,
            bytes: input.len() as u64,
            malformed: Malformed { malformed_lines: 1, first_malformed_line: Some(4) },
        };
        assert_eq!(report, expected);
    }

    #[test]
    fn strict_runs_name_line_and_column() {
        let mut out = Vec::new();
        let reading = Reading::new(Path::new("part.gcode"));
        let err =
            drive_reader(&b"G1 X1\nG1 Y2..3\n"[..], reading, &mut Identity::default(), &mut out).unwrap_err();
        assert_eq!(err.to_string(), "part.gcode:2:5: malformed number after 'Y'");
    }

    #[test]
    fn a_line_longer_than_the_limit_stops_a_strict_run_with_its_length() {
        let mut input = b"G1 X1\n".to_vec();
        input.extend(std::iter::repeat_n(0u8, 3 << 20));
        input.extend_from_slice(b"\rG1 X2\n");
        let reading = Reading::new(Path::new("zeros.gcode"));
        let err = drive_reader(&input[..], reading, &mut Identity::default(), &mut io::sink()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "zeros.gcode:2:1: line of 3145728 bytes is longer than the limit of 262144 (not read)"
        );
    }

    #[test]
    fn a_line_longer_than_the_limit_is_copied_through_by_a_lenient_copy() {
        let mut input = b"G1 X1\r".to_vec();
        input.extend(std::iter::repeat_n(b"G1 X1 Y1 E1 ", 300_000).flatten());
        input.extend_from_slice(b"\r\nM104 S0");
        let (out, report) = identity(&input);
        assert!(out == input);
        let expected = CopyReport {
            lines: 3,
            bytes: input.len() as u64,
            malformed: Malformed { malformed_lines: 1, first_malformed_line: Some(2) },
        };
        assert_eq!(report, expected);
    }

    /// Records what every line did, reading plain moves' words or not.
    struct Effects {
        reads_words: bool,
        seen: Vec<(Effect, Option<u32>, bool)>,
    }

    impl Pass for Effects {
        fn reads_words(&self) -> bool {
            self.reads_words
        }

        fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn Write) -> Step {
            let unlisted = ctx.block.plain.present != 0 && ctx.block.words.is_empty();
            self.seen.push((*ctx.effect, ctx.state.structure.layer, unlisted));
            Ok(Flow::Continue)
        }
    }

    /// A pass that does not read plain moves' words sees the same effects, line by line, on
    /// real files of every slicer; the words are missing from exactly the plain moves.
    #[test]
    fn leaving_plain_words_unlisted_changes_no_effect() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
        for file in
            ["prusaslicer/pr_bunny_3tool_rel.gcode", "cura/cura_dual.gcode", "slic3r/slic3r_cone_2tool.gcode"]
        {
            let text = std::fs::read(dir.join(file)).unwrap();
            let run = |reads_words: bool| {
                let mut pass = Effects { reads_words, seen: Vec::new() };
                let reading = Reading { strictness: Strictness::Lenient, ..Reading::new(Path::new(file)) };
                drive_reader(&text[..], reading, &mut pass, &mut io::sink()).unwrap();
                pass.seen
            };
            let (listed, lean) = (run(true), run(false));
            assert!(listed.len() > 1000, "{file}");
            assert!(listed.iter().all(|s| !s.2), "{file}: a plain move's words were not listed");
            let plain_moves = lean.iter().filter(|s| s.2).count();
            assert!(plain_moves > listed.len() / 2, "{file}: {plain_moves} plain moves");
            let strip =
                |v: Vec<(Effect, Option<u32>, bool)>| v.into_iter().map(|s| (s.0, s.1)).collect::<Vec<_>>();
            assert!(strip(listed) == strip(lean), "{file}");
        }
    }

    proptest::proptest! {
        #[test]
        /// Any bytes come out as they went in, except UTF-16 text, refused by name
        /// (`gcode::encoding`): random bytes start with a byte order mark (FF FE) one time in
        /// 65 536, which failed this property now and then.
        fn identity_round_trips_any_bytes(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..2000)) {
            let head = &bytes[..bytes.len().min(crate::gcode::encoding::ENCODING_HEAD)];
            if crate::gcode::encoding::refuse_utf16(head).is_err() {
                proptest::prop_assert!(try_identity(&bytes).is_err());
            } else {
                let (out, report) = identity(&bytes);
                proptest::prop_assert_eq!(report.bytes, bytes.len() as u64);
                proptest::prop_assert_eq!(out, bytes);
            }
        }

        #[test]
        fn identity_refuses_utf16_after_a_byte_order_mark(rest in proptest::collection::vec(proptest::num::u8::ANY, 0..200), big: bool) {
            let mut bytes = if big { vec![0xfe, 0xff] } else { vec![0xff, 0xfe] };
            bytes.extend(rest);
            proptest::prop_assert!(try_identity(&bytes).is_err());
        }

        #[test]
        fn identity_round_trips_gcode_like_text(lines in proptest::collection::vec("[GMTXYZEFN;() *.0-9a-z\"{}\t\r-]{0,40}", 0..50), crlf: bool) {
            let text = lines.join(if crlf { "\r\n" } else { "\n" });
            proptest::prop_assert_eq!(identity(text.as_bytes()).0, text.as_bytes());
        }
    }
}
