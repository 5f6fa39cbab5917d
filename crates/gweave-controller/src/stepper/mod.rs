//! The step interrupt's logic, and the queue that feeds it.
//!
//! # Two sides
//!
//! The main loop plans moves and cuts them into *segments* ([`prep`]): a few milliseconds of
//! motion at a constant step rate. The step interrupt ([`Stepper::tick`]) runs them: at each
//! interrupt it makes at most one step on each axis and says when to come back. They meet only
//! through the [`StepQueue`], a ring with one producer (the main loop) and one consumer (the
//! interrupt), as GRBL's planner and stepper meet through its segment buffer
//! (`gnea/grbl:grbl/stepper.c`). A segment is written completely before the producer publishes
//! it by moving `head`; the consumer copies it before it frees the slot by moving `tail`. On an
//! AVR, loads and stores of one byte cannot be torn, which is all the atomics here need.
//!
//! # Bresenham's algorithm
//!
//! A move of `(dx, dy, dz, de)` steps takes `n = max(dx, dy, dz, de)` *step events*; the axis
//! with the most steps steps at every event, the others at evenly spread events. Each axis keeps
//! a counter; at every event it adds its step count, and when the counter reaches `n` it steps
//! and subtracts `n`. Over the `n` events the counter gains `d * n` and loses `n` per step, so
//! the axis makes exactly `d` steps: integers only, no drift, exact totals. (Bresenham's line
//! algorithm, 1965; GRBL and Marlin step the same way.) Starting each counter at `n / 2` spreads
//! the minor axes' steps to the middle of their intervals.
//!
//! ```text
//!   dx = 5, dy = 2, n = 5           event:  1  2  3  4  5
//!   counter y (starts at 2, +2 per event):  4  6  3  5  2
//!   reaches 5: step y, counter - 5:         .  *  .  *  .    (counters after: 4 1 3 0 2)
//! ```

pub mod prep;

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};

use crate::limits::{IDLE_TICKS, MAX_TIMER_TICKS, SEGMENTS, STEP_BLOCKS};
use crate::MOTORS;

/// What a move is to the stepper: steps per axis, their directions, and the endstops that end
/// it early (homing).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StepBlock {
    /// Steps per motor (absolute): X, Y, Z, E, and a mixing hotend's other inputs.
    pub steps: [u32; MOTORS],
    /// Step events: the largest of `steps`.
    pub events: u32,
    /// DIR pin levels for this move (the settings' inversion applied).
    pub dir_bits: u8,
    /// Endstops that stop this move when triggered (bit `1 << axis`; 0 for a normal move).
    pub endstop_mask: u8,
    /// Endstop pins whose triggered level is low: an endstop is triggered when
    /// `(levels ^ endstop_invert) & bit` is set.
    pub endstop_invert: u8,
    /// Motors whose steps go towards + (bit `1 << motor`, before the DIR inversion): how the
    /// stepper counts X, Y and Z's steps ([`StepQueue::counted_steps`]).
    pub positive_bits: u8,
}

impl StepBlock {
    /// No move.
    pub const IDLE: StepBlock = StepBlock {
        steps: [0; MOTORS],
        events: 0,
        dir_bits: 0,
        endstop_mask: 0,
        endstop_invert: 0,
        positive_bits: 0,
    };
}

/// A few milliseconds of one block at a constant step rate.
///
/// Packed: 9 bytes on the host as on the AVR (which aligns nothing), not 12.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(C, packed)]
pub struct Segment {
    /// Slot of its block in the step block ring.
    pub block: u8,
    /// Whether the block starts with this segment (the stepper loads it and resets Bresenham).
    pub starts_block: bool,
    /// Step events in this segment (at least 1).
    pub events: u16,
    /// Timer ticks between step events.
    pub interval_ticks: u32,
    /// Step events per interrupt, as a power of two: `1 << events_per_tick_log2`
    /// (multi-stepping when the interval is shorter than
    /// [`crate::limits::MULTISTEP_TICKS`], see [`Stepper::tick`]).
    pub events_per_tick_log2: u8,
}

/// The ring between the main loop and the step interrupt. On a board, a `static`.
pub struct StepQueue {
    segments: [UnsafeCell<Segment>; SEGMENTS],
    blocks: [UnsafeCell<StepBlock>; STEP_BLOCKS],
    /// Next segment slot the producer writes.
    head: AtomicU8,
    /// Next segment slot the consumer reads.
    tail: AtomicU8,
    /// The stepper is running a segment it has taken.
    busy: AtomicBool,
    /// Set by the producer: drop everything, now and forever (a halt).
    abort: AtomicBool,
    /// Set by the stepper when an endstop ended a homing move; cleared by the producer.
    endstop_hit: AtomicBool,
    /// Where X, Y and Z's motors are, in steps, counted by the stepper as it pulses them (from
    /// the planner's coordinates, set while idle): `M114`'s `Count` (see
    /// [`StepQueue::counted_steps`]).
    counted: UnsafeCell<[i32; COUNTED_AXES]>,
}

