//! Print-time estimation: stream a G-code file through the core parser and modal state, the
//! planner and the steppers, and add up the time per layer and per feature.
//!
//! ```
//! use gweave_sim::estimate;
//! use gweave_sim::{KlipperLimits, MotionProfile};
//!
//! let gcode = "G1 X100 F3000\nG4 P500\n";
//! let est = estimate(gcode.as_bytes(), &MotionProfile::klipper(KlipperLimits::default())).unwrap();
//! // 0.25 s start buffer, 100 mm at 50 mm/s with a = 3000, 0.5 s dwell, Klipper's final flush.
//! assert!((est.dwell_s - 0.5).abs() < 1e-12);
//! assert!((est.motion_s - (2.0 + 50.0 / 3000.0)).abs() < 1e-12);
//! ```
//!
//! What waits for the motion queue to drain, and so ends the lookahead at a stop: `G4`, `M400`,
//! `M109`/`M190` (the heating time itself is not estimated), `G28`, `M84`/`M18`, and Klipper's
//! `SET_KINEMATIC_POSITION`; `T<n>` as the machine's firmware changes tool ([`ToolChange`]:
//! Marlin with several extruders at every `T`, Klipper's `ACTIVATE_EXTRUDER` when the extruder
//! changes, a mixing hotend or a single extruder never). Arcs are cut into chords of at most 1 mm, as both firmwares do
//! (Klipper `[gcode_arcs] resolution`, Marlin `MM_PER_ARC_SEGMENT`). Moves before any `F` run at
//! both firmwares' default of 25 mm/s.
//!
//! In Klipper mode the total reproduces Klipper's batch-mode print time
//! (`Klipper3d/klipper:klippy/toolhead.py`, `extras/motion_queuing.py`, `extras/stepper_enable.py`):
//! it starts with a 0.25 s buffer (`BUFFER_TIME_START`) before the first move, `M84` stalls
//! twice for 0.1 s (`DISABLE_STALL_TIME`), and at exit the step generator has flushed 0.25 s
//! (`BGFLUSH_EXTRA_TIME`) past the last motion plus twice the 1 ms step-generation window, which
//! Klipper's reported print time includes. These go to `overhead_s`, not to any layer.
//!
//! Mixing hotends (a profile with `steps.mixing_e`): the mixing commands are followed with the
//! core's [`MixingState`] (Marlin `M163`/`M164`/`M165` virtual tools selected by `T<n>`,
//! RepRapFirmware `M567` mixes of tools), and the active mix splits the E steps of the
//! following moves. Firmware retraction (`G10`/`G11`) is an extrude-only move of the `M207`
//! length at Marlin's `RETRACT_FEEDRATE` (45 mm/s) and `RETRACT_RECOVER_FEEDRATE` (8 mm/s).
//!
//! [`Estimator`] is also the motion core of the virtual printer ([`crate::interp::Machine`]):
//! it splits a line into [`Estimator::lex`] and [`Estimator::apply`] (syntax and modal state) and [`Estimator::run`]
//! (planning), so the machine can look at, or change, what a line does in between (refuse a
//! cold extrusion, scale the feed by `M220`).
//!
//! Inside, the work has two sides that share nothing but a queue of jobs: the parse
//! side (`front`: lexer, modal state, time accounts, moves cut to straight chords) and the plan
//! side (`back`: planner, steppers, clock). [`Estimator`] runs them one after the other on each
//! line; [`estimate`] runs them on two threads of their own (the parse side reads the file too)
//! and gets the same result to the bit.

use std::collections::BTreeMap;
use std::io::Read;
use std::sync::mpsc;

use gweave::colour::dialect::{DialectError, MixingState};
use gweave::gcode::layers::Feature;
use gweave::gcode::state::{A, E, X, Y, Z};
use gweave::rotary::cylinder::RotaryConfig;
use gweave::{Block, Effect, Firmware, LineReader, RawLine, State};
use thiserror::Error;

use crate::inkjet::FireWait;
use crate::motion::kinematics::{Move, MoveError, Pos};
use crate::motion::limits::{MotionProfile, ProfileError};
use crate::motion::planner::PositionSet;
use crate::motion::speed_trace::SpeedTrace;
use crate::motion::stepper::{StepTotals, Steppers};
use crate::profile::MachineProfile;

mod back;
mod front;
mod modes;
mod report;
mod rotary_feed;
mod timer;
mod tool_change;

use back::Back;
use front::{Chords, Front};
pub use front::{HugeArcs, Malformed, Refused, MAX_ARC_CHORDS};
#[cfg(test)]
pub(crate) use modes::tests::silent;
pub(crate) use modes::{estimate_modes, modes_sides, Jobs, ModeEstimate, Modes, ModesParse, ModesPlan};
pub use report::{estimate_file, estimate_report, EstimateFileError, EstimateReport};
pub use tool_change::ToolChange;

