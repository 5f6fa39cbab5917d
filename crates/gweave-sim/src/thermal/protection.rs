//! Protection: Marlin's thermal safety checks for one heater, on the
//! simulated clock.
//!
//! Four checks, each a typed [`ThermalFault`] with Marlin's exact `Error:`
//! line, followed by [`KILL_LINE`] when the printer halts:
//!
//! * **MAXTEMP / MINTEMP**: the reading is above `max_temp_c` or below
//!   `min_temp_c` (Marlin `HEATER_0_MAXTEMP 275`, `BED_MAXTEMP 150`,
//!   `*_MINTEMP 5`). A shorted thermistor reads hot and trips MAXTEMP; an
//!   open one reads cold and trips MINTEMP. We check MINTEMP whether or not
//!   the heater has a target (our reading of Marlin's behaviour at boot with
//!   a disconnected sensor).
//! * **Heating watch** (`WATCH_TEMP_PERIOD`/`INCREASE`, bed
//!   `WATCH_BED_TEMP_*`): when a target is set well above the current
//!   reading, the reading must rise by `increase` within `period`; if it
//!   did, the watch re-arms from the new reading, otherwise "Heating
//!   failed". Catches a heater that never heats. As in Marlin 2.x
//!   (`HeaterWatch::restart` in `Marlin/src/module/temperature.h`) the
//!   watch works in whole degrees (the float reading is truncated into a
//!   `celsius_t`) and arms only when `reading + increase` is below
//!   `target - TEMP_HYSTERESIS - 1`; `TEMP_HYSTERESIS` (3 C, bed
//!   `TEMP_BED_HYSTERESIS` 3 C) is the M109/M190 settle band, not the
//!   runaway hysteresis. A target more than `increase + 4` C above the
//!   reading arms it; a closer one is left to the runaway check.
//! * **Thermal runaway** (`THERMAL_PROTECTION_PERIOD`/`HYSTERESIS`): once
//!   the reading has first reached the target, it may drop more than
//!   `hysteresis` below the target for at most `period`; longer is a
//!   runaway. Catches a heater (or sensor) lost after reaching temperature.
//!
//! Defaults (Marlin's `Configuration.h`: `THERMAL_PROTECTION_*`, `WATCH_*`): hotend runaway 40 s / 4 C and watch
//! 20 s / +2 C; bed runaway 20 s / 2 C and watch 60 s / +2 C.

use gweave::range::{self};
use gweave::settings::{CheckRanges, Table};
use gweave::{OutOfRange, Range};
use serde::{Deserialize, Serialize};

use crate::thermal::heater::HeaterId;

/// The line Marlin prints after any thermal error, when it halts.
pub const KILL_LINE: &str = "Error:Printer halted. kill() called!";

/// Limits and periods of one heater's protection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProtectionConfig {
    /// `THERMAL_PROTECTION_PERIOD`, s.
    pub runaway_period_s: f64,
    /// `THERMAL_PROTECTION_HYSTERESIS`, C.
    pub runaway_hysteresis_c: f64,
    /// `WATCH_TEMP_PERIOD`, s.
    pub watch_period_s: f64,
    /// `WATCH_TEMP_INCREASE`, C.
    pub watch_increase_c: f64,
    /// MINTEMP, C.
    pub min_temp_c: f64,
    /// MAXTEMP, C.
    pub max_temp_c: f64,
}

/// A protection period (Marlin ships 20 to 60 s; 0 disables the check).
const PROTECT_PERIOD_S: Range = Range::new(0.0, 3_600.0, "s");
/// A protection band in kelvin.
const PROTECT_BAND_C: Range = Range::new(0.0, 100.0, "°C");
/// MINTEMP may sit below 0 °C for a printer in the cold.
const MIN_TEMP_C: Range = Range::new(-50.0, 500.0, "°C");

impl CheckRanges for ProtectionConfig {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("runaway_period_s", self.runaway_period_s, PROTECT_PERIOD_S)?;
        t.check("runaway_hysteresis_c", self.runaway_hysteresis_c, PROTECT_BAND_C)?;
        t.check("watch_period_s", self.watch_period_s, PROTECT_PERIOD_S)?;
        t.check("watch_increase_c", self.watch_increase_c, PROTECT_BAND_C)?;
        t.check("min_temp_c", self.min_temp_c, MIN_TEMP_C)?;
        t.check("max_temp_c", self.max_temp_c, range::TEMPERATURE_C)
    }
}

