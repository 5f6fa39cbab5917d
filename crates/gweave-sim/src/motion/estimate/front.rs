//! The parse side of the estimator: lines go through the core lexer and modal state, and come
//! out as [`Job`]s for the plan side ([`super::back::Back`]): moves cut to straight chords, waits
//! for the queue to drain, dwells, limit changes. Everything the G-code file decides lives
//! here; nothing here depends on what the planner has done, so the two sides can run on two
//! threads ([`super::estimate`]).

use std::collections::HashMap;

use gweave::colour::dialect::{MixingState, MARLIN_VIRTUAL_TOOLS};
use gweave::gcode::arc::Arc;
use gweave::gcode::layers::Structure;
use gweave::gcode::lexer::{parse_into, parse_line, parse_line_lean};
use gweave::gcode::line::PlainMove;
use gweave::gcode::reader::Part;
use gweave::gcode::state::{self, Path};
use gweave::rotary::cylinder::RotaryConfig;
use gweave::RefusedWord;
use gweave::{Block, Command, Effect, Firmware, MixingCode, RawLine, Severity, State, StateOptions};

use super::rotary_feed::DeclaredFeed;
use super::tool_change::ToolChange;
mod plain_move;

use super::{
    EstimateError, Job, Key, ARC_CHORD_MM, DEFAULT_FEED_MM_S, FW_RECOVER_FEED_MM_S, FW_RETRACT_FEED_MM_S,
    KLIPPER_MOTOR_OFF_S, KLIPPER_START_BUFFER_S,
};
use crate::inkjet::FireWait;
use crate::interp::commands;
use crate::motion::kinematics::{Move, Pos};
use crate::motion::limits::{AxisUpdate, CornerMode, MotionProfile, ProfileError, M204};
use crate::motion::planner::{Planner, PositionSet};

/// Parser, modal state and the bookkeeping that turns lines into jobs.
#[derive(Debug, Clone)]
pub(super) struct Front {
    pub(super) block: Block,
    pub(super) state: State,
    /// The profile the plan side runs with, kept in step through [`Job::Profile`].
    pub(super) profile: MotionProfile,
    /// The profiles of the other modes the same lines are planned in (a file's silent mode:
    /// [`super::modes`]), each changed by the same commands; empty for one plan side.
    pub(super) other_modes: Vec<MotionProfile>,
    book: Bookkeeping,
    mix_index: HashMap<Vec<u64>, usize>,
    /// The mixing commands' state, for a profile with mixing inputs.
    pub(super) mixing: Option<MixingState>,
    pub(super) line: u64,
    /// Lines with an error, skipped as firmware skips them.
    pub(super) malformed: Malformed,
    /// Lines with a word out of its range, skipped as the virtual printer refuses them.
    pub(super) refused: Refused,
    /// The feed convention a rotary program declared in its header ([`Front::declare_rotary`]):
    /// `None` for every other file, which then costs one untaken branch a line.
    rotary: Option<DeclaredFeed>,
    /// Whether a `T<n>` waits for the queued moves ([`Front::tool_changes`]).
    tool_change: ToolChange,
    /// The plain move of the line `estimate`'s own reader read last (`plain_move.rs`).
    plain: PlainMove,
}

/// Arcs longer than [`MAX_ARC_CHORDS`] chords of `ARC_CHORD_MM` (over 100 m: no printer's
/// bed), planned with that many longer chords, and counted with the first one's line.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct HugeArcs {
    /// How many arcs.
    pub huge_arcs: u64,
    /// The line of the first, 1-based.
    pub first_huge_arc_line: Option<u64>,
}

impl HugeArcs {
    fn add(&mut self, line: u64) {
        self.huge_arcs += 1;
        self.first_huge_arc_line.get_or_insert(line);
    }
}

/// Lines with a word outside the range its command declares (the virtual printer's registry,
/// `interp::commands`): skipped, as the virtual printer refuses them, and counted.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct Refused {
    /// How many lines.
    pub refused_lines: u64,
    /// The first of them, 1-based.
    pub first_refused_line: Option<u64>,
    /// Why the first was refused (`G4 S = 1e30 is out of range: 0 to 86400 s`).
    pub first_refusal: Option<String>,
}

