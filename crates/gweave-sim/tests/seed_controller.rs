//! The controller seed's machine (examples/machines/seed-controller.toml): its thermistor table
//! loaded from a CSV file named by the profile and read by the virtual printer's firmware, and
//! its `M0` (home, motors off, end of program), and its constant-speed stepping.

use std::path::Path;

use gweave_sim::estimate;
use gweave_sim::MachineProfile;
use gweave_sim::{CornerMode, KlipperLimits, MotionProfile};
use gweave_sim::{Machine, Outcome};

fn example() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/seed-controller.toml")
}

#[test]
fn the_seed_table_is_loaded_and_heats_to_target() {
    let profile = MachineProfile::from_file(&example()).unwrap();
    let table = profile.thermal.thermistor_table_entries.clone().unwrap();
    assert_eq!(table.entries().len(), 31, "the seed's 31 pairs");
    // One 10-bit sample per reading, sorted by it; between two rows the reading is interpolated
    // linearly.
    let (a0, t0) = table.entries()[9];
    let (a1, t1) = table.entries()[10];
    assert_eq!((t0, t1), (210.0, 200.0));
    let mid = (a0 + a1) / 2;
    let expected = t0 + (t1 - t0) * f64::from(mid - a0) / f64::from(a1 - a0);
    assert_eq!(table.celsius(mid), expected);
    let mut machine = Machine::new(profile).unwrap();
    let mut replies = Vec::new();
    for line in ["M104 S200", "M109 S200", "M105"] {
        let outcome = machine.execute(line.as_bytes(), &mut |_, r: &str| replies.push(r.to_owned()));
        assert_eq!(outcome, Outcome::Ok, "{line}: {replies:?}");
    }
    let report = replies.iter().rev().find(|r| r.contains("T:")).unwrap();
    let t: f64 = report.split("T:").nth(1).unwrap().split_whitespace().next().unwrap().parse().unwrap();
    assert!((t - 200.0).abs() < 3.0, "{report}");
}

#[test]
fn a_bad_table_names_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.csv"), "adc,celsius\n100,200\n90,oops\n").unwrap();
    let profile = dir.path().join("m.toml");
    std::fs::write(&profile, "[thermal]\nthermistor_table = \"t.csv\"\n").unwrap();
    let e = MachineProfile::from_file(&profile).unwrap_err().to_string();
    assert!(e.contains("t.csv: line 3: `oops` is not a number"), "{e}");
    std::fs::write(&profile, "[thermal]\nthermistor_table = \"missing.csv\"\n").unwrap();
    let e = MachineProfile::from_file(&profile).unwrap_err().to_string();
    assert!(e.contains("[thermal] thermistor_table") && e.contains("missing.csv"), "{e}");
}

#[test]
fn m0_per_profile_marlin_stops_the_seed_ends_the_program() {
    let seed = MachineProfile::from_file(&example()).unwrap();
    let mut marlin = seed.clone();
    marlin.firmware.m0 = gweave_sim::ProgramStop::Marlin;
    for (profile, ended, x_after) in [(marlin, false, 50.0), (seed, true, 0.0)] {
        let mut machine = Machine::new(profile).unwrap();
        for line in ["G28", "G1 X50 Y20 F3000", "M0"] {
            assert_eq!(machine.execute(line.as_bytes(), &mut |_, _| {}), Outcome::Ok);
        }
        // The seed homes before switching the motors off; Marlin stops where it is.
        assert_eq!(machine.position()[0], x_after);
        assert_eq!(machine.program_ended(), ended);
    }
}

/// A move of each kind at the seed's constant speed: 10 mm of X at F600 (800 steps of
/// 1 / (10 mm/s * 80 steps/mm) = 1 s), X10 Y15 at F1200 (Y dominates with 1200 steps of
/// 1 / (20 * 80) s = 0.75 s), a 2 mm retract at F2400 (1000 E steps of 1 / (40 * 500) s =
/// 0.05 s), 0.2 mm of Z at F600 (800 steps of 1 / (10 * 4000) s = 0.02 s, above Z's 5 mm/s
/// limit, which the seed does not have).
const MOVES: &str = "G1 X10 F600\nG1 X20 Y15 F1200\nG1 E-2 F2400\nG1 Z0.2 F600\n";
const MOVES_S: f64 = 1.0 + 0.75 + 0.05 + 0.02;

#[test]
fn constant_motion_times_each_move_by_its_dominant_steps() {
    let seed = MachineProfile::from_file(&example()).unwrap();
    assert_eq!(seed.motion.corners, CornerMode::Constant {});
    let est = estimate(MOVES.as_bytes(), &seed.motion).unwrap();
    assert!((est.motion_s - MOVES_S).abs() < 1e-12, "{}", est.motion_s);
    assert_eq!(est.blocks, 4);
    // The first move alone is exactly one second.
    assert_eq!(estimate("G1 X10 F600\n".as_bytes(), &seed.motion).unwrap().motion_s, 1.0);
    // The same moves planned with Marlin's acceleration take longer and step the same.
    let marlin = estimate(MOVES.as_bytes(), &MotionProfile::default()).unwrap();
    assert!(marlin.motion_s > MOVES_S + 0.01, "{}", marlin.motion_s);
    assert_eq!(est.steps, marlin.steps);
    assert_eq!(est.steps.axes, [1600, 1200, 800, 1000, 0]);
}

#[test]
fn the_virtual_printer_moves_at_constant_speed() {
    let mut machine = Machine::new(MachineProfile::from_file(&example()).unwrap()).unwrap();
    // Hot first: the seed's firmware, like Marlin, refuses a cold retract.
    let job = format!("M109 S200\n{MOVES}M400\n");
    for line in job.lines() {
        assert_eq!(machine.execute(line.as_bytes(), &mut |_, _| {}), Outcome::Ok, "{line}");
    }
    let report = machine.report();
    assert!((report.time.motion_s - MOVES_S).abs() < 1e-12, "{:?}", report.time);
    assert_eq!(report.steps.axes, [1600, 1200, 800, 1000, 0]);
}

/// A real file at constant speed: the same step counts as with Klipper's planner, which also
/// steps every move (Marlin's joins moves of fewer than 6 steps to the next, so its motors skip
/// their back-and-forth and count fewer), and faster than either, having no acceleration.
#[test]
fn a_real_file_steps_as_klipper_at_constant_speed() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/cura/cura_torus.gcode");
    let text = std::fs::read(file).unwrap();
    let constant = MotionProfile { corners: CornerMode::Constant {}, ..MotionProfile::default() };
    let fast = estimate(text.as_slice(), &constant).unwrap();
    let klipper = estimate(text.as_slice(), &MotionProfile::klipper(KlipperLimits::default())).unwrap();
    let marlin = estimate(text.as_slice(), &MotionProfile::default()).unwrap();
    assert_eq!(fast.steps, klipper.steps);
    assert_eq!(fast.steps.axes, [1_363_044, 1_397_168, 90_800, 410_309, 0]);
    assert!(marlin.steps.axes[0] < fast.steps.axes[0], "{:?}", marlin.steps);
    assert!(fast.motion_s < klipper.motion_s.min(marlin.motion_s), "{}", fast.motion_s);
}
