//! The interpreter: a virtual Marlin-like printer that executes one command at a time on a
//! simulated clock.
//!
//! A line goes through the core parser and modal state ([`Estimator::lex`] and [`Estimator::apply`]), the machine
//! looks at what it does (refuses a cold extrusion, scales the feed by `M220` and the flow by
//! `M221`, warns about moves outside the build volume), and the motion core plans it
//! ([`Estimator::run`]): the lookahead planner streams blocks to the steppers, and the clock is
//! the end of the last executed block, as on a real board whose planner buffer runs behind the
//! commands it has acknowledged. Whatever makes the firmware wait (`G4`, `M400`, `M109`, `M190`,
//! `G28`, `M303`) drains the planner first. The heaters ([`Thermal`]) are advanced to the clock
//! after every command, so they heat, cool and trip their protection while the machine moves.
//!
//! ```
//! use gweave_sim::{Machine, Outcome};
//! use gweave_sim::MachineProfile;
//!
//! let mut m = Machine::new(MachineProfile::default()).unwrap();
//! let mut replies = Vec::new();
//! let mut out = |_t: f64, line: &str| replies.push(line.to_owned());
//! assert_eq!(m.execute(b"G1 X10 F3000", &mut out), Outcome::Ok);
//! assert_eq!(m.execute(b"M114", &mut out), Outcome::Ok);
//! assert_eq!(m.execute(b"G123", &mut out), Outcome::Ok);
//! assert_eq!(replies, [
//!     "X:10.00 Y:0.00 Z:0.00 E:0.00 Count X:800 Y:0 Z:0",
//!     "echo:Unknown command: \"G123\"",
//! ]);
//! ```
//!
//! Replies follow Marlin (`Marlin/src/core/language.h`, `Marlin/src/gcode/queue.cpp`): `M105` answers
//! `ok T:.. /.. B:.. /.. @:.. B@:..` itself (see [`Machine::acknowledged`]); every other command
//! leaves the final `ok` to the caller (the serial protocol or `gweave sim`).

pub(crate) mod commands;
mod heat;
mod host;
mod motion;
mod pause;
mod report;
mod sd;
mod settings;
mod warning_text;

use std::collections::BTreeMap;

use gweave::gcode::retraction::Retraction;
use gweave::gcode::state;
use gweave::{Block, Command};
use thiserror::Error;

use crate::inkjet::recoat::RecoatCheck;
use crate::inkjet::{CanvasGeometry, FireWait, InkjetCanvas, InkjetError, LayerSink};
use crate::link::early::EarlyLines;
use crate::motion::estimate::{EstimateError, Estimator, ToolChange};
use crate::motion::speed_trace::SpeedTrace;
use crate::profile::{FaultSpec, MachineProfile, MachineProfileError};
use crate::thermal::protection::ThermalFault;
use crate::thermal::{Thermal, ThermalError};

pub(crate) use commands::lookup;
use commands::Call;
pub(crate) use commands::Link;
pub use commands::{help_lines, CommandSpec, Param, Queue, COMMANDS};
pub use report::{HeaterStats, InkjetSummary, SimReport, SimTimes, SimWarning, WarningKind};

/// Marlin's reply to any command while stopped (`STR_ERR_STOPPED`).
pub const STOPPED_LINE: &str = "Error:Printer stopped due to errors. Fix the error and use M999 to restart. (Temperature is reset. Set it after restarting)";

/// Warnings kept with their details; later ones are only counted.
const MAX_WARNINGS: usize = 1000;

