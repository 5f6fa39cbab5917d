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
}