/// The most chords an arc is cut into: 100 m of arc at `ARC_CHORD_MM`. A `G2` with
/// `I10000000` would otherwise be 63 million chords, half a minute of planning.
pub const MAX_ARC_CHORDS: u32 = 100_000;

/// Lines that could not be read: the engine's tally, as `stats --lenient` reports it.
pub use gweave::Malformed;

/// What turns a move into jobs besides the move itself: its time account (tag) and the
/// firmware's fixed overheads. Apart from the state, so that a move can be read in place from
/// the state's effect while this changes.
#[derive(Debug, Clone)]
struct Bookkeeping {
    key_index: HashMap<Key, u64>,
    /// The last key looked up and its tag.
    last_tag: Option<(Key, u64)>,
    mix: usize,
    /// The selected tool (`T<n>` carried out by [`Front::run`]), for per-tool E steps.
    tool: u32,
    klipper: bool,
    started: bool,
    motors_on: bool,
    /// Arcs of more than [`MAX_ARC_CHORDS`] chords.
    huge_arcs: HugeArcs,
    /// Every layer after the first is accounted as one ([`Front::first_layer_only`]).
    fold_later_layers: bool,
    /// The printhead's wait after a fire, on a machine that has one ([`Front::fires`]).
    fire: Option<FireWait>,
    /// Whether a move was queued since the last `M400` or `G4`: a fire then runs while the
    /// carriage travels and waits no time of its own.
    moved_since_m400: bool,
}

impl Front {
    /// The parse side for `profile`, with the jobs that set up the plan side (the first mix).
    pub(super) fn new(profile: &MotionProfile, jobs: &mut Vec<Job>) -> Result<Self, EstimateError> {
        let klipper = matches!(profile.corners, CornerMode::Klipper(_));
        let mixing = match profile.steps.mixing_e.len() {
            0 => None,
            n => Some(
                MixingState::new(n, MARLIN_VIRTUAL_TOOLS)
                    .map_err(|source| EstimateError::Mixing { line: 0, source })?,
            ),
        };
        let book = Bookkeeping {
            key_index: HashMap::new(),
            last_tag: None,
            mix: 0,
            tool: 0,
            klipper,
            started: false,
            motors_on: false,
            huge_arcs: HugeArcs::default(),
            fold_later_layers: false,
            fire: None,
            moved_since_m400: true,
        };
        let mut front = Self {
            block: Block::default(),
            state: State::default(),
            profile: profile.clone(),
            other_modes: Vec::new(),
            book,
            mix_index: HashMap::new(),
            mixing,
            line: 0,
            malformed: Malformed::default(),
            refused: Refused::default(),
            rotary: None,
            tool_change: ToolChange::default(),
            plain: PlainMove::default(),
        };
        front.refresh_mix(jobs);
        Ok(front)
    }

    /// Reads the lines to come as `firmware` reads them (the file's, [`Firmware::resolve`]d as
    /// `stats` resolves it): before the first line, as the modal state starts afresh.
    pub(super) fn read_as(&mut self, firmware: Firmware) {
        self.state = State::new(StateOptions { firmware, ..StateOptions::default() });
    }

    /// Reads the F of the moves to come as a rotary program's header declares them (see
    /// `rotary_feed.rs`): before the first line. A machine the convention cannot be honoured
    /// on (a rotary axis in millimetres) keeps the firmware model's reading.
    pub(super) fn declare_rotary(&mut self, machine: RotaryConfig) {
        self.rotary = DeclaredFeed::new(machine);
    }

    /// Changes tool as `tool_change` says the machine's firmware does: before the first line.
    pub(super) fn tool_changes(&mut self, tool_change: ToolChange) {
        self.tool_change = tool_change;
    }

    /// How a `T<n>` is carried out ([`Front::tool_changes`]).
    pub(super) fn tool_change(&self) -> ToolChange {
        self.tool_change
    }

    /// `G93` (`true`) or `G94`: in a rotary program, the F of the moves to come is one over
    /// their minutes, or per minute; elsewhere F keeps the firmware model's reading.
    pub(super) fn inverse_time(&mut self, on: bool) {
        if let Some(declared) = &mut self.rotary {
            declared.inverse_time = on;
        }
    }

