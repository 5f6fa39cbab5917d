//! Marlin's planner buffer (`Marlin/src/module/planner.cpp`: `Planner::recalculate`,
//! `reverse_pass`, `forward_pass`, `recalculate_trapezoids`), in whole steps as the firmware
//! plans (see `marlin_block.rs` for how a move becomes a block, `marlin_steps.rs` for its
//! step trapezoid and time, `marlin_position.rs` for the position in whole steps and what
//! `G92` and homing do to it).
//!
//! The ring buffer has `lookahead_blocks` slots and, like any ring buffer that tells full
//! from empty by its two indices, holds one block less. A new move waits for a free slot: when
//! the buffer is full the oldest block leaves first, with its speeds final (the firmware's
//! stepper takes it while the host keeps the buffer full). After each new block a reverse pass
//! (from `MINIMUM_PLANNER_SPEED` at the end of the buffer) and a forward pass set every entry
//! speed: `entry_v2 <= exit_v2 + 2 a len` backwards, `<= entry_v2_prev + 2 a len_prev`
//! forwards. The oldest block's entry speed is never changed: the block before it has already
//! left with that exit speed (or, on an empty buffer, the machine stands still).

use super::marlin_block::{populate, MarlinBlock, Previous, Settings, MINIMUM_PLANNER_SPEED};
use super::marlin_position::{PositionSet, StepPosition};
use super::marlin_steps::StepProfile;
use super::trapezoid::Trapezoid;
use super::{BlockSink, Lesser, PlannedBlock};
use crate::motion::kinematics::{deltas, extent, Move, MoveKind, Pos};
use crate::motion::limits::MotionProfile;

const MIN_V2: f64 = MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED;

#[derive(Debug, Clone, Copy)]
struct Block {
    /// The entry allowed by the reverse pass alone (braking for everything after it).
    reverse_v2: f64,
    entry_v2: f64,
    /// `2 a len`, the squared speed the block gains accelerating over its whole length (or
    /// loses braking): the entry of the next block is at most `entry_v2 + gain_v2`, the entry
    /// of this one at most `exit_v2 + gain_v2`. Infinite for a block of "nominal length" (one
    /// long enough to brake from its nominal speed to a stop, Marlin's
    /// `BLOCK_BIT_NOMINAL_LENGTH`), for which Marlin skips both checks on the grounds that the
    /// next block cannot enter faster than this one's nominal speed: true under junction
    /// deviation, not always under classic jerk, whose "safe speed" at a junction may exceed
    /// the previous block's nominal speed (a slow Z hop followed by a fast travel). Then the
    /// block is left faster than it runs, as in the firmware. Worked out once, so that each
    /// pass is one add and one `minsd` a block without a branch: the same numbers as the
    /// passes worked out each time before (`(2 a) len`, and `x + inf = inf` where they skipped
    /// the check).
    gain_v2: f64,
    b: MarlinBlock,
    /// The move, from the end of the last block made (dropped moves before it included), and
    /// its length and kind along the path.
    mv: Move,
    geo: (f64, MoveKind),
}

/// The queued blocks and how far they are planned.
#[derive(Debug, Clone, Default)]
struct Queue {
    /// The queued blocks, oldest first, are `blocks[head..]`: a slice rather than a ring, so
    /// that the passes run over contiguous memory without wrapping an index per block. The
    /// blocks already emitted before `head` are dropped in one move once there are as many of
    /// them as blocks queued (each block is moved at most once on average).
    blocks: Vec<Block>,
    head: usize,
    /// The queued blocks whose entry speed is final, counted from the oldest (which always is):
    /// `blocks[head..][..=planned]`. Marlin's `block_buffer_planned`, see [`Queue::replan`].
    planned: usize,
}

/// The Marlin planner buffer.
#[derive(Debug, Clone, Default)]
pub(crate) struct MarlinBuffer {
    queue: Queue,
    prev: Previous,
    /// The planner position in whole steps, and where the last block ended.
    at: StepPosition,
    /// The extruder moves drive.
    tool: usize,
    /// The settings in force, taken from the profile at the first move after a change.
    settings: Option<Settings>,
}

