//! The emulated RAMPS 1.4 board: the gweave firmware (`make firmware`) running on an
//! ATmega2560 at 16 MHz in libsimavr, wired as a printer.
//!
//! - the serial port is a byte queue each way ([`Board::send`], [`Board::run_until_line`]), or
//!   a pseudo-terminal for real hosts (the `gweave-board` binary);
//! - every STEP pulse moves its axis one microstep in the direction of its DIR pin, with the
//!   cycle it happened at ([`ramps::Axis`]);
//! - X, Y and Z close their minimum endstop when they reach position 0;
//! - the InkShield's pins (an inkjet build) are decoded into nozzle fires ([`inkshield`]);
//! - the heater MOSFETs heat the project's thermal plant (`gweave-sim`'s [`gweave_sim::Heater`]),
//!   whose thermistor voltage feeds the analog inputs A13-A15.
//!
//! ```no_run
//! use gweave_board::{Board, Wiring};
//!
//! let mut board = Board::new("firmware/out/gweave-ramps.elf".as_ref(), Wiring::default()).unwrap();
//! board.run_until_line(|l| l == "start", 1.0).unwrap();
//! let reply = board.command("G1 X10 F3000", 5.0).unwrap();
//! assert_eq!(reply.last().unwrap(), "ok");
//! ```
//!
//! simavr 1.6 needs three work-arounds, all in `csrc/shim.c`: ADC8-15 inputs are not stored
//! (the mux is redirected), the byte time counts a parity bit (set again from UBRR), and
//! UDRE stays low after the transmitter is switched off (raised by the harness).

mod board;
pub mod inkshield;
pub mod ramps;
pub mod sim;

pub use board::{Board, BoardError, CPU_HZ, SLICE_CYCLES};
pub use ramps::{Wiring, D9};
