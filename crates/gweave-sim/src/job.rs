//! A file run through the virtual printer from its first line to its end: what `gweave sim` and
//! `gweave.sim()` both do, written once so that the two cannot drift (they did: the command line
//! stopped at the controller seed's `M0` and Python ran on past it).
//!
//! The file is read as a host streams it: line by line, in bounded memory, as the firmware its
//! flavour names reads it. The machine profile decides which printer runs it: the Marlin model
//! ([`Machine`]), or gweave's own controller core ([`core_board`], `[firmware] kind = "gweave"`).

use std::io;
use std::path::{Path, PathBuf};

use gweave::gcode::container;
use gweave::gcode::ends::{missing_footer, read_ends};
use gweave::gcode::flavour::read_firmware;
use gweave::gcode::lexed::{self, Lexed};
use gweave::gcode::reader::Part;
use gweave::options::Spelling;
use gweave::rotary::cylinder::RotaryConfig;
use gweave::{LineReader, Progress};

use crate::core_board::{self, CoreBoardError, CoreReport};
use crate::inkjet::layers::LayerPngs;
use crate::inkjet::InkjetError;
use crate::interp::{Machine, Outcome, SimError, SimReport};
use crate::profile::build_options::FirmwareKind;
use crate::profile::{FaultSpec, MachineProfile};

/// The longest a run of a file may hold the simulated clock, s: 30 days, past which the
/// machine stops ([`Machine::limit_clock`]). A heater that is on is simulated loop by loop, as
/// the firmware runs it every 0.1 s: a quarter of a second of CPU a simulated day on the
/// default machine, more with more heaters, and there is no exact shortcut (its PID integrates
/// each loop's error over that loop's period, which differs from the next in its last bits). A
/// command is held to a week (`interp::motion::MAX_COMMAND_S`), but lines of
/// them add up: 200 of `G4 S86400` (2 KB) ran for 54 s. The longest prints run for days, a
/// large-format one a week or two; a month is past any, and costs seconds.
pub const MAX_FILE_RUN_S: f64 = 30.0 * 24.0 * 3600.0;

/// What a simulation is asked for beyond the file and the machine profile.
#[derive(Debug, Clone, Default)]
pub struct SimSetup {
    /// Heater faults injected at given times, added to the profile's own.
    pub faults: Vec<FaultSpec>,
    /// Record the planned toolhead speed over time ([`Machine::speed_trace`]), for a chart.
    pub record_speed: bool,
    /// Write each inkjet layer, once it is finished, as PNGs into this folder (on a machine
    /// with a printhead): `layer_<k>_head<h>.png`.
    pub raster_out: Option<PathBuf>,
}

/// What ran the file, and what it did.
pub enum Simulation {
    /// The Marlin model: the machine after the run (its heaters' series and speed trace, for
    /// charts), its report and the `Error:` lines it printed.
    Marlin {
        /// The machine as the run left it.
        machine: Box<Machine>,
        /// What it did.
        report: Box<SimReport>,
        /// Its `Error:` lines.
        errors: Vec<String>,
    },
    /// The controller core: its report (its errors inside).
    Core(CoreReport),
}

impl Simulation {
    /// Whether the printer halted (a thermal fault or `M112`): a failed run.
    pub fn halted(&self) -> bool {
        match self {
            Simulation::Marlin { report, .. } => report.halted,
            Simulation::Core(report) => report.halted,
        }
    }

    /// The `Error:` lines the printer printed.
    pub fn errors(&self) -> &[String] {
        match self {
            Simulation::Marlin { errors, .. } => errors,
            Simulation::Core(report) => &report.errors,
        }
    }
}

