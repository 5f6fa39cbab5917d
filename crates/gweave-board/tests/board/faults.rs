//! Faults and bad input on the emulated board: each ends in a safe state with Marlin's words,
//! never a crash or a stuck board.

use gweave_board::{Board, Wiring};
use gweave_sim::HeaterFault;

/// Run until the halt, then check Marlin's two lines, that every heater is off and that the
/// board stays halted past the watchdog's timeout.
fn assert_halts(board: &mut Board, error: &str, timeout_s: f64) {
    let lines = board.run_until_line(|l| l == "Error:Printer halted. kill() called!", timeout_s).unwrap();
    assert!(lines.iter().any(|l| l == error), "{lines:?}");
    board.run_for(1.5).unwrap();
    assert_safe(board);
    let reply = board.command("G1 X10 F3000", 1.0).unwrap();
    assert_eq!(reply, ["Error:Printer halted. kill() called!", "ok"]);
}

/// Every heater off, no driver enabled.
fn assert_safe(board: &Board) {
    for i in 0..3 {
        assert_eq!(board.plant(i).heater.last_power_w(), 0.0, "heater {i} still on");
    }
    for socket in 0..4 {
        assert!(!board.axis(socket).enabled(), "driver {socket} still enabled");
    }
}

#[test]
fn a_heater_that_cannot_heat_halts_with_heating_failed() {
    let mut board = crate::common::booted(Wiring::default());
    board.shield_mut().plants[0].heater.inject(HeaterFault::CartridgeDisconnected);
    assert_eq!(board.command("M104 S200", 1.0).unwrap().last().unwrap(), "ok");
    // Marlin's heating watch: 2 °C within 20 s, or the heater is not heating.
    assert_halts(&mut board, "Error:Heating failed, system stopped! Heater_ID: 0", 30.0);
}

#[test]
fn a_hotend_past_maxtemp_halts() {
    let mut board = crate::common::booted(Wiring::default());
    // A shorted MOSFET or a runaway heater: the hotend at 280 °C, above MAXTEMP (275).
    board.shield_mut().plants[0].heater.set_temperature(280.0);
    assert_halts(&mut board, "Error:MAXTEMP triggered, system stopped! Heater_ID: 0", 2.0);
}

#[test]
fn m112_stops_a_move_at_once() {
    let mut board = crate::common::booted(Wiring::default());
    assert_eq!(board.command("M104 S200", 1.0).unwrap().last().unwrap(), "ok");
    board.send_line("G1 X100 F600");
    board.run_for(0.5).unwrap();
    let moved = board.net_steps()[0];
    assert!(moved > 0, "moving before the M112");
    board.send_line("M112");
    board.run_until_line(|l| l == "Error:Printer halted. kill() called!", 1.0).unwrap();
    let at_halt = board.net_steps()[0];
    board.run_for(1.5).unwrap();
    // No step after the halt's line, and far from the 8000 steps of the move.
    assert_eq!(board.net_steps()[0], at_halt);
    assert!(at_halt < 8000 / 2, "{at_halt} steps");
    assert_eq!(board.plant(0).heater.last_power_w(), 0.0);
}

/// Regression (review of the emergency parser: the main loop heard only what the 255-byte
/// receive buffer kept, so an `M112` sent after a buffer's worth of lines was lost): during an
/// `M109` wait, which holds the line queue, a host streams 600 bytes and then `M112`; the
/// buffer has long overflowed, and the parser in the receive interrupt hears it all the same.
#[test]
fn m112_past_a_full_receive_buffer_halts_the_board() {
    let mut board = crate::common::booted(Wiring::default());
    board.send_line("M109 S200");
    board.run_for(0.2).unwrap();
    for _ in 0..100 {
        board.send_line("G4 P1");
    }
    board.send_line("M112");
    board.run_until_line(|l| l == "Error:Printer halted. kill() called!", 1.0).unwrap();
    board.run_for(1.5).unwrap();
    assert_safe(&board);
}

#[test]
fn a_kilobyte_line_and_binary_garbage_get_errors_and_the_board_carries_on() {
    let mut board = crate::common::booted(Wiring::default());
    // 1 KB of words: far past the 95 bytes a line may have (a comment past them would only be
    // cut off, as Marlin does).
    let long = format!("G1{}", " X1".repeat(342));
    board.send_line(&long);
    let lines = board.run_until_line(|l| l.starts_with("ok"), 2.0).unwrap();
    assert!(lines.iter().any(|l| l.starts_with("Error:")), "{lines:?}");
    let garbage: Vec<u8> = (0..512u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8).collect();
    board.send(&garbage);
    board.send(b"\n");
    board.run_for(1.0).unwrap();
    board.lines();
    // Still answering, and nothing moved.
    let reply = board.command("M105", 1.0).unwrap();
    assert!(reply.last().unwrap().starts_with("ok T:"), "{reply:?}");
    assert_eq!(board.net_steps(), [0; 7]);
}

#[test]
fn a_hung_main_loop_is_reset_by_the_watchdog_with_the_heaters_off() {
    let mut board = Board::new(&crate::common::fault_elf(), Wiring::default()).unwrap();
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    assert_eq!(board.command("M104 S200", 1.0).unwrap().last().unwrap(), "ok");
    board.run_for(1.0).unwrap();
    assert!(board.plant(0).heater.last_power_w() > 0.0, "heating before the hang");
    // The main loop spins forever, the hotend's PWM (an interrupt) still on: only the
    // watchdog (1 s) can end it.
    board.send_line("M9999");
    let hung_at = board.now_s();
    let lines = board.run_until_line(|l| l == "start", 3.0).unwrap();
    let reset_after_s = board.now_s() - hung_at;
    assert!((0.9..2.0).contains(&reset_after_s), "restarted {reset_after_s:.2} s after the hang");
    assert_eq!(lines[lines.len() - 2..], ["echo:Watchdog Reset", "start"], "{lines:?}");
    // A safe state: every heater off, no driver enabled, the target forgotten.
    board.run_for(1.0).unwrap();
    assert_safe(&board);
    let report = board.command("M105", 1.0).unwrap();
    assert!(report.last().unwrap().contains(" /0.0"), "{report:?}");
}
