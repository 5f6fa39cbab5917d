//! The Marlin planner's position, in whole steps per motor, and what re-sets it.
//!
//! Marlin plans every block from its own position in whole steps (`Planner::position`,
//! `Marlin/src/module/planner.cpp`): a block moves each motor by `lround(target *
//! steps_per_mm)` less that position, and a block of fewer than `MIN_STEPS_PER_SEGMENT` steps
//! is dropped without moving the position, so its distance goes with the next block. What
//! takes the position afresh, as Marlin 2.x does it (`Marlin/src/gcode/geometry/G92.cpp`,
//! `Marlin/src/module/motion.cpp`):
//!
//! - `G92 E<e>` calls `sync_plan_position_e`, that is `Planner::set_e_position_mm`: E alone is
//!   set to `lround(e * steps_per_mm)`. X, Y and Z keep their steps, those of a dropped move
//!   included (before this module, every axis was rounded afresh, and the steppers lost the
//!   dropped move's X and Y steps at every `G92 E0`).
//! - `G92 X/Y/Z/A`, with workspace offsets (Marlin's default, `NO_WORKSPACE_OFFSETS` unset),
//!   changes only the named axes' `position_shift`: the machine does not move, and neither do
//!   the planner's steps; later targets are `logical - shift`, rounded from there (in single
//!   precision, as Marlin's floats). A firmware built with `NO_WORKSPACE_OFFSETS` calls
//!   `sync_plan_position` there instead and rounds every axis afresh; that build is not
//!   modelled.
//! - An axis given the value it has is left alone (`NEAR_ZERO(d)`): `G92 E0` at E0 changes
//!   nothing.
//! - Homing (`G28`): `set_axis_is_at_home` clears the homed axes' shift and
//!   `sync_plan_position` takes every axis, E included, afresh from the current position.
//!
//! These come as events ([`PositionSet`]) from whoever read the line: a move that starts
//! elsewhere than the last one ended without one (a caller of [`super::Planner::push`] that
//! reports no re-sets) has every axis taken afresh, as after homing.

use super::marlin_block::Settings;
use crate::motion::kinematics::{axis, Pos};
use crate::motion::rounding::round_i64;

/// What set the logical position without a move, for a planner that keeps whole steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PositionSet {
    /// `G92`: the axes whose value changed are the ones it named.
    G92,
    /// Homing the axes of `axes` (bit i: axis i of X Y Z).
    Home {
        /// Bit i: axis i homed.
        axes: u8,
    },
}

/// Marlin's `NEAR_ZERO`: a `G92` value this close to the axis' position changes nothing, mm.
const NEAR_ZERO_MM: f64 = 0.000_001;

/// The planner's position: whole steps in machine (native) coordinates, and the logical
/// positions the blocks are reported in.
#[derive(Debug, Clone, Default)]
pub(super) struct StepPosition {
    /// Whole steps per motor, X Y Z E A.
    pub(super) steps: [f64; 5],
    /// `position_shift` per axis, mm (degrees for A): native = logical - shift, in single
    /// precision as Marlin keeps it. E's stays 0 (E has no workspace offset).
    shift: [f32; 5],
    /// Where the last block made ended (the start of the next block), logical.
    pub(super) block_end: Pos,
    /// Where the last move pushed ended, logical: Marlin's `current_position`.
    last_end: Pos,
    /// The E steps per mm `steps[E]` is in.
    e_steps_per_mm: f64,
}

impl StepPosition {
    /// The E position in the steps of the extruder `set` drives: another extruder with other
    /// E steps rescales it, as Marlin's `buffer_segment` does.
    #[inline(always)]
    pub(super) fn use_settings(&mut self, set: &Settings) {
        let e_steps_per_mm = set.steps_per_unit[axis::E];
        if e_steps_per_mm != self.e_steps_per_mm && self.e_steps_per_mm > 0.0 {
            self.steps[axis::E] =
                round_i64(self.steps[axis::E] * e_steps_per_mm / self.e_steps_per_mm) as f64;
        }
        self.e_steps_per_mm = e_steps_per_mm;
    }

    /// The whole steps of logical position `pos`.
    #[inline(always)]
    pub(super) fn steps_at(&self, pos: Pos, set: &Settings) -> [f64; 5] {
        set.steps_at(pos, &self.shift)
    }

    /// A move from `start` to `end` is about to be planned. A start elsewhere than the last
    /// move's end, with no [`PositionSet`] reported, takes every axis afresh.
    #[inline(always)]
    pub(super) fn moving(&mut self, start: Pos, end: Pos, set: &Settings) {
        if self.last_end != start {
            self.steps = self.steps_at(start, set);
            self.block_end = start;
        }
        self.last_end = end;
    }

