//! Cutting planned blocks into segments of constant step rate (the main loop's half of the
//! stepper).
//!
//! # The speed profile of a block
//!
//! A block enters at `v_entry`, accelerates at `a` to its cruise speed, cruises, and decelerates
//! at `a` to `v_exit` (a trapezoid; a triangle when the block is too short to reach cruise):
//!
//! ```text
//!   speed
//!    v_cruise |      ____________________
//!             |     /                    \
//!             |    /                      \
//!    v_entry  |___/                        \___ v_exit
//!             |
//!             +---|------|--------------|------|---> distance s (mm)
//!                 0   accel_end    decel_start   L
//! ```
//!
//! Under constant acceleration the speed at distance `s` follows from `v² = v0² + 2 a s`, and
//! the time to go from `s0` to `s1` inside the ramp is the speed gained over the acceleration,
//! `(v(s1) - v(s0)) / a`; on the flat part it is the distance over the speed. These closed forms
//! give the exact time of every step event.
//!
//! # Segments
//!
//! The interrupt cannot afford a square root per step on an 8-bit board (GRBL and Marlin avoid
//! it too), so the main loop cuts the block into segments of about [`SEGMENT_S`] and gives each
//! the step interval that makes it last exactly as long as the profile says:
//! `interval = (t(s1) - t(s0)) / events`. Within a segment the rate is constant; from one
//! segment to the next it follows the profile, so the speed is a staircase under the trapezoid,
//! 200 steps a second. The fraction of a tick that an interval cannot hold is carried into the
//! next segment, so no error adds up: the block takes its planned time to within a tick.
//!
//! The event counts are integers that add up to the block's events exactly; each segment's end
//! is placed at `s = events_done * L / events`, so the distance and the steps never part.
//!
//! A block's exit speed is fixed when it is taken from the planner (GRBL re-reads it while the
//! block runs): the planner raises speeds only as more moves arrive, and a block once started
//! keeps the plan it started with, which is always safe.

use super::{Segment, StepQueue};
use crate::limits::{
    MAX_EVENTS_PER_TICK_LOG2, MIN_STEP_TICKS, MULTISTEP_TICKS, SEGMENT_S, STEP_BLOCKS, TICKS_PER_S,
};
use crate::math::sqrt;
use crate::planner::{Block, Planner};

/// The trapezoid of one block (see the module's text).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    entry_v2: f32,
    exit_v2: f32,
    cruise_v: f32,
    accel_mm_s2: f32,
    /// `1 / accel` and `1 / cruise`, s²/mm and s/mm: divisions done once per block, not per
    /// segment (a float division is the slowest arithmetic an AVR does).
    inv_accel: f32,
    inv_cruise_v: f32,
    accel_end_mm: f32,
    decel_start_mm: f32,
    len_mm: f32,
}

impl Profile {
    /// The profile of a block of `len_mm` entered at `entry_v2` and left at `exit_v2` (speeds
    /// squared), cruising at most at `nominal_v2`.
    pub fn new(len_mm: f32, entry_v2: f32, nominal_v2: f32, exit_v2: f32, accel_mm_s2: f32) -> Profile {
        let two_a = 2.0 * accel_mm_s2;
        let mut accel_end_mm = ((nominal_v2 - entry_v2) / two_a).max(0.0);
        let mut decel_len_mm = ((nominal_v2 - exit_v2) / two_a).max(0.0);
        let mut cruise_v2 = nominal_v2;
        if accel_end_mm + decel_len_mm > len_mm {
            // A triangle: the ramps meet where v² from both ends is equal:
            // entry² + 2 a s = exit² + 2 a (L - s).
            accel_end_mm = (((exit_v2 - entry_v2) / two_a + len_mm) / 2.0).clamp(0.0, len_mm);
            decel_len_mm = len_mm - accel_end_mm;
            cruise_v2 = entry_v2 + two_a * accel_end_mm;
        }
        let cruise_v = sqrt(cruise_v2);
        Profile {
            entry_v2,
            exit_v2,
            cruise_v,
            accel_mm_s2,
            inv_accel: 1.0 / accel_mm_s2,
            inv_cruise_v: if cruise_v > 0.0 { 1.0 / cruise_v } else { 0.0 },
            accel_end_mm,
            decel_start_mm: len_mm - decel_len_mm,
            len_mm,
        }
    }

    fn ramp_up_v(&self, s_mm: f32) -> f32 {
        sqrt(self.entry_v2 + 2.0 * self.accel_mm_s2 * s_mm)
    }

