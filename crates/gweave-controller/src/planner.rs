//! The look-ahead planner: how fast each move may start and end.
//!
//! # Why look ahead
//!
//! A move cannot start at full speed: the motors accelerate at a limited rate `a` (mm/s²), so
//! the speed grows as `v² = v0² + 2 a d` over a distance `d`. Stopping at the end of every
//! short segment of a curve would be slow and shake the machine, so the planner keeps the next
//! [`PLANNER_BLOCKS`] moves and lets the head pass each junction as fast as the corner and the
//! moves ahead allow: it must always be able to stop by the end of the last move it knows.
//!
//! # Speeds at the junctions (GRBL's junction deviation)
//!
//! At a corner of angle `θ` between two moves (the angle between their directions; 0 means
//! straight on), the head may keep the speed of a circle that passes within the junction
//! deviation `δ` of the corner's point, tangent to both moves. Such a circle has radius
//! `r = δ sin(θ/2) / (1 - sin(θ/2))`, and on it the centripetal acceleration `v²/r` must stay
//! within `a`, so
//!
//! ```text
//!   v_junction² = a δ sin(θ/2) / (1 - sin(θ/2)),     sin(θ/2) = sqrt((1 - cos θ) / 2)
//! ```
//!
//! (`gnea/grbl:grbl/planner.c`, "junction deviation"; Marlin uses the same with δ = 0.013 mm).
//! Straight on (`θ = 0`) the limit is the moves' own speeds; a full reversal (`θ = 180°`)
//! allows nothing.
//!
//! # The passes
//!
//! Each block's entry speed is at most its junction limit, and so that the machine can stop:
//! - the reverse pass, from the newest block (which must end at rest) back to the oldest,
//!   caps each entry so the block can slow down to the next one's entry:
//!   `entry_i² ≤ entry_{i+1}² + 2 a_i L_i`;
//! - the forward pass, from the oldest block on, caps each entry to what the block before can
//!   reach by accelerating: `entry_{i+1}² ≤ entry_i² + 2 a_i L_i`.
//!
//! The oldest block's entry is fixed: it is the exit speed the block before it (already being
//! stepped) was given, or rest. Speeds are kept squared, as the formulas want them.
//!
//! # Only what can change (GRBL's `block_buffer_planned`)
//!
//! A new move only ever raises the entries before it (the newest block no longer has to stop
//! at its end), so an entry already at its junction limit is final, and so is one the forward
//! pass lowered (the block before it accelerates all the way into it: a higher limit behind
//! cannot raise it, and a block at its limit cuts what comes after it from what comes before).
//! Everything up to the last such block keeps its entry, and the passes run over the blocks
//! after it only: on a stream of short straight segments, one or two blocks a line instead of
//! all 16. Reading and planning a line must take the chip less time than the line's motion
//! (`half_millimetre_segments_at_60_mm_s_never_run_dry`, on the emulated board); the entries
//! are those of the passes over every block, exactly
//! (`planning_only_the_blocks_that_can_change_gives_the_full_passes_entries`).
//!
//! # A rotary axis
//!
//! On a lathe-type printer the mandrel's angle A is a fifth coordinate ([`crate::rotary`]): its
//! steps go to [`A_MOTOR`], its degrees count in the move's direction (for the junctions) and
//! in its length as the feed convention says ([`crate::rotary::Rotary::path_len`]), and its own speed and
//! acceleration limits hold like any axis'.

use crate::limits::{MAX_STEP_HZ, MIN_STEPS_PER_SEGMENT, PLANNER_BLOCKS};
use crate::math::sqrt;
use crate::mixing::Mixer;
use crate::rotary::{Feed, A_MOTOR};
use crate::settings::Settings;
use crate::stepper::StepBlock;
use crate::{AXES, E};