/// Feed rate before the file sets one, mm/s (Klipper `gcode_move`, Marlin `feedrate_mm_s`).
pub(crate) const DEFAULT_FEED_MM_S: f64 = 25.0;
/// Longest chord an arc is cut into, mm.
pub(crate) const ARC_CHORD_MM: f64 = 1.0;
/// Klipper's `BUFFER_TIME_START`, s.
const KLIPPER_START_BUFFER_S: f64 = 0.25;
/// Klipper's two `DISABLE_STALL_TIME` dwells around `M84`, s.
const KLIPPER_MOTOR_OFF_S: f64 = 0.2;
/// Marlin's `RETRACT_FEEDRATE` and `RETRACT_RECOVER_FEEDRATE` for `G10`/`G11`, mm/s.
const FW_RETRACT_FEED_MM_S: f64 = 45.0;
const FW_RECOVER_FEED_MM_S: f64 = 8.0;
/// Klipper's step generation at exit: `BGFLUSH_EXTRA_TIME` past the last motion plus twice the
/// 1 ms `SDS_CHECK_TIME` scan window, s.
const KLIPPER_EXIT_FLUSH_S: f64 = 0.25 + 2.0 * 0.001;

/// Why a file could not be estimated.
#[derive(Debug, Error)]
pub enum EstimateError {
    /// Reading the input failed.
    #[error("reading G-code: {0}")]
    Io(#[from] std::io::Error),
    /// A move the planner cannot take.
    #[error("line {line}: {source}")]
    Move {
        /// 1-based line number.
        line: u64,
        /// What is wrong with it.
        source: MoveError,
    },
    /// A limit set by the file (M201, M203, M204, M205, `SET_VELOCITY_LIMIT`) or the profile
    /// itself (line 0) is invalid.
    #[error("line {line}: {source}")]
    Profile {
        /// 1-based line number, 0 for the profile given.
        line: u64,
        /// What is wrong with it.
        source: ProfileError,
    },
    /// A mixing command (`M163`-`M165`, `M567`, `T<n>` on a mixing hotend) that the firmware
    /// would refuse. [`Estimator::line`] ignores these; the virtual printer reports them.
    #[error("line {line}: {source}")]
    Mixing {
        /// 1-based line number.
        line: u64,
        /// What is wrong with it.
        source: DialectError,
    },
}

impl EstimateError {
    /// The 1-based line of the file at fault, if the error is about one (0: the profile given).
    pub fn line(&self) -> Option<u64> {
        match self {
            Self::Io(_) => None,
            Self::Move { line, .. } | Self::Profile { line, .. } | Self::Mixing { line, .. } => Some(*line),
        }
    }

    /// What is wrong, without the line.
    pub fn reason(&self) -> String {
        match self {
            Self::Io(e) => e.to_string(),
            Self::Move { source, .. } => source.to_string(),
            Self::Profile { source, .. } => source.to_string(),
            Self::Mixing { source, .. } => source.to_string(),
        }
    }
}

/// The estimated times of a file.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Estimate {
    /// Everything, s.
    pub total_s: f64,
    /// Time spent moving, s.
    pub motion_s: f64,
    /// `G4` dwells, s.
    pub dwell_s: f64,
    /// Firmware bookkeeping that belongs to no layer (see the module documentation), s.
    pub overhead_s: f64,
    /// Planned blocks (arcs count once per chord).
    pub blocks: u64,
    /// Motion and dwell before the first layer, s.
    pub unlayered_s: f64,
    /// Motion and dwell per layer (index = the core's 0-based layer), s.
    pub layer_s: Vec<f64>,
    /// Motion and dwell per feature, s.
    pub feature_s: BTreeMap<Feature, f64>,
    /// Steps per motor.
    pub steps: StepTotals,
    /// Lines skipped because they could not be read.
    #[serde(flatten)]
    pub malformed: Malformed,
    /// Arcs too long to cut into chords of `ARC_CHORD_MM`.
    #[serde(flatten)]
    pub huge_arcs: HugeArcs,
    /// Lines skipped because a word is out of its command's range, as the virtual printer
    /// refuses them.
    #[serde(flatten)]
    pub refused: Refused,
}

/// What a block's time is attributed to, the mix its E steps are split by and the tool they
/// are counted for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Key {
    layer: Option<u32>,
    feature: Feature,
    mix: usize,
    tool: u32,
}

/// What the parse side asks of the plan side, in file order.
#[derive(Debug)]
enum Job {
    /// Plan a straight move; `line` for its error.
    Move { mv: Move, line: u64 },
    /// Plan an arc's chords, cut as they are planned.
    Arc { chords: Box<Chords>, line: u64 },
    /// Plan every queued move to a stop (the firmware waits for its queue to drain).
    Drain,
    /// The logical position became `pos` without a move (`G92`, homing): a planner in whole
    /// steps re-sets the axes the firmware does.
    SetPosition { pos: Pos, by: PositionSet },
    /// A `G4` dwell, attributed to `tag` (after a [`Job::Drain`]).
    Dwell { t_s: f64, tag: u64 },
    /// Firmware bookkeeping time that belongs to no layer.
    Overhead { t_s: f64 },
    /// The key of the next tag number.
    Key(Key),
    /// The weights of the next mix number.
    Mix(Vec<f64>),
    /// The following moves drive this extruder.
    Tool(u32),
    /// The limits of mode `mode` changed (already checked by the parse side); a plan side
    /// takes its own mode's (0 for an estimate of one mode, [`modes`]).
    Profile { profile: Box<MotionProfile>, line: u64, mode: usize },
    /// The clock is read here: a progress line ([`modes`]).
    Mark,
}