    fn ramp_down_v(&self, s_mm: f32) -> f32 {
        sqrt(self.exit_v2 + 2.0 * self.accel_mm_s2 * (self.len_mm - s_mm))
    }

    /// The speed at `s_mm` from the start, mm/s.
    pub fn speed_mm_s(&self, s_mm: f32) -> f32 {
        if s_mm < self.accel_end_mm {
            self.ramp_up_v(s_mm)
        } else if s_mm <= self.decel_start_mm {
            self.cruise_v
        } else {
            self.ramp_down_v(s_mm)
        }
    }

    /// The time from `s0_mm` to `s1_mm` (`s0 <= s1`), seconds: each part of the trapezoid in
    /// its closed form.
    pub fn time_s(&self, s0_mm: f32, s1_mm: f32) -> f32 {
        let mut t_s = 0.0;
        let (a0, a1) = (s0_mm, s1_mm.min(self.accel_end_mm));
        if a1 > a0 {
            t_s += (self.ramp_up_v(a1) - self.ramp_up_v(a0)) * self.inv_accel;
        }
        let (c0, c1) = (s0_mm.max(self.accel_end_mm), s1_mm.min(self.decel_start_mm));
        if c1 > c0 {
            t_s += (c1 - c0) * self.inv_cruise_v;
        }
        let (d0, d1) = (s0_mm.max(self.decel_start_mm), s1_mm);
        if d1 > d0 {
            t_s += (self.ramp_down_v(d0) - self.ramp_down_v(d1)) * self.inv_accel;
        }
        t_s
    }

    /// [`Profile::time_s`] when the speeds at both ends are known: inside one part of the
    /// trapezoid the time is the speed change over the acceleration, or the distance over the
    /// cruise speed, with no square root; only a segment across a corner of the trapezoid (at
    /// most two a block) takes the general way.
    pub fn time_between_s(&self, s0_mm: f32, v0_mm_s: f32, s1_mm: f32, v1_mm_s: f32) -> f32 {
        if s1_mm <= self.accel_end_mm {
            (v1_mm_s - v0_mm_s) * self.inv_accel
        } else if s0_mm >= self.decel_start_mm {
            (v0_mm_s - v1_mm_s) * self.inv_accel
        } else if s0_mm >= self.accel_end_mm && s1_mm <= self.decel_start_mm {
            (s1_mm - s0_mm) * self.inv_cruise_v
        } else {
            self.time_s(s0_mm, s1_mm)
        }
    }
}

/// A segment's length in timer ticks.
const SEGMENT_TICKS: u32 = (SEGMENT_S * TICKS_PER_S as f32) as u32;

/// The block being cut.
struct Running {
    profile: Profile,
    events: u32,
    events_done: u32,
    mm_per_event: f32,
    /// Events in [`SEGMENT_S`] at 1 mm/s.
    events_per_mm_s: f32,
    /// The speed where the next segment starts, mm/s (the last one's end speed).
    speed_mm_s: f32,
    slot: u8,
    homing: bool,
}

/// The segment maker: takes blocks from the planner and pushes segments into the step queue.
#[derive(Default)]
pub struct Prep {
    running: Option<Running>,
    next_slot: u8,
    /// Fraction of a timer tick not yet given to any interval.
    carry_ticks: f32,
}

impl Prep {
    /// Nothing running.
    pub const fn new() -> Self {
        Prep { running: None, next_slot: 0, carry_ticks: 0.0 }
    }

    /// Whether a block is still being cut.
    pub fn is_busy(&self) -> bool {
        self.running.is_some()
    }

    /// Forgets the block being cut (a halt).
    pub fn clear(&mut self) {
        self.running = None;
    }

    /// Pushes segments while the queue has room and the planner has moves.
    pub fn fill(&mut self, planner: &mut Planner, queue: &StepQueue) {
        while queue.has_room() {
            let starts_block = self.running.is_none();
            if starts_block && !self.start(planner, queue) {
                return;
            }
            let Some(run) = self.running.as_mut() else { return };
            if run.homing && queue.endstop_hit() {
                // The endstop ended this move: nothing more of it.
                self.running = None;
                continue;
            }
            let segment = next_segment(run, &mut self.carry_ticks, starts_block);
            queue.push(segment);
            if run.events_done == run.events {
                self.running = None;
            }
        }
    }

