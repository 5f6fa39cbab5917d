//! How Marlin turns one move into a planner block (`Marlin/src/module/planner.cpp`,
//! `Planner::buffer_segment` and `Planner::_populate_block`, bugfix-2.0.x of late 2020).
//!
//! 1. **Steps.** The target is rounded to whole steps per axis, and the block moves by the
//!    difference from the planner's step position. `step_event_count` is the most steps any
//!    motor takes; below `MIN_STEPS_PER_SEGMENT` (6) the move is dropped and its distance
//!    carried into the next one (the position does not advance).
//! 2. **Length.** The XYZ distance of those whole steps; when no XYZ motor takes 6 steps the
//!    block is measured along E (a retract, or a tiny move that mostly extrudes).
//! 3. **Nominal speed.** The feed over the length. While the buffer runs low (2 to
//!    `BLOCK_BUFFER_SIZE / 2 - 1` blocks queued) a block faster than `min_segment_time_us` is
//!    slowed: its time becomes `t + 2 (min - t) / queued` (`SLOWDOWN`). Then every motor,
//!    E included, is held to its M203 maximum by one factor. The nominal rate is
//!    `ceil(step_event_count / time)` steps/s.
//! 4. **Acceleration.** M204 P (extruding), T (travel) or R (no XYZ steps) in steps/s² of the
//!    busiest motor, rounded up; then each motor with steps is held to its M201 maximum
//!    (whole steps/s², truncated). Extrude-only blocks are not held to E's M201.
//! 5. **Corner speed.** Junction deviation or classic jerk (below), then the entry speed starts
//!    at `MINIMUM_PLANNER_SPEED` (0.05 mm/s) for the lookahead to raise.
//!
//! Junction deviation: the junction vector is the XYZE distance normalised over all four axes
//! when the block extrudes (XYZ alone otherwise), the acceleration along the change of
//! direction is held to each axis' M201 maximum, and for blocks under 1 mm turning by less than
//! 45 degrees the speed is also capped at `v^2 = a len / theta` (`JD_HANDLE_SMALL_SEGMENTS`;
//! Marlin takes `theta` from a table within 0.01 rad of `acos`, gweave from `acos`). A near
//! reversal (`cos > 0.999999`) stops at the minimum planner speed. This is Marlin 2.0's rule as
//! of late 2020 (the ground truth's version); earlier 2.0 releases scaled the XYZE vector by the
//! XYZ length instead of normalising it, and 2.1 has not been compared.
//!
//! Classic jerk (Marlin 2.0's rule, adapted there from Prusa firmware): a block may start from
//! rest at its "safe speed", the nominal speed scaled until no axis' speed exceeds its jerk. At
//! a junction the smaller nominal speed is scaled until every axis' change of speed is within
//! its jerk (an axis that reverses counts its larger speed, not the difference), and when both
//! blocks' safe speeds exceed 99 % of that, the safe speed is used instead.

use super::junction::HalfAngle;
use super::{Greater, Lesser};
use crate::motion::kinematics::Pos;
use crate::motion::limits::{MarlinCorners, MotionProfile};
use crate::motion::rounding::{ceil, round_f32, round_i64, trunc};

/// `MIN_STEPS_PER_SEGMENT`.
pub(crate) const MIN_STEPS_PER_SEGMENT: f64 = 6.0;
/// `MINIMUM_PLANNER_SPEED`, mm/s.
pub(crate) const MINIMUM_PLANNER_SPEED: f64 = 0.05;
/// `SLOWDOWN_DIVISOR`.
const SLOWDOWN_DIVISOR: usize = 2;
/// A junction this close to a full reversal stops (`-u_prev . u > 0.999999`).
const REVERSAL_NEG_COS: f64 = 0.999_999;
/// Blocks under this length, mm, also get the small-segment arc limit.
const SMALL_SEGMENT_MM: f64 = 1.0;
/// cos 135 degrees: the small-segment limit applies to gentler corners than this.
const SMALL_SEGMENT_NEG_COS: f64 = -std::f64::consts::FRAC_1_SQRT_2;

