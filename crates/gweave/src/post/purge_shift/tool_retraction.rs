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
//!   where it was:      new tool feeds r_change - p_new
//! ```
//!
//! The old tool ends retracted by `r_change`, as in the file. The new tool starts the moved
//! lines with `r_place` in force, as the old tool did, so it feeds them exactly as the old tool
//! would have (the slicer's retraction among them: it becomes an ordinary travel retraction),
//! ends them with `r_change`, and the last feed brings it to `p_new`, which the file's own
//! unretraction after the change then undoes as it did before. With the usual slicer file
//! (`r_place = 0`, `r_change = p_new`) that is the file's retraction and unretraction moved with
//! the change and nothing where it was. Lines between two moved places see every tool in the
//! state they had in the input: per-tool totals are the input's, moved purge apart.

use std::collections::HashMap;

use super::fallback::Spot;
use crate::gcode::retraction::Retraction;
use crate::gcode::state::{Effect, MM_PER_INCH};
use crate::post::purge_block::write_exact_feed;

/// Tools whose parked retraction is remembered (a file naming more keeps the first ones; a tool
/// beyond them is taken as parked with nothing retracted).
const TOOLS: usize = 256;
/// Feeds below this are rounding remainders, not a retraction worth a line, mm.
const EPS_MM: f64 = 1e-6;

/// The retraction in force of every tool, following the input (each line fed by the tool that
/// is active there in the input).
#[derive(Debug, Default)]
pub(crate) struct ToolRetractions {
    tool: u32,
    active: Retraction,
    parked: HashMap<u32, f64>,
}

impl ToolRetractions {
    /// Follows one line of the input, run by `tool`.
    pub(super) fn follow(&mut self, tool: u32, effect: &Effect) {
        if tool != self.tool {
            let mm = self.active.in_force_mm();
            if self.parked.len() < TOOLS || self.parked.contains_key(&self.tool) {
                self.parked.insert(self.tool, mm);
            }
            self.active = Retraction::default();
            let new = self.parked.get(&tool).copied().unwrap_or(0.0);
            self.active.feed(-new);
            self.tool = tool;
        }
        self.active.follow(effect);
    }

    /// The active tool's retraction in force, mm.
    pub(super) fn in_force_mm(&self) -> f64 {
        self.active.in_force_mm()
    }
}

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
}

impl Bracket {
    /// The bracket for a change moved from where the old tool had `r_change_mm` retracted to
    /// where it had `r_place_mm`, the new tool having `p_new_mm` parked (the module's formula).
    pub(super) fn new(r_place_mm: f64, r_change_mm: f64, p_new_mm: f64) -> Self {
        Bracket {
            old_mm: -(r_change_mm - r_place_mm),
            new_mm: p_new_mm - r_place_mm,
            settle_mm: r_change_mm - p_new_mm,
        }
    }
}

/// The lines of a bracket at `spot`: the old tool's feed `old_mm` (before the change lines) and
/// the new tool's `new_mm` (after them), as E-only moves at `feed_mm_min` in the file's E mode
/// and units, the second part ending with the E and the feed rate the file has at `spot`
/// restored. `\n`-terminated lines; nothing when both feeds are below a micrometre.
pub(crate) fn write_bracket(spot: &Spot, old_mm: f64, new_mm: f64, feed_mm_min: f64) -> [Vec<u8>; 2] {
    let mut parts = [Vec::new(), Vec::new()];
    if old_mm.abs() < EPS_MM && new_mm.abs() < EPS_MM {
        return parts;
    }
    let fmt = super::fallback::FORMAT;
    let start = &spot.start;
    let unit = if spot.inches { MM_PER_INCH } else { 1.0 };
    if !start.relative_e {
        // E counted from 0 here, the file's E put back after: the lines do not depend on it.
        parts[0].extend_from_slice(b"G92 E0\n");
    }
    let mut e_mm = 0.0;
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
    if !start.relative_e {
        out.extend_from_slice(b"G92 E");
        fmt.write(out, start.pos[3] / unit, fmt.extrusion_decimals.max(5));
        out.push(b'\n');
    }
    if start.feed_mm_min > 0.0 {
        out.extend_from_slice(if start.rapid_mode { b"G0 " } else { b"G1 " });
        write_exact_feed(out, &fmt, start.feed_mm_min / unit);
        out.push(b'\n');
    }
    parts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_usual_slicer_change_moves_its_retraction_and_unretraction() {
        // PrusaSlicer: `G1 E-10` before `T0`, T0 parked with 10 mm, the change split into an
        // extrusion (nothing retracted there).
        assert_eq!(Bracket::new(0.0, 10.0, 10.0), Bracket { old_mm: -10.0, new_mm: 10.0, settle_mm: 0.0 });
        // The first change to a tool never used: it has nothing to unretract, so the moved
        // lines' 10 mm retraction is undone where the change was.
        assert_eq!(Bracket::new(0.0, 10.0, 0.0), Bracket { old_mm: -10.0, new_mm: 0.0, settle_mm: 10.0 });
    }

    #[test]
    fn each_tool_keeps_its_own_retraction_across_changes() {
        use crate::gcode::state::Move;
        let mut t = ToolRetractions::default();
        let e = |e_mm: f64| {
            let from: crate::gcode::state::Position = Default::default();
            let mut to = from;
            to[crate::gcode::state::E] = e_mm;
            Effect::Move(Move {
                from,
                to,
                path: crate::gcode::state::Path::Line,
                rapid: false,
                feed_mm_min: 0.0,
            })
        };
        t.follow(0, &e(-10.0));
        assert_eq!(t.in_force_mm(), 10.0);
        t.follow(1, &Effect::None);
        assert_eq!(t.in_force_mm(), 0.0);
        t.follow(1, &e(-4.0));
        t.follow(0, &Effect::None);
        assert_eq!(t.in_force_mm(), 10.0);
        t.follow(0, &e(10.0));
        assert_eq!(t.in_force_mm(), 0.0);
        t.follow(1, &Effect::None);
        assert_eq!(t.in_force_mm(), 4.0);
    }
}
