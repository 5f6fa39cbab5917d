//! What a board does for the core, written once: the main loop ([`run`]), the stepper
//! drivers' and endstops' pins ([`Pin`], [`Driver`]), and the memory-mapped registers a
//! board's drivers are made of ([`Reg`]).
//!
//! A board (the ATmega2560 of `firmware/ramps`, the STM32F4 of `firmware/cortex`) implements
//! [`Pin`] for its GPIO and [`Board`] for the rest: the serial line, the clock, the thermistors'
//! ADC, the heaters' and fan's outputs (and, through [`Io`], the EEPROM and the watchdog). Its
//! `main` sets the chip up and calls [`run`], which never returns. What stays the board's own
//! is what differs with the chip: the step interrupt's timer and how fast it can pulse the
//! STEP pins (an 8-bit AVR needs each pin a constant, unrolled; a Cortex-M writes a port's set
//! and clear halves at once), and the start-up of clocks and interrupts.

use core::marker::PhantomData;
use core::ops::{BitAnd, BitOr, Not};
use core::ptr::{read_volatile, write_volatile};

use crate::serial::emergency::Heard;
use crate::{Controller, Inputs, Io, Outputs};

/// One memory-mapped peripheral register of `T` (a byte on the AVR, a word on a Cortex-M):
/// writing it configures or drives a peripheral, reading it gives its state. Every access is
/// volatile, so the compiler neither caches nor drops it.
pub struct Reg<T> {
    address: usize,
    width: PhantomData<T>,
}

impl<T> Clone for Reg<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Reg<T> {}

impl<T: Copy + BitAnd<Output = T> + BitOr<Output = T> + Not<Output = T>> Reg<T> {
    /// The register at `address`.
    ///
    /// # Safety
    /// `address` must be a register of the chip, always mapped and `T` wide, whose reads and
    /// writes do nothing a peripheral's driver does not mean (the board's register list, from
    /// the chip's datasheet).
    pub const unsafe fn new(address: usize) -> Self {
        Reg { address, width: PhantomData }
    }

    /// The register's address.
    pub const fn address(self) -> usize {
        self.address
    }

    /// Reads the register.
    #[inline(always)]
    pub fn read(self) -> T {
        // SAFETY: `new`'s contract: a mapped register of this width.
        unsafe { read_volatile(self.address as *const T) }
    }

    /// Writes the register.
    #[inline(always)]
    pub fn write(self, value: T) {
        // SAFETY: as in `read`.
        unsafe { write_volatile(self.address as *mut T, value) }
    }

    /// Replaces the bits of `mask` by those of `value`, leaving the others (read, modify,
    /// write: not atomic, so a caller that shares the register with an interrupt runs it with
    /// interrupts off).
    #[inline(always)]
    pub fn modify(self, mask: T, value: T) {
        self.write(self.read() & !mask | value & mask);
    }

    /// Sets the bits of `mask`, leaving the others (the same caveat as [`Reg::modify`]).
    #[inline(always)]
    pub fn set_bits(self, mask: T) {
        self.write(self.read() | mask);
    }

    /// Clears the bits of `mask`, leaving the others (the same caveat as [`Reg::modify`]).
    #[inline(always)]
    pub fn clear_bits(self, mask: T) {
        self.write(self.read() & !mask);
    }
}

/// One GPIO pin of a board. An output starts low, the safe level of every output of a printer
/// board (heaters and fans off, STEP idle); an enable that is active low is driven high by the
/// caller first ([`set_up_pins`]).
pub trait Pin: Copy {
    /// Makes the pin an output.
    fn make_output(self);
    /// Makes the pin an input with the chip's pull-up on, so an open switch reads high.
    fn make_input_pullup(self);
    /// Drives an output high or low (safe against the step interrupt writing the same port).
    fn write(self, high: bool);
    /// Reads the pin's level.
    fn read(self) -> bool;
}