    /// In a rotary program, the F of the move the modal state just made rewritten so that the
    /// firmware model takes the time the declared convention gives ([`DeclaredFeed`]). One
    /// place for `estimate` ([`Front::lexed`]) and the virtual printer ([`Front::apply`]).
    #[inline(always)]
    fn read_rotary_feed(&mut self) {
        if let Some(declared) = &self.rotary {
            if let Effect::Move(m) = &mut self.state.effect {
                declared.rewrite_feed(m, &self.profile.steps, !self.book.klipper);
            }
        }
    }

    /// First half of reading a line: read the line's words into [`Front::block`], counting
    /// it; the modal state is not touched yet.
    pub(super) fn lex(&mut self, raw: &[u8]) {
        parse_into(raw, &mut self.block);
        self.count_lexed();
    }

    /// [`Front::lex`] for a line lexed already, into `block` (by another thread): it is taken
    /// in, and `block` gets the one it replaces, for the lexer to reuse.
    pub(super) fn take_lexed(&mut self, block: &mut Block) {
        std::mem::swap(&mut self.block, block);
        self.count_lexed();
    }

    /// Counts the line now in [`Front::block`].
    #[inline(always)]
    fn count_lexed(&mut self) {
        self.line += 1;
        count_malformed(&mut self.malformed, self.line, &self.block);
    }

    /// Whether the line just read ([`Front::lex`]) has a word outside the range its command
    /// declares: then none of it happens (the caller applies nothing), as the virtual printer
    /// refuses it, and it is counted in [`Front::refused`]. The same check as the virtual
    /// printer's, on the same ranges ([`commands::check_line`]); every command is taken as built.
    #[inline(always)]
    pub(super) fn refuses(&mut self, raw: &[u8]) -> bool {
        match commands::check_line(&self.block, raw, self.state.motion, |c| commands::lookup(c, b"")) {
            Ok(()) => false,
            Err(refusal) => {
                self.refuse(refusal);
                true
            }
        }
    }

    #[cold]
    #[inline(never)]
    fn refuse(&mut self, refusal: RefusedWord) {
        self.count_refused(|| refusal.to_string());
        // Nothing of the line happened: a reader of the state's effect (`modes`) sees none.
        self.state.effect = Effect::None;
    }

    /// Counts the line just read as refused, `why` the first time.
    #[cold]
    fn count_refused(&mut self, why: impl FnOnce() -> String) {
        let refused = &mut self.refused;
        refused.refused_lines += 1;
        if refused.first_refused_line.is_none() {
            refused.first_refused_line = Some(self.line);
            refused.first_refusal = Some(why());
        }
    }

    /// Second half of reading a line: apply the line just read to the modal state.
    pub(super) fn apply(&mut self, raw: &[u8]) -> &Effect {
        self.state.apply(raw, &self.block);
        self.read_rotary_feed();
        &self.state.effect
    }

    /// Counts the wait after each fire (`M700`/`M578`) of a printhead.
    pub(super) fn fires(&mut self, fire: FireWait) {
        self.book.fire = Some(fire);
    }

    /// Whether a move was queued since the last `M400` or `G4`.
    pub(super) fn moved_since_m400(&self) -> bool {
        self.book.moved_since_m400
    }

    /// Accounts every layer after the first as one: the time accounts then stop growing with
    /// the layers (a key per layer, feature and tool: tens of MB for a long print), for a
    /// caller that needs only the total and the first layer's time.
    pub(super) fn first_layer_only(&mut self) {
        self.book.fold_later_layers = true;
    }

    /// The arcs too long for chords of [`ARC_CHORD_MM`] so far.
    pub(super) fn huge_arcs(&self) -> HugeArcs {
        self.book.huge_arcs
    }

    /// A line longer than [`MAX_LINE`](gweave::gcode::reader::MAX_LINE), which is not read:
    /// counted as malformed.
    pub(super) fn skip_long_line(&mut self) {
        self.line += 1;
        self.malformed.add(self.line);
    }

