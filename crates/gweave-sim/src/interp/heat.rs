//! The heater commands of the interpreter and the clock that drives the thermal plant.
//!
//! After every command the heaters are stepped up to the machine clock ([`Machine::sync`]);
//! the step is split at the times of injected faults and of `M155` auto-reports, so both happen
//! at their exact simulated time. `M109`/`M190` wait in steps of the firmware's sample period
//! until Marlin's settle rule ([`Thermal::poll_wait`]) is met, printing the status once a second
//! as Marlin 2.x does (`wait_for_hotend`/`wait_for_bed` in `Marlin/src/module/temperature.cpp`):
//! ` T:.. /.. B:.. /.. @:.. B@:.. W:?`, where `W:` counts the residency time down in whole
//! seconds once the reading is within `TEMP_WINDOW` of the target and is `?` before. (Marlin
//! 1.x printed a shorter `T:.. E:0 W:?`; hosts read the `T:` either way.)

use super::commands::Call;
use super::{Halt, Machine, WarningKind};
use crate::thermal::autotune::AutotuneConfig;
use crate::thermal::control::PidGains;
use crate::thermal::heater::HeaterId;
use crate::thermal::{Thermal, ThermalError, WaitMode, WaitStatus};

/// The longest `M109`/`M190`/`M303` the machine waits before giving up, simulated s. Marlin
/// has no such limit (its protection ends a hopeless wait); this only bounds a run whose
/// protection was configured away.
const MAX_WAIT_S: f64 = 3.0 * 3600.0;
/// Period of the status lines during a wait, s.
const WAIT_REPORT_S: f64 = 1.0;

impl Machine {
    /// `M104`/`M109 [T<hotend>] S|R<celsius>`: the hotend's target; `M109` also waits (`S`:
    /// while heating, `R`: both ways).
    pub(super) fn hotend_target(&mut self, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
        let (s, r) = self.target_words();
        let b = self.core.block();
        // On a single nozzle `T` names a tool, and every tool heats the one hotend.
        let hotend = b.get(b'T').map_or(self.active_hotend_index(), |t| {
            if self.profile.single_nozzle_tools > 0 && self.profile.has_tool(t.max(0.0) as u32) {
                0
            } else {
                t.max(0.0) as u8
            }
        });
        let id = HeaterId::Hotend(hotend);
        if self.thermal.target(id).is_err() {
            out(self.now_s(), &format!("echo:M{} Invalid extruder {hotend}", c.number));
            self.warn(WarningKind::InvalidExtruder { tool: u32::from(hotend) });
            return;
        }
        self.set_target(id, s.or(r), out);
        if c.number == 109 {
            self.run_core(c.line, out);
            self.sync(out);
            self.wait_heater(id, mode(r.is_some() && s.is_none()), out);
        }
    }

    /// `M140`/`M190 S|R<celsius>`: the bed's target; `M190` also waits. Unknown without a bed.
    pub(super) fn bed_target(&mut self, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
        if self.thermal.target(HeaterId::Bed).is_err() {
            self.unknown_command(c.line, out);
            return;
        }
        let (s, r) = self.target_words();
        self.set_target(HeaterId::Bed, s.or(r), out);
        if c.number == 190 {
            self.run_core(c.line, out);
            self.sync(out);
            self.wait_heater(HeaterId::Bed, mode(r.is_some() && s.is_none()), out);
        }
    }

    /// `M116` (RepRapFirmware): wait for every heater that has a target.
    pub(super) fn m116(&mut self, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
        self.run_core(c.line, out);
        self.core.drain();
        self.sync(out);
        let ids = (0..self.thermal.hotend_count())
            .map(HeaterId::Hotend)
            .chain(self.profile.thermal.bed.map(|_| HeaterId::Bed))
            .filter(|&id| self.thermal.target(id).is_ok_and(|t| t > 0.0))
            .collect::<Vec<_>>();
        for id in ids {
            self.wait_heater(id, WaitMode::HeatOnly, out);
            // The emergency parser's `M108` ends the whole command, not one heater's wait.
            if !self.host.wait_for_heatup || self.halt.is_some() {
                break;
            }
        }
    }

    /// `M105`: the temperatures, answered with its own `ok` as Marlin does.
    pub(super) fn m105(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let text = format!("ok {}", self.thermal.m105_report());
        out(self.now_s(), &text);
        self.acknowledged = true;
    }

    /// `M155 S<seconds>`: report the temperatures every S seconds (0: off).
    pub(super) fn m155(&mut self) {
        self.autoreport_s = self.report_period_s().unwrap_or(0.0);
        self.next_report_s = self.now_s() + self.autoreport_s;
    }

    /// RepRapFirmware `G10 P<tool> S<active> [R<standby>]` and its successor `M568` (same
    /// words): the tool's hotend target (we keep the active temperature; tools idle at standby
    /// are not simulated). On a mixing hotend every tool is the one nozzle.
    pub(super) fn rrf_tool_temperature(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let b = self.core.block();
        let hotend = match b.get(b'P') {
            Some(tool) if self.profile.mixing_inputs == 0 => {
                self.profile.hotend_of_tool(tool.max(0.0) as usize)
            }
            _ => self.active_hotend_index(),
        };
        let s = b.get(b'S');
        self.set_target(HeaterId::Hotend(hotend), s, out);
    }

