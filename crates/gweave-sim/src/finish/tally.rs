//! The `stats` count and the settings of a file the measure reads: what the metadata's filament
//! comes from, always what `gweave stats` counts.
//!
//! Most lines of a print are plain moves (`G1 X.. Y.. E..`), and the measure reads them for
//! three things only: the modal state, the `stats` count and whether they state a time (they
//! do not). So a transform's output is read as `estimate` reads its input
//! ([`TallyPass::read`]): a plain move's numbers go straight from the line into the state
//! ([`read_plain_move`], [`State::apply_plain`]) and the count
//! ([`StatsPass::plain_move`]), without a [`Block`] or the state's [`Effect`](gweave::Effect);
//! every other line goes through the lexer and [`State::apply`]. The two give the same state
//! and count to the bit (the property test below).

use std::io;

use gweave::gcode::lexer::{parse_line, parse_line_lean, read_plain_move};
use gweave::gcode::line::PlainMove;
use gweave::post::metadata::{read_setting, Figures};
use gweave::{Block, Ctx, Pass, RawLine, State, StatsPass};

/// The `stats` count and the settings ([`read_setting`]).
pub(super) struct TallyPass {
    pub(super) stats: StatsPass,
    pub(super) figures: Figures,
    /// The count's first error (it writes nothing: none is expected).
    pub(super) failed: Option<io::Error>,
}

impl TallyPass {
    pub(super) fn new() -> Self {
        TallyPass { stats: StatsPass::new(None), figures: Figures::default(), failed: None }
    }

    /// Counts a line the caller has read into `ctx`.
    pub(super) fn line(&mut self, ctx: &Ctx<'_>) {
        if let Err(e) = self.stats.line(ctx, &mut io::sink()) {
            self.failed.get_or_insert_with(|| io::Error::other(e.to_string()));
        }
        if let Some(c) = ctx.block.comment_text(ctx.line.bytes) {
            read_setting(c, &mut self.figures);
        }
    }

    /// Reads the whole line `line` into `state` and counts it, as `stats` reads it (a lenient
    /// run: the transform has read the file already). A plain move is read by its numbers
    /// alone, into `plain`, where they are all its meaning ([`State::reads_words`] is `false`:
    /// E extrudes); any other line by the lexer, into `block`. Returns whether it was read as a
    /// plain move: such a line states no time and no setting.
    #[inline(always)]
    pub(super) fn read(
        &mut self,
        line: &RawLine<'_>,
        state: &mut State,
        block: &mut Block,
        plain: &mut PlainMove,
    ) -> bool {
        if !state.reads_words() && read_plain_move(line, plain) {
            let from = state.pos;
            let moved = state.apply_plain(plain);
            self.stats.plain_move(line, &from, moved, state);
            return true;
        }
        match state.reads_words() {
            true => parse_line(line, block),
            false => parse_line_lean(line, block),
        }
        state.apply(line.bytes, block);
        self.line(&Ctx { line: *line, block, effect: &state.effect, state });
        false
    }
}

#[cfg(test)]
mod tests {
    use gweave::gcode::reader::Part;
    use gweave::{Effect, Firmware, LineReader, StateOptions};

    use super::*;

    /// Everything a line leaves behind: the state (but its effect, which the plain path does
    /// not write) and the count (`Debug` shows each `f64` to the bit it round-trips to).
    fn after(state: &State, tally: &TallyPass) -> String {
        let mut state = state.clone();
        state.effect = Effect::None;
        format!("{state:?}\n{:?}\n{:?}", tally.stats, tally.figures)
    }