/// A streaming estimator: feed it lines, then [`Estimator::finish`].
#[derive(Debug)]
pub struct Estimator {
    front: Front,
    back: Back,
    /// The jobs of the line being run; empty between calls.
    jobs: Vec<Job>,
}

impl Estimator {
    /// An estimator for a machine with this profile.
    pub fn new(profile: &MotionProfile) -> Result<Self, EstimateError> {
        Self::with_steps(profile, true)
    }

    /// An estimator that only keeps time, without stepping the motors: up to a fifth faster
    /// (what a transform's metadata needs).
    pub fn timing_only(profile: &MotionProfile) -> Result<Self, EstimateError> {
        Self::with_steps(profile, false)
    }

    /// An estimator for `machine` as its firmware runs it: its motion, each tool change waiting
    /// for the queued moves as the firmware makes it wait ([`ToolChange::of`]), and, on a
    /// machine with a printhead, the wait after each fire (`FireWait::of`); stepping the
    /// motors if `count_steps`. The lines are read as Marlin reads them until
    /// [`Estimator::read_as`] says otherwise.
    pub fn for_machine(machine: &MachineProfile, count_steps: bool) -> Result<Self, EstimateError> {
        let mut est = Self::with_steps(&machine.motion, count_steps)?;
        est.tool_changes(ToolChange::of(machine));
        if let Some(ink) = &machine.inkjet {
            est.fires(FireWait::of(&ink.printhead));
        }
        Ok(est)
    }

    /// An estimator that steps the motors (`count_steps`) or only keeps time, which is faster.
    fn with_steps(profile: &MotionProfile, count_steps: bool) -> Result<Self, EstimateError> {
        let back =
            Back::new(profile, count_steps).map_err(|source| EstimateError::Profile { line: 0, source })?;
        let mut jobs = Vec::new();
        let front = Front::new(profile, &mut jobs)?;
        let mut est = Self { front, back, jobs };
        est.execute()?;
        Ok(est)
    }

    /// Reads the lines to come as `firmware` reads them (a file's, [`Firmware::resolve`]d from
    /// its flavour as `stats` does): call before the first line. Without it, lines read as
    /// Marlin reads them.
    pub fn read_as(&mut self, firmware: Firmware) {
        self.front.read_as(firmware);
    }

    /// Reads the F of the moves to come as the rotary program's header declares it
    /// ([`RotaryConfig::from_header`]): a NIST or combined feed with the rotary axis A in
    /// degrees, or inverse time between `G93` and `G94` (`rotary_feed.rs`). Call before the
    /// first line; `gweave estimate` and the virtual printer both do for a file with the header.
    pub fn declare_rotary(&mut self, machine: RotaryConfig) {
        self.front.declare_rotary(machine);
    }

    /// Counts the wait after each fire of a printhead (`M700`/`M578`, `FireWait`), as the
    /// firmware of an inkjet machine waits. Call before the first line.
    pub fn fires(&mut self, fire: FireWait) {
        self.front.fires(fire);
    }

    /// Changes tool as the machine's firmware does ([`ToolChange::of`] the machine): whether a
    /// `T<n>` waits for the queued moves. Call before the first line; without it, nothing waits
    /// (one extruder, or a mixing hotend).
    pub fn tool_changes(&mut self, tool_change: ToolChange) {
        self.front.tool_changes(tool_change);
    }

    /// How a `T<n>` is carried out ([`Estimator::tool_changes`]).
    pub fn tool_change(&self) -> ToolChange {
        self.front.tool_change()
    }

    /// Whether a move was queued since the last `M400` or `G4` (a fire would land along it).
    pub fn moved_since_m400(&self) -> bool {
        self.front.moved_since_m400()
    }

    /// Keeps the first layer's time apart ([`Estimate::layer_s`]`[0]`, the same to the bit) and
    /// accounts every later layer as one (`layer_s[1]`), so that memory does not grow with the
    /// layers: what a transform's metadata needs (its total and first layer). Call before the
    /// first line.
    pub fn first_layer_only(&mut self) {
        self.front.first_layer_only();
    }

    /// Execute one line (without its line ending). Mixing commands the firmware would refuse
    /// are skipped, and so are lines with a word out of its command's range, as the virtual
    /// printer refuses them ([`Estimate::refused`]).
    pub fn line(&mut self, raw: &[u8]) -> Result<(), EstimateError> {
        self.front.lex(raw);
        if self.front.refuses(raw) {
            return Ok(());
        }
        let effect = *self.front.apply(raw);
        skip_mixing_errors(self.run(raw, &effect))
    }

