//! The finishing copy: the written file to its target in large writes, with the few lines the
//! metadata rewrites found by a vector search.
//!
//! Of the lines of a sliced file, only progress lines and the slicer's figures change: one
//! `M73` per percent, a handful of footer lines. Every one of them holds an `M` or an `m`
//! ([`MetadataPass::rewritten`]), which plain moves (`G1 X.. Y.. E..`) never do. So the copy
//! looks at no line at all but those: `memchr2` finds the next `M` or `m` (32 bytes a step),
//! the line around it is cut from the line ends on either side, and the rule a line-by-line
//! copy applies decides whether it changes. The bytes between two changed lines go out in one
//! write. Which lines are lines is as every pass reads them ([`LineReader`]): a line ends at
//! `\n`, `\r\n` or a lone `\r`; one longer than [`MAX_LINE`] is never a whole line, so it is
//! copied as it is.
//!
//! Until the run's header is written (before the first line, or after Cura's Griffin header
//! block) the copy goes line by line, since where the header goes depends on lines with no `M`
//! in them (`;END_OF_HEADER`).
//!
//! [`LineReader`]: crate::gcode::reader::LineReader

use std::io::{self, Read, Write};
use std::path::Path;

use memchr::{memchr2, memrchr2};

use super::MetadataPass;
use crate::error::Error;
use crate::gcode::encoding::{refuse_utf16, ENCODING_HEAD};
use crate::gcode::reader::{find_line_end, MAX_LINE};

/// Bytes read at a time: what is written at once when no line in them changes. More than
/// [`MAX_LINE`], so a whole line always fits after the unfinished one moved to the front.
const CHUNK: usize = 1 << 20;

impl MetadataPass {
    /// Copies `input` (read from `path`) to `out` with the header and the metadata; errors
    /// name `path` for a read and `shown` (the output the user named) for a write. Lines are
    /// split as every pass splits them: the pieces of a line longer than [`MAX_LINE`] are
    /// copied as they are. Lines that cannot change are not looked at (the module's doc).
    pub fn copy(
        mut self,
        input: impl Read,
        path: &Path,
        shown: &Path,
        out: &mut dyn Write,
    ) -> crate::Result<()> {
        let mut chunks =
            Chunks { inner: input, buf: vec![0; CHUNK], start: 0, end: 0, eof: false, first: true };
        let written = |e| Error::io(shown, e);
        loop {
            if chunks.start == chunks.end && chunks.eof {
                break;
            }
            let data = &chunks.buf[chunks.start..chunks.end];
            let copied =
                if data.is_empty() { 0 } else { self.step(data, chunks.eof, out).map_err(written)? };
            if copied == 0 {
                chunks.refill().map_err(|e| Error::io(path, e))?;
            }
            chunks.start += copied;
        }
        // The input ended inside a long line, its last, copied in pieces without an ending.
        if std::mem::take(&mut self.long_line) {
            self.open_line = true;
        }
        self.finish(out).map_err(written)
    }

    /// Copies what it can of `data` (the input from where the copy stands, `eof`: all of what
    /// is left) and returns how many bytes: none when `data` ends inside a line that may
    /// still change and more is to be read.
    fn step(&mut self, data: &[u8], eof: bool, out: &mut dyn Write) -> io::Result<usize> {
        let Some((content, eol)) = line_end(data, eof) else {
            // The data ends inside a line, or on a `\r` that may be half of a `\r\n`.
            let content = data.len() - usize::from(data.last() == Some(&b'\r'));
            if self.long_line || content > MAX_LINE {
                out.write_all(&data[..content])?;
                self.long_line = true;
                return Ok(content);
            }
            return Ok(0);
        };
        let line = content + eol;
        if std::mem::take(&mut self.long_line) || content > MAX_LINE {
            // The end of a long line, or all of one: copied as it is. Without an ending, it is
            // the file's last line, which what follows must not run on in.
            out.write_all(&data[..line])?;
            self.open_line = eol == 0;
        } else if !self.header_written {
            self.line(&data[..content], &data[content..line], out)?;
        } else {
            // Every line whose end is in the data: all of it at the end of the input, else up
            // to the last `\n` or `\r`. A `\r` last may be half of a `\r\n`, whose `\n` then
            // opens the next data as an empty line: which lines hold what is the same.
            let lines = match memrchr2(b'\n', b'\r', data) {
                _ if eof => data.len(),
                at => at.map_or(line, |at| at + 1),
            };
            self.lines(&data[..lines], out)?;
            return Ok(lines);
        }
        Ok(line)
    }