    /// Whether `line` is a whole line to estimate: the pieces of a line longer than
    /// [`MAX_LINE`](gweave::gcode::reader::MAX_LINE) are not, and its last piece counts it as
    /// malformed.
    #[inline(always)]
    fn is_whole(&mut self, line: &RawLine<'_>) -> bool {
        match line.part {
            Part::Whole => true,
            Part::Last { .. } => {
                self.skip_long_line();
                false
            }
            Part::Piece => false,
        }
    }

    /// [`Front::lex`], [`Front::apply`] and [`Front::run`] for a line from a reader, whose look-ahead bytes
    /// speed up the lexer. A move is read in place from the state (it is large).
    #[inline(always)]
    pub(super) fn step(&mut self, line: &RawLine<'_>, jobs: &mut Vec<Job>) -> Result<(), EstimateError> {
        if !self.is_whole(line) {
            return Ok(());
        }
        // A plain move's words are read by no one here (only M-codes and extended commands
        // are, below): leave them unlisted where the state does without them.
        if self.state.reads_words() {
            parse_line(line, &mut self.block);
        } else {
            parse_line_lean(line, &mut self.block);
        }
        self.lexed(line, jobs)
    }

    /// The rest of [`Front::step`] once the line is lexed into [`Front::block`].
    #[inline(always)]
    fn lexed(&mut self, line: &RawLine<'_>, jobs: &mut Vec<Job>) -> Result<(), EstimateError> {
        self.count_lexed();
        if self.refuses(line.bytes) {
            return Ok(());
        }
        self.state.apply(line.bytes, &self.block);
        self.read_rotary_feed();
        self.run_applied(line.bytes, jobs)
    }

    /// [`Front::run`] for the effect the modal state made of the line, as it is in the state
    /// (changed there by the caller, if at all). A move is read in place: an `Effect` is two
    /// 7-axis positions and an arc, which a copy right after the state wrote them field by
    /// field loads in wide pieces the stores in flight cannot forward (docs/performance.md).
    #[inline(always)]
    pub(super) fn run_applied(&mut self, raw: &[u8], jobs: &mut Vec<Job>) -> Result<(), EstimateError> {
        if let Effect::Move(m) = &self.state.effect {
            self.book.motion(&self.state.structure, m, self.line, jobs);
            return Ok(());
        }
        // Any other effect is a few words, on a line that is rarely a print's.
        let effect = self.state.effect;
        self.run(raw, &effect, jobs)
    }

    /// Turn `effect` (what [`Front::apply`] said `raw` does, possibly changed by the caller)
    /// and the line's motion-related commands into jobs.
    pub(super) fn run(
        &mut self,
        raw: &[u8],
        effect: &Effect,
        jobs: &mut Vec<Job>,
    ) -> Result<(), EstimateError> {
        match effect {
            Effect::Move(m) => {
                self.book.motion(&self.state.structure, m, self.line, jobs);
                return Ok(());
            }
            Effect::Dwell { t_s } => {
                self.dwell(*t_s, jobs);
                self.book.moved_since_m400 = false;
            }
            Effect::Home { axes } => {
                jobs.push(Job::Drain);
                let pos = at(&self.state.pos);
                jobs.push(Job::SetPosition { pos, by: PositionSet::Home { axes: *axes } });
            }
            Effect::SetPosition => {
                jobs.push(Job::SetPosition { pos: at(&self.state.pos), by: PositionSet::G92 });
            }
            // The state kept the machine where it was ([`gweave::gcode::arc`]).
            Effect::ArcRefused(refusal) => self.count_refused(|| format!("the arc is refused: {refusal}")),
            Effect::FirmwareRetract { e_mm } => {
                self.firmware_retract(*e_mm, jobs);
                return Ok(());
            }
            Effect::ToolChange { to, .. } => return self.select_tool(*to, jobs),
            _ => {}
        }
        match self.block.command {
            Command::Code { letter: b'M', number, sub: None } => self.m_code(raw, number, jobs),
            Command::Code { letter: b'G', number: n @ (93 | 94), sub: None } => {
                self.inverse_time(n == 93);
                Ok(())
            }
            Command::Extended => self.extended(raw, jobs),
            _ => Ok(()),
        }
    }

