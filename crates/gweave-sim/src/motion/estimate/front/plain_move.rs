//! `estimate`'s own reader of a plain move (`G0`/`G1` with X, Y, Z, E and F numbers and nothing
//! else, nearly every line of a print): its numbers go from the line straight into the planner's
//! job, without the general [`Block`](gweave::Block), the modal state's
//! [`Effect::Move`](gweave::Effect) and its copy into the job. Every other line, and every line
//! of a file whose plain moves mean something else (a rotary program's declared feed, an
//! extrusion word other than E), goes through [`Front::step`] as before: the same commands, the
//! same ranges, the same errors. `stats` and `check` keep the general reader, which must list
//! every word; `estimate` reads nothing of a plain move but its five numbers.

use gweave::gcode::lexer::read_plain_move;
use gweave::gcode::reader::Part;
use gweave::RawLine;

use super::{at, EstimateError, Front, Job};
use crate::interp::commands;

impl Front {
    /// [`Front::step`] for `estimate`, whose lines are read by nothing else: a plain move is
    /// read by [`read_plain_move`] into [`Front::plain`] (kept from line to line: made afresh,
    /// its six fields cost six stores a line) and planned from the modal position before and
    /// after it (the same jobs, to the bit: the tests below).
    #[inline(always)]
    pub(in super::super) fn read(
        &mut self,
        line: &RawLine<'_>,
        jobs: &mut Vec<Job>,
    ) -> Result<(), EstimateError> {
        if !(self.reads_plain_moves() && line.part == Part::Whole && read_plain_move(line, &mut self.plain)) {
            return self.step(line, jobs);
        }
        // What `Front::step` does with a plain move: counted, checked against the `G0 G1` row's
        // ranges (refused whole, as the virtual printer refuses it), followed by the modal
        // state, and planned if it moves.
        self.line += 1;
        if let Err(refusal) = commands::check_plain(&self.plain) {
            self.refuse(refusal);
            return Ok(());
        }
        let from = at(&self.state.pos);
        if self.state.apply_plain(&self.plain) {
            let to = at(&self.state.pos);
            self.book.straight(&self.state.structure, from, to, self.state.feed_mm_min, self.line, jobs);
        }
        Ok(())
    }

    /// Whether a plain move's numbers are all its meaning here: E extrudes
    /// ([`gweave::State::reads_words`]) and F is the firmware's feed (no declared rotary feed).
    #[inline(always)]
    fn reads_plain_moves(&self) -> bool {
        !self.state.reads_words() && self.rotary.is_none()
    }
}

#[cfg(test)]
mod tests {
    use gweave::LineReader;

    use gweave::gcode::line::PlainMove;

    use super::*;
    use crate::motion::limits::{KlipperLimits, MotionProfile};

    /// Everything a line leaves behind on the parse side: its jobs, then the modal state and
    /// the counts (`Debug` shows each `f64` to the bit it round-trips to).
    fn after(front: &Front, jobs: &[Job]) -> String {
        let s = &front.state;
        format!(
            "{jobs:?}\n{:?} {:?} {:?} {:?} {:?} {:?} {} {:?} {:?} {:?}",
            s.pos.map(f64::to_bits),
            s.feed_mm_min.to_bits(),
            s.motion,
            s.filament_mm.iter().map(|f| f.to_bits()).collect::<Vec<_>>(),
            s.structure,
            s.tool,
            front.line,
            front.malformed,
            front.refused,
            book(front),
        )
    }

    /// The bookkeeping, without its map's order (a `HashMap`'s differs from map to map).
    fn book(front: &Front) -> String {
        let b = &front.book;
        format!(
            "{:?} {} {} {} {} {} {}",
            b.last_tag,
            b.key_index.len(),
            b.mix,
            b.tool,
            b.started,
            b.motors_on,
            b.moved_since_m400
        )
    }