/// One planned move.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Block {
    /// The steps, for the stepper.
    pub step: StepBlock,
    /// Length of the move in mm (of X, Y and Z; of E for a move of the extruder alone; with a
    /// rotary axis, as its feed convention says: [`crate::rotary::Rotary::path_len`]).
    pub len_mm: f32,
    /// Acceleration of the move along its path, mm/s².
    pub accel_mm_s2: f32,
    /// Squared speed the move asks for (its feed rate within the axes' limits), (mm/s)².
    pub nominal_v2: f32,
    /// Squared highest entry speed (the junction limit), (mm/s)².
    pub max_entry_v2: f32,
    /// Squared planned entry speed, (mm/s)².
    pub entry_v2: f32,
}

/// Where a move goes and how fast, for [`Planner::add_with_a`]. One argument by reference, not
/// three: with seven arguments (more bytes than AVR's argument registers r8-r25) the firmware
/// built by rustc-web 1.96 read the last one, the mixer, from its stack frame's return-address
/// bytes while the caller had passed it in registers, and the emulated board crashed on a
/// bogus pointer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// X, Y, Z and E, steps.
    pub steps: [i32; AXES],
    /// The rotary axis A, steps.
    pub a_steps: i32,
    /// The feed.
    pub feed: Feed,
    /// The move as the G-code commands it (X, Y, Z, E in mm, then A in degrees), which F is
    /// measured over; `None`: its steps' distances. A rotary program's helix advances 0.005 mm
    /// of X per 5-degree chord at `F6.675` (NIST: F along X, A following): 0 or 1 step of X,
    /// and measured in steps the chord is 0 mm (A alone: 5 degrees at 6.675 deg/min, 45 s, not
    /// 45 ms) or 0.0125 mm (twice its time).
    pub commanded: Option<[f32; AXES + 1]>,
}

/// The ring of planned moves, and where the planned moves end.
pub struct Planner {
    blocks: [Block; PLANNER_BLOCKS],
    first: usize,
    count: usize,
    /// Unit direction of the last planned move (XYZE in mm, then A in degrees), for the next
    /// junction.
    previous_unit: [f32; AXES + 1],
    previous_nominal_v2: f32,
    /// How many of the oldest waiting blocks have their final entry (see the module's text).
    /// (A byte: at most [`PLANNER_BLOCKS`].)
    planned: u8,
    /// Where the last planned move ends, in steps per axis.
    pub position_steps: [i32; AXES],
    /// The same for the rotary axis A (0 without one).
    pub position_a_steps: i32,
    /// The extruder the moves planned from now on drive: 0, or 1 after `T1` on a board with two
    /// hotends (RAMPS "EEB"), whose E steps go to the motor after E0's, on E1's socket.
    pub extruder: u8,
}

impl Default for Planner {
    fn default() -> Self {
        Planner::new()
    }
}

impl Planner {
    /// An empty planner at the origin.
    pub const fn new() -> Self {
        const EMPTY: Block = Block {
            step: StepBlock::IDLE,
            len_mm: 0.0,
            accel_mm_s2: 0.0,
            nominal_v2: 0.0,
            max_entry_v2: 0.0,
            entry_v2: 0.0,
        };
        Planner {
            blocks: [EMPTY; PLANNER_BLOCKS],
            first: 0,
            count: 0,
            previous_unit: [0.0; AXES + 1],
            previous_nominal_v2: 0.0,
            planned: 0,
            position_steps: [0; AXES],
            position_a_steps: 0,
            extruder: 0,
        }
    }

    /// Whether no move can be added now.
    pub fn is_full(&self) -> bool {
        self.count == PLANNER_BLOCKS
    }

    /// Whether no move waits.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Forgets every waiting move (a halt).
    pub fn clear(&mut self) {
        self.count = 0;
        self.planned = 0;
    }