    fn m_code(&mut self, raw: &[u8], number: u32, jobs: &mut Vec<Job>) -> Result<(), EstimateError> {
        let b = &self.block;
        let axes =
            || AxisUpdate { x: b.get(b'X'), y: b.get(b'Y'), z: b.get(b'Z'), e: b.get(b'E'), a: b.get(b'A') };
        let changed = match number {
            400 => {
                jobs.push(Job::Drain);
                self.book.moved_since_m400 = false;
                return Ok(());
            }
            700 | 578 => {
                self.fire(jobs);
                return Ok(());
            }
            109 | 190 => {
                jobs.push(Job::Drain);
                return Ok(());
            }
            18 | 84 => {
                jobs.push(Job::Drain);
                if self.book.klipper && std::mem::take(&mut self.book.motors_on) {
                    jobs.push(Job::Overhead { t_s: KLIPPER_MOTOR_OFF_S });
                }
                return Ok(());
            }
            n if MixingCode::sets_a_mix(n) => return self.mixing_command(raw, jobs),
            201 if !self.book.klipper => self.changed(|p| p.set_max_accel(&axes())),
            203 if !self.book.klipper => self.changed(|p| p.set_max_feed(&axes())),
            205 if !self.book.klipper => self.changed(|p| {
                let jd = b.get(b'J').map_or(Ok(()), |j| p.set_junction_deviation(j));
                jd.and_then(|()| p.set_jerk(&axes(), b.get(b'B')))
            }),
            204 => {
                let m204 = M204 { s: b.get(b'S'), p: b.get(b'P'), r: b.get(b'R'), t: b.get(b'T') };
                match self.changed(|p| p.set_accel(&m204)) {
                    // Klipper answers an M204 without S, P and T with a message and goes on.
                    Err(ProfileError::M204NeedsPAndT) => return Ok(()),
                    other => other,
                }
            }
            _ => return Ok(()),
        };
        self.change_profile(changed, jobs)
    }

    /// The profile of each mode (this one's first, then [`Front::other_modes`]) as `set`
    /// changes it: a copy is made only for a command that sets limits (one per `M`-code line,
    /// `M73` and `M106` included, led the estimate's profile).
    fn changed(
        &self,
        set: impl Fn(&mut MotionProfile) -> Result<(), ProfileError>,
    ) -> Result<Vec<MotionProfile>, ProfileError> {
        let modes = std::iter::once(&self.profile).chain(&self.other_modes);
        modes
            .map(|p| {
                let mut profile = p.clone();
                set(&mut profile).map(|()| profile)
            })
            .collect()
    }

    /// Klipper's extended commands that change motion: `SET_KINEMATIC_POSITION` and
    /// `SET_VELOCITY_LIMIT`.
    fn extended(&mut self, raw: &[u8], jobs: &mut Vec<Job>) -> Result<(), EstimateError> {
        let name = self.block.command_span.of(raw);
        let args = self.block.text_of(raw).unwrap_or_default();
        let arg = |key: &str| -> Option<f64> {
            std::str::from_utf8(args).ok()?.split_whitespace().find_map(|kv| {
                let (k, v) = kv.split_once('=')?;
                k.eq_ignore_ascii_case(key).then(|| v.parse().ok()).flatten()
            })
        };
        if name.eq_ignore_ascii_case(b"SET_KINEMATIC_POSITION") {
            jobs.push(Job::Drain);
            for (axis, key) in [(state::X, "X"), (state::Y, "Y"), (state::Z, "Z")] {
                if let Some(v) = arg(key) {
                    self.state.pos[axis] = v;
                }
            }
            Ok(())
        } else if name.eq_ignore_ascii_case(b"SET_VELOCITY_LIMIT") {
            if !matches!(self.profile.corners, CornerMode::Klipper(_)) {
                return Ok(());
            }
            let changed = self.changed(|p| match &mut p.corners {
                CornerMode::Klipper(k) => k.set_velocity_limit(
                    arg("VELOCITY"),
                    arg("ACCEL"),
                    arg("SQUARE_CORNER_VELOCITY"),
                    arg("MINIMUM_CRUISE_RATIO"),
                ),
                // The modes share their kind of corners ([`super::modes`]).
                CornerMode::Marlin { .. } | CornerMode::Constant {} => Ok(()),
            });
            self.change_profile(changed, jobs)
        } else {
            Ok(())
        }
    }

