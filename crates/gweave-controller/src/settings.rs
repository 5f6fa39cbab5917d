//! The printer's settings: what the board's configuration sets at build time, what `M92`,
//! `M201`, `M203`, `M204`, `M205` and `M301` change over serial, and what `M500` keeps in
//! EEPROM.
//!
//! The defaults are a common i3-style printer on RAMPS 1.4 (issue 37): 80/80/400/93 steps per
//! mm, endstops at the minimum of X, Y and Z reading high when triggered, every DIR pin high for
//! a positive move, Marlin's default limits and thermal protection.

use crate::rotary::Rotary;
use crate::{AXES, HEATERS};

/// PID gains of one heater, in per-second units: `Kp` in duty per °C, `Ki` in duty per °C·s,
/// `Kd` in duty per °C/s (Marlin's `M301 P I D` as printed by `M503`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pid {
    /// Proportional gain, duty (0-255) per °C of error.
    pub kp: f32,
    /// Integral gain, duty per °C·s of accumulated error.
    pub ki: f32,
    /// Derivative gain, duty per °C/s of temperature change.
    pub kd: f32,
}

/// The printer's settings. Every field has its unit in its name.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Steps per millimetre, per axis (`M92`).
    pub steps_per_mm: [f32; AXES],
    /// Highest speed per axis, mm/s (`M203`).
    pub max_feed_mm_s: [f32; AXES],
    /// Highest acceleration per axis, mm/s² (`M201`).
    pub max_accel_mm_s2: [f32; AXES],
    /// Acceleration of moves that extrude, mm/s² (`M204 P`, or `S`).
    pub print_accel_mm_s2: f32,
    /// Acceleration of moves of the extruder alone (retractions), mm/s² (`M204 R`).
    pub retract_accel_mm_s2: f32,
    /// Acceleration of moves that do not extrude, mm/s² (`M204 T`, or `S`).
    pub travel_accel_mm_s2: f32,
    /// Junction deviation, mm (`M205 J`): how far the path may stray from a corner's point if
    /// the move were to go round it at the junction speed (GRBL's model, see
    /// [`crate::planner`]).
    pub junction_deviation_mm: f32,
    /// The machine's travel from its minimum (the endstops, position 0) per axis, mm. Homing
    /// runs at most 1.5 times this far. E is unused.
    pub travel_mm: [f32; AXES],
    /// Homing speed per axis, mm/s (Marlin's `HOMING_FEEDRATE_MM_M`: 50, 50, 4 mm/s).
    pub homing_feed_mm_s: [f32; AXES],
    /// The order `G28` homes the axes in (axis indices: 2, 1, 0 is Z, then Y, then X).
    pub homing_order: [u8; 3],
    /// Distance to back off after first touching an endstop, mm (Marlin's
    /// `HOMING_BUMP_MM`: 5, 5, 2), before touching it again at half speed.
    pub homing_bump_mm: [f32; AXES],
    /// DIR pin bits to invert (bit `1 << motor`, [`crate::MOTORS`]: a mixing hotend's inputs
    /// E1-E3 after E0 = E): with 0, every DIR pin is high for a positive move.
    pub invert_dir: u8,
    /// Endstop pin bits whose triggered level is low (bit `1 << axis`): with 0, an endstop pin
    /// reads high when triggered.
    pub endstop_inverting: u8,
    /// Hotends fitted: 1 (RAMPS "EFB": hotend, fan, bed) or 2 ("EEB": the second hotend's heater
    /// on D9, and no part fan).
    pub hotends: u8,
    /// Thermistor table per sensor, in [`crate::HEATERS`] order, as Marlin numbers them (only
    /// type 1 is built in; 0 means no sensor).
    pub thermistor: [u8; HEATERS],
    /// PID gains of the hotends (`M301`). The bed is switched on below its target and off above
    /// (bang-bang, Marlin's default without `PIDTEMPBED`): it is slow and heavy, and needs no
    /// tuning that way.
    pub hotend_pid: Pid,
    /// Lowest hotend temperature an extruding move may run at, °C (Marlin's `EXTRUDE_MINTEMP`,
    /// 170); 0 allows cold extrusion.
    pub extrude_min_c: f32,
    /// Longest extrusion one move may make, mm of filament (Marlin's `EXTRUDE_MAXLENGTH`, 200);
    /// a longer one is refused as `PREVENT_LENGTHY_EXTRUDE` does. 0 allows any.
    pub extrude_max_mm: f32,
    /// Highest temperature allowed per heater, °C: above it the machine halts (MAXTEMP).
    pub max_temp_c: [f32; HEATERS],
    /// Inputs of a mixing hotend, 2 to [`crate::limits::MIX_INPUTS`] (E0, E1, ...; see
    /// [`crate::mixing`]), or 0 for a plain extruder. A build-time fact, not kept by `M500`.
    pub mixing_inputs: u8,
    /// Inkjet heads wired (0 to [`crate::limits::INKJET_HEADS`]; each an HP C6602 on its own
    /// pulse pin, `M700 P<head>`), or 0: no inkjet, and `M700` is unknown. A build-time fact,
    /// not kept by `M500`; only a build with the feature `inkjet` fires them.
    pub inkjet_heads: u8,
    /// The rotary axis A of a lathe-type printer ([`crate::rotary`]), or
    /// [`Rotary::NONE`]. A build-time fact, not kept by `M500`.
    pub rotary: Rotary,
}

