//! The heaters' safety rules: each one, the failure it catches, and Marlin's words for it.
//!
//! A heater cartridge left on without control melts plastic, chars wood and starts fires. These
//! rules, as Marlin's (`Marlin/src/module/temperature.cpp`, the defaults of `Configuration.h`),
//! halt the machine with every heater off when the temperature says the loop is broken:
//!
//! | rule | fires when | catches |
//! |---|---|---|
//! | MAXTEMP | above the heater's maximum (275 °C hotend, 150 °C bed) | a heater stuck on (failed MOSFET, bad gains), a shorted thermistor (reads the table's hottest end) |
//! | MINTEMP | below 5 °C with the heater on | an open or unplugged thermistor (reads 0 °C: the heater would run forever) |
//! | heating watch | after `M104`/`M140` the temperature has not risen 2 °C within 20 s (hotend) or 60 s (bed) | a heater that does not heat: cartridge unplugged, fuse, a thermistor fallen out of the block |
//! | thermal runaway | once the target was reached, it stays more than 4 °C (hotend) or 2 °C (bed) below for 40 s (hotend) or 20 s (bed) | a thermistor that came loose later, a heater that failed while printing, a fan blowing the heat away |
//!
//! Each prints `Error:<what>, system stopped! Heater_ID: <0, 1 or bed>` (`core/language.h`:
//! `STR_T_MAXTEMP` "MAXTEMP triggered", `STR_T_MINTEMP` "MINTEMP triggered",
//! `STR_T_HEATING_FAILED` "Heating failed", `STR_T_THERMAL_RUNAWAY` "Thermal Runaway",
//! `STR_STOPPED_HEATER`), then the machine halts ([`crate::Controller::kill`]).

/// A fault of one heater.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Above the maximum temperature.
    MaxTemp,
    /// Below the minimum temperature while heating.
    MinTemp,
    /// Did not heat by the watch's increase within its period.
    HeatingFailed,
    /// Fell and stayed below the reached target.
    ThermalRunaway,
}

impl Fault {
    /// Marlin's text for the fault.
    pub fn text(self) -> &'static [u8] {
        match self {
            Fault::MaxTemp => b"MAXTEMP triggered",
            Fault::MinTemp => b"MINTEMP triggered",
            Fault::HeatingFailed => b"Heating failed",
            Fault::ThermalRunaway => b"Thermal Runaway",
        }
    }
}

/// The rules' numbers for one kind of heater.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rules {
    /// MINTEMP, °C (Marlin `HEATER_0_MINTEMP`, `BED_MINTEMP`: 5).
    pub min_c: f32,
    /// Thermal runaway: how long (ms) the temperature may stay more than `runaway_c` below the
    /// reached target (`THERMAL_PROTECTION_PERIOD` 40 s, `THERMAL_PROTECTION_BED_PERIOD` 20 s).
    pub runaway_ms: u32,
    /// Thermal runaway hysteresis, °C (`THERMAL_PROTECTION_HYSTERESIS` 4, bed 2).
    pub runaway_c: f32,
    /// Heating watch period, ms (`WATCH_TEMP_PERIOD` 20 s, `WATCH_BED_TEMP_PERIOD` 60 s).
    pub watch_ms: u32,
    /// Heating watch increase, °C (`WATCH_TEMP_INCREASE`, `WATCH_BED_TEMP_INCREASE`: 2).
    pub watch_c: f32,
}

/// Hotends' rules.
pub const HOTEND: Rules =
    Rules { min_c: 5.0, runaway_ms: 40_000, runaway_c: 4.0, watch_ms: 20_000, watch_c: 2.0 };
/// The bed's rules.
pub const BED: Rules =
    Rules { min_c: 5.0, runaway_ms: 20_000, runaway_c: 2.0, watch_ms: 60_000, watch_c: 2.0 };

/// Marlin's `TEMP_HYSTERESIS` (3 °C): a target this close (plus the watch's increase and one
/// degree) to the temperature is not watched, since it may never rise by the increase.
const WATCH_MARGIN_C: f32 = 3.0 + 1.0;

/// The watch and runaway state of one heater.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Guard {
    /// Heating watch: the temperature to reach and by when (ms).
    watch: Option<(f32, u32)>,
    /// Runaway: `None` before the target is first reached; then the time (ms) by which the
    /// temperature must be back within the hysteresis.
    runaway_deadline_ms: Option<u32>,
}