    /// Plans a move from [`Planner::position_steps`] to `target_steps` at `feed_mm_s` (within
    /// the settings' limits); `endstop_mask` names the endstops that end it (homing). A move of
    /// no step is not planned. Returns `false`, planning nothing, when the planner is full.
    ///
    /// On a mixing hotend the E steps go to the inputs by `mixer`'s active mix
    /// ([`Mixer::split`]), each input a motor of the block; the planner's speeds and lengths stay
    /// those of E.
    #[inline(never)]
    pub fn add(
        &mut self,
        target_steps: [i32; AXES],
        feed_mm_s: f32,
        endstop_mask: u8,
        s: &Settings,
        mixer: &mut Mixer,
    ) -> bool {
        let target = Target {
            steps: target_steps,
            a_steps: self.position_a_steps,
            feed: Feed::PerSecond(feed_mm_s),
            commanded: None,
        };
        self.add_with_a(&target, endstop_mask, s, mixer)
    }

    /// [`Planner::add`] with the rotary axis' target and the feed as `G93`/`G94` give it
    /// ([`Target`]). Without a rotary axis fitted, A stays where it is.
    pub fn add_with_a(&mut self, target: &Target, endstop_mask: u8, s: &Settings, mixer: &mut Mixer) -> bool {
        if self.is_full() {
            return false;
        }
        let Target { steps: target_steps, a_steps: target_a_steps, feed, commanded } = *target;
        let rotary = s.rotary.fitted(s.mixing_inputs);
        let mut step =
            StepBlock { endstop_mask, endstop_invert: s.endstop_inverting, ..StepBlock::default() };
        let mut delta_mm = [0.0f32; AXES];
        for axis in 0..AXES {
            // 32-bit arithmetic only (64-bit costs kilobytes on an AVR); at most 2^31 steps, so
            // the stepper's counters (below 2 × events) fit 32 bits.
            let delta = target_steps[axis].saturating_sub(self.position_steps[axis]);
            step.steps[axis] = delta.unsigned_abs();
            step.events = step.events.max(step.steps[axis]);
            if delta > 0 {
                step.dir_bits |= 1 << axis;
            }
            delta_mm[axis] = delta as f32 / s.steps_per_mm[axis];
        }
        let a_delta = if rotary { target_a_steps.saturating_sub(self.position_a_steps) } else { 0 };
        step.events = step.events.max(a_delta.unsigned_abs());
        let delta_deg = if rotary { a_delta as f32 / s.rotary.steps_per_deg } else { 0.0 };
        if step.events < MIN_STEPS_PER_SEGMENT && endstop_mask == 0 {
            // Too short to plan: the position stays, so the next move takes this one's steps.
            return true;
        }
        if mixer.inputs() > 0 {
            let e_delta = target_steps[E].saturating_sub(self.position_steps[E]);
            step.dir_bits &= !(1 << E);
            // The step events are the most steps any motor makes. E's total was counted above
            // (a move too short to plan is judged on it, as the Marlin model does), but once
            // split no motor makes it: each input makes its share. Counted, it made the
            // stepper run an event per E step, four times the inputs' rate with four of them,
            // and the interrupt starved the main loop at 3 500 steps/s per motor
            // (`x_y_and_four_mixing_inputs_hold_ten_thousand_steps_a_second`). A rotary axis is
            // never beside a mixing hotend (`Rotary::fitted`).
            step.events = step.steps[..E].iter().copied().max().unwrap_or(0);
            for (k, d) in mixer.split(e_delta).into_iter().enumerate() {
                step.steps[E + k] = d.unsigned_abs();
                step.events = step.events.max(step.steps[E + k]);
                if d > 0 {
                    step.dir_bits |= 1 << (E + k);
                }
            }
        } else if self.extruder > 0 {
            // A second extruder: E's steps and direction go to its motor. E's position stays one
            // count for both, as Marlin keeps one E position across a tool change: a file's E
            // values run on from one extruder to the other. (A rotary axis, on the same socket,
            // is never fitted beside a second hotend: `printer_file`.)
            let motor = E + usize::from(self.extruder);
            step.steps[motor] = core::mem::take(&mut step.steps[E]);
            if step.dir_bits & (1 << E) != 0 {
                step.dir_bits ^= (1 << E) | (1 << motor);
            }
        }
        // A's motor is E1's socket, which a mixing hotend's input would use: never both
        // (`Rotary::fitted`).
        step.steps[A_MOTOR] = step.steps[A_MOTOR].max(a_delta.unsigned_abs());
        if a_delta > 0 {
            step.dir_bits |= 1 << A_MOTOR;
        }
        step.positive_bits = step.dir_bits;
        step.dir_bits ^= s.invert_dir;
        if step.events == 0 {
            return true;
        }
        let xyz_mm2: f32 = delta_mm[..E].iter().map(|d| d * d).sum();
        let len_mm = match commanded {
            Some(c) if rotary => s.rotary.path_len(c[..E].iter().map(|d| d * d).sum(), c[AXES], c[E]),
            _ => s.rotary.path_len(xyz_mm2, delta_deg, delta_mm[E]),
        };
        // Speed and acceleration along the path, within every axis' own limits: an axis
        // covering a fraction `|d|/L` of the path moves at that fraction of the path's speed.
        let mut feed_mm_s = feed.speed(len_mm);
        let mut accel_mm_s2 = if xyz_mm2 == 0.0 && delta_deg == 0.0 {
            s.retract_accel_mm_s2
        } else if delta_mm[E] != 0.0 {
            s.print_accel_mm_s2
        } else {
            s.travel_accel_mm_s2
        };
        let mut unit = [0.0f32; AXES + 1];
        let mut unit_norm2 = 0.0;
        let limits = |axis: usize| match axis {
            AXES => (s.rotary.max_feed_deg_s, s.rotary.max_accel_deg_s2),
            _ => (s.max_feed_mm_s[axis], s.max_accel_mm_s2[axis]),
        };
        for axis in 0..=AXES {
            let d = if axis == AXES { delta_deg } else { delta_mm[axis] };
            let fraction = d.abs() / len_mm;
            if fraction > 0.0 {
                let (max_feed, max_accel) = limits(axis);
                feed_mm_s = feed_mm_s.min(max_feed / fraction);
                accel_mm_s2 = accel_mm_s2.min(max_accel / fraction);
            }
            unit[axis] = d;
            unit_norm2 += d * d;
        }
        // Marlin's MAX_STEP_FREQUENCY: the motor with the most steps (`events` of them over
        // `len_mm`) steps at most MAX_STEP_HZ times a second, so no speed asks more of the
        // step interrupt than it can hold.
        feed_mm_s = feed_mm_s.min(MAX_STEP_HZ as f32 * len_mm / step.events as f32);
        let unit_norm = sqrt(unit_norm2);
        for u in &mut unit {
            *u /= unit_norm;
        }
        let nominal_v2 = feed_mm_s * feed_mm_s;
        let max_entry_v2 = if self.is_empty() {
            // Nothing before it in the planner: the move before (if any) is being stepped and
            // was planned to stop.
            0.0
        } else {
            self.junction_v2(&unit, accel_mm_s2, s.junction_deviation_mm)
                .min(nominal_v2)
                .min(self.previous_nominal_v2)
        };
        let slot = (self.first + self.count) % PLANNER_BLOCKS;
        self.blocks[slot] = Block {
            step,
            len_mm,
            accel_mm_s2,
            nominal_v2,
            max_entry_v2,
            entry_v2: if self.is_empty() { 0.0 } else { max_entry_v2 },
        };
        self.count += 1;
        self.previous_unit = unit;
        self.previous_nominal_v2 = nominal_v2;
        self.position_steps = target_steps;
        if rotary {
            self.position_a_steps = target_a_steps;
        }
        self.recalculate();
        true
    }

