//! The controller: the main loop's half of the firmware, tying the serial line, the commands,
//! the planner, the segment maker and the heaters together.
//!
//! One turn of the main loop is one [`Controller::poll`]: read the temperatures and run the
//! heaters (and feed the watchdog), cut planned moves into segments for the step interrupt,
//! carry on with the command that waits (homing, `M109`, `M400`, `G4`), and, when none waits,
//! run the next line. Nothing in a turn waits: a command that takes time is a state
//! (`Wait`) the next turns look at, so the heaters and the steppers are served all along.
//! The time comes in as an argument, so on the host every test is deterministic.

mod commands;
mod homing;
#[cfg(feature = "inkjet")]
mod inkjet;
mod mixing;
mod registry;
mod report;
mod soft_endstops;
#[cfg(test)]
mod tests;

use crate::heat::Heat;
use crate::mixing::Mixer;
use crate::planner::Planner;
use crate::serial::emergency::{Heard, Urgent};
use crate::serial::out::{line, Reply};
use crate::serial::protocol::{self, LineError};
use crate::serial::reader::LineReader;
use crate::settings::Settings;
use crate::stepper::prep::Prep;
use crate::stepper::{StepQueue, COUNTED_AXES};
use crate::{Inputs, Io, Outputs, AXES, BED, HEATERS};
use homing::Homing;
use soft_endstops::SoftEndstops;

/// Marlin's `DEFAULT_KEEPALIVE_INTERVAL`: while a command runs longer, the host hears
/// `echo:busy: processing` this often, so it knows the board is alive.
const KEEPALIVE_MS: u32 = 2_000;

/// How often `M109`/`M190` print the temperatures while they wait.
const HEAT_REPORT_MS: u32 = 1_000;

/// Marlin's `TEMP_WINDOW` / `TEMP_BED_WINDOW`: a wait for a temperature ends within this of it.
const TEMP_WINDOW_C: f32 = 1.0;

/// Marlin's `MIN_COOLING_SLOPE_DEG` and `MIN_COOLING_SLOPE_TIME` (hotend and bed alike): a wait
/// to cool down (`M109 R`, `M190 R`) gives up once the temperature fell less than this much in
/// that long, so a target below the room's (`M109 R10`) does not wait for ever.
const MIN_COOLING_SLOPE_C: f32 = 1.5;
const MIN_COOLING_SLOPE_MS: u32 = 60_000;

/// What the running command waits for before its `ok`.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Wait {
    /// Nothing: the next line may run.
    Nothing,
    /// The moves to finish (`M400`, `M84`, `M0`, before `G4`), then maybe a dwell (ms), and
    /// the motors to switch off then (`M84`, `M18`, `M0`: bits of [`Controller::motors`]).
    Moves { then_dwell_ms: u32, then_off: u8 },
    /// Until this time (ms).
    Dwell { until_ms: u32 },
    /// Heater `heater` to reach its target (`M109`, `M190`); `both_ways`: also to cool down
    /// to it (`R`), the temperature at the last cooling check and the next check's time.
    Heat { heater: u8, both_ways: bool, cooled_from_c: f32, check_ms: u32 },
    /// The homing sequence.
    Home(Homing),
    /// The moves to finish and the head to refill, then fire these nozzles (`M700`).
    #[cfg(feature = "inkjet")]
    Fire { head: u8, nozzles: u16 },
}