    /// The target words `S` and `R` of a heater command. LinuxCNC gives an M-code's value as
    /// `P` (`M104 P200`), as the state reads it.
    fn target_words(&self) -> (Option<f64>, Option<f64>) {
        let b = self.core.block();
        let values_in_p = self.core.state().options().firmware.values_in_p();
        let s = b.get(b'S').or_else(|| b.get(b'P').filter(|_| values_in_p));
        (s, b.get(b'R'))
    }

    fn active_hotend_index(&self) -> u8 {
        self.profile.hotend_of_tool(self.tool)
    }

    fn set_target(&mut self, id: HeaterId, celsius: Option<f64>, out: &mut dyn FnMut(f64, &str)) {
        let Some(c) = celsius else { return };
        if let Err(e) = self.thermal.set_target(id, c) {
            self.thermal_refused(e, out);
        }
    }

    fn thermal_refused(&mut self, e: ThermalError, out: &mut dyn FnMut(f64, &str)) {
        self.refuse(e.to_string(), out);
    }

    /// `M109`/`M190`: wait with the machine standing still, printing the status every second.
    fn wait_heater(&mut self, id: HeaterId, mode: WaitMode, out: &mut dyn FnMut(f64, &str)) {
        self.thermal.set_moving(false);
        let Ok(mut wait) = self.thermal.begin_wait(id, mode) else {
            return;
        };
        let step_s = self.profile.thermal.sample_period_s;
        let start_s = self.now_s();
        let mut report_s = start_s + WAIT_REPORT_S;
        self.host.wait_for_heatup = true;
        loop {
            match self.thermal.poll_wait(&mut wait) {
                WaitStatus::Reached | WaitStatus::Halted => break,
                WaitStatus::Waiting => {}
            }
            // `gweave serve`, paced: the host's `M108` or `M112` sent meanwhile acts now.
            self.hear_early(out);
            if !self.host.wait_for_heatup || self.halt.is_some() {
                break;
            }
            if self.now_s() - start_s > MAX_WAIT_S {
                self.warn(WarningKind::WaitTimeout { heater: id });
                out(self.now_s(), "echo:gweave-sim: wait abandoned after 3 h");
                break;
            }
            self.idle_for(step_s, out);
            if self.halt == Some(Halt::ClockLimit) {
                break;
            }
            if self.now_s() + 1e-9 >= report_s {
                let text = self.thermal.wait_status_line(&wait);
                out(self.now_s(), &text);
                report_s += WAIT_REPORT_S;
            }
        }
    }

    /// The emergency parser's `M108`: a heating wait ends where it is (Marlin clears
    /// `wait_for_heatup`; the command then answers `ok`).
    pub(super) fn end_heating_wait(&mut self) {
        self.host.wait_for_heatup = false;
    }

    /// The host is quiet: `t_s` seconds of its wall clock pass on a board with no command
    /// waiting (`gweave serve` calls this while the line is silent, so that a board left alone
    /// lives in real time). Moves still queued run to a stop first, as Marlin's planner empties
    /// its buffer when nothing follows; then the heaters (with thermal protection) and the
    /// `M155` auto-reports run through the rest. A time that is not positive and finite changes
    /// nothing: the clock never runs backwards.
    pub fn idle(&mut self, t_s: f64, out: &mut dyn FnMut(f64, &str)) {
        if !(t_s > 0.0 && t_s.is_finite()) {
            return;
        }
        if self.core.queued() > 0 {
            self.core.drain();
            self.sync(out);
        }
        self.core.idle(t_s);
        self.idle_s += t_s;
        self.sync(out);
        self.timed_reports(out);
    }

    /// Let time pass with the machine standing still (heating waits, autotune).
    fn idle_for(&mut self, t_s: f64, out: &mut dyn FnMut(f64, &str)) {
        self.core.idle(t_s);
        self.heating_s += t_s;
        self.sync(out);
    }

    /// `M301 [E<n>] [P] [I] [D]`: set the given gains, print them all.
    pub(super) fn m301(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let b = self.core.block();
        let id = HeaterId::Hotend(b.get(b'E').map_or(0, |e| e.max(0.0) as u8));
        let (p, i, d) = (b.get(b'P'), b.get(b'I'), b.get(b'D'));
        let result = self.thermal.pid_gains(id).and_then(|g| {
            let gains = PidGains { kp: p.unwrap_or(g.kp), ki: i.unwrap_or(g.ki), kd: d.unwrap_or(g.kd) };
            self.thermal.set_pid_gains(id, gains).map(|()| gains)
        });
        match result {
            Ok(g) => out(self.now_s(), &g.report_line(false)),
            Err(e) => self.thermal_refused(e, out),
        }
    }