    /// The junction limit between the last planned move and one in direction `unit`.
    fn junction_v2(&self, unit: &[f32; AXES + 1], accel_mm_s2: f32, deviation_mm: f32) -> f32 {
        let cos_theta = -self.previous_unit.iter().zip(unit).map(|(p, u)| p * u).sum::<f32>();
        if cos_theta > 0.999_999 {
            return 0.0; // a full reversal
        }
        if cos_theta < -0.999_999 {
            return f32::MAX; // straight on
        }
        let sin_half = sqrt(0.5 * (1.0 - cos_theta));
        accel_mm_s2 * deviation_mm * sin_half / (1.0 - sin_half)
    }

    fn at(&mut self, i: usize) -> &mut Block {
        &mut self.blocks[(self.first + i) % PLANNER_BLOCKS]
    }

    /// The reverse and forward passes over the blocks whose entries can still change (see the
    /// module's text); the oldest block's entry is always fixed.
    fn recalculate(&mut self) {
        let start = usize::from(self.planned).max(1);
        let mut next_entry_v2 = 0.0; // the newest block ends at rest
        for i in (start..self.count).rev() {
            let b = self.at(i);
            b.entry_v2 = b.max_entry_v2.min(next_entry_v2 + 2.0 * b.accel_mm_s2 * b.len_mm);
            next_entry_v2 = b.entry_v2;
        }
        for i in start - 1..self.count.saturating_sub(1) {
            let b = self.at(i);
            let reachable_v2 = b.entry_v2 + 2.0 * b.accel_mm_s2 * b.len_mm;
            let next = self.at(i + 1);
            if reachable_v2 < next.entry_v2 {
                next.entry_v2 = reachable_v2;
                self.planned = (i + 2) as u8; // accelerating all the way into block i + 1: final
            } else if next.entry_v2 == next.max_entry_v2 {
                self.planned = (i + 2) as u8; // at its limit: final
            }
        }
    }