    /// [`Estimator::line`] for a line from a [`LineReader`],
    /// whose look-ahead bytes speed up the lexer: the same result to the bit. The pieces of a
    /// line longer than [`MAX_LINE`](gweave::gcode::reader::MAX_LINE) count as one malformed
    /// line ([`Estimator::skip_long_line`]).
    pub fn read_line(&mut self, line: &RawLine<'_>) -> Result<(), EstimateError> {
        let ran = self.front.step(line, &mut self.jobs);
        // What the line did before an error still happens, as in firmware.
        self.execute()?;
        skip_mixing_errors(ran)
    }

    /// First of a line's two steps, for a caller that checks the words before the
    /// line changes anything (the virtual printer refuses a value out of range, as GRBL's
    /// parser checks a whole line first): read the line into [`Estimator::block`]...
    pub fn lex(&mut self, raw: &[u8]) {
        self.front.lex(raw)
    }

    /// [`Estimator::lex`] for a line already lexed into `block`, which gets the block it
    /// replaces.
    pub fn take_lexed(&mut self, block: &mut Block) {
        self.front.take_lexed(block)
    }

    /// ...then apply it to the modal state and say what it does (kept in
    /// [`State::effect`] until the next line).
    pub fn apply(&mut self, raw: &[u8]) -> &Effect {
        self.front.apply(raw)
    }

    /// Second half of [`Estimator::line`]: carry out `effect` (normally what
    /// [`Estimator::apply`] returned for `raw`, possibly changed by the caller) and the line's
    /// motion-related commands.
    pub fn run(&mut self, raw: &[u8], effect: &Effect) -> Result<(), EstimateError> {
        let ran = self.front.run(raw, effect, &mut self.jobs);
        // What the line did before an error still happens, as in firmware.
        self.execute()?;
        ran
    }

    /// [`Estimator::run`] for the effect the modal state made of `raw` ([`Estimator::apply`]),
    /// read where it is, in [`State::effect`]: the caller
    /// changes it there (through [`Estimator::state_mut`]) instead of copying it.
    pub fn run_applied(&mut self, raw: &[u8]) -> Result<(), EstimateError> {
        let ran = self.front.run_applied(raw, &mut self.jobs);
        // What the line did before an error still happens, as in firmware.
        self.execute()?;
        ran
    }

    /// Hand the pending jobs to the plan side.
    fn execute(&mut self) -> Result<(), EstimateError> {
        let result = self.jobs.iter().try_for_each(|job| self.back.execute(job));
        self.jobs.clear();
        result
    }

    /// The line last parsed.
    pub fn block(&self) -> &Block {
        &self.front.block
    }

    /// The modal state after the line last parsed.
    pub fn state(&self) -> &State {
        &self.front.state
    }

    /// The modal state, to set what the machine found out itself (the position after homing).
    pub fn state_mut(&mut self) -> &mut State {
        &mut self.front.state
    }

    /// The machine homed `axes` (bit i: axis i of X Y Z) and the caller set where that left it
    /// in [`Estimator::state_mut`]: the planner takes its position afresh from there, as the
    /// firmware does after homing.
    pub fn homed(&mut self, axes: u8) {
        let pos = front::at(&self.front.state.pos);
        self.back.planner.set_position(pos, PositionSet::Home { axes });
    }

    /// Lines parsed so far (the 1-based number of the last one).
    pub fn line_number(&self) -> u64 {
        self.front.line
    }

    /// The clock: the end of the last block executed plus dwells and waits, s. Queued moves
    /// are not counted until they leave the planner.
    pub fn now_s(&self) -> f64 {
        self.back.acc.t_s
    }

    /// Moves waiting in the lookahead queue.
    pub fn queued(&self) -> usize {
        self.back.planner.queued()
    }

    /// The motion profile in force (M201-M205 change it).
    pub fn profile(&self) -> &MotionProfile {
        self.back.planner.profile()
    }

    /// The motors.
    pub fn steppers(&self) -> &Steppers {
        &self.back.acc.steppers
    }

    /// The motors, to step what the planner does not plan (homing).
    pub fn steppers_mut(&mut self) -> &mut Steppers {
        &mut self.back.acc.steppers
    }

    /// Record the planned speed over time from now on ([`Estimator::speed_trace`]).
    pub fn record_speed(&mut self) {
        self.back.acc.speed.get_or_insert_with(Default::default);
    }

    /// The planned speed over time, if [`Estimator::record_speed`] was called.
    pub fn speed_trace(&self) -> Option<&SpeedTrace> {
        self.back.acc.speed.as_deref()
    }

    /// The mixing state, for a profile with mixing inputs.
    pub fn mixing(&self) -> Option<&MixingState> {
        self.front.mixing.as_ref()
    }

