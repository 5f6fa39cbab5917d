//! Hand-computed plans for both planners.

use super::*;
use crate::motion::limits::KlipperLimits;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn mv(from: Pos, to: Pos, feed_mm_s: f64, tag: u64) -> Move {
    Move { start: from, end: to, feed_mm_s, tag }
}

/// Plan a path through `points` (XYZE) at one feed rate, then flush.
fn plan(profile: MotionProfile, points: &[[f64; 4]], feed_mm_s: f64) -> Vec<PlannedBlock> {
    let mut planner = Planner::new(profile).unwrap();
    let mut out = Vec::new();
    for (i, w) in points.windows(2).enumerate() {
        let p = |a: [f64; 4]| Pos::xyze(a[0], a[1], a[2], a[3]);
        planner.push(&mv(p(w[0]), p(w[1]), feed_mm_s, i as u64), &mut out).unwrap();
    }
    planner.flush(&mut out);
    assert_eq!(planner.queued(), 0);
    out
}

fn klipper() -> MotionProfile {
    MotionProfile::klipper(KlipperLimits::default())
}

fn marlin() -> MotionProfile {
    MotionProfile::default()
}

fn total_s(blocks: &[PlannedBlock]) -> f64 {
    blocks.iter().map(PlannedBlock::duration_s).sum()
}

/// Marlin's time for a block of `steps` at `nominal` steps/s, from and to `floor` steps/s,
/// `up` steps accelerating and `down` braking (see `marlin_steps.rs`).
fn marlin_steps_s(steps: f64, nominal: f64, floor: f64, up: f64, down: f64) -> f64 {
    (up + down) * 2.0 / (nominal + floor) + (steps - up - down) / nominal
}

#[test]
fn single_move_trapezoid_in_both_modes() {
    // 100 mm at 50 mm/s, a = 3000: 0 -> 50 in 1/60 s over 5/12 mm, same down.
    let b = plan(klipper(), &[[0.0; 4], [100.0, 0.0, 0.0, 0.0]], 50.0);
    let t = b[0].trapezoid;
    assert!(close(t.accel_t_s, 1.0 / 60.0, 1e-12) && close(t.decel_t_s, 1.0 / 60.0, 1e-12), "{t:?}");
    assert!(close(t.cruise_t_s, (100.0 - 5.0 / 6.0) / 50.0, 1e-12), "{t:?}");
    assert_eq!((t.entry_v_mm_s, t.exit_v_mm_s), (0.0, 0.0));
    // Marlin, in steps of 1/80 mm: 4000 steps/s, 240000 steps/s², from and to the 120 steps/s
    // floor (1.5 mm/s): ceil(33.30) = 34 steps up, floor(33.30) = 33 down.
    let b = plan(marlin(), &[[0.0; 4], [100.0, 0.0, 0.0, 0.0]], 50.0);
    let t = b[0].trapezoid;
    assert!(close(b[0].duration_s(), marlin_steps_s(8000.0, 4000.0, 120.0, 34.0, 33.0), 1e-12), "{t:?}");
    assert_eq!((t.entry_v_mm_s, t.cruise_v_mm_s, t.exit_v_mm_s), (1.5, 50.0, 1.5));
}

#[test]
fn short_move_is_a_triangle() {
    // 3 mm, a = 3000, wants 200 mm/s: peak v^2 = 3000 * 3 = 9000 (94.87 mm/s), no cruise.
    let no_cruise_ratio = KlipperLimits { minimum_cruise_ratio: 0.0, ..KlipperLimits::default() };
    let b = plan(MotionProfile::klipper(no_cruise_ratio), &[[0.0; 4], [3.0, 0.0, 0.0, 0.0]], 200.0);
    let t = b[0].trapezoid;
    assert!(close(t.cruise_v_mm_s, 9000f64.sqrt(), 1e-9), "{t:?}");
    assert!(close(t.cruise_t_s, 0.0, 1e-12));
    assert!(close(t.accel_t_s, 9000f64.sqrt() / 3000.0, 1e-12), "{t:?}");
    // Marlin: 240 steps meet halfway; 120 steps of 240000 steps/s² from 120 steps/s reach
    // trunc(sqrt(120² + 480000 * 120)) = 7590 steps/s, 94.875 mm/s.
    let b = plan(marlin(), &[[0.0; 4], [3.0, 0.0, 0.0, 0.0]], 200.0);
    let t = b[0].trapezoid;
    assert_eq!((t.cruise_v_mm_s, t.cruise_t_s), (94.875, 0.0));
    assert!(close(b[0].duration_s(), 480.0 / 7710.0, 1e-12), "{t:?}");
}