/// The axes whose steps the stepper counts (X, Y, Z: `M114`'s `Count`, as Marlin's).
pub const COUNTED_AXES: usize = 3;

// SAFETY: the cells are shared between one producer and one consumer; `head`/`tail` hand each
// slot over (written completely, then published with Release; read after an Acquire load), so
// no slot is ever read and written at the same time. Step block slots are written only for a
// block none of whose segments is in the ring (see `prep`).
unsafe impl Sync for StepQueue {}

impl Default for StepQueue {
    fn default() -> Self {
        StepQueue::new()
    }
}

impl StepQueue {
    /// An empty queue.
    pub const fn new() -> Self {
        StepQueue {
            segments: [const {
                UnsafeCell::new(Segment {
                    block: 0,
                    starts_block: false,
                    events: 0,
                    interval_ticks: 0,
                    events_per_tick_log2: 0,
                })
            }; SEGMENTS],
            blocks: [const { UnsafeCell::new(StepBlock::IDLE) }; STEP_BLOCKS],
            head: AtomicU8::new(0),
            tail: AtomicU8::new(0),
            busy: AtomicBool::new(false),
            abort: AtomicBool::new(false),
            endstop_hit: AtomicBool::new(false),
            counted: UnsafeCell::new([0; COUNTED_AXES]),
        }
    }

    /// Producer, only while the steppers are idle (nothing queued, nothing running): the
    /// counts go on from `steps` (the planner's coordinates, which homing and `G92` change).
    pub fn set_counted_steps(&self, steps: [i32; COUNTED_AXES]) {
        // SAFETY: the consumer writes the counts only when it steps, and it steps only segments
        // the producer queued: none is queued or running now.
        unsafe { core::ptr::write_volatile(self.counted.get(), steps) };
    }

    /// Producer: where X, Y and Z's motors are, in steps, as the stepper counted them (Marlin's
    /// `count_position`): behind the planned position while moves run.
    ///
    /// The stepper may interrupt the read between two of its bytes (an AVR loads one byte at a
    /// time), so the counts are read until two reads in a row agree: the interrupt changes
    /// them by one step at most between two reads, and two whole reads without an interrupt
    /// between agree.
    pub fn counted_steps(&self) -> [i32; COUNTED_AXES] {
        // SAFETY: only the consumer writes the counts; a read racing it is retried (above).
        // Volatile: the compiler must load again each time.
        let read = || unsafe { core::ptr::read_volatile(self.counted.get()) };
        let mut last = read();
        loop {
            let now = read();
            if now == last {
                return now;
            }
            last = now;
        }
    }

    fn queued(&self) -> usize {
        let head = usize::from(self.head.load(Ordering::Acquire));
        let tail = usize::from(self.tail.load(Ordering::Acquire));
        (head + 2 * SEGMENTS - tail) % (2 * SEGMENTS)
    }

    /// Whether the producer can push a segment.
    pub fn has_room(&self) -> bool {
        self.queued() < SEGMENTS
    }

    /// Whether the steppers are still: nothing queued and nothing running.
    pub fn is_idle(&self) -> bool {
        self.queued() == 0 && !self.busy.load(Ordering::Acquire)
    }

    /// Producer: writes a step block into `slot`. Only for a block whose segments are not yet
    /// pushed (`prep` hands out slots in turn, one per block, [`STEP_BLOCKS`] of them).
    pub(crate) fn write_block(&self, slot: u8, block: StepBlock) {
        // SAFETY: the stepper reads a block slot only when it takes the block's first segment
        // from the ring. `prep` writes block `b` into slot `b % STEP_BLOCKS` only while the ring
        // has room: had the ring still a segment of block `b - STEP_BLOCKS`, the blocks between
        // would hold the other `SEGMENTS - 1` slots (each has at least one segment) and the ring
        // would be full.
        unsafe { *self.blocks[usize::from(slot)].get() = block };
    }

    /// Producer: appends a segment; `false` if the ring is full.
    pub(crate) fn push(&self, segment: Segment) -> bool {
        if !self.has_room() {
            return false;
        }
        let head = self.head.load(Ordering::Relaxed);
        // SAFETY: slot `head` is outside the consumer's window [tail, head).
        unsafe { *self.segments[usize::from(head) % SEGMENTS].get() = segment };
        self.head.store(((usize::from(head) + 1) % (2 * SEGMENTS)) as u8, Ordering::Release);
        true
    }