impl MarlinBuffer {
    pub(crate) fn queued(&self) -> usize {
        self.queue.len()
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

    /// Queue `mv`, whose length and kind along the path are `geo` (the planner measured them
    /// already: see `extent`).
    pub(crate) fn push(
        &mut self,
        mv: &Move,
        geo: (f64, MoveKind),
        profile: &MotionProfile,
        sink: &mut dyn BlockSink,
    ) {
        // Borrowed, not copied: the settings are some 250 bytes, and a move's work a few
        // hundred instructions.
        let set = self.settings.get_or_insert_with(|| Settings::new(profile, self.tool));
        self.at.use_settings(set);
        self.at.moving(mv.start, mv.end, set);
        let target = self.at.steps_at(mv.end, set);
        let delta = std::array::from_fn(|i| target[i] - self.at.steps[i]);
        if self.queue.len() + 1 >= set.buffer_size {
            self.queue.emit_front(sink);
        }
        // A move of fewer than MIN_STEPS_PER_SEGMENT steps is dropped: the position stays,
        // so its distance goes with the next move.
        let Some(b) = populate(delta, mv.feed_mm_s, self.queue.len(), set, &mut self.prev) else {
            return;
        };
        self.at.steps = target;
        // After a dropped move the block starts where the last block ended, not where `mv`
        // does: measured afresh.
        let block_end = self.at.block_end;
        let geo = if block_end == mv.start { geo } else { extent(&deltas(block_end, mv.end)) };
        let mv = Move { start: block_end, ..*mv };
        self.at.block_end = mv.end;
        let gain_v2 = if b.nominal_length { f64::INFINITY } else { 2.0 * b.accel * b.mm };
        self.queue.push(Block { reverse_v2: -1.0, entry_v2: MIN_V2, gain_v2, b, mv, geo });
    }

    /// The logical position became `pos` without a move (`G92`, homing): the planner's steps
    /// change as Marlin's do (see `marlin_position.rs`).
    pub(crate) fn set_position(&mut self, pos: Pos, by: PositionSet, profile: &MotionProfile) {
        let set = self.settings.get_or_insert_with(|| Settings::new(profile, self.tool));
        self.at.use_settings(set);
        self.at.set(pos, by, set);
    }

    /// Drops every queued block unexecuted, as `Planner::quick_stop()` empties the buffer and
    /// forgets the previous block's speed (the machine stands). Returns how far the blocks
    /// would have moved each axis, X Y Z E A. The position in steps stays where the last
    /// block would have ended: the next move, starting where the machine stopped, takes every
    /// axis afresh, as `set_current_from_steppers_for_axis` and `sync_plan_position` do after
    /// a quick stop.
    pub(crate) fn discard(&mut self) -> [f64; 5] {
        let mut undone = [0.0; 5];
        for block in &self.queue.blocks[self.queue.head..] {
            for (sum, d) in undone.iter_mut().zip(deltas(block.mv.start, block.mv.end)) {
                *sum += d;
            }
        }
        self.queue = Queue::default();
        self.prev = Previous::default();
        undone
    }

    /// Plan the rest of the buffer to a stop and emit it.
    pub(crate) fn flush(&mut self, sink: &mut dyn BlockSink) {
        while self.queue.len() > 0 {
            self.queue.emit_front(sink);
        }
    }
}

impl Queue {
    fn len(&self) -> usize {
        self.blocks.len() - self.head
    }

    /// Append a block and plan the queue again.
    fn push(&mut self, block: Block) {
        if block.b.max_entry_v2 < MIN_V2 {
            // A junction slower than the exit the passes assume for the last block: the
            // reverse limits of the blocks before it fall, and what was final is no longer.
            self.planned = 0;
            self.blocks[self.head..].iter_mut().for_each(|q| q.reverse_v2 = -1.0);
        }
        self.blocks.push(block);
        self.replan();
    }

