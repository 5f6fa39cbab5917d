//! Thermal: the facade over every heater of the virtual printer (hotends by
//! index and an optional bed) on the simulated clock.
//!
//! Each heater is a [`Heater`] plant read through the thermistor model and
//! the firmware table, a [`Control`] algorithm, and its [`Protection`].
//! [`Thermal::step`] advances all of them by `dt_s`, sampling (reading,
//! protecting, controlling) every `sample_period_s` like the firmware's
//! temperature loop; the plant integrates exactly in between.
//!
//! On a fault every heater is switched off and the facade stays halted;
//! the fault carries Marlin's `Error:` lines.
//!
//! The subsystem is Marlin's `module/temperature.cpp` taken apart: the [`heater`] plant (a lumped
//! chain of thermal masses), the [`thermistor`] (NTC beta model and the firmware's ADC table, or a
//! table from a CSV file, [`thermistor_csv`]), the [`control`] algorithms (PID, bang-bang),
//! [`protection`] (thermal runaway, heating failed, MINTEMP/MAXTEMP) and [`autotune`] (`M303`);
//! the `[thermal]` table of the profile is [`ThermalConfig`].
//!
//! ```
//! use gweave_sim::HeaterId;
//! use gweave_sim::{Thermal, ThermalConfig, WaitMode, WaitStatus};
//!
//! let mut th = Thermal::new(ThermalConfig::default()).unwrap();
//! th.set_target(HeaterId::Hotend(0), 210.0).unwrap();
//! let mut wait = th.begin_wait(HeaterId::Hotend(0), WaitMode::HeatOnly).unwrap();
//! while th.poll_wait(&mut wait) == WaitStatus::Waiting {
//!     assert!(th.step(1.0).is_none());
//! }
//! assert!(th.m105_report().starts_with("T:2"));
//! ```

pub(crate) mod autotune;
mod config;
pub(crate) mod control;
pub(crate) mod heater;
pub(crate) mod protection;
mod rest;
mod series;
pub(crate) mod thermistor;
pub(crate) mod thermistor_csv;

pub use config::ThermalConfig;
pub(crate) use config::WaitConfig;
pub(crate) use series::{Sample, TimeSeries};

use std::path::PathBuf;

use gweave::settings::{CheckRanges, Table};
use gweave::OutOfRange;
use thiserror::Error;

use crate::thermal::autotune::{Autotune, AutotuneConfig, AutotuneError, AutotuneFailure, AutotuneStatus};
use crate::thermal::control::{Control, ControlError, PidGains};
use crate::thermal::heater::{Heater, HeaterError, HeaterId};
use crate::thermal::protection::{Protection, ThermalFault};
use crate::thermal::thermistor::{BetaThermistor, ThermistorError, ThermistorTable};

/// Marlin's reply to an extrusion below the minimum temperature.
pub const COLD_EXTRUSION_LINE: &str = "echo: cold extrusion prevented";

