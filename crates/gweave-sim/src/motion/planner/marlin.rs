//! Marlin's planner buffer (`Marlin/src/module/planner.cpp`: `Planner::recalculate`,
//! `reverse_pass`, `forward_pass`, `recalculate_trapezoids`), in whole steps as the firmware
//! plans (see `marlin_block.rs` for how a move becomes a block, `marlin_steps.rs` for its
//! step trapezoid and time).
//!
//! The ring buffer has `lookahead_blocks` slots and, like any ring buffer that tells full
//! from empty by its two indices, holds one block less. A new move waits for a free slot: when
//! the buffer is full the oldest block leaves first, with its speeds final (the firmware's
//! stepper takes it while the host keeps the buffer full). After each new block a reverse pass
//! (from `MINIMUM_PLANNER_SPEED` at the end of the buffer) and a forward pass set every entry
//! speed: `entry_v2 <= exit_v2 + 2 a len` backwards, `<= entry_v2_prev + 2 a len_prev`
//! forwards. The oldest block's entry speed is never changed: the block before it has already
//! left with that exit speed (or, on an empty buffer, the machine stands still).

use std::collections::VecDeque;

use super::marlin_block::{populate, MarlinBlock, Previous, Settings, MINIMUM_PLANNER_SPEED};
use super::marlin_steps::StepProfile;
use super::trapezoid::Trapezoid;
use super::{BlockSink, Lesser, PlannedBlock};
use crate::motion::kinematics::{axis, deltas, extent, Move, MoveKind, Pos};
use crate::motion::limits::MotionProfile;
use crate::motion::rounding::round_i64;

const MIN_V2: f64 = MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED;

#[derive(Debug, Clone)]
struct Block {
    /// The move, from the end of the last block made (dropped moves before it included).
    mv: Move,
    b: MarlinBlock,
    /// The entry allowed by the reverse pass alone (braking for everything after it).
    reverse_v2: f64,
    entry_v2: f64,
}

impl Block {
    /// The highest entry speed the next block can get from this one: `entry_v2 + 2 a len`, or
    /// no limit for a block of "nominal length" (one long enough to brake from its nominal
    /// speed to a stop, Marlin's `BLOCK_BIT_NOMINAL_LENGTH`). Marlin skips the check for those
    /// on the grounds that the next block cannot enter faster than this one's nominal speed:
    /// true under junction deviation, not always under classic jerk, whose "safe speed" at a
    /// junction may exceed the previous block's nominal speed (a slow Z hop followed by a
    /// fast travel). Then the block is left faster than it runs, as in the firmware.
    fn reach_v2(&self) -> f64 {
        if self.b.nominal_length {
            f64::INFINITY
        } else {
            self.entry_v2 + 2.0 * self.b.accel * self.b.mm
        }
    }
}

/// The Marlin planner buffer.
#[derive(Debug, Clone, Default)]
pub(crate) struct MarlinBuffer {
    blocks: VecDeque<Block>,
    prev: Previous,
    /// The planner position, whole steps per axis.
    position: [f64; 5],
    /// Where the last block made ended (the start of the next block), and where the last move
    /// pushed ended: a move that starts elsewhere follows a `G92` or homing.
    block_end: Pos,
    last_end: Option<Pos>,
    /// The extruder moves drive, and the E steps per mm the position is in.
    tool: usize,
    e_steps_per_mm: f64,
    /// The settings in force, taken from the profile at the first move after a change.
    settings: Option<Settings>,
}

impl MarlinBuffer {
    pub(crate) fn queued(&self) -> usize {
        self.blocks.len()
    }

    /// Moves from now on drive extruder `tool`, with its own E limits if it has them.
    pub(crate) fn select_tool(&mut self, tool: usize) {
        if tool != self.tool {
            self.tool = tool;
            self.settings = None;
        }
    }

    /// The profile changed: the next move takes its settings afresh.
    pub(crate) fn profile_changed(&mut self) {
        self.settings = None;
    }

    pub(crate) fn push(&mut self, mv: &Move, profile: &MotionProfile, sink: &mut dyn BlockSink) {
        // Borrowed, not copied: the settings are some 250 bytes, and a move's work a few
        // hundred instructions.
        let set = self.settings.get_or_insert_with(|| Settings::new(profile, self.tool));
        let e_steps_per_mm = set.steps_per_unit[axis::E];
        if e_steps_per_mm != self.e_steps_per_mm && self.e_steps_per_mm > 0.0 {
            // Another extruder with other E steps: the E position in its steps, as Marlin's
            // `buffer_segment` rescales it.
            self.position[axis::E] =
                round_i64(self.position[axis::E] * e_steps_per_mm / self.e_steps_per_mm) as f64;
        }
        self.e_steps_per_mm = e_steps_per_mm;
        if self.last_end != Some(mv.start) {
            // Marlin's `set_position_mm`: every axis takes the new position, in whole steps.
            self.position = set.steps_at(mv.start);
            self.block_end = mv.start;
        }
        self.last_end = Some(mv.end);
        let target = set.steps_at(mv.end);
        let delta = std::array::from_fn(|i| target[i] - self.position[i]);
        if self.blocks.len() + 1 >= set.buffer_size {
            emit_front(&mut self.blocks, sink);
        }
        // A move of fewer than MIN_STEPS_PER_SEGMENT steps is dropped: the position stays,
        // so its distance goes with the next move.
        let Some(b) = populate(delta, mv.feed_mm_s, self.blocks.len(), set, &mut self.prev) else {
            return;
        };
        self.position = target;
        let mv = Move { start: self.block_end, ..*mv };
        self.block_end = mv.end;
        self.blocks.push_back(Block { mv, b, reverse_v2: -1.0, entry_v2: MIN_V2 });
        self.replan();
    }

