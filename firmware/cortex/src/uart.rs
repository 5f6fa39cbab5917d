//! USART1: the serial link to the host.
//!
//! Receiving: each byte raises the "receive register not empty" interrupt, whose handler gives
//! it to the emergency parser (`M112`, `M108`: heard the moment they arrive, even when the
//! buffer is full, as Marlin's parser in its receive interrupt) and puts it in a ring buffer; the main loop takes bytes out when it has time (at 250000 baud a byte
//! comes every 40 us, and planning a move or printing a reply takes longer). Sending: the main
//! loop waits until the transmit register is empty (TXE) and writes the next byte.
//! Registers: RM0090, "USART register map".

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicU8, Ordering};

use gweave_controller::serial::emergency::{EmergencyParser, Heard};

use crate::pins;
use crate::regs::{nvic_enable, reg, Reg, RCC_APB2ENR};

const USART1: usize = 0x4001_1000;
const SR: Reg = reg(USART1);
const DR: Reg = reg(USART1 + 0x04);
const BRR: Reg = reg(USART1 + 0x08);
const CR1: Reg = reg(USART1 + 0x0C);
/// SR: a byte was received; the transmit register is empty.
const RXNE: u32 = 1 << 5;
const TXE: u32 = 1 << 7;
/// CR1: USART enable, receive interrupt, transmitter and receiver on (8N1 is the default).
const UE: u32 = 1 << 13;
const RXNEIE: u32 = 1 << 5;
const TE: u32 = 1 << 3;
const RE: u32 = 1 << 2;
/// RCC_APB2ENR: USART1's clock.
const USART1EN: u32 = 1 << 4;

/// Bytes kept between the interrupt and the main loop: two full Marlin lines plus headroom, as
/// on the AVR; 256 so that a one-byte index wraps around by itself.
const RX_SIZE: usize = 256;

/// The ring buffer: the interrupt writes at `head`, the main loop reads at `tail`; each side
/// writes only its own index.
struct Ring {
    buf: UnsafeCell<[u8; RX_SIZE]>,
    head: AtomicU8,
    tail: AtomicU8,
    /// The emergency parser's state: the interrupt's alone.
    parser: UnsafeCell<EmergencyParser>,
    /// What it heard ([`Heard::bits`]): the interrupt adds, the main loop takes.
    heard: AtomicU8,
}

// SAFETY: one core; a slot is written by the interrupt before `head` moves past it (Release)
// and read by the main loop after it saw `head` move (Acquire), never both at once; `parser`
// is touched by the interrupt only.
unsafe impl Sync for Ring {}

static RX: Ring = Ring {
    buf: UnsafeCell::new([0; RX_SIZE]),
    head: AtomicU8::new(0),
    tail: AtomicU8::new(0),
    parser: UnsafeCell::new(EmergencyParser::new()),
    heard: AtomicU8::new(0),
};

/// Set the port up at `baud`, 8N1, with the receive interrupt on. `apb2_hz` is the clock of
/// the bus USART1 sits on.
pub fn init(apb2_hz: u32, baud: u32) {
    RCC_APB2ENR.modify(USART1EN, USART1EN);
    pins::USART1_TX.make_alternate_high(7);
    pins::USART1_RX.make_alternate_high(7);
    // With 16 samples per bit, BRR holds apb2_hz / baud as a fixed-point number with four
    // fraction bits, which is the same as the plain quotient: 336 for 250000 baud at 84 MHz.
    BRR.write((apb2_hz + baud / 2) / baud);
    CR1.write(UE | RXNEIE | TE | RE);
    nvic_enable(crate::start::USART1_INTERRUPT);
}

/// The receive interrupt: the emergency parser hears the byte, then it is stored. With the
/// buffer full it is lost (heard all the same): the host's line checksum catches the damaged
/// line and it is sent again.
///
/// # Safety
/// Called by the core for USART1's interrupt only.
pub unsafe extern "C" fn receive_interrupt() {
    if SR.read() & RXNE == 0 {
        return;
    }
    // Reading DR clears RXNE (and the interrupt).
    let byte = DR.read() as u8;
    let mut heard = Heard::new();
    // SAFETY: only this interrupt touches the parser, and it does not interrupt itself.
    unsafe { (*RX.parser.get()).hear_into(byte, &mut heard) };
    if heard != Heard::new() {
        RX.heard.fetch_or(heard.bits(), Ordering::Relaxed);
    }
    let head = RX.head.load(Ordering::Relaxed);
    let next = head.wrapping_add(1);
    if next != RX.tail.load(Ordering::Acquire) {
        // SAFETY: the slot at `head` is not visible to the main loop until `head` moves.
        unsafe { (*RX.buf.get())[usize::from(head)] = byte };
        RX.head.store(next, Ordering::Release);
    }
}

/// The next received byte, if any.
pub fn read() -> Option<u8> {
    let tail = RX.tail.load(Ordering::Relaxed);
    if tail == RX.head.load(Ordering::Acquire) {
        return None;
    }
    // SAFETY: the interrupt wrote this slot before moving `head` past it and will not write it
    // again until `tail` moves on.
    let byte = unsafe { (*RX.buf.get())[usize::from(tail)] };
    RX.tail.store(tail.wrapping_add(1), Ordering::Release);
    Some(byte)
}

/// What the emergency parser heard since the last call.
pub fn heard() -> Heard {
    Heard::from_bits(RX.heard.swap(0, Ordering::Relaxed))
}

/// Send bytes, each when the transmitter can take it.
pub fn write(bytes: &[u8]) {
    for &b in bytes {
        while SR.read() & TXE == 0 {}
        DR.write(u32::from(b));
    }
}