    /// Take the changed profiles (one per mode, as [`Front::changed`] gives them) if the planner
    /// would, and pass each on to its mode's plan side.
    fn change_profile(
        &mut self,
        profiles: Result<Vec<MotionProfile>, ProfileError>,
        jobs: &mut Vec<Job>,
    ) -> Result<(), EstimateError> {
        let line = self.line;
        let profiles = profiles.map_err(|source| EstimateError::Profile { line, source })?;
        // Every mode's change is checked before any is taken: a refused one stops the line.
        let modes = std::iter::once(&self.profile).chain(&self.other_modes);
        for (old, new) in modes.zip(&profiles) {
            Planner::check_change(old, new).map_err(|source| EstimateError::Profile { line, source })?;
        }
        let modes = std::iter::once(&mut self.profile).chain(&mut self.other_modes);
        for (mode, (old, new)) in modes.zip(profiles).enumerate() {
            *old = new.clone();
            jobs.push(Job::Profile { profile: Box::new(new), line, mode });
        }
        Ok(())
    }

    /// The queue drained, then `t_s` with nothing moving.
    fn dwell(&mut self, t_s: f64, jobs: &mut Vec<Job>) {
        jobs.push(Job::Drain);
        let tag = self.book.tag(&self.state.structure, jobs);
        jobs.push(Job::Dwell { t_s, tag });
    }

    /// `M700 P S` (Marlin's hpc6602 patch) / `M578 P S` (RepRapFirmware): a printhead's fire
    /// runs when it is read; with nothing moving, the firmware's wait after it is the print's
    /// (`crate::inkjet`'s notes). A fire while moves run waits beside them.
    fn fire(&mut self, jobs: &mut Vec<Job>) {
        let Some(fire) = self.book.fire else { return };
        if fire.fires(self.block.get(b'P')) && !self.book.moved_since_m400 {
            self.dwell(fire.wait_s, jobs);
        }
    }

    /// `M163`-`M165` and `M567` on a mixing hotend (ignored without one).
    fn mixing_command(&mut self, raw: &[u8], jobs: &mut Vec<Job>) -> Result<(), EstimateError> {
        let Some(mixing) = &mut self.mixing else {
            return Ok(());
        };
        let line = self.line;
        mixing.follow_line(raw, &self.block).map_err(|source| EstimateError::Mixing { line, source })?;
        self.refresh_mix(jobs);
        Ok(())
    }

    /// `T<n>`: the queued moves run out first if the firmware waits ([`ToolChange`]); on a
    /// mixing hotend, select virtual tool n (Marlin) or the tool's `M567` mix (RepRapFirmware).
    fn select_tool(&mut self, tool: u32, jobs: &mut Vec<Job>) -> Result<(), EstimateError> {
        if self.tool_change.waits(self.book.tool, tool) {
            jobs.push(Job::Drain);
        }
        if let Some(mixing) = &mut self.mixing {
            if mixing.rrf_mix(tool).is_none() {
                let line = self.line;
                mixing.select_tool(tool as usize).map_err(|source| EstimateError::Mixing { line, source })?;
            }
        }
        self.book.tool = tool;
        jobs.push(Job::Tool(tool));
        self.refresh_mix(jobs);
        Ok(())
    }

    /// Make the mix in force the one that splits the E steps of the following moves.
    fn refresh_mix(&mut self, jobs: &mut Vec<Job>) {
        let Some(mixing) = &self.mixing else {
            return;
        };
        let weights = match mixing.rrf_mix(self.state.tool) {
            Some(rrf) => rrf,
            None => mixing.active_mix().ratios(),
        };
        let bits: Vec<u64> = weights.iter().map(|w| w.to_bits()).collect();
        // Index 0 is the plan side's "no mix" entry.
        let next = self.mix_index.len() + 1;
        self.book.mix = *self.mix_index.entry(bits).or_insert_with(|| {
            jobs.push(Job::Mix(weights.to_vec()));
            next
        });
    }

