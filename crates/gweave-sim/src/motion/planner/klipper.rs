//! Klipper's lookahead (`Klipper3d/klipper:klippy/toolhead.py`, `Move` and `LookAheadQueue`),
//! reproduced from its published behaviour so that print times agree with Klipper's own.
//!
//! Each move gets, when queued:
//! - `max_cruise_v2`: the requested speed capped by `max_velocity`, then by `limit_speed` from the
//!   Z axis (`max_z_velocity * len/|dz|`), from extrude-only and retract moves
//!   (`max_extrude_only_velocity / |e ratio|`) and from the rotary axis;
//! - `delta_v2 = 2 a len`, the most its squared speed can change over the move;
//! - `max_start_v2`: the junction limit with the previous move (see [`super::junction`]), also
//!   capped by both cruise speeds and by what the previous move can reach;
//! - for `minimum_cruise_ratio`, a second "smoothed" profile with the pseudo acceleration
//!   `a (1 - ratio)`: `mcr_delta_v2 = 2 a_mcr len` and `max_mcr_start_v2`.
//!
//! The flush walks the queue backwards from a stop at its end. `start_v2` is limited by the
//! junction and by what braking over this move allows. The smoothed profile finds the peaks of
//! each accelerate-then-decelerate run: a move that can accelerate in the smoothed profile ends
//! a run, and the peak `(mcr_start_v2 + reachable_mcr_v2) / 2` caps the cruise speed of every
//! move of that run. Moves that cannot accelerate take their cruise speed from the move before
//! them in a second, forward walk.
//!
//! Lazy flushing: while moves keep arriving, the queue is flushed only up to the start of the
//! last run whose peak is known, because a later move can raise only speeds after that point.
//! A lazy flush is tried whenever the queued moves (at their nominal speeds) add up to the flush
//! time: 1 s after a full flush, 0.15 s after any other flush. This bounds the queue to about
//! that much motion while giving the same speeds as planning the whole file at once.

use std::collections::VecDeque;

use super::junction::{extruder_v2, HalfAngle};
use super::{BlockSink, Lesser, PlannedBlock};
use crate::motion::kinematics::{axis, deltas, Geometry, Move, MoveKind, Pos};
use crate::motion::limits::{AxisLimits, KlipperLimits};
use crate::motion::planner::trapezoid::Trapezoid;

/// Queued motion after a full flush before the first lazy flush is tried (`BUFFER_TIME_HIGH`).
const FLUSH_AFTER_FULL_S: f64 = 1.0;
/// Queued motion between lazy flush attempts (`LOOKAHEAD_FLUSH_TIME`).
const FLUSH_AFTER_LAZY_S: f64 = 0.15;
/// The acceleration Klipper gives extrude-only moves before the extruder limits them.
const EXTRUDE_ONLY_ACCEL_MM_S2: f64 = 99_999_999.9;

/// One queued move with Klipper's planning quantities (squared speeds in (mm/s)^2). Of its
/// geometry it keeps what the junction with the next move and the block need: the length,
/// the kind and the X Y Z E ratios (the deltas and the rotary ratio are read once, in
/// [`KlipperLookahead::new_move`]): a queued move is copied in and out of the queue, and
/// walked again at each flush attempt. Its positions are kept apart, and only for a sink that
/// reads them ([`KlipperLookahead::ends`]): 120 bytes a move instead of 208.
#[derive(Debug, Clone)]
struct QueuedMove {
    /// The move's tag, for its block.
    tag: u64,
    len: f64,
    kind: MoveKind,
    /// `delta / len` of X Y Z E ([`Geometry::ratio`]).
    ratio: [f64; 4],
    accel: f64,
    junction_deviation_mm: f64,
    min_move_t: f64,
    max_start_v2: f64,
    max_cruise_v2: f64,
    delta_v2: f64,
    max_mcr_start_v2: f64,
    mcr_delta_v2: f64,
}

