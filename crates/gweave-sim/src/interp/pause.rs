//! `M600`, the filament change of Marlin's `ADVANCED_PAUSE_FEATURE` (`Marlin/src/feature/pause.cpp`,
//! host prompts from `Marlin/src/feature/host_actions.cpp`), as a board without a display runs it
//! for a host:
//!
//! 1. pause: the host prompt `Pause` / `Dismiss`, retract, park (raise Z, move to the park
//!    point), unload the filament;
//! 2. wait for the user: `echo:Insert filament and send M108`, the prompt `Nozzle Parked` /
//!    `Continue`, and `echo:busy: paused for user` every 2 s until `M108` or `M876 S0` arrives
//!    (through the emergency parser: the command queue is held by the `M600` meanwhile);
//! 3. resume: load and purge, the prompt `Paused` / `PurgeMore` / `Continue` closed at once (a
//!    board without a display does not wait there), back to the print, `ok`.
//!
//! The park and filament moves take their time on the clock (Marlin's default lengths and
//! speeds, below) and leave the nozzle where it was, as Marlin's unpark does; the filament they
//! move goes out and back in and is not counted.
//!
//! The wait is the serial protocol's business ([`crate::link::serial::Protocol`] holds the `ok` and the
//! lines after it while [`Machine::waiting_for_user`]); a run of a file (`gweave sim`) has no user
//! to wait for: the next command continues as if the user had pressed Continue at once.

use super::Machine;
use crate::link::early::EarlyLines;

/// Why a host prompt is open (Marlin's `PromptReason`): what answering it with `M876` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum PromptReason {
    /// A message with a Dismiss button.
    Info,
    /// `M25`'s "Pause SD" / "Resume": answering resumes the SD print (Marlin injects `M24`).
    PauseResume,
    /// "Nozzle Parked" / "Continue": answering ends the wait, as `M108` does.
    UserContinue,
    /// "Paused" / "PurgeMore" / "Continue" after loading.
    FilamentLoad,
}

/// `PAUSE_PARK_RETRACT_LENGTH` (2 mm) at `PAUSE_PARK_RETRACT_FEEDRATE` (60 mm/s), the park moves
/// (`NOZZLE_PARK_Z_RAISE_MIN` to 20 mm at `NOZZLE_PARK_Z_FEEDRATE` 5 mm/s, then across the bed at
/// `NOZZLE_PARK_XY_FEEDRATE` 100 mm/s), simulated s.
const PARK_S: f64 = 2.0 / 60.0 + 20.0 / 5.0 + 2.0;
/// `FILAMENT_CHANGE_UNLOAD_LENGTH` 100 mm at `FILAMENT_CHANGE_UNLOAD_FEEDRATE` 10 mm/s.
const UNLOAD_S: f64 = 100.0 / 10.0;
/// `ADVANCED_PAUSE_PURGE_LENGTH` 50 mm at `ADVANCED_PAUSE_PURGE_FEEDRATE` 3 mm/s.
const PURGE_S: f64 = 50.0 / 3.0;

impl Machine {
    /// Whether a command (`M600`) waits for the user to answer its prompt.
    pub fn waiting_for_user(&self) -> bool {
        self.host.waiting_for_user
    }

    /// The emergency parser saw `line` while the board waits for the user: a command whose row
    /// says what the parser does at once (its `urgent` in `interp/commands.rs`: `M108` and
    /// `M876` end the wait, `M112` kills) is done; any other line waits its turn.
    pub fn emergency(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        if !self.profile.firmware.emergency_parser || self.halt.is_some() {
            return;
        }
        let text = super::command_text(line);
        // The parser reads `M`, the number, then a space or the end (Marlin's `e_parser.h`).
        let Some((letter, rest)) = text.split_first() else { return };
        let digits = rest.iter().take_while(|b| b.is_ascii_digit()).count();
        let ends = rest.get(digits).is_none_or(u8::is_ascii_whitespace);
        if !letter.eq_ignore_ascii_case(&b'M') || !(1..=4).contains(&digits) || !ends {
            return;
        }
        let number = rest[..digits].iter().fold(0u32, |n, d| n * 10 + u32::from(d - b'0'));
        let command = gweave::Command::Code { letter: b'M', number, sub: None };
        if let Some(row) = super::commands::lookup(command, b"") {
            if let Some(urgent) = row.urgent.filter(|_| self.built_with(row)) {
                urgent(self, number, text, out);
            }
        }
    }

