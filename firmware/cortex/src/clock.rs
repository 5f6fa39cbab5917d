//! The millisecond clock, and the slow software PWM of the heaters and the fan.
//!
//! Both run in the step interrupt (`main.rs`), which comes back at least every millisecond:
//! it adds the ticks of each interval that ended to the clock, and at each new millisecond
//! switches the power outputs. Each has a duty of 0-255, and is on during the first `duty`
//! milliseconds of every 256 ms period: heaters and beds respond over seconds, so a 4 Hz PWM
//! is plenty, and slow switching is kind to the big bed MOSFET (the AVR build does the same,
//! see firmware/ramps/src/clock.rs).
//!
//! The duties are set by the main loop. Should the main loop hang, the PWM would go on at the
//! last duty: the watchdog (`watchdog.rs`) resets the chip, which switches every output off.

use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

use gweave_controller::board::Pin as _;

use crate::pins::POWER;
use crate::step_timer::TICKS_PER_S;

/// Step timer ticks per millisecond.
pub const TICKS_PER_MS: u32 = TICKS_PER_S / 1000;

static NOW_MS: AtomicU32 = AtomicU32::new(0);
static DUTY: [AtomicU8; POWER.len()] = [const { AtomicU8::new(0) }; POWER.len()];

/// The interrupt's own count: ticks into the current millisecond, and the outputs' levels.
pub struct Clock {
    sub_ms_ticks: u32,
    on: [bool; POWER.len()],
}

impl Clock {
    pub const fn new() -> Clock {
        Clock { sub_ms_ticks: 0, on: [false; POWER.len()] }
    }

    /// Count `ticks` that passed (from the step interrupt); switch the outputs at each new
    /// millisecond.
    pub fn advance_in_interrupt(&mut self, ticks: u32) {
        self.sub_ms_ticks += ticks;
        while self.sub_ms_ticks >= TICKS_PER_MS {
            self.sub_ms_ticks -= TICKS_PER_MS;
            let ms = NOW_MS.load(Ordering::Relaxed).wrapping_add(1);
            NOW_MS.store(ms, Ordering::Relaxed);
            let phase = ms as u8;
            for ((pin, duty), on) in POWER.iter().zip(&DUTY).zip(&mut self.on) {
                let want = phase < duty.load(Ordering::Relaxed);
                if want != *on {
                    pin.write(want);
                    *on = want;
                }
            }
        }
    }
}

/// Milliseconds since power-on (wrapping after 49 days).
pub fn now_ms() -> u32 {
    NOW_MS.load(Ordering::Relaxed)
}

/// The outputs' duties, in the order of [`POWER`]: hotend 0, hotend 1, bed, fan.
pub fn set_duty(duty: [u8; POWER.len()]) {
    for (d, v) in DUTY.iter().zip(duty) {
        d.store(v, Ordering::Relaxed);
    }
}

/// Every output off at once, from anywhere (the fault handler): the duties first, so the
/// interrupt, if it still runs, keeps them off.
pub fn all_off() {
    set_duty([0; POWER.len()]);
    for pin in POWER {
        pin.write(false);
    }
}