impl QueuedMove {
    /// `limit_speed`: lower the cruise speed and the acceleration of this move.
    #[inline(always)]
    fn limit_speed(&mut self, speed: f64, accel: f64) {
        let speed2 = speed * speed;
        if speed2 < self.max_cruise_v2 {
            self.max_cruise_v2 = speed2;
            self.min_move_t = self.len / speed;
        }
        self.accel = self.accel.lesser(accel);
        self.delta_v2 = 2.0 * self.len * self.accel;
        self.mcr_delta_v2 = self.mcr_delta_v2.lesser(self.delta_v2);
    }

    fn is_kinematic(&self) -> bool {
        self.kind == MoveKind::Kinematic
    }

    /// `calc_junction`: the highest entry speed allowed by the corner with `prev`.
    #[inline(always)]
    fn calc_junction(&mut self, prev: &QueuedMove, icv_mm_s: f64) {
        if !self.is_kinematic() || !prev.is_kinematic() {
            return;
        }
        let (r, pr) = (&self.ratio, &prev.ratio);
        let e_v2 = extruder_v2(icv_mm_s, pr[axis::E], r[axis::E]).unwrap_or(self.max_cruise_v2);
        let mut v2 = self
            .max_cruise_v2
            .lesser(prev.max_cruise_v2)
            .lesser(prev.max_start_v2 + prev.delta_v2)
            .lesser(e_v2);
        let half = HalfAngle::from_neg_cos(-(r[0] * pr[0] + r[1] * pr[1] + r[2] * pr[2]));
        if let (Some(jd_v2), Some(prev_jd_v2)) = (
            half.deviation_v2(self.accel, self.junction_deviation_mm),
            half.deviation_v2(prev.accel, prev.junction_deviation_mm),
        ) {
            v2 = v2
                .lesser(jd_v2)
                .lesser(prev_jd_v2)
                .lesser(half.centripetal_v2(self.delta_v2))
                .lesser(half.centripetal_v2(prev.delta_v2));
        }
        self.max_start_v2 = v2;
        self.max_mcr_start_v2 = v2.lesser(prev.max_mcr_start_v2 + prev.mcr_delta_v2);
    }

    /// The planned block, at `ends` (the move's start and the block's end, the origin for a
    /// sink that reads no positions).
    #[inline(always)]
    fn block(&self, entry_v2: f64, cruise_v2: f64, exit_v2: f64, [start, end]: [Pos; 2]) -> PlannedBlock {
        let trapezoid = Trapezoid::from_v2(self.len, self.accel, entry_v2, cruise_v2, exit_v2);
        PlannedBlock {
            tag: self.tag,
            start,
            end,
            len: self.len,
            accel_mm_s2: self.accel,
            kind: self.kind,
            trapezoid,
        }
    }
}

/// The result of the backward walk for one move: its start speed, its cruise speed when known
/// (`None` for a move that cannot accelerate), and the start speed of the move after it.
#[derive(Debug, Clone, Copy, Default)]
struct Walk {
    start_v2: f64,
    cruise_v2: Option<f64>,
    next_start_v2: f64,
}

/// Klipper's lookahead queue.
#[derive(Debug, Clone)]
pub(crate) struct KlipperLookahead {
    queue: VecDeque<QueuedMove>,
    /// The start of each queued move and the end of its block, in step with `queue`, kept only
    /// while the sink reads positions ([`BlockSink::reads_positions`]: a sink says the same for
    /// the whole run, as `estimate`'s time accounts and a `Vec` do).
    ends: VecDeque<[Pos; 2]>,
    walk: Vec<Walk>,
    flush_budget_s: f64,
    /// `max_z_velocity` / `max_z_accel` resolved against the limits at start, as Klipper reads
    /// them from the config once.
    z_velocity_mm_s: f64,
    z_accel_mm_s2: f64,
    /// The limits' [`KlipperLimits::junction_deviation_mm`] and
    /// [`KlipperLimits::mcr_pseudo_accel_mm_s2`], worked out when the limits are set
    /// ([`KlipperLookahead::set_limits`]) instead of at every move (a division a move).
    junction_deviation_mm: f64,
    mcr_accel_mm_s2: f64,
}