#[test]
fn klipper_minimum_cruise_ratio_keeps_half_the_move_cruising() {
    // Planned with a_mcr = 1500: peak v^2 = 1500 * 3 = 4500 (67.08 mm/s); at a = 3000 that
    // takes 0.75 mm each way and leaves 1.5 mm, half the move, to cruise.
    let b = plan(klipper(), &[[0.0; 4], [3.0, 0.0, 0.0, 0.0]], 200.0);
    let t = b[0].trapezoid;
    let v = 4500f64.sqrt();
    assert!(close(t.cruise_v_mm_s, v, 1e-9), "{t:?}");
    assert!(close(t.cruise_t_s, 1.5 / v, 1e-12) && close(t.accel_t_s, v / 3000.0, 1e-12), "{t:?}");
}

#[test]
fn klipper_square_corner_runs_at_square_corner_velocity() {
    let b = plan(klipper(), &[[0.0; 4], [50.0, 0.0, 0.0, 0.0], [50.0, 50.0, 0.0, 0.0]], 100.0);
    assert!(close(b[0].trapezoid.exit_v_mm_s, 5.0, 1e-9), "{:?}", b[0].trapezoid);
    assert!(close(b[1].trapezoid.entry_v_mm_s, 5.0, 1e-9));
    // Each leg: 0/5 -> 100 and back with a = 3000; speeds are capped at 100 mm/s.
    let leg = |v0: f64, v1: f64| {
        let (ad, dd) = ((1e4 - v0 * v0) / 6000.0, (1e4 - v1 * v1) / 6000.0);
        ad / ((v0 + 100.0) / 2.0) + dd / ((v1 + 100.0) / 2.0) + (50.0 - ad - dd) / 100.0
    };
    assert!(close(total_s(&b), leg(0.0, 5.0) + leg(5.0, 0.0), 1e-12));
}

#[test]
fn marlin_square_corner_uses_junction_deviation() {
    // v^2 = 3000 * 0.013 * sin45 / (1 - sin45) = 94.155, v = 9.7033 mm/s; Marlin leaves the
    // first leg at that speed rounded up to a whole step rate (8000 steps/s nominal):
    // ceil(8000 * 9.7033 / 100) = 777 steps/s, 9.7125 mm/s.
    let b = plan(marlin(), &[[0.0; 4], [50.0, 0.0, 0.0, 0.0], [50.0, 50.0, 0.0, 0.0]], 100.0);
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let v = (3000.0 * 0.013 * s / (1.0 - s)).sqrt();
    assert!(close(v, 9.7033, 1e-4));
    assert_eq!(b[0].trapezoid.exit_v_mm_s, 777.0 / 80.0, "{:?}", b[0].trapezoid);
}

#[test]
fn collinear_chain_does_not_slow_down() {
    let pts: Vec<[f64; 4]> = (0..=10).map(|i| [10.0 * i as f64, 0.0, 0.0, 0.0]).collect();
    for profile in [klipper(), marlin()] {
        let b = plan(profile, &pts, 50.0);
        assert_eq!(b.len(), 10);
        for blk in &b[1..9] {
            assert_eq!((blk.trapezoid.entry_v_mm_s, blk.trapezoid.exit_v_mm_s), (50.0, 50.0));
        }
        assert_eq!(b.iter().map(|b| b.tag).collect::<Vec<_>>(), (0..10).collect::<Vec<_>>());
    }
    // Like one 100 mm move: L/v + v/a, and in Marlin's steps as its single-move test.
    assert!(close(total_s(&plan(klipper(), &pts, 50.0)), 2.0 + 50.0 / 3000.0, 1e-12));
    let marlin_s = total_s(&plan(marlin(), &pts, 50.0));
    assert!(close(marlin_s, marlin_steps_s(8000.0, 4000.0, 120.0, 34.0, 33.0), 1e-12), "{marlin_s}");
}

