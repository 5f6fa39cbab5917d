//! What `G92` and homing do to the virtual Marlin's step counts (`marlin_position.rs`):
//! regressions for the X and Y steps a `G92 E0` used to lose after a dropped short move.

use gweave_sim::{Estimator, MotionProfile};

/// The motor positions (X Y Z E A, steps) after running `lines` on the default Marlin profile
/// (80 steps/mm on X and Y, 500 on E), every move made.
fn motor_steps(lines: &str) -> [i64; 5] {
    let mut est = Estimator::new(&MotionProfile::default()).unwrap();
    for line in lines.lines() {
        est.line(line.as_bytes()).unwrap();
    }
    est.drain();
    est.steppers().position_steps()
}

/// A block to X10 Y10 E1, then a move of 4 X, 4 Y and 5 E steps: fewer than Marlin's
/// `MIN_STEPS_PER_SEGMENT` (6), so the planner drops it and its distance goes with the next
/// block.
const DROPPED: &str = "G1 X10 Y10 E1 F3000\nG1 X10.05 Y10.05 E1.01\n";

#[test]
fn dropped_short_move_x_steps_survive_g92_e0() {
    // Marlin's `G92 E0` re-sets E alone: the block to X20 Y20 makes the dropped 4 steps and its
    // own 796 on X and Y. Before the fix every axis was rounded afresh at X10.05 and the
    // steppers ended at 1596.
    let steps = motor_steps(&format!("{DROPPED}G92 E0\nG1 X20 Y20 E1\n"));
    assert_eq!(steps, [1600, 1600, 0, 1000, 0]);
}

#[test]
fn dropped_short_move_x_steps_survive_g92_x() {
    // Marlin's default `G92 X0` shifts the workspace: native X = logical + 10.05, nothing is
    // rounded afresh, and X10 is 804 steps past the 800 the motor made (1600 before the fix).
    let steps = motor_steps(&format!("{DROPPED}G92 X0\nG1 X10 Y20 E2\n"));
    assert_eq!(steps, [1604, 1600, 0, 1000, 0]);
}

#[test]
fn g92_to_the_value_e_has_changes_nothing() {
    // A G92 that names the value an axis has changes nothing (Marlin's `NEAR_ZERO`): E is not
    // rounded afresh, and the dropped move's 5 E steps still go out with the next block.
    let steps = motor_steps(&format!("{DROPPED}G92 E1.01\nG1 X20 Y20 E2\n"));
    assert_eq!(steps, [1600, 1600, 0, 1000, 0]);
}