/// STEP, DIR and ENABLE of one stepper driver socket.
#[derive(Clone, Copy)]
pub struct Driver<P> {
    /// A rising edge moves the motor one (micro)step.
    pub step: P,
    /// The direction of the next steps.
    pub dir: P,
    /// Active low, as on every common driver (A4988, DRV8825, TMC22xx): the driver holds its
    /// motor only while this pin is low.
    pub enable: P,
}

/// Sets the drivers' and the minimum endstops' pins up at start-up: each driver disabled
/// (ENABLE high) before its pins become outputs, so no motor twitches; the endstops inputs with
/// the pull-up on (a switch closes to ground).
pub fn set_up_pins<P: Pin>(drivers: &[Driver<P>], endstops: &[P]) {
    for d in drivers {
        d.enable.write(true);
        d.enable.make_output();
        d.step.make_output();
        d.dir.make_output();
    }
    for &e in endstops {
        e.make_input_pullup();
    }
}

/// The X, Y and Z minimum endstops' levels as [`Inputs::endstops`] and
/// [`Stepper::tick`](crate::Stepper::tick) take them: bit `1 << axis`. Inlined, so that with
/// constant pins each read is a couple of instructions in the step interrupt.
#[inline(always)]
pub fn endstop_bits<P: Pin>(endstops: &[P; 3]) -> u8 {
    let [x, y, z] = *endstops;
    u8::from(x.read()) | u8::from(y.read()) << 1 | u8::from(z.read()) << 2
}

/// Drives the drivers' ENABLE pins (active low) as [`Outputs::steppers_enabled`] asks.
pub fn write_enables<P: Pin>(drivers: &[Driver<P>], steppers_enabled: u8) {
    for (motor, d) in drivers.iter().enumerate() {
        d.enable.write(steppers_enabled & (1 << motor) == 0);
    }
}

/// What the main loop asks of a board besides [`Io`].
pub trait Board: Io {
    /// The next byte the serial line received, if any (from the receive interrupt's buffer).
    fn receive(&mut self) -> Option<u8>;
    /// What the receive interrupt's emergency parser heard since the last call
    /// ([`crate::serial::emergency`]: it reads each byte as it arrives, even one the full
    /// buffer has no room for).
    fn heard(&mut self) -> Heard;
    /// The clock, the thermistors' latest readings and the endstops, read for one turn.
    fn inputs(&mut self) -> Inputs;
    /// Drives the heaters, the fan and the stepper enables as the core asks after a turn.
    fn apply(&mut self, outputs: &Outputs);
}

/// The bytes received, into the line queue while it takes them. A byte it refuses (the line it
/// ends finds the queue full) is kept in `refused` and offered first at the next turn.
fn queue_received(controller: &mut Controller<'_>, board: &mut impl Board, refused: &mut Option<u8>) {
    while let Some(byte) = refused.take().or_else(|| board.receive()) {
        if !controller.receive(byte) {
            *refused = Some(byte);
            return;
        }
    }
}

