//! Print time against Klipper's own batch mode on a real Cura file (ground truth in the fixtures
//! README: Klipper at commit 84104bb, `max_velocity 300`, `max_accel 3000`,
//! `minimum_cruise_ratio 0.5`, `square_corner_velocity 5`, `instantaneous_corner_velocity 1`).

use gweave_sim::{estimate, Estimate};
use gweave_sim::{KlipperLimits, MotionProfile};

/// The fixture prepared for Klipper's batch mode as the README says: `G28` becomes
/// `SET_KINEMATIC_POSITION X=0 Y=0 Z=0`, `M109`/`M190` go, `{machine_depth}` becomes 220.
fn prepared() -> String {
    let text = include_str!("data/cura_torus.gcode");
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let command = line.split(';').next().unwrap_or("").split_whitespace().next().unwrap_or("");
        match command {
            "G28" => out.push_str("SET_KINEMATIC_POSITION X=0 Y=0 Z=0"),
            "M109" | "M190" => continue,
            _ => out.push_str(&line.replace("{machine_depth}", "220")),
        }
        out.push('\n');
    }
    out
}

fn run(limits: KlipperLimits) -> Estimate {
    estimate(prepared().as_bytes(), &MotionProfile::klipper(limits)).unwrap()
}

fn assert_within_0_01_percent(got_s: f64, want_s: f64) {
    let rel = (got_s - want_s).abs() / want_s;
    assert!(rel < 1e-4, "got {got_s:.4} s, Klipper {want_s} s ({:.5} %)", rel * 100.0);
}

#[test]
fn unbounded_extrude_only_matches_klipper() {
    let est = run(KlipperLimits::default());
    assert_within_0_01_percent(est.total_s, 749.631);
    // The parts add up, and the time lands in Cura's 28 layers.
    let parts = est.motion_s + est.dwell_s + est.overhead_s;
    assert!((parts - est.total_s).abs() < 1e-9);
    assert_eq!(est.layer_s.len(), 28);
    let attributed: f64 = est.unlayered_s + est.layer_s.iter().sum::<f64>();
    assert!((attributed - est.motion_s - est.dwell_s).abs() < 1e-6);
    assert!(est.feature_s.values().sum::<f64>() - attributed < 1e-6);
    assert!(est.layer_s.iter().all(|&t| t > 1.0), "{:?}", est.layer_s);
}

#[test]
fn bounded_extrude_only_matches_klipper() {
    let est = run(KlipperLimits {
        max_extrude_only_velocity_mm_s: Some(80.0),
        max_extrude_only_accel_mm_s2: Some(800.0),
        ..KlipperLimits::default()
    });
    assert_within_0_01_percent(est.total_s, 749.924);
}

#[test]
fn end_gcode_g91_is_relative() {
    // Cura's end G-code after printing to E747: G91, `G1 E-2`, `G1 E-2 Z0.2`, `G1 Z10`. Read as
    // absolute (klipper_estimator's mistake) E would run back 749 mm to -2 and Z stop at 10.
    let text = "G1 X1 E747 F1500\nG91\nG1 E-2 F2700\nG1 E-2 Z0.2 F2400\nG1 Z10\nG90\n";
    let est = estimate(text.as_bytes(), &MotionProfile::klipper(KlipperLimits::default())).unwrap();
    // E: 747 mm out and 4 mm back at 500 steps/mm; Z: 10.2 mm at 4000 steps/mm.
    assert_eq!(est.steps.axes[3], (747 + 4) * 500);
    assert_eq!(est.steps.axes[2], 40_800);
}
