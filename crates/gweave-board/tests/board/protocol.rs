//! The firmware's serial protocol on the emulated board: what a host sees.

use gweave_board::{Board, Wiring};

#[test]
fn boot_prints_start() {
    let mut board = Board::new(&crate::common::elf(), Wiring::default()).unwrap();
    let lines = board.run_until_line(|l| l == "start", 1.0).unwrap();
    assert_eq!(lines, ["start"]);
    // The start-up takes a few milliseconds, not the whole second.
    assert!(board.now_s() < 0.05, "start after {} s", board.now_s());
}

#[test]
fn m115_names_the_firmware_and_its_capabilities() {
    let mut board = crate::common::booted(Wiring::default());
    let lines = board.command("M115", 1.0).unwrap();
    assert!(lines[0].starts_with("FIRMWARE_NAME:"), "{lines:?}");
    assert!(lines.iter().any(|l| l.starts_with("Cap:")), "{lines:?}");
    assert_eq!(lines.last().unwrap(), "ok");
}

/// `M155 S1`: the board prints its temperatures every second unasked (OctoPrint's auto-report,
/// announced by `AUTOREPORT_TEMP:1`); `S0` stops it.
#[test]
fn m155_s1_reports_the_temperatures_every_second() {
    let mut board = crate::common::booted(Wiring::default());
    let caps = board.command("M115", 1.0).unwrap();
    assert!(caps.iter().any(|l| l == "Cap:AUTOREPORT_TEMP:1"), "{caps:?}");
    assert_eq!(board.command("M155 S1", 1.0).unwrap(), ["ok"]);
    let start = board.now_s();
    for n in 1..=3 {
        let lines = board.run_until_line(|l| l.starts_with(" T:"), 1.5).unwrap();
        let at = board.now_s() - start;
        // Room temperature through the thermistor table, as `M105` reads it.
        let report = lines.last().unwrap();
        assert!((crate::common::field(report, "T:") - 25.0).abs() <= 1.0, "{lines:?}");
        assert!((at - f64::from(n)).abs() < 0.05, "report {n} at {at:.3} s");
    }
    assert_eq!(board.command("M155 S0", 1.0).unwrap(), ["ok"]);
    board.run_for(2.5).unwrap();
    assert!(board.lines().is_empty());
}

#[test]
fn m105_reads_room_temperature_from_the_thermistors() {
    let mut board = crate::common::booted(Wiring::default());
    // The first full set of oversampled readings.
    board.run_for(0.2).unwrap();
    let lines = board.command("M105", 1.0).unwrap();
    let reply = lines.last().unwrap();
    assert!(reply.starts_with("ok T:"), "{lines:?}");
    // The plants are at 25 C; the type 1 table reads them within a degree.
    let t = crate::common::field(reply, "T:");
    let b = crate::common::field(reply, "B:");
    assert!((t - 25.0).abs() <= 1.0 && (b - 25.0).abs() <= 1.0, "{reply}");
}

#[test]
fn a_wrong_checksum_is_asked_again_with_resend() {
    let mut board = crate::common::booted(Wiring::default());
    assert_eq!(board.command(&crate::common::numbered(1, "M110 N0"), 1.0).unwrap().last().unwrap(), "ok");
    // The right checksum of "N1 G4 P0" is not 0.
    board.send_line("N1 G4 P0*0");
    let lines = board.run_until_line(|l| l.starts_with("ok"), 1.0).unwrap();
    assert!(lines.iter().any(|l| l.starts_with("Error:checksum mismatch")), "{lines:?}");
    assert!(lines.iter().any(|l| l == "Resend: 1"), "{lines:?}");
    // Sent again correctly, the line runs.
    assert_eq!(board.command(&crate::common::numbered(1, "G4 P0"), 1.0).unwrap().last().unwrap(), "ok");
}

/// printcore starts every print with `N-1 M110 N-1` (Marlin: the next line is N0). The core
/// first read `N-1` as no number; the emulated board found it (crates/gweave-py/tests/test_board.py).
#[test]
fn printcores_n_minus_1_m110_is_understood() {
    let mut board = crate::common::booted(Wiring::default());
    assert_eq!(board.command("N-1 M110 N-1*125", 1.0).unwrap(), ["ok"]);
    assert_eq!(board.command(&crate::common::numbered(0, "G4 P0"), 1.0).unwrap(), ["ok"]);
}

#[test]
fn m500_keeps_the_settings_in_eeprom_across_a_reset() {
    let mut board = crate::common::booted(Wiring::default());
    let m503 = |board: &mut gweave_board::Board| {
        let lines = board.command("M503", 1.0).unwrap();
        lines.into_iter().find(|l| l.contains("M92 ")).unwrap_or_default()
    };
    assert!(m503(&mut board).ends_with("M92 X80.00 Y80.00 Z400.00 E93.00"));
    assert_eq!(board.command("M92 X100 E95.5", 1.0).unwrap().last().unwrap(), "ok");
    assert_eq!(board.command("M500", 2.0).unwrap().last().unwrap(), "ok");
    // The reset button: RAM is gone, the EEPROM is not.
    board.reset();
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    assert!(m503(&mut board).ends_with("M92 X100.00 Y80.00 Z400.00 E95.50"), "{}", m503(&mut board));
    // And the new steps/mm drive the pins: 1 mm of X is 100 steps now.
    for line in ["G91", "G1 X1 F600", "M400"] {
        board.command(line, 5.0).unwrap();
    }
    assert_eq!(board.net_steps()[0], 100);
}

#[test]
fn a_missing_or_foreign_firmware_is_an_error_naming_it() {
    let host_elf = std::env::current_exe().unwrap();
    let host_elf = host_elf.to_str().unwrap();
    for path in ["/nonexistent/gweave-ramps.elf", env!("CARGO_MANIFEST_DIR"), host_elf] {
        let err = gweave_board::Board::new(path.as_ref(), Wiring::default()).err().expect(path);
        assert!(err.to_string().contains(path), "{err}");
    }
}