impl KlipperLookahead {
    pub(crate) fn new(limits: &KlipperLimits) -> Self {
        Self {
            queue: VecDeque::new(),
            ends: VecDeque::new(),
            walk: Vec::new(),
            flush_budget_s: FLUSH_AFTER_FULL_S,
            z_velocity_mm_s: limits.max_z_velocity_mm_s.unwrap_or(limits.max_velocity_mm_s),
            z_accel_mm_s2: limits.max_z_accel_mm_s2.unwrap_or(limits.max_accel_mm_s2),
            junction_deviation_mm: limits.junction_deviation_mm(),
            mcr_accel_mm_s2: limits.mcr_pseudo_accel_mm_s2(),
        }
    }

    /// The limits of the moves pushed from now on are `limits` (`SET_VELOCITY_LIMIT`); the Z
    /// limits stay those read at start, as Klipper reads them from its config once.
    pub(crate) fn set_limits(&mut self, limits: &KlipperLimits) {
        self.junction_deviation_mm = limits.junction_deviation_mm();
        self.mcr_accel_mm_s2 = limits.mcr_pseudo_accel_mm_s2();
    }

    pub(crate) fn queued(&self) -> usize {
        self.queue.len()
    }

    /// Queue a move (with its already checked geometry) and flush what is final. Never inlined
    /// into [`super::Planner::push`]: there `VecDeque::push_back` went out of line and copied
    /// each move with `memcpy` (+20 instructions a move), and whether the compiler did so
    /// changed with unrelated edits elsewhere in the crate (+47 a line in the guard build once).
    #[inline(never)]
    pub(crate) fn push<S: BlockSink + ?Sized>(
        &mut self,
        mv: &Move,
        geo: Geometry,
        limits: &KlipperLimits,
        rotary: (&AxisLimits, &AxisLimits),
        sink: &mut S,
    ) {
        if sink.reads_positions() {
            self.ends.push_back([mv.start, PlannedBlock::end_of(mv, geo.kind)]);
        }
        let mut q = self.new_move(mv, geo, limits, rotary);
        let Some(prev) = self.queue.back() else {
            self.queue.push_back(q);
            return;
        };
        q.calc_junction(prev, limits.instantaneous_corner_velocity_mm_s);
        self.flush_budget_s -= q.min_move_t;
        self.queue.push_back(q);
        if self.flush_budget_s <= 0.0 {
            self.flush_queue(true, sink);
        }
    }

    /// Drops every queued move unexecuted, as Klipper's emergency stop (`M112`) leaves the
    /// lookahead queue. Returns how far the moves would have moved each axis, X Y Z E A: from
    /// their positions, kept while the sink reads them (the virtual printer's does), else from
    /// their lengths along X Y Z E.
    pub(crate) fn discard(&mut self) -> [f64; 5] {
        let mut undone = [0.0; 5];
        if self.ends.len() == self.queue.len() {
            for [start, end] in &self.ends {
                for (sum, d) in undone.iter_mut().zip(deltas(*start, *end)) {
                    *sum += d;
                }
            }
        } else {
            for q in &self.queue {
                for (sum, r) in undone.iter_mut().zip(q.ratio) {
                    *sum += r * q.len;
                }
            }
        }
        self.queue.clear();
        self.ends.clear();
        self.flush_budget_s = FLUSH_AFTER_FULL_S;
        undone
    }

    /// Plan everything queued, ending at a stop.
    pub(crate) fn flush<S: BlockSink + ?Sized>(&mut self, sink: &mut S) {
        self.flush_queue(false, sink);
        self.flush_budget_s = FLUSH_AFTER_FULL_S;
    }

