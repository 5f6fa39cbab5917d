//! The InkShield and its HP C6602 cartridges on the emulated board: the nozzle pulses decoded
//! from the pins, with where the head was and how they were timed.
//!
//! The wiring is the inkjet firmware's (`firmware/ramps/src/pins.rs`): the shield's address
//! lines A, B, C, D (the nozzle's number, bit 0 first) on D17, D16, D23, D25, and a pulse line
//! per head on D19 and D2. A nozzle fires on a pulse of its head's line: the decoder passes the
//! pulse to the resistor the address lines select (the nozzle is read when the pulse rises,
//! and must not change before it falls).
//!
//! Pulses of one head close together are one *fire* (one `M700`): the firmware fires a mask's
//! nozzles one after the other, in address order, with at most a step interrupt between two
//! (a few hundred microseconds), while two fires of a head are at least 800 us apart. Each
//! fire keeps where X, Y and Z were (the axes' microsteps) when its first pulse rose.
//!
//! The timing is checked against the InkShield library's and Steve Kelly's Marlin patch's
//! (`NicholasCLewis/InkShield`, `sjkelly/Marlin` branch `hpc6602`): [`Timing`] keeps the
//! extremes, and [`Timing::faults`] counts what a cartridge would get wrong.

use crate::sim::PortPin;

/// Heads wired (pulse lines).
pub const HEADS: usize = 2;
/// Address lines A, B, C, D: D17, D16, D23, D25.
pub const ADDRESS: [PortPin; 4] =
    [PortPin::new(b'H', 0), PortPin::new(b'H', 1), PortPin::new(b'A', 1), PortPin::new(b'A', 3)];
/// Pulse lines of heads 0 and 1: D19, D2.
pub const PULSE: [PortPin; HEADS] = [PortPin::new(b'D', 2), PortPin::new(b'E', 4)];
/// Nozzles of a C6602: addresses 0-11.
pub const NOZZLES: u8 = 12;

/// Two pulses of one head further apart than this are two fires, cycles (500 us at 16 MHz:
/// longer than the longest step interrupt between two nozzles, shorter than the 800 us a head
/// needs between fires).
const FIRE_GAP_CYCLES: u64 = 8_000;

/// One fire: a head's nozzles pulsed together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fire {
    /// The head (`M700 P`).
    pub head: u8,
    /// The nozzles pulsed, bit `1 << address`.
    pub nozzles: u16,
    /// When its first pulse rose, cycles.
    pub cycle: u64,
    /// Where X, Y and Z were then, microsteps from their endstops.
    pub steps: [i64; 3],
}

/// The extremes of the pulses' timing, in cycles, and the faults seen.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Timing {
    /// Narrowest and widest pulse.
    pub width_min: Option<u64>,
    pub width_max: Option<u64>,
    /// Shortest time from a pulse's fall to the next pulse's rise, any head.
    pub gap_min: Option<u64>,
    /// Shortest time between two fires of one head (first rises).
    pub refill_min: Option<u64>,
    /// Pulses whose address changed while they were high, pulses of two heads at once,
    /// addresses past the 12 nozzles, a nozzle pulsed twice in a fire or out of address order,
    /// an axis moving during a fire: each would misplace or miss drops.
    pub faults: u64,
}

/// The decoder's state, fed with the pins' edges.
#[derive(Debug, Clone, Default)]
pub struct InkShield {
    /// The address lines' levels, bit per line.
    address: u8,
    /// Per head: the rising edge's cycle and the address then, while its line is high.
    high: [Option<(u64, u8)>; HEADS],
    last_fall: Option<u64>,
    /// The fire being collected per head, and when its last pulse fell.
    open: [Option<(Fire, u64)>; HEADS],
    /// The fires, in order of their end.
    pub fires: Vec<Fire>,
    pub timing: Timing,
}

impl InkShield {
    /// An edge of address line `line` (0-3).
    pub fn address_changed(&mut self, line: usize, high: bool) {
        if self.high.iter().any(Option::is_some) {
            self.timing.faults += 1;
        }
        let bit = 1 << line;
        self.address = if high { self.address | bit } else { self.address & !bit };
    }

