//! Each tool's own retraction, kept with its tool when a change moves.
//!
//! ## Why
//! A slicer ends a tool with a tool-change retraction (PrusaSlicer: `G1 E-10` before `T1`) and
//! starts the next with the unretraction of what that tool retracted when it was put away (`G1
//! E10` after the travel). Each input has its own filament, so each retraction belongs to the
//! tool active when it runs: on a dual extruder, and on a mixing hotend whose tools are virtual
//! (the retraction pulls back the inputs of the active mix). Moving the `T` line earlier puts
//! the old tool's retraction after it: the new tool would retract filament it never pushed and
//! the old tool keep the unretraction of its next change-back, 10 mm lost per cycle for one
//! tool and 10 mm blobbed by the other. So a moved change takes a bracket with it.
//!
//! ## The bracket
//! With `r_place` the old tool's retraction in force where the change now goes (0 inside an
//! extrusion), `r_change` the old tool's in force where the change was (the tool-change
//! retraction), and `p_new` what the new tool has parked (retracted when it was put away):
//!
//! ```text
//!   at the new place:  old tool feeds -(r_change - r_place)   T   new tool feeds p_new - r_place
//! ```
//!
//! The old tool ends retracted by `r_change`, as in the file. The new tool starts the moved
//! lines with `r_place` in force, as the old tool did, so it feeds them exactly as the old tool
//! would have. The slicer's tool-change retraction among them (E-only moves after the last
//! forward feed, `dropped_mm` in all) has just been made by the old tool at the new place, so it
//! is taken out: the new tool reaches the place of the change with `r_change - dropped_mm` in
//! force, and it must be at `p_new` for the file's own unretraction after the travel. With
//! `left = r_change - dropped_mm - p_new`:
//!
//! ```text
//!   where it was:  left > 0: the new tool feeds left;  left < 0: -left of the file's
//!                  unretraction after the change is taken out (`absorbed_mm`)
//! ```
//!
//! For the usual slicer file (`r_place = 0`, `r_change = dropped_mm = p_new`) the file's
//! retraction and unretraction are moved to the new place and nothing else feeds: the output's
//! E motion is the input's. Lines between two moved places see every tool in the state they had
//! in the input: per-tool totals are the input's, moved purge apart.
//!
//! ## No `G92` right after the split
//! In absolute E the inserted moves are written in the file's own E coordinates, not from a
//! `G92 E0`: the first half of a split can be shorter than Marlin's `MIN_STEPS_PER_SEGMENT` (6
//! steps), which the planner drops and carries into the next block; a position reset before that
//! block makes the virtual printer re-set every axis (its `set_position_mm`) and lose the
//! carried steps, so the head would end a few steps off (13 X steps on the Slic3r cone). An
//! E-only move right after the split carries them instead. A `G92 E` comes only after the
//! inserted moves, when they do not bring E back to where the file has it.

use super::fallback::Spot;
use super::{Feature, Kind, PurgeShift, Region, EPS_E_MM};
use crate::gcode::reader::RawLine;
use crate::gcode::retraction::{write_e_only, write_e_reset};
use crate::gcode::state::{Effect, MM_PER_INCH};
use crate::pass::Ctx;
use std::io::{self, Write};

/// Feeds below this are rounding remainders, not a retraction worth a line, mm.
const EPS_MM: f64 = 1e-6;

/// The feeds that keep each tool's retraction with it across a moved change, mm (negative:
/// retract).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bracket {
    /// Fed by the old tool just before the change, at its new place.
    pub old_mm: f64,
    /// Fed by the new tool just after it.
    pub new_mm: f64,
    /// Fed by the new tool where the change was.
    pub settle_mm: f64,
    /// The file's tool-change retraction taken out where the change was.
    pub dropped_mm: f64,
    /// The file's unretraction after the change taken out.
    pub absorbed_mm: f64,
}

impl Bracket {
    /// The bracket for a change moved from where the old tool had `r_change_mm` retracted to
    /// where it had `r_place_mm`, the new tool having `p_new_mm` parked and the file's E-only
    /// retraction `dropped_mm` before the change being taken out (the module's formula).
    pub(super) fn new(r_place_mm: f64, r_change_mm: f64, p_new_mm: f64, dropped_mm: f64) -> Self {
        let left_mm = r_change_mm - dropped_mm - p_new_mm;
        let (settle_mm, absorbed_mm) =
            if left_mm.abs() < EPS_MM { (0.0, 0.0) } else { (left_mm.max(0.0), (-left_mm).max(0.0)) };
        Bracket {
            old_mm: -(r_change_mm - r_place_mm),
            new_mm: p_new_mm - r_place_mm,
            settle_mm,
            dropped_mm,
            absorbed_mm,
        }
    }
}