    /// `Move.__init__` plus the kinematics' and the extruder's `check_move`. Inlined, like
    /// the two above, so that the move is put together in registers and stored once, into
    /// the queue: a queued move is some 200 bytes, and each copy of it a call to `memcpy`.
    #[inline(always)]
    fn new_move(
        &self,
        mv: &Move,
        geo: Geometry,
        k: &KlipperLimits,
        (max_feed, max_accel): (&AxisLimits, &AxisLimits),
    ) -> QueuedMove {
        let kinematic = geo.kind == MoveKind::Kinematic;
        let (velocity, accel) = if kinematic {
            (mv.feed_mm_s.lesser(k.max_velocity_mm_s), k.max_accel_mm_s2)
        } else {
            (mv.feed_mm_s, EXTRUDE_ONLY_ACCEL_MM_S2)
        };
        let len = geo.len;
        let mut q = QueuedMove {
            tag: mv.tag,
            len,
            kind: geo.kind,
            ratio: [geo.ratio[axis::X], geo.ratio[axis::Y], geo.ratio[axis::Z], geo.ratio[axis::E]],
            accel,
            junction_deviation_mm: self.junction_deviation_mm,
            min_move_t: len / velocity,
            max_start_v2: 0.0,
            max_cruise_v2: velocity * velocity,
            delta_v2: 2.0 * len * accel,
            max_mcr_start_v2: 0.0,
            mcr_delta_v2: 2.0 * len * self.mcr_accel_mm_s2,
        };
        let d = geo.delta;
        if kinematic && d[axis::Z] != 0.0 {
            let z_ratio = len / d[axis::Z].abs();
            q.limit_speed(self.z_velocity_mm_s * z_ratio, self.z_accel_mm_s2 * z_ratio);
        }
        let e_ratio = geo.ratio[axis::E];
        let extrude_only_or_retract = (d[axis::X] == 0.0 && d[axis::Y] == 0.0) || e_ratio < 0.0;
        if d[axis::E] != 0.0 && extrude_only_or_retract {
            let inv = 1.0 / e_ratio.abs();
            let v = k.max_extrude_only_velocity_mm_s.map_or(f64::INFINITY, |v| v * inv);
            let a = k.max_extrude_only_accel_mm_s2.map_or(f64::INFINITY, |a| a * inv);
            q.limit_speed(v, a);
        }
        // The rotary axis, as one of Klipper's extra axes: its own speed and accel limits.
        let a_ratio = geo.ratio[axis::A].abs();
        if a_ratio > 0.0 {
            q.limit_speed(max_feed.a / a_ratio, max_accel.a / a_ratio);
        }
        q
    }

    /// The forward walk: the first `flush_count` queued moves to `sink`, at `ends` (their
    /// start and their block's end). Read in place, then dropped from the queue by the caller
    /// (no copy of each move on its way out).
    #[inline(always)]
    fn emit<S: BlockSink + ?Sized>(
        &self,
        flush_count: usize,
        ends: impl Iterator<Item = [Pos; 2]>,
        sink: &mut S,
    ) {
        let mut prev_cruise_v2: f64 = 0.0;
        for ((m, w), ends) in self.queue.iter().zip(&self.walk).zip(ends).take(flush_count) {
            let cruise_v2 = w.cruise_v2.unwrap_or_else(|| prev_cruise_v2.lesser(w.start_v2));
            let (entry_v2, exit_v2) = (w.start_v2.lesser(cruise_v2), w.next_start_v2.lesser(cruise_v2));
            sink.block(&m.block(entry_v2, cruise_v2, exit_v2, ends));
            prev_cruise_v2 = cruise_v2;
        }
    }

