//! A rotary axis on the core's twin: A's steps, what F means on a move that turns it (NIST,
//! combined, `G93` inverse time), `G92 A`, homing leaving it alone. docs/firmware.md, "Rotary".

use std::cell::RefCell;
use std::rc::Rc;

use gweave_controller::limits::TICKS_PER_S;
use gweave_controller::rotary::{Rotary, RotaryFeed, A_MOTOR};
use gweave_controller::twin::{FirstOrder, Twin};
use gweave_controller::{Settings, StepQueue, X};

/// 3200 steps per turn (a 1/16-stepped motor on the mandrel), A at up to 360 deg/s.
const STEPS_PER_DEG: f32 = 3200.0 / 360.0;

fn twin(feed: RotaryFeed) -> Twin<'static, FirstOrder> {
    let settings = Settings {
        extrude_min_c: 0.0,
        rotary: Rotary {
            steps_per_deg: STEPS_PER_DEG,
            max_feed_deg_s: 360.0,
            max_accel_deg_s2: 36_000.0,
            feed,
        },
        ..Settings::DEFAULT
    };
    let queue: &'static StepQueue = Box::leak(Box::new(StepQueue::new()));
    Twin::new(queue, settings, FirstOrder::default())
}

/// Sends `text`, expects every line answered, then lets the moves finish. Returns the replies.
fn run(t: &mut Twin<'static, FirstOrder>, text: &str) -> String {
    let replies = t.run_lines(text.as_bytes(), 60_000).expect("every line answered");
    t.run_ms(10_000);
    String::from_utf8(replies).unwrap()
}

/// The ticks of each step of `motor` while `text` runs.
fn step_ticks(t: &mut Twin<'static, FirstOrder>, motor: usize, text: &str) -> Vec<u64> {
    let ticks = Rc::new(RefCell::new(Vec::new()));
    let seen = Rc::clone(&ticks);
    t.on_step = Some(Box::new(move |m, tick| {
        if m == motor {
            seen.borrow_mut().push(tick);
        }
    }));
    run(t, text);
    t.on_step = None;
    let v = ticks.borrow().clone();
    v
}

/// The most common interval between two steps (the cruise), in ticks.
fn cruise_interval_ticks(ticks: &[u64]) -> f64 {
    let mut intervals: Vec<u64> = ticks.windows(2).map(|w| w[1] - w[0]).collect();
    intervals.sort_unstable();
    intervals[intervals.len() / 2] as f64
}

#[test]
fn a_turn_of_a_is_its_steps_and_g92_a_moves_nothing() {
    let mut t = twin(RotaryFeed::Nist);
    let replies = run(&mut t, "G1 A360 F3600\nG92 A0\nG1 A-90\nM114\n");
    assert!(replies.contains("A:-90.00 Count X:0 Y:0 Z:0 A:2400"), "{replies}");
    assert_eq!(t.pulses[A_MOTOR], 3200 + 800);
    assert_eq!(t.pulses[..A_MOTOR], [0, 0, 0, 0], "A alone moved");
    // Homing leaves the mandrel where it is: it has no endstop.
    run(&mut t, "G28\n");
    assert_eq!(t.pulses[A_MOTOR], 4000);
}

#[test]
fn a_pure_a_move_runs_at_f_degrees_per_minute() {
    // F3600: 60 deg/s, 533.3 steps/s, a step every 1875 us (3750 ticks).
    let mut t = twin(RotaryFeed::Nist);
    let ticks = step_ticks(&mut t, A_MOTOR, "G1 A360 F3600\n");
    assert_eq!(ticks.len(), 3200);
    let expected = f64::from(TICKS_PER_S) / (60.0 * f64::from(STEPS_PER_DEG));
    let cruise = cruise_interval_ticks(&ticks);
    assert!((cruise - expected).abs() / expected < 0.01, "{cruise} ticks, planned {expected}");
}