/// Why a file could not be simulated. An option is named by its identity; a front end spells
/// it as its flag or keyword ([`SimJobError::spelled`]).
#[derive(Debug, thiserror::Error)]
pub enum SimJobError {
    /// The file could not be opened or read.
    #[error("reading {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// The Marlin model could not be built from the profile.
    #[error(transparent)]
    Machine(#[from] SimError),
    /// The controller core could not be built from the profile.
    #[error(transparent)]
    Core(#[from] CoreBoardError),
    /// An inkjet layer could not be written (`raster_out`); it names the file.
    #[error(transparent)]
    RasterOut(InkjetError),
    /// An option the controller core has no model for (its heaters cannot be faulted, its
    /// planner keeps no speed trace).
    #[error("{}", marlin_model_only(option, Spelling::Keyword))]
    MarlinModelOnly {
        /// The option, by its identity in [`SimOptions`](crate::reading::SimOptions) (`fault`,
        /// `plot_speed`).
        option: &'static str,
    },
}

impl SimJobError {
    /// The message, an option named as `spelling` names it (`--plot-speed`, `plot_speed`).
    pub fn spelled(&self, spelling: Spelling) -> String {
        match self {
            SimJobError::MarlinModelOnly { option } => marlin_model_only(option, spelling),
            e => e.to_string(),
        }
    }
}

fn marlin_model_only(option: &str, spelling: Spelling) -> String {
    let option = spelling.name(option);
    format!("{option} is for the Marlin model: the machine profile runs the controller core ([firmware] kind = \"gweave\")")
}

/// Runs `input` on the printer `profile` describes, until its end, a halt, or the program's end
/// (the seed's `M0`, `[firmware] m0 = "seed"`); `progress` follows the bytes read.
pub fn simulate(
    input: &Path,
    mut profile: MachineProfile,
    options: &SimSetup,
    progress: &mut dyn Progress,
) -> Result<Simulation, SimJobError> {
    let read_error = |source| SimJobError::Read { path: input.to_owned(), source };
    if profile.firmware.kind == FirmwareKind::Gweave {
        if !options.faults.is_empty() {
            return Err(SimJobError::MarlinModelOnly { option: "fault" });
        }
        if options.record_speed {
            return Err(SimJobError::MarlinModelOnly { option: "plot_speed" });
        }
        return on_core(input, &profile).map(Simulation::Core);
    }
    profile.faults.extend(options.faults.iter().cloned());
    let mut machine = Box::new(Machine::new(profile)?);
    machine.limit_clock(MAX_FILE_RUN_S);
    if options.record_speed {
        machine.record_speed();
    }
    if let (Some(dir), Some(_)) = (&options.raster_out, machine.inkjet()) {
        // Each layer is written as it is finished: the machine holds one layer, not the print.
        let pngs = LayerPngs::new(dir).map_err(SimJobError::RasterOut)?;
        machine.send_inkjet_layers_to(Box::new(pngs));
    }
    // The file is read as `stats` reads it: as the firmware its flavour names.
    machine.read_as(read_firmware(input, None).map_err(read_error)?);
    let file = container::open(input).map_err(read_error)?;
    progress.set_len(file.text_len.unwrap_or(0));
    // A rotary program's F words follow the convention its header declares, read from the
    // stream's head as `estimate` reads it.
    let (rotary, file) = RotaryConfig::from_stream_head(file).map_err(read_error)?;
    if let Some(rotary) = rotary {
        machine.declare_rotary(rotary);
    }
    let mut errors = Vec::new();
    let mut out = |_t: f64, line: &str| {
        if line.starts_with("Error:") {
            errors.push(line.to_owned());
        }
    };
    // The file is read and lexed on a second thread, a batch of lines ahead of the machine
    // (`gweave::gcode::lexed`, as `stats` reads): a sixth of the work of a line, which the
    // machine's thread no longer waits for.
    let (lexer, lexed) = lexed::lexer(file, machine.reads_words());
    let unterminated = std::thread::scope(|scope| {
        scope.spawn(move || lexer.run());
        // Dropped on a halt or at the program's end: the lexer then stops too.
        run_lexed(&mut machine, lexed, &mut out, progress)
    })
    .map_err(read_error)?;
    // A file cut short (a copy or an upload stopped) runs to its cut and stops there, as on a
    // printer: said as `check` says it, on the last line. The ends are read only for a file whose
    // last line has no ending.
    if let Some(footer) =
        unterminated.then(|| read_ends(input).ok().and_then(|e| missing_footer(&e))).flatten()
    {
        machine.file_cut(footer);
    }
    machine.finish(&mut out);
    if let Some(failure) = machine.take_inkjet_failure() {
        return Err(SimJobError::RasterOut(failure));
    }
    let report = Box::new(machine.report());
    Ok(Simulation::Marlin { machine, report, errors })
}

/// Runs every line of `lexed` on `machine`, to the end, a halt or the program's end; `progress`
/// follows the bytes read. Returns whether the file's last line, read to the end of the file,
/// has no line ending.
fn run_lexed(
    machine: &mut Machine,
    mut lexed: Lexed,
    out: &mut dyn FnMut(f64, &str),
    progress: &mut dyn Progress,
) -> io::Result<bool> {
    let mut unterminated = false;
    let (mut position, mut reported) = (0u64, 0u64);
    while let Some(batch) = lexed.next_batch() {
        let mut batch = batch?;
        let (mut lines, blocks) = batch.lines_mut();
        for block in blocks {
            // The batch holds a block for each of its lines: never `None`.
            let Some(line) = lines.next_line() else { break };
            position = line.offset + (line.bytes.len() + line.eol.len()) as u64;
            match line.part {
                Part::Whole => {
                    unterminated = line.eol.is_empty();
                    // A halt stops the run, and so does the seed's M0 (`[firmware] m0 = "seed"`).
                    if machine.execute_lexed(line.bytes, block, out) == Outcome::Halted
                        || machine.program_ended()
                    {
                        return Ok(false);
                    }
                }
                Part::Piece => continue,
                Part::Last { len } => {
                    position += len;
                    machine.skip_long_line();
                }
            }
        }
        if position >= reported + PROGRESS_BYTES {
            progress.advance(position);
            reported = position;
        }
        lexed.recycle(batch);
    }
    Ok(unterminated)
}

/// Bytes read between two reports of progress.
const PROGRESS_BYTES: u64 = 4 << 20;

/// `[firmware] kind = "gweave"`: the file on gweave's own controller core (docs/firmware.md), as
/// a host streams it to the board.
fn on_core(input: &Path, profile: &MachineProfile) -> Result<CoreReport, SimJobError> {
    let read_error = |source| SimJobError::Read { path: input.to_owned(), source };
    let mut reader = LineReader::new(container::open(input).map_err(read_error)?);
    let mut failed = None;
    // Inside a line longer than the reader's buffer: its first piece was sent.
    let mut in_long_line = false;
    let mut next_line = || loop {
        match reader.next_line() {
            Ok(Some(line)) => match line.part {
                Part::Whole => return Some(line.bytes.to_vec()),
                // Far longer than the board's 95 bytes: its first bytes stand for it, and the
                // board refuses the line as too long.
                Part::Piece if !in_long_line => {
                    in_long_line = true;
                    return Some(line.bytes[..line.bytes.len().min(256)].to_vec());
                }
                Part::Piece => {}
                Part::Last { .. } => in_long_line = false,
            },
            Ok(None) => return None,
            Err(e) => {
                failed = Some(e);
                return None;
            }
        }
    };
    let report = core_board::run_on_core(profile, &mut next_line)?;
    match failed {
        Some(e) => Err(read_error(e)),
        None => Ok(report),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gweave::Quiet;

    /// The seed's M0 ends the program (it homes the axes, the seed's end of program): X500, past
    /// the bed, is never reached; Marlin's M0 goes on to it.
    #[test]
    fn a_run_stops_at_the_seeds_m0() {
        let dir = tempfile::tempdir().unwrap();
        let job = dir.path().join("job.gcode");
        std::fs::write(&job, "G28\nG1 X50 F3000\nM0\nG1 X500\n").unwrap();
        for (stop, runs_on) in [(crate::ProgramStop::Seed, false), (crate::ProgramStop::Marlin, true)] {
            let mut profile = MachineProfile::default();
            profile.firmware.m0 = stop;
            let Simulation::Marlin { report, .. } =
                simulate(&job, profile, &SimSetup::default(), &mut Quiet).unwrap()
            else {
                panic!("the Marlin model runs the default profile")
            };
            let out_of_bounds = report.warnings.iter().any(|w| w.kind.name() == "out_of_bounds");
            assert_eq!(out_of_bounds, runs_on, "{stop:?}: {:?}", report.warnings);
            if !runs_on {
                assert_eq!(report.position[0], 0.0, "homed by the seed's M0");
            }
        }
    }

    /// Regression: `check` warned that a file cut mid-number looks truncated, and the virtual
    /// printer ran it to its cut without a word. The warning is on the last line; the whole
    /// file gets none.
    #[test]
    fn a_file_cut_short_is_said_truncated_on_its_last_line() {
        let dir = tempfile::tempdir().unwrap();
        let (whole, part, newlines) = crate::test_support::cone_cut_short(dir.path());
        let truncated = |path: &Path| {
            let run = simulate(path, MachineProfile::default(), &SimSetup::default(), &mut Quiet).unwrap();
            let Simulation::Marlin { report, .. } = run else {
                panic!("the Marlin model runs the default profile")
            };
            let said: Vec<_> =
                report.warnings.iter().filter(|w| w.kind.name() == "truncated").cloned().collect();
            (report.warning_counts.get("truncated").copied(), said, report.lines)
        };
        let (count, said, lines) = truncated(&part);
        assert_eq!((count, lines), (Some(1), newlines + 1));
        assert_eq!(said[0].line, newlines + 1);
        assert_eq!(
            said[0].kind,
            crate::interp::WarningKind::Truncated { footer: gweave::gcode::ends::Footer::PrusaSlicer }
        );
        assert!(said[0].kind.to_string().starts_with("the file looks truncated"), "{}", said[0].kind);
        assert_eq!(truncated(&whole).0, None);
    }

    /// The file is lexed on a second thread, ahead of the machine (issue 35: `sim` 2.95x
    /// klipper_estimator's speed, 3.18x since): the machine ends as a run of every line through
    /// [`Machine::execute`] leaves it, also after `\r\r\n` and lone `\r` endings, a line past the
    /// reader's length, a last line cut mid-word (which the lexer marks as such), and with a
    /// firmware that reads the words of plain moves (LinuxCNC, which extrudes with A).
    #[test]
    fn a_file_lexed_ahead_runs_as_line_by_line() {
        let dir = tempfile::tempdir().unwrap();
        let moves: String = (0..3000)
            .map(|i| format!("G1 X{} Y{} E{}.5 F{}\n", i % 90, (i * 7) % 80, i, 1200 + i % 7 * 600))
            .collect();
        let long = format!("G1 X{}\n", "9".repeat(gweave::gcode::reader::MAX_LINE + 10));
        let texts = [
            format!(
                "M104 S200\nG28\n{moves}M109 S200\r\r\nM117 S\r\r\nG1 X5 E1\rG1 X6 E2\r{long}G1 X7 Y7 E3\n"
            ),
            format!("; flavor\n{moves}G1 X1 E1\nG1 X2 Y"),
            format!("G21\nG90\n{}G0 X80 Y80 F9000\n;FLAVOR:Mach3\n", moves.replace(" E", " A")),
        ];
        for (k, text) in texts.iter().enumerate() {
            let path = dir.path().join(format!("t{k}.gcode"));
            std::fs::write(&path, text).unwrap();
            let Simulation::Marlin { report, errors, .. } =
                simulate(&path, MachineProfile::default(), &SimSetup::default(), &mut Quiet).unwrap()
            else {
                panic!("the Marlin model runs the default profile")
            };
            let mut machine = Machine::new(MachineProfile::default()).unwrap();
            machine.read_as(read_firmware(&path, None).unwrap());
            assert_eq!(machine.reads_words(), k == 2, "text {k}");
            let mut said = Vec::new();
            let mut out = |_t: f64, line: &str| {
                if line.starts_with("Error:") {
                    said.push(line.to_owned());
                }
            };
            let mut reader = LineReader::new(text.as_bytes());
            while let Some(line) = reader.next_line().unwrap() {
                match line.part {
                    Part::Whole => _ = machine.execute(line.bytes, &mut out),
                    Part::Piece => {}
                    Part::Last { .. } => machine.skip_long_line(),
                }
            }
            machine.finish(&mut out);
            assert_eq!(*report, machine.report(), "text {k}");
            assert_eq!(errors, said, "text {k}");
            assert!(
                report.lines > 3000 && report.blocks > 2000,
                "text {k}: {} lines, {} blocks",
                report.lines,
                report.blocks
            );
        }
    }

    /// Regression (B5): 200 lines of `G4 S86400` ran 200 simulated days, 54 s of CPU with the
    /// hotend on. A file's run stops at 30 days; cold, the heaters rest and their loops are
    /// passed over, so the month costs a few loops a dwell (the hot month runs loop by loop,
    /// `interp`'s `a_clock_past_its_limit_halts_the_machine` holds that to the limit).
    #[test]
    fn two_hundred_days_of_dwell_stop_at_a_files_time_limit() {
        let dir = tempfile::tempdir().unwrap();
        let job = dir.path().join("dwell.gcode");
        std::fs::write(&job, "G4 S86400\n".repeat(200)).unwrap();
        let Simulation::Marlin { machine, report, errors } =
            simulate(&job, MachineProfile::default(), &SimSetup::default(), &mut Quiet).unwrap()
        else {
            panic!("the Marlin model runs the default profile")
        };
        assert!(report.halted);
        assert_eq!(report.lines, 31, "the 31st dwell passes the limit");
        assert_eq!(
            errors,
            ["Error:gweave-sim: the run reached its limit of 30 days of simulated time: stopped"]
        );
        assert_eq!(machine.thermal().now_s(), MAX_FILE_RUN_S);
        assert!(machine.thermal().loops_run() < 100, "{}", machine.thermal().loops_run());
    }

    #[test]
    fn a_missing_file_is_named() {
        let e = simulate(
            Path::new("/nowhere/job.gcode"),
            MachineProfile::default(),
            &SimSetup::default(),
            &mut Quiet,
        )
        .err()
        .unwrap();
        assert!(e.to_string().starts_with("reading /nowhere/job.gcode: "), "{e}");
    }
}
