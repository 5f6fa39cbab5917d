//! Where a transform's output differs from its input, found while both stream.
//!
//! A transform copies most of its input byte for byte: `mix` and `purge-shift` change a few
//! lines at each tool change (a purge added, a retraction dropped, a change moved earlier) and
//! keep the thousands of moves between. [`LineDiff`] reads the input beside the output. While
//! they agree, the two readers' buffered bytes are compared at once, eight bytes at a time
//! ([`LineDiff::compare_ahead`]): each output line within the equal stretch is the input's next
//! line by its length alone, and the input's reader passes over it without looking for its end
//! ([`LineDiff::same_in_stretch`]). Where the stretch ends (a difference, or the end of what either
//! reader holds), the input is read one line at a time, and equal lines advance both. At the
//! first difference it
//! buffers lines of both files until they agree again on [`RESYNC_LINES`] lines in a row (a
//! hash of each buffered line finds the candidates; the lines are then compared byte for byte).
//! Several equal lines, not one, because slicers repeat lines (`G1 E-.8 F2100`, `G1 Z.4`) and
//! one of them would resync inside a changed block. The anchor the search picks does not change
//! what the changes add up to: the lines outside the changes are the same bytes in both files,
//! so any alignment describes the output exactly; a poor one only makes a change longer.
//!
//! Memory is bounded: each file's buffered lines are capped ([`LineDiff::new`]); a change
//! longer than that is [`DiffError::PastCap`], and the caller measures the output in full.

use std::collections::VecDeque;
use std::io::{self, Read};

use gweave::gcode::reader::{Part, RawLine};
use gweave::LineReader;

/// Equal lines in a row that end a change.
pub(super) const RESYNC_LINES: usize = 3;

/// What the comparison found for the output's next lines, in output order.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Op {
    /// The output's next line is the input's next line, byte for byte.
    Same,
    /// The output's next `added` lines stand where the input has the lines `removed` (either
    /// may be empty, not both).
    Changed { removed: Vec<Vec<u8>>, added: usize },
}

/// Why the comparison stopped.
#[derive(Debug, thiserror::Error)]
pub(super) enum DiffError {
    /// Reading the input failed.
    #[error(transparent)]
    Io(#[from] io::Error),
    /// A change ran past the cap of buffered lines.
    #[error("a change longer than {0} lines")]
    PastCap(usize),
}

/// The streaming comparison of an output (its lines given one by one to [`LineDiff::push`])
/// with the input it was made from (read as needed).
pub(super) struct LineDiff<R> {
    input: LineReader<R>,
    input_ended: bool,
    /// Input lines read and not yet matched, in order.
    ahead: VecDeque<Vec<u8>>,
    /// Output lines since the files differ, not yet matched.
    pending: Vec<Vec<u8>>,
    /// While the files differ: the hash of each line in `ahead` and in `pending` (a change is
    /// tens of lines: a scan of them costs less than a map).
    ahead_hashes: Vec<u64>,
    pending_hashes: Vec<u64>,
    /// Output lines matched again after a change, to compare from the input's matched lines on.
    replay: VecDeque<Vec<u8>>,
    /// The shortest change found so far (the input's and the output's lines before the
    /// anchor), taken once no shorter one can be found.
    best: Option<(usize, usize)>,
    output_ended: bool,
    /// Buffered lines of either file at most.
    cap: usize,
    /// Line buffers to reuse.
    spare: Vec<Vec<u8>>,
    /// Bytes at the front of the input's unread ones known to be the output's from its next
    /// line on ([`LineDiff::compare_ahead`]); 0 but while the files are in step.
    equal: usize,
}

impl<R: Read> LineDiff<R> {
    /// A comparison with the input `input`, holding at most `cap` lines of either file.
    pub(super) fn new(input: R, cap: usize) -> Self {
        LineDiff {
            input: LineReader::new(input),
            input_ended: false,
            ahead: VecDeque::new(),
            pending: Vec::new(),
            ahead_hashes: Vec::new(),
            pending_hashes: Vec::new(),
            replay: VecDeque::new(),
            best: None,
            output_ended: false,
            cap,
            spare: Vec::new(),
            equal: 0,
        }
    }