#[test]
fn marlin_drops_moves_under_six_steps_and_carries_them_on() {
    // 0.05 mm (4 steps) is no block; the next move starts where the last block ended, so it
    // takes the 4 steps with it: 0.05 + 10 mm, 804 steps.
    let b = plan(marlin(), &[[0.0; 4], [0.05, 0.0, 0.0, 0.0], [10.05, 0.0, 0.0, 0.0]], 50.0);
    assert_eq!(b.len(), 1);
    assert_eq!((b[0].start.x_mm, b[0].end.x_mm, b[0].tag), (0.0, 10.05, 1));
    assert!(close(b[0].len, 10.05, 1e-12));
}

#[test]
fn klipper_extruder_corner_limit() {
    // Straight on, but E per mm jumps from 0 to 0.04: v <= 1 / 0.04 = 25 mm/s.
    let b = plan(klipper(), &[[0.0; 4], [50.0, 0.0, 0.0, 0.0], [100.0, 0.0, 0.0, 2.0]], 100.0);
    assert!(close(b[0].trapezoid.exit_v_mm_s, 25.0, 1e-9), "{:?}", b[0].trapezoid);
}

#[test]
fn klipper_extrude_only_limits() {
    let limits = KlipperLimits {
        max_extrude_only_velocity_mm_s: Some(30.0),
        max_extrude_only_accel_mm_s2: Some(800.0),
        ..KlipperLimits::default()
    };
    let b = plan(MotionProfile::klipper(limits), &[[0.0; 4], [0.0, 0.0, 0.0, -2.0]], 45.0);
    // 30 mm/s at 800: 0.5625 mm each way in 0.0375 s, 0.875 mm cruise.
    assert!(close(b[0].duration_s(), 0.075 + 0.875 / 30.0, 1e-12), "{:?}", b[0]);
    assert_eq!(b[0].kind, MoveKind::ExtrudeOnly);
    // Unbounded: 45 mm/s with Klipper's 1e8 mm/s^2 placeholder.
    let b = plan(klipper(), &[[0.0; 4], [0.0, 0.0, 0.0, -2.0]], 45.0);
    assert!(close(b[0].duration_s(), 2.0 / 45.0, 1e-6), "{:?}", b[0]);
}

#[test]
fn z_limits() {
    let limits = KlipperLimits { max_z_velocity_mm_s: Some(5.0), ..KlipperLimits::default() };
    let b = plan(MotionProfile::klipper(limits), &[[0.0; 4], [0.0, 0.0, 10.0, 0.0]], 50.0);
    assert!(close(b[0].trapezoid.cruise_v_mm_s, 5.0, 1e-12));
    // Marlin: Z at most 5 mm/s and 100 mm/s^2, at 4000 steps/mm 20000 steps/s and 400000
    // steps/s², from and to 0.05 mm/s: 20000 * 0.01 is 200.00002 in single precision, so 201
    // steps/s; ceil(499.95) = 500 steps up, 499 down.
    let b = plan(marlin(), &[[0.0; 4], [0.0, 0.0, 10.0, 0.0]], 50.0);
    let want = marlin_steps_s(40_000.0, 20_000.0, 201.0, 500.0, 499.0);
    assert!(close(b[0].duration_s(), want, 1e-12), "{:?}", b[0]);
}