    /// `G10`/`G11`: an extrude-only move of the retraction length.
    fn firmware_retract(&mut self, e_mm: f64, jobs: &mut Vec<Job>) {
        let start = at(&self.state.pos);
        let end = Pos { e_mm: start.e_mm + e_mm, ..start };
        let feed_mm_s = if e_mm < 0.0 { FW_RETRACT_FEED_MM_S } else { FW_RECOVER_FEED_MM_S };
        let tag = self.book.tag(&self.state.structure, jobs);
        self.book.motors_on = true;
        jobs.push(Job::Move { mv: Move { start, end, feed_mm_s, tag }, line: self.line });
    }
}

impl Bookkeeping {
    /// The tag for the current layer, feature and mix. The key changes only at a new layer,
    /// feature, mix or tool, so the last one is kept: hashing it for every move cost a tenth
    /// of the whole simulation.
    #[inline]
    fn tag(&mut self, s: &Structure, jobs: &mut Vec<Job>) -> u64 {
        let layer = match s.layer {
            Some(l) if l > 0 && self.fold_later_layers => Some(1),
            layer => layer,
        };
        let key = Key { layer, feature: s.feature, mix: self.mix, tool: self.tool };
        match self.last_tag {
            Some((last, tag)) if last == key => tag,
            _ => self.new_tag(key, jobs),
        }
    }

    #[cold]
    #[inline(never)]
    fn new_tag(&mut self, key: Key, jobs: &mut Vec<Job>) -> u64 {
        let next = self.key_index.len() as u64;
        let tag = *self.key_index.entry(key).or_insert_with(|| {
            jobs.push(Job::Key(key));
            next
        });
        self.last_tag = Some((key, tag));
        tag
    }

    /// Motion is about to start: Klipper's start buffer before the first move. Inlined (it
    /// runs for every move; as a call it cost 16 instructions a move), the first move's work
    /// out of line.
    #[inline(always)]
    fn moving(&mut self, jobs: &mut Vec<Job>) {
        if !self.started {
            self.start(jobs);
        }
        self.motors_on = true;
        self.moved_since_m400 = true;
    }

    #[cold]
    #[inline(never)]
    fn start(&mut self, jobs: &mut Vec<Job>) {
        self.started = true;
        if self.klipper {
            jobs.push(Job::Overhead { t_s: KLIPPER_START_BUFFER_S });
        }
    }

    /// A move of the file, on line `line`: straight, or an arc cut into chords. Inlined into
    /// the parse loop (most lines are a straight move: as a call it cost some 10 instructions a
    /// line of saving and restoring registers), the arc out of line.
    #[inline(always)]
    fn motion(&mut self, s: &Structure, m: &state::Move, line: u64, jobs: &mut Vec<Job>) {
        match &m.path {
            Path::Arc(arc) => {
                let (feed_mm_s, tag) = self.moving_at(s, m.feed_mm_min, jobs);
                self.arc(m, arc, feed_mm_s, tag, line, jobs)
            }
            Path::Line => self.straight(s, at(&m.from), at(&m.to), m.feed_mm_min, line, jobs),
        }
    }

    /// A straight move of the file from `start` to `end` at `feed_mm_min` (0: none set yet),
    /// on line `line`.
    #[inline(always)]
    fn straight(
        &mut self,
        s: &Structure,
        start: Pos,
        end: Pos,
        feed_mm_min: f64,
        line: u64,
        jobs: &mut Vec<Job>,
    ) {
        let (feed_mm_s, tag) = self.moving_at(s, feed_mm_min, jobs);
        push_move(jobs, Move { start, end, feed_mm_s, tag }, line);
    }

    /// A move starts at `feed_mm_min`: its feed in mm/s and its tag.
    #[inline(always)]
    fn moving_at(&mut self, s: &Structure, feed_mm_min: f64, jobs: &mut Vec<Job>) -> (f64, u64) {
        let feed_mm_s = if feed_mm_min > 0.0 { feed_mm_min / 60.0 } else { DEFAULT_FEED_MM_S };
        let tag = self.tag(s, jobs);
        self.moving(jobs);
        (feed_mm_s, tag)
    }