    /// `text` line by line through the lexer and [`State::apply`] (the general path) and
    /// through [`TallyPass::read`], read as `firmware` reads it: the same state and count after
    /// every line, and the same `stats` report. Returns how many lines were read as plain
    /// moves.
    fn same_as_the_general_path(text: &str, firmware: Firmware) -> usize {
        let options = StateOptions { firmware, ..StateOptions::default() };
        let (mut general, mut read) = (State::new(options.clone()), State::new(options));
        let (mut general_tally, mut read_tally) = (TallyPass::new(), TallyPass::new());
        let (mut block, mut plain) = (Block::default(), PlainMove::default());
        let mut taken = 0;
        let mut reader = LineReader::new(text.as_bytes());
        while let Some(line) = reader.next_line().unwrap() {
            assert_eq!(line.part, Part::Whole);
            match general.reads_words() {
                true => parse_line(&line, &mut block),
                false => parse_line_lean(&line, &mut block),
            }
            general.apply(line.bytes, &block);
            general_tally.line(&Ctx { line, block: &block, effect: &general.effect, state: &general });
            taken += usize::from(read_tally.read(&line, &mut read, &mut block, &mut plain));
            assert_eq!(after(&general, &general_tally), after(&read, &read_tally), "{:?}", line.bytes);
        }
        let report =
            |tally: TallyPass, state: &State| serde_json::to_string(&tally.stats.into_stats(state)).unwrap();
        assert_eq!(report(general_tally, &general), report(read_tally, &read));
        taken
    }

    /// The near misses of a plain move (glued, lower case, `G01`, an exponent, a comment, a
    /// repeated letter, a long number, a word without a number, CR endings), moves that do not
    /// move, retractions, travel and the modes and tools between them count as the general
    /// path counts them, for each firmware's reading of E and G91.
    #[test]
    fn a_plain_move_counts_as_the_general_path_counts_it() {
        let text = "G1 X10 Y10 F3000\r\nG1X1\nG1 X1 ;c\nG01 X5 E1\nG1 X1e3\ng1 X3 E.5\nG1 X-.5 E0.2\n\
                    G1 X1 X2 E1\nG1 X2 E0.123456789012345678\nG1 X1.25  Y2  \nG1\nG0 F1200\nG1 X\n\
                    ;TYPE:External perimeter\nG1 X1..2\nG1\tX3\n G1 X4\nN10 G1 X5*99\nG1 X6 E-0.8 F2100\n\
                    T1\nG91\nG1 Z0.3 E1\nG1 X1 X2\nG20\nM83\nG1 X1 Y1 E0.1\nG90\nG21\nG92 E0\n\
                    ;LAYER_CHANGE\nG1 Z.4\nG1 X8 F0\nG1 X9 E2 F-5\r\nG1 E-1\nG1 E1\nG1 X20 Y30 E1\n\
                    G0 X21 Y30\nG1 X123456789012345678901234567890 Y1\rG1 X7 Y7 E9\nG1 Y2 E9.5";
        assert_eq!(same_as_the_general_path(text, Firmware::Marlin), 20);
        // RepRapFirmware's G91 moves E relative too.
        assert_eq!(same_as_the_general_path(text, Firmware::RepRapFirmware), 20);
        // LinuxCNC extrudes with A: every line through the lexer.
        assert_eq!(same_as_the_general_path(text, Firmware::LinuxCnc), 0);
    }

    proptest::proptest! {
        /// Random plain moves and near misses, after random modes, tools and comments, count
        /// as the general path counts them, line by line.
        #[test]
        fn plain_moves_count_as_the_general_path_counts_them(
            lines in proptest::collection::vec(
                "(G90|G91|M82|M83|G20|G21|G92 X1 E2|T[0-2]|;LAYER_CHANGE|;TYPE:Support material|G10|G11|\
                 ([Gg]0?[01]|G[01]|G[01]|G[01])( {1,2}[XYZEFxA]-?[0-9]{0,4}(\\.[0-9]{0,4})?([eE][0-9])?[.+-]?){0,5}( ?;c)? ?)",
                1..40),
            eol in "(\n|\r\n|\r)",
        ) {
            let mut text = String::from("G1 X3 Y4 Z5 E6 F100\n");
            for line in &lines {
                text.push_str(line);
                text.push_str(&eol);
            }
            for firmware in [Firmware::Marlin, Firmware::RepRapFirmware, Firmware::LinuxCnc] {
                same_as_the_general_path(&text, firmware);
            }
        }
    }
}