/// Why a machine cannot be built.
#[derive(Debug, Error)]
pub enum SimError {
    /// The profile is invalid.
    #[error(transparent)]
    Profile(#[from] MachineProfileError),
    /// The motion core rejected the motion profile.
    #[error(transparent)]
    Motion(#[from] EstimateError),
    /// The heaters could not be built.
    #[error(transparent)]
    Thermal(#[from] ThermalError),
    /// The inkjet canvas could not be built.
    #[error(transparent)]
    Inkjet(#[from] InkjetError),
    /// The printhead's recoat names axes the virtual printer cannot check.
    #[error("{0}")]
    Recoat(String),
}

/// What the machine is in after a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Ready for the next command.
    Ok,
    /// Stopped by a thermal fault or `M112`; every command but `M999` and the queries
    /// (`M105`, `M114`, `M115`, `M119`) is refused until `M999`.
    Halted,
}

/// Why the machine stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Halt {
    Thermal(ThermalFault),
    Emergency,
    /// The clock passed the run's limit ([`Machine::limit_clock`]).
    ClockLimit,
}

/// The virtual printer.
#[derive(Debug)]
pub struct Machine {
    profile: MachineProfile,
    core: Estimator,
    thermal: Thermal,
    inkjet: Option<InkjetCanvas>,
    /// The recoat check of a binder-jet machine whose printhead has a `[recoat]` table.
    recoat: Option<RecoatCheck>,
    /// An `M0` with the seed's behaviour ended the program (see [`Machine::program_ended`]).
    program_ended: bool,
    /// Physical minus logical X Y Z: `G92` moves the logical origin, homing resets it.
    shift_mm: [f64; 3],
    halt: Option<Halt>,
    /// The clock the machine stops at ([`Machine::limit_clock`]), s; infinite for a host's board.
    clock_limit_s: f64,
    /// Faults to inject, by time; `next_fault` is the first not yet injected.
    faults: Vec<FaultSpec>,
    next_fault: usize,
    /// `M155 S`: temperature auto-report period (0 = off) and the next report time.
    autoreport_s: f64,
    next_report_s: f64,
    feed_pct: f64,
    flow_pct: f64,
    /// The tool filament is counted for (`T<n>`), and the filament fed per tool, mm.
    tool: usize,
    filament_mm: Vec<f64>,
    /// The retraction in force per tool: what of the fed filament has not left the nozzle.
    retraction: Vec<Retraction>,
    homed: [bool; 3],
    acknowledged: bool,
    /// The last command is one hosts time by the wall clock (`M400`).
    wall_timed: bool,
    /// Settings beyond the planner's and heaters' (`M92`, `M207`-`M209`, `M851`, EEPROM).
    settings: settings::Settings,
    /// Job timer, prompts, pins, levelling.
    host: host::HostState,
    /// What the host sends while a command runs, for the emergency parser (`gweave serve`
    /// paced: [`Machine::listen`]).
    early: Option<EarlyLines>,
    sd: sd::SdCard,
    ended: bool,
    heating_s: f64,
    homing_s: f64,
    /// Time the host left the board alone ([`Machine::idle`]).
    idle_s: f64,
    thermal_faults: Vec<ThermalFault>,
    unknown: BTreeMap<String, u64>,
    warnings: Vec<SimWarning>,
    warning_counts: BTreeMap<&'static str, u64>,
}

/// Distinct unknown command names the report counts one by one; the rest count together as
/// [`UNKNOWN_OTHERS`].
pub const UNKNOWN_KINDS: usize = 256;
/// The report's name for unknown commands past the first [`UNKNOWN_KINDS`].
pub const UNKNOWN_OTHERS: &str = "(others)";
/// An unknown command's name is kept to this many characters.
const UNKNOWN_NAME_CHARS: usize = 32;

impl Machine {
    /// A machine at power-on: every axis at 0 (the endstops of the default profile), heaters at
    /// ambient, nothing homed.
    pub fn new(profile: MachineProfile) -> Result<Machine, SimError> {
        let mut profile = profile;
        profile.normalize()?;
        let core = Estimator::for_machine(&profile, true)?;
        let thermal = Thermal::new(profile.thermal.clone())?;
        let inkjet = match &profile.inkjet {
            None => None,
            Some(ink) => {
                let [width_px, height_px] = ink.canvas_px(&profile.bed);
                let geometry = CanvasGeometry {
                    origin_x_mm: ink.origin_x_mm,
                    origin_y_mm: ink.origin_y_mm,
                    width_px,
                    height_px,
                };
                Some(InkjetCanvas::new(&ink.printhead, geometry)?)
            }
        };
        let recoat = match &profile.inkjet {
            Some(ink) => match &ink.printhead.recoat {
                Some(r) => {
                    // The powder bed is the canvas the drops are recorded on.
                    let [w, h] = ink.canvas_px(&profile.bed);
                    let pitch = ink.printhead.pitch_mm();
                    let x = [ink.origin_x_mm, ink.origin_x_mm + w as f64 * pitch];
                    let y = [ink.origin_y_mm, ink.origin_y_mm + h as f64 * pitch];
                    Some(RecoatCheck::new(r, x, y).map_err(SimError::Recoat)?)
                }
                None => None,
            },
            None => None,
        };
        let steps = &profile.motion.steps;
        let settings = settings::Settings::new([steps.x, steps.y, steps.z, steps.e]);
        let mut faults = profile.faults.clone();
        faults.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        Ok(Machine {
            profile,
            core,
            thermal,
            inkjet,
            recoat,
            program_ended: false,
            shift_mm: [0.0; 3],
            halt: None,
            clock_limit_s: f64::INFINITY,
            faults,
            next_fault: 0,
            autoreport_s: 0.0,
            next_report_s: 0.0,
            feed_pct: 100.0,
            flow_pct: 100.0,
            tool: 0,
            filament_mm: vec![0.0],
            retraction: vec![Retraction::default()],
            homed: [false; 3],
            acknowledged: false,
            wall_timed: false,
            settings,
            host: host::HostState::default(),
            early: None,
            sd: sd::SdCard::default(),
            ended: false,
            heating_s: 0.0,
            homing_s: 0.0,
            idle_s: 0.0,
            thermal_faults: Vec::new(),
            unknown: BTreeMap::new(),
            warnings: Vec::new(),
            warning_counts: BTreeMap::new(),
        })
    }

    /// Reads the lines to come as `firmware` reads them: a file's, as `stats` reads it
    /// ([`gweave::gcode::flavour::read_firmware`]). Call before the first line; a host on the
    /// serial line is read as Marlin reads it.
    pub fn read_as(&mut self, firmware: gweave::Firmware) {
        self.core.read_as(firmware);
    }

    /// Reads the F of the moves to come as the rotary program's header declares them
    /// (`gweave::rotary::cylinder::RotaryConfig::from_stream_head`): a NIST or combined feed
    /// with the rotary axis A in degrees, or inverse time between `G93` and `G94` (see
    /// the estimator's [`Estimator::declare_rotary`], which `gweave estimate` uses too).
    pub fn declare_rotary(&mut self, machine: gweave::rotary::cylinder::RotaryConfig) {
        self.core.declare_rotary(machine);
    }

    /// Lines printed at power-on, as Marlin does: `start`, then `echo:` lines.
    pub fn boot_lines(&self) -> Vec<String> {
        vec![
            "start".to_owned(),
            format!("echo:gweave-sim {} (Marlin compatible)", env!("CARGO_PKG_VERSION")),
            format!("echo:Machine: {}", self.profile.name),
        ]
    }

    /// Skips a line longer than [`MAX_LINE`](gweave::gcode::reader::MAX_LINE), as firmware
    /// would refuse it: counted as malformed (call this for its last piece).
    pub fn skip_long_line(&mut self) {
        self.core.skip_long_line();
    }

    /// Executes ONE command (no N/checksum; comments allowed) at the current simulated time,
    /// advancing the simulated clock by what the command takes (moves through the planner,
    /// G4, M400, M109/M190 waits with the thermal plant, M303 autotune). Replies other than
    /// the final "ok" go to `out` with their simulated timestamps (e.g. M109 status lines once a
    /// second, M105/M114/M119 texts, `echo:Unknown command: "G123"`, Error: lines).
    pub fn execute(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) -> Outcome {
        self.execute_block(line, None, out)
    }

    /// Whether the lines given to [`Machine::execute_lexed`] must have the words of their plain
    /// moves listed ([`gweave::gcode::lexer::parse_line`]) rather than only in
    /// [`Block::plain`] ([`gweave::gcode::lexer::parse_line_lean`]): the firmware the file is
    /// read as decides ([`Machine::read_as`]).
    pub fn reads_words(&self) -> bool {
        self.core.state().reads_words()
    }

    /// [`Machine::execute`] for a line a file reader has lexed already, on another thread
    /// ([`gweave::gcode::lexed`]): `block` is what the lexer made of `line` (its plain moves'
    /// words listed as [`Machine::reads_words`] says), and gets back a block to reuse. The
    /// reader ends a line at any `\r` or `\n`, so the line is as [`Machine::execute`] trims
    /// it; the lexer only adds, to the first error of a last line without an ending, that the
    /// file may be cut there, which the machine counts alike.
    pub fn execute_lexed(
        &mut self,
        line: &[u8],
        block: &mut Block,
        out: &mut dyn FnMut(f64, &str),
    ) -> Outcome {
        self.execute_block(line, Some(block), out)
    }

    /// [`Machine::execute`] of `line`, lexed already into `lexed` if given.
    fn execute_block(
        &mut self,
        line: &[u8],
        lexed: Option<&mut Block>,
        out: &mut dyn FnMut(f64, &str),
    ) -> Outcome {
        self.acknowledged = false;
        self.wall_timed = false;
        let line = trim_line_end(line);
        if self.sd_write_line(line, out) {
            return self.outcome();
        }
        if self.host.waiting_for_user {
            // A run of a file has nobody to answer M600: the user pressed Continue at once.
            self.finish_user_wait(out);
        }
        if trim(line) == b"?" {
            // Before the parser, which has no word for it; answered even when halted.
            (commands::help_spec().run)(self, &Call { line, number: 0, before: [0.0; state::AXES] }, out);
            return self.outcome();
        }
        let before = self.core.state().pos;
        match lexed {
            Some(block) => self.core.take_lexed(block),
            None => self.core.lex(line),
        }
        let command = self.core.block().command;
        // The one lookup of the line's command: its words are checked against this row, and
        // it runs this row's handler.
        let spec = commands::lookup(command, self.core.block().command_span.of(line));
        if self.halt.is_some() && !spec.is_some_and(|s| s.while_halted) {
            // A stopped Marlin reads no destination and changes no mode (`G0_G1` reads its
            // words only `if (IsRunning())`): nothing of the line happens, so `M999` finds the
            // machine where and as it stopped.
            out(self.now_s(), STOPPED_LINE);
            return Outcome::Halted;
        }
        // A line without a command is checked against the modal motion's row instead.
        let row = |c: Command| {
            if c == command { spec } else { commands::lookup(c, b"") }.filter(|s| self.built_with(s))
        };
        if let Err(e) = commands::check_line(self.core.block(), line, self.core.state().motion, row) {
            // Nothing of the line happened: the values in force stay.
            self.refuse(e.to_string(), out);
            return self.outcome();
        }
        self.core.apply(line);
        match (command, spec) {
            // Junk where the command belongs: no command, so no modal move either.
            (Command::None, _) if self.core.block().starts_unreadable() => self.unknown_command(line, out),
            (Command::None, _) => self.motion(line, out),
            (Command::Code { number, .. }, Some(spec)) if self.built_with(spec) => {
                self.run_spec(spec, &Call { line, number, before }, out)
            }
            (Command::Extended, Some(spec)) => self.run_spec(spec, &Call { line, number: 0, before }, out),
            _ => self.unknown_command(line, out),
        }
        self.sync(out);
        self.timed_reports(out);
        self.outcome()
    }

    /// The auto-reports that are not the heaters' (`M154` position, `M27 S` SD status).
    fn timed_reports(&mut self, out: &mut dyn FnMut(f64, &str)) {
        self.timed_host_reports(out);
        self.timed_sd_reports(out);
    }

    /// Whether the last command is one hosts time by the wall clock: `M400`, which OctoPrint's
    /// pause sends before it queues the `M114` that completes the pause.
    pub fn wall_timed(&self) -> bool {
        self.wall_timed
    }

    /// Simulated time, s.
    pub fn now_s(&self) -> f64 {
        self.core.now_s()
    }

    /// Whether the last [`Machine::execute`] already sent its own `ok` line (`M105`, as Marlin
    /// answers `ok T:...` in one line): the caller must not send another.
    pub fn acknowledged(&self) -> bool {
        self.acknowledged
    }

    /// The profile the machine was built with (after filling derived defaults).
    pub fn profile(&self) -> &MachineProfile {
        &self.profile
    }

    /// The heaters, e.g. to read temperatures or inject a fault now
    /// (`thermal_mut().heater_mut(HeaterId::Hotend(0))?.inject(..)`).
    pub fn thermal(&self) -> &Thermal {
        &self.thermal
    }

    /// See [`Machine::thermal`].
    pub fn thermal_mut(&mut self) -> &mut Thermal {
        &mut self.thermal
    }

    /// The inkjet canvases, on a machine with a printhead.
    pub fn inkjet(&self) -> Option<&InkjetCanvas> {
        self.inkjet.as_ref()
    }

    /// Hands each finished inkjet layer to `sink` (`gweave sim --raster-out`), on a machine
    /// with a printhead; without a sink a finished layer is only cleared for the next.
    pub fn send_inkjet_layers_to(&mut self, sink: Box<dyn LayerSink>) {
        if let Some(canvas) = &mut self.inkjet {
            canvas.send_layers_to(sink);
        }
    }

    /// Why a finished inkjet layer could not be handed over: the sink's first failure (the
    /// layers after it were not handed over). Taken: a second call says nothing.
    pub fn take_inkjet_failure(&mut self) -> Option<InkjetError> {
        self.inkjet.as_mut().and_then(InkjetCanvas::take_failure)
    }

    /// Stops the machine once its clock passes `max_s`: the heaters are simulated up to it and
    /// no further, an `Error:` line and a `time_limit` warning say so, and the machine halts with
    /// its heaters off, as on a fault (a run of a file stops there). A run of a file is held to
    /// [`MAX_FILE_RUN_S`](crate::MAX_FILE_RUN_S); a host's board has no limit, its clock
    /// following the wall clock for as long as the server runs.
    pub fn limit_clock(&mut self, max_s: f64) {
        self.clock_limit_s = max_s;
    }

    /// Record the planned toolhead speed over time from now on (for the speed chart).
    pub fn record_speed(&mut self) {
        self.core.record_speed();
    }

    /// The planned speed over time, if [`Machine::record_speed`] was called.
    pub fn speed_trace(&self) -> Option<&SpeedTrace> {
        self.core.speed_trace()
    }

    /// Whether an `M0` ended the program (`[firmware] m0 = "seed"`): a run of a file stops
    /// there, and `gweave serve` closes the link.
    pub fn program_ended(&self) -> bool {
        self.program_ended
    }

    /// The logical position X Y Z E A (what `M114` prints), mm and degrees.
    pub fn position(&self) -> [f64; 5] {
        let p = self.core.state().pos;
        [p[state::X], p[state::Y], p[state::Z], p[state::E], p[state::A]]
    }

    /// The end of a job: plan and execute everything still queued (and, in Klipper mode, add
    /// Klipper's exit flush), and hand the last inkjet layer over. Later calls do nothing.
    pub fn finish(&mut self, out: &mut dyn FnMut(f64, &str)) {
        if !std::mem::replace(&mut self.ended, true) {
            self.core.end();
            self.sync(out);
            if let Some(canvas) = &mut self.inkjet {
                canvas.finish();
            }
            let mut unfinished = Vec::new();
            if let Some(check) = &self.recoat {
                check.finish(&mut unfinished);
            }
            for detail in unfinished {
                self.warn(WarningKind::Inkjet { detail });
            }
            // A fault asked for past the run's end never happened: said, not silently dropped.
            let end_s = self.now_s();
            let missed: Vec<WarningKind> = self.faults[self.next_fault..]
                .iter()
                .map(|spec| WarningKind::FaultNotInjected { fault: spec.to_string(), end_s })
                .collect();
            for warning in missed {
                self.warn(warning);
            }
        }
    }

    fn outcome(&self) -> Outcome {
        if self.halt.is_some() {
            Outcome::Halted
        } else {
            Outcome::Ok
        }
    }

    fn is_klipper(&self) -> bool {
        matches!(self.profile.motion.corners, crate::motion::limits::CornerMode::Klipper(_))
    }

    /// Plans what the line does (the effect the modal state made of it, as the handlers left it
    /// there); a refusal becomes an `echo:` reply and a warning.
    fn run_core(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        if let Err(e) = self.core.run_applied(line) {
            let message = match &e {
                EstimateError::Mixing { source, .. } => source.to_string(),
                EstimateError::Profile { source, .. } => source.to_string(),
                other => other.to_string(),
            };
            self.refuse(message, out);
        }
    }

    /// Says on the serial line and in the report that a command was not carried out.
    fn refuse(&mut self, message: String, out: &mut dyn FnMut(f64, &str)) {
        out(self.now_s(), &format!("echo:{message}"));
        self.warn(WarningKind::Refused { message });
    }

    /// Carries out a command of the registry: drains the planner first if it says so.
    fn run_spec(&mut self, spec: &CommandSpec, call: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
        if spec.queue == Queue::Drains {
            self.core.drain();
        }
        (spec.run)(self, call, out);
    }

    /// Whether this firmware build has the command: the build option its row needs
    /// (`[firmware]` options such as `sdcard`).
    pub(super) fn built_with(&self, spec: &CommandSpec) -> bool {
        self.profile.firmware.has(spec.needs)
    }

    /// `M220`/`M221`: set the percentage (`S`), or report it.
    fn percentage(
        &mut self,
        label: &str,
        out: &mut dyn FnMut(f64, &str),
        field: impl Fn(&mut Self) -> &mut f64,
    ) {
        match self.core.block().get(b'S') {
            Some(v) => *field(self) = v,
            None => {
                let v = *field(self);
                out(self.now_s(), &format!("echo:{label}{v:.0}%"));
            }
        }
    }

    fn tool_change(&mut self, line: &[u8], number: u32, out: &mut dyn FnMut(f64, &str)) {
        let mixing = self.profile.mixing_inputs > 0;
        let valid = if mixing {
            (number as usize) < gweave::colour::dialect::MARLIN_VIRTUAL_TOOLS
                || self.core.mixing().is_some_and(|m| m.rrf_mix(number).is_some())
        } else {
            self.profile.has_tool(number)
        };
        if !valid {
            // Marlin with several extruders synchronizes before it looks at the tool.
            if self.core.tool_change() == ToolChange::Synchronize {
                self.core.drain();
            }
            out(self.now_s(), &format!("echo:T{number} Invalid extruder"));
            self.warn(WarningKind::InvalidExtruder { tool: number });
            return;
        }
        // The core waits for the queued moves if the firmware does ([`ToolChange`]).
        self.run_core(line, out);
        if !mixing {
            // Checked above: the hotend exists (the one nozzle, for a tool of a single nozzle).
            let _ = self.thermal.set_active_extruder(self.profile.hotend_of_tool(number as usize));
        }
        self.tool = number as usize;
        if self.filament_mm.len() <= self.tool {
            self.filament_mm.resize(self.tool + 1, 0.0);
            self.retraction.resize(self.tool + 1, Retraction::default());
        }
    }

    /// `M700 P<head> S<bits>` / `M578`: record the drops at the carriage position; the
    /// estimator counts the firmware's wait after the fire (`inkjet`'s notes, [`FireWait`]).
    fn fire(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        let b = self.core.block();
        let head = b.get(b'P').map(FireWait::head);
        let bits = b.get(b'S').map_or(0, |s| s.max(0.0) as u64);
        let [x, y, z] = self.physical_xyz();
        let moved = self.core.moved_since_m400();
        let Some(canvas) = &mut self.inkjet else {
            return;
        };
        let mut found = Vec::new();
        canvas.on_m700(head, bits, [x, y, z], moved, &mut found);
        if let Some(check) = &mut self.recoat {
            let a = self.core.state().pos[state::A];
            check.on_fire([x, y, z, a], z, &mut found);
        }
        for detail in found {
            self.warn(WarningKind::Inkjet { detail });
        }
        self.run_core(line, out);
    }

    /// Counts an unknown command by its name in the report (the first [`UNKNOWN_KINDS`] names;
    /// a file of garbage would otherwise grow the table without bound) and says so, as Marlin.
    fn unknown_command(&mut self, line: &[u8], out: &mut dyn FnMut(f64, &str)) {
        let text = String::from_utf8_lossy(command_text(line)).into_owned();
        out(self.now_s(), &format!("echo:Unknown command: \"{text}\""));
        let mut name: String =
            text.split_whitespace().next().unwrap_or("").chars().take(UNKNOWN_NAME_CHARS).collect();
        if self.unknown.len() >= UNKNOWN_KINDS - 1 && !self.unknown.contains_key(&name) {
            name = UNKNOWN_OTHERS.to_owned();
        }
        *self.unknown.entry(name).or_default() += 1;
        self.warn(WarningKind::UnknownCommand { command: text });
    }

    /// The file ended at the last line executed without its slicer's last line and without a
    /// line ending: it looks cut short ([`WarningKind::Truncated`]).
    pub(crate) fn file_cut(&mut self, footer: gweave::gcode::ends::Footer) {
        self.warn(WarningKind::Truncated { footer });
    }

    /// An auto-report's period, the line's `S` (`M27`, `M154`, `M155`): whole seconds, as
    /// Marlin reads it (`parser.value_byte()`), so `S0.5` is 0, off. Read as a fraction,
    /// `M155 S0.000001` sent the host a report every simulated microsecond.
    fn report_period_s(&self) -> Option<f64> {
        self.core.block().get(b'S').map(f64::trunc)
    }

    fn warn(&mut self, kind: WarningKind) {
        *self.warning_counts.entry(kind.name()).or_default() += 1;
        if self.warnings.len() < MAX_WARNINGS {
            self.warnings.push(SimWarning { line: self.core.line_number(), t_s: self.now_s(), kind });
        }
    }

    fn heaters_off(&mut self) {
        self.thermal.all_off();
    }

    fn physical_xyz(&self) -> [f64; 3] {
        let p = self.core.state().pos;
        std::array::from_fn(|i| p[i] + self.shift_mm[i])
    }
}

fn trim_line_end(line: &[u8]) -> &[u8] {
    let end = line.iter().rposition(|&b| b != b'\n' && b != b'\r').map_or(0, |i| i + 1);
    &line[..end]
}

fn trim(s: &[u8]) -> &[u8] {
    let start = s.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(s.len());
    let end = s.iter().rposition(|b| !b.is_ascii_whitespace()).map_or(start, |i| i + 1);
    &s[start..end]
}

/// The command as Marlin quotes it: the line without its comment, trimmed.
fn command_text(line: &[u8]) -> &[u8] {
    let code = line.split(|&b| b == b';').next().unwrap_or(line);
    trim(code)
}

#[cfg(test)]
mod firmware_tests;
#[cfg(test)]
mod params_tests;
#[cfg(test)]
mod tests;
