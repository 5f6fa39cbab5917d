//! Software endstops: a move never takes X, Y or Z past the machine's travel once the axis is
//! homed.
//!
//! The endstop switches sit at the minimum of each axis and are only looked at while homing:
//! during a print nothing stops a carriage driven past either end of its rail but the frame, and
//! a stepper that keeps pushing there grinds its belt, skips steps (every later layer shifts) or
//! drives the nozzle into the bed. Once homing has found where an axis' 0 is, the firmware
//! knows where the rail ends (`travel_mm` further), so, as Marlin does with its default
//! `MIN_SOFTWARE_ENDSTOPS` and `MAX_SOFTWARE_ENDSTOPS` (`Marlin/src/module/motion.cpp`,
//! `apply_motion_limits`), each target is clamped into that range before it is planned: the
//! move goes as far as the rail allows, silently, and the position becomes the clamped one (a
//! later relative move counts from there). An axis not homed since power-on is not clamped: its
//! 0 is wherever the carriage stood, and the limits would mean nothing.
//!
//! `G92` renames the position without moving: the rail's ends keep their place, so they are
//! renamed with it (Marlin's position shift). `M211 S0` switches the clamping off (a machine
//! whose travel is set too short), `M211 S1` back on; `M211` alone reports it in Marlin 2.1's
//! words (`M211_report`), with the limits in the coordinates in force:
//!
//! ```text
//!   M211 S1 ; ON
//!   Min:  X0.00 Y0.00 Z0.00   Max:  X200.00 Y200.00 Z200.00
//! ```

use crate::serial::out::{line, Reply};
use crate::{Io, AXES, AXIS_LETTERS, Z};

/// The software endstops' state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SoftEndstops {
    /// Whether moves are clamped (`M211 S`; on at power-on).
    enabled: bool,
    /// Axes homed since power-on (bit `1 << axis`).
    homed: u8,
    /// Where each axis' minimum (its endstop) is in the coordinates in force, mm: 0 after
    /// homing, moved by `G92`.
    min_mm: [f32; 3],
}

impl SoftEndstops {
    /// Power-on: on, nothing homed.
    pub(super) const fn new() -> SoftEndstops {
        SoftEndstops { enabled: true, homed: 0, min_mm: [0.0; 3] }
    }

    /// `axis` was homed: its endstop is position 0.
    pub(super) fn homed(&mut self, axis: usize) {
        self.homed |= 1 << axis;
        self.min_mm[axis] = 0.0;
    }

    /// `G92` named the position `to_mm` of `axis`, which was `from_mm`: the ends of the rail are
    /// renamed by as much.
    pub(super) fn renamed(&mut self, axis: usize, from_mm: f32, to_mm: f32) {
        if axis <= Z {
            self.min_mm[axis] += to_mm - from_mm;
        }
    }

    /// `M211 S`: clamping on or off.
    pub(super) fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// Clamps the target `position_mm` into each homed axis' travel (`travel_mm`, from its
    /// endstop; a travel of 0, not given, is not clamped).
    pub(super) fn clamp(&self, position_mm: &mut [f32; AXES], travel_mm: &[f32; AXES]) {
        if !self.enabled {
            return;
        }
        for axis in 0..=Z {
            if self.homed & (1 << axis) != 0 && travel_mm[axis] > 0.0 {
                let min = self.min_mm[axis];
                position_mm[axis] = position_mm[axis].max(min).min(min + travel_mm[axis]);
            }
        }
    }

    /// `M211`'s report, as Marlin 2.1 words it: its state as the line that sets it, then the
    /// limits.
    pub(super) fn report(&self, io: &mut impl Io, travel_mm: &[f32; AXES]) {
        line(io, if self.enabled { b"  M211 S1 ; ON" } else { b"  M211 S0 ; OFF" });
        let mut r = Reply::new();
        // The minima, then the maxima, in one loop: each float written is an AVR call, and an
        // unrolled loop of them was 800 bytes of flash.
        for i in 0..6 {
            let axis = i % 3;
            if axis == 0 {
                r.s(if i == 0 { b"  Min: " } else { b"   Max: " });
            }
            let end_mm = if i < 3 { self.min_mm[axis] } else { self.min_mm[axis] + travel_mm[axis] };
            r.s(&[b' ', AXIS_LETTERS[axis]]).f2(end_mm);
        }
        r.send(io);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_homed_axes_are_clamped_into_their_travel() {
        let travel = [200.0, 180.0, 150.0, 0.0];
        let mut s = SoftEndstops::new();
        let mut p = [250.0, -5.0, 400.0, 900.0];
        s.clamp(&mut p, &travel);
        assert_eq!(p, [250.0, -5.0, 400.0, 900.0], "nothing homed");
        s.homed(0);
        s.homed(1);
        s.clamp(&mut p, &travel);
        assert_eq!(p, [200.0, 0.0, 400.0, 900.0], "X and Y, not Z nor E");
        s.set_enabled(false);
        let mut q = [-1.0, 181.0, 0.0, 0.0];
        s.clamp(&mut q, &travel);
        assert_eq!(q, [-1.0, 181.0, 0.0, 0.0], "M211 S0");
    }

    #[test]
    fn g92_renames_the_ends_of_the_rail_with_the_position() {
        // Homed, at X 50; `G92 X0` there: the rail now runs from X -50 to X 150.
        let travel = [200.0, 200.0, 200.0, 0.0];
        let mut s = SoftEndstops::new();
        s.homed(0);
        s.renamed(0, 50.0, 0.0);
        let mut p = [-80.0, 0.0, 0.0, 0.0];
        s.clamp(&mut p, &travel);
        assert_eq!(p[0], -50.0);
        p[0] = 170.0;
        s.clamp(&mut p, &travel);
        assert_eq!(p[0], 150.0);
    }
}