#[test]
fn under_nist_f_is_along_x_and_a_follows() {
    // X 10 mm at F600 (10 mm/s): 1 s, A's 360 deg in the same second (3200 steps/s).
    let mut t = twin(RotaryFeed::Nist);
    let ticks = step_ticks(&mut t, X, "G1 X10 A360 F600\n");
    assert_eq!((t.pulses[X], t.pulses[A_MOTOR]), (800, 3200));
    let expected = f64::from(TICKS_PER_S) / (10.0 * 80.0);
    let cruise = cruise_interval_ticks(&ticks);
    assert!((cruise - expected).abs() / expected < 0.02, "{cruise} ticks, planned {expected}");
}

#[test]
fn combined_counts_degrees_with_millimetres() {
    // X 30 mm and A 40 deg at F3000: a path of 50 at 50/s, so X at 30 mm/s (2400 steps/s).
    let mut t = twin(RotaryFeed::Combined);
    let ticks = step_ticks(&mut t, X, "G1 X30 A40 F3000\n");
    let expected = f64::from(TICKS_PER_S) / (30.0 * 80.0);
    let cruise = cruise_interval_ticks(&ticks);
    assert!((cruise - expected).abs() / expected < 0.02, "{cruise} ticks, planned {expected}");
}

#[test]
fn g93_runs_each_move_in_one_over_f_minutes() {
    // G93 F30: two seconds for 90 deg (45 deg/s, a step every 2500 us), then G94 F3600 is
    // 60 deg/s again.
    let mut t = twin(RotaryFeed::Nist);
    let ticks = step_ticks(&mut t, A_MOTOR, "G93\nG1 A90 F30\n");
    let expected = f64::from(TICKS_PER_S) / (45.0 * f64::from(STEPS_PER_DEG));
    let cruise = cruise_interval_ticks(&ticks);
    assert!((cruise - expected).abs() / expected < 0.01, "{cruise} ticks, planned {expected}");
    let ticks = step_ticks(&mut t, A_MOTOR, "G94\nG1 A180 F3600\n");
    let expected = f64::from(TICKS_PER_S) / (60.0 * f64::from(STEPS_PER_DEG));
    let cruise = cruise_interval_ticks(&ticks);
    assert!((cruise - expected).abs() / expected < 0.01, "{cruise} ticks, planned {expected}");
}

#[test]
fn without_a_rotary_axis_a_moves_nothing() {
    let queue: &'static StepQueue = Box::leak(Box::new(StepQueue::new()));
    let mut t = Twin::new(queue, Settings::DEFAULT, FirstOrder::default());
    // M400: M114 counts the steps made, which are all made once the move has finished.
    let replies = run(&mut t, "G1 X1 A360 F600\nM400\nM114\n");
    assert!(replies.contains("X:1.00 Y:0.00 Z:0.00 E:0.00 Count X:80 Y:0 Z:0\n"), "{replies}");
    assert_eq!(t.pulses[A_MOTOR], 0);
}

#[test]
fn a_helix_chord_of_less_than_a_step_of_x_takes_its_commanded_time() {
    // `gweave rotary tube`'s helix under NIST: 0.005 mm of X per 5-degree chord at F6.675, 45 ms
    // a chord (the mandrel at 111 deg/s). X makes 0 or 1 step a chord: measured in steps the
    // move was A alone (5 degrees at 6.675 deg/min: 45 s a chord) or 0.0125 mm (90 ms). Twenty
    // chords, straight on in X, A and E: 0.9 s.
    let mut t = twin(RotaryFeed::Nist);
    let chords: String = (1..=20)
        .map(|k| format!("G1 X{:.3} A{} E{:.5} F6.675\n", 0.005 * k as f32, 5 * k, 0.03 * k as f32))
        .collect();
    let ticks = step_ticks(&mut t, A_MOTOR, &chords);
    assert_eq!(ticks.len(), 889, "100 degrees");
    let took_s = (ticks[ticks.len() - 1] - ticks[0]) as f64 / f64::from(TICKS_PER_S);
    assert!((0.85..0.95).contains(&took_s), "{took_s} s");
}