/// The controller core's main-loop half. See the crate's documentation for the board's side.
pub struct Controller<'q> {
    queue: &'q StepQueue,
    settings: Settings,
    reader: LineReader,
    /// The last line number taken (`N`).
    last_line: i32,
    planner: Planner,
    /// The mixing hotend's tools and shares (inert without one).
    mixer: Mixer,
    prep: Prep,
    heat: Heat,
    /// When each inkjet head last fired (`M700`).
    #[cfg(feature = "inkjet")]
    inkjet: crate::inkjet::Heads,
    /// Where the commands have put the head, mm (logical position).
    position_mm: [f32; AXES],
    /// Where E was last named (`G92 E`, `M92 E`), mm, and its motor's steps then: E's targets
    /// are counted in steps from there, so naming E never moves nor rounds the motor (see
    /// `Controller::target_steps`). X, Y and Z are named at 0 by homing, where the steps are 0.
    anchor_e_mm: f32,
    anchor_e_steps: i32,
    /// The rotary axis' angle, degrees, and where it was last named (`G92 A`) with its motor's
    /// steps then: counted from there as E is, so a program that re-declares the angle every
    /// hundred turns (`rotary tube`) loses no fraction of a step.
    position_a_deg: f32,
    anchor_a_deg: f32,
    anchor_a_steps: i32,
    /// `G93`: F is one over each move's time in minutes, this many moves a second (F / 60).
    inverse_time: Option<f32>,
    /// Axes whose coordinates are relative (`G91`, and `M83` for E; bit `1 << AXES`: A).
    relative: u8,
    /// The travel moves are kept within once homed (`M211`).
    soft_endstops: SoftEndstops,
    feed_mm_s: f32,
    fan_duty: u8,
    steppers_enabled: u8,
    wait: Wait,
    /// When the running command started, for the keepalive (ms).
    busy_since_ms: u32,
    next_report_ms: u32,
    /// `M155`: the temperatures are printed every so many seconds (0: never; at most 60, so
    /// a byte), next at `next_report_ms` (every second instead while `M109`/`M190` wait).
    auto_report_s: u8,
    /// What the emergency parser heard: an `M112` (halt before anything else), an `M108` (a
    /// heating wait ends).
    emergency: bool,
    continue_heard: bool,
    halted: bool,
    inputs: Inputs,
}

impl<'q> Controller<'q> {
    /// A controller at rest on `queue` (shared with the [`crate::Stepper`]) with `settings`
    /// (the board's build-time defaults; [`Controller::boot`] reads EEPROM over them).
    pub fn new(queue: &'q StepQueue, settings: Settings) -> Self {
        Controller {
            queue,
            settings,
            reader: LineReader::new(),
            last_line: 0,
            planner: Planner::new(),
            mixer: Mixer::new(settings.mixing_inputs),
            prep: Prep::new(),
            heat: Heat::default(),
            #[cfg(feature = "inkjet")]
            inkjet: crate::inkjet::Heads::new(),
            position_mm: [0.0; AXES],
            anchor_e_mm: 0.0,
            anchor_e_steps: 0,
            position_a_deg: 0.0,
            anchor_a_deg: 0.0,
            anchor_a_steps: 0,
            inverse_time: None,
            relative: 0,
            soft_endstops: SoftEndstops::new(),
            // Marlin's power-on feed rate: 1500 mm/min.
            feed_mm_s: 25.0,
            fan_duty: 0,
            steppers_enabled: 0,
            wait: Wait::Nothing,
            busy_since_ms: 0,
            next_report_ms: 0,
            auto_report_s: 0,
            emergency: false,
            continue_heard: false,
            halted: false,
            inputs: Inputs { now_ms: 0, adc: [0; HEATERS], endstops: 0 },
        }
    }

    /// Power-on: prints `start` (a host knows the board is up) and reads the settings kept in
    /// EEPROM, if any.
    pub fn boot(&mut self, io: &mut impl Io, inputs: &Inputs) {
        self.inputs = *inputs;
        line(io, b"start");
        // Only what `M500` keeps is read; the build's fixed facts (sizes, sensors) stay.
        let _ = self.settings.load(io);
        self.load_tools(io);
    }

    /// What the board's emergency parser heard as the bytes arrived, ahead of every queue
    /// ([`crate::serial::emergency`], run by the receive interrupt): an `M112` halts the board
    /// at the next turn, an `M108` ends a heating wait.
    pub fn heard(&mut self, heard: Heard) {
        self.emergency |= heard.has(Urgent::Kill);
        self.continue_heard |= heard.has(Urgent::Continue);
    }

    /// Takes one byte from the host into the line queue (the emergency parser heard it as it
    /// arrived: [`Controller::heard`]).
    /// Returns `false`, taking nothing, when the byte would end a line and the line queue is
    /// full: offer it again after the next [`Controller::poll`].
    #[must_use = "a byte refused must be offered again, or the line it ends is lost"]
    pub fn receive(&mut self, byte: u8) -> bool {
        self.reader.push(byte)
    }

