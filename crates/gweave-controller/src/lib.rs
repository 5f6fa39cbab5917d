//! The gweave controller core: what a 3D printer's firmware means, without the board.
//!
//! This crate is the firmware of the controller described in the project's controller document
//! (an Arduino Mega 2560 with a RAMPS 1.4 shield): it reads G-code from the serial line with the
//! Marlin host protocol, plans moves with acceleration, turns them into step pulses, and keeps
//! two hotends and a bed at temperature with PID control and Marlin's safety rules. It knows
//! no chip's registers or pins. A board (the ATmega2560 firmware in `firmware/ramps`, the
//! emulated board, the virtual printer) moves bytes, ADC readings, endstop levels and duties
//! between this core and its hardware; what every board's firmware shares (the main loop, the
//! drivers' pins, a volatile register) is [`board`], written once.
//!
//! `#![no_std]`, no allocator, no `f64`, no `core::fmt` and no float parsing from `core` (on an
//! 8-bit AVR they cost kilobytes of flash and RAM): numbers are read and written by hand
//! ([`gcode::number`], [`serial::out`]). Every buffer is a fixed size named in one place
//! ([`limits`]).
//!
//! # The board's side, in one page
//!
//! ```
//! use gweave_controller::{Controller, Inputs, Io, Settings, StepQueue, Stepper};
//! use gweave_controller::serial::emergency::{EmergencyParser, Heard};
//!
//! /// What the board does with the core's requests: here, collect the serial output.
//! struct Board { sent: Vec<u8> }
//! impl Io for Board {
//!     fn send(&mut self, bytes: &[u8]) { self.sent.extend_from_slice(bytes); }
//!     fn build_settings(&self) -> Settings { Settings::DEFAULT }
//! }
//!
//! // The queue between the main loop (producer) and the step interrupt (consumer). On a board
//! // it is a `static`; the controller and the stepper each hold a shared reference.
//! let queue = StepQueue::new();
//! let mut controller = Controller::new(&queue, Settings::DEFAULT);
//! let mut stepper = Stepper::new(&queue);
//! let mut board = Board { sent: Vec::new() };
//!
//! // Power on: `start`, and the settings kept in EEPROM (none here: the defaults stay).
//! let inputs = Inputs { now_ms: 0, adc: [1000, 1000, 1000], endstops: 0 };
//! controller.boot(&mut board, &inputs);
//! // The receive interrupt: each byte heard by the emergency parser as it arrives (`M112`
//! // acts even behind a full queue), then kept in the receive buffer.
//! let (mut parser, mut heard) = (EmergencyParser::default(), Heard::default());
//! let line = b"N1 G1 X1 F600*48\n";
//! for &b in line {
//!     parser.hear_into(b, &mut heard);
//! }
//! // The main loop: what the parser heard, the bytes into the line queue, one turn.
//! controller.heard(heard);
//! for &b in line {
//!     assert!(controller.receive(b)); // `false`: the line queue is full, offer it again later
//! }
//! controller.poll(&mut board, &inputs);
//! // The timer interrupt: pulse these STEP pins, set these DIR pins, come back in so many ticks.
//! let mut x_steps = 0;
//! for _ in 0..2000 {
//!     let out = stepper.tick(0);
//!     x_steps += u32::from(out.step_bits & 1);
//!     controller.poll(&mut board, &inputs);
//! }
//! assert_eq!(x_steps, 80); // 1 mm at 80 steps/mm
//! assert_eq!(board.sent, b"start\nok\n");
//! // What to drive: heater and fan duties (0-255), stepper enables.
//! let outputs = controller.outputs();
//! assert_eq!(outputs.heater_duty, [0, 0, 0]);
//! ```
//!
//! # How a line travels
//!
//! 1. The board's receive interrupt gives each byte to the emergency parser as it arrives
//!    ([`serial::emergency`]: `M112` kills, `M108` ends a heating wait, ahead of any queue),
//!    and the main loop passes on what it heard ([`Controller::heard`]);
//!    [`Controller::receive`] collects bytes into lines ([`serial::reader`], bounded; a line
//!    too long or with bytes no G-code has is refused, never executed in part).
//! 2. [`Controller::poll`] takes one line when the machine can take it, checks its line number
//!    and checksum ([`serial::protocol`]), parses all its words ([`gcode::words`]: the whole
//!    line is checked before anything changes, as GRBL does), and runs the command
//!    ([`machine`]).
//! 3. A move becomes a block in the look-ahead [`planner`] (speeds at the junctions, trapezoids).
//! 4. The main loop cuts the oldest block into short segments of constant step rate
//!    ([`stepper::prep`]) and hands them to the step interrupt through the [`StepQueue`].
//! 5. The interrupt ([`Stepper::tick`]) runs Bresenham's algorithm over the axes: integers
//!    only, exact step totals.
//! 6. Meanwhile [`heat`] reads the thermistors, runs the PID loops and the safety rules; a
//!    fault halts the machine ([`Controller::kill`]): heaters off, steppers off, an `Error:`
//!    line, then only a reset helps.
//!
//! With the feature `std`, `twin` runs the core on a simulated board on the host (a clock, the
//! step interrupt, endstops, a thermal plant): the core's own tests use it, and so can anything
//! that wants the firmware's behaviour without a board.
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