    /// `LookAheadQueue.flush`: the backward walk, then the forward walk over the moves that are
    /// final. A lazy flush emits nothing until a run's peak is known.
    fn flush_queue<S: BlockSink + ?Sized>(&mut self, lazy: bool, sink: &mut S) {
        self.flush_budget_s = FLUSH_AFTER_LAZY_S;
        let n = self.queue.len();
        self.walk.clear();
        self.walk.resize(n, Walk::default());
        let mut flush_count = n;
        let mut searching = lazy;
        let (mut next_start_v2, mut next_mcr_start_v2, mut peak_cruise_v2) = (0.0, 0.0, 0.0);
        let mut pending = 0usize;
        for i in (0..n).rev() {
            let m = &self.queue[i];
            let reachable_start_v2 = next_start_v2 + m.delta_v2;
            let start_v2 = m.max_start_v2.lesser(reachable_start_v2);
            let reachable_mcr_v2 = next_mcr_start_v2 + m.mcr_delta_v2;
            let mcr_start_v2 = m.max_mcr_start_v2.lesser(reachable_mcr_v2);
            pending += 1;
            let mut cruise_v2 = None;
            if mcr_start_v2 < reachable_mcr_v2 {
                // This move can accelerate. If it can also decelerate, or it is a full
                // acceleration followed by moves that only decelerate, it tops a run.
                if mcr_start_v2 + m.mcr_delta_v2 > next_mcr_start_v2 || pending > 1 {
                    if searching && peak_cruise_v2 != 0.0 {
                        flush_count = i + pending;
                        searching = false;
                    }
                    peak_cruise_v2 = (mcr_start_v2 + reachable_mcr_v2) * 0.5;
                }
                cruise_v2 = Some(
                    ((start_v2 + reachable_start_v2) * 0.5).lesser(m.max_cruise_v2).lesser(peak_cruise_v2),
                );
                pending = 0;
            }
            self.walk[i] = Walk { start_v2, cruise_v2, next_start_v2 };
            next_start_v2 = start_v2;
            next_mcr_start_v2 = mcr_start_v2;
        }
        if searching || flush_count == 0 {
            return;
        }
        // Two loops, with and without positions: one that looks up each move's ends cost 30
        // instructions a move more.
        let origin = [Pos::default(); 2];
        if sink.reads_positions() {
            debug_assert_eq!(self.ends.len(), n, "a sink that reads positions from the first move");
            let ends = self.ends.iter().copied().chain(std::iter::repeat(origin));
            self.emit(flush_count, ends, sink);
        } else {
            self.emit(flush_count, std::iter::repeat(origin), sink);
        }
        self.queue.drain(..flush_count);
        self.ends.drain(..flush_count.min(self.ends.len()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::limits::MotionProfile;
    use proptest::prelude::*;

    fn limits() -> KlipperLimits {
        KlipperLimits {
            max_extrude_only_velocity_mm_s: Some(40.0),
            max_extrude_only_accel_mm_s2: Some(900.0),
            ..KlipperLimits::default()
        }
    }

    /// Plan a path into `sink`; with `full` no lazy flush ever happens before the final flush.
    fn plan_into<S: BlockSink>(moves: &[Move], full: bool, sink: &mut S) {
        let limits = limits();
        let profile = MotionProfile::klipper(limits);
        let rotary = (&profile.max_feed_mm_s, &profile.max_accel_mm_s2);
        let mut k = KlipperLookahead::new(&limits);
        for mv in moves {
            if full {
                k.flush_budget_s = f64::INFINITY;
            }
            k.push(mv, mv.geometry().unwrap(), &limits, rotary, sink);
        }
        k.flush(sink);
    }

    fn plan(moves: &[Move], full: bool) -> Vec<PlannedBlock> {
        let mut out: Vec<PlannedBlock> = Vec::new();
        plan_into(moves, full, &mut out);
        out
    }

    /// A sink that keeps only time, as `estimate`'s accounts do without step counts.
    struct TimeOnly(Vec<PlannedBlock>);

    impl BlockSink for TimeOnly {
        fn block(&mut self, block: &PlannedBlock) {
            self.0.push(*block);
        }

        fn reads_positions(&self) -> bool {
            false
        }
    }

    fn path() -> impl Strategy<Value = Vec<Move>> {
        let step = (-30.0..30.0f64, -30.0..30.0f64, 0..10u8, 0.0..0.5f64, 2.0..200.0f64);
        proptest::collection::vec(step, 1..400).prop_map(|steps| {
            let mut at = Pos::default();
            let mut moves = Vec::new();
            for (i, (dx, dy, kind, de, feed)) in steps.into_iter().enumerate() {
                let mut to = at;
                match kind {
                    // A retract or unretract, or a layer change.
                    0 => to.e_mm -= de,
                    1 => to.e_mm += de,
                    2 => to.z_mm += 0.2,
                    // Mostly short printing and travel moves.
                    k => {
                        let scale = if k < 6 { 0.05 } else { 1.0 };
                        to.x_mm += dx * scale;
                        to.y_mm += dy * scale;
                        to.e_mm += if k % 2 == 0 { de * scale } else { 0.0 };
                    }
                }
                moves.push(Move { start: at, end: to, feed_mm_s: feed, tag: i as u64 });
                at = to;
            }
            moves
        })
    }

    proptest! {
        /// The queue keeps the moves' positions apart, only for a sink that reads them: such a
        /// sink gets each move's start and its block's end, one that does not gets the origin,
        /// and both the same speeds and times to the bit.
        #[test]
        fn positions_are_kept_only_for_a_sink_that_reads_them(moves in path()) {
            let with = plan(&moves, false);
            let mut without = TimeOnly(Vec::new());
            plan_into(&moves, false, &mut without);
            prop_assert_eq!(with.len(), without.0.len());
            for (a, b) in with.iter().zip(&without.0) {
                let mv = &moves[a.tag as usize];
                prop_assert_eq!(a.start, mv.start);
                prop_assert_eq!(a.end, PlannedBlock::end_of(mv, a.kind));
                let at_origin = PlannedBlock { start: Pos::default(), end: Pos::default(), ..*a };
                // Debug shows each number to the bit it round-trips to (and -0 apart from 0).
                prop_assert_eq!(format!("{at_origin:?}"), format!("{b:?}"));
            }
        }

        /// Klipper's lazy flushing commits a move only once no later move can change its speeds.
        #[test]
        fn lazy_flushing_equals_full_lookahead(moves in path()) {
            let lazy = plan(&moves, false);
            let full = plan(&moves, true);
            prop_assert_eq!(lazy.len(), full.len());
            for (a, b) in lazy.iter().zip(&full) {
                prop_assert_eq!(a.tag, b.tag);
                let (ta, tb) = (a.trapezoid, b.trapezoid);
                for (x, y) in [
                    (ta.entry_v_mm_s, tb.entry_v_mm_s),
                    (ta.cruise_v_mm_s, tb.cruise_v_mm_s),
                    (ta.exit_v_mm_s, tb.exit_v_mm_s),
                    (ta.duration_s(), tb.duration_s()),
                ] {
                    prop_assert!((x - y).abs() <= 1e-9 * y.abs().max(1.0), "{:?} vs {:?}", ta, tb);
                }
            }
        }
    }

    /// Regression for the junction deviation and the smoothed acceleration worked out when the
    /// limits are set, not at each move: after `SET_VELOCITY_LIMIT` (a square corner velocity
    /// of 1 instead of 5, half the acceleration, a minimum cruise ratio) the moves plan as a
    /// planner started with those limits plans them, to the bit.
    #[test]
    fn limits_set_mid_stream_plan_as_a_planner_started_with_them() {
        use crate::motion::planner::Planner;
        let square = |n: usize| -> Vec<Move> {
            let corners = [(0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)];
            (0..n)
                .map(|i| {
                    let (a, b) = (corners[i % 4], corners[(i + 1) % 4]);
                    let start = Pos::xyze(a.0, a.1, 0.2, i as f64);
                    let end = Pos::xyze(b.0, b.1, 0.2, i as f64 + 1.0);
                    Move { start, end, feed_mm_s: 150.0, tag: i as u64 }
                })
                .collect()
        };
        let before = limits();
        let after = KlipperLimits {
            square_corner_velocity_mm_s: 1.0,
            max_accel_mm_s2: before.max_accel_mm_s2 / 2.0,
            minimum_cruise_ratio: 0.25,
            ..before
        };
        let mut changed = Planner::new(MotionProfile::klipper(before)).unwrap();
        let mut fresh = Planner::new(MotionProfile::klipper(after)).unwrap();
        let mut sink: Vec<PlannedBlock> = Vec::new();
        for mv in square(9) {
            changed.push(&mv, &mut sink).unwrap();
        }
        changed.flush(&mut sink);
        changed.set_profile(MotionProfile::klipper(after)).unwrap();
        let (mut got, mut want): (Vec<PlannedBlock>, Vec<PlannedBlock>) = (Vec::new(), Vec::new());
        for mv in square(12) {
            changed.push(&mv, &mut got).unwrap();
            fresh.push(&mv, &mut want).unwrap();
        }
        changed.flush(&mut got);
        fresh.flush(&mut want);
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
        // The corners are planned with the new limits: 1 mm/s at the square corners (the
        // junction deviation formula gives exactly the square corner velocity there).
        assert!((got[1].trapezoid.entry_v_mm_s - 1.0).abs() < 1e-9, "{:?}", got[1].trapezoid);
    }
}
