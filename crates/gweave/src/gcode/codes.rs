//! The commands the modal state ([`State`](super::state::State)) interprets, declared once.
//!
//! `State::apply` matches these codes itself (it is the hot path of every command, and a table
//! lookup per line would show), so this table is what it answers to: a test applies every G- and
//! M-code from 0 to 1000 and checks that exactly the codes listed here change the state or say
//! what the line does (an [`Effect`](super::effect::Effect)). The virtual printer's command
//! registry (`gweave-sim`) is checked to carry out every one of them, so that `gweave stats`,
//! `gweave estimate` and `gweave sim` read the same commands.

/// Codes the modal state reads, and what it makes of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModalCode {
    /// The codes, space-separated, as written in G-code (`G90 G91`, `T<n>`).
    pub codes: &'static str,
    /// What the state makes of them.
    pub meaning: &'static str,
}

/// Every command the modal state interprets.
pub const MODAL_CODES: &[ModalCode] = &[
    ModalCode { codes: "G0 G1 G2 G3", meaning: "motion mode, then the move to the axis words (F the feed rate)" },
    ModalCode { codes: "G4", meaning: "a dwell of S seconds plus P milliseconds" },
    ModalCode { codes: "G10 G11", meaning: "firmware retract / recover by the M207 length; a G10 with P or L (S in RepRapFirmware) is none: with S, a tool temperature" },
    ModalCode { codes: "G20 G21", meaning: "inches / millimetres" },
    ModalCode { codes: "G28", meaning: "homing: the named axes (all without words) are at 0" },
    ModalCode { codes: "G90 G91", meaning: "absolute / relative axes (E too, as the firmware does)" },
    ModalCode { codes: "G92", meaning: "set the logical position" },
    ModalCode { codes: "M82 M83", meaning: "absolute / relative extrusion" },
    ModalCode { codes: "M104 M109", meaning: "hotend target (T the hotend)" },
    ModalCode { codes: "M106 M107", meaning: "part fan speed / off" },
    ModalCode { codes: "M140 M190", meaning: "bed target" },
    ModalCode { codes: "M207", meaning: "the firmware retraction's length" },
    ModalCode { codes: "M568", meaning: "a RepRapFirmware tool temperature" },
    ModalCode { codes: "T<n>", meaning: "tool change" },
];

/// Each code of [`MODAL_CODES`] on its own: `G0`, `G1`, ..., `T<n>`.
pub fn modal_codes() -> impl Iterator<Item = &'static str> {
    MODAL_CODES.iter().flat_map(|c| c.codes.split_whitespace())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::lexer::parse_into;
    use crate::gcode::line::Block;
    use crate::gcode::state::State;

    /// The state after the lines of `start`, then after `line` too, as text: every field and
    /// the line's effect, but not the file's structure (which counts every command).
    fn after(start: &str, line: &str) -> (String, String) {
        let mut state = State::default();
        let mut block = Block::default();
        // The empty line clears the effect of the last line of `start`.
        for l in start.lines().chain([""]) {
            parse_into(l.as_bytes(), &mut block);
            state.apply(l.as_bytes(), &block);
        }
        let text = |state: &State| {
            let mut state = state.clone();
            state.structure = Default::default();
            format!("{state:?}")
        };
        let before = text(&state);
        parse_into(line.as_bytes(), &mut block);
        state.apply(line.as_bytes(), &block);
        (before, text(&state))
    }

    /// Exactly the listed codes change the modal state, from a fresh state or from one with
    /// every mode switched (relative, inches, retracted, fan on), so that a code which only sets the
    /// mode already in force is still seen.
    #[test]
    fn the_state_interprets_exactly_the_listed_codes() {
        let listed: Vec<&str> = modal_codes().collect();
        for letter in ['G', 'M'] {
            for n in 0..=1000 {
                let code = format!("{letter}{n}");
                let line = format!("{code} X1 Y2 Z3 E4 S5 P6 R7 T1 F100");
                let changes = ["", "G91\nM83\nG20\nG10\nT2\nM106 S100"].iter().any(|start| {
                    let (before, after) = after(start, &line);
                    before != after
                });
                assert_eq!(changes, listed.contains(&code.as_str()), "{line}");
            }
        }
        let (before, after) = after("", "T1");
        assert_ne!(before, after, "T<n>");
        assert!(listed.contains(&"T<n>"));
    }
}
