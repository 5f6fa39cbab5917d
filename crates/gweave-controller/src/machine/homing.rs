//! `G28`: finding the origin with the endstops.
//!
//! A stepper motor knows only how many steps it made, not where it is: at power-on the
//! position is unknown. Homing drives each axis towards its endstop (a switch at the minimum of
//! its travel) until the switch closes, which defines position 0. As Marlin does
//! (`Marlin/src/module/motion.cpp`, `homeaxis`), each axis goes in three moves:
//! 1. towards the endstop at the homing speed, at most 1.5 times the axis' travel (the axis may
//!    start anywhere); the step interrupt ends the move the moment the switch reads triggered;
//! 2. back off the bump distance (5 mm for X and Y, 2 mm for Z), so the switch opens again;
//! 3. towards it again at half speed: the switch is met more gently, so the place it closes at
//!    is repeatable to a step or two.
//!
//! A bump distance of 0 leaves out moves 2 and 3: the first touch is the origin.
//!
//! The axes home one after the other in the settings' order (by default Z, Y, X, the
//! controller document's order; Marlin homes X, Y, Z), each only if named on the line, all
//! three if none is.
//!
//! A move towards the endstop that ends without the switch closing (unplugged, broken, or the
//! axis stalled) is a failure: the position is unknown and the next moves could crash the
//! head. As Marlin's `validate_homing_move`, the board says `Error:Homing Failed` and halts.

use super::Controller;
use crate::gcode::words::Words;
use crate::math::round_i32;
use crate::{AXIS_LETTERS, X, Y, Z};

/// Where a `G28` is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Homing {
    /// Axes still to home (bits).
    axes: u8,
    /// The step of the current axis: 0 not started, 1 approaching, 2 backing off, 3 bumping.
    phase: u8,
}

impl Homing {
    /// The axes named on the line, or all three.
    pub(super) fn new(w: &Words) -> Homing {
        let named = [X, Y, Z].iter().filter(|&&a| w.has(AXIS_LETTERS[a])).fold(0u8, |m, &a| m | 1 << a);
        Homing { axes: if named == 0 { 1 << X | 1 << Y | 1 << Z } else { named }, phase: 0 }
    }

    /// Called when the machine is still: queues the next move; returns `Ok(true)` when every
    /// axis is home, `Err(())` when a move towards the endstop ended without reaching it.
    pub(super) fn next(&mut self, c: &mut Controller<'_>) -> Result<bool, ()> {
        let order = c.settings.homing_order.map(usize::from);
        let Some(&axis) = order.iter().find(|&&a| a <= Z && self.axes & (1 << a) != 0) else {
            // Every axis home (an order that leaves one out never homes it).
            return Ok(true);
        };
        // Phases 1 and 3 drove towards the endstop: the switch must have closed.
        if matches!(self.phase, 1 | 3) && !c.queue.endstop_hit() {
            return Err(());
        }
        let s = c.settings;
        let feed_mm_s = s.homing_feed_mm_s[axis];
        // Moves relative to where the axis is taken to be now.
        let go = |c: &mut Controller<'_>, mm: f32, feed_mm_s: f32, stop_at_endstop: bool| {
            let mut target = c.planner.position_steps;
            target[axis] = target[axis].saturating_add(round_i32(mm * s.steps_per_mm[axis]));
            c.queue.clear_endstop_hit();
            c.planner.add(target, feed_mm_s, if stop_at_endstop { 1 << axis } else { 0 }, &s, &mut c.mixer);
        };
        self.phase += 1;
        // Without a bump distance the first touch is the origin: there is nothing to back off
        // (Marlin's `homeaxis` skips both moves when `HOMING_BUMP_MM` is 0).
        if self.phase == 2 && round_i32(s.homing_bump_mm[axis] * s.steps_per_mm[axis]) == 0 {
            self.phase = 4;
        }
        match self.phase {
            1 => go(c, -1.5 * s.travel_mm[axis], feed_mm_s, true),
            2 => go(c, s.homing_bump_mm[axis], feed_mm_s, false),
            3 => go(c, -2.0 * s.homing_bump_mm[axis], feed_mm_s / 2.0, true),
            _ => {
                // At the endstop: this is 0.
                c.position_mm[axis] = 0.0;
                c.planner.position_steps[axis] = 0;
                c.soft_endstops.homed(axis);
                self.axes &= !(1 << axis);
                self.phase = 0;
                return Ok(self.axes == 0);
            }
        }
        Ok(false)
    }
}
