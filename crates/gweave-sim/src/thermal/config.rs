//! The `[thermal]` table of the machine profile: every heater's plant, sensor, controller and
//! protection, and the firmware's settle rule for `M109`/`M190` (Marlin's `Configuration.h`
//! temperature settings), with their ranges.

use std::path::PathBuf;

use gweave::range::{self};
use gweave::settings::{CheckRanges, Table};
use gweave::{OutOfRange, Range};
use serde::{Deserialize, Serialize};

use super::control::{ControlConfig, PidConfig, PidGains};
use super::heater::HeaterConfig;
use super::protection::ProtectionConfig;
use super::thermistor::{BetaThermistor, ThermistorTable};

/// Marlin's M109/M190 settle rule: the reading must stay near the target
/// for a residency time (`TEMP_RESIDENCY_TIME 10`, `TEMP_WINDOW 1`,
/// `TEMP_HYSTERESIS 3`, same for the bed).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaitConfig {
    /// Time the reading must stay close to the target, s.
    pub residency_s: f64,
    /// The residency timer starts within this distance of the target, C.
    pub window_c: f64,
    /// Leaving this distance restarts the timer, C.
    pub hysteresis_c: f64,
}

impl Default for WaitConfig {
    fn default() -> Self {
        Self { residency_s: 10.0, window_c: 1.0, hysteresis_c: 3.0 }
    }
}

const RESIDENCY_S: Range = Range::new(0.0, 3_600.0, "s");
const WAIT_BAND_C: Range = Range::new(0.0, 100.0, "°C");

impl CheckRanges for WaitConfig {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.check("residency_s", self.residency_s, RESIDENCY_S)?;
        t.check("window_c", self.window_c, WAIT_BAND_C)?;
        t.check("hysteresis_c", self.hysteresis_c, WAIT_BAND_C)
    }
}

/// Every heater of the machine and the firmware's thermal settings.
/// Unknown keys are rejected; missing keys take the documented defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ThermalConfig {
    /// Hotend plants, `T0`, `T1`, ... (default: one [`HeaterConfig::hotend_40w`]; a key an
    /// entry leaves out is that heater's).
    #[serde(deserialize_with = "crate::thermal::heater::hotends_with_defaults")]
    pub hotends: Vec<HeaterConfig>,
    /// Bed plant (default [`HeaterConfig::bed_200w`], also for the keys a `[thermal.bed]` leaves
    /// out); `None` for no bed.
    #[serde(deserialize_with = "crate::thermal::heater::bed_with_defaults")]
    pub bed: Option<HeaterConfig>,
    /// The sensor on every heater (default Marlin type 1).
    pub thermistor: BetaThermistor,
    /// A CSV file of the firmware's table (see `crate::thermal::thermistor_csv`); default: a table
    /// generated from `thermistor` every `table_step_c`. A relative path is read from the
    /// profile's folder ([`crate::profile::MachineProfile::from_file`]).
    pub thermistor_table: Option<PathBuf>,
    /// That file's table, once read.
    #[serde(skip)]
    pub thermistor_table_entries: Option<ThermistorTable>,
    /// Temperature step of the generated firmware table, C (5).
    pub table_step_c: f64,
    /// Hotend control (default PID with [`PidGains::DEFAULT_HOTEND_40W`]).
    pub hotend_control: ControlConfig,
    /// Bed control (default the seed's bang-bang, as Marlin ships without
    /// `PIDTEMPBED`).
    pub bed_control: ControlConfig,
    /// Thermal protection of the hotends (Marlin's `THERMAL_PROTECTION_HOTENDS` settings).
    pub hotend_protection: ProtectionConfig,
    /// Thermal protection of the bed (`THERMAL_PROTECTION_BED`).
    pub bed_protection: ProtectionConfig,
    /// How `M109` settles.
    pub hotend_wait: WaitConfig,
    /// How `M190` settles.
    pub bed_wait: WaitConfig,
    /// Targets are capped this far below MAXTEMP (Marlin `HOTEND_OVERSHOOT`
    /// 15 C, `BED_OVERSHOOT` 10 C).
    pub hotend_overshoot_c: f64,
    /// The bed's margin below its MAXTEMP, C.
    pub bed_overshoot_c: f64,
    /// Period of the firmware's read-protect-control loop, s (0.1).
    pub sample_period_s: f64,
    /// `EXTRUDE_MINTEMP`, C (170); `None` allows cold extrusion (M302 P1).
    pub extrude_min_c: Option<f64>,
    /// Recording period of the time series, s (1.0).
    pub record_period_s: f64,
    /// Recorded samples kept before the series halves its resolution.
    pub record_max_samples: usize,
}

