//! The retraction in force, and so the filament that really leaves the nozzle: the one tracker
//! behind `gweave stats`'s filament count and the passes that insert moves (a purge block, a
//! fallback purge), which must neither retract twice nor leave the nozzle empty.
//!
//! Filament fed backwards is a retraction, whether the nozzle stands (`G1 E-0.8`), lifts
//! (`G1 Z0.6 E-0.8`) or wipes along XY while it retracts (PrusaSlicer's wipe): it is pulled
//! back into the nozzle, not printed. Filament fed forwards first refills what is retracted
//! (the prime that undoes the retraction pushes nothing out); only the rest leaves the nozzle,
//! whether the nozzle moves (an extrusion) or stands (a purge, a prime line's blob). So a
//! retraction and the prime that undoes it cancel, and a stationary purge counts. Firmware
//! retraction (`G10`/`G11`) is followed the same way.

use crate::gcode::number::NumberFormat;
use crate::gcode::state::{Effect, Move, X, Y};

/// Follows the retraction in force over the moves of a file.
#[derive(Debug, Clone, Copy, Default)]
pub struct Retraction {
    in_force_mm: f64,
}

impl Retraction {
    /// Whether `mv` moves only filament: E changes, X and Y do not.
    pub fn moves_filament_only(mv: &Move) -> bool {
        mv.e_mm() != 0.0 && mv.to[X] == mv.from[X] && mv.to[Y] == mv.from[Y]
    }

    /// Follows `fed_mm` of filament fed (negative: retracted) by a move, a firmware retraction
    /// or recovery, the move's own E unless the pass rewrote it. Returns what left the nozzle,
    /// mm: the feed beyond the retraction in force, which it undoes first.
    #[inline]
    pub fn feed(&mut self, fed_mm: f64) -> f64 {
        if fed_mm < 0.0 {
            self.in_force_mm -= fed_mm;
            0.0
        } else if self.in_force_mm == 0.0 {
            // Most moves of a print: extrusion with nothing retracted (`stats`'s hot path).
            fed_mm
        } else {
            let refill = fed_mm.min(self.in_force_mm);
            self.in_force_mm -= refill;
            fed_mm - refill
        }
    }

    /// Follows the filament a line feeds: a move's E, or a firmware retraction or recovery
    /// (`G10`/`G11`, which the firmware does with E the file never names). Returns what left
    /// the nozzle, mm.
    pub fn follow(&mut self, effect: &Effect) -> f64 {
        match effect {
            Effect::Move(mv) => self.feed(mv.e_mm()),
            Effect::FirmwareRetract { e_mm } => self.feed(*e_mm),
            _ => 0.0,
        }
    }

    /// Part of the retraction was taken out of the output (a dropped tool-change retraction).
    pub fn withdraw(&mut self, mm: f64) {
        self.in_force_mm = (self.in_force_mm - mm).max(0.0);
    }

    /// The retraction in force, mm.
    pub fn in_force_mm(&self) -> f64 {
        self.in_force_mm
    }
}

/// Tools whose parked retraction is remembered by [`ToolRetractions`] (a file naming more keeps
/// the first ones; a tool beyond them comes back with nothing retracted).
const PARKED_TOOLS: usize = 256;

/// The one nozzle's retraction in force and, as the slicer sees it (a nozzle per tool), each
/// tool's: the tracker of the passes that rewrite tool changes (`mix`, `purge-shift`).
///
/// A slicer ends a tool with its tool-change retraction and unretracts a tool only if that tool
/// retracted, so on one nozzle the retraction in force is the nozzle's, but what the next line
/// will undo is the tool's. Each line is fed to the nozzle and to the active tool; a change of
/// tool parks the active tool's retraction and takes back what the new one parked. The active
/// tool is kept apart, so the common line (an extrusion, no change of tool) pays one comparison
/// for the tool, not a map lookup.
#[derive(Debug, Clone, Default)]
pub struct ToolRetractions {
    nozzle: Retraction,
    tool: u32,
    active: Retraction,
    /// The retraction each tool left in force when it was put away, mm.
    parked: Vec<(u32, f64)>,
}

impl ToolRetractions {
    /// Makes `tool` the active one (its parked retraction back in force).
    #[inline]
    fn select(&mut self, tool: u32) {
        if tool != self.tool {
            self.switch(tool);
        }
    }

    #[cold]
    fn switch(&mut self, tool: u32) {
        let (old, mm) = (self.tool, self.active.in_force_mm());
        if let Some((_, parked)) = self.parked.iter_mut().find(|(t, _)| *t == old) {
            *parked = mm;
        } else if self.parked.len() < PARKED_TOOLS {
            self.parked.push((old, mm));
        }
        self.active = Retraction { in_force_mm: self.parked_mm(tool) };
        self.tool = tool;
    }

    /// What `tool` (not the active one) parked, mm.
    fn parked_mm(&self, tool: u32) -> f64 {
        self.parked.iter().find(|(t, _)| *t == tool).map_or(0.0, |&(_, mm)| mm)
    }

    /// Follows one line run by `tool` (the filament its effect feeds, [`Retraction::follow`]).
    #[inline]
    pub fn follow(&mut self, tool: u32, effect: &Effect) {
        self.select(tool);
        let fed_mm = match effect {
            Effect::Move(mv) => mv.e_mm(),
            Effect::FirmwareRetract { e_mm } => *e_mm,
            _ => return,
        };
        self.feed(tool, fed_mm);
    }

    /// Follows `fed_mm` of filament fed by `tool` (negative: retracted), on the nozzle and for
    /// the tool.
    #[inline]
    pub fn feed(&mut self, tool: u32, fed_mm: f64) {
        self.select(tool);
        self.nozzle.feed(fed_mm);
        self.active.feed(fed_mm);
    }

