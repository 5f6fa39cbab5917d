//! Moves on the emulated board: STEP pulses counted on the pins, per axis.

use gweave_board::Wiring;

/// Sockets X, Y, Z, E0, E1.
const X: usize = 0;
const Y: usize = 1;
const Z: usize = 2;

#[test]
fn a_g1_move_gives_exactly_its_steps_on_every_axis() {
    let mut board = crate::common::booted(Wiring::default());
    // From the start position (the origin until homed), relative.
    for line in ["G91", "G1 X10 Y-5 Z0.5 F3000", "G1 X-2.5 F1200", "M400"] {
        assert_eq!(board.command(line, 30.0).unwrap().last().unwrap(), "ok", "{line}");
    }
    // 7.5 mm * 80, -5 mm * 80, 0.5 mm * 400 (the default printer's steps/mm).
    assert_eq!(board.net_steps(), [600, -400, 200, 0, 0]);
    assert_eq!(board.axis(X).steps_plus, 800);
    assert_eq!(board.axis(X).steps_minus, 200);
    for socket in [X, Y, Z] {
        assert_eq!(board.axis(socket).steps_while_disabled, 0, "socket {socket}");
        // Drivers need a STEP pulse of at least 1 us (16 cycles) to see it.
        assert!(board.axis(socket).min_pulse_cycles.unwrap() >= 16, "socket {socket}");
    }
}

#[test]
fn g28_homes_z_then_y_then_x_against_the_endstops() {
    let mut board = crate::common::booted(Wiring { record_steps: true, ..Wiring::default() });
    let lines = board.command("G28", 120.0).unwrap();
    assert_eq!(lines.last().unwrap(), "ok", "{lines:?}");
    // Each axis stops on the step that closes its switch (position 0).
    for socket in [X, Y, Z] {
        assert_eq!(board.axis(socket).position, 0, "socket {socket}");
    }
    // Z moves first and is done before Y starts; Y is done before X starts.
    let span = |socket: usize| {
        let log = &board.axis(socket).step_log;
        (log.first().unwrap().0, log.last().unwrap().0)
    };
    let (z, y, x) = (span(Z), span(Y), span(X));
    assert!(z.1 < y.0 && y.1 < x.0, "Z {z:?} Y {y:?} X {x:?}");
    let report = board.command("M114", 1.0).unwrap();
    assert!(report[0].starts_with("X:0.00 Y:0.00 Z:0.00"), "{report:?}");
}
