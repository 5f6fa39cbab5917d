//! Timer1: the step timer.
//!
//! Timer1 counts the 16 MHz clock divided by 8, so one tick is 0.5 us (2 MHz), and in "clear
//! timer on compare" mode restarts at 0 when it reaches OCR1A, raising an interrupt. The
//! handler pulses the STEP pins due now and writes OCR1A with the ticks to the next
//! interrupt: the controller's stepper decides both (see `main.rs`).

use crate::regs::{interrupt_free, OCR1A, TCCR1A, TCCR1B, TCNT1, TIMSK1};

/// Timer ticks per second.
pub const TICKS_PER_S: u32 = 2_000_000;
/// TCCR1B: waveform mode 4 (CTC with OCR1A as top: WGM12) and clock divided by 8 (CS11).
const WGM12: u8 = 1 << 3;
const CS11: u8 = 1 << 1;
/// TIMSK1: interrupt on compare match A.
const OCIE1A: u8 = 1 << 1;

/// Configure Timer1 and start its interrupt, the first after `ticks`.
pub fn start(ticks: u16) {
    interrupt_free(|| {
        TCCR1A.write(0);
        TCCR1B.write(WGM12 | CS11);
        TCNT1.write(0);
        OCR1A.write(ticks.max(1));
        TIMSK1.write(OCIE1A);
    });
}

/// Set the ticks to the next interrupt, from inside the handler (the counter restarted at 0
/// when this interrupt fired, so the new top counts from then).
#[inline(always)]
pub fn set_next_in_interrupt(ticks: u16) {
    OCR1A.write(ticks.max(1));
}
