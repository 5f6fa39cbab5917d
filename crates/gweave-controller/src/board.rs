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
    /// The byte at `ahead` in the receive buffer (0: the next one), if received, left there:
    /// the emergency parser hears what waits behind a full line queue.
    fn peek(&self, ahead: usize) -> Option<u8>;
    /// The clock, the thermistors' latest readings and the endstops, read for one turn.
    fn inputs(&mut self) -> Inputs;
    /// Drives the heaters, the fan and the stepper enables as the core asks after a turn.
    fn apply(&mut self, outputs: &Outputs);
}

/// The bytes received: each heard by the emergency parser once, as it arrives, then queued
/// while the line queue takes them. `heard` bytes at the front of the board's buffer were heard
/// before; returns how many are now. Only heard bytes are queued: one the receive interrupt
/// adds meanwhile is heard at the next turn (queueing it unheard once let the count go wrong
/// and the parser hear nothing more, so an `M112` waited its turn).
fn hear_and_queue(controller: &mut Controller<'_>, board: &mut impl Board, mut heard: usize) -> usize {
    while let Some(byte) = board.peek(heard) {
        controller.hear(byte);
        heard += 1;
    }
    while heard > 0 {
        let Some(byte) = board.peek(0) else { break };
        if !controller.receive(byte) {
            break;
        }
        let _ = board.receive();
        heard -= 1;
    }
    heard
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
    // How many bytes at the front of the receive buffer the emergency parser has heard: each
    // is heard once, when it arrives, and queued when the line queue has room (a byte the
    // controller refuses stays in the buffer, offered again after its turn).
    let mut heard = 0;
    loop {
        heard = hear_and_queue(controller, board, heard);
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
    use std::cell::RefCell;
    use std::collections::VecDeque;
    use std::vec::Vec;

    use super::*;
    use crate::{Settings, StepQueue};

    /// A board whose receive interrupt delivers one more byte each time the main loop looks at
    /// the front of its buffer: bytes arrive between hearing and queueing.
    struct Racing {
        buffer: RefCell<VecDeque<u8>>,
        arriving: RefCell<VecDeque<u8>>,
        sent: Vec<u8>,
    }

    impl Io for Racing {
        fn send(&mut self, bytes: &[u8]) {
            self.sent.extend_from_slice(bytes);
        }
        fn build_settings(&self) -> Settings {
            Settings::DEFAULT
        }
    }

    impl Board for Racing {
        fn receive(&mut self) -> Option<u8> {
            self.buffer.get_mut().pop_front()
        }
        fn peek(&self, ahead: usize) -> Option<u8> {
            if ahead == 0 {
                if let Some(b) = self.arriving.borrow_mut().pop_front() {
                    self.buffer.borrow_mut().push_back(b);
                }
            }
            self.buffer.borrow().get(ahead).copied()
        }
        fn inputs(&mut self) -> Inputs {
            Inputs { now_ms: 0, adc: [1000; crate::HEATERS], endstops: 0 }
        }
        fn apply(&mut self, _: &Outputs) {}
    }

    /// Regression (the breaking session's `M112` behind a full queue, and on the first fix the
    /// emulated board: bytes that arrived between hearing and queueing were queued unheard, and
    /// the parser heard nothing after): every byte is heard once, in order, whatever arrives
    /// when, and an `M112` among them halts the board.
    #[test]
    fn every_byte_is_heard_once_however_it_arrives() {
        let queue = StepQueue::new();
        let mut controller = Controller::new(&queue, Settings::DEFAULT);
        // More lines than the line queue holds: the `M112` waits behind a full queue.
        let text = b"G4 S10\nM105\nM105\nM105\nM105\nM105\nM112\n";
        let mut board = Racing {
            buffer: RefCell::default(),
            arriving: RefCell::new(text.iter().copied().collect()),
            sent: Vec::new(),
        };
        let inputs = board.inputs();
        controller.boot(&mut board, &inputs);
        let mut heard = 0;
        for _ in 0..text.len() * 2 {
            heard = hear_and_queue(&mut controller, &mut board, heard);
            assert!(heard <= board.buffer.borrow().len());
        }
        // Everything arrived and was heard; what the queue could not take waits in the buffer,
        // the end of the text, in order (the rest was queued, each byte once).
        assert!(board.arriving.borrow().is_empty());
        let waiting: Vec<u8> = board.buffer.borrow().iter().copied().collect();
        assert_eq!(heard, waiting.len());
        assert!(waiting.len() >= b"M112\n".len() && text.ends_with(&waiting), "{waiting:?}");
        controller.poll(&mut board, &inputs);
        assert!(controller.is_halted());
        assert!(std::str::from_utf8(&board.sent).unwrap().contains("Error:Printer halted. kill() called!"));
    }
}