impl Default for ThermalConfig {
    fn default() -> Self {
        Self {
            hotends: vec![HeaterConfig::hotend_40w()],
            bed: Some(HeaterConfig::bed_200w()),
            thermistor: BetaThermistor::default(),
            thermistor_table: None,
            thermistor_table_entries: None,
            table_step_c: 5.0,
            hotend_control: ControlConfig::Pid(PidConfig::with_gains(PidGains::DEFAULT_HOTEND_40W)),
            bed_control: ControlConfig::BangBang(Default::default()),
            hotend_protection: ProtectionConfig::hotend(),
            bed_protection: ProtectionConfig::bed(),
            hotend_wait: WaitConfig::default(),
            bed_wait: WaitConfig::default(),
            hotend_overshoot_c: 15.0,
            bed_overshoot_c: 10.0,
            sample_period_s: 0.1,
            extrude_min_c: Some(170.0),
            record_period_s: 1.0,
            record_max_samples: 100_000,
        }
    }
}

/// Hotends of one machine (`T0` to `T7`, as Marlin's `HOTENDS` allows).
const HOTENDS: Range = Range::new(1.0, 8.0, "hotends");
/// Step of the generated table: finer than 0.1 °C adds nothing, coarser than 50 °C misreads.
const TABLE_STEP_C: Range = Range::new(0.1, 50.0, "°C");
const OVERSHOOT_C: Range = Range::new(0.0, 100.0, "°C");
/// The firmware's temperature loop; it must advance the clock, and a period longer than a few
/// seconds no longer controls anything.
const SAMPLE_PERIOD_S: Range = Range::new(0.001, 10.0, "s");
const RECORD_PERIOD_S: Range = Range::new(0.001, 86_400.0, "s");
/// Samples kept in memory (about 40 bytes each).
const RECORD_SAMPLES: Range = Range::new(2.0, 1_000_000.0, "samples");

impl CheckRanges for ThermalConfig {
    fn check_ranges(&self, t: &Table) -> Result<(), OutOfRange> {
        t.count("hotends (count)", self.hotends.len() as u64, HOTENDS)?;
        for (i, h) in self.hotends.iter().enumerate() {
            h.check_ranges(&t.sub("hotends").item(i))?;
        }
        if let Some(bed) = &self.bed {
            bed.check_ranges(&t.sub("bed"))?;
        }
        self.thermistor.check_ranges(&t.sub("thermistor"))?;
        t.check("table_step_c", self.table_step_c, TABLE_STEP_C)?;
        self.hotend_control.check_ranges(&t.sub("hotend_control"))?;
        self.bed_control.check_ranges(&t.sub("bed_control"))?;
        self.hotend_protection.check_ranges(&t.sub("hotend_protection"))?;
        self.bed_protection.check_ranges(&t.sub("bed_protection"))?;
        self.hotend_wait.check_ranges(&t.sub("hotend_wait"))?;
        self.bed_wait.check_ranges(&t.sub("bed_wait"))?;
        t.check("hotend_overshoot_c", self.hotend_overshoot_c, OVERSHOOT_C)?;
        t.check("bed_overshoot_c", self.bed_overshoot_c, OVERSHOOT_C)?;
        t.check("sample_period_s", self.sample_period_s, SAMPLE_PERIOD_S)?;
        t.check_opt("extrude_min_c", self.extrude_min_c, range::TEMPERATURE_C)?;
        t.check("record_period_s", self.record_period_s, RECORD_PERIOD_S)?;
        t.count("record_max_samples", self.record_max_samples as u64, RECORD_SAMPLES)
    }
}