/// The profile's values in the units the block computation uses, taken once per move.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Settings {
    pub steps_per_unit: [f64; 5],
    /// `axis_steps_per_mm` and `steps_to_mm`, single precision as in Marlin.
    steps_per_unit32: [f32; 5],
    mm_per_step: [f32; 5],
    /// M203, single precision as Marlin compares it.
    max_feed32: [f32; 5],
    max_accel: [f64; 5],
    /// M201 in whole steps/s² per motor (`max_acceleration_steps_per_s2`).
    max_accel_steps: [f64; 5],
    accel: [f64; 3],
    corners: MarlinCorners,
    min_segment_time_us: f64,
    /// `BLOCK_BUFFER_SIZE`.
    pub buffer_size: usize,
}

impl Settings {
    /// The settings for moves of extruder `tool`.
    pub(crate) fn new(profile: &MotionProfile, tool: usize) -> Self {
        let s = &profile.steps;
        let own = profile.extruders.get(tool).copied().unwrap_or_default();
        let steps_per_unit = [s.x, s.y, s.z, own.steps_per_mm.unwrap_or(s.e), s.a()];
        let mut max_accel = profile.max_accel_mm_s2.to_array();
        let mut max_feed = profile.max_feed_mm_s.to_array();
        max_accel[3] = own.max_accel_mm_s2.unwrap_or(max_accel[3]);
        max_feed[3] = own.max_feed_mm_s.unwrap_or(max_feed[3]);
        let a = &profile.accel;
        let (buffer_size, min_segment_time_us) = match profile.corners {
            crate::motion::limits::CornerMode::Marlin { lookahead_blocks, min_segment_time_us, .. } => {
                (lookahead_blocks, min_segment_time_us)
            }
            crate::motion::limits::CornerMode::Klipper(_)
            | crate::motion::limits::CornerMode::Constant {} => {
                unreachable!("a Marlin planner has a Marlin profile")
            }
        };
        Self {
            steps_per_unit,
            steps_per_unit32: steps_per_unit.map(|s| s as f32),
            mm_per_step: steps_per_unit.map(|s| 1.0 / s as f32),
            max_feed32: max_feed.map(|m| m as f32),
            max_accel,
            max_accel_steps: std::array::from_fn(|i| trunc(max_accel[i] * steps_per_unit[i])),
            accel: [a.print_mm_s2, a.travel_mm_s2, a.retract_mm_s2],
            corners: profile.corners.marlin_corners().expect("a Marlin profile"),
            min_segment_time_us,
            buffer_size,
        }
    }

    /// The planner position of logical position `pos` with the workspace shifted by `shift`
    /// (native = logical - shift, see `marlin_position.rs`): each axis rounded to whole steps
    /// (Marlin's positions and steps per mm are single precision; without a shift the native
    /// position is the logical one to the bit).
    pub(crate) fn steps_at(&self, pos: Pos, shift: &[f32; 5]) -> [f64; 5] {
        let p = pos.to_array();
        std::array::from_fn(|i| round_f32((p[i] as f32 - shift[i]) * self.steps_per_unit32[i]))
    }
}

/// What the next junction needs of the block before it; it outlives the block's stay in the
/// buffer, as Marlin's `previous_*` statics do.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Previous {
    unit: [f64; 5],
    speed: [f64; 5],
    nominal_v2: f64,
    safe_v: f64,
}

/// A populated block: everything the lookahead and the step trapezoid need.
#[derive(Debug, Clone, Copy)]
pub(crate) struct MarlinBlock {
    /// `step_event_count`.
    pub steps: f64,
    /// Length, mm (or E mm, or A degrees).
    pub mm: f64,
    /// Whole steps/s.
    pub nominal_rate: f64,
    pub nominal_v2: f64,
    /// Whole steps/s² of the busiest motor.
    pub accel_steps: f64,
    /// The same in mm/s².
    pub accel: f64,
    pub max_entry_v2: f64,
    /// Long enough to brake from its nominal speed to `MINIMUM_PLANNER_SPEED`
    /// (`BLOCK_BIT_NOMINAL_LENGTH`): the lookahead then takes its junction speeds as they are.
    pub nominal_length: bool,
    /// No XYZ motor takes `MIN_STEPS_PER_SEGMENT` steps: measured along E (or A).
    pub xyz_below_min_steps: bool,
}