    /// Lines the host sends while a command runs reach the emergency parser through `lines`
    /// ([`EarlyLines`]), looked at between the steps of a heating wait.
    pub fn listen(&mut self, lines: EarlyLines) {
        self.early = Some(lines);
    }

    /// The emergency parser's look at what the host sent since the last look, while a command
    /// runs: `M108` ends a heating wait, `M112` kills (see [`Machine::emergency`]).
    pub(super) fn hear_early(&mut self, out: &mut dyn FnMut(f64, &str)) {
        let Some(early) = &self.early else { return };
        for line in early.take() {
            self.emergency(&line, out);
        }
    }

    /// Heaters off, halted until `M999`, as `M112` leaves the board.
    pub(super) fn kill(&mut self, out: &mut dyn FnMut(f64, &str)) {
        self.stop_motors();
        self.halt = Some(super::Halt::Emergency);
        self.heaters_off();
        out(self.now_s(), crate::thermal::protection::KILL_LINE);
    }

    /// The motors stop at once, as Marlin's `kill()` after `quick_stop()` (`M112`, a thermal
    /// fault): what the planner still held never runs, and the filament its moves were counted
    /// as feeding when they were queued is taken back (the queue holds one tool's moves: a
    /// tool change waits for the moves before it).
    pub(super) fn stop_motors(&mut self) {
        let undone_mm = self.core.quick_stop();
        self.filament_mm[self.tool] -= undone_mm;
    }

    /// The wait for the user ends (the emergency parser's `M108`, `M112`).
    pub(super) fn end_user_wait(&mut self) {
        self.host.waiting_for_user = false;
    }

    /// `M600`: pause and ask for the filament (steps 1 and 2 above).
    pub(super) fn m600(&mut self, out: &mut dyn FnMut(f64, &str)) {
        self.core.drain();
        self.sync(out);
        self.prompt(PromptReason::Info, "Pause", &["Dismiss"], out);
        let t = PARK_S + if self.thermal.hotend_count() > 0 { UNLOAD_S } else { 0.0 };
        self.park_for(t, out);
        out(self.now_s(), "echo:Insert filament and send M108");
        self.prompt(PromptReason::UserContinue, "Nozzle Parked", &["Continue"], out);
        self.host.waiting_for_user = true;
    }

    /// The user answered: load, purge, back to the print (step 3 above).
    pub fn finish_user_wait(&mut self, out: &mut dyn FnMut(f64, &str)) {
        self.host.waiting_for_user = false;
        if self.halt.is_some() {
            return;
        }
        self.park_for(PURGE_S, out);
        self.prompt(PromptReason::FilamentLoad, "Paused", &["PurgeMore", "Continue"], out);
        self.prompt_end(out);
        self.park_for(PARK_S, out);
    }

    /// Parking and filament moves: time on the clock, counted with homing in the report.
    pub(super) fn park_for(&mut self, t_s: f64, out: &mut dyn FnMut(f64, &str)) {
        self.core.idle(t_s);
        self.homing_s += t_s;
        self.sync(out);
    }

    /// `M876`: the host answered the open prompt (Marlin's `hostui.handle_response`).
    pub(super) fn answer_prompt(&mut self) {
        match self.host.prompt.take() {
            Some(PromptReason::UserContinue) => self.host.waiting_for_user = false,
            Some(PromptReason::PauseResume) => self.sd_resume(),
            Some(PromptReason::Info | PromptReason::FilamentLoad) | None => {}
        }
    }

    /// A host prompt as Marlin's `hostui.prompt_do` prints it (only with `prompt_support`).
    pub(super) fn prompt(
        &mut self,
        reason: PromptReason,
        message: &str,
        buttons: &[&str],
        out: &mut dyn FnMut(f64, &str),
    ) {
        if !self.profile.firmware.prompt_support {
            return;
        }
        self.prompt_end(out);
        self.host.prompt = Some(reason);
        let t = self.now_s();
        out(t, &format!("//action:prompt_begin {message}"));
        for b in buttons {
            out(t, &format!("//action:prompt_button {b}"));
        }
        out(t, "//action:prompt_show");
    }

    /// Closes the open prompt (`//action:prompt_end`).
    fn prompt_end(&mut self, out: &mut dyn FnMut(f64, &str)) {
        if self.profile.firmware.prompt_support {
            self.host.prompt = None;
            out(self.now_s(), "//action:prompt_end");
        }
    }
}