impl ProtectionConfig {
    /// Marlin's hotend defaults: runaway 40 s / 4 C, watch 20 s / +2 C,
    /// MINTEMP 5 C, MAXTEMP 275 C.
    pub fn hotend() -> Self {
        Self {
            runaway_period_s: 40.0,
            runaway_hysteresis_c: 4.0,
            watch_period_s: 20.0,
            watch_increase_c: 2.0,
            min_temp_c: 5.0,
            max_temp_c: 275.0,
        }
    }

    /// Marlin's bed defaults: runaway 20 s / 2 C, watch 60 s / +2 C,
    /// MINTEMP 5 C, MAXTEMP 150 C.
    pub fn bed() -> Self {
        Self {
            runaway_period_s: 20.0,
            runaway_hysteresis_c: 2.0,
            watch_period_s: 60.0,
            watch_increase_c: 2.0,
            min_temp_c: 5.0,
            max_temp_c: 150.0,
        }
    }
}

/// Which check tripped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// The reading fell away from a target it had held.
    ThermalRunaway,
    /// The reading did not rise enough while heating.
    HeatingFailed,
    /// The reading is below the minimum (a sensor off or shorted open).
    MinTemp,
    /// The reading is above the maximum.
    MaxTemp,
}

impl FaultKind {
    /// Marlin's wording before `, system stopped!`.
    fn marlin_text(self) -> &'static str {
        match self {
            FaultKind::ThermalRunaway => "Thermal Runaway",
            FaultKind::HeatingFailed => "Heating failed",
            FaultKind::MinTemp => "MINTEMP triggered",
            FaultKind::MaxTemp => "MAXTEMP triggered",
        }
    }
}

/// A thermal fault: what, which heater, when.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThermalFault {
    /// Which check tripped.
    pub kind: FaultKind,
    /// On which heater.
    pub heater: HeaterId,
    /// Simulated time of detection, s.
    pub at_s: f64,
}

impl ThermalFault {
    /// The exact Marlin error line, e.g.
    /// `Error:Thermal Runaway, system stopped! Heater_ID: 0` or
    /// `Error:Heating failed, system stopped! Heater_ID: bed`.
    pub fn error_line(&self) -> String {
        format!("Error:{}, system stopped! Heater_ID: {}", self.kind.marlin_text(), self.heater)
    }

    /// The error line followed by [`KILL_LINE`], as Marlin prints them.
    pub fn lines(&self) -> [String; 2] {
        [self.error_line(), KILL_LINE.to_owned()]
    }
}

/// Where the runaway check is (Marlin's `TRState`).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Runaway {
    /// No target.
    Inactive,
    /// Target set, not yet reached; the watch covers this phase.
    FirstHeating,
    /// Target reached; a drop below `target - hysteresis` must recover by
    /// `deadline_s`.
    Stable { deadline_s: f64 },
}

/// An armed heating watch, in Marlin's whole degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Watch {
    must_reach_c: i32,
    deadline_s: f64,
}

/// A temperature as Marlin's `celsius_t` holds it: the float truncated
/// toward zero into an integer.
fn whole_degrees(celsius: f64) -> i32 {
    celsius.trunc().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i32
}

/// The protection state of one heater.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Protection {
    heater: HeaterId,
    cfg: ProtectionConfig,
    /// `TEMP_HYSTERESIS`: the watch arms only this far (plus 1 C) beyond
    /// the increase.
    watch_hysteresis_c: f64,
    runaway: Runaway,
    runaway_target_c: f64,
    watch: Option<Watch>,
}

impl Protection {
    /// The checks of `heater`; `watch_hysteresis_c` is Marlin's
    /// `TEMP_HYSTERESIS` (the M109/M190 settle band, 3 C by default).
    pub(crate) fn new(heater: HeaterId, cfg: ProtectionConfig, watch_hysteresis_c: f64) -> Self {
        Self {
            heater,
            cfg,
            watch_hysteresis_c,
            runaway: Runaway::Inactive,
            runaway_target_c: 0.0,
            watch: None,
        }
    }

