//! The motion planner: turns requested straight moves into blocks with trapezoidal speed
//! profiles, looking ahead over the queued moves so that corners and short moves slow the
//! machine down only as much as the limits require.
//!
//! Two planners imitate two firmwares, and a third the controller seed (chosen by
//! [`CornerMode`]):
//! - [`CornerMode::Klipper`]: Klipper's lookahead, reproduced closely enough that print times
//!   agree with Klipper's own to well under 0.01 % (see `klipper.rs` for the method);
//! - [`CornerMode::Marlin`]: Marlin's planner in whole steps, junction deviation or classic
//!   jerk, over its bounded block buffer; print times agree with Marlin's own planner to
//!   0.01 % (see `marlin.rs`);
//! - [`CornerMode::Constant`]: no acceleration, each move at its feed on its dominant motor,
//!   timed in whole steps as the seed's delay-per-step loop runs (see `constant.rs`).
//!
//! All stream: [`Planner::push`] hands finished blocks to a [`BlockSink`] as soon as their
//! speeds are final and the queue stays bounded (Marlin: `lookahead_blocks`; Klipper: about a
//! second of motion), so a file of any size plans in constant memory.
//! [`Planner::flush`] plans the rest to a stop, for the end of the file or a dwell
//! (G4, M400, M109, ...).
//!
//! ```
//! use gweave_sim::{Move, Pos};
//! use gweave_sim::{KlipperLimits, MotionProfile};
//! use gweave_sim::{PlannedBlock, Planner};
//!
//! let mut planner = Planner::new(MotionProfile::klipper(KlipperLimits::default())).unwrap();
//! let mut blocks: Vec<PlannedBlock> = Vec::new();
//! let mv = Move { start: Pos::default(), end: Pos::xyze(100.0, 0.0, 0.0, 0.0), feed_mm_s: 50.0, tag: 7 };
//! planner.push(&mv, &mut blocks).unwrap();
//! planner.flush(&mut blocks);
//! assert_eq!(blocks.len(), 1);
//! // 0 -> 50 mm/s at 3000 mm/s^2 and back: 2 x 1/60 s, 100 - 2 x 0.41667 mm at 50 mm/s.
//! assert!((blocks[0].trapezoid.duration_s() - (2.0 / 60.0 + (100.0 - 2.5 / 3.0) / 50.0)).abs() < 1e-12);
//! ```

mod constant;
mod junction;
mod klipper;
mod marlin;
mod marlin_block;
mod marlin_position;
mod marlin_steps;
mod trapezoid;

pub use marlin_position::PositionSet;
pub(crate) use trapezoid::Trapezoid;

use crate::motion::kinematics::{extent, Geometry, Move, MoveError, MoveKind, Pos};
use crate::motion::limits::{CornerMode, MotionProfile, ProfileError};
use klipper::KlipperLookahead;
use marlin::MarlinBuffer;

/// A planned block: one move with its final speeds and phase times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedBlock {
    /// The tag of the move it came from.
    pub tag: u64,
    /// Start position (the origin for a sink that reads no positions:
    /// `BlockSink::reads_positions`).
    pub start: Pos,
    /// End position (for a move without XYZ travel, XYZ stay at the start; the origin for a
    /// sink that reads no positions).
    pub end: Pos,
    /// The length the speeds refer to: XYZ mm, or A degrees / E mm for moves without XYZ.
    pub len: f64,
    /// The acceleration used, in the same length unit per s².
    pub accel_mm_s2: f64,
    /// What the move drives.
    pub kind: MoveKind,
    /// Speeds and times.
    pub trapezoid: Trapezoid,
}

impl PlannedBlock {
    fn new(mv: &Move, (len, kind): (f64, MoveKind), accel_mm_s2: f64, trapezoid: Trapezoid) -> Self {
        Self { tag: mv.tag, start: mv.start, end: Self::end_of(mv, kind), len, accel_mm_s2, kind, trapezoid }
    }