impl Settings {
    /// The default printer (issue 37, Marlin 2.1's `Configuration.h` defaults for limits and
    /// thermal settings).
    pub const DEFAULT: Settings = Settings {
        steps_per_mm: [80.0, 80.0, 400.0, 93.0],
        max_feed_mm_s: [300.0, 300.0, 5.0, 25.0],
        max_accel_mm_s2: [3000.0, 3000.0, 100.0, 10000.0],
        print_accel_mm_s2: 3000.0,
        retract_accel_mm_s2: 3000.0,
        travel_accel_mm_s2: 3000.0,
        junction_deviation_mm: 0.013,
        travel_mm: [200.0, 200.0, 200.0, 0.0],
        homing_feed_mm_s: [50.0, 50.0, 4.0, 0.0],
        homing_order: [2, 1, 0],
        homing_bump_mm: [5.0, 5.0, 2.0, 0.0],
        invert_dir: 0,
        endstop_inverting: 0,
        hotends: 1,
        thermistor: [1, 0, 1],
        hotend_pid: Pid { kp: 22.2, ki: 1.08, kd: 114.0 },
        extrude_min_c: 170.0,
        extrude_max_mm: 200.0,
        max_temp_c: [275.0, 275.0, 150.0],
        mixing_inputs: 0,
        inkjet_heads: 0,
        rotary: Rotary::NONE,
    };
}

impl Default for Settings {
    fn default() -> Self {
        Settings::DEFAULT
    }
}

/// Where the settings start in EEPROM, and the mark of this layout's version before them.
/// Changing the layout changes the mark, so an old EEPROM reads as "no settings".
pub const EEPROM_MARK: [u8; 4] = *b"GWC1";

/// Bytes of the settings in EEPROM: the mark, [`Settings::STORED`] floats (little-endian) and a
/// CRC-16 of them.
pub const EEPROM_BYTES: u16 = 4 + 4 * Settings::STORED as u16 + 2;

impl Settings {
    /// How many numbers `M500` keeps: steps, feeds and accelerations per axis (12), the three
    /// accelerations and the junction deviation (4), the hotends' PID gains (3).
    pub const STORED: usize = 19;