    /// The output's bytes read and not yet given as lines (`unread`: from its next line's
    /// start on). While the files are in step, they are compared with the input's at once
    /// (when the last stretch found is used up): [`LineDiff::same_in_stretch`] then matches
    /// each line within the equal stretch by its length.
    #[inline]
    pub(super) fn compare_ahead(&mut self, unread: &[u8]) {
        if self.equal == 0 && self.pending.is_empty() && self.ahead.is_empty() {
            self.equal = common_prefix(unread, self.input.unread());
        }
    }

    /// Whether the output's next line `line` is the input's next by the equal stretch
    /// ([`LineDiff::compare_ahead`]): its op is then [`Op::Same`], and the input's reader has
    /// passed over the line; else nothing is read, and the line goes to [`LineDiff::push`]. A
    /// whole line only, ended by `\n` or `\r\n`: after a lone `\r` the input's reader looks at
    /// the next byte (a `\n` would make it one `\r\n` ending), which the output's line does not
    /// say. (The op is not added to a list: copying it there cost more than the match.)
    #[inline]
    pub(super) fn same_in_stretch(&mut self, line: &RawLine<'_>) -> bool {
        let len = line.bytes.len() + line.eol.len();
        let same = len <= self.equal
            && line.part == Part::Whole
            && line.eol.last() == Some(&b'\n')
            && self.input.skip_line(len);
        if same {
            self.equal -= len;
        }
        same
    }

    /// The output's next line (without its line ending): appends to `ops` what is now known of
    /// the output's lines not yet given an [`Op`], possibly none (the files differ and have not
    /// agreed again yet).
    pub(super) fn push(&mut self, line: &[u8], ops: &mut Vec<Op>) -> Result<(), DiffError> {
        // The input is read line by line from here: the stretch no longer starts at its
        // unread bytes.
        self.equal = 0;
        self.push_one(line, ops)?;
        self.replay(ops)
    }

    /// The output lines matched again after a change, compared in step.
    fn replay(&mut self, ops: &mut Vec<Op>) -> Result<(), DiffError> {
        while let Some(line) = self.replay.pop_front() {
            self.push_one(&line, ops)?;
            recycle(&mut self.spare, line);
        }
        Ok(())
    }

    /// The output has ended: the rest of both files is one last change, if they differ.
    pub(super) fn finish(&mut self, ops: &mut Vec<Op>) -> Result<(), DiffError> {
        self.output_ended = true;
        loop {
            while !self.input_ended {
                if self.read_input()? && !self.pending.is_empty() {
                    self.best = min_anchor(self.best, self.anchor_ending_input());
                }
                self.check_cap()?;
            }
            let Some(anchor) = self.best.take() else { break };
            self.resync(anchor, ops)?;
            self.replay(ops)?;
        }
        if !self.ahead.is_empty() || !self.pending.is_empty() {
            let removed = self.ahead.drain(..).collect();
            ops.push(Op::Changed { removed, added: self.pending.len() });
            self.pending.clear();
        }
        Ok(())
    }

    fn push_one(&mut self, line: &[u8], ops: &mut Vec<Op>) -> Result<(), DiffError> {
        if self.pending.is_empty() {
            // In step: the common case, a line compared and forgotten.
            if let Some(next) = self.ahead.front() {
                if next == line {
                    let next = self.ahead.pop_front().unwrap_or_default();
                    recycle(&mut self.spare, next);
                    ops.push(Op::Same);
                    return Ok(());
                }
            } else if !self.input_ended {
                match self.input.next_line()? {
                    Some(next) if next.bytes == line => {
                        ops.push(Op::Same);
                        return Ok(());
                    }
                    Some(next) => {
                        let next = owned(&mut self.spare, next.bytes);
                        self.ahead.push_back(next);
                    }
                    None => self.input_ended = true,
                }
            }
            // The files differ from here: what is read ahead is where they may agree again.
            self.ahead_hashes.clear();
            self.ahead_hashes.extend(self.ahead.iter().map(|l| hash(l)));
            self.pending_hashes.clear();
        }
        let owned = owned(&mut self.spare, line);
        self.pending_hashes.push(hash(&owned));
        self.pending.push(owned);
        self.best = min_anchor(self.best, self.anchor_ending_output());
        // Read the input ahead of the output, so that a block the output dropped is found
        // before the output has gone as far past it.
        while !self.input_ended && self.ahead.len() < (2 * self.pending.len() + 8).min(self.cap) {
            if self.read_input()? {
                self.best = min_anchor(self.best, self.anchor_ending_input());
            }
        }
        match self.best.filter(|&anchor| self.settled(anchor)) {
            Some(anchor) => {
                self.best = None;
                self.resync(anchor, ops)
            }
            None => self.check_cap(),
        }
    }