/// The lines of a bracket at `spot`: the old tool's feed `old_mm` (before the change lines) and
/// the new tool's `new_mm` (after them), as E-only moves at `feed_mm_min` in the file's E mode
/// and units, the second part ending with the E (absolute E: a `G92 E` when the feeds do not add
/// up to nothing) and the feed rate the file has at `spot` restored (unless it is `feed_mm_min`
/// in G1 already). `\n`-terminated lines;
/// nothing when both feeds are below a micrometre.
pub(crate) fn write_bracket(spot: &Spot, old_mm: f64, new_mm: f64, feed_mm_min: f64) -> [Vec<u8>; 2] {
    let mut parts = [Vec::new(), Vec::new()];
    if old_mm.abs() < EPS_MM && new_mm.abs() < EPS_MM {
        return parts;
    }
    let fmt = super::fallback::FORMAT;
    let start = &spot.start;
    let unit = if spot.inches { MM_PER_INCH } else { 1.0 };
    // Absolute E: counted from the E the file has here (no reset right after the split: the
    // module says why).
    let mut e_mm = if start.relative_e { 0.0 } else { start.pos[3] };
    for (out, f) in parts.iter_mut().zip([old_mm, new_mm]) {
        if f.abs() < EPS_MM {
            continue;
        }
        e_mm += f;
        let word = if start.relative_e { f } else { e_mm };
        out.extend_from_slice(b"G1 ");
        fmt.write_word(out, b'E', word / unit);
        out.push(b' ');
        fmt.write_word(out, b'F', feed_mm_min / unit);
        out.push(b'\n');
    }
    let out = &mut parts[1];
    if !start.relative_e && (old_mm + new_mm).abs() >= EPS_MM {
        write_e_reset(out, &fmt, start.pos[3] / unit);
        out.push(b'\n');
    }
    // The moves set `feed_mm_min` in G1: if that is what the file has in force, it stays;
    // else the feed rate (and G0/G1 mode) in force at `spot` is restored.
    if start.feed_mm_min > 0.0 && (start.rapid_mode || start.feed_mm_min != feed_mm_min) {
        write_e_only(out, &fmt, start.rapid_mode, None, Some(start.feed_mm_min / unit));
        out.push(b'\n');
    }
    parts
}

/// An E-only move of the input (no X, Y or Z motion), as the pass may take it out: the E the
/// file has after it, the modes it is written in and the feed rate it sets.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EOnly {
    /// The file's E after the line, mm.
    pub e_after_mm: f64,
    pub relative_e: bool,
    pub inches: bool,
    /// The feed rate the line sets (its own `F`), mm/min, and whether it is a `G0`.
    pub sets_feed_mm_min: Option<f64>,
    pub rapid: bool,
}

impl EOnly {
    /// The line `ctx` as an E-only move that can be rewritten (not numbered or checksummed).
    pub(crate) fn of(ctx: &Ctx<'_>) -> Option<EOnly> {
        match ctx.effect {
            Effect::Move(m)
                if m.from[..3] == m.to[..3]
                    && m.e_mm() != 0.0
                    && ctx.block.line_number.is_none()
                    && ctx.block.checksum.is_none() =>
            {
                Some(EOnly {
                    e_after_mm: ctx.state.pos[crate::gcode::state::E],
                    relative_e: ctx.state.relative_e(),
                    inches: ctx.state.inches,
                    sets_feed_mm_min: ctx.block.names(b'F').then_some(ctx.state.feed_mm_min),
                    rapid: m.rapid,
                })
            }
            _ => None,
        }
    }

    /// The file's E after the line, file units.
    pub(crate) fn e_after(&self) -> f64 {
        self.e_after_mm / if self.inches { MM_PER_INCH } else { 1.0 }
    }

    /// The line `line` of this move, feeding only `fed_mm` of its feed: nothing fed, only the
    /// feed rate it sets (in absolute E the caller owes a `G92 E` to [`EOnly::e_after`] before
    /// the next line that reads E); in relative E its E word replaced; in absolute E a `G92`
    /// puts E where the line then moves it by `fed_mm` alone, and the line stays as it is.
    /// `\n`-terminated lines.
    pub(crate) fn feeding(&self, line: &[u8], fed_mm: f64) -> Vec<u8> {
        let fmt = super::fallback::FORMAT;
        let unit = if self.inches { MM_PER_INCH } else { 1.0 };
        let mut out = Vec::new();
        if !self.relative_e && fed_mm.abs() >= EPS_MM {
            write_e_reset(&mut out, &fmt, (self.e_after_mm - fed_mm) / unit);
            out.push(b'\n');
            out.extend_from_slice(line);
            out.push(b'\n');
            return out;
        }
        let fed = (fed_mm.abs() >= EPS_MM).then_some(fed_mm / unit);
        if fed.is_none() && self.sets_feed_mm_min.is_none() {
            return out;
        }
        write_e_only(&mut out, &fmt, self.rapid, fed, self.sets_feed_mm_min.map(|f| f / unit));
        out.push(b'\n');
        out
    }
}