    /// The numbers kept in EEPROM, in their EEPROM order.
    fn stored(&mut self) -> [&mut f32; Settings::STORED] {
        let [s0, s1, s2, s3] = &mut self.steps_per_mm;
        let [f0, f1, f2, f3] = &mut self.max_feed_mm_s;
        let [a0, a1, a2, a3] = &mut self.max_accel_mm_s2;
        let hp = &mut self.hotend_pid;
        [
            s0,
            s1,
            s2,
            s3,
            f0,
            f1,
            f2,
            f3,
            a0,
            a1,
            a2,
            a3,
            &mut self.print_accel_mm_s2,
            &mut self.retract_accel_mm_s2,
            &mut self.travel_accel_mm_s2,
            &mut self.junction_deviation_mm,
            &mut hp.kp,
            &mut hp.ki,
            &mut hp.kd,
        ]
    }

    /// Writes the settings to EEPROM (`M500`); returns the CRC written.
    pub fn save(&self, io: &mut impl crate::Io) -> u16 {
        let mut copy = *self;
        let mut crc = 0xFFFF;
        io.eeprom_write(0, &EEPROM_MARK);
        for (i, v) in copy.stored().into_iter().enumerate() {
            let bytes = v.to_le_bytes();
            crc = crc16(crc, &bytes);
            io.eeprom_write(4 + 4 * i as u16, &bytes);
        }
        io.eeprom_write(EEPROM_BYTES - 2, &crc.to_le_bytes());
        crc
    }

    /// Reads the settings from EEPROM (`M501`, and at boot); returns the CRC read, or `None`,
    /// changing nothing, when the EEPROM holds no settings of this layout, a wrong CRC, or a
    /// number that is not finite.
    pub fn load(&mut self, io: &mut impl crate::Io) -> Option<u16> {
        let mut mark = [0u8; 4];
        io.eeprom_read(0, &mut mark);
        if mark != EEPROM_MARK {
            return None;
        }
        let mut read = *self;
        let mut crc = 0xFFFF;
        for (i, v) in read.stored().into_iter().enumerate() {
            let mut bytes = [0u8; 4];
            io.eeprom_read(4 + 4 * i as u16, &mut bytes);
            crc = crc16(crc, &bytes);
            *v = f32::from_le_bytes(bytes);
            if !v.is_finite() {
                return None;
            }
        }
        let mut stored_crc = [0u8; 2];
        io.eeprom_read(EEPROM_BYTES - 2, &mut stored_crc);
        if u16::from_le_bytes(stored_crc) != crc {
            return None;
        }
        *self = read;
        Some(crc)
    }
}

/// CRC-16/CCITT of `bytes`, continuing from `crc` (start with `0xFFFF`): catches any EEPROM
/// byte worn or half written.
pub(crate) fn crc16(mut crc: u16, bytes: &[u8]) -> u16 {
    for &b in bytes {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
        }
    }
    crc
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Eeprom([u8; 4096]);
    impl crate::Io for Eeprom {
        fn send(&mut self, _: &[u8]) {}
        fn build_settings(&self) -> Settings {
            Settings::DEFAULT
        }
        fn eeprom_read(&mut self, addr: u16, buf: &mut [u8]) {
            buf.copy_from_slice(&self.0[usize::from(addr)..usize::from(addr) + buf.len()]);
        }
        fn eeprom_write(&mut self, addr: u16, data: &[u8]) {
            self.0[usize::from(addr)..usize::from(addr) + data.len()].copy_from_slice(data);
        }
    }

    #[test]
    fn settings_survive_eeprom_and_a_worn_byte_is_noticed() {
        let mut eeprom = Eeprom([0xFF; 4096]);
        let mut s = Settings::DEFAULT;
        assert_eq!(s.load(&mut eeprom), None, "erased EEPROM");
        s.steps_per_mm[3] = 415.5;
        s.hotend_pid.kd = 80.25;
        let crc = s.save(&mut eeprom);
        let mut back = Settings::DEFAULT;
        assert_eq!(back.load(&mut eeprom), Some(crc));
        assert_eq!(back, s);
        eeprom.0[10] ^= 1;
        let mut again = Settings::DEFAULT;
        assert_eq!(again.load(&mut eeprom), None);
        assert_eq!(again, Settings::DEFAULT);
        assert_eq!(EEPROM_BYTES, 82);
    }
}