    /// Takes the oldest block for stepping, with its exit speed squared (the next block's
    /// entry, or rest); the next block's entry is fixed from now on.
    pub fn pop(&mut self) -> Option<(Block, f32)> {
        if self.count == 0 {
            return None;
        }
        let block = self.blocks[self.first];
        self.first = (self.first + 1) % PLANNER_BLOCKS;
        self.count -= 1;
        self.planned = self.planned.saturating_sub(1);
        let exit_v2 = if self.count > 0 { self.blocks[self.first].entry_v2 } else { 0.0 };
        Some((block, exit_v2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn planned(moves: &[[i32; AXES]]) -> Planner {
        let mut p = Planner::new();
        for &m in moves {
            assert!(p.add(m, 100.0, 0, &Settings::DEFAULT, &mut Mixer::new(0)));
        }
        p
    }

    #[test]
    fn a_straight_line_keeps_speed_through_its_junction() {
        // Two 10 mm moves along X at 100 mm/s (3000 mm/s²): the junction is straight, so the
        // second starts at the speed the first reaches, capped by its own stop:
        // v² = 2 a L = 60000 > 100², so the full 100 mm/s.
        let mut p = planned(&[[800, 0, 0, 0], [1600, 0, 0, 0]]);
        let (first, exit_v2) = p.pop().unwrap();
        assert_eq!(first.entry_v2, 0.0);
        assert_eq!(first.step.steps, [800, 0, 0, 0, 0, 0, 0]);
        assert_eq!(exit_v2, 100.0 * 100.0);
    }

    #[test]
    fn a_right_angle_slows_to_the_junction_deviation_speed() {
        let mut p = planned(&[[800, 0, 0, 0], [800, 800, 0, 0]]);
        p.pop();
        let (second, _) = p.pop().unwrap();
        // θ = 90°: sin(45°) = 0.7071, v² = 3000 * 0.013 * 0.7071 / 0.2929 = 94.15 (9.7 mm/s).
        assert!((second.entry_v2 - 94.15).abs() < 0.05, "{}", second.entry_v2);
    }

    #[test]
    fn a_reversal_stops_and_a_full_planner_refuses() {
        let mut p = planned(&[[800, 0, 0, 0], [0, 0, 0, 0]]);
        assert_eq!(p.pop().unwrap().1, 0.0);
        let mut p = Planner::new();
        for i in 0..PLANNER_BLOCKS as i32 {
            assert!(p.add([6 * (i + 1), 0, 0, 0], 10.0, 0, &Settings::DEFAULT, &mut Mixer::new(0)));
        }
        assert!(p.is_full());
        assert!(!p.add([1000, 0, 0, 0], 10.0, 0, &Settings::DEFAULT, &mut Mixer::new(0)));
        assert_eq!(p.position_steps, [6 * PLANNER_BLOCKS as i32, 0, 0, 0]);
    }

    #[test]
    fn a_move_of_fewer_than_six_steps_goes_with_the_next() {
        let mut p = Planner::new();
        let mut mixer = Mixer::new(0);
        assert!(p.add([5, 0, 0, 0], 10.0, 0, &Settings::DEFAULT, &mut mixer));
        assert!(p.is_empty() && p.position_steps == [0; AXES], "not planned");
        assert!(p.add([9, 0, 0, 2], 10.0, 0, &Settings::DEFAULT, &mut mixer));
        assert_eq!(p.pop().unwrap().0.step.steps, [9, 0, 0, 2, 0, 0, 0]);
    }

    #[test]
    fn a_mixing_blocks_events_are_its_busiest_inputs_steps_not_es_total() {
        // 10 mm of X (800 steps) and 4 × 800 steps of E split evenly over four inputs: each
        // input makes 800 steps, so 800 events, not E's 3200 (which made the stepper run four
        // events per input step and starved the mixing image's main loop).
        let mut mixer = Mixer::new(4);
        mixer.set_active([Some(1.0); 4]).unwrap();
        let mut p = Planner::new();
        assert!(p.add([800, 0, 0, 3200], 10.0, 0, &Settings::DEFAULT, &mut mixer));
        let (b, _) = p.pop().unwrap();
        assert_eq!(b.step.steps, [800, 0, 0, 800, 800, 800, 800]);
        assert_eq!(b.step.events, 800);
        // One input taking all of E: its steps are the events.
        mixer.set_active([Some(1.0), Some(0.0), Some(0.0), Some(0.0)]).unwrap();
        assert!(p.add([1600, 0, 0, 6400], 10.0, 0, &Settings::DEFAULT, &mut mixer));
        let (b, _) = p.pop().unwrap();
        assert_eq!(b.step.steps, [800, 0, 0, 3200, 0, 0, 0]);
        assert_eq!(b.step.events, 3200);
    }

    #[test]
    fn the_second_extruders_moves_step_its_own_motor_both_ways() {
        // `T1` on a board with two hotends: E's steps and direction go to the motor after E0's
        // (E1's socket), E0 makes none; back on extruder 0 they are E0's again.
        let mut p = Planner::new();
        let mut mixer = Mixer::new(0);
        p.extruder = 1;
        assert!(p.add([800, 0, 0, 93], 10.0, 0, &Settings::DEFAULT, &mut mixer));
        let (b, _) = p.pop().unwrap();
        assert_eq!((b.step.steps, b.step.positive_bits), ([800, 0, 0, 0, 93, 0, 0], 0b1_0001));
        assert!(p.add([800, 0, 0, 0], 10.0, 0, &Settings::DEFAULT, &mut mixer));
        let (b, _) = p.pop().unwrap();
        assert_eq!((b.step.steps, b.step.positive_bits), ([0, 0, 0, 0, 93, 0, 0], 0));
        p.extruder = 0;
        assert!(p.add([800, 0, 0, 40], 10.0, 0, &Settings::DEFAULT, &mut mixer));
        let (b, _) = p.pop().unwrap();
        assert_eq!((b.step.steps, b.step.positive_bits), ([0, 0, 0, 40, 0, 0, 0], 0b1000));
    }

    #[test]
    fn a_speed_beyond_the_step_rate_cap_is_lowered_to_it() {
        // 1000 mm/s asked of X at 80 steps/mm (80 000 steps/s), the axis' limit raised out of
        // the way: the cap, 40 000 steps/s, is 500 mm/s.
        let mut s = Settings::DEFAULT;
        s.max_feed_mm_s[0] = 2000.0;
        let mut p = Planner::new();
        assert!(p.add([8000, 0, 0, 0], 1000.0, 0, &s, &mut Mixer::new(0)));
        let (b, _) = p.pop().unwrap();
        assert!((sqrt(b.nominal_v2) - MAX_STEP_HZ as f32 / 80.0).abs() < 0.01, "{}", sqrt(b.nominal_v2));
        // A diagonal is held by its fastest motor: Y at 400 steps/mm over a 3-4-5 move.
        s.steps_per_mm[1] = 400.0;
        s.max_feed_mm_s[1] = 2000.0;
        assert!(p.add([8000 + 240, 1600, 0, 0], 1000.0, 0, &s, &mut Mixer::new(0)));
        let (b, _) = p.pop().unwrap();
        // 5 mm along the path, 1600 Y steps: 40 000 steps/s is 125 mm/s along the path.
        assert!((sqrt(b.nominal_v2) - 125.0).abs() < 0.01, "{}", sqrt(b.nominal_v2));
    }

    /// The entries the reverse and forward passes over every waiting block give (the planner
    /// before it planned only the blocks that can change).
    fn full_passes(p: &Planner) -> Vec<f32> {
        let mut b: Vec<Block> = (0..p.count).map(|i| p.blocks[(p.first + i) % PLANNER_BLOCKS]).collect();
        let mut next_entry_v2 = 0.0;
        for i in (1..b.len()).rev() {
            b[i].entry_v2 = b[i].max_entry_v2.min(next_entry_v2 + 2.0 * b[i].accel_mm_s2 * b[i].len_mm);
            next_entry_v2 = b[i].entry_v2;
        }
        for i in 0..b.len().saturating_sub(1) {
            let reachable_v2 = b[i].entry_v2 + 2.0 * b[i].accel_mm_s2 * b[i].len_mm;
            b[i + 1].entry_v2 = b[i + 1].entry_v2.min(reachable_v2);
        }
        b.iter().map(|b| b.entry_v2).collect()
    }

    #[test]
    fn planning_only_the_blocks_that_can_change_gives_the_full_passes_entries() {
        // Pseudo-random moves (short and long, corners, reversals, changes of speed), blocks
        // taken by the stepper now and then, as a print streams them.
        let mut seed = 0x2545_f491_u32;
        let mut next = move |n: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed % n
        };
        let mut p = Planner::new();
        let mut mixer = Mixer::new(0);
        let mut target = [0i32; AXES];
        let mut skipped = 0;
        for step in 0..20_000 {
            if p.is_full() || next(3) == 0 {
                p.pop();
            } else {
                for axis in [0, 1, E] {
                    target[axis] += next(400) as i32 - 200;
                }
                let feed_mm_s = [20.0, 60.0, 150.0][next(3) as usize];
                assert!(p.add(target, feed_mm_s, 0, &Settings::DEFAULT, &mut mixer));
            }
            let entries: Vec<f32> =
                (0..p.count).map(|i| p.blocks[(p.first + i) % PLANNER_BLOCKS].entry_v2).collect();
            assert_eq!(entries, full_passes(&p), "after step {step}");
            skipped += usize::from(p.planned.saturating_sub(1));
        }
        // The point of it: most of the passes are skipped.
        assert!(skipped > 20_000, "only {skipped} blocks skipped");
    }

    #[test]
    fn z_moves_are_held_to_zs_limits() {
        let mut p = planned(&[[0, 0, 4000, 0]]);
        let (b, _) = p.pop().unwrap();
        assert_eq!(b.nominal_v2, 25.0); // Z at most 5 mm/s
        assert_eq!(b.accel_mm_s2, 100.0);
        assert_eq!(b.len_mm, 10.0);
    }
}