    /// Let `t_s` pass with the machine standing still, attributed to no layer (heating,
    /// homing). Plan the queue first with [`Estimator::drain`].
    pub fn idle(&mut self, t_s: f64) {
        if t_s > 0.0 {
            self.back.acc.t_s += t_s;
        }
    }

    /// An emergency stop: the moves still queued in the planner are dropped unexecuted (they
    /// add no time, no steps, no filament) and the position goes back to where the executed
    /// blocks left the machine, in the coordinates in force (a `G92` after a dropped move
    /// keeps its shift: the dropped distances are taken off, not the old positions put back).
    /// Returns the filament the dropped moves would have fed, mm.
    pub fn quick_stop(&mut self) -> f64 {
        let undone = self.back.planner.discard();
        let pos = &mut self.front.state.pos;
        for (axis, d) in [X, Y, Z, E, A].into_iter().zip(undone) {
            pos[axis] -= d;
        }
        undone[3]
    }

    /// Plan every queued move to a stop and execute it (what `M400` waits for).
    pub fn drain(&mut self) {
        self.back.drain();
    }

    /// Plan the rest and return the estimate.
    pub fn finish(mut self) -> Estimate {
        self.end();
        self.summary()
    }

    /// The end of the file: plan the rest and, in Klipper mode, add its exit flush. Call once.
    pub fn end(&mut self) {
        self.back.end();
    }

    /// The times so far (moves still queued in the planner are not counted).
    pub fn summary(&self) -> Estimate {
        Estimate {
            malformed: self.front.malformed,
            huge_arcs: self.front.huge_arcs(),
            refused: self.front.refused.clone(),
            ..self.back.summary()
        }
    }

    /// Counts a line longer than [`MAX_LINE`](gweave::gcode::reader::MAX_LINE) (given in
    /// pieces by the line reader; call this for its last) as a malformed line, not read.
    pub fn skip_long_line(&mut self) {
        self.front.skip_long_line();
    }
}

/// The firmware refuses a bad mixing command and goes on; so does the estimate. Inlined: it is
/// called for every line, and as a call it cost 16 instructions a line of `estimate`.
#[inline(always)]
fn skip_mixing_errors(result: Result<(), EstimateError>) -> Result<(), EstimateError> {
    match result {
        Err(EstimateError::Mixing { .. }) => Ok(()),
        other => other,
    }
}

/// Jobs handed from one thread to the other at a time: large enough that the hand-over costs
/// nothing per line, small enough to stay in the cache.
const BATCH: usize = 1024;
/// An empty batch. The room past [`BATCH`] takes the last line's jobs (an arc's chords, a
/// few dozen at most on real files) without growing.
fn new_batch() -> Vec<Job> {
    Vec::with_capacity(BATCH + 64)
}
/// Batches in flight between the threads; with [`BATCH`] this bounds the memory in between
/// (under 1 MB).
const BATCHES_IN_FLIGHT: usize = 4;

/// Estimate a whole file read from `input`, step counts included. Two threads share the work:
/// one reads the file, lexes the lines and follows the modal state, one plans and steps. The
/// result is the same, to the bit, as feeding every line to one [`Estimator`] (the plan side
/// sees the same jobs in the same order); the memory is bounded by the read buffer and the
/// batches in flight.
/// The lines are read as Marlin reads them; `estimate_report` runs an estimator set up otherwise
/// ([`Estimator::for_machine`], [`Estimator::read_as`]).
pub fn estimate<R: Read + Send>(input: R, profile: &MotionProfile) -> Result<Estimate, EstimateError> {
    estimate_on(input, Estimator::new(profile)?)
}

/// [`estimate`] without the step counts (all zero), up to a fifth faster.
pub fn estimate_time<R: Read + Send>(input: R, profile: &MotionProfile) -> Result<Estimate, EstimateError> {
    estimate_on(input, Estimator::timing_only(profile)?)
}

/// [`estimate`] on `estimator`, set up and fed no line yet (its firmware, the machine's tool
/// changes and fires, a rotary program's feed: see `estimate_report`).
pub(crate) fn estimate_on<R: Read + Send>(input: R, estimator: Estimator) -> Result<Estimate, EstimateError> {
    let Estimator { mut front, mut back, jobs } = estimator;
    debug_assert!(jobs.is_empty());
    let (to_back, batches) = mpsc::sync_channel::<Vec<Job>>(BATCHES_IN_FLIGHT);
    let (return_batch, spare_batches) = mpsc::channel::<Vec<Job>>();
    std::thread::scope(|scope| {
        let planning = scope.spawn(move || -> Result<Back, EstimateError> {
            for mut batch in batches {
                for job in &batch {
                    back.execute(job)?;
                }
                batch.clear();
                // The parse side may have finished and gone: then the batch is not needed.
                let _ = return_batch.send(batch);
            }
            Ok(back)
        });
        let mut batch = new_batch();
        let handover = Handover { to_back: &to_back, spare: &spare_batches };
        let parsed = parse_lines(LineReader::new(input), &mut front, &mut batch, &handover);
        // The lines before an error are planned too: one of them may hold an earlier error. A
        // closed channel means the plan side stopped on an error, which it returns.
        let _ = to_back.send(batch);
        drop(to_back);
        // The plan side is behind the parse side: its error, if any, is on an earlier line.
        let mut back = planning.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        parsed?;
        back.end();
        Ok(Estimate {
            malformed: front.malformed,
            huge_arcs: front.huge_arcs(),
            refused: front.refused,
            ..back.summary()
        })
    })
}