pub mod board;
pub mod gcode;
pub mod heat;
#[cfg(feature = "inkjet")]
pub mod inkjet;
pub mod limits;
pub mod machine;
pub mod math;
pub mod mixing;
pub mod planner;
#[cfg(feature = "std")]
pub mod printer_file;
pub mod rotary;
pub mod serial;
pub mod settings;
pub mod stepper;
#[cfg(feature = "std")]
pub mod twin;

pub use machine::Controller;
pub use settings::Settings;
pub use stepper::{StepOut, StepQueue, Stepper};

/// The axes, in the order of every per-axis array: X, Y, Z, then the extruder E.
pub const AXES: usize = 4;
/// The motors the step interrupt drives, in the order of its per-motor arrays and bits: X, Y,
/// Z, then the extruder E (input E0 of a mixing hotend) and the other inputs of a mixing hotend
/// (E1 at bit `1 << (E + 1)`, ...; see [`mixing`]).
pub const MOTORS: usize = AXES + limits::MIX_INPUTS - 1;
/// The index of each axis in per-axis arrays, and its bit in step, direction and endstop bytes
/// (`1 << X`).
pub const X: usize = 0;
/// See [`X`].
pub const Y: usize = 1;
/// See [`X`].
pub const Z: usize = 2;
/// See [`X`]: the extruder (the second hotend's extruder is not driven by this core yet).
pub const E: usize = 3;
/// The axis letters, in axis order.
pub const AXIS_LETTERS: [u8; AXES] = *b"XYZE";

/// The temperature sensors and heaters, in the order of [`Inputs::adc`] and
/// [`Outputs::heater_duty`]: hotend 0 (RAMPS TEMP_0, D10), hotend 1 (TEMP_1, D9 on an "EEB"
/// board), the bed (TEMP_BED, D8).
pub const HEATERS: usize = 3;
/// Index of the first hotend in [`Inputs::adc`] and [`Outputs::heater_duty`].
pub const HOTEND0: usize = 0;
/// Index of the second hotend.
pub const HOTEND1: usize = 1;
/// Index of the bed.
pub const BED: usize = 2;

/// What the board reads for the core at each turn of the main loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Inputs {
    /// Milliseconds since power-on (wrapping after 49 days; the core takes differences only).
    pub now_ms: u32,
    /// Raw 10-bit ADC readings (0-1023) of the thermistor inputs, in [`HEATERS`] order.
    pub adc: [u16; HEATERS],
    /// The endstop pins' levels, bit `1 << axis` high when the pin reads high (the core applies
    /// the settings' inversion: [`Settings::endstop_inverting`]).
    pub endstops: u8,
}

/// What the board drives for the core, read after each turn of the main loop
/// ([`Controller::outputs`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outputs {
    /// Heater duty, 0 (off) to 255 (always on), in [`HEATERS`] order. A software PWM or a timer
    /// PWM at a few hertz to a few hundred hertz is enough: the heaters are slow.
    pub heater_duty: [u8; HEATERS],
    /// Part cooling fan duty, 0-255 (`M106 S<duty>`).
    pub fan_duty: u8,
    /// Stepper drivers to enable, bit `1 << motor` ([`MOTORS`]; RAMPS EN pins are active low:
    /// the board inverts).
    pub steppers_enabled: u8,
}

/// What the core asks of the board besides the inputs and outputs: the serial line's transmit
/// side, the EEPROM, and the watchdog. Only [`Io::send`] is required; the others do nothing by
/// default (a board without EEPROM keeps the defaults at every boot).
pub trait Io {
    /// Sends bytes to the host (UART transmit). A board may block until they are written or
    /// queue them; the core writes at most a few hundred bytes per turn.
    fn send(&mut self, bytes: &[u8]);
    /// The board's build-time settings (its printer file), which `M502` restores. The board
    /// keeps them where it keeps its program (flash), not the core in RAM.
    fn build_settings(&self) -> Settings;
    /// Reads `buf.len()` bytes of EEPROM from `addr`. Erased EEPROM reads `0xFF`.
    fn eeprom_read(&mut self, addr: u16, buf: &mut [u8]) {
        let _ = addr;
        buf.fill(0xFF);
    }
    /// Writes bytes to EEPROM at `addr` (the board may skip bytes that are unchanged).
    fn eeprom_write(&mut self, addr: u16, data: &[u8]) {
        let _ = (addr, data);
    }
    /// Resets the hardware watchdog. The core calls it once per turn in which the heaters were
    /// managed, so a main loop that hangs stops calling it and the watchdog resets the board,
    /// whose start-up leaves every heater off.
    fn watchdog_feed(&mut self) {}
    /// Fires inkjet head `head` (`M700 P`): each nozzle whose bit is set in `nozzles` (bit `a`:
    /// address `a`, 0-11) once, in address order, with the printhead's pulse timing
    /// ([`inkjet`]: the address held around a 5 us pulse, at least a microsecond between two
    /// nozzles). The core calls it when the moves before the `M700` have ended and the head
    /// has refilled.
    #[cfg(feature = "inkjet")]
    fn inkjet_fire(&mut self, head: u8, nozzles: u16) {
        let _ = (head, nozzles);
    }
}