    /// Arm (or disarm) the heating watch after a new target was set
    /// (M104/M109/M140/M190): in whole degrees, armed only when
    /// `reading + increase < target - TEMP_HYSTERESIS - 1`.
    pub(crate) fn start_watching(&mut self, now_s: f64, temp_c: f64, target_c: f64) {
        let target = whole_degrees(target_c);
        let must_reach_c = whole_degrees(temp_c) + whole_degrees(self.cfg.watch_increase_c);
        let margin = whole_degrees(self.watch_hysteresis_c) + 1;
        self.watch = (target != 0 && must_reach_c < target - margin)
            .then_some(Watch { must_reach_c, deadline_s: now_s + self.cfg.watch_period_s });
    }

    /// Whether no check is armed (no heating watch, no runaway state: no target): a reading is
    /// then held to MINTEMP and MAXTEMP alone, and one that does not change neither faults
    /// anew nor changes this state.
    pub(crate) fn idle(&self) -> bool {
        self.watch.is_none() && matches!(self.runaway, Runaway::Inactive)
    }

    /// Run every check on a reading at `now_s`; the first fault found.
    pub(crate) fn check(&mut self, now_s: f64, temp_c: f64, target_c: f64) -> Option<ThermalFault> {
        let heater = self.heater;
        let fault = |kind| Some(ThermalFault { kind, heater, at_s: now_s });
        if temp_c > self.cfg.max_temp_c {
            return fault(FaultKind::MaxTemp);
        }
        if temp_c < self.cfg.min_temp_c {
            return fault(FaultKind::MinTemp);
        }
        if let Some(w) = self.watch {
            if now_s >= w.deadline_s {
                if whole_degrees(temp_c) < w.must_reach_c {
                    return fault(FaultKind::HeatingFailed);
                }
                self.start_watching(now_s, temp_c, target_c);
            }
        }
        self.check_runaway(now_s, temp_c, target_c).and_then(|()| fault(FaultKind::ThermalRunaway))
    }