#[test]
fn marlin_extruder_with_its_own_limits() {
    // T1 may move E at 2 mm/s only: a 10 mm prime at 20 mm/s takes about 5 s there, and about
    // 0.5 s on T0 (E limit 25 mm/s).
    let mut p = marlin();
    p.extruders = vec![
        Default::default(),
        crate::motion::limits::ExtruderLimits { max_feed_mm_s: Some(2.0), ..Default::default() },
    ];
    let mut planner = Planner::new(p).unwrap();
    let mut out: Vec<PlannedBlock> = Vec::new();
    let prime =
        |from: f64| mv(Pos::xyze(0.0, 0.0, 0.0, from), Pos::xyze(0.0, 0.0, 0.0, from + 10.0), 20.0, 0);
    planner.push(&prime(0.0), &mut out).unwrap();
    planner.flush(&mut out);
    planner.select_tool(1);
    planner.push(&prime(10.0), &mut out).unwrap();
    planner.flush(&mut out);
    assert!((out[0].duration_s() - 0.5).abs() < 0.01, "{:?}", out[0]);
    assert!((out[1].duration_s() - 5.0).abs() < 0.01, "{:?}", out[1]);
    assert_eq!(out[1].trapezoid.cruise_v_mm_s, 2.0);
}

#[test]
fn marlin_buffer_is_bounded_and_emits_early() {
    let mut planner = Planner::new(marlin()).unwrap();
    let mut n = 0usize;
    let mut count = |_: &PlannedBlock| n += 1;
    for i in 0..100 {
        let (a, b) = (Pos::xyze(i as f64, 0.0, 0.0, 0.0), Pos::xyze(i as f64 + 1.0, 0.0, 0.0, 0.0));
        planner.push(&mv(a, b, 50.0, 0), &mut count).unwrap();
        assert!(planner.queued() <= 16);
    }
    planner.flush(&mut count);
    assert_eq!(n, 100);
}

#[test]
fn marlin_travel_print_and_retract_accelerations() {
    let mut p = marlin();
    p.accel =
        crate::motion::limits::MoveAccel { print_mm_s2: 500.0, retract_mm_s2: 1000.0, travel_mm_s2: 2000.0 };
    let b =
        plan(p, &[[0.0; 4], [100.0, 0.0, 0.0, 0.0], [200.0, 0.0, 0.0, 1.0], [200.0, 0.0, 0.0, 0.0]], 20.0);
    assert_eq!(b.iter().map(|b| b.accel_mm_s2).collect::<Vec<_>>(), vec![2000.0, 500.0, 1000.0]);
}

#[test]
fn zero_length_moves_are_dropped_and_bad_moves_rejected() {
    let mut planner = Planner::new(klipper()).unwrap();
    let mut out: Vec<PlannedBlock> = Vec::new();
    planner.push(&mv(Pos::default(), Pos::default(), 10.0, 0), &mut out).unwrap();
    assert_eq!(planner.queued(), 0);
    let bad = mv(Pos::default(), Pos::xyze(1.0, 0.0, 0.0, 0.0), -1.0, 0);
    assert_eq!(planner.push(&bad, &mut out), Err(MoveError::BadFeed(-1.0)));
    for feed in [0.0, f64::INFINITY] {
        let bad = mv(Pos::default(), Pos::xyze(1.0, 0.0, 0.0, 0.0), feed, 0);
        assert_eq!(planner.push(&bad, &mut out), Err(MoveError::BadFeed(feed)));
    }
    let nan = mv(Pos::default(), Pos::xyze(1.0, 0.0, 0.0, 0.0), f64::NAN, 0);
    assert!(matches!(planner.push(&nan, &mut out), Err(MoveError::BadFeed(f)) if f.is_nan()));
    // Any axis, either end, infinite or NaN; a huge but finite position is fine.
    for v in [f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
        for axis in 0..5 {
            let mut end = [1.0, 0.0, 0.0, 0.0, 0.0];
            end[axis] = v;
            let to = Pos { x_mm: end[0], y_mm: end[1], z_mm: end[2], e_mm: end[3], a_deg: end[4] };
            for (from, to) in [(Pos::default(), to), (to, Pos::default())] {
                let bad = mv(from, to, 10.0, 0);
                assert_eq!(planner.push(&bad, &mut out), Err(MoveError::NonFinitePosition), "{v} on {axis}");
            }
        }
    }
    assert!(planner.push(&mv(Pos::default(), Pos::xyze(1e300, 0.0, 0.0, 0.0), 10.0, 0), &mut out).is_ok());
}

