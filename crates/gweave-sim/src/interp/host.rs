//! Commands that are about the board and its host rather than the motion: messages (`M117`,
//! `M118`), the print job timer (`M31`, `M75`-`M77`), power off (`M81`),
//! software endstops (`M211`), pins (`M42`, `M226`), position auto-reports (`M154`), host prompts
//! (`M876`) and bed levelling (`G29`, `M420`), one method per command, which the command's row
//! in the registry (`commands.rs`) calls. Replies are Marlin 2.1's (`Marlin/src/gcode/...`,
//! strings from `Marlin/src/core/language.h`).

use super::Machine;

/// Simulated seconds one probe point of `G29` takes (descent, probe, raise, travel).
const PROBE_POINT_S: f64 = 1.5;

/// The board's state that only the host sees.
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct HostState {
    /// Print job timer: accumulated seconds, and the start of the running stretch.
    job_s: f64,
    job_since_s: Option<f64>,
    /// `M211`: software endstops off (they are on at power-on).
    soft_endstops_off: bool,
    /// `M42`: pin values set by the host.
    pins: std::collections::BTreeMap<i64, f64>,
    /// `M154 S`: position auto-report period, s (0: off), and the next report time.
    pub autoreport_pos_s: f64,
    pub next_pos_report_s: f64,
    /// `G29` ran (a mesh exists), and `M420 S1` applies it.
    mesh_probed: bool,
    levelling_on: bool,
    /// `M600` waits for the user ([`Machine::waiting_for_user`]).
    pub waiting_for_user: bool,
    /// A heating wait runs until this is false (Marlin's `wait_for_heatup`, which the
    /// emergency parser's `M108` clears).
    pub wait_for_heatup: bool,
    /// The host prompt that is open, if any.
    pub prompt: Option<super::pause::PromptReason>,
}

impl Machine {
    /// `M31`: the print job time, as Marlin's `duration_t` prints it.
    pub(super) fn m31(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let text = duration_text(self.job_time_s());
        out(self.now_s(), &format!("echo:Print time: {text}"));
    }

    /// `M81`: power off: heaters off, motors off (the axes must be homed again).
    pub(super) fn power_off(&mut self) {
        self.heaters_off();
        self.core.drain();
        self.homed = [false; 3];
    }

    /// `M118 [A1] [E1] text`: the text to the host, with the prefixes the flags ask for.
    pub(super) fn m118(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        let (text, prefix) = m118_text(super::command_text(line));
        out(self.now_s(), &format!("{prefix}{text}"));
    }

    /// `M154 S<s>`: the position auto-report period (0: off), from now.
    pub(super) fn m154(&mut self) {
        let period = self.report_period_s().unwrap_or(0.0);
        self.host.autoreport_pos_s = period;
        self.host.next_pos_report_s = self.now_s() + period;
    }

    /// `M211 [S0|S1]`: software endstops off or on, silently (`S` without a number is on, as
    /// Marlin's `value_bool` reads it); alone, their state and limits in Marlin 2.1's words
    /// (`M211_report`), as gweave's firmware prints them.
    pub(super) fn m211(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let block = self.core.block();
        if block.has(b'S') {
            self.host.soft_endstops_off = block.get(b'S') == Some(0.0);
            return;
        }
        let on = if self.host.soft_endstops_off { "  M211 S0 ; OFF" } else { "  M211 S1 ; ON" };
        let [(x0, x1), (y0, y1), (z0, z1)] = self.profile.bed.ranges();
        out(self.now_s(), on);
        out(self.now_s(), &format!("  Min:  X{x0:.2} Y{y0:.2} Z{z0:.2}   Max:  X{x1:.2} Y{y1:.2} Z{z1:.2}"));
    }

    /// `M42 P<pin> S<value>`: the virtual pin holds the value.
    pub(super) fn m42(&mut self) {
        let b = self.core.block();
        if let (Some(p), Some(s)) = (b.get(b'P'), b.get(b'S')) {
            self.host.pins.insert(p as i64, s);
        }
    }

    /// `M226 P<pin> S<state>`: waits until the pin reads the state. The virtual pins hold what
    /// `M42` wrote (0 otherwise) and nothing else changes them, so a wait for another state
    /// would never end: it is refused instead of hanging the board.
    pub(super) fn m226(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let b = self.core.block();
        let pin = b.get(b'P').map_or(-1, |p| p as i64);
        let want = b.get(b'S').unwrap_or(-1.0);
        let has = self.host.pins.get(&pin).copied().unwrap_or(0.0);
        if want >= 0.0 && (has != 0.0) != (want != 0.0) {
            self.refuse(format!("M226: pin {pin} never reaches state {want}: not waiting"), out);
        }
    }

    /// `M876 S<n>` answers the open host prompt; `M876 P1` only says the host supports them.
    pub(super) fn m876(&mut self) {
        if self.core.block().has(b'S') {
            self.answer_prompt();
        }
    }

    /// `M117 <text>`: the status message goes to the host too, as `//action:notification`
    /// (Marlin's `HOST_STATUS_NOTIFICATIONS`, with `host_action_commands`); without host
    /// actions it is accepted.
    pub(super) fn m117(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        if self.profile.firmware.host_action_commands {
            let text = String::from_utf8_lossy(super::command_text(line)).into_owned();
            let message = text.get(4..).unwrap_or("").trim_start();
            out(self.now_s(), &format!("//action:notification {message}"));
        }
    }