    /// Whether no anchor shorter than `(i, j)` can still be found: one would end within the
    /// lines of both files already read.
    fn settled(&self, (i, j): (usize, usize)) -> bool {
        let needed = i + j + RESYNC_LINES - 1;
        (self.output_ended || self.pending.len() >= needed)
            && (self.input_ended || self.ahead.len() >= needed)
    }

    /// Reads one input line into `ahead` (indexed while the files differ): whether one came.
    fn read_input(&mut self) -> Result<bool, DiffError> {
        let Some(next) = self.input.next_line()? else {
            self.input_ended = true;
            return Ok(false);
        };
        let next = owned(&mut self.spare, next.bytes);
        self.ahead_hashes.push(hash(&next));
        self.ahead.push_back(next);
        Ok(true)
    }

    /// The anchor, if any, whose run of equal lines ends at the output's last line.
    fn anchor_ending_output(&self) -> Option<(usize, usize)> {
        let j = self.pending.len().checked_sub(RESYNC_LINES)?;
        let h = self.pending_hashes[j];
        (0..self.ahead_hashes.len()).find(|&i| self.ahead_hashes[i] == h && self.agree(i, j)).map(|i| (i, j))
    }

    /// The anchor, if any, whose run of equal lines ends at the input's last line read.
    fn anchor_ending_input(&self) -> Option<(usize, usize)> {
        let i = self.ahead.len().checked_sub(RESYNC_LINES)?;
        let h = self.ahead_hashes[i];
        (0..self.pending_hashes.len())
            .find(|&j| self.pending_hashes[j] == h && self.agree(i, j))
            .map(|j| (i, j))
    }

    /// Whether the input's lines from `i` and the output's from `j` agree on
    /// [`RESYNC_LINES`] lines.
    fn agree(&self, i: usize, j: usize) -> bool {
        i + RESYNC_LINES <= self.ahead.len()
            && j + RESYNC_LINES <= self.pending.len()
            && (0..RESYNC_LINES).all(|k| self.ahead[i + k] == self.pending[j + k])
    }

    /// The files agree again from the input's line `i` and the output's line `j` on: the lines
    /// before are a change, and the output's lines from `j` are compared again, in step.
    fn resync(&mut self, (i, j): (usize, usize), ops: &mut Vec<Op>) -> Result<(), DiffError> {
        let removed = self.ahead.drain(..i).collect();
        ops.push(Op::Changed { removed, added: j });
        for line in self.pending.drain(j..).rev() {
            self.replay.push_front(line);
        }
        for line in self.pending.drain(..) {
            recycle(&mut self.spare, line);
        }
        self.ahead_hashes.clear();
        self.pending_hashes.clear();
        Ok(())
    }