/// Errors of the thermal facade.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ThermalError {
    /// A heater's plant is invalid.
    #[error(transparent)]
    Heater(#[from] HeaterError),
    /// A control algorithm's settings are invalid.
    #[error(transparent)]
    Control(#[from] ControlError),
    /// The thermistor model or its table is invalid.
    #[error(transparent)]
    Thermistor(#[from] ThermistorError),
    /// An autotune could not start or failed.
    #[error(transparent)]
    Autotune(#[from] AutotuneError),
    /// The machine has no such heater.
    #[error("no heater {0:?} on this machine")]
    UnknownHeater(HeaterId),
    /// PID gains asked of a heater that is not PID-controlled.
    #[error("heater {0:?} is not PID-controlled")]
    NotPid(HeaterId),
    /// The heaters are halted by a fault until `M999`.
    #[error("printer halted: {}", .0.error_line())]
    Halted(ThermalFault),
    /// A value (a target) outside its range.
    #[error(transparent)]
    Range(#[from] OutOfRange),
    /// The profile names a thermistor table file that was never read.
    #[error("thermistor_table {} was named but not read (load the profile with MachineProfile::from_file)", .0.display())]
    TableNotRead(PathBuf),
}

/// Firmware loops one [`Thermal::step`] runs before it integrates the rest of the step in one
/// go: 1 000 000 samples, 28 h of simulated time at the default 0.1 s period.
pub(crate) const MAX_SAMPLES_PER_STEP: u32 = 1_000_000;

/// A time on Marlin's `millis()` clock. The residency of a wait is counted in whole milliseconds
/// as the firmware does, so a simulated clock made of many 0.1 s steps (which drifts by parts
/// in 1e13) ends a wait on the step where the firmware would.
fn millis(t_s: f64) -> i64 {
    (t_s * 1000.0).round() as i64
}

/// Span of the generated firmware table, C.
const TABLE_MIN_C: f64 = -20.0;
const TABLE_MAX_C: f64 = 400.0;

/// One heater with its controller and protection.
#[derive(Debug)]
struct Channel {
    id: HeaterId,
    plant: Heater,
    control: Box<dyn Control>,
    protection: Protection,
    wait: WaitConfig,
    max_target_c: f64,
    target_c: f64,
    reading_c: f64,
    /// The firmware table's bracket of the last reading (see [`ThermistorTable::celsius_near`]).
    bracket: usize,
    power: u8,
}

/// How M109/M190 wait: `S` waits only while heating, `R` both ways.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WaitMode {
    /// `S`: wait only while heating (a hotter reading ends the wait at once).
    HeatOnly,
    /// `R`: wait for the target whether heating or cooling.
    Both,
}

/// Result of polling a wait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WaitStatus {
    /// Not yet settled.
    Waiting,
    /// Settled: the residency time passed within the window.
    Reached,
    /// The printer halted on a thermal fault.
    Halted,
}

/// An M109/M190 wait in progress (see [`Thermal::begin_wait`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TempWait {
    heater: HeaterId,
    mode: WaitMode,
    first_poll: bool,
    residency_start_s: Option<f64>,
}

/// An extrusion was refused because the hotend is too cold.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[error("cold extrusion prevented: T{hotend} at {temp_c:.2} C, minimum {min_c:.2} C")]
pub struct ColdExtrusion {
    pub hotend: u8,
    pub temp_c: f64,
    pub min_c: f64,
}

/// The heaters of a machine on the simulated clock.
#[derive(Debug)]
pub struct Thermal {
    thermistor: BetaThermistor,
    table: ThermistorTable,
    sample_period_s: f64,
    extrude_min_c: Option<f64>,
    channels: Vec<Channel>,
    hotends: u8,
    active: u8,
    now_s: f64,
    /// The plants are integrated up to here; between firmware samples nothing changes their
    /// inputs, so they are advanced only when a sample (or a change of input) needs them.
    plant_s: f64,
    samples_taken: u64,
    /// Firmware loops run in full; the others were passed over at rest (`rest`).
    loops_run: u64,
    halted: Option<ThermalFault>,
    autotune: Option<(HeaterId, Autotune, bool)>,
    autotune_lines: Vec<String>,
    autotune_result: Option<Result<PidGains, AutotuneFailure>>,
    series: TimeSeries,
}

impl Thermal {
    /// Build every heater from `cfg`, validating all of it.
    pub fn new(cfg: ThermalConfig) -> Result<Self, ThermalError> {
        // The same check as the machine profile's, so a config built in code is held to it too.
        cfg.check_ranges(&Table::root().sub("thermal"))?;
        let table = match (&cfg.thermistor_table_entries, &cfg.thermistor_table) {
            (Some(table), _) => table.clone(),
            (None, Some(path)) => return Err(ThermalError::TableNotRead(path.clone())),
            (None, None) => cfg.thermistor.table(TABLE_MIN_C, TABLE_MAX_C, cfg.table_step_c)?,
        };
        let mut channels = Vec::new();
        let plants = cfg
            .hotends
            .iter()
            .enumerate()
            .map(|(i, h)| (HeaterId::Hotend(i as u8), h))
            .chain(cfg.bed.iter().map(|b| (HeaterId::Bed, b)));
        for (id, plant_cfg) in plants {
            let (control, protection, wait, overshoot) = match id {
                HeaterId::Bed => (&cfg.bed_control, cfg.bed_protection, cfg.bed_wait, cfg.bed_overshoot_c),
                HeaterId::Hotend(_) => {
                    (&cfg.hotend_control, cfg.hotend_protection, cfg.hotend_wait, cfg.hotend_overshoot_c)
                }
            };
            let plant = Heater::new(*plant_cfg)?;
            let reading_c = table.celsius(plant.read_adc(&cfg.thermistor));
            channels.push(Channel {
                id,
                plant,
                control: control.build()?,
                protection: Protection::new(id, protection, wait.hysteresis_c),
                wait,
                max_target_c: protection.max_temp_c - overshoot,
                target_c: 0.0,
                reading_c,
                bracket: 0,
                power: 0,
            });
        }
        Ok(Self {
            thermistor: cfg.thermistor,
            table,
            sample_period_s: cfg.sample_period_s,
            extrude_min_c: cfg.extrude_min_c,
            hotends: cfg.hotends.len() as u8,
            channels,
            active: 0,
            now_s: 0.0,
            plant_s: 0.0,
            samples_taken: 0,
            loops_run: 0,
            halted: None,
            autotune: None,
            autotune_lines: Vec::new(),
            autotune_result: None,
            series: TimeSeries::new(cfg.record_period_s, cfg.record_max_samples),
        })
    }

    fn channel(&self, id: HeaterId) -> Result<&Channel, ThermalError> {
        self.channels.iter().find(|c| c.id == id).ok_or(ThermalError::UnknownHeater(id))
    }

    fn channel_mut(&mut self, id: HeaterId) -> Result<&mut Channel, ThermalError> {
        self.channels.iter_mut().find(|c| c.id == id).ok_or(ThermalError::UnknownHeater(id))
    }

    /// Simulated time, s.
    pub fn now_s(&self) -> f64 {
        self.now_s
    }

    /// Number of hotends.
    pub fn hotend_count(&self) -> u8 {
        self.hotends
    }

    /// The fault that halted the printer, if any.
    pub fn halted(&self) -> Option<&ThermalFault> {
        self.halted.as_ref()
    }

    /// M999: leave the halted state. Targets stay at 0 and injected plant faults stay; the
    /// protection checks run again from the next sample.
    pub fn clear_halt(&mut self) {
        self.halted = None;
    }

    /// Set a target (M104/M109/M140/M190), capped at MAXTEMP minus the
    /// overshoot margin; negative means 0. Arms the heating watch.
    pub fn set_target(&mut self, id: HeaterId, celsius: f64) -> Result<(), ThermalError> {
        if let Some(fault) = self.halted {
            return Err(ThermalError::Halted(fault));
        }
        let now_s = self.now_s;
        let ch = self.channel_mut(id)?;
        let target = if celsius.is_nan() { 0.0 } else { celsius }.clamp(0.0, ch.max_target_c);
        ch.target_c = target;
        ch.protection.start_watching(now_s, ch.reading_c, target);
        Ok(())
    }

    /// Every heater off at once, as Marlin's `disable_all_heaters` (`kill()`, `M81`): the
    /// targets 0 and the outputs low now, not at the next sample (an `M105` just after an
    /// `M112` said `@:127`).
    pub fn all_off(&mut self) {
        self.settle_plants();
        // An autotune running gave its power back at the next sample.
        self.autotune = None;
        let now_s = self.now_s;
        for ch in &mut self.channels {
            ch.target_c = 0.0;
            ch.power = 0;
            ch.control.reset();
            ch.protection.start_watching(now_s, ch.reading_c, 0.0);
        }
    }

    /// The current target, C.
    pub fn target(&self, id: HeaterId) -> Result<f64, ThermalError> {
        Ok(self.channel(id)?.target_c)
    }

    /// The firmware's reading (sensor through the table), C.
    pub fn temperature(&self, id: HeaterId) -> Result<f64, ThermalError> {
        Ok(self.channel(id)?.reading_c)
    }

    /// The `@:` power, 0..=127.
    pub fn power(&self, id: HeaterId) -> Result<u8, ThermalError> {
        Ok(self.channel(id)?.power)
    }

    /// The plant, for inspection, as of the last firmware sample or change of its inputs (the
    /// plants are integrated lazily, see [`Thermal::step`]).
    pub fn heater(&self, id: HeaterId) -> Result<&Heater, ThermalError> {
        Ok(&self.channel(id)?.plant)
    }

    /// The plant, for fault injection.
    pub fn heater_mut(&mut self, id: HeaterId) -> Result<&mut Heater, ThermalError> {
        self.settle_plants();
        Ok(&mut self.channel_mut(id)?.plant)
    }

    /// Select the active extruder (reported as `T:` and `@:`).
    pub fn set_active_extruder(&mut self, hotend: u8) -> Result<(), ThermalError> {
        self.channel(HeaterId::Hotend(hotend))?;
        self.active = hotend;
        Ok(())
    }

    /// Part-cooling fan fraction (0..=1), cooling every hotend.
    pub fn set_fan(&mut self, fraction: f64) {
        self.settle_plants();
        for ch in &mut self.channels {
            if let HeaterId::Hotend(_) = ch.id {
                ch.plant.set_fan(fraction);
            }
        }
    }

    /// Tell controllers whether the machine moves (bang-bang runs faster).
    pub fn set_moving(&mut self, moving: bool) {
        for ch in &mut self.channels {
            ch.control.set_moving(moving);
        }
    }

    /// M301/M304 query.
    pub fn pid_gains(&self, id: HeaterId) -> Result<PidGains, ThermalError> {
        self.channel(id)?.control.pid_gains().ok_or(ThermalError::NotPid(id))
    }

    /// M301/M304 set.
    pub fn set_pid_gains(&mut self, id: HeaterId, gains: PidGains) -> Result<(), ThermalError> {
        if self.channel_mut(id)?.control.set_pid_gains(gains) {
            Ok(())
        } else {
            Err(ThermalError::NotPid(id))
        }
    }

    /// M302: set the minimum extrusion temperature; `None` allows cold
    /// extrusion.
    pub fn set_extrude_min(&mut self, min_c: Option<f64>) {
        self.extrude_min_c = min_c;
    }

    /// May hotend `hotend` extrude? Marlin refuses below `EXTRUDE_MINTEMP`
    /// and prints [`COLD_EXTRUSION_LINE`].
    pub fn check_extrude(&self, hotend: u8) -> Result<(), ColdExtrusion> {
        let Some(min_c) = self.extrude_min_c else {
            return Ok(());
        };
        let temp_c = self.channel(HeaterId::Hotend(hotend)).map_or(f64::NEG_INFINITY, |c| c.reading_c);
        if temp_c < min_c {
            Err(ColdExtrusion { hotend, temp_c, min_c })
        } else {
            Ok(())
        }
    }

    /// Start M303 on `id` (its target is cleared; the relay drives it).
    /// With `apply` (`M303 U1`) the found gains replace the heater's PID
    /// gains, which requires a PID-controlled heater. During the tune the
    /// target is 0, so MINTEMP/MAXTEMP stay armed but the watch and runaway
    /// checks do not apply; the tune has its own overshoot and timeout
    /// aborts.
    pub fn start_autotune(
        &mut self,
        id: HeaterId,
        cfg: AutotuneConfig,
        apply: bool,
    ) -> Result<(), ThermalError> {
        if let Some(fault) = self.halted {
            return Err(ThermalError::Halted(fault));
        }
        let now_s = self.now_s;
        let ch = self.channel_mut(id)?;
        if apply && ch.control.pid_gains().is_none() {
            return Err(ThermalError::NotPid(id));
        }
        ch.target_c = 0.0;
        self.autotune = Some((id, Autotune::new(id, cfg, now_s)?, apply));
        self.autotune_result = None;
        Ok(())
    }

    /// Whether an M303 is running.
    pub fn autotune_running(&self) -> bool {
        self.autotune.is_some()
    }

    /// Take the M303 progress lines printed since the last call.
    pub fn take_autotune_lines(&mut self) -> Vec<String> {
        std::mem::take(&mut self.autotune_lines)
    }

    /// Take the result of the last finished M303.
    pub fn take_autotune_result(&mut self) -> Option<Result<PidGains, AutotuneFailure>> {
        self.autotune_result.take()
    }

    /// The recorded time series.
    pub fn series(&self) -> &TimeSeries {
        &self.series
    }

    /// Firmware loops run in full so far: the loops of the clock, less those passed over while
    /// every heater rested ([`Thermal::step`]). What the heaters cost a run.
    pub fn loops_run(&self) -> u64 {
        self.loops_run
    }

    /// Advance the simulated clock by `dt_s`, running the firmware loop at every sample instant
    /// on the way. Returns the fault if the printer halted during this step.
    ///
    /// The heater power changes only at samples, and the plant's step is exact for any length
    /// (see the heater module), so the plants are integrated from sample to sample, however
    /// many moves (calls) lie between: a long print costs one plant step per sample, not one
    /// per move.
    ///
    /// One call runs at most `MAX_SAMPLES_PER_STEP` firmware loops: past them the heaters
    /// have long settled, so the rest of the step is integrated with the last power and the
    /// loop resumes at its end. A dwell of a century (or a clock pushed to 1e308 s by a huge
    /// move) then costs a bounded time instead of hanging.
    ///
    /// While every heater rests (off, and its plant still to the bit) a loop changes nothing
    /// but the clock, and the loops are passed over: only what the clock moves is carried out
    /// (see `rest`), with the same temperatures, records and faults as running each in full.
    pub fn step(&mut self, dt_s: f64) -> Option<ThermalFault> {
        let end_s = self.now_s + dt_s;
        if !(dt_s > 0.0 && end_s.is_finite()) {
            return None;
        }
        let was_halted = self.halted.is_some();
        let mut budget = MAX_SAMPLES_PER_STEP;
        loop {
            let next_sample_s = self.samples_taken as f64 * self.sample_period_s;
            if next_sample_s > end_s + 1e-9 {
                break;
            }
            if budget == 0 {
                // A saturating cast: a clock beyond u64 samples simply never samples again.
                self.samples_taken = (end_s / self.sample_period_s).ceil() as u64;
                break;
            }
            budget -= 1;
            self.now_s = self.now_s.max(next_sample_s);
            self.settle_plants();
            self.sample();
            self.samples_taken += 1;
            self.loops_run += 1;
            if self.at_rest() {
                budget -= self.rest(end_s, budget);
            }
        }
        self.now_s = end_s;
        if was_halted {
            None
        } else {
            self.halted
        }
    }

    /// Integrate the plants up to the clock, with the power of the last sample.
    fn settle_plants(&mut self) {
        let h_s = self.now_s - self.plant_s;
        if h_s > 1e-12 {
            for ch in &mut self.channels {
                ch.plant.step(control::duty(ch.power), h_s);
            }
        }
        self.plant_s = self.now_s;
    }

    /// One firmware loop at `now_s`: read, protect, control, record.
    fn sample(&mut self) {
        let now_s = self.now_s;
        for i in 0..self.channels.len() {
            let ch = &mut self.channels[i];
            ch.reading_c = self.table.celsius_near(ch.plant.read_adc(&self.thermistor), &mut ch.bracket);
            if self.halted.is_some() {
                ch.power = 0;
                continue;
            }
            if let Some(fault) = ch.protection.check(now_s, ch.reading_c, ch.target_c) {
                self.halt(fault);
                continue;
            }
            ch.power = match &mut self.autotune {
                Some((id, tune, _)) if *id == ch.id => {
                    let status = tune.update(now_s, ch.reading_c);
                    self.autotune_lines.extend(tune.take_lines());
                    match status {
                        AutotuneStatus::Running { power } => power,
                        AutotuneStatus::Finished(gains) => {
                            if self.autotune.as_ref().is_some_and(|a| a.2) {
                                ch.control.set_pid_gains(gains);
                            }
                            self.autotune = None;
                            self.autotune_result = Some(Ok(gains));
                            0
                        }
                        AutotuneStatus::Failed(failure) => {
                            self.autotune = None;
                            self.autotune_result = Some(Err(failure));
                            0
                        }
                    }
                }
                _ => ch.control.update(now_s, ch.reading_c, ch.target_c),
            };
        }
        if self.series.due(now_s) {
            self.record();
        }
    }

    /// Records every heater's reading, target and power now in the series.
    fn record(&mut self) {
        let now_s = self.now_s;
        let samples = self
            .channels
            .iter()
            .map(|c| Sample {
                t_s: now_s,
                heater: c.id,
                temp_c: c.reading_c,
                target_c: c.target_c,
                power: c.power,
            })
            .collect();
        self.series.record(now_s, samples);
    }

    /// Switch everything off and remember the fault.
    fn halt(&mut self, fault: ThermalFault) {
        self.halted = Some(fault);
        self.autotune = None;
        for ch in &mut self.channels {
            ch.target_c = 0.0;
            ch.power = 0;
            ch.control.reset();
        }
    }

    /// Stateless closeness check, without residency: with
    /// [`WaitMode::Both`] the reading is within `window_c` of the target,
    /// with [`WaitMode::HeatOnly`] it is above `target - window_c`. M109 and
    /// M190 should use [`Thermal::begin_wait`] and [`Thermal::poll_wait`],
    /// which add Marlin's residency time.
    pub fn is_at_target(&self, id: HeaterId, mode: WaitMode) -> Result<bool, ThermalError> {
        let ch = self.channel(id)?;
        let off_c = ch.reading_c - ch.target_c;
        Ok(match mode {
            WaitMode::HeatOnly => off_c > -ch.wait.window_c,
            WaitMode::Both => off_c.abs() < ch.wait.window_c,
        })
    }

    /// Start an M109/M190 wait on `id`.
    pub fn begin_wait(&self, id: HeaterId, mode: WaitMode) -> Result<TempWait, ThermalError> {
        self.channel(id)?;
        Ok(TempWait { heater: id, mode, first_poll: true, residency_start_s: None })
    }

    /// Poll a wait after stepping. Marlin's rule: with `S` (heat only) a
    /// heater already above its target when the wait starts is done at
    /// once; otherwise a
    /// residency timer starts once the reading is within `window_c` of the
    /// target (starting `residency_s / 3` late if it already was at the
    /// first poll), restarts whenever the reading strays beyond
    /// `hysteresis_c`, and the wait ends after `residency_s` on it.
    pub fn poll_wait(&self, wait: &mut TempWait) -> WaitStatus {
        if self.halted.is_some() {
            return WaitStatus::Halted;
        }
        let Ok(ch) = self.channel(wait.heater) else {
            return WaitStatus::Halted;
        };
        let now_s = self.now_s;
        let first = std::mem::replace(&mut wait.first_poll, false);
        // Marlin decides "wants to cool" when the wait starts (and again only if the target
        // changes); later the residency alone ends the wait, overshoot or not.
        if first && wait.mode == WaitMode::HeatOnly && ch.reading_c > ch.target_c {
            return WaitStatus::Reached;
        }
        let off_c = (ch.target_c - ch.reading_c).abs();
        let w = ch.wait;
        match wait.residency_start_s {
            None if off_c < w.window_c => {
                let late_s = if first { w.residency_s / 3.0 } else { 0.0 };
                wait.residency_start_s = Some(now_s + late_s);
            }
            Some(_) if off_c > w.hysteresis_c => wait.residency_start_s = Some(now_s),
            _ => {}
        }
        match wait.residency_start_s {
            Some(start_s) if millis(now_s) - millis(start_s) >= millis(w.residency_s) => WaitStatus::Reached,
            _ => WaitStatus::Waiting,
        }
    }

    /// Whole seconds of residency left in a wait, as Marlin prints after ` W:` in the M109/M190
    /// status lines: `None` (printed `?`) until the residency timer has started. Marlin computes
    /// it in milliseconds and divides by 1000, truncating.
    fn residency_left_s(&self, wait: &TempWait) -> Option<u64> {
        let start_s = wait.residency_start_s?;
        let residency_s = self.channel(wait.heater).map_or(0.0, |c| c.wait.residency_s);
        let left_ms = millis(residency_s) - (millis(self.now_s) - millis(start_s));
        Some((left_ms.max(0) / 1000) as u64)
    }

    /// The M105 status, exactly as Marlin formats it (without the leading
    /// `ok `): `T:210.00 /210.00 B:60.00 /60.00 @:64 B@:0`; with several
    /// hotends the active one as `T:` then `T0:`, `T1:`... after the bed,
    /// and `@0:`, `@1:`... after `B@:`.
    pub fn m105_report(&self) -> String {
        self.status(self.active)
    }

    /// The status line Marlin 2.x prints every second during M109/M190
    /// (`wait_for_hotend`/`wait_for_bed`), with its leading space: the
    /// M105 status of the hotend waited for (the active one for the bed)
    /// and ` W:` with the residency left in whole seconds, `?` before it starts:
    /// ` T:199.48 /200.00 B:25.00 /0.00 @:22 B@:0 W:9`.
    pub fn wait_status_line(&self, wait: &TempWait) -> String {
        let hotend = match wait.heater {
            HeaterId::Hotend(n) => n,
            HeaterId::Bed => self.active,
        };
        let left = self.residency_left_s(wait).map_or("?".to_owned(), |s| s.to_string());
        format!(" {} W:{left}", self.status(hotend))
    }

    /// The M105 fields with `hotend` as `T:` and `@:` (Marlin's
    /// `print_heater_states(target_extruder)`).
    fn status(&self, hotend: u8) -> String {
        use std::fmt::Write;
        let mut out = String::new();
        let hotends: Vec<&Channel> =
            self.channels.iter().filter(|c| matches!(c.id, HeaterId::Hotend(_))).collect();
        let bed = self.channels.iter().find(|c| c.id == HeaterId::Bed);
        let active = hotends[usize::from(hotend).min(hotends.len() - 1)];
        let _ = write!(out, "T:{:.2} /{:.2}", active.reading_c, active.target_c);
        if let Some(b) = bed {
            let _ = write!(out, " B:{:.2} /{:.2}", b.reading_c, b.target_c);
        }
        if hotends.len() > 1 {
            for (i, h) in hotends.iter().enumerate() {
                let _ = write!(out, " T{i}:{:.2} /{:.2}", h.reading_c, h.target_c);
            }
        }
        let _ = write!(out, " @:{}", active.power);
        if let Some(b) = bed {
            let _ = write!(out, " B@:{}", b.power);
        }
        if hotends.len() > 1 {
            for (i, h) in hotends.iter().enumerate() {
                let _ = write!(out, " @{i}:{}", h.power);
            }
        }
        out
    }
}
