//! Timer0: the millisecond clock, and the slow software PWM of the heaters and the fan.
//!
//! Timer0 counts the 16 MHz clock divided by 64 (250 kHz) and, in "clear timer on compare"
//! mode, restarts after 250 counts: one interrupt per millisecond. The handler counts the
//! milliseconds and switches the heater and fan outputs: each has a duty of 0-255, and an
//! output is on during the first `duty` milliseconds of every 256 ms period. Heaters and beds
//! respond over seconds, so a 4 Hz PWM is plenty, and slow switching is kind to the big bed
//! MOSFET (Marlin's "soft PWM" does the same for the same reason).
//!
//! The duties are set by the main loop. Should the main loop hang, the PWM would go on at the
//! last duty: the watchdog (see `watchdog.rs`) resets the chip, which switches every output
//! off, long before that can overheat anything.

use core::cell::UnsafeCell;

use gweave_controller::board::Pin as _;

use crate::pins::Pin;
use crate::regs::{interrupt_free, OCR0A, TCCR0A, TCCR0B, TIMSK0};

/// TCCR0A: waveform mode 2, "clear timer on compare match A" (CTC).
const WGM01: u8 = 1 << 1;
/// TCCR0B: clock select 3, the CPU clock divided by 64.
const CS_DIV64: u8 = (1 << 1) | 1;
/// TIMSK0: interrupt on compare match A.
const OCIE0A: u8 = 1 << 1;

/// How many outputs the PWM drives (hotend, bed, D9).
pub const PWM_OUTPUTS: usize = 3;

struct State {
    now_ms: UnsafeCell<u32>,
    duty: UnsafeCell<[u8; PWM_OUTPUTS]>,
    phase: UnsafeCell<u8>,
}

// SAFETY: one core; the main loop touches `now_ms` and `duty` only with interrupts off.
unsafe impl Sync for State {}

static STATE: State =
    State { now_ms: UnsafeCell::new(0), duty: UnsafeCell::new([0; PWM_OUTPUTS]), phase: UnsafeCell::new(0) };

/// The pins the PWM drives, fixed at start-up.
static mut PINS: Option<[Pin; PWM_OUTPUTS]> = None;

/// Start the clock and the PWM on `pins` (all made outputs, off).
pub fn init(pins: [Pin; PWM_OUTPUTS]) {
    for p in pins {
        p.write(false);
        p.make_output();
    }
    interrupt_free(|| {
        // SAFETY: interrupts are off, so the handler cannot be reading it.
        unsafe { PINS = Some(pins) };
        TCCR0A.write(WGM01);
        // 250 counts of 4 us: 1 ms (the counter runs 0..=249).
        OCR0A.write(249);
        TCCR0B.write(CS_DIV64);
        TIMSK0.write(OCIE0A);
    });
}

/// Milliseconds since start-up (wraps after 49 days).
pub fn now_ms() -> u32 {
    // SAFETY: a 4-byte value the handler changes: read it with interrupts off.
    interrupt_free(|| unsafe { *STATE.now_ms.get() })
}

/// Set the duty (0 = off, 255 = on) of each PWM output.
pub fn set_duty(duty: [u8; PWM_OUTPUTS]) {
    // SAFETY: interrupts are off while the array is written.
    interrupt_free(|| unsafe { *STATE.duty.get() = duty });
}

/// Switch every PWM output off at once (a halt): the duties go to zero and the pins low now,
/// without waiting for the next millisecond.
pub fn all_off() {
    set_duty([0; PWM_OUTPUTS]);
    // SAFETY: read only; written once in `init` before interrupts were enabled.
    if let Some(pins) = unsafe { PINS } {
        for p in pins {
            p.write(false);
        }
    }
}

/// The compare-match interrupt of Timer0 (vector 21, TIMER0_COMPA), every millisecond.
#[no_mangle]
pub unsafe extern "avr-interrupt" fn __vector_21() {
    // SAFETY: interrupts are off inside the handler.
    unsafe {
        *STATE.now_ms.get() = (*STATE.now_ms.get()).wrapping_add(1);
        let phase = (*STATE.phase.get()).wrapping_add(1);
        *STATE.phase.get() = phase;
        if let Some(pins) = PINS {
            let duty = *STATE.duty.get();
            for (p, d) in pins.iter().zip(duty) {
                // On while the phase is below the duty; 255 is on all the time.
                p.write_in_interrupt(phase < d || d == u8::MAX);
            }
        }
    }
}
