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

use gweave::gcode::effect::Motion;
use gweave::gcode::line::PlainMove;
use gweave::gcode::state::{self};
use gweave::range::{self};
use gweave::{Block, Command, Effect, MixingCode, OutOfRange, Range, RefusedWord, Value, WordRanges};

use super::{sd, Machine};
use crate::motion::limits;
use crate::profile::build_options::Feature;
use crate::thermal::control;

/// What a handler is given: the line, the code's number and the logical position before it.
/// What the line does to the modal state is in the state
/// ([`State::effect`](gweave::State::effect)), where handlers read and change it
/// in place: a move is too large to copy per line (docs/performance.md).
#[derive(Debug, Clone, Copy)]
pub(super) struct Call<'a> {
    /// The raw line (without its line end).
    pub line: &'a [u8],
    /// The code's number (`104` for `M104`, the tool for `T<n>`; 0 for a named command).
    pub number: u32,
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
    /// What the virtual printer does with them, one line (the `?` reply and `docs/gcode.md`);
    /// the build option it needs is [`needs`](Self::needs), which both show beside it.
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
    /// The build option (`[firmware]` key) it needs; a board built without it answers
    /// `Unknown command`, as Marlin does a command it was not compiled with. The one list of
    /// the commands an option gates: the `?` reply and docs/gcode.md show it from here.
    pub needs: Feature,
    /// Whether the serial link carries it out before the machine sees it.
    pub link: Link,
    /// What Marlin's emergency parser (`EMERGENCY_PARSER`, `Marlin/src/feature/e_parser.h`) does
    /// with it the moment it arrives, ahead of the held command queue (while `M600` waits for the
    /// user): `None` for the commands it does not know. The row's handler still runs when the
    /// line's turn in the queue comes.
    pub(super) urgent: Option<Urgent>,
}

/// What the emergency parser does at once with a command, given the code's number and the
/// command's text (see [`CommandSpec::urgent`]).
pub(super) type Urgent = fn(&mut Machine, u32, &[u8], &mut dyn FnMut(f64, &str));

/// Who carries a command out when a host sends it over the serial link
/// ([`crate::link::serial`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Link {
    /// The machine (the row's handler), behind the link: every command but the link's own.
    Machine,
    /// `M110 N<n>`: the link sets its line number (Marlin's `GCodeQueue`, `queue.cpp`); the
    /// machine, reading a file, accepts it.
    LineNumber,
    /// `M113 S<s>`: the link's keepalive interval (Marlin's `host_keepalive_interval`,
    /// `gcode/host/M113.cpp`), clamped into the row's range as Marlin caps it; reading a file,
    /// the machine accepts it.
    Keepalive,
}

