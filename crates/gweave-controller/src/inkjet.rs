//! Inkjet printheads: an HP C6602 cartridge driven through Nicholas Lewis's InkShield, fired
//! by `M700 P<head> S<nozzles>` as in Steve Kelly's Marlin patch (`sjkelly/Marlin`, branch
//! `hpc6602`, `Marlin_main.cpp`), the binder-jet seed's firmware.
//!
//! **The physics.** The C6602 is a thermal inkjet: under each of its 12 nozzles (one column at
//! 96 dpi, 0.2646 mm apart) sits a thin-film resistor. A pulse of current of a few microseconds
//! boils a film of ink on it; the vapour bubble pushes one drop (about 160 pl) out of the
//! nozzle, and capillarity refills the chamber. The InkShield raises the cartridge's supply
//! above the board's 5 V and puts a 4-to-16 decoder in front of the resistors: four *address*
//! lines (A, B, C, D) say which nozzle, and the *pulse* line gates the current. Hence the
//! timing (the InkShield library, `NicholasCLewis/InkShield`, and the patch):
//!
//! - a nozzle fires with a pulse of [`PULSE_US`] (5 us): shorter does not boil the film, longer
//!   heats the resistor and the ink for nothing and wears the resistor;
//! - the address is set before the pulse rises and held until it falls, then cleared: a
//!   changing address during a pulse would fire another nozzle;
//! - the nozzles set in `S` fire one after the other, in address order (one resistor at a time:
//!   the supply feeds one), a microsecond or more apart;
//! - two fires of one head are at least [`MIN_FIRE_INTERVAL_US`] (800 us) apart: the chambers
//!   must refill, or the next drops come out short.
//!
//! **What `M700` does here.** The patch fires as soon as the line is parsed, while the queued
//! moves may still run; the G-code has to put an `M400` before every `M700` (`gweave raster`
//! does). Here `M700` waits for the queued moves to end, as an `M400` would, so the drops land
//! where the moves before it put the head even without the `M400`; then it waits for the
//! head's refill time if needed, and the board fires the nozzles ([`crate::Io::inkjet_fire`],
//! with the pulse timing above). `S` is a 12-bit mask (bit `a` fires nozzle address `a`, the
//! least significant bit address 0, as the patch); `P` the head, which the patch needs too
//! (without `P` it fires nothing). A value outside its range, a fraction or a missing `P` is
//! refused with an `Error:` line and fires nothing: a host stops a print that would put its
//! drops in the wrong place.

use crate::limits::INKJET_HEADS;

/// Nozzles of an HP C6602, one address each (0-11).
pub const NOZZLES: u32 = 12;
/// The largest nozzle mask, every nozzle (`S4095`).
pub const ALL_NOZZLES: u16 = (1 << NOZZLES) - 1;
/// The width of the pulse that fires one nozzle, microseconds (the InkShield library's).
pub const PULSE_US: u32 = 5;
/// The shortest time between two fires of one head, microseconds (the patch's refill wait).
pub const MIN_FIRE_INTERVAL_US: u32 = 800;

/// The refill wait on the core's millisecond clock: two clock edges apart is more than one
/// full millisecond, so more than [`MIN_FIRE_INTERVAL_US`] whatever the fraction of a
/// millisecond the clock hid at each end.
const MIN_FIRE_INTERVAL_MS_TICKS: u32 = MIN_FIRE_INTERVAL_US.div_ceil(1000) + 1;

/// When each head last fired, for the refill wait.
#[derive(Debug, Clone, Copy, Default)]
pub struct Heads {
    last_fire_ms: [u32; INKJET_HEADS],
    /// Bit `1 << head`: the head has fired since power-on (its time above is meaningful).
    fired: u8,
}

impl Heads {
    /// No head has fired.
    pub const fn new() -> Self {
        Heads { last_fire_ms: [0; INKJET_HEADS], fired: 0 }
    }

    /// Whether `head` may fire at `now_ms` (its chambers have refilled).
    pub fn ready(&self, head: usize, now_ms: u32) -> bool {
        match self.last_fire_ms.get(head) {
            Some(&last) if self.fired & (1 << head) != 0 => {
                now_ms.wrapping_sub(last) >= MIN_FIRE_INTERVAL_MS_TICKS
            }
            _ => true,
        }
    }

    /// Notes that `head` fired at `now_ms`.
    pub fn fired(&mut self, head: usize, now_ms: u32) {
        if let Some(last) = self.last_fire_ms.get_mut(head) {
            *last = now_ms;
            self.fired |= 1 << head;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_head_waits_two_clock_edges_and_the_other_does_not() {
        let mut heads = Heads::new();
        assert!(heads.ready(0, 7));
        heads.fired(0, 7);
        // 7 ms could be 7.999 ms, 8 ms could be 8.0: only 9 is surely 800 us later.
        assert!(!heads.ready(0, 7));
        assert!(!heads.ready(0, 8));
        assert!(heads.ready(0, 9));
        assert!(heads.ready(1, 7));
        // Across the clock's wrap.
        heads.fired(1, u32::MAX);
        assert!(!heads.ready(1, 0));
        assert!(heads.ready(1, 1));
    }
}
