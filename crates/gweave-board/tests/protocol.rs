//! The firmware's serial protocol on the emulated board.

mod common;

use gweave_board::Wiring;

#[test]
fn boot_prints_start() {
    let mut board = gweave_board::Board::new(&common::elf(), Wiring::default()).unwrap();
    let lines = board.run_until_line(|l| l == "start", 1.0).unwrap();
    assert_eq!(lines, ["start"]);
    // The start-up takes a few milliseconds, not the whole second.
    assert!(board.now_s() < 0.05, "start after {} s", board.now_s());
}

#[test]
fn m105_answers_with_the_temperature() {
    let mut board = common::booted(Wiring::default());
    board.run_for(0.1).unwrap();
    let lines = board.command("M105", 1.0).unwrap();
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(lines[0].starts_with("ok T:"), "{lines:?}");
}