impl CommandSpec {
    /// The range the row declares for the word `letter`, if it reads it as a number.
    pub fn range_of(&self, letter: u8) -> Option<Range> {
        self.params.iter().find(|p| p.letters.as_bytes().contains(&letter)).map(|p| p.range)
    }
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
            .field("needs", &self.needs)
            .field("link", &self.link)
            .field("urgent", &self.urgent.is_some())
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

/// `M303 E`: the heater to tune, a hotend index or -1 for the bed (Marlin's `M303 E-1`).
const HEATER: Range = Range::new(-1.0, 255.0, "");
/// `M303 C`: relay cycles. At least 3: the first is the heat-up, and the gains are those of two
/// cycles that agree (`thermal::autotune`); Marlin takes 5 by default and a hundred is hours.
const AUTOTUNE_CYCLES: Range = Range::new(3.0, 100.0, "cycles");
/// `M700`/`M578 P`: the printhead, an index as a tool's.
const HEAD: Range = Range::new(0.0, 255.0, "");
/// `M700`/`M578 S`: a bit per nozzle, up to 64 nozzles
/// ([`gweave::gen::printhead::MAX_NOZZLES`]); the firmware ignores the bits past the head's
/// nozzles.
const NOZZLE_BITS: Range = Range::new(0.0, u64::MAX as f64, "");
/// `M26 S`: a byte position in the selected SD file (Marlin's `uint32_t`); past its end, the
/// end.
const SD_BYTE: Range = Range::new(0.0, 4_294_967_295.0, "bytes");
/// `M113 S`: the keepalive interval, at most Marlin's `NOMORE(host_keepalive_interval, 60)`;
/// 0 turns it off.
const KEEPALIVE_S: Range = Range::new(0.0, crate::link::serial::MAX_KEEPALIVE_S as f64, "s");

/// `M900 K`: Marlin's linear advance factor, mm of filament per mm/s of extrusion speed; Marlin
/// refuses one outside 0 to 10 (`M900.cpp`, "K value out of range").
const ADVANCE_K: Range = Range::new(0.0, 10.0, "mm/(mm/s)");

/// A move's words: its feed rate and its X Y Z, an absolute position or a relative step, within
/// 10 m of the origin either way (`range::POSITION_MM`: the largest gantry; `X1e29` is a typo
/// the planner would take for 10^29 mm). E and A are not bounded: an absolute E counts up the
/// whole print's filament (hundreds of metres), a rotary program's A its turns.
const MOVE: &[Param] = &[p("F", range::FEED_MM_MIN), p("XYZ", range::POSITION_MM)];
/// The words of the commands that take a period.
const PERIOD: &[Param] = &[p("S", range::PERIOD_S)];
/// RepRapFirmware's tool temperature, `G10 P<tool> S<active> R<standby>` and `M568`.
const TOOL_TEMP: &[Param] = &[p("P", TOOL), p("SR", range::TEMPERATURE_C)];

/// What a row says unless it says otherwise: a handler that accepts the command, a board that
/// stops answering when halted, the moves left streaming, no number words, no build option, the
/// machine carrying it out.
const ROW: CommandSpec = CommandSpec {
    codes: "",
    what: "",
    run: accepted,
    while_halted: false,
    queue: Queue::Streams,
    params: &[],
    needs: Feature::Always,
    link: Link::Machine,
    urgent: None,
};

/// Every command the interpreter carries out, in the order of the help listing.
pub const COMMANDS: &[CommandSpec] = &[
    CommandSpec { codes: "G0 G1", what: "linear move (G0 a travel), through the lookahead planner and the steppers", run: motion, params: MOVE, ..ROW },
    CommandSpec { codes: "G2 G3", what: "arc clockwise / counter-clockwise in XY (I J centre or R), planned as 1 mm chords", run: motion, params: &[p("F", range::FEED_MM_MIN), p("XYZIJR", range::POSITION_MM)], needs: Feature::Arcs, ..ROW },
    CommandSpec { codes: "G4", what: "dwell P milliseconds or S seconds, after the queued moves", run: dwell, params: &[p("S", range::PERIOD_S), p("P", DWELL_MS)], ..ROW },
    CommandSpec { codes: "G10 G11", what: "firmware retract / recover (45 / 8 mm/s), Marlin's `G10 S1` too; G10 with P (tool) and S sets a tool temperature (RepRapFirmware)", run: g10_g11, params: TOOL_TEMP, needs: Feature::FwRetract, ..ROW },
    CommandSpec { codes: "G20 G21", what: "inches / millimetres", run: core, ..ROW },
    CommandSpec { codes: "G28", what: "home the named axes (all without words) against the endstops, with Marlin's bump", run: home, ..ROW },
    CommandSpec { codes: "G29", what: "bed levelling: probe the grid in simulated time, store a flat mesh, levelling on", run: g29, needs: Feature::Mesh, ..ROW },
    CommandSpec { codes: "G90 G91", what: "absolute / relative coordinates (E too)", run: core, ..ROW },
    CommandSpec { codes: "G92", what: "set the logical position without moving", run: set_position, params: &[p("XYZ", range::POSITION_MM)], ..ROW },
    CommandSpec { codes: "G93 G94", what: "inverse-time feed (F = 1 / minutes of each move) / units per minute, in a rotary program (its header's feed convention)", run: core, ..ROW },
    CommandSpec { codes: "M0 M1", what: "program stop: finish the moves, motors off; with m0 = \"seed\" also home and end the program", run: program_stop, queue: Queue::Drains, ..ROW },
    CommandSpec { codes: "M17 M18 M84", what: "motors on (accepted) / off (the axes must be homed again)", run: motors, params: PERIOD, ..ROW },
    CommandSpec { codes: "M20", what: "SD card (serve --sd DIR): list the files (L: long names)", run: sd::m20, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M21", what: "SD card: mount", run: sd::m21, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M22", what: "SD card: release", run: sd::m22, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M23", what: "SD print: select a file", run: sd::m23, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M24", what: "SD print: start or resume", run: sd::m24, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M25", what: "SD print: pause", run: sd::m25, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M26", what: "SD print: set the byte position S", run: sd::m26, params: &[p("S", SD_BYTE)], needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M27", what: "SD print status (S<n>: every n s)", run: sd::m27, params: PERIOD, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M28", what: "SD upload: the following lines to a file until M29", run: sd::m28, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M29", what: "SD upload: end it", run: sd::m29, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M30", what: "SD card: delete a file", run: sd::m30, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M32", what: "SD print: select a file and start", run: sd::m32, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M33", what: "long name of a file", run: sd::m33, needs: Feature::LongFilenames, ..ROW },
    CommandSpec { codes: "M31", what: "print job time", run: m31, ..ROW },
    CommandSpec { codes: "M42", what: "set a pin: P pin, S value", run: m42, params: &[p("S", range::PWM)], needs: Feature::PinControl, ..ROW },
    CommandSpec { codes: "M226", what: "wait for a pin state", run: m226, needs: Feature::PinControl, ..ROW },
    CommandSpec { codes: "M73", what: "progress (accepted)", run: accepted, params: &[p("P", PROGRESS_PCT)], needs: Feature::SetProgress, ..ROW },
    CommandSpec { codes: "M117", what: "status message, sent to the host as //action:notification", run: m117, ..ROW },
    CommandSpec { codes: "M75 M76 M77", what: "print job timer start / pause / stop", run: job_timer, ..ROW },
    CommandSpec { codes: "M80", what: "power on", run: accepted, needs: Feature::PsuControl, ..ROW },
    CommandSpec { codes: "M81", what: "power off: heaters and motors off", run: m81, ..ROW },
    CommandSpec { codes: "M82 M83", what: "absolute / relative extrusion", run: core, ..ROW },
    CommandSpec { codes: "M92", what: "steps per unit X Y Z E of the steppers", run: m92, params: &[p("XYZE", range::STEPS_PER_UNIT)], ..ROW },
    CommandSpec { codes: "M104 M109", what: "hotend target (T picks the hotend), M109 also waits: S while heating, R both ways", run: hotend_target, params: &[p("SRP", range::TEMPERATURE_C), p("T", TOOL)], ..ROW },
    CommandSpec { codes: "M105", what: "report temperatures and heater powers: ok T:.. /.. B:.. /.. @:.. B@:..", run: m105, while_halted: true, ..ROW },
    CommandSpec { codes: "M106 M107", what: "part fan speed / off (the fan cools the hotend)", run: fan, params: &[p("SP", range::PWM)], ..ROW },
    CommandSpec { codes: "M108 M410", what: "emergency parser: break a wait / quick stop (accepted: waits end by themselves)", run: accepted, urgent: Some(break_wait), ..ROW },
    CommandSpec { codes: "M110", what: "set the line number (serial protocol)", run: accepted, while_halted: true, link: Link::LineNumber, ..ROW },
    CommandSpec { codes: "M113", what: "host keepalive: busy lines every S seconds during a long command (serial protocol; 0: off, no S: report it)", run: accepted, while_halted: true, params: &[p("S", KEEPALIVE_S)], link: Link::Keepalive, ..ROW },
    CommandSpec { codes: "M112", what: "emergency stop: queued moves dropped, heaters off, halted until M999", run: emergency_stop, while_halted: true, urgent: Some(kill_now), ..ROW },
    CommandSpec { codes: "M114", what: "position and motor counts after the queued moves", run: m114, while_halted: true, queue: Queue::Drains, ..ROW },
    CommandSpec { codes: "M115", what: "firmware name, extruder count and the capabilities of the [firmware] table", run: m115, while_halted: true, ..ROW },
    CommandSpec { codes: "M116", what: "wait for every heater with a target (RepRapFirmware)", run: m116, ..ROW },
    CommandSpec { codes: "M118", what: "print a message to the host (A1: // prefix, E1: echo: prefix)", run: m118, ..ROW },
    CommandSpec { codes: "M119", what: "endstop states", run: m119, while_halted: true, queue: Queue::Drains, ..ROW },
    CommandSpec { codes: "M140 M190", what: "bed target, M190 also waits: S while heating, R both ways", run: bed_target, params: &[p("SRP", range::TEMPERATURE_C)], ..ROW },
    CommandSpec { codes: "M154", what: "report the position every S seconds", run: m154, params: PERIOD, needs: Feature::AutoreportPos, ..ROW },
    CommandSpec { codes: "M155", what: "report temperatures every S seconds (0: off)", run: m155, params: PERIOD, needs: Feature::AutoreportTemp, ..ROW },
    CommandSpec { codes: "M163 M164 M165 M166", what: "mixing: set a weight, store a virtual tool, mix at once, gradient (accepted)", run: mixing, ..ROW },
    CommandSpec { codes: "M201", what: "maximum acceleration per axis", run: core, params: &[p("XYZE", range::ACCEL_MM_S2), p("A", limits::ACCEL_DEG_S2)], ..ROW },
    CommandSpec { codes: "M203", what: "maximum feed rate per axis", run: core, params: &[p("XYZE", range::SPEED_MM_S), p("A", limits::SPEED_DEG_S)], ..ROW },
    CommandSpec { codes: "M204", what: "print (P, S) / retract (R) / travel (T) acceleration", run: core, params: &[p("SPRT", range::ACCEL_MM_S2)], ..ROW },
    CommandSpec { codes: "M205", what: "junction deviation (J) or classic jerk (X Y Z E), minimum segment time (B), minimum feed rates (S T)", run: m205, params: &[p("XYZE", limits::JERK_MM_S), p("J", limits::JUNCTION_DEVIATION_MM), p("B", limits::MIN_SEGMENT_TIME_US), p("ST", range::SPEED_MM_S.or_zero())], ..ROW },
    CommandSpec { codes: "M207 M208 M209", what: "firmware retraction: retract length (the planner's G10), recover, auto-retract", run: retraction_settings, params: &[p("SWZ", range::LEN_MM), p("F", range::FEED_MM_MIN)], needs: Feature::FwRetract, ..ROW },
    CommandSpec { codes: "M211", what: "software endstops on/off and their limits", run: m211, ..ROW },
    CommandSpec { codes: "M220 M221", what: "feed rate / flow percentage (no S: report it)", run: percentage, params: &[p("S", PERCENT)], ..ROW },
    CommandSpec { codes: "M300", what: "beep (accepted)", run: accepted, needs: Feature::Buzzer, ..ROW },
    CommandSpec { codes: "M301", what: "set or report the hotend PID gains", run: m301, params: &[p("PID", control::GAIN), p("E", TOOL)], ..ROW },
    CommandSpec { codes: "M303", what: "PID autotune on the thermal plant (relay method), U1 applies the gains", run: m303, queue: Queue::Drains, params: &[p("S", range::TEMPERATURE_C), p("E", HEATER), p("C", AUTOTUNE_CYCLES)], ..ROW },
    CommandSpec { codes: "M304", what: "set or report the bed PID gains", run: m304, params: &[p("PID", control::GAIN)], ..ROW },
    CommandSpec { codes: "M400", what: "wait for the queued moves to finish; its ok takes that time in wall time too (hosts time it)", run: m400, queue: Queue::Drains, ..ROW },
    CommandSpec { codes: "M420", what: "bed levelling on/off (S), mesh report (V)", run: m420, needs: Feature::Mesh, ..ROW },
    CommandSpec { codes: "M500 M501", what: "settings: save to / load from the EEPROM file", run: eeprom, needs: Feature::Eeprom, ..ROW },
    CommandSpec { codes: "M502 M503", what: "settings: factory defaults, report", run: defaults_or_report, ..ROW },
    CommandSpec { codes: "M524", what: "abort the SD print", run: sd::m524, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M563 M567", what: "tool definition (accepted) and mix ratios (RepRapFirmware)", run: mixing, ..ROW },
    CommandSpec { codes: "M568", what: "tool temperature, as G10 P S (RepRapFirmware 3.3+; on a mixing hotend, the nozzle's)", run: rrf_tool_temperature, params: TOOL_TEMP, ..ROW },
    CommandSpec { codes: "M600", what: "filament change: park, host prompts, wait for M108 / M876 S0, purge, resume", run: m600, needs: Feature::AdvancedPause, ..ROW },
    CommandSpec { codes: "M851", what: "probe offsets X Y Z", run: m851, params: &[p("XYZ", range::POSITION_MM)], needs: Feature::Probe, ..ROW },
    CommandSpec { codes: "M900", what: "linear advance K (accepted: it shapes the extruder's motion, not the print's time)", run: accepted, params: &[p("K", ADVANCE_K)], needs: Feature::LinearAdvance, ..ROW },
    CommandSpec { codes: "M876", what: "answer a host prompt", run: m876, needs: Feature::PromptSupport, urgent: Some(answer_now), ..ROW },
    CommandSpec { codes: "M928", what: "log the following commands to an SD file until M29", run: sd::m928, needs: Feature::Sdcard, ..ROW },
    CommandSpec { codes: "M578 M700", what: "inkjet fire at the carriage position (machines with a printhead)", run: fire, params: &[p("P", HEAD), p("S", NOZZLE_BITS)], ..ROW },
    CommandSpec { codes: "M999", what: "restart after a halt", run: restart, while_halted: true, ..ROW },
    CommandSpec { codes: "T<n>", what: "select a tool (a virtual mixing tool on a mixing hotend)", run: tool_change, ..ROW },
    CommandSpec { codes: "SET_VELOCITY_LIMIT SET_KINEMATIC_POSITION", what: "Klipper's limits and position (Klipper mode)", run: klipper, ..ROW },
    CommandSpec { codes: "?", what: "this list", run: help, while_halted: true, ..ROW },
];

/// The `?` reply: a title line, then `echo:  <codes>  <what>` per command, with the build
/// option it needs from its row (`[firmware.sdcard]`), so that no help text repeats the gating.
pub fn help_lines() -> Vec<String> {
    std::iter::once("echo:gweave-sim commands:".to_owned())
        .chain(COMMANDS.iter().map(|c| match c.needs.key() {
            Some(key) => format!("echo:  {:<19}  {} [firmware.{key}]", c.codes, c.what),
            None => format!("echo:  {:<19}  {}", c.codes, c.what),
        }))
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
pub(crate) fn lookup(command: Command, name: &[u8]) -> Option<&'static CommandSpec> {
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

/// The words of the line in `block` against the ranges its command's row declares
/// ([`check`]), before the line changes anything: what the virtual printer refuses, and what
/// `estimate` skips, alike. A line without a command is a move in the modal motion `modal`
/// (not one that starts with junk: [`Block::starts_unreadable`], which no firmware reads).
/// `row` gives the row of a command, `None` for one the machine does not have (not in the
/// registry, or not in its build): that is unknown, not out of range, and is not checked. The
/// dispatcher, which has looked the line's command up already, answers with that row
/// (`commands::lookup` once a line); `estimate` and `check` with [`lookup`], every command
/// taken as built. A plain move, most lines of a print, is checked by [`PlainRanges`] without
/// asking `row` (its words may not be listed in the block).
#[inline(always)]
pub(crate) fn check_line(
    block: &Block,
    line: &[u8],
    modal: Motion,
    row: impl FnOnce(Command) -> Option<&'static CommandSpec>,
) -> Result<(), RefusedWord> {
    // Inlined, a plain move costs its comparisons and no call.
    if block.plain.present != 0 {
        return check_plain(&block.plain);
    }
    check_other_line(block, line, modal, row)
}

/// [`check_line`] for a plain move read without a [`Block`] (`estimate`'s own reader).
#[inline(always)]
pub(crate) fn check_plain(plain: &PlainMove) -> Result<(), RefusedWord> {
    PlainRanges::get().check(plain)
}

/// [`check_line`] for a line that is not a plain move.
#[inline(never)]
fn check_other_line(
    block: &Block,
    line: &[u8],
    modal: Motion,
    row: impl FnOnce(Command) -> Option<&'static CommandSpec>,
) -> Result<(), RefusedWord> {
    if block.words.is_empty() {
        return Ok(());
    }
    let command = match block.command {
        // Junk where the command belongs (`!!! Z5`): no command and no move, nothing to check.
        Command::None if block.starts_unreadable() => return Ok(()),
        Command::None => {
            let number = match modal {
                Motion::Rapid => 0,
                Motion::Linear => 1,
                Motion::ArcCw => 2,
                Motion::ArcCcw => 3,
            };
            Command::Code { letter: b'G', number, sub: None }
        }
        command => command,
    };
    match command {
        Command::Code { letter, number, .. } => match row(command) {
            Some(spec) => check((letter, number), spec.params, block, line),
            None => Ok(()),
        },
        _ => Ok(()),
    }
}

/// The ranges the `G0 G1` row declares for a plain move's words, in the order of
/// [`PlainMove::LETTERS`], as bounds side by side: a plain move, most lines of a print, is
/// checked without a search of its row, two comparisons for each bounded letter it has (it
/// is on the hot path of `estimate`, `sim` and `check`; walking the row's `Range`s letter by
/// letter cost about 50 instructions a move).
struct PlainRanges {
    min: [f64; PlainMove::LETTERS.len()],
    max: [f64; PlainMove::LETTERS.len()],
    /// Bit i: letter i has a range.
    bounded: u8,
}

impl PlainRanges {
    #[inline]
    fn get() -> &'static PlainRanges {
        static RANGES: OnceLock<PlainRanges> = OnceLock::new();
        RANGES.get_or_init(|| {
            let g1 = lookup(Command::Code { letter: b'G', number: 1, sub: None }, b"");
            let ranges = PlainMove::LETTERS.map(|letter| g1.and_then(|row| row.range_of(letter)));
            let bounded =
                ranges.iter().enumerate().fold(0, |bits, (i, r)| bits | (u8::from(r.is_some()) << i));
            // A range that also takes 0 ([`Range::or_zero`]) keeps its bounds: a 0 goes to
            // `refusal`, which reads the range itself and lets it pass.
            PlainRanges {
                min: ranges.map(|r| r.map_or(f64::NEG_INFINITY, |r| r.min)),
                max: ranges.map(|r| r.map_or(f64::INFINITY, |r| r.max)),
                bounded,
            }
        })
    }

    #[inline(always)]
    fn check(&self, plain: &PlainMove) -> Result<(), RefusedWord> {
        // Only the letters the line has and the row bounds (a move is mostly X, Y and an
        // unbounded E): two or three comparisons.
        let mut letters = plain.present & self.bounded;
        while letters != 0 {
            let i = letters.trailing_zeros() as usize;
            let v = plain.values[i];
            // NaN is never inside.
            if !(v >= self.min[i] && v <= self.max[i]) {
                return self.refusal(plain);
            }
            letters &= letters - 1;
        }
        Ok(())
    }

    /// The first word of the line out of its range, in the order of the row's words, as
    /// [`check`] finds it on the same words (a 0 may be in a range that takes it).
    #[cold]
    #[inline(never)]
    fn refusal(&self, plain: &PlainMove) -> Result<(), RefusedWord> {
        let g1 = lookup(Command::Code { letter: b'G', number: 1, sub: None }, b"");
        for param in g1.map_or(&[][..], |row| row.params) {
            for letter in param.letters.bytes() {
                let Some(i) = PlainMove::LETTERS.iter().position(|&l| l == letter) else { continue };
                if plain.present >> i & 1 != 0 && !param.range.contains(plain.values[i]) {
                    return Err(plain_refusal(plain, i, &param.range));
                }
            }
        }
        Ok(())
    }
}

/// The refusal of a plain move's word `i`, outside `range`.
#[cold]
#[inline(never)]
fn plain_refusal(plain: &PlainMove, i: usize, range: &Range) -> RefusedWord {
    let letter = PlainMove::LETTERS[i];
    let name = format!("G{} {}", u8::from(!plain.rapid), letter as char);
    RefusedWord {
        letter,
        refusal: OutOfRange { name, value: range::short(plain.values[i]), range: range.to_string() },
    }
}

/// The registry's ranges, lent to the engine's lint (`gweave check`): it flags the words the
/// virtual printer refuses a line for (every command taken as built), and `estimate` skips one
/// for.
#[derive(Debug)]
pub struct RegistryRanges;

/// The one [`RegistryRanges`].
pub static REGISTRY_RANGES: RegistryRanges = RegistryRanges;

impl WordRanges for RegistryRanges {
    fn check(&self, block: &Block, line: &[u8], motion: Motion) -> Result<(), RefusedWord> {
        check_line(block, line, motion, |command| lookup(command, b""))
    }
}

/// Refuses a line whose words are outside what `params` declares, before it changes anything
/// (as GRBL's parser checks a whole line first): the first such word as the uniform reply,
/// `M104 S = 600 is out of range: 0 to 500 °C`. `code` names the command (`M104`); a word that
/// is not a number (`Snan`, `S1..2`) is outside every range, written as it was.
pub(super) fn check(
    code: (u8, u32),
    params: &[Param],
    block: &Block,
    line: &[u8],
) -> Result<(), RefusedWord> {
    for param in params {
        for letter in param.letters.bytes() {
            let Some(word) = block.word(letter) else { continue };
            let name = || format!("{}{} {}", code.0 as char, code.1, letter as char);
            match word.value {
                // The name is written only for a refusal: formatting it for every word in range
                // cost an allocation and about 700 instructions a word (callgrind), on every
                // line checked (a transform's windows check each `G92` they set).
                Value::Number(v) if param.range.contains(v) => {}
                Value::Number(v) => {
                    param.range.check(&name(), v).map_err(|refusal| RefusedWord { letter, refusal })?;
                }
                Value::Invalid => {
                    let written = word.span.of(line).get(1..).unwrap_or_default();
                    let refusal = OutOfRange {
                        name: name(),
                        value: String::from_utf8_lossy(written).into_owned(),
                        range: param.range.to_string(),
                    };
                    return Err(RefusedWord { letter, refusal });
                }
                // A bare letter (`G28 X`), a quoted string or an expression (RepRapFirmware's
                // `{...}`) is not a number the command reads.
                Value::Empty | Value::Text(_) | Value::Expr(_) => {}
            }
        }
    }
    Ok(())
}

// The handlers. The SD card's are in its own module (`sd`); the rest are one method or a few
// lines each.

fn motion(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.motion(c.line, out)
}

fn core(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.run_core(c.line, out)
}

fn dwell(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    match m.core.state().effect {
        Effect::Dwell { t_s } if t_s > super::motion::MAX_COMMAND_S => {
            m.refuse(format!("a dwell of {t_s:.0} s: refused"), out)
        }
        _ => {
            m.thermal.set_moving(false);
            m.run_core(c.line, out);
        }
    }
}

/// RepRapFirmware's `G10 P<tool> S<temp>` sets a tool's temperature; the state says which `G10`
/// is which (Marlin's `G10 S1` is a retraction).
fn g10_g11(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if c.number == 10 && m.core.state().g10_is_not_a_retraction(m.core.block()) {
        m.rrf_tool_temperature(out)
    } else {
        if let Effect::FirmwareRetract { e_mm } = m.core.state().effect {
            m.feed_filament(e_mm);
        }
        m.run_core(c.line, out)
    }
}

fn home(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.home(c.line, &c.before, out)
}

fn g29(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.g29(out)
}

/// `G92`: the machine stays where it is; what changes is the logical origin.
fn set_position(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    let pos = m.core.state().pos;
    for (shift, (before, now)) in m.shift_mm.iter_mut().zip(c.before.iter().zip(pos)) {
        *shift += before - now;
    }
    m.run_core(c.line, out);
}

/// `M0`/`M1`: finish the moves (drained before), motors off; the controller seed's `M0` also
/// homes and ends the program.
fn program_stop(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.run_core(c.line, out);
    if c.number == 0 && m.profile.firmware.m0 == crate::profile::build_options::ProgramStop::Seed {
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
    m.run_core(c.line, out);
    m.core.drain();
    if !m.core.block().has(b'S') {
        m.homed = [false; 3];
    }
}

fn m31(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m31(out)
}

fn m42(m: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    m.m42()
}

fn m226(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m226(out)
}

fn m117(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m117(c.line, out)
}

/// `M75` starts the print job timer, `M76` pauses it, `M77` stops it (back to zero).
fn job_timer(m: &mut Machine, c: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    match c.number {
        75 => m.job_timer_start(),
        76 => m.job_timer_pause(),
        _ => m.job_timer_stop(),
    }
}

/// `M81`: power off.
fn m81(m: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    m.power_off()
}

fn m118(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m118(c.line, out)
}

fn m154(m: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    m.m154()
}

fn m211(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m211(out)
}

fn m420(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m420(out)
}

fn m876(m: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    m.m876()
}

fn m92(m: &mut Machine, _: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    m.m92()
}

/// `M207` retraction, `M208` recovery, `M209` auto-retract.
fn retraction_settings(m: &mut Machine, c: &Call<'_>, _: &mut dyn FnMut(f64, &str)) {
    match c.number {
        207 => m.m207(),
        208 => m.m208(),
        _ => m.m209(),
    }
}

fn m304(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m304(out)
}

/// `M500` saves the settings to the EEPROM file, `M501` loads them.
fn eeprom(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if c.number == 500 {
        m.m500(out)
    } else {
        m.m501(out)
    }
}

/// `M502` restores the factory settings, `M503` reports them.
fn defaults_or_report(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if c.number == 502 {
        m.m502(out)
    } else {
        m.m503(out)
    }
}

fn m851(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.m851(out)
}

/// Accepted, nothing to simulate (`M73`: the progress is the host's; `M110`, `M113`: the
/// serial link's; `M80`: the power is on; `M300`: a beep; `M108`, `M410`: emergency commands
/// with nothing to interrupt, the waits end by themselves here).
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

/// `M112`: the moves still queued dropped, heaters off, halted until `M999`.
fn emergency_stop(m: &mut Machine, _: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    m.kill(out);
}

/// The emergency parser's `M108` ends a wait for the user; its `M410` (quick stop) finds no
/// moves to stop while the board waits.
fn break_wait(m: &mut Machine, number: u32, _: &[u8], _: &mut dyn FnMut(f64, &str)) {
    if number == 108 {
        m.end_user_wait();
        m.end_heating_wait();
    }
}

/// The emergency parser's `M112`: killed at once, the wait ended with it.
fn kill_now(m: &mut Machine, _: u32, _: &[u8], out: &mut dyn FnMut(f64, &str)) {
    m.end_user_wait();
    m.kill(out);
}

/// The emergency parser's `M876`: `S<n>` answers the open prompt; `M876 P1` only says the host
/// supports prompts.
fn answer_now(m: &mut Machine, _: u32, text: &[u8], _: &mut dyn FnMut(f64, &str)) {
    if text.windows(2).any(|w| w[0].eq_ignore_ascii_case(&b'S') && w[1].is_ascii_digit()) {
        m.answer_prompt();
    }
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
        m.run_core(c.line, out)
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
    m.run_core(c.line, out);
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
    m.run_core(c.line, out);
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
        m.fire(c.line, out)
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
    m.tool_change(c.line, c.number, out)
}

/// Klipper's `SET_VELOCITY_LIMIT` and `SET_KINEMATIC_POSITION`, carried out by the motion core
/// in Klipper mode; a Marlin board does not know them.
fn klipper(m: &mut Machine, c: &Call<'_>, out: &mut dyn FnMut(f64, &str)) {
    if m.is_klipper() {
        m.run_core(c.line, out)
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

    /// A plain move (the lexer's fast path: its words may go unlisted) is refused exactly as the
    /// same words read the general way (here with a comment after them), by the `G0 G1` row.
    #[test]
    fn a_plain_move_is_checked_by_its_rows_ranges() {
        let cases = [
            ("G1 X10 Y-5 Z0.2 E1 F600", None),
            ("G1 X10 E100000000 F1", None),
            ("G0 X20000", Some("G0 X = 20000 is out of range: -10000 to 10000 mm")),
            ("G1 Y5 Z-10001", Some("G1 Z = -10001 is out of range: -10000 to 10000 mm")),
            ("G1 X1 F0", Some("G1 F = 0 is out of range: 1 to 100000 mm/min")),
            ("G1 F1000000 X99999", Some("G1 F = 1000000 is out of range: 1 to 100000 mm/min")),
        ];
        for (text, want) in cases {
            for line in [text.to_owned(), format!("{text} ; the general way")] {
                let mut block = Block::default();
                gweave::gcode::lexer::parse_into(line.as_bytes(), &mut block);
                assert_eq!(block.plain.present != 0, !line.contains(';'), "{line}");
                let got = check_line(&block, line.as_bytes(), Motion::Linear, |c| lookup(c, b""));
                assert_eq!(got.map_err(|e| e.to_string()).err().as_deref(), want, "{line}");
            }
        }
    }

    /// The serial link's own commands are declared in their rows: `M110` and `M113` alone, and
    /// `M113`'s interval has the range the link clamps into (Marlin's 60 s cap).
    #[test]
    fn the_links_own_commands_are_m110_and_m113() {
        let own: Vec<(&str, Link)> =
            COMMANDS.iter().filter(|c| c.link != Link::Machine).map(|c| (c.codes, c.link)).collect();
        assert_eq!(own, [("M110", Link::LineNumber), ("M113", Link::Keepalive)]);
        let m113 = lookup(Command::Code { letter: b'M', number: 113, sub: None }, b"").unwrap();
        assert_eq!(m113.range_of(b'S').map(|r| (r.min, r.max)), Some((0.0, 60.0)));
        assert_eq!(m113.range_of(b'P'), None);
    }
}