    /// Where the block ends: for a move without XYZ travel, XYZ stay at the start.
    #[inline(always)]
    pub(super) fn end_of(mv: &Move, kind: MoveKind) -> Pos {
        let mut end = mv.end;
        if kind != MoveKind::Kinematic {
            (end.x_mm, end.y_mm, end.z_mm) = (mv.start.x_mm, mv.start.y_mm, mv.start.z_mm);
        }
        end
    }

    /// Time the block takes, s.
    pub fn duration_s(&self) -> f64 {
        self.trapezoid.duration_s()
    }
}

/// The smaller of two speeds or accelerations, in one `minsd`. `f64::min` also sorts out NaN,
/// which costs a few instructions per call and showed in the planner's profile; a planned
/// move's numbers are never NaN (its positions and feed rate are checked finite first).
pub(crate) trait Lesser {
    fn lesser(self, other: f64) -> f64;
}

impl Lesser for f64 {
    #[inline(always)]
    fn lesser(self, other: f64) -> f64 {
        if self < other {
            self
        } else {
            other
        }
    }
}

/// The larger of two numbers in one `maxsd`, for the same reason as [`Lesser`]: Marlin's step
/// trapezoid takes a few maxima a block (rates held to `MINIMAL_STEP_RATE`, step counts to 0).
pub(crate) trait Greater {
    fn greater(self, other: f64) -> f64;
}

impl Greater for f64 {
    #[inline(always)]
    fn greater(self, other: f64) -> f64 {
        if self > other {
            self
        } else {
            other
        }
    }
}

/// Receives planned blocks in order. Closures `FnMut(&PlannedBlock)` and `Vec<PlannedBlock>` are
/// sinks.
pub trait BlockSink {
    /// One more block, in execution order.
    fn block(&mut self, block: &PlannedBlock);

    /// Whether this sink reads a block's [`PlannedBlock::start`] and [`PlannedBlock::end`]:
    /// one that keeps only time (`estimate` without step counts) says no, and Klipper's
    /// planner then leaves them at the origin instead of keeping each move's positions. A
    /// sink gives the same answer for the whole run of a planner.
    fn reads_positions(&self) -> bool {
        true
    }
}

impl<F: FnMut(&PlannedBlock)> BlockSink for F {
    fn block(&mut self, block: &PlannedBlock) {
        self(block)
    }
}

impl BlockSink for Vec<PlannedBlock> {
    fn block(&mut self, block: &PlannedBlock) {
        self.push(*block)
    }
}

#[derive(Debug, Clone)]
enum Engine {
    Klipper(Box<KlipperLookahead>),
    Marlin(Box<MarlinBuffer>),
    /// Constant speed keeps no queue: each move's block is final as it arrives.
    Constant,
}

/// A streaming lookahead planner for one machine profile.
#[derive(Debug, Clone)]
pub struct Planner {
    profile: MotionProfile,
    engine: Engine,
}

impl Planner {
    /// A planner for `profile`, which is checked first.
    pub fn new(profile: MotionProfile) -> Result<Self, ProfileError> {
        profile.validate()?;
        let engine = match &profile.corners {
            CornerMode::Klipper(k) => Engine::Klipper(Box::new(KlipperLookahead::new(k))),
            CornerMode::Marlin { .. } => Engine::Marlin(Box::default()),
            CornerMode::Constant {} => Engine::Constant,
        };
        Ok(Self { profile, engine })
    }

    /// The profile in force.
    pub fn profile(&self) -> &MotionProfile {
        &self.profile
    }

    /// Replace the profile mid-stream (M201, M203, M204, M205, `SET_VELOCITY_LIMIT`): moves
    /// pushed from now on use it, queued moves keep their limits, as in both firmwares. The
    /// corner mode (Marlin, Klipper or constant) cannot change.
    pub fn set_profile(&mut self, profile: MotionProfile) -> Result<(), ProfileError> {
        Self::check_change(&self.profile, &profile)?;
        self.profile = profile;
        match (&mut self.engine, &self.profile.corners) {
            (Engine::Marlin(m), _) => m.profile_changed(),
            (Engine::Klipper(k), CornerMode::Klipper(limits)) => k.set_limits(limits),
            _ => {}
        }
        Ok(())
    }