    /// One turn of the main loop with the inputs read now.
    pub fn poll(&mut self, io: &mut impl Io, inputs: &Inputs) {
        self.inputs = *inputs;
        if self.emergency && !self.halted {
            self.kill(io, None);
        }
        if self.halted {
            // Only a reset helps; every line is answered so that the host does not wait.
            while self.reader.pop().is_some() {
                line(io, b"Error:Printer halted. kill() called!");
                line(io, b"ok");
            }
            return;
        }
        match self.heat.manage(&self.settings, &inputs.adc, inputs.now_ms) {
            Ok(true) => io.watchdog_feed(),
            Ok(false) => {}
            Err(fault) => return self.kill(io, Some(fault)),
        }
        self.prep.fill(&mut self.planner, self.queue);
        self.report_temperatures_when_due(io, inputs.now_ms);
        if !self.moving() {
            // The stepper's counts go on from the planner's coordinates (homing and `G92` name
            // new ones while nothing moves).
            self.queue.set_counted_steps(self.counted_when_idle());
        }
        self.carry_on(io);
        while self.wait == Wait::Nothing && !self.planner.is_full() {
            let Some(l) = self.reader.pop() else { break };
            self.busy_since_ms = inputs.now_ms;
            self.run_line(io, l.bytes(), l.too_long);
            self.prep.fill(&mut self.planner, self.queue);
            if self.halted {
                return;
            }
        }
        if self.wait != Wait::Nothing && inputs.now_ms.wrapping_sub(self.busy_since_ms) >= KEEPALIVE_MS {
            self.busy_since_ms = self.busy_since_ms.wrapping_add(KEEPALIVE_MS);
            line(io, b"echo:busy: processing");
        }
    }

    /// Checks a line's number and checksum, then runs it.
    fn run_line(&mut self, io: &mut impl Io, raw: &[u8], too_long: bool) {
        if too_long {
            return self.refuse(
                io,
                b"Error:Line too long, Last Line: ",
                protocol::line_number(raw).is_some(),
            );
        }
        let body = match protocol::check(raw, self.last_line) {
            Ok(checked) => {
                if let Some(n) = checked.number {
                    self.last_line = n;
                }
                checked.body
            }
            Err(e) => return self.refuse(io, LineError::message(e), true),
        };
        self.run_command(io, body);
    }

    /// Answers a refused line as Marlin: the error with the last line number, a request to send
    /// again from the next one (numbered lines), `ok`; the lines received after it are dropped,
    /// since the host sends them again.
    fn refuse(&mut self, io: &mut impl Io, message: &[u8], resend: bool) {
        Reply::new().s(message).i32(self.last_line).send(io);
        if resend {
            Reply::new().s(b"Resend: ").i32(self.last_line.wrapping_add(1)).send(io);
            self.reader.flush();
        }
        line(io, b"ok");
    }

    /// Continues the waiting command; prints its `ok` when it is done.
    fn carry_on(&mut self, io: &mut impl Io) {
        let now = self.inputs.now_ms;
        let done = match self.wait {
            Wait::Nothing => return,
            Wait::Moves { then_dwell_ms, then_off } => {
                if self.moving() {
                    false
                } else if then_off != 0 {
                    // The moves have ended: only now do the drivers let go (Marlin's `M84`
                    // waits with `planner.synchronize()`; a driver off mid-move loses steps).
                    self.steppers_enabled &= !then_off;
                    self.wait = Wait::Moves { then_dwell_ms, then_off: 0 };
                    then_dwell_ms == 0
                } else if then_dwell_ms > 0 {
                    self.wait = Wait::Dwell { until_ms: now.wrapping_add(then_dwell_ms) };
                    false
                } else {
                    true
                }
            }
            Wait::Dwell { until_ms } => (now.wrapping_sub(until_ms) as i32) >= 0,
            Wait::Heat { heater, both_ways, cooled_from_c, check_ms } => {
                let h = &self.heat.heaters[usize::from(heater)];
                let cooling = both_ways && h.temp_c > h.target_c;
                let stalled = cooling && (now.wrapping_sub(check_ms) as i32) >= 0 && {
                    let stalled = cooled_from_c - h.temp_c < MIN_COOLING_SLOPE_C;
                    let next_ms = now.wrapping_add(MIN_COOLING_SLOPE_MS);
                    self.wait = Wait::Heat { heater, both_ways, cooled_from_c: h.temp_c, check_ms: next_ms };
                    stalled
                };
                // `M108` heard: Marlin's `wait_for_heatup` cleared, the wait ends here.
                core::mem::take(&mut self.continue_heard)
                    || stalled
                    || h.target_c <= 0.0
                    || if both_ways {
                        self.heat.at_target(usize::from(heater), TEMP_WINDOW_C)
                    } else {
                        h.temp_c >= h.target_c - TEMP_WINDOW_C
                    }
            }
            #[cfg(feature = "inkjet")]
            Wait::Fire { head, nozzles } => self.fire_when_ready(io, head, nozzles),
            Wait::Home(mut homing) => {
                if self.moving() {
                    false
                } else {
                    let Ok(finished) = homing.next(self) else {
                        // Marlin's `STR_ERR_HOMING_FAILED`, then its `kill()`.
                        line(io, b"Error:Homing Failed");
                        return self.kill(io, None);
                    };
                    if !finished {
                        self.wait = Wait::Home(homing);
                        self.prep.fill(&mut self.planner, self.queue);
                    }
                    finished
                }
            }
        };
        if done {
            self.wait = Wait::Nothing;
            line(io, b"ok");
        }
    }