    /// An arc of the file, cut into chords as the plan side takes them ([`Chords`]): a huge
    /// arc costs time, never memory. Past MAX_ARC_CHORDS they are longer than ARC_CHORD_MM, and
    /// counted.
    #[inline(never)]
    fn arc(&mut self, m: &state::Move, arc: &Arc, feed_mm_s: f64, tag: u64, line: u64, jobs: &mut Vec<Job>) {
        let (start, end) = (at(&m.from), at(&m.to));
        let wanted = (m.len_mm() / ARC_CHORD_MM).ceil();
        if wanted > MAX_ARC_CHORDS as f64 {
            self.huge_arcs.add(line);
        }
        let count = wanted.clamp(1.0, MAX_ARC_CHORDS as f64) as u32;
        let chords = Chords { arc: *arc, from: m.from, to: m.to, start, end, feed_mm_s, tag, count };
        jobs.push(Job::Arc { chords: Box::new(chords), line });
    }
}

/// An arc's chords, computed one at a time: chord `k` of `count` ends at fraction `k / count`
/// of the sweep (Z, E and A moving linearly along it, a helix), the last exactly at the end.
#[derive(Debug)]
pub(super) struct Chords {
    arc: Arc,
    from: state::Position,
    to: state::Position,
    start: Pos,
    end: Pos,
    feed_mm_s: f64,
    tag: u64,
    count: u32,
}

impl Chords {
    pub(super) fn moves(&self) -> impl Iterator<Item = Move> + '_ {
        let point = move |k: u32| {
            if k == self.count {
                return self.end;
            }
            let t = f64::from(k) / f64::from(self.count);
            let [x_mm, y_mm] = self.arc.point(t);
            let lerp = |axis: usize| self.from[axis] + (self.to[axis] - self.from[axis]) * t;
            Pos { x_mm, y_mm, z_mm: lerp(state::Z), e_mm: lerp(state::E), a_deg: lerp(state::A) }
        };
        (1..=self.count).scan(self.start, move |from, k| {
            let to = point(k);
            let mv = Move { start: *from, end: to, feed_mm_s: self.feed_mm_s, tag: self.tag };
            *from = to;
            Some(mv)
        })
    }
}

/// Pushes a straight move's job, written straight into the vector's room. `jobs.push(Job::Move
/// {..})` built the 112-byte job on the stack (the vector may grow first, a call) and copied it
/// over in 16-byte loads, each spanning two 8-byte stores still in flight, which the CPU cannot
/// forward: the copy waited for every older store to reach the cache, among them the stores
/// into the batch whose lines the planning core had just read (perf: 40-50 % of the move's
/// bookkeeping samples on that copy).
#[inline(always)]
fn push_move(jobs: &mut Vec<Job>, mv: Move, line: u64) {
    jobs.reserve(1);
    let len = jobs.len();
    if let Some(room) = jobs.spare_capacity_mut().first_mut() {
        room.write(Job::Move { mv, line });
        // SAFETY: the element at `len` was written just above, within the capacity.
        unsafe { jobs.set_len(len + 1) };
    }
}

/// The machine position of the core's modal position.
///
/// Read axis by axis, on purpose. The modal state has just written each axis on its own (an
/// 8-byte store), and the compiler would read two neighbouring axes in one 16-byte load: a load
/// that spans two stores still in flight cannot take its bytes from them, and waits until
/// every older store has reached the cache, among them the jobs written for the other core.
/// That one load had 40 % of the `estimate` parse thread's samples (perf, the 286 MB file); read
/// as the state wrote them, each axis comes straight from its store. Most of that wait moved to
/// the next stores (the jobs'): `estimate` gained 1-4 % (docs/performance.md).
#[inline(always)]
pub(super) fn at(p: &state::Position) -> Pos {
    // SAFETY: a read of an element of `p`, through a valid, aligned reference. Volatile only so
    // that the compiler keeps the reads apart.
    let axis = |i: usize| unsafe { std::ptr::read_volatile(&p[i]) };
    Pos {
        x_mm: axis(state::X),
        y_mm: axis(state::Y),
        z_mm: axis(state::Z),
        e_mm: axis(state::E),
        a_deg: axis(state::A),
    }
}

/// Counts line `line` in `malformed` if its block has an error.
#[inline(always)]
fn count_malformed(malformed: &mut Malformed, line: u64, block: &Block) {
    if !block.diagnostics.is_empty()
        && block.diagnostics.iter().any(|d| d.finding.severity() == Severity::Error)
    {
        malformed.add(line);
    }
}
