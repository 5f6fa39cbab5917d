//! What `G92`, homing and dropped short moves do to the virtual Marlin's step counts
//! (`marlin_position.rs`): regressions for the X and Y steps a `G92 E0` used to lose after a
//! dropped short move, and for the step pulses a purge-shifted file makes.

use gweave_sim::{Estimator, KlipperLimits, MotionProfile};

/// The motor positions (X Y Z E A, steps) and step pulses (both directions) after running
/// `lines` on the default Marlin profile (80 steps/mm on X and Y, 500 on E), every move made.
fn run(lines: &str) -> ([i64; 5], [u64; 5]) {
    let mut est = Estimator::new(&MotionProfile::default()).unwrap();
    for line in lines.lines() {
        est.line(line.as_bytes()).unwrap();
    }
    est.drain();
    (est.steppers().position_steps(), est.steppers().totals().axes)
}

fn motor_steps(lines: &str) -> [i64; 5] {
    run(lines).0
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

/// Bug 2 of the task that fixed `G92`: `sim` of the purge-shifted 224 MB bench file made 120 X,
/// 1200 Y and 480 E step pulses fewer than the input over 47 580 changes, and ended at the same
/// counts. Not a lost step: purge-shift splits a move where the change goes, and when the piece
/// after the change is under 6 steps Marlin drops it and carries it into the next block, which
/// here goes back the other way, so the motors never make that piece and its way back (layer
/// 330 of the file, 4.7 steps on Y: 10 pulses). Both runs end on the same steps.
#[test]
fn purge_shift_split_under_min_steps_makes_fewer_pulses_not_lost_steps() {
    let input = "M83\nG1 X57.184 Y93.523 F1200\nG1 X56.51 Y94.196 E.03262\nG1 X56.228 Y93.896 E.01411\n";
    let shifted = "M83\nG1 X57.184 Y93.523 F1200\nG1 X56.56868 Y94.13741 E.02978\nG1 E-10 F2400\nT0\n\
                   G1 E10 F2400\nG1 F1200\nG1 X56.51 Y94.196 E.00284\nG1 X56.228 Y93.896 E.01411\n";
    let (input_at, input_pulses) = run(input);
    let (shifted_at, shifted_pulses) = run(shifted);
    assert_eq!(input_at, [4498, 7512, 0, 23, 0]);
    assert_eq!(shifted_at, input_at);
    // Y: 7482 -> 7536 -> 7512 (78 pulses) against 7482 -> 7531 -> 7512 (68); X 4575 -> 4521 ->
    // 4498 (77) against 4575 -> 4525 -> 4498 (77); E 10 000 more for the moved retraction.
    assert_eq!(input_pulses[..2], [4575 + 77, 7482 + 78]);
    assert_eq!(shifted_pulses[..2], [4575 + 77, 7482 + 68]);
    assert_eq!(shifted_pulses[3], input_pulses[3] + 10_000);
}

/// `G92 E0` after a dropped travel plans as the same file with E counted on (no `G92`): the
/// same blocks, times and step pulses, on Marlin's planner (E alone re-set, the travel's 4 X
/// and Y steps carried into the next block) and on Klipper's (G92 only moves its offsets).
#[test]
fn g92_e0_plans_as_the_file_without_it_on_both_planners() {
    let travel = "G1 X10 Y10 E1 F3000\nG1 X10.05 Y10.05\n";
    let with_g92 = format!("{travel}G92 E0\nG1 X20 Y20 E1\nG1 X30 Y10 E2\n");
    let without = format!("{travel}G1 X20 Y20 E2\nG1 X30 Y10 E3\n");
    for profile in [MotionProfile::default(), MotionProfile::klipper(KlipperLimits::default())] {
        let estimate = |text: &str| {
            let mut est = Estimator::new(&profile).unwrap();
            text.lines().for_each(|line| est.line(line.as_bytes()).unwrap());
            est.finish()
        };
        let (a, b) = (estimate(&with_g92), estimate(&without));
        assert_eq!((a.blocks, a.motion_s), (b.blocks, b.motion_s), "{:?}", profile.corners);
        assert_eq!(a.steps.axes, b.steps.axes, "{:?}", profile.corners);
        assert_eq!(a.steps.axes[..2], [2400, 2400]);
    }
}