    /// The temperatures unasked, `M105`'s line without its `ok`: every second while `M109` or
    /// `M190` waits (Marlin's words while heating), else every `M155` interval (Marlin's
    /// auto-report), if one is set.
    fn report_temperatures_when_due(&mut self, io: &mut impl Io, now_ms: u32) {
        let interval_ms = if matches!(self.wait, Wait::Heat { .. }) {
            HEAT_REPORT_MS
        } else {
            u32::from(self.auto_report_s) * 1000
        };
        if interval_ms > 0 && (now_ms.wrapping_sub(self.next_report_ms) as i32) >= 0 {
            self.next_report_ms = now_ms.wrapping_add(interval_ms);
            let mut r = Reply::new();
            self.heat.report(&self.settings, &mut r);
            r.send(io);
        }
    }

    /// X, Y and Z's motors in steps when nothing moves: where the planned moves end.
    fn counted_when_idle(&self) -> [i32; COUNTED_AXES] {
        let mut xyz = [0; COUNTED_AXES];
        xyz.copy_from_slice(&self.planner.position_steps[..COUNTED_AXES]);
        xyz
    }

    /// Whether moves are planned, being cut or being stepped.
    fn moving(&self) -> bool {
        !self.planner.is_empty() || self.prep.is_busy() || !self.queue.is_idle()
    }

    /// Halts the machine: steps stop at the next interrupt, every heater and stepper is off,
    /// the fault (if any) and Marlin's `kill()` line are printed, and from now on every line is
    /// answered with that error. Only a reset (or the watchdog) brings the board back, with
    /// everything off. `fault`: the heater and what went wrong.
    pub fn kill(&mut self, io: &mut impl Io, fault: Option<(usize, crate::heat::safety::Fault)>) {
        self.queue.abort();
        // What the host sent before the halt is not run, nor answered.
        self.reader.flush();
        self.planner.clear();
        self.prep.clear();
        self.heat.all_off();
        self.fan_duty = 0;
        self.steppers_enabled = 0;
        self.halted = true;
        self.wait = Wait::Nothing;
        if let Some((heater, what)) = fault {
            let mut r = Reply::new();
            r.s(b"Error:").s(what.text()).s(b", system stopped! Heater_ID: ");
            if heater == BED {
                r.s(b"bed");
            } else {
                r.u32(heater as u32);
            }
            r.send(io);
        }
        line(io, b"Error:Printer halted. kill() called!");
    }

    /// Whether the machine is halted (after a fault or `M112`).
    pub fn is_halted(&self) -> bool {
        self.halted
    }

    /// What the board drives now.
    pub fn outputs(&self) -> Outputs {
        Outputs {
            heater_duty: self.heat.duties(),
            fan_duty: self.fan_duty,
            steppers_enabled: self.steppers_enabled,
        }
    }

    /// The settings in force.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The heaters' state (temperatures, targets, duties).
    pub fn heat(&self) -> &Heat {
        &self.heat
    }

    /// Where the commands have put the head (mm), moves still running included.
    pub fn position_mm(&self) -> [f32; AXES] {
        self.position_mm
    }

    /// The same in steps (the planner's position).
    pub fn position_steps(&self) -> [i32; AXES] {
        self.planner.position_steps
    }

    /// The rotary axis' angle (degrees) and its planner position (steps); `None` without one.
    pub fn position_a(&self) -> Option<(f32, i32)> {
        self.rotary().then_some((self.position_a_deg, self.planner.position_a_steps))
    }

    /// Whether the machine has a rotary axis ([`crate::rotary::Rotary::fitted`]).
    fn rotary(&self) -> bool {
        self.settings.rotary.fitted(self.settings.mixing_inputs)
    }
}
