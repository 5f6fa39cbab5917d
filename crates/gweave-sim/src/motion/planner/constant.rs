//! Constant-speed motion: the controller seed's stepping (`[motion.corners] mode = "constant"`).
//!
//! The seed's firmware (an Arduino controller, docs/seeds.md) has no planner and no
//! acceleration. Each move is a Bresenham line over X Y Z E: the motor with the most steps
//! ("dominant") steps once per loop and the loop waits a fixed delay derived from the feed rate,
//! so every motor starts and stops at full speed and every corner is taken at full speed. The
//! delay makes the dominant motor run at the commanded feed:
//!
//! ```text
//!   step period  = 1 / (feed_mm_s * steps_per_mm of the dominant motor)
//!   move time    = dominant steps * step period
//! ```
//!
//! The time is counted in whole steps, as the seed's loop runs, not as `length / feed`: the
//! two differ by the rounding of the end points to whole steps (a 0.01 mm X move at 80 steps/mm
//! is one step, 0.0125 mm of motor travel), and a diagonal runs faster than its feed along the
//! path, since the feed holds along the dominant axis only (X10 Y10 at F600 takes 1 s, not
//! 1.414 s). The step counts are those of whole-step positions, `round(end * steps_per_mm) -
//! round(start * steps_per_mm)`, the motors' own counts as long as no `G92` has put an axis off
//! its step grid. Ties go to the first motor in X Y Z E A order.
//!
//! What is not the seed's: the delay is exact (the seed's delay code is a figure its text does
//! not reproduce; an Arduino delay counts whole microseconds, and the loop body takes its own
//! time per step), and A (rotary) counts as one more motor.

use super::{PlannedBlock, Trapezoid};
use crate::motion::kinematics::{Geometry, Move};
use crate::motion::limits::StepsPerUnit;
use crate::motion::rounding::round_i64;

/// The block of `mv` at constant speed: no acceleration, its whole time cruising.
pub(super) fn block(mv: &Move, geo: &Geometry, steps: &StepsPerUnit) -> PlannedBlock {
    let t_s = duration_s(mv, steps);
    // The speed along the block's reference length; a move of no whole step takes no time
    // (its motors do not move) and keeps its feed as its speed.
    let v = if t_s > 0.0 { geo.len / t_s } else { mv.feed_mm_s };
    let trapezoid = Trapezoid {
        entry_v_mm_s: v,
        cruise_v_mm_s: v,
        exit_v_mm_s: v,
        cruise_t_s: t_s,
        ..Trapezoid::default()
    };
    PlannedBlock::new(mv, (geo.len, geo.kind), 0.0, trapezoid)
}

/// The time of `mv`: its dominant motor's steps, each `1 / (feed * steps_per_unit)` long.
fn duration_s(mv: &Move, steps: &StepsPerUnit) -> f64 {
    let spu = [steps.x, steps.y, steps.z, steps.e, steps.a()];
    let (start, end) = (mv.start.to_array(), mv.end.to_array());
    let mut dominant = (0_u64, 1.0);
    for i in 0..5 {
        let n = (round_i64(end[i] * spu[i]) - round_i64(start[i] * spu[i])).unsigned_abs();
        if n > dominant.0 {
            dominant = (n, spu[i]);
        }
    }
    let (n, spu) = dominant;
    n as f64 / (mv.feed_mm_s * spu)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::kinematics::{MoveKind, Pos};

    fn planned(start: Pos, end: Pos, feed_mm_min: f64) -> PlannedBlock {
        let mv = Move { start, end, feed_mm_s: feed_mm_min / 60.0, tag: 0 };
        block(&mv, &mv.geometry().unwrap(), &StepsPerUnit::default())
    }

    #[test]
    fn x_move_takes_its_steps_times_the_period() {
        // 10 mm at 80 steps/mm = 800 steps; F600 = 10 mm/s, period 1 / (10 * 80) s: 1.0 s.
        let b = planned(Pos::default(), Pos::xyze(10.0, 0.0, 0.0, 0.0), 600.0);
        assert_eq!(b.duration_s(), 1.0);
        let t = b.trapezoid;
        assert_eq!((t.entry_v_mm_s, t.cruise_v_mm_s, t.exit_v_mm_s), (10.0, 10.0, 10.0));
        assert_eq!((t.accel_t_s, t.decel_t_s, b.accel_mm_s2), (0.0, 0.0, 0.0));
    }

    #[test]
    fn diagonal_holds_the_feed_on_its_dominant_axis() {
        // X10 Y5 at F600: X is dominant with 800 steps (Y 400), 800 / (10 * 80) = 1.0 s, so
        // the 11.18 mm path runs at 11.18 mm/s, above the feed.
        let b = planned(Pos::default(), Pos::xyze(10.0, 5.0, 0.0, 0.0), 600.0);
        assert_eq!(b.duration_s(), 1.0);
        assert!((b.trapezoid.cruise_v_mm_s - 125f64.sqrt()).abs() < 1e-12);
        // With Z dominant (0.3 mm x 4000 = 1200 steps against X's 80): 1200 / (10 * 4000) s.
        let z = planned(Pos::default(), Pos::xyze(1.0, 0.0, 0.3, 0.0), 600.0);
        assert!((z.duration_s() - 0.03).abs() < 1e-15, "{}", z.duration_s());
    }

    #[test]
    fn extrude_only_move_runs_at_its_feed() {
        // A 2 mm retract at F2400 (40 mm/s), 500 steps/mm: 1000 steps of 1 / 20000 s = 0.05 s.
        let b = planned(Pos::xyze(0.0, 0.0, 0.0, 2.0), Pos::default(), 2400.0);
        assert_eq!(b.kind, MoveKind::ExtrudeOnly);
        assert!((b.duration_s() - 0.05).abs() < 1e-15, "{}", b.duration_s());
    }

    #[test]
    fn time_counts_whole_steps_not_length() {
        // 0.01 mm of X at 80 steps/mm rounds to one step (0.0125 mm): 1 / (10 * 80) s, where
        // length / feed would be 0.001 s.
        let one = planned(Pos::default(), Pos::xyze(0.01, 0.0, 0.0, 0.0), 600.0);
        assert_eq!(one.duration_s(), 1.0 / 800.0);
        // 0.004 mm is no whole step: no time, and the speed stays the feed.
        let none = planned(Pos::default(), Pos::xyze(0.004, 0.0, 0.0, 0.0), 600.0);
        assert_eq!((none.duration_s(), none.trapezoid.cruise_v_mm_s), (0.0, 10.0));
    }
}