    /// `M303 E<heater> S<temp> [C<cycles>] [U1]`: relay autotune on the plant (E-1 is the bed).
    pub(super) fn m303(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let b = self.core.block();
        let (e, s) = (b.get(b'E'), b.get(b'S'));
        let id = match e {
            Some(e) if e < 0.0 => HeaterId::Bed,
            e => HeaterId::Hotend(e.map_or(0, |e| e as u8)),
        };
        let default_c = if id == HeaterId::Bed { 70.0 } else { 150.0 };
        let mut cfg = AutotuneConfig::new(s.unwrap_or(default_c));
        if let Some(c) = b.get(b'C') {
            cfg.cycles = c.max(0.0) as u32;
        }
        let apply = b.get(b'U').is_some_and(|u| u != 0.0);
        // The registry drained the planner (`Queue::Drains`).
        self.sync(out);
        self.thermal.set_moving(false);
        if let Err(e) = self.thermal.start_autotune(id, cfg, apply) {
            self.thermal_refused(e, out);
            return;
        }
        let step_s = self.profile.thermal.sample_period_s;
        let start_s = self.now_s();
        while self.thermal.autotune_running() && self.halt.is_none() && self.now_s() - start_s <= MAX_WAIT_S {
            self.idle_for(step_s, out);
            for l in self.thermal.take_autotune_lines() {
                out(self.now_s(), &l);
            }
        }
        for l in self.thermal.take_autotune_lines() {
            out(self.now_s(), &l);
        }
        self.thermal.take_autotune_result();
    }

    /// Step the heaters up to the machine clock, injecting faults and auto-reporting on time; a
    /// clock past its limit ([`Machine::limit_clock`]) steps them to the limit and halts.
    pub(super) fn sync(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let clock_s = self.core.now_s();
        let target_s = clock_s.min(self.clock_limit_s);
        loop {
            let now_s = self.thermal.now_s();
            if let Some(f) = self.faults.get(self.next_fault) {
                if f.at_s <= now_s + 1e-12 {
                    let spec = *f;
                    self.next_fault += 1;
                    if let Ok(h) = self.thermal.heater_mut(spec.heater) {
                        h.inject(spec.fault);
                    }
                    continue;
                }
            }
            if self.autoreport_s > 0.0 && self.next_report_s <= now_s + 1e-12 {
                let text = format!(" {}", self.thermal.m105_report());
                out(now_s, &text);
                self.next_report_s += self.autoreport_s;
                continue;
            }
            // A NaN gap (an infinite clock) also ends the loop.
            let gap_s = target_s - now_s;
            if gap_s.is_nan() || gap_s <= 1e-12 {
                break;
            }
            let mut until_s = target_s;
            if let Some(f) = self.faults.get(self.next_fault) {
                until_s = until_s.min(f.at_s);
            }
            if self.autoreport_s > 0.0 {
                until_s = until_s.min(self.next_report_s);
            }
            let fault = self.thermal.step(until_s - now_s);
            if self.thermal.now_s() <= now_s {
                // The thermal clock cannot advance (the machine clock is beyond any finite
                // time): stop here rather than spin.
                break;
            }
            if let Some(fault) = fault {
                for l in fault.lines() {
                    out(fault.at_s, &l);
                }
                self.thermal_faults.push(fault);
                self.warn(WarningKind::Thermal { message: fault.error_line() });
                if self.halt.is_none() {
                    self.halt = Some(Halt::Thermal(fault));
                    // The moves executed up to this line's clock have run.
                    self.stop_motors();
                }
            }
        }
        if clock_s > self.clock_limit_s && self.halt.is_none() {
            self.stop_at_clock_limit(out);
        }
    }

    /// The clock passed its limit: say so, switch the heaters off and halt.
    #[cold]
    #[inline(never)]
    fn stop_at_clock_limit(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let limit = WarningKind::ClockLimit { limit_s: self.clock_limit_s };
        out(self.clock_limit_s, &format!("Error:gweave-sim: {limit}"));
        self.warn(limit);
        self.halt = Some(Halt::ClockLimit);
        self.heaters_off();
    }
}

fn mode(both: bool) -> WaitMode {
    if both {
        WaitMode::Both
    } else {
        WaitMode::HeatOnly
    }
}

/// Per-heater statistics from the recorded series.
pub(super) fn heater_stats(thermal: &Thermal, ids: &[HeaterId]) -> Vec<super::HeaterStats> {
    ids.iter()
        .filter_map(|&id| {
            let mut n = 0u64;
            let mut power_sum = 0.0;
            let mut max_c = f64::NEG_INFINITY;
            for s in thermal.series().of(id) {
                n += 1;
                power_sum += f64::from(s.power);
                max_c = max_c.max(s.temp_c);
            }
            let power_w = thermal.heater(id).ok()?.config().power_w;
            let duty = if n > 0 {
                power_sum / (n as f64 * f64::from(crate::thermal::control::POWER_MAX))
            } else {
                0.0
            };
            Some(super::HeaterStats {
                heater: id,
                temp_c: thermal.temperature(id).ok()?,
                target_c: thermal.target(id).ok()?,
                max_c: if n > 0 { max_c } else { thermal.temperature(id).ok()? },
                mean_duty: duty,
                energy_wh: duty * power_w * thermal.now_s() / 3600.0,
            })
        })
        .collect()
}