    /// The reverse and forward passes over the buffer, from the first block whose entry can
    /// still change.
    ///
    /// Appending a block only raises the reverse limits before it (the last block's exit
    /// goes from `MINIMUM_PLANNER_SPEED` to that block's entry limit, which `push` checks is
    /// no lower). So an entry that is final stays final: the oldest block's (it is leaving),
    /// and that of a block after a final one whose entry is its junction limit
    /// (`max_entry_v2`, which the reverse limit never exceeds) or what the block before
    /// reaches by accelerating over its length (a growing reverse limit no longer matters).
    /// Those blocks are `queue[..=planned]`, as Marlin's `block_buffer_planned` and GRBL's
    /// `block_buffer_planned` mark them, and the passes skip them. The reverse pass also stops
    /// at the first block whose reverse limit did not change (nothing before it changes
    /// either), and the forward pass starts there.
    fn replan(&mut self) {
        let queue = &mut self.blocks[self.head..];
        let n = queue.len();
        let mut first_changed = self.planned + 1;
        let mut exit_v2 = MIN_V2;
        for i in (self.planned + 1..n).rev() {
            let q = &mut queue[i];
            let reverse_v2 = q.b.max_entry_v2.lesser(exit_v2 + q.gain_v2);
            if reverse_v2 == q.reverse_v2 {
                first_changed = i + 1;
                break;
            }
            q.reverse_v2 = reverse_v2;
            exit_v2 = reverse_v2;
        }
        let Some(before) = first_changed.checked_sub(1).and_then(|i| queue.get(i)) else {
            return;
        };
        let mut reach_v2 = before.entry_v2 + before.gain_v2;
        for q in queue.iter_mut().skip(first_changed) {
            q.entry_v2 = q.reverse_v2.lesser(reach_v2);
            reach_v2 = q.entry_v2 + q.gain_v2;
        }
        while let [before, q, ..] = &queue[self.planned..] {
            if q.entry_v2 != q.b.max_entry_v2 && q.entry_v2 != before.entry_v2 + before.gain_v2 {
                break;
            }
            self.planned += 1;
        }
    }

    /// Takes the oldest block out of the buffer and hands it to `sink` with its step
    /// trapezoid.
    fn emit_front(&mut self, sink: &mut dyn BlockSink) {
        let queue = &self.blocks[self.head..];
        // Read in place: a block is some 200 bytes.
        let Some(Block { mv, b, entry_v2, geo: (geo_len, kind), .. }) = queue.first() else {
            return;
        };
        let exit_v2 = queue.get(1).map_or(MIN_V2, |next| next.entry_v2);
        // Speed over nominal speed, in single precision as Marlin's `recalculate_trapezoids`.
        let inverse_nominal = 1.0 / (b.nominal_v2 as f32).sqrt();
        let factor = |v2: f64| (v2 as f32).sqrt() * inverse_nominal;
        let steps =
            StepProfile::new(b.steps, b.nominal_rate, b.accel_steps, factor(*entry_v2), factor(exit_v2));
        // The speeds along the path: Marlin's length, unless it measured a tiny XYZ move along
        // E; the times are the steps' either way.
        let len = if b.xyz_below_min_steps && *kind == MoveKind::Kinematic { *geo_len } else { b.mm };
        let mm_per_step = len / b.steps;
        let trapezoid = Trapezoid {
            entry_v_mm_s: steps.initial_rate * mm_per_step,
            cruise_v_mm_s: steps.cruise_rate * mm_per_step,
            exit_v_mm_s: steps.final_rate * mm_per_step,
            accel_t_s: steps.accel_t_s,
            cruise_t_s: steps.cruise_t_s,
            decel_t_s: steps.decel_t_s,
        };
        sink.block(&PlannedBlock::new(mv, (*geo_len, *kind), b.accel, trapezoid));
        self.head += 1;
        self.planned = self.planned.saturating_sub(1);
        if self.head >= self.blocks.len() - self.head {
            self.blocks.drain(..self.head);
            self.head = 0;
        }
    }
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
                let geo = extent(&deltas(mv.start, mv.end));
                planner.push(&mv, geo, &profile, &mut sink);
                let mut full = planner.clone();
                let full = &mut full.queue;
                full.blocks.iter_mut().for_each(|b| b.reverse_v2 = -1.0);
                full.planned = 0;
                full.replan();
                let queue = &planner.queue.blocks[planner.queue.head..];
                for (a, b) in queue.iter().zip(&full.blocks[full.head..]) {
                    prop_assert_eq!(a.entry_v2, b.entry_v2);
                }
                at = to;
            }
        }
    }
}