    /// Plan the rest of the buffer to a stop and emit it.
    pub(crate) fn flush(&mut self, sink: &mut dyn BlockSink) {
        while !self.blocks.is_empty() {
            emit_front(&mut self.blocks, sink);
        }
    }

    /// The reverse and forward passes over the buffer, the oldest block excepted. The reverse
    /// pass stops at the first block whose reverse limit did not change (nothing before it can
    /// change either: Marlin's `block_buffer_planned`), and the forward pass starts there.
    fn replan(&mut self) {
        let n = self.blocks.len();
        let mut first_changed = 1.min(n);
        let mut exit_v2 = MIN_V2;
        for i in (1..n).rev() {
            let b = &mut self.blocks[i];
            let reverse_v2 = if b.b.nominal_length {
                b.b.max_entry_v2
            } else {
                b.b.max_entry_v2.lesser(exit_v2 + 2.0 * b.b.accel * b.b.mm)
            };
            if reverse_v2 == b.reverse_v2 {
                first_changed = i;
                break;
            }
            b.reverse_v2 = reverse_v2;
            exit_v2 = reverse_v2;
        }
        let Some(before) = first_changed.checked_sub(1).and_then(|i| self.blocks.get(i)) else {
            return;
        };
        let mut reach_v2 = before.reach_v2();
        for b in self.blocks.iter_mut().skip(first_changed) {
            b.entry_v2 = b.reverse_v2.lesser(reach_v2);
            reach_v2 = b.reach_v2();
        }
    }
}

/// Takes the oldest block out of the buffer and hands it to `sink` with its step trapezoid.
fn emit_front(blocks: &mut VecDeque<Block>, sink: &mut dyn BlockSink) {
    let Some(Block { mv, b, entry_v2, .. }) = blocks.pop_front() else {
        return;
    };
    let exit_v2 = blocks.front().map_or(MIN_V2, |next| next.entry_v2);
    // Speed over nominal speed, in single precision as Marlin's `recalculate_trapezoids`.
    let inverse_nominal = 1.0 / (b.nominal_v2 as f32).sqrt();
    let factor = |v2: f64| (v2 as f32).sqrt() * inverse_nominal;
    let steps = StepProfile::new(b.steps, b.nominal_rate, b.accel_steps, factor(entry_v2), factor(exit_v2));
    // The speeds along the path: Marlin's length, unless it measured a tiny XYZ move along
    // E; the times are the steps' either way.
    let (geo_len, kind) = extent(&deltas(mv.start, mv.end));
    let len = if b.xyz_below_min_steps && kind == MoveKind::Kinematic { geo_len } else { b.mm };
    let mm_per_step = len / b.steps;
    let trapezoid = Trapezoid {
        entry_v_mm_s: steps.initial_rate * mm_per_step,
        cruise_v_mm_s: steps.cruise_rate * mm_per_step,
        exit_v_mm_s: steps.final_rate * mm_per_step,
        accel_t_s: steps.accel_t_s,
        cruise_t_s: steps.cruise_t_s,
        decel_t_s: steps.decel_t_s,
    };
    sink.block(&PlannedBlock::new(&mv, (geo_len, kind), b.accel, trapezoid));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::kinematics::Pos;
    use proptest::prelude::*;

    proptest! {
        /// The early-stopping replan gives the same entry speeds as replanning everything.
        #[test]
        fn early_stop_equals_full_replan(
            steps in proptest::collection::vec((-5.0..5.0f64, -5.0..5.0f64, 5.0..200.0f64), 1..200),
            buffer in 3usize..40,
        ) {
            let mut profile = MotionProfile::default();
            if let crate::motion::limits::CornerMode::Marlin { lookahead_blocks, .. } = &mut profile.corners {
                *lookahead_blocks = buffer;
            }
            let mut planner = MarlinBuffer::default();
            let mut sink = |_: &PlannedBlock| {};
            let mut at = Pos::default();
            for (dx, dy, feed) in steps {
                let to = Pos::xyze(at.x_mm + dx, at.y_mm + dy, 0.0, at.e_mm + 0.1);
                let mv = Move { start: at, end: to, feed_mm_s: feed, tag: 0 };
                planner.push(&mv, &profile, &mut sink);
                let mut full = planner.clone();
                full.blocks.iter_mut().skip(1).for_each(|b| b.reverse_v2 = -1.0);
                full.replan();
                for (a, b) in planner.blocks.iter().zip(&full.blocks) {
                    prop_assert_eq!(a.entry_v2, b.entry_v2);
                }
                at = to;
            }
        }
    }
}