/// The main loop, the same on every board: `start` (after `echo:Watchdog Reset` if the
/// watchdog reset the chip), then forever: the bytes received into the core, one turn of the
/// controller, its outputs driven.
pub fn run(controller: &mut Controller<'_>, board: &mut impl Board, by_watchdog: bool) -> ! {
    if by_watchdog {
        board.send(b"echo:Watchdog Reset\n");
    }
    let inputs = board.inputs();
    controller.boot(board, &inputs);
    let mut refused = None;
    loop {
        // What the emergency parser heard first: an `M112` behind a full queue acts now.
        controller.heard(board.heard());
        queue_received(controller, board, &mut refused);
        let inputs = board.inputs();
        controller.poll(board, &inputs);
        board.apply(&controller.outputs());
        if controller.is_halted() {
            // Halted (a thermal fault, M112) is a safe state that must last until the user
            // resets the board: the watchdog must not restart it into a working printer.
            board.watchdog_feed();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;
    use std::vec::Vec;

    use super::*;
    use crate::serial::emergency::EmergencyParser;
    use crate::{Settings, StepQueue};

    /// A serial line into a receive buffer of `room` bytes, with the emergency parser in its
    /// receive interrupt, as the boards have it.
    struct Wire {
        arriving: VecDeque<u8>,
        buffer: VecDeque<u8>,
        room: usize,
        parser: EmergencyParser,
        heard: Heard,
        sent: Vec<u8>,
    }

    impl Wire {
        fn new(text: &[u8], room: usize) -> Wire {
            let arriving = text.iter().copied().collect();
            Wire {
                arriving,
                buffer: VecDeque::new(),
                room,
                parser: EmergencyParser::default(),
                heard: Heard::default(),
                sent: Vec::new(),
            }
        }

        /// The receive interrupt, for `n` more bytes: each heard, then kept if there is room.
        fn arrive(&mut self, n: usize) {
            for _ in 0..n {
                let Some(b) = self.arriving.pop_front() else { return };
                self.parser.hear_into(b, &mut self.heard);
                if self.buffer.len() < self.room {
                    self.buffer.push_back(b);
                }
            }
        }

        fn replies(&self) -> &str {
            std::str::from_utf8(&self.sent).unwrap()
        }
    }

    impl Io for Wire {
        fn send(&mut self, bytes: &[u8]) {
            self.sent.extend_from_slice(bytes);
        }
        fn build_settings(&self) -> Settings {
            Settings::DEFAULT
        }
    }

    impl Board for Wire {
        fn receive(&mut self) -> Option<u8> {
            self.buffer.pop_front()
        }
        fn heard(&mut self) -> Heard {
            core::mem::take(&mut self.heard)
        }
        fn inputs(&mut self) -> Inputs {
            Inputs { now_ms: 0, adc: [1000; crate::HEATERS], endstops: 0 }
        }
        fn apply(&mut self, _: &Outputs) {}
    }

    /// Regression (review of the emergency parser: the main loop heard only what the receive
    /// buffer kept, so an `M112` sent behind a full line queue and a full buffer was lost, and
    /// earlier the breaking session's `M112` waited behind a full queue): the parser hears
    /// every byte as it arrives, kept or not, and the board halts at its next turn.
    #[test]
    fn an_m112_past_a_full_queue_and_a_full_buffer_halts_the_board() {
        let queue = StepQueue::new();
        let mut controller = Controller::new(&queue, Settings::DEFAULT);
        let mut text = b"G4 S10\n".repeat(20);
        text.extend_from_slice(b"M112\n");
        let mut board = Wire::new(&text, 32);
        let inputs = board.inputs();
        controller.boot(&mut board, &inputs);
        let mut refused = None;
        // No turn runs a line: the queue fills, then the buffer, then bytes are lost.
        for _ in 0..20 {
            board.arrive(8);
            controller.heard(board.heard());
            queue_received(&mut controller, &mut board, &mut refused);
        }
        assert!(board.arriving.is_empty() && board.buffer.len() == 32, "the buffer overflowed");
        controller.poll(&mut board, &inputs);
        assert!(controller.is_halted());
        assert!(board.replies().ends_with("Error:Printer halted. kill() called!\n"), "{}", board.replies());
    }

    /// A byte the full line queue refuses is offered again at the next turn, not lost: six
    /// `M105`s through a queue of four, each answered.
    #[test]
    fn a_refused_byte_is_offered_again() {
        let queue = StepQueue::new();
        let mut controller = Controller::new(&queue, Settings::DEFAULT);
        let mut board = Wire::new(&b"M105\n".repeat(6), 256);
        let inputs = board.inputs();
        controller.boot(&mut board, &inputs);
        board.arrive(usize::MAX);
        let mut refused = None;
        queue_received(&mut controller, &mut board, &mut refused);
        assert_eq!(refused, Some(b'\n'), "the queue is full before the last lines");
        for _ in 0..10 {
            controller.poll(&mut board, &inputs);
            queue_received(&mut controller, &mut board, &mut refused);
        }
        assert_eq!(board.replies().matches("ok T:").count(), 6, "{}", board.replies());
    }
}