    /// Copies `lines`, whole lines (the last one without an ending only at the end of the
    /// input), after the header: the lines that change are found by their `M` or `m` and
    /// written in place, what lies between them in one write each.
    fn lines(&mut self, lines: &[u8], out: &mut dyn Write) -> io::Result<()> {
        // `lines[..written]` is written; `from` is where a line starts, the search from there.
        let (mut written, mut from) = (0, 0);
        while let Some(found) = memchr2(b'M', b'm', &lines[from..]) {
            let at = from + found;
            // Most lines found are commands (`M104 S210`): the `M` opens the line, and the line
            // is short enough for the reader's inline search for its end.
            let start = match at.checked_sub(1).map(|before| lines[before]) {
                None | Some(b'\n' | b'\r') => at,
                Some(_) => memrchr2(b'\n', b'\r', &lines[from..at]).map_or(from, |i| from + i + 1),
            };
            let end = find_line_end(&lines[at..]).map_or(lines.len(), |i| at + i);
            let line = &lines[start..end];
            if line.len() <= MAX_LINE {
                if let Some(rewritten) = self.rewritten(line) {
                    out.write_all(&lines[written..start])?;
                    out.write_all(&rewritten)?;
                    written = end;
                }
            }
            from = end;
        }
        out.write_all(&lines[written..])?;
        // The file's last line, without an ending: what follows it must start a line.
        if lines.last().is_some_and(|b| !matches!(b, b'\n' | b'\r')) {
            self.open_line = true;
        }
        Ok(())
    }

    /// One whole line before the header is written, `bytes` without its line ending `eol`.
    fn line(&mut self, bytes: &[u8], eol: &[u8], out: &mut dyn Write) -> io::Result<()> {
        let cura_flavour_first = self.first_line && bytes.starts_with(b";FLAVOR:");
        if self.first_line {
            self.first_line = false;
            if !eol.is_empty() {
                self.eol = eol.to_vec();
            }
            // Ultimaker's printers read the Griffin header only at the very top, and Cura's
            // post-processing scripts expect its `;FLAVOR:` line to open the file (its first
            // piece): the header goes after them.
            if bytes != b";START_OF_HEADER" && !cura_flavour_first {
                self.write_header(out)?;
            }
        }
        let rewritten = self.rewritten(bytes);
        out.write_all(rewritten.as_deref().unwrap_or(bytes))?;
        out.write_all(eol)?;
        self.open_line = eol.is_empty();
        if !self.header_written && (bytes == b";END_OF_HEADER" || cura_flavour_first) {
            self.write_header(out)?;
        }
        Ok(())
    }

    fn finish(&mut self, out: &mut dyn Write) -> io::Result<()> {
        if self.first_line || !self.header_written {
            self.write_header(out)?;
        }
        if self.wrote_filament {
            return Ok(());
        }
        // A file without the slicer's figures (a generated one): PrusaSlicer's footer.
        self.end_open_line(out)?;
        super::write_footer(&self.figures, &self.eol, out)
    }
}

/// The end of the line at the start of `data`: its length and its ending's (0 for the input's
/// last line without one). `None`: the data runs out first, or on a `\r` that more input may
/// make a `\r\n`.
fn line_end(data: &[u8], eof: bool) -> Option<(usize, usize)> {
    let Some(at) = memchr2(b'\n', b'\r', data) else { return eof.then_some((data.len(), 0)) };
    match (data[at], data.get(at + 1)) {
        (b'\n', _) => Some((at, 1)),
        (_, Some(b'\n')) => Some((at, 2)),
        (_, Some(_)) => Some((at, 1)),
        (_, None) => eof.then_some((at, 1)),
    }
}

/// The input read in chunks: `buf[start..end]` is read and not yet copied.
struct Chunks<R> {
    inner: R,
    buf: Vec<u8>,
    start: usize,
    end: usize,
    eof: bool,
    /// No read yet: the first reads the encoding's head.
    first: bool,
}