    /// `text` line by line through [`Front::step`] (the general path) and [`Front::read`]:
    /// the same jobs and the same state after every line. Returns how many lines the plain
    /// move reader took.
    fn same_as_the_general_path(text: &str, profile: &MotionProfile) -> usize {
        let (mut general_jobs, mut read_jobs) = (Vec::new(), Vec::new());
        let mut general = Front::new(profile, &mut general_jobs).unwrap();
        let mut read = Front::new(profile, &mut read_jobs).unwrap();
        let mut taken = 0;
        let mut reader = LineReader::new(text.as_bytes());
        while let Some(line) = reader.next_line().unwrap() {
            let a = general.step(&line, &mut general_jobs).map_err(|e| e.to_string());
            let b = read.read(&line, &mut read_jobs).map_err(|e| e.to_string());
            assert_eq!(a, b, "{:?}", line.bytes);
            assert_eq!(after(&general, &general_jobs), after(&read, &read_jobs), "{:?}", line.bytes);
            taken += usize::from(read_plain_move(&line, &mut PlainMove::default()));
            general_jobs.clear();
            read_jobs.clear();
        }
        taken
    }

    fn profiles() -> [MotionProfile; 2] {
        [MotionProfile::default(), MotionProfile::klipper(KlipperLimits::default())]
    }

    /// The near misses of a plain move (glued, lower-case, `G01`, an exponent, a comment, a
    /// repeated letter, a number too long for the fast digits, a word without a number, out
    /// of range, CR line ends) give what the general path gives, taken or not.
    #[test]
    fn near_misses_of_a_plain_move_read_as_the_general_path_reads_them() {
        let text = "G1 X10 Y10 F3000\r\nG1X1\nG1 X1 ;c\nG01 X5 E1\nG1 X1e3\ng1 X3 E.5\nG1 X-.5 E0.2\n\
                    G1 X1 X2 E1\nG1 X2 E0.123456789012345678\nG1 X1.25  Y2  \nG1\nG0 F1200\nG1 X\n\
                    G1 X1..2\nG1\tX3\n G1 X4\nN10 G1 X5*99\nG1 X6 E-0.8 F2100\nG91\nG1 Z0.3 E1\n\
                    G1 X1 X2\nG20\nM83\nG1 X1 Y1 E0.1\nG90\nG21\nG1 X999999 Y3\nG1 X8 F0\nG1 X9 F-5\r\n\
                    G1 X123456789012345678901234567890 Y1\rG1 X7 Y7 E9\nG1 Y2 E9.5";
        for profile in profiles() {
            // Only the plain moves are taken: the first, `G1 X-.5`, the repeated X, the long E,
            // the spaces at the end, the F alone, `G1 X6`, `G1 Z0.3`, X1 X2, `X1 Y1`, the
            // out-of-range X, both F, the long X, and the last two.
            assert_eq!(same_as_the_general_path(text, &profile), 16);
        }
    }

    proptest::proptest! {
        /// Random plain moves and near misses, after random modes, give the general path's
        /// jobs and state, line by line, with either planner's bookkeeping.
        #[test]
        fn the_plain_move_reader_gives_the_general_paths_jobs(
            modes in proptest::collection::vec(
                "(G90|G91|M82|M83|G20|G21|G92 X1 E2|T1|;LAYER:2|;TYPE:External perimeter|M204 S900)", 0..4),
            lines in proptest::collection::vec(
                "([Gg]0?[01]|G[01]|G[01]|G[01])( {1,2}[XYZEFxA]-?[0-9]{0,9}(\\.[0-9]{0,9})?([eE][0-9])?[.+-]?){0,5}( ?;c)? ?",
                1..8),
            long in "G1 X[0-9]{16,40}(\\.[0-9]{1,30})?",
            eol in "(\n|\r\n|\r)",
        ) {
            let mut text = format!("G1 X3 Y4 Z5 E6 F100\n{}\n", modes.join("\n"));
            for line in lines.iter().chain([&long]) {
                text.push_str(line);
                text.push_str(&eol);
            }
            for profile in profiles() {
                same_as_the_general_path(&text, &profile);
            }
        }
    }
}