/// Populate a block for a move by `delta` steps requested at `feed_mm_s`, with `queued` blocks
/// in the buffer; `None` when the move is too short to be a block. Updates `prev` when a block
/// is made.
pub(crate) fn populate(
    delta: [f64; 5],
    feed_mm_s: f64,
    queued: usize,
    set: &Settings,
    prev: &mut Previous,
) -> Option<MarlinBlock> {
    let steps_abs = delta.map(f64::abs);
    let steps = steps_abs.iter().fold(0.0, |m: f64, &s| m.greater(s));
    if steps < MIN_STEPS_PER_SEGMENT {
        return None;
    }
    // Marlin computes the length, the rates and the acceleration in single precision, and
    // its roundings up (`ceil`) fall differently when a rate is a whole number in exact
    // arithmetic (a 180 mm move at 25 mm/s and 80 steps/mm is 2000 steps/s exactly, 2001 in
    // `float`): so does gweave, up to the acceleration in mm/s². The corner speeds after it
    // are in double precision, where rounding no longer shifts a whole step.
    let dist32: [f32; 5] = std::array::from_fn(|i| delta[i] as f32 * set.mm_per_step[i]);
    let xyz_steps = steps_abs[..3].iter().any(|&s| s >= MIN_STEPS_PER_SEGMENT);
    let mm32 = length_mm(&dist32, &steps_abs, xyz_steps);
    let extrudes = steps_abs[3] > 0.0;
    let steps32 = steps as f32;
    let inverse_mm32 = 1.0 / mm32;

    let inverse_s32 = slowdown(marlin_feed(feed_mm_s) * inverse_mm32, queued, set);
    let mut nominal_v2_32 = (mm32 * inverse_s32) * (mm32 * inverse_s32);
    let mut nominal_rate = ceil(f64::from(steps32 * inverse_s32));
    let mut speed32: [f32; 5] = dist32.map(|d| d * inverse_s32);
    // An axis that does not move (speed 0) is never over its positive limit.
    let mut factor = 1.0f32;
    for (s, &max) in speed32.iter().zip(&set.max_feed32) {
        let cs = s.abs();
        if cs > max {
            factor = factor.min(max / cs);
        }
    }
    if factor < 1.0 {
        speed32 = speed32.map(|s| s * factor);
        // `nominal_rate *= speed_factor` on an unsigned integer: truncated.
        nominal_rate = trunc(f64::from(nominal_rate as f32 * factor));
        nominal_v2_32 *= factor * factor;
    }
    let steps_per_mm32 = steps32 * inverse_mm32;
    let accel_steps = acceleration_steps(set, &steps_abs, steps, steps_per_mm32, extrudes);
    let accel = (accel_steps as f32 / steps_per_mm32) as f64;
    let mm = mm32 as f64;
    let nominal_v2 = nominal_v2_32 as f64;
    let speed = speed32.map(f64::from);

    let first = queued == 0 || prev.nominal_v2 < 1e-12;
    let max_entry_v2 = match set.corners {
        MarlinCorners::JunctionDeviation(jd) => {
            let dist = dist32.map(f64::from);
            let unit = if extrudes { normalised(dist) } else { dist.map(|d| d / mm) };
            let v2 = if first {
                0.0
            } else {
                deviation_v2(&prev.unit, &unit, accel, mm, jd, set).lesser(nominal_v2).lesser(prev.nominal_v2)
            };
            prev.unit = unit;
            v2
        }
        MarlinCorners::Jerk(jerk) => {
            let jerk = jerk.to_array();
            let nominal_v = nominal_v2.sqrt();
            let safe_v = safe_speed(nominal_v, &speed, &jerk);
            let v = if first { safe_v } else { jerk_junction_v(nominal_v, &speed, safe_v, prev, &jerk) };
            prev.safe_v = safe_v;
            v * v
        }
    };
    prev.speed = speed;
    prev.nominal_v2 = nominal_v2;
    let nominal_length = nominal_v2 <= MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED + 2.0 * accel * mm;
    Some(MarlinBlock {
        steps,
        mm,
        nominal_rate,
        nominal_v2,
        accel_steps,
        accel,
        max_entry_v2,
        nominal_length,
        xyz_below_min_steps: !xyz_steps,
    })
}

/// The block's length: XYZ, or along E when no XYZ motor takes `MIN_STEPS_PER_SEGMENT` steps.
fn length_mm(dist32: &[f32; 5], steps_abs: &[f64; 5], xyz_steps: bool) -> f32 {
    if xyz_steps {
        (dist32[0] * dist32[0] + dist32[1] * dist32[1] + dist32[2] * dist32[2]).sqrt()
    } else if steps_abs[4] > 0.0 {
        // gweave's rotary axis (not in Marlin 2.0): an A move without XYZ is measured in degrees.
        dist32[4].abs()
    } else {
        dist32[3].abs()
    }
}