/// How a line reads the E coordinate: an E taken out in absolute E leaves the machine's E off
/// the file's until a `G92 E` puts it back, which is written only before a line that reads E
/// (and not at all when the file resets E first, as slicers do right after the tool-change
/// retraction): a `G92` right after a move too short for the planner would lose its carried
/// steps in the virtual printer (the module's "No `G92` right after the split").
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum EWord {
    None,
    /// `G92 E`: sets E itself.
    Reset,
    /// A move or command with an E word.
    Reads,
}

impl EWord {
    pub(crate) fn of(block: &crate::gcode::line::Block) -> EWord {
        if !block.names(b'E') {
            EWord::None
        } else if block.command.is_g(92) {
            EWord::Reset
        } else {
            EWord::Reads
        }
    }
}

/// What a held line feeds and how the pass may rewrite it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Feeds {
    /// Filament the line feeds (negative: retracts), mm.
    pub fed_mm: f64,
    /// The line as an E-only move the pass may take out (none for a line the pass wrote).
    pub e_only: Option<EOnly>,
    pub e_word: EWord,
}

impl Feeds {
    /// The line `ctx` of the input.
    pub(crate) fn of(ctx: &Ctx<'_>) -> Feeds {
        let fed_mm = match ctx.effect {
            Effect::Move(m) => m.e_mm(),
            _ => 0.0,
        };
        Feeds { fed_mm, e_only: EOnly::of(ctx), e_word: EWord::of(ctx.block) }
    }

    /// A line the pass wrote, feeding `fed_mm`.
    pub(crate) fn written(fed_mm: f64) -> Feeds {
        Feeds { fed_mm, e_only: None, e_word: EWord::None }
    }
}

/// Where the change was: the file's unretraction after it, already made at the new place.
impl PurgeShift {
    /// Before a line that reads E as `e_word` says: the `G92 E` owed since an E was taken out
    /// (none if the line resets E itself), as text.
    pub(super) fn owed_e_reset(&mut self, e_word: EWord) -> Vec<u8> {
        let mut text = Vec::new();
        match (e_word, self.e_reset) {
            (EWord::Reset, Some(_)) => self.e_reset = None,
            (EWord::Reads, Some(e)) => {
                write_e_reset(&mut text, &super::fallback::FORMAT, e);
                text.push(b'\n');
                self.e_reset = None;
            }
            _ => {}
        }
        text
    }

    /// Holds lines the pass wrote (`\n`-separated `text`) as passed over by the walk, feeding
    /// `fed_mm` in all, numbered as the line `like` they stand for.
    pub(super) fn hold_text(
        &mut self,
        out: &mut dyn Write,
        text: &[u8],
        like: &RawLine<'_>,
        fed_mm: f64,
    ) -> io::Result<()> {
        for bytes in text.split(|&b| b == b'\n').filter(|l| !l.is_empty()) {
            let text = self.text.push(bytes, like.eol);
            let held =
                self.held(text, like.number, Kind::Other(Feeds::written(fed_mm)), None, Feature::Unknown);
            self.push(out, held)?;
        }
        Ok(())
    }

    /// After a moved change the new tool has already unretracted what the file's unretraction
    /// after the travel feeds (the tool_retraction module): E-only forward feeds give up to
    /// `owed_mm`. A line feeding otherwise (an extrusion, a retraction), a change or the end of
    /// the print proper gets the rest first, as a retraction of the new tool. Returns whether
    /// the line was written (taken out or replaced).
    pub(super) fn absorb(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write, feeds: Feeds) -> io::Result<bool> {
        let fed_mm = feeds.fed_mm;
        let in_print = ctx.state.structure.region == Region::Print;
        if let Some(e) = feeds.e_only.filter(|_| fed_mm > 0.0 && in_print) {
            let taken_mm = fed_mm.min(self.owed_mm);
            self.owed_mm = if self.owed_mm - taken_mm < EPS_E_MM { 0.0 } else { self.owed_mm - taken_mm };
            let left_mm = fed_mm - taken_mm;
            let text = e.feeding(ctx.line.bytes, left_mm);
            if e.relative_e || left_mm < EPS_E_MM {
                self.hold_text(out, &text, &ctx.line, left_mm)?;
                if !e.relative_e {
                    self.e_reset = Some(e.e_after());
                }
                return Ok(true);
            }
            // Absolute E, part of it fed: the `G92` before the line, which then follows as it is.
            let reset = text.split(|&b| b == b'\n').next().unwrap_or_default().to_vec();
            self.hold_text(out, &reset, &ctx.line, 0.0)?;
            self.e_reset = None;
            return Ok(false);
        }
        let feeds = match ctx.effect {
            Effect::Move(m) => m.e_mm() != 0.0,
            Effect::FirmwareRetract { .. } => true,
            _ => false,
        };
        if feeds || !in_print {
            self.settle_owed(ctx, out)?;
        }
        Ok(false)
    }