/// Where the parse side hands its batches and takes empty ones.
struct Handover<'a> {
    to_back: &'a mpsc::SyncSender<Vec<Job>>,
    spare: &'a mpsc::Receiver<Vec<Job>>,
}

/// The parse side: every line read, lexed and followed through the modal state on this thread,
/// into jobs, sent in batches. Stops early, with `Ok`, when the plan side has stopped (it
/// reports its error itself).
///
/// Reading and lexing on a thread of their own ([`gweave::gcode::lexed`], as `stats` does) cost
/// more than they saved here: each line's block was written out to memory and read back on
/// another core, and the three threads shared two cores (docs/performance.md, "Estimate on two
/// threads").
fn parse_lines<R: Read>(
    mut reader: LineReader<R>,
    front: &mut Front,
    batch: &mut Vec<Job>,
    handover: &Handover,
) -> Result<(), EstimateError> {
    // A stopped run (Python's Ctrl-C) stops here too, not only at the reader: the lines
    // already read would otherwise be parsed and planned first. It is looked at with each batch
    // (a millisecond of parsing), not every few thousand lines by a count of its own (6
    // instructions a line): lines that make no job cost little, and the reader stops at its
    // next read.
    let stop = gweave::Token::current();
    while let Some(line) = reader.next_line()? {
        skip_mixing_errors(front.read(&line, batch))?;
        if batch.len() >= BATCH {
            if let Some(stop) = &stop {
                stop.check()?;
            }
            let next = handover.spare.try_recv().unwrap_or_else(|_| new_batch());
            if handover.to_back.send(std::mem::replace(batch, next)).is_err() {
                return Ok(());
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use gweave::LineReader;

    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn marlin_layers_features_dwell_and_m204() {
        let text = ";FLAVOR:Marlin\n;LAYER:0\n;TYPE:WALL-OUTER\nG1 X10 E1 F600\n;LAYER:1\n;TYPE:FILL\n\
                    G1 X20 E2\nG4 P1000\nM204 T500\nG0 X30 F6000\n";
        let est = estimate(text.as_bytes(), &MotionProfile::default()).unwrap();
        // In Marlin's steps (80/mm, a = 240000 steps/s²): two collinear 10 mm moves at 10 mm/s
        // (800 steps/s) from and to 120 steps/s: 2 steps up, then 1 step down before the dwell.
        let (leg0, leg1) = (4.0 / 920.0 + 798.0 / 800.0, 799.0 / 800.0 + 2.0 / 920.0);
        // The travel with M204 T500 (40000 steps/s²) cannot reach 8000 steps/s: 400 steps up to
        // trunc(sqrt(120² + 80000 * 400)) = 5658 steps/s and 400 down.
        let travel = 1600.0 / 5778.0;
        assert!(close(est.layer_s[0], leg0), "{est:?}");
        assert!(close(est.layer_s[1], leg1 + 1.0 + travel), "{est:?}");
        assert!(close(est.feature_s[&Feature::OuterWall], leg0));
        assert!(close(est.feature_s[&Feature::Infill], leg1 + 1.0 + travel));
        assert!(close(est.total_s, leg0 + leg1 + 1.0 + travel));
        assert_eq!((est.dwell_s, est.overhead_s, est.blocks), (1.0, 0.0, 3));
        assert_eq!(est.steps.axes[0], 30 * 80);
    }

    #[test]
    fn arcs_are_cut_into_chords() {
        // A half circle of radius 10 (31.4 mm) becomes 32 chords, ending exactly at X20.
        let est =
            estimate("G1 X0 Y0 F600\nG2 X20 Y0 I10 J0\n".as_bytes(), &MotionProfile::default()).unwrap();
        assert_eq!(est.blocks, 32);
        assert_eq!(est.steps.axes[0], 20 * 80);
    }

    /// Regression (a refused arc was planned as a straight move): an arc Marlin refuses takes
    /// no time and moves nothing, the next move starts where the machine stayed, and the
    /// estimate counts the line refused.
    #[test]
    fn a_refused_arc_takes_no_time() {
        let refused =
            estimate("G1 X0 Y0 F600\nG2 X20 Y0 E5\nG1 Y10\n".as_bytes(), &MotionProfile::default()).unwrap();
        let without = estimate("G1 X0 Y0 F600\nG1 Y10\n".as_bytes(), &MotionProfile::default()).unwrap();
        assert_eq!(
            (refused.total_s, refused.blocks, refused.steps.axes),
            (without.total_s, 1, without.steps.axes)
        );
        assert_eq!(refused.refused.refused_lines, 1);
        assert_eq!(refused.refused.first_refused_line, Some(2));
        let why = refused.refused.first_refusal.as_deref();
        assert_eq!(why, Some("the arc is refused: an arc needs R or a non-zero I or J"));
    }

    #[test]
    fn a_huge_arc_is_planned_without_a_vec_of_chords() {
        // A radius of 10 000 inches (the registry's ranges are on the words as written), 254 m:
        // 1.6 million chords of 1 mm.
        let text = "G20\nG1 X0 Y0 F600\nG2 X0 Y0 I10000 J0 E1\nG1 X10\n";
        let mut est = Estimator::new(&MotionProfile::default()).unwrap();
        for line in text.lines() {
            est.line(line.as_bytes()).unwrap();
            assert!(est.jobs.capacity() < 64, "{} jobs held", est.jobs.capacity());
        }
        let sequential = est.finish();
        assert_eq!(sequential.huge_arcs, HugeArcs { huge_arcs: 1, first_huge_arc_line: Some(3) });
        // The first move goes nowhere: the arc's chords and the last move.
        assert_eq!(sequential.blocks, u64::from(MAX_ARC_CHORDS) + 1);
        let threaded = estimate(text.as_bytes(), &MotionProfile::default()).unwrap();
        assert_eq!(threaded, sequential);
    }

    /// A printhead's fire waits 800 us when nothing moves: after `M400` or `G4`, for `P` naming
    /// one of the heads; not while moves run (no `M400` since), nor without a head.
    #[test]
    fn a_fire_waits_only_with_nothing_moving_and_a_head_named() {
        let fire = FireWait { wait_s: 800e-6, heads: 2 };
        let dwell_s = |text: &str| {
            let threaded = |fire: Option<FireWait>| {
                let mut est = Estimator::timing_only(&MotionProfile::default()).unwrap();
                if let Some(fire) = fire {
                    est.fires(fire);
                }
                estimate_on(text.as_bytes(), est).unwrap()
            };
            assert_eq!(threaded(None).dwell_s, 0.0, "{text}: no printhead, no wait");
            let mut est = Estimator::new(&MotionProfile::default()).unwrap();
            est.fires(fire);
            text.lines().for_each(|l| est.line(l.as_bytes()).unwrap());
            let sequential = est.finish();
            assert_eq!(threaded(Some(fire)).dwell_s, sequential.dwell_s, "{text}");
            sequential.dwell_s
        };
        assert_eq!(dwell_s("G1 X10 F600\nM400\nM700 P0 S3\nM700 P1 S1\nM578 P1 S1\n"), 3.0 * 800e-6);
        assert_eq!(dwell_s("G1 X10 F600\nM700 P0 S3\n"), 0.0);
        assert_eq!(dwell_s("G1 X10 F600\nM400\nG1 X20\nM700 P0 S3\n"), 0.0);
        assert_eq!(dwell_s("G1 X10 F600\nG4 P0\nM700 P1 S3\n"), 800e-6);
        assert_eq!(dwell_s("M400\nM700 S3\nM700 P2 S3\nM700 P0.4 S1\n"), 800e-6);
        // A negative head is out of the registry's range: refused, as the virtual printer
        // refuses it, so it fires nothing.
        assert_eq!(dwell_s("M400\nM700 P-1 S1\n"), 0.0);
    }

    #[test]
    fn malformed_lines_are_counted_not_dropped() {
        let text = "G1 X10 F600\nG1 X1..2\n\0\0\0\nG1 X20\n";
        let est = estimate(text.as_bytes(), &MotionProfile::default()).unwrap();
        assert_eq!(est.malformed, Malformed { malformed_lines: 2, first_malformed_line: Some(2) });
        assert_eq!(est.blocks, 2);
    }

    /// Every line through one [`Estimator`], on this thread.
    fn sequential(text: &[u8], profile: &MotionProfile) -> Result<Estimate, EstimateError> {
        let mut est = Estimator::new(profile)?;
        let mut reader = LineReader::new(text);
        while let Some(line) = reader.next_line()? {
            est.line(line.bytes)?;
        }
        Ok(est.finish())
    }

    fn fixture(path: &str) -> Vec<u8> {
        std::fs::read(format!("{}/../../tests/data/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap()
    }

    #[test]
    fn threads_give_the_one_thread_result_to_the_bit() {
        let klipper = MotionProfile::klipper(crate::motion::limits::KlipperLimits::default());
        for path in [
            "prusaslicer/pr_bunny_3tool_rel.gcode",
            "prusaslicer/pr_sphere_rrf_fwretract.gcode",
            "cura/cura_torus.gcode",
            "slic3r/slic3r_cone_2tool.gcode",
        ] {
            let text = fixture(path);
            for profile in [&MotionProfile::default(), &klipper] {
                let one = sequential(&text, profile).unwrap();
                let two = estimate(&text[..], profile).unwrap();
                // Bit for bit: the same jobs reach the planner in the same order.
                assert_eq!(one, two, "{path}");
                assert!(one.blocks > 1000 && one.steps.axes[0] > 0, "{path}: {one:?}");
                let time_only = estimate_time(&text[..], profile).unwrap();
                assert_eq!(time_only.total_s.to_bits(), one.total_s.to_bits(), "{path}");
                assert_eq!(time_only.layer_s, one.layer_s, "{path}");
                assert_eq!(time_only.steps.axes, [0; 5], "{path}");
            }
        }
    }

    /// Regression: a transform's metadata estimate kept an account per layer, feature and tool
    /// (purge-shift's peak memory grew from 17 MB to 50 MB with 60 times the layers).
    #[test]
    fn first_layer_only_keeps_the_first_layer_to_the_bit_in_two_accounts() {
        let text = fixture("prusaslicer/pr_bunny_3tool_rel.gcode");
        let all = sequential(&text, &MotionProfile::default()).unwrap();
        let mut est = Estimator::new(&MotionProfile::default()).unwrap();
        est.first_layer_only();
        let mut reader = LineReader::new(&text[..]);
        while let Some(line) = reader.next_line().unwrap() {
            est.read_line(&line).unwrap();
        }
        let folded = est.finish();
        assert!(all.layer_s.len() > 100, "{}", all.layer_s.len());
        assert_eq!(folded.layer_s.len(), 2);
        assert_eq!(folded.layer_s[0].to_bits(), all.layer_s[0].to_bits());
        assert_eq!(folded.total_s.to_bits(), all.total_s.to_bits());
        assert_eq!((folded.blocks, folded.steps), (all.blocks, all.steps));
    }

    #[test]
    fn an_error_planning_a_late_line_is_reported_with_that_line() {
        // Thousands of lines (several batches between the threads), then two relative turns of
        // 9.99e307 degrees (A has no range: a rotary program counts its turns), which is
        // finite, then infinite: the planner refuses the second.
        let mut text = String::from("G1 F600\n");
        for i in 0..3000 {
            text.push_str(&format!("G1 X{}\n", i % 7));
        }
        let huge = "9".repeat(308);
        text.push_str(&format!("G91\nG1 A{huge}\nG1 A{huge}\nG1 X1\nM204 S-5\n"));
        let err = estimate(text.as_bytes(), &MotionProfile::default()).unwrap_err();
        assert!(
            matches!(err, EstimateError::Move { line: 3004, source: MoveError::NonFinitePosition }),
            "{err}"
        );
        let err = sequential(text.as_bytes(), &MotionProfile::default()).unwrap_err();
        assert!(matches!(err, EstimateError::Move { line: 3004, .. }), "{err}");
    }

    /// A limit the planner cannot take stops the estimate at its line: Klipper's
    /// `SET_VELOCITY_LIMIT` has no declared ranges, its values are checked by the planner.
    #[test]
    fn bad_input_is_an_error_with_its_line() {
        let klipper = MotionProfile::klipper(crate::motion::limits::KlipperLimits::default());
        let text = "G1 X1 F600\nSET_VELOCITY_LIMIT ACCEL=-5\n";
        let err = estimate(text.as_bytes(), &klipper).unwrap_err();
        assert!(matches!(err, EstimateError::Profile { line: 2, .. }), "{err}");
    }

    /// Regression (estimate_plans_values_sim_refuses): a word outside its command's range (the
    /// virtual printer's registry) was planned: `G4 P` of 10^30 ms, a move of 10^29 mm. Such
    /// a line is skipped and counted, on both the threaded and the line-by-line path, and the
    /// lines around it are planned as before: one 10 mm move at 10 mm/s and a 1 s dwell.
    #[test]
    fn a_word_out_of_its_range_is_refused_and_counted() {
        let huge = format!("1{}", "0".repeat(29));
        let text = format!("G1 X10 F600\nG4 P{huge}0\nG1 X{huge}\nM204 S-5\nG1 F0\nG4 S1\n");
        let threaded = estimate(text.as_bytes(), &MotionProfile::default()).unwrap();
        assert_eq!(threaded, sequential(text.as_bytes(), &MotionProfile::default()).unwrap());
        let first = "G4 P = 1e30 is out of range: 0 to 86400000 ms".to_owned();
        assert_eq!(
            threaded.refused,
            Refused { refused_lines: 4, first_refused_line: Some(2), first_refusal: Some(first) }
        );
        assert_eq!((threaded.blocks, threaded.dwell_s, threaded.steps.axes[0]), (1, 1.0, 800));
        // The refused lines cost nothing: the time is that of the text without them.
        let kept = estimate(&b"G1 X10 F600\nG4 S1\n"[..], &MotionProfile::default()).unwrap();
        assert_eq!(threaded.total_s, kept.total_s);
    }
}
