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

/// A board wired as `wiring`, run until the firmware said `start`.
pub fn booted(wiring: Wiring) -> Board {
    let mut board = Board::new(&elf(), wiring).unwrap();
    board.run_until_line(|l| l == "start", 1.0).unwrap();
    board
}