    fn check_cap(&self) -> Result<(), DiffError> {
        match self.ahead.len().max(self.pending.len()) > self.cap {
            true => Err(DiffError::PastCap(self.cap)),
            false => Ok(()),
        }
    }
}

/// Line buffers kept for reuse at most: a change's worth, so that their memory does not grow
/// with the file.
pub(super) const SPARE_LINES: usize = 1024;

/// Keeps `line`'s buffer for reuse, if `spare` has room.
pub(super) fn recycle(spare: &mut Vec<Vec<u8>>, line: Vec<u8>) {
    if spare.len() < SPARE_LINES {
        spare.push(line);
    }
}

/// `bytes` in a buffer from `spare`.
fn owned(spare: &mut Vec<Vec<u8>>, bytes: &[u8]) -> Vec<u8> {
    let mut v = spare.pop().unwrap_or_default();
    v.clear();
    v.extend_from_slice(bytes);
    v
}

/// Of two anchors, the one with the shorter change.
fn min_anchor(a: Option<(usize, usize)>, b: Option<(usize, usize)>) -> Option<(usize, usize)> {
    match (a, b) {
        (Some(a), Some(b)) => Some(if b.0 + b.1 < a.0 + a.1 { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// How many bytes `a` and `b` start with alike: eight at a time, the first that differ found
/// by the lowest set bit of the difference (a line is a few dozen bytes: a few instructions
/// each, against a search for its end and a comparison of its own).
fn common_prefix(a: &[u8], b: &[u8]) -> usize {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut at = 0;
    for (x, y) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
        let (Ok(x), Ok(y)) = (<[u8; 8]>::try_from(x), <[u8; 8]>::try_from(y)) else { break };
        let differ = u64::from_le_bytes(x) ^ u64::from_le_bytes(y);
        if differ != 0 {
            return at + differ.trailing_zeros() as usize / 8;
        }
        at += 8;
    }
    at + a[at..].iter().zip(&b[at..]).take_while(|(x, y)| x == y).count()
}

/// FNV-1a: lines are short, and only those of a change are hashed.
fn hash(line: &[u8]) -> u64 {
    line.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ops of `output` against `input`, each a line of text.
    fn diff(input: &[&str], output: &[&str], cap: usize) -> Result<Vec<Op>, DiffError> {
        let text = input.iter().map(|l| format!("{l}\n")).collect::<String>();
        let mut d = LineDiff::new(text.as_bytes(), cap);
        let mut ops = Vec::new();
        for line in output {
            d.push(line.as_bytes(), &mut ops)?;
        }
        d.finish(&mut ops)?;
        Ok(ops)
    }

    /// The output rebuilt from the input and the ops: every op accounted for, in order.
    fn apply(input: &[&str], ops: &[Op], output: &[&str]) -> Vec<String> {
        let (mut i, mut j, mut rebuilt) = (0, 0, Vec::new());
        for op in ops {
            match op {
                Op::Same => {
                    assert_eq!(input[i], output[j]);
                    rebuilt.push(input[i].to_owned());
                    (i, j) = (i + 1, j + 1);
                }
                Op::Changed { removed, added } => {
                    let expected: Vec<Vec<u8>> =
                        input[i..i + removed.len()].iter().map(|l| l.as_bytes().to_vec()).collect();
                    assert_eq!(*removed, expected);
                    rebuilt.extend(output[j..j + added].iter().map(|l| l.to_string()));
                    (i, j) = (i + removed.len(), j + added);
                }
            }
        }
        assert_eq!(i, input.len(), "the whole input");
        rebuilt
    }

    fn changes(ops: &[Op]) -> Vec<(usize, usize)> {
        ops.iter()
            .filter_map(|op| match op {
                Op::Changed { removed, added } => Some((removed.len(), *added)),
                Op::Same => None,
            })
            .collect()
    }

    fn moves(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("G1 X{i} Y{} E0.5", i * 7 % 13)).collect()
    }

    #[test]
    fn equal_files_are_all_the_same() {
        let lines = moves(50);
        let lines: Vec<&str> = lines.iter().map(String::as_str).collect();
        let ops = diff(&lines, &lines, 100).unwrap();
        assert_eq!(ops, vec![Op::Same; 50]);
    }

    #[test]
    fn an_inserted_block_is_one_change_adding_it() {
        let input = moves(40);
        let input: Vec<&str> = input.iter().map(String::as_str).collect();
        let mut output = input.clone();
        output.splice(20..20, ["T1", "G1 E25 F200", "G1 E-0.8 F2100"]);
        let ops = diff(&input, &output, 100).unwrap();
        assert_eq!(changes(&ops), [(0, 3)]);
        assert_eq!(apply(&input, &ops, &output), output);
        assert_eq!(ops[20], Op::Changed { removed: vec![], added: 3 });
    }

    #[test]
    fn a_removed_block_is_one_change_removing_it() {
        let input = moves(40);
        let input: Vec<&str> = input.iter().map(String::as_str).collect();
        let mut output = input.clone();
        output.drain(10..22);
        let ops = diff(&input, &output, 100).unwrap();
        assert_eq!(changes(&ops), [(12, 0)]);
        assert_eq!(apply(&input, &ops, &output), output);
    }

    #[test]
    fn a_moved_block_is_an_insertion_and_a_removal() {
        let input = moves(60);
        let input: Vec<&str> = input.iter().map(String::as_str).collect();
        // purge-shift: a tool change's lines moved 15 lines earlier.
        let mut output = input.clone();
        let block: Vec<&str> = output.drain(30..35).collect();
        output.splice(15..15, block);
        let ops = diff(&input, &output, 100).unwrap();
        assert_eq!(changes(&ops), [(0, 5), (5, 0)]);
        assert_eq!(apply(&input, &ops, &output), output);
    }

    /// Slicers repeat retractions and Z hops: one equal line inside a change does not end it,
    /// and the change found is the shortest that rebuilds the output.
    #[test]
    fn repeated_lines_do_not_resync_inside_a_change() {
        let mut input = Vec::new();
        for i in 0..30 {
            input.push(format!("G1 X{i} E1"));
            if i % 5 == 0 {
                input.extend(["G1 E-0.8 F2100".to_owned(), "G1 Z0.4".to_owned()]);
            }
        }
        let input: Vec<&str> = input.iter().map(String::as_str).collect();
        let mut output = input.clone();
        // A replaced block holding a repeated line and pair.
        output.splice(12..14, ["G1 E-0.8 F2100", "G1 Z0.4", "T2", "G1 E-0.8 F2100"]);
        let ops = diff(&input, &output, 100).unwrap();
        assert_eq!(apply(&input, &ops, &output), output);
        let changed: usize = changes(&ops).iter().map(|(r, a)| r + a).sum();
        assert!(changed <= 6, "{:?}", changes(&ops));
    }

    #[test]
    fn a_change_past_the_cap_is_refused() {
        let input = moves(200);
        let input: Vec<&str> = input.iter().map(String::as_str).collect();
        let mut output = input.clone();
        let added: Vec<String> = (0..150).map(|i| format!("G1 Z{i}")).collect();
        output.splice(20..20, added.iter().map(String::as_str));
        assert!(matches!(diff(&input, &output, 100), Err(DiffError::PastCap(100))));
        // Under the cap, the same change is found.
        let ops = diff(&input, &output, 400).unwrap();
        assert_eq!(changes(&ops), [(0, 150)]);
    }

    /// The ops of `output` against `input` (whole texts) as the measure finds them: the
    /// output read by a line reader that takes `step` bytes at a time (a file still written),
    /// each stretch of it compared at once with the input's. Also how many lines were matched
    /// in a stretch.
    fn diff_by_stretches(
        input: &[u8],
        output: &[u8],
        step: usize,
        cap: usize,
    ) -> Result<(Vec<Op>, usize), DiffError> {
        /// Reads at most `self.1` bytes a time.
        struct Trickle<'a>(&'a [u8], usize);
        impl Read for Trickle<'_> {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                let n = buf.len().min(self.1).min(self.0.len());
                buf[..n].copy_from_slice(&self.0[..n]);
                self.0 = &self.0[n..];
                Ok(n)
            }
        }
        let mut d = LineDiff::new(input, cap);
        let mut reader = LineReader::new(Trickle(output, step));
        let (mut ops, mut in_stretch) = (Vec::new(), 0);
        loop {
            d.compare_ahead(reader.unread());
            let Some(line) = reader.next_line()? else { break };
            if d.same_in_stretch(&line) {
                ops.push(Op::Same);
                in_stretch += 1;
            } else {
                d.push(line.bytes, &mut ops)?;
            }
        }
        d.finish(&mut ops)?;
        Ok((ops, in_stretch))
    }

