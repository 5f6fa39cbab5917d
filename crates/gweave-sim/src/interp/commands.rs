//! The command registry of the virtual printer: every command (or family of codes handled
//! together) is declared ONCE here, with its codes, its help line, its handler, whether it waits
//! for the queued moves and whether a halted board still answers it. The interpreter dispatches
//! through this table alone ([`lookup`]); the reply to `?` (the seed controller's help) and the
//! table in `docs/gcode.md` come from it, and tests keep both equal to it and check that every
//! code it lists is carried out and every code it does not list is unknown.
//!
//! Marlin lays its commands out the same way (`Marlin/src/gcode/gcode.cpp`'s
//! `process_parsed_command`, one file per command family under `Marlin/src/gcode/`); adding a
//! command here is one row plus its handler (see `docs/architecture.md`, "Adding a command to
//! the virtual printer").
//!
//! Every number word a command reads has a physical range, declared in its row
//! ([`CommandSpec::params`]). The dispatcher checks them before the line changes anything and
//! refuses a value outside with one uniform reply, `echo:M155 S = -1 is out of range: 0 to
//! 86400 s` (the range's own text from `gweave::range`), keeping the value in force, as Marlin
//! echoes a bad parameter instead of acting on it. A handler reads its words knowing they are
//! in range.

use std::collections::HashMap;
use std::sync::OnceLock;

use gweave::firmware::MixingCode;
use gweave::gcode::line::{Block, Command, Value};
use gweave::gcode::state::{self, Effect};
use gweave::range::{self, OutOfRange, Range};

use super::Machine;
use crate::motion::limits;
use crate::thermal::control;

/// What a handler is given: the line, the code's number, what the line does to the modal state
/// and the logical position before it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Call<'a> {
    /// The raw line (without its line end).
    pub line: &'a [u8],
    /// The code's number (`104` for `M104`, the tool for `T<n>`; 0 for a named command).
    pub number: u32,
    /// What the modal state made of the line.
    pub effect: Effect,
    /// The logical position before the line.
    pub before: state::Position,
}

/// A command's handler: carries the command out on the machine, replies through `out`.
pub(super) type Handler = fn(&mut Machine, &Call<'_>, &mut dyn FnMut(f64, &str));

/// Whether a command waits for the moves queued before it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Queue {
    /// Runs in order behind the queued moves, which keep streaming through the planner (a
    /// handler whose wait depends on its words, `M109`, `G28`, `T<n>`, drains the planner itself
    /// once it knows it will run).
    Streams,
    /// The dispatcher drains the planner (every queued move is executed) before the handler
    /// runs, as Marlin's `planner.synchronize()` at the top of `M114`, `M400`...
    Drains,
}

/// One entry of the registry: the codes it covers, what the virtual printer does with them,
/// and how.
#[derive(Clone, Copy)]
pub struct CommandSpec {
    /// The codes, space-separated, as written in G-code (`G0 G1`, `T<n>`, `?`).
    pub codes: &'static str,
    /// What the virtual printer does with them, one line (the `?` reply and `docs/gcode.md`).
    pub what: &'static str,
    /// Carries the command out.
    pub(super) run: Handler,
    /// A halted board (thermal fault, `M112`) still answers it; every other command gets
    /// [`STOPPED_LINE`](super::STOPPED_LINE) until `M999`.
    pub while_halted: bool,
    /// Whether it waits for the queued moves.
    pub queue: Queue,
    /// The number words it reads and the values each may take: the dispatcher refuses the
    /// whole line before it changes anything if one is outside (`check`).
    pub params: &'static [Param],
}

/// Number words of a command that share one physical range.
#[derive(Debug, Clone, Copy)]
pub struct Param {
    /// The letters (`"XYZE"` for `M92`'s steps per unit).
    pub letters: &'static str,
    /// What each may be.
    pub range: Range,
}

/// Words `letters`, each in `range`.
const fn p(letters: &'static str, range: Range) -> Param {
    Param { letters, range }
}

impl std::fmt::Debug for CommandSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CommandSpec")
            .field("codes", &self.codes)
            .field("while_halted", &self.while_halted)
            .field("queue", &self.queue)
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