#[test]
fn profile_changes_apply_to_later_moves_only() {
    let mut planner = Planner::new(klipper()).unwrap();
    let mut p = planner.profile().clone();
    p.set_accel(&crate::motion::limits::M204 { s: Some(1000.0), ..Default::default() }).unwrap();
    let mut out: Vec<PlannedBlock> = Vec::new();
    let a = Pos::xyze(10.0, 0.0, 0.0, 0.0);
    planner.push(&mv(Pos::default(), a, 50.0, 0), &mut out).unwrap();
    planner.set_profile(p).unwrap();
    planner.push(&mv(a, Pos::xyze(10.0, 10.0, 0.0, 0.0), 50.0, 1), &mut out).unwrap();
    planner.flush(&mut out);
    assert_eq!((out[0].accel_mm_s2, out[1].accel_mm_s2), (3000.0, 1000.0));
    assert_eq!(planner.set_profile(marlin()), Err(ProfileError::ModeChange));
}

fn random_path() -> impl proptest::strategy::Strategy<Value = Vec<([f64; 4], f64)>> {
    use proptest::prelude::*;
    let point = (-20.0..20.0f64, -20.0..20.0f64, 0.0..2.0f64, -1.0..2.0f64, 1.0..250.0f64);
    proptest::collection::vec(point, 1..120)
        .prop_map(|v| v.into_iter().map(|(x, y, z, e, f)| ([x, y, z, e], f)).collect())
}

proptest::proptest! {
    /// Every Klipper plan is physically consistent: speeds continuous across junctions, from and
    /// to rest, never above the requested feed, and no speed change steeper than the
    /// acceleration.
    #[test]
    fn plans_are_consistent(path in random_path()) {
        let (out, feeds) = plan_random(klipper(), &path);
        proptest::prop_assert_eq!(out.len(), path.len());
        proptest::prop_assert_eq!(out[0].trapezoid.entry_v_mm_s, 0.0);
        proptest::prop_assert_eq!(out[out.len() - 1].trapezoid.exit_v_mm_s, 0.0);
        for w in out.windows(2) {
            let (a, b) = (w[0].trapezoid.exit_v_mm_s, w[1].trapezoid.entry_v_mm_s);
            proptest::prop_assert!(close(a, b, 1e-9 * a.max(1.0)), "{a} then {b}");
        }
        for b in &out {
            let t = b.trapezoid;
            let slack = 1e-9 * t.cruise_v_mm_s.max(1.0);
            proptest::prop_assert!(t.cruise_v_mm_s <= feeds[b.tag as usize] + slack);
            proptest::prop_assert!(t.entry_v_mm_s <= t.cruise_v_mm_s + slack && t.exit_v_mm_s <= t.cruise_v_mm_s + slack);
            let dv2 = 2.0 * b.accel_mm_s2 * b.len;
            let up = t.cruise_v_mm_s.powi(2) - t.entry_v_mm_s.powi(2);
            let down = t.cruise_v_mm_s.powi(2) - t.exit_v_mm_s.powi(2);
            proptest::prop_assert!(up + down <= dv2 * (1.0 + 1e-9) + 1e-9, "{b:?}");
            proptest::prop_assert!(t.accel_t_s >= 0.0 && t.cruise_t_s >= 0.0 && t.decel_t_s >= 0.0);
            proptest::prop_assert!(b.duration_s().is_finite() && b.duration_s() > 0.0);
        }
    }

    /// Marlin plans in whole steps, so its speeds are rounded (up, and to at least 120 steps/s);
    /// what holds exactly: blocks in order, each a chain of moves ending where the next block
    /// starts, every phase time finite and non-negative, and a move of many steps never slower
    /// than its feed allows.
    #[test]
    fn marlin_plans_are_consistent(path in random_path(), jerk in proptest::bool::ANY) {
        let mut profile = marlin();
        if jerk {
            profile.corners = crate::motion::limits::CornerMode::Marlin {
                junction_deviation_mm: None,
                jerk_mm_s: Some(crate::motion::limits::Jerk { x: 10.0, y: 10.0, z: 0.3, e: 5.0 }),
                lookahead_blocks: 16,
                min_segment_time_us: 20_000.0,
            };
        }
        let (out, _) = plan_random(profile, &path);
        proptest::prop_assert!(out.len() <= path.len());
        for w in out.windows(2) {
            proptest::prop_assert!(w[0].tag < w[1].tag);
            proptest::prop_assert_eq!(w[0].end, w[1].start);
        }
        for b in &out {
            let t = b.trapezoid;
            proptest::prop_assert!(t.accel_t_s >= 0.0 && t.cruise_t_s >= 0.0 && t.decel_t_s >= 0.0);
            proptest::prop_assert!(b.duration_s().is_finite() && b.duration_s() > 0.0, "{b:?}");
        }
    }
}