    /// The rest of the unretraction the new tool made at the new place, retracted before the
    /// line `ctx` (the file's unretraction after the change was shorter than that).
    pub(super) fn settle_owed(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> io::Result<()> {
        let mut before = self.spot_here(ctx.state);
        if let Effect::Move(m) = ctx.effect {
            before.start.pos[3] = m.from[crate::gcode::state::E];
        }
        let [retract, restore] = self.owed_retraction(&before);
        self.hold_text(out, &retract, &ctx.line, -self.owed_mm)?;
        self.owed_mm = 0.0;
        self.hold_text(out, &restore, &ctx.line, 0.0)
    }

    /// The lines retracting what is still owed at `spot` (the module's `settle_owed`), after
    /// the `G92 E` owed if a line was taken out (their E words are the file's).
    pub(super) fn owed_retraction(&mut self, spot: &Spot) -> [Vec<u8>; 2] {
        let [mut retract, restore] =
            write_bracket(spot, -self.owed_mm, 0.0, self.rules.block.retract_feed_mm_min);
        retract.splice(0..0, self.owed_e_reset(EWord::Reads));
        [retract, restore]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_usual_slicer_change_moves_its_retraction_and_unretraction() {
        // PrusaSlicer: `G1 E-10` before `T0`, T0 parked with 10 mm, the change split into an
        // extrusion (nothing retracted there): the file's `G1 E-10` and T0's `G1 E10` after the
        // travel are taken out, what feeds is the same 10 mm each way at the new place.
        let b = |old_mm, new_mm, settle_mm, dropped_mm, absorbed_mm| Bracket {
            old_mm,
            new_mm,
            settle_mm,
            dropped_mm,
            absorbed_mm,
        };
        assert_eq!(Bracket::new(0.0, 10.0, 10.0, 10.0), b(-10.0, 10.0, 0.0, 10.0, 10.0));
        // The first change to a tool never used: it has nothing to unretract, and the file's
        // 10 mm retraction is the one made at the new place.
        assert_eq!(Bracket::new(0.0, 10.0, 0.0, 10.0), b(-10.0, 0.0, 0.0, 10.0, 0.0));
        // A wipe retracted 0.5 mm of the 10 along XY (kept: the new tool wipes now), 9.5 mm
        // E-only taken out: the new tool unretracts only those 0.5 mm after the travel.
        assert_eq!(Bracket::new(0.0, 10.0, 10.0, 9.5), b(-10.0, 10.0, 0.0, 9.5, 9.5));
        // Nothing E-only to take out (a lift-and-retract), a tool never used: the new tool
        // feeds back where the change was what the moved lines retracted.
        assert_eq!(Bracket::new(0.0, 10.0, 0.0, 0.0), b(-10.0, 0.0, 10.0, 0.0, 0.0));
    }

    /// Regression: the feed rate was restored after the inserted moves even when they had just
    /// set it (`G1 E-10 F2400`, then `G1 F2400`, after a slicer's own retraction at F2400).
    #[test]
    fn the_feed_rate_is_restored_only_when_the_moves_changed_it() {
        use crate::post::purge_block::PurgeStart;
        let spot = |feed_mm_min, rapid_mode| Spot {
            start: PurgeStart {
                pos: [0.0, 0.0, 0.2, 5.0],
                absolute_xyz: true,
                relative_e: true,
                feed_mm_min,
                rapid_mode,
                retracted_mm: 0.0,
            },
            inches: false,
        };
        let text = |parts: [Vec<u8>; 2]| parts.map(|p| String::from_utf8(p).unwrap());
        assert_eq!(text(write_bracket(&spot(2400.0, false), 0.0, 10.0, 2400.0)), ["", "G1 E10 F2400\n"]);
        assert_eq!(
            text(write_bracket(&spot(1800.0, false), -10.0, 10.0, 2400.0)),
            ["G1 E-10 F2400\n", "G1 E10 F2400\nG1 F1800\n"]
        );
        // G0 modal in the file: the mode is put back, with its feed rate.
        assert_eq!(
            text(write_bracket(&spot(2400.0, true), 0.0, 10.0, 2400.0)),
            ["", "G1 E10 F2400\nG0 F2400\n"]
        );
    }
}