    proptest::proptest! {
        /// Regression of the comparison by stretches: the ops are those of the line by line
        /// comparison for any edit of any file, whatever its line endings (a lone `\r`, `\r\n`,
        /// endings that differ between the files) and however the output's bytes arrive.
        #[test]
        fn stretches_give_the_ops_of_the_line_by_line_comparison(
            lines in proptest::collection::vec(("G1 X[0-9]{1,3}( E[0-9])?|G1 E-0.8|;c|", 0..3usize), 1..80),
            edits in proptest::collection::vec((0..80usize, 0..3usize, "G1 Z[0-9]|T[0-2]|G1 E-0.8|;c|"), 0..6),
            changed_eols in proptest::bool::ANY,
            step in 1usize..200,
        ) {
            let eols = [&b"\n"[..], b"\r\n", b"\r"];
            let text = |lines: &[(String, usize)]| -> Vec<u8> {
                lines.iter().flat_map(|(l, e)| [l.as_bytes(), eols[*e]].concat()).collect()
            };
            let mut output = lines.clone();
            for (at, kind, line) in &edits {
                let at = at % (output.len() + 1);
                match kind {
                    0 => output.insert(at, (line.clone(), 0)),
                    1 if at < output.len() => drop(output.remove(at)),
                    _ if at < output.len() && changed_eols => output[at].1 = (output[at].1 + 1) % 3,
                    _ => {}
                }
            }
            let (input, output) = (text(&lines), text(&output));
            let line_texts = |text: &[u8]| -> Vec<Vec<u8>> {
                let mut r = LineReader::new(text);
                let mut all = Vec::new();
                while let Some(l) = r.next_line().unwrap() {
                    all.push(l.bytes.to_vec());
                }
                all
            };
            let by_lines = {
                let mut d = LineDiff::new(&input[..], 100);
                let mut ops = Vec::new();
                for line in line_texts(&output) {
                    d.push(&line, &mut ops).unwrap();
                }
                d.finish(&mut ops).unwrap();
                ops
            };
            proptest::prop_assert_eq!(diff_by_stretches(&input, &output, step, 100).unwrap().0, by_lines);
        }
    }