/// `SLOWDOWN`: while 2 to `BLOCK_BUFFER_SIZE / 2 - 1` blocks are queued, a block shorter than
/// the minimum segment time `min` takes `t + 2 (min - t) / queued` (Marlin's whole
/// microseconds and integer division). Returns the new inverse of the block's time.
fn slowdown(inverse_s32: f32, queued: usize, set: &Settings) -> f32 {
    if !(2..set.buffer_size / SLOWDOWN_DIVISOR).contains(&queued) {
        return inverse_s32;
    }
    let segment_us = round_i64(f64::from(1e6f32 / inverse_s32));
    let short_us = set.min_segment_time_us as i64 - segment_us;
    if short_us > 0 {
        1e6f32 / (segment_us + 2 * short_us / queued as i64) as f32
    } else {
        inverse_s32
    }
}

/// The acceleration in whole steps/s² of the busiest motor: M204 R without XYZ (or A) steps,
/// else P when extruding and T when not, rounded up; then held to each moving motor's M201
/// limit in whole steps/s² (Marlin's `LIMIT_ACCEL_LONG`, truncating).
fn acceleration_steps(
    set: &Settings,
    steps_abs: &[f64; 5],
    steps: f64,
    steps_per_mm32: f32,
    extrudes: bool,
) -> f64 {
    let moves_xyza = steps_abs[..3].iter().chain(&steps_abs[4..]).any(|&s| s > 0.0);
    if !moves_xyza {
        return ceil(f64::from(set.accel[2] as f32 * steps_per_mm32));
    }
    let base = if extrudes { set.accel[0] } else { set.accel[1] };
    let mut a = ceil(f64::from(base as f32 * steps_per_mm32));
    for (&axis_steps, &max) in steps_abs.iter().zip(&set.max_accel_steps) {
        if axis_steps > 0.0 && max < a && a * axis_steps > max * steps {
            a = trunc(max * steps / axis_steps);
        }
    }
    a
}

/// The feed rate as Marlin holds it: `F` / 60 in single precision, scaled by the 100 %
/// feed-rate override (`MMS_SCALED`, `0.01f * 100`, in double precision), back to single.
fn marlin_feed(feed_mm_s: f64) -> f32 {
    let f = (feed_mm_s * 60.0) as f32 / 60.0;
    (f as f64 * f64::from(0.01f32) * 100.0) as f32
}

/// The vector scaled to length 1 (zero components stay zero).
fn normalised(v: [f64; 5]) -> [f64; 5] {
    let len = v.iter().map(|c| c * c).sum::<f64>().sqrt();
    v.map(|c| c / len)
}

/// Junction deviation between unit directions `prev` and `unit` (see the module comment).
fn deviation_v2(prev: &[f64; 5], unit: &[f64; 5], accel: f64, mm: f64, jd: f64, set: &Settings) -> f64 {
    let neg_cos: f64 = -prev.iter().zip(unit).map(|(a, b)| a * b).sum::<f64>();
    if neg_cos > REVERSAL_NEG_COS {
        return MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED;
    }
    let neg_cos = neg_cos.max(-REVERSAL_NEG_COS);
    let change = normalised(std::array::from_fn(|i| unit[i] - prev[i]));
    // An axis whose direction does not change (0) is never over its positive limit.
    let mut junction_accel = accel;
    for (&c, &max) in change.iter().zip(&set.max_accel) {
        if junction_accel * c.abs() > max {
            junction_accel = (max / c).abs();
        }
    }
    let sin = HalfAngle::from_neg_cos(neg_cos).sin;
    let mut v2 = junction_accel * jd * sin / (1.0 - sin);
    if mm < SMALL_SEGMENT_MM && neg_cos < SMALL_SEGMENT_NEG_COS {
        // A polygon of short sides approximates an arc: turning by theta over mm is a circle
        // of radius mm / theta, whose centripetal limit is v^2 = a mm / theta.
        let theta = (-neg_cos).acos();
        v2 = v2.lesser(mm * junction_accel / theta);
    }
    v2
}