    /// An edge of head `head`'s pulse line at `cycle`, the axes at `steps`.
    pub fn pulse_changed(&mut self, head: usize, high: bool, cycle: u64, steps: [i64; 3]) {
        if high {
            if self.high.iter().any(Option::is_some) {
                self.timing.faults += 1;
            }
            if let Some(fall) = self.last_fall {
                min(&mut self.timing.gap_min, cycle - fall);
            }
            self.high[head] = Some((cycle, self.address));
            self.collect(head, cycle, steps);
            return;
        }
        let Some((rise, _)) = self.high[head].take() else { return };
        let width = cycle - rise;
        min(&mut self.timing.width_min, width);
        self.timing.width_max = Some(self.timing.width_max.map_or(width, |m| m.max(width)));
        self.last_fall = Some(cycle);
        if let Some((_, end)) = self.open[head].as_mut() {
            *end = cycle;
        }
    }

    /// Adds the pulse rising now to its head's fire, or closes that fire and opens another.
    fn collect(&mut self, head: usize, cycle: u64, steps: [i64; 3]) {
        let nozzle = self.address;
        if nozzle >= NOZZLES {
            self.timing.faults += 1;
            return;
        }
        if let Some((fire, end)) = self.open[head].as_mut() {
            let later_nozzle = u32::from(nozzle) >= 16 - fire.nozzles.leading_zeros();
            if cycle - *end <= FIRE_GAP_CYCLES && later_nozzle {
                fire.nozzles |= 1 << nozzle;
                if fire.steps != steps {
                    self.timing.faults += 1;
                }
                return;
            }
            if cycle - *end <= FIRE_GAP_CYCLES {
                // Close in time but not in address order: a nozzle twice, or a firmware that
                // lost its place; counted, then a fire of its own.
                self.timing.faults += 1;
            }
        }
        self.close(head);
        if let Some(last) = self.fires.iter().rev().find(|f| usize::from(f.head) == head) {
            min(&mut self.timing.refill_min, cycle - last.cycle);
        }
        let fire = Fire { head: head as u8, nozzles: 1 << nozzle, cycle, steps };
        self.open[head] = Some((fire, cycle));
    }

    fn close(&mut self, head: usize) {
        if let Some((fire, _)) = self.open[head].take() {
            self.fires.push(fire);
        }
    }

    /// Every fire so far, the ones still open closed (call once the firmware is idle).
    pub fn finish(&mut self) -> &[Fire] {
        for head in 0..HEADS {
            self.close(head);
        }
        self.fires.sort_by_key(|f| f.cycle);
        &self.fires
    }
}

fn min(slot: &mut Option<u64>, v: u64) {
    *slot = Some(slot.map_or(v, |m| m.min(v)));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pulses nozzles `list` of `head` from `cycle`, 100 cycles apart, 82 cycles wide.
    fn fire(s: &mut InkShield, head: usize, list: &[u8], mut cycle: u64) {
        for &n in list {
            for line in 0..4 {
                s.address_changed(line, n & (1 << line) != 0);
            }
            s.pulse_changed(head, true, cycle, [1, 2, 3]);
            s.pulse_changed(head, false, cycle + 82, [1, 2, 3]);
            cycle += 100;
        }
    }

    #[test]
    fn pulses_close_together_are_one_fire_and_the_timing_is_kept() {
        let mut s = InkShield::default();
        fire(&mut s, 0, &[0, 11], 1_000);
        fire(&mut s, 1, &[3], 2_000);
        // 800 us after head 0's first fire.
        fire(&mut s, 0, &[5], 1_000 + 12_800);
        let fires = s.finish().to_vec();
        let got: Vec<(u8, u16, u64)> = fires.iter().map(|f| (f.head, f.nozzles, f.cycle)).collect();
        assert_eq!(got, vec![(0, 0x801, 1_000), (1, 8, 2_000), (0, 32, 13_800)]);
        assert_eq!(fires[0].steps, [1, 2, 3]);
        let t = s.timing;
        assert_eq!(
            (t.width_min, t.width_max, t.gap_min, t.refill_min),
            (Some(82), Some(82), Some(18), Some(12_800))
        );
        assert_eq!(t.faults, 0);
    }

    #[test]
    fn an_address_changing_during_a_pulse_or_a_nozzle_twice_is_a_fault() {
        let mut s = InkShield::default();
        s.pulse_changed(0, true, 10, [0; 3]);
        s.address_changed(0, true);
        s.pulse_changed(0, false, 90, [0; 3]);
        fire(&mut s, 0, &[0], 200);
        assert_eq!(s.timing.faults, 2);
    }
}