    /// Whether a planner running `current` would take `next` ([`Planner::set_profile`]'s rule),
    /// for a caller that keeps its own copy of the profile.
    pub fn check_change(current: &MotionProfile, next: &MotionProfile) -> Result<(), ProfileError> {
        next.validate()?;
        let same_mode = matches!(
            (&current.corners, &next.corners),
            (CornerMode::Klipper(_), CornerMode::Klipper(_))
                | (CornerMode::Marlin { .. }, CornerMode::Marlin { .. })
                | (CornerMode::Constant {}, CornerMode::Constant {})
        );
        if same_mode {
            Ok(())
        } else {
            Err(ProfileError::ModeChange)
        }
    }

    /// Queue a move; blocks whose speeds became final go to `sink`. A move that goes nowhere is
    /// dropped, as both firmwares do.
    pub fn push<S: BlockSink>(&mut self, mv: &Move, sink: &mut S) -> Result<(), MoveError> {
        let delta = mv.checked_delta()?;
        let (len, kind) = extent(&delta);
        if len == 0.0 {
            return Ok(());
        }
        // Marlin's planner measures the move in its own steps: the ratios are not worked out.
        match (&mut self.engine, &self.profile.corners) {
            (Engine::Klipper(k), CornerMode::Klipper(limits)) => {
                let rotary = (&self.profile.max_feed_mm_s, &self.profile.max_accel_mm_s2);
                k.push(mv, Geometry::with_extent(delta, len, kind), limits, rotary, sink);
            }
            (Engine::Marlin(m), CornerMode::Marlin { .. }) => m.push(mv, (len, kind), &self.profile, sink),
            (Engine::Constant, CornerMode::Constant {}) => {
                let geo = Geometry::with_extent(delta, len, kind);
                sink.block(&constant::block(mv, &geo, &self.profile.steps))
            }
            _ => unreachable!("set_profile keeps the corner mode of the engine"),
        }
        Ok(())
    }

    /// The logical position became `pos` without a move (`G92`, homing). Marlin's planner
    /// keeps its position in whole steps and changes it as the firmware does (`G92 E` takes E
    /// afresh and leaves X Y Z their steps; `G92 X` shifts the origin; homing takes every axis
    /// afresh: see `marlin_position.rs`); Klipper's (`klippy/extras/gcode_move.py`: `G92` only
    /// moves the G-code offsets) and the constant-speed planner measure each move on its own,
    /// and need nothing.
    pub fn set_position(&mut self, pos: Pos, by: PositionSet) {
        if let Engine::Marlin(m) = &mut self.engine {
            m.set_position(pos, by, &self.profile);
        }
    }

    /// Moves from now on drive extruder `tool` (`T<n>`): in Marlin mode with its own E limits,
    /// if the profile gives it some (`extruders`).
    pub fn select_tool(&mut self, tool: usize) {
        if let Engine::Marlin(m) = &mut self.engine {
            m.select_tool(tool);
        }
    }

    /// Plan every queued move to a stop and emit it.
    pub fn flush<S: BlockSink>(&mut self, sink: &mut S) {
        match &mut self.engine {
            Engine::Klipper(k) => k.flush(sink),
            Engine::Marlin(m) => m.flush(sink),
            Engine::Constant => {}
        }
    }

    /// Drops every queued move unexecuted (an emergency stop: Marlin's `quick_stop()`,
    /// Klipper's shutdown): returns how far they would have moved each axis, X Y Z E A, so
    /// that the caller can take its position back to where the emitted blocks left the
    /// machine. A block already emitted has run.
    pub fn discard(&mut self) -> [f64; 5] {
        match &mut self.engine {
            Engine::Klipper(k) => k.discard(),
            Engine::Marlin(m) => m.discard(),
            Engine::Constant => [0.0; 5],
        }
    }

    /// How many moves wait in the lookahead queue.
    pub fn queued(&self) -> usize {
        match &self.engine {
            Engine::Klipper(k) => k.queued(),
            Engine::Marlin(m) => m.queued(),
            Engine::Constant => 0,
        }
    }
}

#[cfg(test)]
mod tests;
