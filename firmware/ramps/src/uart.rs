//! USART0: the serial link to the host through the Mega's USB-serial chip.
//!
//! Receiving: each byte raises the "receive complete" interrupt, whose handler gives it to the
//! emergency parser (`M112`, `M108`: heard the moment they arrive, as Marlin's parser in its
//! receive interrupt, even when the buffer is full) and puts it in a ring buffer; the main loop
//! takes bytes out when it has time. Without the buffer a byte that
//! arrives while the main loop is busy (planning a move, printing a reply) would be overwritten
//! by the next one after 40 us at 250000 baud. Sending: the main loop waits until the transmit
//! register is free (UDRE) and writes the next byte; a reply of 30 bytes takes 1.2 ms.

use core::cell::UnsafeCell;

use gweave_controller::serial::emergency::{EmergencyParser, Heard};

use crate::regs::{interrupt_free, UBRR0, UCSR0A, UCSR0B, UCSR0C, UDR0};

/// UCSR0A: the transmit data register is empty (a new byte may be written).
const UDRE0: u8 = 1 << 5;
/// UCSR0A: double speed (the baud divider counts 8 clocks per bit instead of 16).
const U2X0: u8 = 1 << 1;
/// UCSR0B: receive-complete interrupt, receiver and transmitter enable.
const RXCIE0: u8 = 1 << 7;
const RXEN0: u8 = 1 << 4;
const TXEN0: u8 = 1 << 3;
/// UCSR0C: 8 data bits (UCSZ01, UCSZ00), no parity, one stop bit.
const FRAME_8N1: u8 = (1 << 2) | (1 << 1);

/// Bytes kept between the interrupt and the main loop: two full Marlin lines of 96 bytes plus
/// headroom, since a host may send the next line as soon as the `ok` of the last one left.
/// Costs its size in RAM; 256 so that a one-byte index wraps around by itself.
const RX_SIZE: usize = 256;

/// The ring buffer: the interrupt writes at `head`, the main loop reads at `tail`; each side
/// writes only its own index, so no lock is needed beyond reading the other index once. The
/// emergency parser's state is the interrupt's alone; what it heard the main loop takes with
/// interrupts off.
struct Ring {
    buf: UnsafeCell<[u8; RX_SIZE]>,
    head: UnsafeCell<u8>,
    tail: UnsafeCell<u8>,
    parser: UnsafeCell<EmergencyParser>,
    heard: UnsafeCell<Heard>,
}

// SAFETY: the firmware has one core; the interrupt and the main loop each own one index, and
// every access to the other side's index is a single byte read (atomic on the AVR); `parser`
// is touched by the interrupt only, `heard` by the main loop only with interrupts off.
unsafe impl Sync for Ring {}

static RX: Ring = Ring {
    buf: UnsafeCell::new([0; RX_SIZE]),
    head: UnsafeCell::new(0),
    tail: UnsafeCell::new(0),
    parser: UnsafeCell::new(EmergencyParser::new()),
    heard: UnsafeCell::new(Heard::new()),
};

/// Set the port up at `baud` (250000 or 115200, 8N1) with the receive interrupt on.
pub fn init(cpu_hz: u32, baud: u32) {
    // With U2X the baud rate is cpu_hz / (8 * (UBRR + 1)): 250000 baud is UBRR 7 exactly,
    // 115200 is UBRR 16 (2.1 % fast, within what a receiver tolerates), as Arduino sets them.
    let ubrr = (cpu_hz / 4 / baud).saturating_sub(1) / 2;
    interrupt_free(|| {
        UCSR0A.write(U2X0);
        UBRR0.write(ubrr as u16);
        UCSR0C.write(FRAME_8N1);
        UCSR0B.write(RXCIE0 | RXEN0 | TXEN0);
    });
}

/// The receive-complete interrupt (vector 25, USART0_RX): the emergency parser hears the byte,
/// then it is stored. With the buffer full it is lost (heard all the same): the host's line
/// checksum catches the damaged line and it is sent again.
#[no_mangle]
pub unsafe extern "avr-interrupt" fn __vector_25() {
    let byte = UDR0.read();
    // SAFETY: interrupts are off inside the handler; only it writes `head` and the parser, and
    // the main loop reads `heard` with interrupts off.
    unsafe {
        (*RX.parser.get()).hear_into(byte, &mut *RX.heard.get());
        let head = *RX.head.get();
        let next = head.wrapping_add(1);
        if next != core::ptr::read_volatile(RX.tail.get()) {
            (*RX.buf.get())[usize::from(head)] = byte;
            *RX.head.get() = next;
        }
    }
}

/// The next received byte, if any.
pub fn read() -> Option<u8> {
    // SAFETY: only the main loop writes `tail`; `head` is read once, a single byte.
    unsafe {
        let tail = *RX.tail.get();
        if tail == core::ptr::read_volatile(RX.head.get()) {
            return None;
        }
        let byte = core::ptr::read_volatile(&(*RX.buf.get())[usize::from(tail)]);
        core::ptr::write_volatile(RX.tail.get(), tail.wrapping_add(1));
        Some(byte)
    }
}

/// What the emergency parser heard since the last call.
pub fn heard() -> Heard {
    // SAFETY: with interrupts off the receive interrupt cannot write `heard` meanwhile. Volatile,
    // so that the compiler cannot move the clearing store past `interrupt_free`'s restoring of
    // the interrupt flag (a store of 0 after an `M112` heard in between would lose it).
    interrupt_free(|| unsafe {
        let heard = core::ptr::read_volatile(RX.heard.get());
        core::ptr::write_volatile(RX.heard.get(), Heard::new());
        heard
    })
}

/// Send one byte, waiting until the transmitter can take it.
pub fn write_byte(byte: u8) {
    while UCSR0A.read() & UDRE0 == 0 {}
    UDR0.write(byte);
}

/// Send bytes.
pub fn write(bytes: &[u8]) {
    for &b in bytes {
        write_byte(b);
    }
}