    /// Consumer: takes the oldest segment, marking the stepper busy; a segment that starts a
    /// block first copies the block into `block`. Nothing else is moved: the step interrupt
    /// runs this at the last event of a segment, before that event's pulses go out, so every
    /// byte copied here makes that one step late (see [`Stepper::tick`]).
    fn pop(&self, block: &mut StepBlock) -> Option<Segment> {
        if self.queued() == 0 {
            return None;
        }
        let tail = self.tail.load(Ordering::Relaxed);
        // SAFETY: slot `tail` was published by the producer's Release store of `head`.
        let segment = unsafe { *self.segments[usize::from(tail) % SEGMENTS].get() };
        if segment.starts_block {
            // SAFETY: see `write_block`; read before `tail` frees the segment's slot.
            *block = unsafe { *self.blocks[usize::from(segment.block)].get() };
        }
        self.busy.store(true, Ordering::Release);
        self.tail.store(((usize::from(tail) + 1) % (2 * SEGMENTS)) as u8, Ordering::Release);
        Some(segment)
    }

    /// Producer: stop every step now and for good (a halt). The stepper drops what it has at its
    /// next interrupt.
    pub fn abort(&self) {
        self.abort.store(true, Ordering::Release);
    }

    /// Whether an endstop ended the last homing move (the producer clears it with
    /// [`StepQueue::clear_endstop_hit`] before the next one).
    pub fn endstop_hit(&self) -> bool {
        self.endstop_hit.load(Ordering::Acquire)
    }

    /// Producer: forgets the last endstop hit (only while the steppers are idle).
    pub fn clear_endstop_hit(&self) {
        self.endstop_hit.store(false, Ordering::Release);
    }
}

/// What the step interrupt does now: pulse `step_bits`, then set the DIR pins to `dir_bits`
/// for the steps to come, then come back after `interval_ticks` of the step timer; an
/// `interval_ticks` of 0 means another step event is due at once: call [`Stepper::tick`]
/// again in the same interrupt, after this one's pulses (multi-stepping).
///
/// The direction is always set one interrupt before the step that needs it, so a driver's
/// direction set-up time (200 ns for an A4988) is met whatever the board's timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepOut {
    /// STEP pins to pulse now, bit `1 << motor` ([`crate::MOTORS`]: a mixing hotend's inputs
    /// after X, Y and Z).
    pub step_bits: u8,
    /// DIR pin levels for the next steps, bit `1 << motor` (set after this call's pulses).
    pub dir_bits: u8,
    /// Timer ticks ([`crate::limits::TICKS_PER_S`]) until the next interrupt; 0: the next
    /// event is due now, in this interrupt.
    pub interval_ticks: u16,
}

/// The consumer side: Bresenham over the segments, called from the step timer's interrupt.
pub struct Stepper<'q> {
    queue: &'q StepQueue,
    block: StepBlock,
    counters: [u32; MOTORS],
    /// Motors with steps in the running block, bit `1 << motor`: the others are skipped.
    moving: u8,
    /// Step events left in the running segment.
    events_left: u16,
    /// Step events left in this interrupt's group (multi-stepping).
    group_left: u8,
    /// Step events per interrupt, log2, for the running segment.
    group_log2: u8,
    interval_ticks: u32,
    /// Ticks still to wait before the next event when an interval exceeds the 16-bit timer.
    wait_ticks: u32,
    dir_bits: u8,
}

impl<'q> Stepper<'q> {
    /// A stepper at rest on `queue`.
    pub fn new(queue: &'q StepQueue) -> Self {
        Stepper {
            queue,
            block: StepBlock::default(),
            counters: [0; MOTORS],
            moving: 0,
            events_left: 0,
            group_left: 0,
            group_log2: 0,
            interval_ticks: 0,
            wait_ticks: 0,
            dir_bits: 0,
        }
    }