impl<R: Read> Chunks<R> {
    /// Moves what is not yet copied (less than a line of [`MAX_LINE`]) to the front and reads
    /// more after it. The first read refuses UTF-16 text, as every pass does.
    fn refill(&mut self) -> io::Result<()> {
        self.buf.copy_within(self.start..self.end, 0);
        self.end -= self.start;
        self.start = 0;
        debug_assert!(self.end < self.buf.len(), "an unfinished line fills the buffer");
        loop {
            match self.inner.read(&mut self.buf[self.end..]) {
                Ok(0) => self.eof = true,
                Ok(n) => self.end += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            }
            if !self.first || self.eof || self.end >= ENCODING_HEAD {
                break;
            }
        }
        if std::mem::take(&mut self.first) {
            refuse_utf16(&self.buf[..self.end])?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::reader::{LineReader, Part};
    use crate::post::metadata::{header_line, Figures};

    /// The copy as it was, line by line through the [`LineReader`] every pass reads with: the
    /// oracle the vector search is held to.
    fn copied_line_by_line(mut pass: MetadataPass, input: &[u8]) -> Vec<u8> {
        let (mut reader, mut out) = (LineReader::new(input), Vec::new());
        while let Some(line) = reader.next_line().unwrap() {
            if line.part == Part::Whole {
                pass.line(line.bytes, line.eol, &mut out).unwrap();
            } else {
                out.extend_from_slice(&[line.bytes, line.eol].concat());
                // As the copy is held to since a long last line's footer ran on in it.
                if let Part::Last { .. } = line.part {
                    pass.open_line = line.eol.is_empty();
                }
            }
        }
        pass.finish(&mut out).unwrap();
        out
    }

    /// The copy, its input read `step` bytes at a time.
    fn copied(pass: MetadataPass, input: &[u8], step: usize) -> Vec<u8> {
        let mut out = Vec::new();
        let path = Path::new("t.gcode");
        pass.copy(Trickle(input, step), path, path, &mut out).unwrap();
        out
    }

    /// A reader that gives at most `.1` bytes a read.
    struct Trickle<'a>(&'a [u8], usize);

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let n = self.0.len().min(self.1).min(buf.len());
            buf[..n].copy_from_slice(&self.0[..n]);
            self.0 = &self.0[n..];
            Ok(n)
        }
    }

    /// Figures with three progress times: the lines after the third keep theirs.
    fn pass() -> MetadataPass {
        let figures = Figures {
            filament_mm: vec![1000.0, 250.5],
            diameter_mm: 1.75,
            density_g_cm3: vec![1.24],
            cost_per_kg: vec![20.0],
            time_s: [3723.0, 4000.0],
            first_layer_s: [61.0, 70.0],
            progress_s: vec![[0.0, 0.0], [1861.5, 2000.0], [3723.0, 4000.0]],
        };
        MetadataPass::new(figures, header_line("mix a.gcode"))
    }

    /// Pieces of lines: moves, every metadata key and what nearly is one (`M730`, `;TIMEX`,
    /// `M73` in a comment, a key after a space), Griffin's and Cura's header lines, spaces,
    /// separators and bytes that are not ASCII.
    const PIECES: &[&str] = &[
        "G1 X1.5 Y2 E0.1",
        "M73 P5 R3",
        "m73 q1 s2",
        "M730",
        "M73P9R2",
        "M",
        "m",
        "73",
        ";TIMEX",
        ";TIME:5",
        "; M73 P1",
        " ",
        "\t",
        "\x0c",
        ";",
        "=",
        ":",
        ";TIME_ELAPSED:3.5",
        ";Filament used: 1m",
        "; filament used [mm] = 1, 2",
        "; filament used = 3mm",
        ";PRINT.TIME:5",
        ";EXTRUDER_TRAIN.1.MATERIAL.VOLUME_USED:4",
        "; total filament cost = 3",
        "filament used [g]",
        "; estimated printing time (normal mode) = 1m",
        ";START_OF_HEADER",
        ";END_OF_HEADER",
        ";FLAVOR:Marlin",
        "caf\u{e9}",
        "\u{a0}",
        "\u{ff}",
    ];

    /// Lines of up to four pieces each, ended by `\n`, `\r\n` or `\r` (the last perhaps by
    /// nothing).
    fn file(lines: &[(Vec<usize>, u8)], last_eol: bool) -> Vec<u8> {
        let mut text = Vec::new();
        for (i, (pieces, eol)) in lines.iter().enumerate() {
            pieces.iter().for_each(|&p| text.extend_from_slice(PIECES[p % PIECES.len()].as_bytes()));
            if last_eol || i + 1 < lines.len() {
                text.extend_from_slice([&b"\n"[..], b"\r\n", b"\r"][usize::from(*eol) % 3]);
            }
        }
        text
    }

    proptest::proptest! {
        /// The copy writes what the line-by-line copy wrote, to the byte, for any lines read in
        /// any pieces: the header where it was, each progress line and figure rewritten as it
        /// was, every other byte kept, the footer after an unterminated last line.
        #[test]
        fn the_copy_writes_what_the_line_by_line_copy_wrote(
            lines in proptest::collection::vec((proptest::collection::vec(0usize..64, 0..4), 0..3u8), 0..40),
            last_eol in proptest::bool::ANY,
            step in 1usize..64,
        ) {
            let input = file(&lines, last_eol);
            proptest::prop_assume!(refuse_utf16(&input).is_ok());
            proptest::prop_assert_eq!(copied(pass(), &input, step), copied_line_by_line(pass(), &input));
        }

        /// No line without an `M` or an `m` is rewritten: the rule the copy's search rests on.
        #[test]
        fn every_rewritten_line_holds_an_m(pieces in proptest::collection::vec(0usize..64, 0..6)) {
            let line: Vec<u8> = file(&[(pieces, 0)], false).into_iter().filter(|b| !b"Mm".contains(b)).collect();
            proptest::prop_assert_eq!(pass().rewritten(&line), None);
        }
    }

    /// Lines longer than [`MAX_LINE`] are copied as they are, whatever they start with, at
    /// the start of the file, inside Cura's Griffin header, in the middle, and last without an
    /// ending; and lines of exactly [`MAX_LINE`] bytes are lines like any other.
    #[test]
    fn long_lines_are_copied_as_they_are_wherever_they_fall() {
        let (long, longest) = (
            format!("M73 P1 R1 ;{}", "x".repeat(MAX_LINE)),
            format!("M73 P2 R2 ;{}", "y".repeat(MAX_LINE - 11)),
        );
        let files = [
            format!("{long}\r\nM73 P0 R0\r\n;END_OF_HEADER\r\n"),
            format!(";START_OF_HEADER\n{long}\n;END_OF_HEADER\nM73 P0 R0\n"),
            format!("G1 X1\nM73 P0 R0\n{long}\r{longest}\rM73 P9 R9\r; filament used [mm] = 1\n"),
            format!("G1 X1\nM73 P0 R0\n{long}"),
            format!("G1 X1\nM73 P0 R0\n{longest}"),
            long.clone(),
        ];
        for (i, input) in files.iter().enumerate() {
            let want = copied_line_by_line(pass(), input.as_bytes());
            for step in [CHUNK, MAX_LINE - 1, 100_003, 65_536] {
                assert!(
                    copied(pass(), input.as_bytes(), step) == want,
                    "file {i}, read {step} bytes at a time"
                );
            }
        }
    }

    /// Regression: after a last line longer than [`MAX_LINE`] without a line ending, the footer
    /// ran on in it (`xxx; filament used [mm] = 0.00`), as did the header after a file of one
    /// such line: the line-by-line copy set the flag for whole lines only.
    #[test]
    fn what_follows_a_long_unterminated_last_line_starts_a_line() {
        let long = format!("M73 P1 R1 ;{}", "x".repeat(MAX_LINE));
        let header = header_line("mix a.gcode");
        let footer = "; filament used [mm] = 0.00\r\n; filament used [cm3] = 0.00\r\n; estimated printing time (normal mode) = 0s\r\n";
        let no_figures = || MetadataPass::new(Figures::default(), header.clone());
        for step in [CHUNK, 100_003] {
            let out = copied(no_figures(), format!("G1 X1\r\n{long}").as_bytes(), step);
            assert!(
                out == format!("{header}\r\nG1 X1\r\n{long}\r\n{footer}").into_bytes(),
                "read {step} at a time"
            );
            let out = copied(no_figures(), long.as_bytes(), step);
            assert!(out == format!("{long}\n{header}\n{}", footer.replace('\r', "")).into_bytes());
        }
    }

    /// The copy writes a line the search passes over in the same write as its neighbours: a
    /// file without a line to change goes out in one write a chunk.
    #[test]
    fn lines_that_do_not_change_go_out_in_large_writes() {
        struct Writes(Vec<usize>);
        impl Write for Writes {
            fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
                self.0.push(buf.len());
                Ok(buf.len())
            }
            fn flush(&mut self) -> io::Result<()> {
                Ok(())
            }
        }
        let input = "G1 X1.5 Y2 E0.1\n".repeat(100_000);
        let mut writes = Writes(Vec::new());
        pass().copy(input.as_bytes(), Path::new("t"), Path::new("t"), &mut writes).unwrap();
        // The header, the first line (line by line, with its end), then chunks, and the footer.
        let chunks: Vec<usize> = writes.0.iter().copied().filter(|&n| n > 1000).collect();
        assert_eq!(chunks.iter().sum::<usize>(), input.len() - 16);
        assert!(chunks.len() == 2 && chunks[0] == CHUNK - 16 && writes.0.len() < 20, "{:?}", writes.0);
    }
}
