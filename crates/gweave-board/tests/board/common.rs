//! Shared by the board tests: the firmware image and a booted board.

use std::path::PathBuf;

use gweave_board::{Board, Wiring};

/// The firmware `make firmware` built (`GWEAVE_FIRMWARE_ELF` overrides the path).
pub fn elf() -> PathBuf {
    let path = std::env::var_os("GWEAVE_FIRMWARE_ELF").map(PathBuf::from).unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../firmware/out/gweave-ramps.elf")
    });
    assert!(path.exists(), "{} is missing: run `make firmware` first", path.display());
    path
}

/// The firmware built with `M9999` hanging its main loop (`make firmware-fault`;
/// `GWEAVE_FAULT_ELF` overrides the path).
pub fn fault_elf() -> PathBuf {
    let path = std::env::var_os("GWEAVE_FAULT_ELF").map(PathBuf::from).unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../firmware/out/gweave-ramps-fault.elf")
    });
    assert!(path.exists(), "{} is missing: run `make firmware-fault` first", path.display());
    path
}

/// The image `make firmware` built as `firmware/out/NAME` (the environment variable `var`
/// overrides the path).
pub fn image(var: &str, name: &str) -> PathBuf {
    let path = std::env::var_os(var)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../firmware/out").join(name));
    assert!(path.exists(), "{} is missing: run `make firmware` first", path.display());
    path
}

/// A board wired as `wiring`, run until the firmware said `start`.
pub fn booted(wiring: Wiring) -> Board {
    let mut board = Board::new(&elf(), wiring).unwrap();
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    board
}

/// The test image (`make firmware-fault`, built for an "EEB" printer: a second hotend heated
/// through D9 and read on A15, a second extruder on the E1 socket), booted as `wiring` with D9
/// wired to hotend 1's heater.
pub fn eeb_board(wiring: Wiring) -> Board {
    let mut board = Board::new(&fault_elf(), Wiring { d9: gweave_board::D9::Hotend1, ..wiring }).unwrap();
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    // The first full set of oversampled readings.
    board.run_for(0.2).unwrap();
    board
}

/// `N<n> <command>*<checksum>`: a line as a host numbers it (the checksum is the XOR of every
/// byte before the `*`).
pub fn numbered(n: u32, command: &str) -> String {
    let body = format!("N{n} {command}");
    let sum = body.bytes().fold(0u8, |a, b| a ^ b);
    format!("{body}*{sum}")
}

/// The number after `key` in a report line (`T:` of `ok T:25.0 /0.0`).
pub fn field(line: &str, key: &str) -> f64 {
    let at = line.find(key).unwrap_or_else(|| panic!("no {key} in {line:?}")) + key.len();
    let text: String =
        line[at..].chars().take_while(|c| c.is_ascii_digit() || *c == '.' || *c == '-').collect();
    text.parse().unwrap_or_else(|_| panic!("no number after {key} in {line:?}"))
}