    /// The interrupt: called when the step timer fires, with the endstop pins' levels (bit
    /// `1 << axis`, high = 1). Integer arithmetic only.
    ///
    /// A segment's first event comes one interval after the segment is taken, each next one an
    /// interval later, so the events of a segment of `n` events and interval `i` fall at
    /// `i, 2i, ... n i` from its start: the profile's times ([`prep`]).
    ///
    /// **Multi-stepping** (as Marlin does above its `MAX_STEP_ISR_FREQUENCY_1X`): an interrupt
    /// costs its entry and exit (saving and restoring the registers) on top of the events it
    /// makes, so at high step rates a segment runs `k = 2^events_per_tick_log2` events per
    /// interrupt, one interrupt every `k i`: [`StepOut::interval_ticks`] is 0 between the events
    /// of one interrupt. The events of a group fall at the time of its last one, each at most
    /// one interrupt period early; a segment's last group may be shorter, and comes as many
    /// intervals after the one before as it has events, so the segment still ends on its
    /// profile's time.
    pub fn tick(&mut self, endstop_levels: u8) -> StepOut {
        if self.queue.abort.load(Ordering::Acquire) {
            self.events_left = 0;
            self.group_left = 0;
            self.wait_ticks = 0;
            self.queue.tail.store(self.queue.head.load(Ordering::Acquire), Ordering::Release);
            self.queue.busy.store(false, Ordering::Release);
            return self.out(0, u32::from(IDLE_TICKS));
        }
        // A long interval is waited out in timer-sized pieces.
        if self.wait_ticks > 0 {
            return self.wait();
        }
        let mut step_bits = 0;
        if self.group_left > 0 {
            let triggered = (endstop_levels ^ self.block.endstop_invert) & self.block.endstop_mask;
            if triggered != 0 {
                // Homing: the endstop is reached; the rest of this block is dropped.
                self.queue.endstop_hit.store(true, Ordering::Release);
                self.events_left = 0;
                self.group_left = 0;
            } else {
                step_bits = self.event();
                self.events_left -= 1;
                self.group_left -= 1;
                if self.group_left > 0 {
                    return self.out(step_bits, 0);
                }
            }
        }
        if self.events_left == 0 && !self.next_segment() {
            self.queue.busy.store(false, Ordering::Release);
            return self.out(step_bits, u32::from(IDLE_TICKS));
        }
        let group = self.events_left.min(1 << self.group_log2) as u8;
        self.group_left = group;
        self.wait_ticks = self.interval_ticks * u32::from(group);
        let mut out = self.wait();
        out.step_bits = step_bits;
        out
    }

    /// One Bresenham step event: the step bits of the motors that step. Unrolled, and only the
    /// block's moving motors do arithmetic: on an 8-bit chip each is a few dozen cycles of
    /// 32-bit additions and comparisons, and a loop over the motors would cost as much again
    /// in indexing (the step interrupt runs this up to 40 000 times a second).
    fn event(&mut self) -> u8 {
        const _: () = assert!(MOTORS == 7, "event() is unrolled for 7 motors");
        let mut bits = 0;
        self.motor_event::<0>(&mut bits);
        self.motor_event::<1>(&mut bits);
        self.motor_event::<2>(&mut bits);
        self.motor_event::<3>(&mut bits);
        self.motor_event::<4>(&mut bits);
        self.motor_event::<5>(&mut bits);
        self.motor_event::<6>(&mut bits);
        bits
    }

    /// Bresenham for motor `M`: add its steps, and step when the counter reaches the events;
    /// X, Y and Z's steps are counted (`M114`'s `Count`).
    #[inline(always)]
    fn motor_event<const M: usize>(&mut self, bits: &mut u8) {
        if self.moving & (1 << M) != 0 {
            let counter = self.counters[M] + self.block.steps[M];
            self.counters[M] = if counter >= self.block.events {
                *bits |= 1 << M;
                if M < COUNTED_AXES {
                    // SAFETY: only the consumer writes the counts (see `counted_steps`).
                    let count = unsafe { &mut (*self.queue.counted.get())[M] };
                    *count =
                        count.wrapping_add(if self.block.positive_bits & (1 << M) != 0 { 1 } else { -1 });
                }
                counter - self.block.events
            } else {
                counter
            };
        }
    }

    /// Takes the next segment, skipping what is left of a homing block that met its endstop.
    fn next_segment(&mut self) -> bool {
        while let Some(segment) = self.queue.pop(&mut self.block) {
            if segment.starts_block {
                // Half of the events: the minor axes' steps fall mid-interval (see above).
                self.counters = [self.block.events / 2; MOTORS];
                self.moving = 0;
                for (motor, &steps) in self.block.steps.iter().enumerate() {
                    if steps != 0 {
                        self.moving |= 1 << motor;
                    }
                }
            }
            if self.block.endstop_mask != 0 && self.queue.endstop_hit.load(Ordering::Acquire) {
                continue;
            }
            self.dir_bits = self.block.dir_bits;
            self.events_left = segment.events;
            self.interval_ticks = segment.interval_ticks;
            self.group_log2 = segment.events_per_tick_log2;
            return true;
        }
        false
    }

    fn wait(&mut self) -> StepOut {
        let now = self.wait_ticks.min(MAX_TIMER_TICKS);
        // Leave no remainder too short for the next interrupt to be on time.
        let now = if self.wait_ticks - now < 100 && self.wait_ticks > MAX_TIMER_TICKS {
            self.wait_ticks / 2
        } else {
            now
        };
        self.wait_ticks -= now;
        self.out(0, now)
    }

    fn out(&self, step_bits: u8, interval_ticks: u32) -> StepOut {
        StepOut {
            step_bits,
            dir_bits: self.dir_bits,
            interval_ticks: interval_ticks.min(MAX_TIMER_TICKS) as u16,
        }
    }
}