    fn start(&mut self, planner: &mut Planner, queue: &StepQueue) -> bool {
        let Some((block, exit_v2)) = planner.pop() else { return false };
        let Block { step, len_mm, accel_mm_s2, nominal_v2, entry_v2, .. } = block;
        let slot = self.next_slot;
        self.next_slot = ((usize::from(slot) + 1) % STEP_BLOCKS) as u8;
        queue.write_block(slot, step);
        let mm_per_event = len_mm / step.events as f32;
        self.running = Some(Running {
            profile: Profile::new(len_mm, entry_v2, nominal_v2, exit_v2, accel_mm_s2),
            events: step.events,
            events_done: 0,
            mm_per_event,
            events_per_mm_s: SEGMENT_S / mm_per_event,
            speed_mm_s: sqrt(entry_v2),
            slot,
            homing: step.endstop_mask != 0,
        });
        true
    }
}

/// The next segment of `run`: about [`SEGMENT_S`] long at the speed where it starts, at least
/// one event. One square root and one division (the interval) a segment.
fn next_segment(run: &mut Running, carry_ticks: &mut f32, starts_block: bool) -> Segment {
    let s0_mm = run.events_done as f32 * run.mm_per_event;
    let v0 = run.speed_mm_s;
    let wanted = (v0 * run.events_per_mm_s) as u32;
    // Whole groups of multi-stepping (`wanted` events in SEGMENT_S are an interval of about
    // SEGMENT_TICKS / wanted), so each interrupt of the segment makes as many events: only a
    // block's last segment may end on a shorter group.
    let group = 1 << events_per_tick_log2(SEGMENT_TICKS / wanted.max(1));
    let wanted = wanted / group * group;
    let events = wanted.clamp(1, u32::from(u16::MAX)).min(run.events - run.events_done);
    run.events_done += events;
    let s1_mm = if run.events_done == run.events {
        run.profile.len_mm
    } else {
        run.events_done as f32 * run.mm_per_event
    };
    let v1 = run.profile.speed_mm_s(s1_mm);
    run.speed_mm_s = v1;
    let total_ticks = run.profile.time_between_s(s0_mm, v0, s1_mm, v1) * TICKS_PER_S as f32 + *carry_ticks;
    let interval = ((total_ticks / events as f32) as u32).max(MIN_STEP_TICKS);
    *carry_ticks = (total_ticks - (interval * events) as f32).max(0.0);
    Segment {
        block: run.slot,
        starts_block,
        events: events as u16,
        interval_ticks: interval,
        events_per_tick_log2: events_per_tick_log2(interval),
    }
}

/// Step events per interrupt (log2) for a step interval: the fewest that keep the interrupts
/// at least [`MULTISTEP_TICKS`] apart.
fn events_per_tick_log2(interval_ticks: u32) -> u8 {
    let mut log2 = 0;
    while log2 < MAX_EVENTS_PER_TICK_LOG2 && interval_ticks << log2 < MULTISTEP_TICKS {
        log2 += 1;
    }
    log2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trapezoid_takes_the_time_of_its_three_parts() {
        // 10 mm from rest to rest, cruise 50 mm/s, 1000 mm/s²: ramps of 1.25 mm and 0.05 s each,
        // 7.5 mm of cruise in 0.15 s.
        let p = Profile::new(10.0, 0.0, 2500.0, 0.0, 1000.0);
        assert!((p.time_s(0.0, 10.0) - 0.25).abs() < 1e-6);
        assert!((p.time_s(0.0, 1.25) - 0.05).abs() < 1e-6);
        assert!((p.speed_mm_s(5.0) - 50.0).abs() < 1e-4);
        assert!((p.speed_mm_s(9.9) - sqrt(200.0)).abs() < 1e-3);
    }

    #[test]
    fn the_time_from_the_end_speeds_is_the_general_time() {
        let p = Profile::new(10.0, 100.0, 2500.0, 400.0, 1000.0);
        let mut s0 = 0.0;
        while s0 < 10.0 {
            let s1 = (s0 + 0.37f32).min(10.0);
            let fast = p.time_between_s(s0, p.speed_mm_s(s0), s1, p.speed_mm_s(s1));
            assert!((fast - p.time_s(s0, s1)).abs() < 1e-6, "{s0}..{s1}");
            s0 = s1;
        }
    }

    #[test]
    fn a_short_block_is_a_triangle() {
        // 1 mm from rest to rest at 1000 mm/s²: the peak at 0.5 mm, v = sqrt(1000) = 31.6 mm/s.
        let p = Profile::new(1.0, 0.0, 2500.0, 0.0, 1000.0);
        assert!((p.speed_mm_s(0.5) - 31.6228).abs() < 1e-3);
        assert!((p.time_s(0.0, 1.0) - 2.0 * 0.0316228).abs() < 1e-6);
    }
}