    /// Marlin's runaway state machine; `Some(())` on a runaway.
    fn check_runaway(&mut self, now_s: f64, temp_c: f64, target_c: f64) -> Option<()> {
        if target_c != self.runaway_target_c {
            self.runaway_target_c = target_c;
            self.runaway = if target_c > 0.0 { Runaway::FirstHeating } else { Runaway::Inactive };
        }
        let floor_c = target_c - self.cfg.runaway_hysteresis_c;
        match self.runaway {
            Runaway::Inactive => None,
            Runaway::FirstHeating if temp_c < target_c => None,
            Runaway::FirstHeating => {
                self.runaway = Runaway::Stable { deadline_s: now_s + self.cfg.runaway_period_s };
                None
            }
            Runaway::Stable { .. } if temp_c >= floor_c => {
                self.runaway = Runaway::Stable { deadline_s: now_s + self.cfg.runaway_period_s };
                None
            }
            Runaway::Stable { deadline_s } if now_s < deadline_s => None,
            Runaway::Stable { .. } => Some(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hotend() -> Protection {
        Protection::new(HeaterId::Hotend(0), ProtectionConfig::hotend(), 3.0)
    }

    #[test]
    fn error_lines_match_marlin() {
        let f = |kind, heater| ThermalFault { kind, heater, at_s: 0.0 };
        assert_eq!(
            f(FaultKind::ThermalRunaway, HeaterId::Hotend(0)).error_line(),
            "Error:Thermal Runaway, system stopped! Heater_ID: 0"
        );
        assert_eq!(
            f(FaultKind::ThermalRunaway, HeaterId::Bed).error_line(),
            "Error:Thermal Runaway, system stopped! Heater_ID: bed"
        );
        assert_eq!(
            f(FaultKind::HeatingFailed, HeaterId::Hotend(1)).error_line(),
            "Error:Heating failed, system stopped! Heater_ID: 1"
        );
        assert_eq!(
            f(FaultKind::MinTemp, HeaterId::Hotend(0)).error_line(),
            "Error:MINTEMP triggered, system stopped! Heater_ID: 0"
        );
        assert_eq!(
            f(FaultKind::MaxTemp, HeaterId::Bed).lines(),
            [
                "Error:MAXTEMP triggered, system stopped! Heater_ID: bed".to_owned(),
                "Error:Printer halted. kill() called!".to_owned()
            ]
        );
    }

    #[test]
    fn min_and_max_temp() {
        let mut p = hotend();
        assert_eq!(p.check(0.0, 25.0, 0.0), None);
        assert_eq!(p.check(1.0, 276.0, 0.0).map(|f| f.kind), Some(FaultKind::MaxTemp));
        assert_eq!(p.check(2.0, -20.0, 0.0).map(|f| f.kind), Some(FaultKind::MinTemp));
        assert_eq!(p.check(3.0, 275.0, 0.0), None);
        assert_eq!(p.check(3.0, 5.0, 0.0), None);
    }

    #[test]
    fn watch_fails_without_rise_and_rearms_with_it() {
        let mut p = hotend();
        p.start_watching(0.0, 25.0, 210.0);
        // Must reach 27 C by 20 s.
        assert_eq!(p.check(19.9, 25.0, 210.0), None);
        // Whole degrees: 26.9 C counts as 26.
        let f = p.check(20.0, 26.9, 210.0).unwrap();
        assert_eq!((f.kind, f.at_s), (FaultKind::HeatingFailed, 20.0));

        let mut p = hotend();
        p.start_watching(0.0, 25.0, 210.0);
        assert_eq!(p.check(20.0, 27.0, 210.0), None);
        // Re-armed from 27 C: 29 C by 40 s.
        assert_eq!(p.check(40.0, 28.0, 210.0).map(|f| f.kind), Some(FaultKind::HeatingFailed));
    }

    #[test]
    fn watch_not_armed_close_to_target() {
        let mut p = hotend();
        // 204 + 2 = 206 is not below 210 - 3 - 1 = 206: no watch.
        p.start_watching(0.0, 204.0, 210.0);
        assert_eq!(p.check(100.0, 204.0, 210.0), None);
        // 203.9 C is 203 in whole degrees: 205 < 206 arms it, and 204.99
        // (204) by the deadline is not 205.
        p.start_watching(0.0, 203.9, 210.0);
        assert_eq!(p.check(20.0, 204.99, 210.0).map(|f| f.kind), Some(FaultKind::HeatingFailed));
        // Target 0 disarms.
        p.start_watching(0.0, 25.0, 0.0);
        assert_eq!(p.check(100.0, 25.0, 0.0), None);
    }

    #[test]
    fn runaway_after_period_below_hysteresis() {
        let mut p = hotend();
        // Heating: far below target never trips runaway (the watch's job).
        assert_eq!(p.check(0.0, 25.0, 210.0), None);
        assert_eq!(p.check(500.0, 100.0, 210.0), None);
        // Reached: stable from 600 s.
        assert_eq!(p.check(600.0, 210.0, 210.0), None);
        // 206 C is within 4 C: the timer keeps restarting.
        assert_eq!(p.check(700.0, 206.0, 210.0), None);
        // Below 206 from 701 s: trips once 40 s have passed since 700 s.
        assert_eq!(p.check(701.0, 205.0, 210.0), None);
        assert_eq!(p.check(739.9, 150.0, 210.0), None);
        let f = p.check(740.0, 150.0, 210.0).unwrap();
        assert_eq!((f.kind, f.at_s), (FaultKind::ThermalRunaway, 740.0));
    }

    #[test]
    fn new_target_restarts_runaway_tracking() {
        let mut p = Protection::new(HeaterId::Bed, ProtectionConfig::bed(), 3.0);
        assert_eq!(p.check(0.0, 60.0, 60.0), None);
        // Raising the target goes back to first heating: no runaway while
        // climbing towards 100 C.
        assert_eq!(p.check(1.0, 60.0, 100.0), None);
        assert_eq!(p.check(100.0, 80.0, 100.0), None);
        // Target 0: inactive.
        assert_eq!(p.check(200.0, 30.0, 0.0), None);
    }
}
