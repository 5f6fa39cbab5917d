//! Planner throughput on ten million short moves (a zig-zag infill with extrusion).
//! Run with `cargo test -p gweave-sim --release --test throughput -- --ignored --nocapture`.

use std::time::Instant;

use gweave_sim::Steppers;
use gweave_sim::{KlipperLimits, MotionProfile};
use gweave_sim::{Move, Pos};
use gweave_sim::{PlannedBlock, Planner};

fn run(profile: MotionProfile, n: u64) -> (f64, f64) {
    let mut planner = Planner::new(profile.clone()).unwrap();
    let mut steppers = Steppers::new(&profile.steps);
    let mut total_s = 0.0;
    let mut sink = |b: &PlannedBlock| {
        total_s += b.duration_s();
        steppers.step_block(b, &[]);
    };
    let started = Instant::now();
    let mut at = Pos::default();
    for i in 0..n {
        // 0.4 mm segments turning by 30 degrees, alternating, along a 100 mm row.
        let angle: f64 = if i % 2 == 0 { 0.26 } else { -0.26 };
        let to = Pos::xyze(at.x_mm + 0.4 * angle.cos(), at.y_mm + 0.4 * angle.sin(), 0.2, at.e_mm + 0.013);
        let to = if to.x_mm > 100.0 { Pos { x_mm: 0.0, ..to } } else { to };
        planner.push(&Move { start: at, end: to, feed_mm_s: 60.0, tag: i }, &mut sink).unwrap();
        at = to;
    }
    planner.flush(&mut sink);
    (started.elapsed().as_secs_f64(), total_s)
}

#[test]
#[ignore = "a release-mode benchmark"]
fn ten_million_moves() {
    for (name, profile) in
        [("klipper", MotionProfile::klipper(KlipperLimits::default())), ("marlin", MotionProfile::default())]
    {
        let (wall_s, print_s) = run(profile, 10_000_000);
        println!("{name}: 10 M moves planned and stepped in {wall_s:.2} s (print time {print_s:.0} s)");
        assert!(wall_s < 10.0);
    }
}