impl Guard {
    /// A new target was set (`M104`, `M109`, `M140`, `M190`): start the heating watch if the
    /// heater has far to go, and wait for the target before watching for runaway.
    pub fn new_target(&mut self, rules: &Rules, target_c: f32, temp_c: f32, now_ms: u32) {
        self.runaway_deadline_ms = None;
        self.watch = (target_c > 0.0 && temp_c < target_c - (rules.watch_c + WATCH_MARGIN_C))
            .then(|| (temp_c + rules.watch_c, now_ms.wrapping_add(rules.watch_ms)));
    }

    /// Checks one reading against the rules.
    pub fn check(
        &mut self,
        rules: &Rules,
        max_c: f32,
        target_c: f32,
        temp_c: f32,
        now_ms: u32,
    ) -> Result<(), Fault> {
        if temp_c > max_c {
            return Err(Fault::MaxTemp);
        }
        if target_c <= 0.0 {
            *self = Guard::default();
            return Ok(());
        }
        if temp_c < rules.min_c {
            return Err(Fault::MinTemp);
        }
        if let Some((watch_c, deadline)) = self.watch {
            if passed(now_ms, deadline) {
                if temp_c < watch_c {
                    return Err(Fault::HeatingFailed);
                }
                // It rose as it should: watch the next period from here, as Marlin does.
                self.rewatch(rules, target_c, temp_c, now_ms);
            }
        }
        match self.runaway_deadline_ms {
            None if temp_c >= target_c => {
                self.runaway_deadline_ms = Some(now_ms.wrapping_add(rules.runaway_ms))
            }
            None => {}
            Some(_) if temp_c >= target_c - rules.runaway_c => {
                self.runaway_deadline_ms = Some(now_ms.wrapping_add(rules.runaway_ms));
            }
            Some(deadline) if passed(now_ms, deadline) => return Err(Fault::ThermalRunaway),
            Some(_) => {}
        }
        Ok(())
    }

    /// The heating watch starts over from `temp_c`; the runaway watch goes on.
    pub fn rewatch(&mut self, rules: &Rules, target_c: f32, temp_c: f32, now_ms: u32) {
        let runaway = self.runaway_deadline_ms;
        self.new_target(rules, target_c, temp_c, now_ms);
        self.runaway_deadline_ms = runaway;
    }
}

/// Whether `now_ms` is past `deadline_ms` on a wrapping millisecond clock.
fn passed(now_ms: u32, deadline_ms: u32) -> bool {
    (now_ms.wrapping_sub(deadline_ms) as i32) > 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_heater_that_does_not_heat_fails_the_watch_after_20_s() {
        let mut g = Guard::default();
        g.new_target(&HOTEND, 210.0, 25.0, 0);
        assert_eq!(g.check(&HOTEND, 275.0, 210.0, 26.9, 20_000), Ok(()));
        assert_eq!(g.check(&HOTEND, 275.0, 210.0, 26.9, 20_001), Err(Fault::HeatingFailed));
    }

    #[test]
    fn a_heater_that_heats_passes_the_watch_and_is_watched_again() {
        let mut g = Guard::default();
        g.new_target(&BED, 60.0, 25.0, 0);
        assert_eq!(g.check(&BED, 150.0, 60.0, 27.5, 60_001), Ok(()));
        assert_eq!(g.check(&BED, 150.0, 60.0, 28.0, 120_002), Err(Fault::HeatingFailed));
    }

    #[test]
    fn runaway_fires_40_s_after_the_temperature_left_the_reached_target() {
        let mut g = Guard::default();
        g.new_target(&HOTEND, 210.0, 209.0, 0);
        assert_eq!(g.check(&HOTEND, 275.0, 210.0, 210.0, 1_000), Ok(()));
        assert_eq!(g.check(&HOTEND, 275.0, 210.0, 206.5, 30_000), Ok(())); // within 4 °C
        assert_eq!(g.check(&HOTEND, 275.0, 210.0, 205.0, 40_000), Ok(()));
        assert_eq!(g.check(&HOTEND, 275.0, 210.0, 150.0, 70_000), Ok(()));
        assert_eq!(g.check(&HOTEND, 275.0, 210.0, 150.0, 70_001), Err(Fault::ThermalRunaway));
    }

    #[test]
    fn min_and_max_temp() {
        let mut g = Guard::default();
        assert_eq!(g.check(&HOTEND, 275.0, 0.0, 0.0, 0), Ok(()), "an open sensor with the heater off");
        assert_eq!(g.check(&HOTEND, 275.0, 200.0, 0.0, 0), Err(Fault::MinTemp));
        assert_eq!(g.check(&HOTEND, 275.0, 0.0, 276.0, 0), Err(Fault::MaxTemp));
        assert_eq!(g.check(&BED, 150.0, 0.0, 151.0, 0), Err(Fault::MaxTemp));
    }
}