/// The speed from which the block may start out of rest: no axis above its jerk.
fn safe_speed(nominal_v: f64, speed: &[f64; 5], jerk: &[f64; 4]) -> f64 {
    let mut safe = nominal_v;
    let mut limited = false;
    for (s, &j) in speed.iter().zip(jerk) {
        let s = s.abs();
        if s > j {
            if limited {
                if s * safe > nominal_v * j {
                    safe = nominal_v * j / s;
                }
            } else {
                safe *= j / s;
                limited = true;
            }
        }
    }
    safe
}

/// Classic jerk at the junction with the previous block.
fn jerk_junction_v(nominal_v: f64, speed: &[f64; 5], safe_v: f64, prev: &Previous, jerk: &[f64; 4]) -> f64 {
    let prev_nominal_v = prev.nominal_v2.sqrt();
    let (mut v, smaller) = if nominal_v < prev_nominal_v {
        (nominal_v, nominal_v / prev_nominal_v)
    } else {
        (prev_nominal_v, 1.0)
    };
    let mut factor = 1.0;
    for ((&exit, &entry), &j) in prev.speed.iter().zip(speed).zip(jerk) {
        let (exit, entry) = (exit * smaller * factor, entry * factor);
        let change = if exit > entry {
            if entry > 0.0 || exit < 0.0 {
                exit - entry
            } else {
                exit.max(-entry)
            }
        } else if entry < 0.0 || exit > 0.0 {
            entry - exit
        } else {
            (-exit).max(entry)
        };
        if change > j {
            factor *= j / change;
        }
    }
    v *= factor;
    let threshold = v * 0.99;
    if prev.safe_v > threshold && safe_v > threshold {
        v = safe_v;
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::limits::{CornerMode, Jerk};

    fn jerk_profile() -> MotionProfile {
        let mut p = MotionProfile::default();
        if let CornerMode::Marlin { jerk_mm_s, junction_deviation_mm, .. } = &mut p.corners {
            *junction_deviation_mm = None;
            *jerk_mm_s = Some(Jerk { x: 10.0, y: 10.0, z: 0.3, e: 5.0 });
        }
        p
    }

    #[test]
    fn fewer_than_six_steps_is_no_block() {
        let set = Settings::new(&MotionProfile::default(), 0);
        let mut prev = Previous::default();
        assert!(populate([5.0, -5.0, 0.0, 5.0, 0.0], 50.0, 3, &set, &mut prev).is_none());
        // XY under six steps but E over: measured along E (0.012 mm at 500 steps/mm).
        let b = populate([5.0, 0.0, 0.0, 6.0, 0.0], 50.0, 3, &set, &mut prev).unwrap();
        assert_eq!((b.steps, b.mm), (6.0, f64::from(0.012f32)));
    }

    #[test]
    fn square_corner_under_classic_jerk() {
        // 10 mm +X then 10 mm +Y at 50 mm/s, jerk 10. X stops from 50: the junction speed is
        // scaled by 10/50 to 10 mm/s, and Y then starts from 0 to 10, within its jerk. Both
        // safe speeds (10 mm/s) exceed 99 % of that, so the safe speed it is.
        let set = Settings::new(&jerk_profile(), 0);
        let mut prev = Previous::default();
        let first = populate([800.0, 0.0, 0.0, 0.0, 0.0], 50.0, 0, &set, &mut prev).unwrap();
        assert!((first.max_entry_v2 - 100.0).abs() < 1e-9, "{first:?}");
        let corner = populate([0.0, 800.0, 0.0, 0.0, 0.0], 50.0, 1, &set, &mut prev).unwrap();
        assert!((corner.max_entry_v2 - 100.0).abs() < 1e-9, "{corner:?}");
        // Straight on at the same speed: no change of speed, so the nominal speed.
        let on = populate([0.0, 800.0, 0.0, 0.0, 0.0], 50.0, 2, &set, &mut prev).unwrap();
        assert!((on.max_entry_v2 - 2500.0).abs() < 1e-9, "{on:?}");
    }

    #[test]
    fn rates_round_up_and_acceleration_is_whole_steps() {
        // 10 mm at 33.33 mm/s, 80 steps/mm: 800 steps at ceil(2666.4) = 2667 steps/s; accel
        // ceil(3000 * 80) = 240000 steps/s², X's own limit.
        let set = Settings::new(&MotionProfile::default(), 0);
        let mut prev = Previous::default();
        let b = populate([800.0, 0.0, 0.0, 0.0, 0.0], 33.33, 0, &set, &mut prev).unwrap();
        assert_eq!((b.nominal_rate, b.accel_steps), (2667.0, 240_000.0));
    }
}