    /// A prime a pass wrote of `mm`: the nozzle is that much less retracted (no tool will undo
    /// it).
    pub fn refill_nozzle(&mut self, mm: f64) {
        self.nozzle.feed(mm);
    }

    /// Part of `tool`'s retraction was taken out of the output (a dropped tool-change
    /// retraction): the nozzle's and the tool's.
    pub fn withdraw(&mut self, tool: u32, mm: f64) {
        self.nozzle.withdraw(mm);
        self.select(tool);
        self.active.withdraw(mm);
    }

    /// The nozzle's retraction in force, mm.
    pub fn nozzle_mm(&self) -> f64 {
        self.nozzle.in_force_mm()
    }

    /// The retraction in force of the tool that ran the last line followed, mm.
    pub fn active_mm(&self) -> f64 {
        self.active.in_force_mm()
    }

    /// `tool`'s retraction in force, mm (what it parked, if it is not the active one).
    pub fn tool_mm(&self, tool: u32) -> f64 {
        if tool == self.tool {
            self.active.in_force_mm()
        } else {
            self.parked_mm(tool)
        }
    }
}

/// `G92 E<e>` (file units, at least 5 decimals), no line ending: after E-only moves a pass
/// inserted or took out (a purge block, a moved or dropped tool-change retraction), E is put
/// back where the file has it, so the file's next E words mean what they meant.
pub(crate) fn write_e_reset(out: &mut Vec<u8>, fmt: &NumberFormat, e: f64) {
    out.extend_from_slice(b"G92 E");
    fmt.write(out, e, fmt.extrusion_decimals.max(5));
}

/// `G0`/`G1` (`rapid`) with the E word `fed` and the feed rate `feed_mm_min` (written exactly,
/// [`write_exact_feed`]) each if given, no line ending: an E-only move a pass writes, or, without
/// `fed`, the feed rate (and motion mode) a line it took out had set, which the next lines rely on.
pub(crate) fn write_e_only(
    out: &mut Vec<u8>,
    fmt: &NumberFormat,
    rapid: bool,
    fed: Option<f64>,
    feed_mm_min: Option<f64>,
) {
    out.extend_from_slice(if rapid { b"G0" } else { b"G1" });
    if let Some(e) = fed {
        out.push(b' ');
        fmt.write_word(out, b'E', e);
    }
    if let Some(f) = feed_mm_min {
        out.push(b' ');
        write_exact_feed(out, fmt, f);
    }
}

/// Appends `F<feed>` for a feed rate being restored: with at least 3 decimals whatever the
/// number format, since the lines after it rely on exactly the feed rate the file set.
pub(crate) fn write_exact_feed(out: &mut Vec<u8>, fmt: &NumberFormat, feed_mm_min: f64) {
    out.push(b'F');
    fmt.write(out, feed_mm_min, fmt.feed_decimals.max(3));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retractions_and_their_primes_cancel_and_the_rest_leaves_the_nozzle() {
        let mut r = Retraction::default();
        // Retract 0.6 while wiping and 0.2 standing: 0.8 in force, nothing printed.
        assert_eq!(r.feed(-0.6) + r.feed(-0.2), 0.0);
        assert!((r.in_force_mm() - 0.8).abs() < 1e-12);
        // A partial prime refills the nozzle, pushing nothing out.
        assert_eq!(r.feed(0.5), 0.0);
        assert!((r.in_force_mm() - 0.3).abs() < 1e-12);
        // A prime with an extra 0.2: only the extra leaves the nozzle.
        assert!((r.feed(0.5) - 0.2).abs() < 1e-12);
        assert_eq!(r.in_force_mm(), 0.0);
        // A stationary purge with nothing retracted is all printed.
        assert_eq!(r.feed(25.0), 25.0);
        r.feed(-2.0);
        r.withdraw(1.5);
        assert!((r.in_force_mm() - 0.5).abs() < 1e-12);
        assert_eq!(r.feed(0.5), 0.0);
    }

    #[test]
    fn each_tool_keeps_its_own_retraction_across_changes() {
        use crate::gcode::state::{Path, Position, E};
        let e = |e_mm: f64| {
            let from = Position::default();
            let mut to = from;
            to[E] = e_mm;
            Effect::Move(Move { from, to, path: Path::Line, rapid: false, feed_mm_min: 0.0 })
        };
        let mut t = ToolRetractions::default();
        t.follow(0, &e(-10.0));
        assert_eq!((t.active_mm(), t.nozzle_mm()), (10.0, 10.0));
        t.follow(1, &Effect::None);
        assert_eq!((t.active_mm(), t.tool_mm(0), t.nozzle_mm()), (0.0, 10.0, 10.0));
        t.follow(1, &e(-4.0));
        t.follow(0, &Effect::None);
        assert_eq!((t.active_mm(), t.tool_mm(1), t.nozzle_mm()), (10.0, 4.0, 14.0));
        t.follow(0, &e(10.0));
        assert_eq!((t.active_mm(), t.nozzle_mm()), (0.0, 4.0));
        t.follow(1, &Effect::None);
        assert_eq!(t.active_mm(), 4.0);
        // A dropped retraction of tool 0 (not the active one) leaves tool 1's alone.
        t.feed(0, -3.0);
        t.withdraw(0, 2.0);
        assert_eq!((t.tool_mm(0), t.tool_mm(1), t.nozzle_mm()), (1.0, 4.0, 5.0));
        // A prime a pass wrote refills the nozzle only.
        t.refill_nozzle(5.0);
        assert_eq!((t.tool_mm(0), t.tool_mm(1), t.nozzle_mm()), (1.0, 4.0, 0.0));
    }
}