// The ranges of the words. Most are the engine's (`gweave::range`) or those the machine profile
// is checked against (`motion::limits`, `thermal::control`): a value the profile would refuse
// is refused on the serial line too.

/// `M220`/`M221` percentages: above 0, at most a hundred times the speed or flow.
const PERCENT: Range = Range::new(1.0, 10_000.0, "%");
/// `M73 P`: a print's progress.
const PROGRESS_PCT: Range = Range::new(0.0, 100.0, "%");
/// `G4 P`: a dwell in milliseconds, up to [`range::PERIOD_S`] (a day).
const DWELL_MS: Range = Range::new(0.0, range::PERIOD_S.max * 1000.0, "ms");
/// A hotend or tool index (`M104 T`, `G10 P`, `M301 E`): a byte, as the heater index is; one
/// the machine does not have is Marlin's `Invalid extruder`.
const TOOL: Range = Range::new(0.0, 255.0, "");

/// The words of the commands that take a period.
const PERIOD: &[Param] = &[p("S", range::PERIOD_S)];
/// RepRapFirmware's tool temperature, `G10 P<tool> S<active> R<standby>` and `M568`.
const TOOL_TEMP: &[Param] = &[p("P", TOOL), p("SR", range::TEMPERATURE_C)];

/// Every command the interpreter carries out, in the order of the help listing.
pub const COMMANDS: &[CommandSpec] = &[
    CommandSpec { codes: "G0 G1", what: "linear move (G0 a travel), through the lookahead planner and the steppers", run: motion, while_halted: false, queue: Queue::Streams, params: &[p("F", range::FEED_MM_MIN)] },
    CommandSpec { codes: "G2 G3", what: "arc clockwise / counter-clockwise in XY (I J centre or R), planned as 1 mm chords", run: motion, while_halted: false, queue: Queue::Streams, params: &[p("F", range::FEED_MM_MIN), p("IJR", range::POSITION_MM)] },
    CommandSpec { codes: "G4", what: "dwell P milliseconds or S seconds, after the queued moves", run: dwell, while_halted: false, queue: Queue::Streams, params: &[p("S", range::PERIOD_S), p("P", DWELL_MS)] },
    CommandSpec { codes: "G10 G11", what: "firmware retract / recover (45 / 8 mm/s), Marlin's `G10 S1` too; G10 with P (tool) and S sets a tool temperature (RepRapFirmware)", run: g10_g11, while_halted: false, queue: Queue::Streams, params: TOOL_TEMP },
    CommandSpec { codes: "G20 G21", what: "inches / millimetres", run: core, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "G28", what: "home the named axes (all without words) against the endstops, with Marlin's bump", run: home, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "G29", what: "bed levelling (firmware.mesh): probe the grid in simulated time, store a flat mesh, levelling on", run: g29, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "G90 G91", what: "absolute / relative coordinates (E too)", run: core, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "G92", what: "set the logical position without moving", run: set_position, while_halted: false, queue: Queue::Streams, params: &[p("XYZ", range::POSITION_MM)] },
    CommandSpec { codes: "G93 G94", what: "inverse-time feed (F = 1 / minutes of each move) / units per minute, in a rotary program (its header's feed convention)", run: feed_mode, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M0 M1", what: "program stop: finish the moves, motors off; with m0 = \"seed\" also home and end the program", run: program_stop, while_halted: false, queue: Queue::Drains, params: &[] },
    CommandSpec { codes: "M17 M18 M84", what: "motors on (accepted) / off (the axes must be homed again)", run: motors, while_halted: false, queue: Queue::Streams, params: PERIOD },
    CommandSpec { codes: "M20 M21 M22", what: "SD card (firmware.sdcard, serve --sd DIR): list files (L: long names), mount, release", run: sd, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M23 M24 M25 M26", what: "SD print: select a file, start/resume, pause, set the byte position", run: sd, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M27", what: "SD print status (S<n>: every n s)", run: sd, while_halted: false, queue: Queue::Streams, params: PERIOD },
    CommandSpec { codes: "M28 M29 M30 M32 M33", what: "SD upload to a file / end it, delete a file, select and start, long name of a file", run: sd, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M31", what: "print job time", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M42", what: "set a pin (firmware.pin_control): P pin, S value", run: host, while_halted: false, queue: Queue::Streams, params: &[p("S", range::PWM)] },
    CommandSpec { codes: "M226", what: "wait for a pin state (firmware.pin_control)", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M73", what: "progress (accepted)", run: accepted, while_halted: false, queue: Queue::Streams, params: &[p("P", PROGRESS_PCT)] },
    CommandSpec { codes: "M117", what: "status message, sent to the host as //action:notification", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M75 M76 M77", what: "print job timer start / pause / stop", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M80 M81", what: "power on (firmware.psu_control) / off: heaters and motors off", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M82 M83", what: "absolute / relative extrusion", run: core, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M92", what: "steps per unit X Y Z E of the steppers", run: settings, while_halted: false, queue: Queue::Streams, params: &[p("XYZE", range::STEPS_PER_UNIT)] },
    CommandSpec { codes: "M104 M109", what: "hotend target (T picks the hotend), M109 also waits: S while heating, R both ways", run: hotend_target, while_halted: false, queue: Queue::Streams, params: &[p("SRP", range::TEMPERATURE_C), p("T", TOOL)] },
    CommandSpec { codes: "M105", what: "report temperatures and heater powers: ok T:.. /.. B:.. /.. @:.. B@:..", run: m105, while_halted: true, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M106 M107", what: "part fan speed / off (the fan cools the hotend)", run: fan, while_halted: false, queue: Queue::Streams, params: &[p("SP", range::PWM)] },
    CommandSpec { codes: "M108 M410", what: "emergency parser: break a wait / quick stop (accepted: waits end by themselves)", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M110", what: "set the line number (serial protocol)", run: accepted, while_halted: true, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M112", what: "emergency stop: heaters off, halted until M999", run: emergency_stop, while_halted: true, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M114", what: "position and motor counts after the queued moves", run: m114, while_halted: true, queue: Queue::Drains, params: &[] },
    CommandSpec { codes: "M115", what: "firmware name, extruder count and the capabilities of the [firmware] table", run: m115, while_halted: true, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M116", what: "wait for every heater with a target (RepRapFirmware)", run: m116, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M118", what: "print a message to the host (A1: // prefix, E1: echo: prefix)", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M119", what: "endstop states", run: m119, while_halted: true, queue: Queue::Drains, params: &[] },
    CommandSpec { codes: "M140 M190", what: "bed target, M190 also waits: S while heating, R both ways", run: bed_target, while_halted: false, queue: Queue::Streams, params: &[p("SRP", range::TEMPERATURE_C)] },
    CommandSpec { codes: "M154", what: "report the position every S seconds (firmware.autoreport_pos)", run: host, while_halted: false, queue: Queue::Streams, params: PERIOD },
    CommandSpec { codes: "M155", what: "report temperatures every S seconds (0: off)", run: m155, while_halted: false, queue: Queue::Streams, params: PERIOD },
    CommandSpec { codes: "M163 M164 M165 M166", what: "mixing: set a weight, store a virtual tool, mix at once, gradient (accepted)", run: mixing, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M201", what: "maximum acceleration per axis", run: core, while_halted: false, queue: Queue::Streams, params: &[p("XYZE", range::ACCEL_MM_S2), p("A", limits::ACCEL_DEG_S2)] },
    CommandSpec { codes: "M203", what: "maximum feed rate per axis", run: core, while_halted: false, queue: Queue::Streams, params: &[p("XYZE", range::SPEED_MM_S), p("A", limits::SPEED_DEG_S)] },
    CommandSpec { codes: "M204", what: "print (P, S) / retract (R) / travel (T) acceleration", run: core, while_halted: false, queue: Queue::Streams, params: &[p("SPRT", range::ACCEL_MM_S2)] },
    CommandSpec { codes: "M205", what: "junction deviation (J) or classic jerk (X Y Z E), minimum segment time (B), minimum feed rates (S T)", run: m205, while_halted: false, queue: Queue::Streams, params: &[p("XYZE", limits::JERK_MM_S), p("J", limits::JUNCTION_DEVIATION_MM), p("B", limits::MIN_SEGMENT_TIME_US), p("ST", range::SPEED_MM_S.or_zero())] },
    CommandSpec { codes: "M207 M208 M209", what: "firmware retraction: retract length (the planner's G10), recover, auto-retract", run: settings, while_halted: false, queue: Queue::Streams, params: &[p("SWZ", range::LEN_MM), p("F", range::FEED_MM_MIN)] },
    CommandSpec { codes: "M211", what: "software endstops on/off and their limits", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M220 M221", what: "feed rate / flow percentage (no S: report it)", run: percentage, while_halted: false, queue: Queue::Streams, params: &[p("S", PERCENT)] },
    CommandSpec { codes: "M300", what: "beep (accepted)", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M301", what: "set or report the hotend PID gains", run: m301, while_halted: false, queue: Queue::Streams, params: &[p("PID", control::GAIN), p("E", TOOL)] },
    CommandSpec { codes: "M303", what: "PID autotune on the thermal plant (relay method), U1 applies the gains", run: m303, while_halted: false, queue: Queue::Drains, params: &[p("S", range::TEMPERATURE_C)] },
    CommandSpec { codes: "M304", what: "set or report the bed PID gains", run: settings, while_halted: false, queue: Queue::Streams, params: &[p("PID", control::GAIN)] },
    CommandSpec { codes: "M400", what: "wait for the queued moves to finish; its ok takes that time in wall time too (hosts time it)", run: m400, while_halted: false, queue: Queue::Drains, params: &[] },
    CommandSpec { codes: "M420", what: "bed levelling on/off (S), mesh report (V)", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M500 M501 M502 M503", what: "settings: save to / load from the EEPROM file, factory defaults, report", run: settings, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M524", what: "abort the SD print", run: sd, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M563 M567", what: "tool definition (accepted) and mix ratios (RepRapFirmware)", run: mixing, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M568", what: "tool temperature, as G10 P S (RepRapFirmware 3.3+; on a mixing hotend, the nozzle's)", run: rrf_tool_temperature, while_halted: false, queue: Queue::Streams, params: TOOL_TEMP },
    CommandSpec { codes: "M600", what: "filament change (firmware.advanced_pause): park, host prompts, wait for M108 / M876 S0, purge, resume", run: m600, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M851", what: "probe offsets X Y Z (firmware.probe)", run: settings, while_halted: false, queue: Queue::Streams, params: &[p("XYZ", range::POSITION_MM)] },
    CommandSpec { codes: "M876", what: "answer a host prompt (firmware.prompt_support)", run: host, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M928", what: "log the following commands to an SD file until M29", run: sd, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M578 M700", what: "inkjet fire at the carriage position (machines with a printhead)", run: fire, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "M999", what: "restart after a halt", run: restart, while_halted: true, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "T<n>", what: "select a tool (a virtual mixing tool on a mixing hotend)", run: tool_change, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "SET_VELOCITY_LIMIT SET_KINEMATIC_POSITION", what: "Klipper's limits and position (Klipper mode)", run: klipper, while_halted: false, queue: Queue::Streams, params: &[] },
    CommandSpec { codes: "?", what: "this list", run: help, while_halted: true, queue: Queue::Streams, params: &[] },
];

/// The `?` reply: a title line, then `echo:  <codes>  <what>` per command.
pub fn help_lines() -> Vec<String> {
    std::iter::once("echo:gweave-sim commands:".to_owned())
        .chain(COMMANDS.iter().map(|c| format!("echo:  {:<19}  {}", c.codes, c.what)))
        .collect()
}

/// A code as the registry's index keys it.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
enum Key {
    /// `G<n>` or `M<n>`.
    Code(u8, u32),
    /// `T<n>`, any n.
    Tool,
    /// A named (Klipper-style) command, upper case.
    Named(String),
    /// `?`.
    Help,
}

impl Key {
    fn parse(code: &str) -> Key {
        match code {
            "T<n>" => Key::Tool,
            "?" => Key::Help,
            _ => match (code.as_bytes()[0], code[1..].parse::<u32>()) {
                (letter @ (b'G' | b'M'), Ok(n)) => Key::Code(letter, n),
                _ => Key::Named(code.to_owned()),
            },
        }
    }
}

/// `G` and `M` codes below this are found in a table, not by hashing: every line of a print
/// looks its command up, and SipHash of the key took 7 % of `gweave sim`.
const TABLE_CODES: u32 = 1000;

/// The registry's index: every code by key, and the `G` and `M` codes below [`TABLE_CODES`]
/// again in a table (the same entries).
struct Index {
    keys: HashMap<Key, usize>,
    /// `G<n>` at `n`, `M<n>` at `TABLE_CODES + n`.
    table: Vec<Option<usize>>,
}

/// Where `letter` `number` is in [`Index::table`], if it is there.
fn table_slot(letter: u8, number: u32) -> Option<usize> {
    let base = match letter {
        b'G' => 0,
        b'M' => TABLE_CODES,
        _ => return None,
    };
    (number < TABLE_CODES).then(|| (base + number) as usize)
}

/// The registry's entry for a parsed command (`name`: a named command's text), if it has one.
pub(super) fn lookup(command: Command, name: &[u8]) -> Option<&'static CommandSpec> {
    static INDEX: OnceLock<Index> = OnceLock::new();
    let index = INDEX.get_or_init(|| {
        let keys: HashMap<Key, usize> = COMMANDS
            .iter()
            .enumerate()
            .flat_map(|(i, c)| c.codes.split_whitespace().map(move |code| (Key::parse(code), i)))
            .collect();
        let mut table = vec![None; 2 * TABLE_CODES as usize];
        for (key, &i) in &keys {
            if let Key::Code(letter, number) = key {
                if let Some(slot) = table_slot(*letter, *number) {
                    table[slot] = Some(i);
                }
            }
        }
        Index { keys, table }
    });
    let key = match command {
        Command::Code { letter: letter @ (b'G' | b'M'), number, sub: None } => {
            if let Some(slot) = table_slot(letter, number) {
                return index.table[slot].map(|i| &COMMANDS[i]);
            }
            Key::Code(letter, number)
        }
        Command::Code { letter: b'T', sub: None, .. } => Key::Tool,
        Command::Extended => Key::Named(String::from_utf8_lossy(name).to_ascii_uppercase()),
        _ => return None,
    };
    index.keys.get(&key).map(|&i| &COMMANDS[i])
}

/// The registry's entry for `?`.
pub(super) fn help_spec() -> &'static CommandSpec {
    COMMANDS.iter().find(|c| c.codes == "?").expect("`?` is in the registry")
}

/// Refuses a line whose words are outside what `params` declares, before it changes anything
/// (as GRBL's parser checks a whole line first): the first such word as the uniform reply,
/// `M104 S = 600 is out of range: 0 to 500 °C`. `code` names the command (`M104`); a word that
/// is not a number (`Snan`, `S1..2`) is outside every range, written as it was.
pub(super) fn check(code: (u8, u32), params: &[Param], block: &Block, line: &[u8]) -> Result<(), OutOfRange> {
    for param in params {
        for letter in param.letters.bytes() {
            let Some(word) = block.word(letter) else { continue };
            let name = || format!("{}{} {}", code.0 as char, code.1, letter as char);
            match word.value {
                Value::Number(v) => {
                    param.range.check(&name(), v)?;
                }
                Value::Invalid => {
                    let written = word.span.of(line).get(1..).unwrap_or_default();
                    return Err(OutOfRange {
                        name: name(),
                        value: String::from_utf8_lossy(written).into_owned(),
                        range: param.range.to_string(),
                    });
                }
                // A bare letter (`G28 X`), a quoted string or an expression (RepRapFirmware's
                // `{...}`) is not a number the command reads.
                Value::Empty | Value::Text(_) | Value::Expr(_) => {}
            }
        }
    }
    Ok(())
}

// The handlers. Families handled by one method of their own module (`sd`, `host`,
// `settings`) pass the code's number on; the rest are one method or a few lines each.

fn motion(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.motion(c.line, c.effect, out)
}

fn core(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.run_core(c.line, &c.effect, out)
}

fn dwell(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    match c.effect {
        Effect::Dwell { t_s } if t_s > super::motion::MAX_COMMAND_S => {
            m.refuse(format!("a dwell of {t_s:.0} s: refused"), out)
        }
        _ => {
            m.thermal.set_moving(false);
            m.run_core(c.line, &c.effect, out);
            m.moved_since_m400 = false;
        }
    }
}

/// RepRapFirmware's `G10 P<tool> S<temp>` sets a tool's temperature; the state says which `G10`
/// is which (Marlin's `G10 S1` is a retraction).
fn g10_g11(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if c.number == 10 && m.core.state().g10_is_not_a_retraction(m.core.block()) {
        m.rrf_tool_temperature(out)
    } else {
        m.run_core(c.line, &c.effect, out)
    }
}

fn home(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.home(c.line, c.effect, &c.before, out)
}

fn g29(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.g29(out)
}

/// `G93`/`G94`: the F of the moves to come is inverse time or per minute. Read in a rotary
/// program (one whose header the simulator honours, [`Machine::declare_rotary`]); elsewhere
/// accepted and F keeps the firmware model's reading.
fn feed_mode(m: &mut Machine, c: &Call<'_>, _out: &mut dyn FnMut(f64, &str)) {
    if let Some(declared) = &mut m.declared_feed {
        declared.inverse_time = c.number == 93;
    }
}

/// `G92`: the machine stays where it is; what changes is the logical origin.
fn set_position(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    let pos = m.core.state().pos;
    for (shift, (before, now)) in m.shift_mm.iter_mut().zip(c.before.iter().zip(pos)) {
        *shift += before - now;
    }
    m.run_core(c.line, &c.effect, out);
}

/// `M0`/`M1`: finish the moves (drained before), motors off; the controller seed's `M0` also
/// homes and ends the program.
fn program_stop(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.run_core(c.line, &c.effect, out);
    if c.number == 0 && m.profile.firmware.m0 == crate::profile::firmware::ProgramStop::Seed {
        m.execute(b"G28", out);
        // The motors go off again after the homing: the axes are no longer homed.
        m.homed = [false; 3];
        m.program_ended = true;
    } else {
        m.homed = [false; 3];
    }
}

/// `M17` (accepted: motors are on when they move), `M18`/`M84` motors off after the moves
/// (`S`: an idle timeout, the axes stay homed).
fn motors(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if c.number == 17 {
        return;
    }
    m.run_core(c.line, &c.effect, out);
    m.core.drain();
    if !m.core.block().has(b'S') {
        m.homed = [false; 3];
    }
}

fn sd(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.sd_command(c.line, c.number, out)
}

fn host(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.host_command(c.line, c.number, out)
}

fn settings(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.settings_command(c.number, out)
}

/// Accepted, nothing to simulate (`M73`: the progress is the host's; `M110`: the line numbers
/// are the serial layer's).
fn accepted(_: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {}

fn hotend_target(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.hotend_target(c, out)
}

fn bed_target(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.bed_target(c, out)
}

fn m105(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m105(out)
}

fn fan(m: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    let fan = m.core.state().thermal.fan;
    m.thermal.set_fan(fan);
}

fn m116(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m116(c, out)
}

fn m155(m: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    m.m155()
}

fn m301(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m301(out)
}

fn m303(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m303(out)
}

/// `M112`: heaters off, halted until `M999`.
fn emergency_stop(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.halt = Some(super::Halt::Emergency);
    m.heaters_off();
    out(m.now_s(), crate::thermal::protection::KILL_LINE);
}

fn m114(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.sync(out);
    let text = m.m114_text();
    out(m.now_s(), &text);
}

fn m115(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    let t = m.now_s();
    out(
        t,
        &format!(
            "FIRMWARE_NAME:gweave-sim {} (Marlin compatible) PROTOCOL_VERSION:1.0 \
             MACHINE_TYPE:{} EXTRUDER_COUNT:{}",
            env!("CARGO_PKG_VERSION"),
            m.profile.name,
            m.thermal.hotend_count()
        ),
    );
    for cap in m.profile.firmware.capability_lines() {
        out(t, &cap);
    }
}

fn m119(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.sync(out);
    for l in m.m119_lines() {
        out(m.now_s(), &l);
    }
}

/// The mixing codes ([`MixingCode`]): those that set a mix (Marlin's `M163`-`M165`,
/// RepRapFirmware's `M567`) go to the mixer of the motion core; a gradient (`M166`) and an RRF
/// tool definition (`M563`) are accepted.
fn mixing(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if MixingCode::sets_a_mix(c.number) {
        m.run_core(c.line, &c.effect, out)
    }
}

/// `M205`: the planner's, its `S T` (minimum feed rates) also kept for `M503`.
fn m205(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    let b = m.core.block();
    for (slot, letter) in m.settings.m205_st.iter_mut().zip([b'S', b'T']) {
        if let Some(v) = b.get(letter) {
            *slot = v;
        }
    }
    m.run_core(c.line, &c.effect, out);
}

/// `M220`/`M221`: feed rate / flow percentage, or report it.
fn percentage(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if c.number == 220 {
        m.percentage("FR:", out, |m| &mut m.feed_pct)
    } else {
        m.percentage("E0 Flow: ", out, |m| &mut m.flow_pct)
    }
}

/// `M400`: the moves were drained before; its `ok` takes that time in wall time too.
fn m400(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.thermal.set_moving(false);
    m.run_core(c.line, &c.effect, out);
    m.moved_since_m400 = false;
    m.wall_timed = true;
}

/// RepRapFirmware 3.3+ sets a tool's temperatures with `M568` (as `G10 P S` before).
fn rrf_tool_temperature(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.rrf_tool_temperature(out)
}

fn m600(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m600(out)
}

/// `M700`/`M578`: fire the printhead, on a machine that has one.
fn fire(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if m.inkjet.is_some() {
        m.fire()
    } else {
        m.unknown_command(c.line, out)
    }
}

/// `M999`: restart after a halt.
fn restart(m: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    m.halt = None;
    m.thermal.clear_halt();
}

fn tool_change(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.tool_change(c.line, c.number, c.effect, out)
}

/// Klipper's `SET_VELOCITY_LIMIT` and `SET_KINEMATIC_POSITION`, carried out by the motion core
/// in Klipper mode; a Marlin board does not know them.
fn klipper(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if m.is_klipper() {
        m.run_core(c.line, &c.effect, out)
    } else {
        m.unknown_command(c.line, out)
    }
}

fn help(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    let t = m.now_s();
    for l in help_lines() {
        out(t, &l);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression (sim_hashed_every_command): `G` and `M` codes looked up in the table, below
    /// `TABLE_CODES`, and by key above it, give the registry's entry, the last to name the code
    /// (as the hashed index had it), and none for a code it lacks.
    #[test]
    fn every_code_finds_its_registry_entry() {
        for letter in [b'G', b'M'] {
            for number in 0..TABLE_CODES + 100 {
                let code = format!("{}{number}", letter as char);
                let expected = COMMANDS
                    .iter()
                    .rposition(|c| c.codes.split_whitespace().any(|k| k == code))
                    .map(|i| &COMMANDS[i]);
                let found = lookup(Command::Code { letter, number, sub: None }, b"");
                assert_eq!(found.map(|c| (c.codes, c.what)), expected.map(|c| (c.codes, c.what)), "{code}");
            }
        }
        assert!(lookup(Command::Code { letter: b'G', number: 1, sub: None }, b"").is_some());
        assert!(lookup(Command::Code { letter: b'G', number: 1, sub: Some(1) }, b"").is_none());
        assert!(lookup(Command::Extended, b"set_velocity_limit").is_some());
    }
}
