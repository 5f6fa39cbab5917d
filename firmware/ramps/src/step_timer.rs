//! Timer1: the step timer.
//!
//! Timer1 counts the 16 MHz clock divided by 8, so one tick is 0.5 us (2 MHz), and runs freely
//! from 0 to 65535 and round again. When it equals OCR1A it raises the "compare match A"
//! interrupt; the handler pulses the STEP pins due now and moves OCR1A on by the ticks to the
//! next interrupt: the controller's stepper decides both (see `main.rs`).
//!
//! Each compare is scheduled from the previous one, not from the moment the handler runs, so the
//! time the handler takes does not add up: the steps keep the core's timing exactly. (Restarting
//! the counter at each match, "CTC" mode, would instead lose a whole turn of the counter, 32 ms,
//! whenever the handler took longer than the next interval.)

use crate::regs::{interrupt_free, OCR1A, TCCR1A, TCCR1B, TCNT1, TIMSK1};

/// Timer ticks per second.
pub const TICKS_PER_S: u32 = 2_000_000;
/// TCCR1B: clock divided by 8 (CS11); waveform mode 0, counting freely.
const CS11: u8 = 1 << 1;
/// TIMSK1: interrupt on compare match A.
const OCIE1A: u8 = 1 << 1;
/// Ticks the handler needs, from leaving until the interrupt can fire again: a compare closer
/// than this to now is put this far ahead (10 us).
const MARGIN_TICKS: u16 = 20;

/// Configure Timer1 and start its interrupt, the first after `ticks`.
pub fn start(ticks: u16) {
    interrupt_free(|| {
        TCCR1A.write(0);
        TCCR1B.write(CS11);
        TCNT1.write(0);
        OCR1A.write(ticks.max(MARGIN_TICKS));
        TIMSK1.write(OCIE1A);
    });
}

/// Schedule the next interrupt `ticks` after the one being handled (from inside the handler).
/// If that moment has passed already (a handler longer than the interval), it fires as soon
/// as the handler is done: a late step rather than a lost turn of the counter.
#[inline(always)]
pub fn set_next_in_interrupt(ticks: u16) {
    let this = OCR1A.read();
    let next = this.wrapping_add(ticks.max(1));
    let now = TCNT1.read();
    // Ticks since this interrupt's compare, and from it to the next one (wrapping counts).
    if now.wrapping_sub(this).saturating_add(MARGIN_TICKS) >= ticks {
        OCR1A.write(now.wrapping_add(MARGIN_TICKS));
    } else {
        OCR1A.write(next);
    }
}