fn plan_random(profile: MotionProfile, path: &[([f64; 4], f64)]) -> (Vec<PlannedBlock>, Vec<f64>) {
    let mut planner = Planner::new(profile).unwrap();
    let mut out: Vec<PlannedBlock> = Vec::new();
    let mut at = Pos::default();
    let mut feeds = Vec::new();
    for (p, f) in path {
        let to = Pos::xyze(p[0], p[1], p[2], p[3]);
        planner.push(&mv(at, to, *f, feeds.len() as u64), &mut out).unwrap();
        feeds.push(*f);
        at = to;
    }
    planner.flush(&mut out);
    (out, feeds)
}

/// An emergency stop drops what is queued unexecuted (Marlin's `quick_stop()`, Klipper's
/// shutdown) and says how far it would have gone, so that the caller takes its position back;
/// the next move plans from a standstill, alone.
#[test]
fn a_discarded_queue_runs_nothing_and_says_how_far_it_went() {
    for profile in [marlin(), klipper()] {
        let mut planner = Planner::new(profile).unwrap();
        let mut out = Vec::new();
        let points = [[0.0; 4], [10.0, 0.0, 0.0, 1.0], [10.0, 5.0, 0.0, 1.5], [20.0, 5.0, 1.0, 1.5]];
        for (i, w) in points.windows(2).enumerate() {
            let p = |a: [f64; 4]| Pos::xyze(a[0], a[1], a[2], a[3]);
            planner.push(&mv(p(w[0]), p(w[1]), 50.0, i as u64), &mut out).unwrap();
        }
        assert!(out.is_empty(), "nothing emitted before the stop: {out:?}");
        let undone = planner.discard();
        assert!(
            undone.iter().zip([20.0, 5.0, 1.0, 1.5, 0.0]).all(|(u, w)| close(*u, w, 1e-12)),
            "{undone:?}"
        );
        assert_eq!(planner.queued(), 0);
        planner.flush(&mut out);
        assert!(out.is_empty(), "the dropped moves never run: {out:?}");
        // From where the machine stopped, the next move alone, from a standstill.
        let start = Pos::xyze(0.0, 0.0, 0.0, 0.0);
        planner.push(&mv(start, Pos::xyze(100.0, 0.0, 0.0, 0.0), 50.0, 9), &mut out).unwrap();
        planner.flush(&mut out);
        assert_eq!(out.len(), 1);
        let alone = plan(planner.profile().clone(), &[[0.0; 4], [100.0, 0.0, 0.0, 0.0]], 50.0);
        assert_eq!(out[0].duration_s(), alone[0].duration_s());
    }
}