    /// The comparison by stretches on two copies of a long file (past a reader's buffer) finds
    /// every line the same, and one change in the middle of it; nearly every line is matched in
    /// a stretch, not read from the input (only those where a read of the output or the input
    /// ends, and around the change).
    #[test]
    fn a_long_file_is_compared_by_stretches() {
        let lines: Vec<String> = moves(60_000).into_iter().map(|l| l + "\n").collect();
        let input = lines.concat();
        let (ops, in_stretch) = diff_by_stretches(input.as_bytes(), input.as_bytes(), 1 << 16, 100).unwrap();
        assert_eq!(ops, vec![Op::Same; 60_000]);
        assert!(in_stretch > 59_000, "{in_stretch} lines in a stretch");
        let output = [lines[..30_000].concat(), "T1\n".into(), lines[30_000..].concat()].concat();
        let (ops, in_stretch) = diff_by_stretches(input.as_bytes(), output.as_bytes(), 1 << 16, 100).unwrap();
        assert_eq!(changes(&ops), [(0, 1)]);
        assert_eq!(ops.len(), 60_001);
        assert!(in_stretch > 59_000, "{in_stretch} lines in a stretch");
    }

    #[test]
    fn changes_at_the_ends_are_found() {
        let input = moves(30);
        let input: Vec<&str> = input.iter().map(String::as_str).collect();
        let mut output = vec!["; gweave mix"];
        output.extend(&input[1..]);
        output.extend(["; footer", "M84"]);
        let ops = diff(&input, &output, 100).unwrap();
        assert_eq!(changes(&ops), [(1, 1), (0, 2)]);
        assert_eq!(apply(&input, &ops, &output), output);
    }
}
