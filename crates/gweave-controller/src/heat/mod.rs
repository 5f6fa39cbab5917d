//! The heaters: thermistor readings to temperatures ([`thermistor`]), PID control of the
//! hotends ([`pid`]), the bed switched on and off,
//! and the safety rules ([`safety`]), run every [`PERIOD_MS`].

pub mod pid;
pub mod safety;
pub mod thermistor;

use crate::serial::out::Reply;
use crate::settings::Settings;
use crate::{BED, HEATERS, HOTEND0, HOTEND1};
use pid::PidState;
use safety::{Fault, Guard, Rules};

/// How often the heaters are managed, ms (Marlin's is about 164 ms on AVR). A hotend's
/// temperature moves by well under a degree in that time.
pub const PERIOD_MS: u32 = 100;

/// One heater: its sensor's temperature, its target, its duty, its loop and its guard.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Heater {
    /// The last reading, °C.
    pub temp_c: f32,
    /// The target, °C (0 is off).
    pub target_c: f32,
    /// The duty driven, 0-255.
    pub duty: u8,
    pid: PidState,
    guard: Guard,
}

/// All heaters.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Heat {
    /// In [`crate::HEATERS`] order.
    pub heaters: [Heater; HEATERS],
    last_ms: Option<u32>,
}

impl Heat {
    /// Whether heater `i` is fitted: a thermistor type the core knows (and, for the second
    /// hotend, two hotends).
    pub fn fitted(settings: &Settings, i: usize) -> bool {
        thermistor::table(settings.thermistor[i]).is_some() && (i != HOTEND1 || settings.hotends >= 2)
    }

    fn rules(i: usize) -> &'static Rules {
        if i == BED {
            &safety::BED
        } else {
            &safety::HOTEND
        }
    }

    /// Sets a heater's target (clamped to 15 °C under its maximum, as Marlin's `HOTEND_OVERSHOOT`),
    /// starting its heating watch. An unfitted heater stays off.
    pub fn set_target(&mut self, settings: &Settings, i: usize, target_c: f32, now_ms: u32) {
        if !Heat::fitted(settings, i) {
            return;
        }
        let h = &mut self.heaters[i];
        let target_c = target_c.clamp(0.0, settings.max_temp_c[i] - 15.0);
        if target_c == h.target_c {
            // The same target again (a slicer's `M104` every layer): the heating watch starts
            // over, as Marlin's `start_watching_hotend` does at every `M104`, but the runaway
            // watch goes on: Marlin restarts it only when the target changes.
            h.guard.rewatch(Heat::rules(i), target_c, h.temp_c, now_ms);
        } else {
            h.target_c = target_c;
            h.guard.new_target(Heat::rules(i), target_c, h.temp_c, now_ms);
        }
    }

    /// Reads the sensors; every [`PERIOD_MS`] runs the PID loops and the safety rules. Returns
    /// whether the heaters were managed (time to feed the watchdog), or the heater at fault.
    pub fn manage(
        &mut self,
        settings: &Settings,
        adc: &[u16; HEATERS],
        now_ms: u32,
    ) -> Result<bool, (usize, Fault)> {
        let dt_ms = match self.last_ms {
            Some(last) if now_ms.wrapping_sub(last) < PERIOD_MS => return Ok(false),
            Some(last) => now_ms.wrapping_sub(last).min(10 * PERIOD_MS),
            None => PERIOD_MS,
        };
        self.last_ms = Some(now_ms);
        for (i, (h, &reading)) in self.heaters.iter_mut().zip(adc).enumerate() {
            let Some(table) = thermistor::table(settings.thermistor[i]).filter(|_| Heat::fitted(settings, i))
            else {
                // A heater no rule watches gets no power, whatever it was given before.
                (h.target_c, h.duty) = (0.0, 0);
                continue;
            };
            h.temp_c = thermistor::celsius(table, reading);
            if let Err(fault) =
                h.guard.check(Heat::rules(i), settings.max_temp_c[i], h.target_c, h.temp_c, now_ms)
            {
                return Err((i, fault));
            }
            h.duty = if i == BED {
                // Bang-bang (see `Settings::hotend_pid`).
                if h.temp_c < h.target_c {
                    255
                } else {
                    0
                }
            } else {
                h.pid.update(&settings.hotend_pid, h.target_c, h.temp_c, dt_ms as f32 / 1000.0)
            };
        }
        Ok(true)
    }

    /// Every heater off, every target cleared (a halt).
    pub fn all_off(&mut self) {
        for h in &mut self.heaters {
            h.target_c = 0.0;
            h.duty = 0;
        }
    }

    /// The duties to drive.
    pub fn duties(&self) -> [u8; HEATERS] {
        self.heaters.map(|h| h.duty)
    }

    /// Whether heater `i` is within `band_c` of its target (or has none): the end of a wait.
    pub fn at_target(&self, i: usize, band_c: f32) -> bool {
        let h = &self.heaters[i];
        h.target_c <= 0.0 || (h.temp_c - h.target_c).abs() <= band_c
    }

    /// Marlin's temperature report, ` T:210.00 /210.00 B:60.00 /60.00 @:64 B@:0` (powers
    /// 0-127, a leading space: `M105` prints it after `ok`), with `T0:`/`T1:` and `@0:`/`@1:`
    /// for two hotends.
    pub fn report(&self, settings: &Settings, r: &mut Reply) {
        let pair = |r: &mut Reply, label: &[u8], h: &Heater| {
            r.s(label).f2(h.temp_c).s(b" /").f2(h.target_c);
        };
        let hotends = &self.heaters[HOTEND0..=HOTEND1];
        pair(r, b" T:", &hotends[0]);
        if Heat::fitted(settings, BED) {
            pair(r, b" B:", &self.heaters[BED]);
        }
        let two = Heat::fitted(settings, HOTEND1);
        if two {
            pair(r, b" T0:", &hotends[0]);
            pair(r, b" T1:", &hotends[1]);
        }
        r.s(b" @:").u32(u32::from(hotends[0].duty / 2));
        if Heat::fitted(settings, BED) {
            r.s(b" B@:").u32(u32::from(self.heaters[BED].duty / 2));
        }
        if two {
            r.s(b" @0:").u32(u32::from(hotends[0].duty / 2)).s(b" @1:").u32(u32::from(hotends[1].duty / 2));
        }
    }
}