    /// The logical position became `pos` without a move.
    pub(super) fn set(&mut self, pos: Pos, by: PositionSet, set: &Settings) {
        match by {
            PositionSet::G92 => self.g92(pos, set),
            PositionSet::Home { axes } => {
                for (i, shift) in self.shift.iter_mut().enumerate().take(3) {
                    if axes & (1 << i) != 0 {
                        *shift = 0.0;
                    }
                }
                self.steps = self.steps_at(pos, set);
                self.block_end = pos;
            }
        }
        self.last_end = pos;
    }

    /// `G92`: E is taken afresh in whole steps; the other axes move their origin, and the
    /// logical start of the next block with it.
    fn g92(&mut self, pos: Pos, set: &Settings) {
        let (was, now) = (self.last_end.to_array(), pos.to_array());
        let mut block_end = self.block_end.to_array();
        for i in 0..5 {
            let change = now[i] - was[i];
            if change.abs() <= NEAR_ZERO_MM {
                continue;
            }
            if i == axis::E {
                self.steps[i] = self.steps_at(pos, set)[i];
                block_end[i] = now[i];
            } else {
                let native = was[i] as f32 - self.shift[i];
                self.shift[i] = now[i] as f32 - native;
                block_end[i] += change;
            }
        }
        self.block_end = Pos::from_array(block_end);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::limits::MotionProfile;

    /// 80 steps/mm on X and Y, 500 on E.
    fn settings() -> Settings {
        Settings::new(&MotionProfile::default(), 0)
    }

    /// The planner after a block to X10 E1 (800 and 500 steps) and a move on to X10.05
    /// E1.01 (4 X and 5 E steps, under `MIN_STEPS_PER_SEGMENT`: dropped, the steps stay).
    fn after_dropped_move(set: &Settings) -> StepPosition {
        let mut at = StepPosition::default();
        at.use_settings(set);
        let (block_end, dropped_end) = (Pos::xyze(10.0, 0.0, 0.0, 1.0), Pos::xyze(10.05, 0.0, 0.0, 1.01));
        at.moving(Pos::default(), block_end, set);
        at.steps = at.steps_at(block_end, set);
        at.block_end = block_end;
        at.moving(block_end, dropped_end, set);
        at
    }

    #[test]
    fn g92_e_keeps_the_x_steps_of_a_dropped_move() {
        let set = settings();
        let mut at = after_dropped_move(&set);
        at.set(Pos::xyze(10.05, 0.0, 0.0, 0.0), PositionSet::G92, &set);
        // E alone is taken afresh; X stays at 800 steps, so the next block to X20 takes the
        // dropped move's 4 steps with its own 796.
        assert_eq!(at.steps, [800.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(at.block_end, Pos::xyze(10.0, 0.0, 0.0, 0.0));
        assert_eq!(at.steps_at(Pos::xyze(20.0, 0.0, 0.0, 1.0), &set), [1600.0, 0.0, 0.0, 500.0, 0.0]);
    }

    #[test]
    fn g92_x_shifts_the_origin_and_keeps_every_step() {
        let set = settings();
        let mut at = after_dropped_move(&set);
        at.set(Pos::xyze(0.0, 0.0, 0.0, 1.01), PositionSet::G92, &set);
        // Nothing is rounded afresh: X10 is now native X20.05, 1604 steps from home.
        assert_eq!(at.steps, [800.0, 0.0, 0.0, 500.0, 0.0]);
        assert!((at.block_end.x_mm - -0.05).abs() < 1e-6, "{:?}", at.block_end);
        assert_eq!(at.steps_at(Pos::xyze(10.0, 0.0, 0.0, 2.0), &set), [1604.0, 0.0, 0.0, 1000.0, 0.0]);
    }

    #[test]
    fn homing_takes_every_axis_afresh_and_clears_its_shift() {
        let set = settings();
        let mut at = after_dropped_move(&set);
        at.set(Pos::xyze(0.0, 0.0, 0.0, 1.01), PositionSet::G92, &set);
        at.set(Pos::xyze(0.0, 0.0, 0.0, 1.01), PositionSet::Home { axes: 0b001 }, &set);
        assert_eq!(at.steps, [0.0, 0.0, 0.0, 505.0, 0.0]);
        assert_eq!(at.steps_at(Pos::xyze(10.0, 0.0, 0.0, 1.01), &set), [800.0, 0.0, 0.0, 505.0, 0.0]);
    }

    #[test]
    fn g92_to_the_value_an_axis_has_changes_nothing() {
        let set = settings();
        let mut at = after_dropped_move(&set);
        at.set(Pos::xyze(10.05, 0.0, 0.0, 1.01), PositionSet::G92, &set);
        // E is not rounded afresh to 505 steps: the dropped move's 5 E steps stay pending too.
        assert_eq!(at.steps, [800.0, 0.0, 0.0, 500.0, 0.0]);
        assert_eq!(at.block_end, Pos::xyze(10.0, 0.0, 0.0, 1.0));
    }
}
