//! The retraction in force: filament pulled back at the nozzle since the last extrusion, which
//! a pass inserting moves (a purge block, a fallback purge) must know so that it neither
//! retracts twice nor leaves the nozzle empty.
//!
//! A move that changes E without XY travel moves only filament: backwards it retracts, forwards
//! it undoes a retraction. Z may change in the same move (`G1 Z0.6 E-0.8`, a retraction with its
//! lift); an extrusion along XY ends any retraction.

use crate::gcode::state::{Move, X, Y};

/// Follows the retraction in force over the moves of a file.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Retraction {
    in_force_mm: f64,
}

impl Retraction {
    /// Whether `mv` moves only filament: E changes, X and Y do not.
    pub fn moves_filament_only(mv: &Move) -> bool {
        mv.e_mm() != 0.0 && mv.to[X] == mv.from[X] && mv.to[Y] == mv.from[Y]
    }

    /// Follows `mv`, of which the output feeds `fed_mm` (the move's own E unless the pass
    /// rewrote it). Undoing more than is retracted leaves none in force.
    pub fn observe(&mut self, mv: &Move, fed_mm: f64) {
        if mv.is_extruding() {
            self.in_force_mm = 0.0;
        } else if Self::moves_filament_only(mv) {
            self.in_force_mm = (self.in_force_mm - fed_mm).max(0.0);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::state::{Path, Position};

    fn mv(from: [f64; 4], to: [f64; 4]) -> Move {
        let pos = |p: [f64; 4]| {
            let mut q: Position = Default::default();
            q[..4].copy_from_slice(&p);
            q
        };
        Move { from: pos(from), to: pos(to), path: Path::Line, rapid: false, feed_mm_min: 1800.0 }
    }

    #[test]
    fn follows_retractions_lifts_and_extrusion() {
        let mut r = Retraction::default();
        // Retract 0.8 with a 0.4 mm lift in the same move, then 0.2 more.
        r.observe(&mv([10.0, 10.0, 0.2, 5.0], [10.0, 10.0, 0.6, 4.2]), -0.8);
        r.observe(&mv([10.0, 10.0, 0.6, 4.2], [10.0, 10.0, 0.6, 4.0]), -0.2);
        assert!((r.in_force_mm() - 1.0).abs() < 1e-12);
        // Travel and a pure Z move change nothing.
        r.observe(&mv([10.0, 10.0, 0.6, 4.0], [50.0, 10.0, 0.6, 4.0]), 0.0);
        r.observe(&mv([50.0, 10.0, 0.6, 4.0], [50.0, 10.0, 0.2, 4.0]), 0.0);
        assert!((r.in_force_mm() - 1.0).abs() < 1e-12);
        // A partial unretraction, then more than is left: none in force, never negative.
        r.observe(&mv([50.0, 10.0, 0.2, 4.0], [50.0, 10.0, 0.2, 4.7]), 0.7);
        assert!((r.in_force_mm() - 0.3).abs() < 1e-12);
        r.observe(&mv([50.0, 10.0, 0.2, 4.7], [50.0, 10.0, 0.2, 5.5]), 0.8);
        assert_eq!(r.in_force_mm(), 0.0);
        // An extrusion ends whatever is left.
        r.observe(&mv([50.0, 10.0, 0.2, 5.5], [50.0, 10.0, 0.2, 5.0]), -0.5);
        r.withdraw(0.2);
        assert!((r.in_force_mm() - 0.3).abs() < 1e-12);
        r.observe(&mv([50.0, 10.0, 0.2, 5.0], [60.0, 10.0, 0.2, 5.3]), 0.3);
        assert_eq!(r.in_force_mm(), 0.0);
    }
}