    /// `G29`: probe the grid (simulated time), store a flat mesh and turn levelling on, with
    /// Marlin's bilinear report.
    pub(super) fn g29(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let Some((nx, ny)) = self.profile.firmware.grid() else { return };
        if self.homed != [true; 3] {
            // Marlin refuses to probe an unhomed machine.
            out(self.now_s(), "echo:Home XYZ First");
            return;
        }
        self.core.drain();
        self.sync(out);
        self.park_for(PROBE_POINT_S * (nx * ny) as f64, out);
        self.host.mesh_probed = true;
        self.host.levelling_on = true;
        for l in self.mesh_lines() {
            out(self.now_s(), &l);
        }
    }

    /// `M420 [S0|S1] [V1]`: levelling off/on, report it (and the mesh with V).
    pub(super) fn m420(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let b = self.core.block();
        let (s, v) = (b.get(b'S'), b.get(b'V').is_some_and(|v| v != 0.0));
        if let Some(s) = s {
            if s != 0.0 && !self.host.mesh_probed {
                self.refuse("Failed to enable Bed Leveling".to_owned(), out);
            } else {
                self.host.levelling_on = s != 0.0;
            }
        }
        if v && self.host.mesh_probed {
            for l in self.mesh_lines() {
                out(self.now_s(), &l);
            }
        }
        let state = if self.host.levelling_on { "ON" } else { "OFF" };
        out(self.now_s(), &format!("echo:Bed Leveling {state}"));
        out(self.now_s(), "echo:Fade Height OFF");
    }

    /// Marlin's `print_bilinear_leveling_grid`: a header row of X indices, one row per Y
    /// (highest first), the virtual bed being flat.
    fn mesh_lines(&self) -> Vec<String> {
        let Some((nx, ny)) = self.profile.firmware.grid() else { return Vec::new() };
        let mut lines = vec!["Bilinear Leveling Grid:".to_owned()];
        lines.push(
            std::iter::once("     ".to_owned()).chain((0..nx).map(|x| format!("    {x}   "))).collect(),
        );
        for y in (0..ny).rev() {
            lines.push(format!(" {y} {}", vec![" +0.000 "; nx].join("")));
        }
        lines
    }

    /// The position auto-report (`M154`), when due: Marlin prints the projected position.
    pub(super) fn timed_host_reports(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let now = self.now_s();
        let period = self.host.autoreport_pos_s;
        if period > 0.0 && self.host.next_pos_report_s <= now + 1e-9 {
            let [x, y, z, e, _] = self.position();
            out(now, &format!("X:{x:.2} Y:{y:.2} Z:{z:.2} E:{e:.2}"));
            // One report for however long the gap was, then on the period again.
            let late = ((now - self.host.next_pos_report_s) / period).floor() + 1.0;
            self.host.next_pos_report_s += late * period;
        }
    }

    /// `M75`: the print job timer runs (from now, unless it runs already).
    pub(super) fn job_timer_start(&mut self) {
        let now = self.now_s();
        self.host.job_since_s.get_or_insert(now);
    }

    /// `M76`: the print job timer stops and keeps its reading.
    pub(super) fn job_timer_pause(&mut self) {
        self.host.job_s = self.job_time_s();
        self.host.job_since_s = None;
    }

    /// `M77`: the print job timer stops and reads zero again.
    pub(super) fn job_timer_stop(&mut self) {
        self.job_timer_pause();
        self.host.job_s = 0.0;
    }

    /// The print job timer's present reading, s.
    fn job_time_s(&self) -> f64 {
        self.host.job_s + self.host.job_since_s.map_or(0.0, |since| self.now_s() - since)
    }
}

/// Marlin's `duration_t::toString`: `12s`, `3m 04s`, `2h 03m 04s`, `1d 02h 03m 04s`.
fn duration_text(t_s: f64) -> String {
    let t = t_s.max(0.0) as u64;
    let (d, h, m, s) = (t / 86400, t / 3600 % 24, t / 60 % 60, t % 60);
    match (d, h, m) {
        (0, 0, 0) => format!("{s}s"),
        (0, 0, _) => format!("{m}m {s:02}s"),
        (0, _, _) => format!("{h}h {m:02}m {s:02}s"),
        _ => format!("{d}d {h:02}h {m:02}m {s:02}s"),
    }
}

/// `M118 [A1] [E1] [Pn] text`: the text, and the prefix the flags ask for (`//` for A1, then
/// `echo:` for E1), as Marlin's `M118` reads its leading flags.
fn m118_text(line: &[u8]) -> (String, &'static str) {
    let text = String::from_utf8_lossy(line);
    let mut rest = text.get(4..).unwrap_or("").trim_start();
    let (mut action, mut echo) = (false, false);
    loop {
        let flag = rest.get(..2).map(str::to_ascii_uppercase);
        let after = rest.get(2..).unwrap_or("");
        let at_word_end = after.is_empty() || after.starts_with(' ');
        match flag.as_deref() {
            Some("A1") if at_word_end => action = true,
            Some("E1") if at_word_end => echo = true,
            Some(p) if p.starts_with('P') && at_word_end => {}
            _ => break,
        }
        rest = after.trim_start();
    }
    let prefix = match (action, echo) {
        (true, true) => "//echo:",
        (true, false) => "//",
        (false, true) => "echo:",
        (false, false) => "",
    };
    (rest.to_owned(), prefix)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn m118_flags_and_durations_read_as_marlin() {
        assert_eq!(m118_text(b"M118 E1 hello world"), ("hello world".to_owned(), "echo:"));
        assert_eq!(m118_text(b"M118 A1 action:pause"), ("action:pause".to_owned(), "//"));
        assert_eq!(m118_text(b"M118 Ahoy"), ("Ahoy".to_owned(), ""));
        assert_eq!(duration_text(12.9), "12s");
        assert_eq!(duration_text(184.0), "3m 04s");
        assert_eq!(duration_text(7384.0), "2h 03m 04s");
    }
}
