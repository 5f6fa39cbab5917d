//! Print-time estimation: stream a G-code file through the core parser and modal state, the
//! planner and the steppers, and add up the time per layer and per feature.
//!
//! ```
//! use gweave_sim::estimate::estimate;
//! use gweave_sim::limits::{KlipperLimits, MotionProfile};
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
//! `SET_KINEMATIC_POSITION`. Arcs are cut into chords of at most 1 mm, as both firmwares do
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
//! it splits a line into [`Estimator::parse`] (syntax and modal state) and [`Estimator::run`]
//! (planning), so the machine can look at, or change, what a line does in between (refuse a
//! cold extrusion, scale the feed by `M220`).

use std::collections::{BTreeMap, HashMap};
use std::io::Read;

use gweave::colour::dialect::{DialectError, MixingState, MARLIN_VIRTUAL_TOOLS};
use gweave::gcode::layers::Feature;
use gweave::gcode::lexer::parse_into;
use gweave::gcode::line::{Block, Command};
use gweave::gcode::reader::LineReader;
use gweave::gcode::state::{self, Effect, Firmware, Path, State, StateOptions};
use thiserror::Error;

use crate::kinematics::{Move, MoveError, Pos};
use crate::limits::{AxisUpdate, CornerMode, MotionProfile, ProfileError, M204};
use crate::planner::{BlockSink, PlannedBlock, Planner};
use crate::speed_trace::SpeedTrace;
use crate::stepper::{StepTotals, Steppers};

/// Feed rate before the file sets one, mm/s (Klipper `gcode_move`, Marlin `feedrate_mm_s`).
pub const DEFAULT_FEED_MM_S: f64 = 25.0;
/// Longest chord an arc is cut into, mm.
pub const ARC_CHORD_MM: f64 = 1.0;
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

/// The sink side: times per key, steppers, the timeline.
#[derive(Debug)]
struct Accounts {
    keys: Vec<Key>,
    key_s: Vec<f64>,
    mixes: Vec<Vec<f64>>,
    steppers: Steppers,
    t_s: f64,
    motion_s: f64,
    last_motion_end_s: f64,
    blocks: u64,
    /// The speed over time, when asked for ([`Estimator::record_speed`]).
    speed: Option<Box<SpeedTrace>>,
}

impl BlockSink for Accounts {
    fn block(&mut self, block: &PlannedBlock) {
        let d = block.duration_s();
        if let Some(trace) = &mut self.speed {
            trace.add(self.t_s, block);
        }
        let key = self.keys[block.tag as usize];
        self.key_s[block.tag as usize] += d;
        self.steppers.select_tool(key.tool as usize);
        self.steppers.step_block(block, &self.mixes[key.mix]);
        self.motion_s += d;
        self.t_s += d;
        self.last_motion_end_s = self.t_s;
        self.blocks += 1;
    }
}

/// A streaming estimator: feed it lines, then [`Estimator::finish`].
#[derive(Debug)]
pub struct Estimator {
    block: Block,
    state: State,
    planner: Planner,
    acc: Accounts,
    key_index: HashMap<Key, u64>,
    /// The last key looked up and its tag.
    last_tag: Option<(Key, u64)>,
    mix_index: HashMap<Vec<u64>, usize>,
    /// The mixing commands' state, for a profile with mixing inputs.
    mixing: Option<MixingState>,
    mix: usize,
    /// The selected tool (`T<n>` carried out by [`Estimator::run`]), for per-tool E steps.
    tool: u32,
    klipper: bool,
    started: bool,
    motors_on: bool,
    dwell_s: f64,
    overhead_s: f64,
    line: u64,
}

impl Estimator {
    /// An estimator for a machine with this profile.
    pub fn new(profile: &MotionProfile) -> Result<Self, EstimateError> {
        let klipper = matches!(profile.corners, CornerMode::Klipper(_));
        let firmware = if klipper { Firmware::Klipper } else { Firmware::Marlin };
        let planner =
            Planner::new(profile.clone()).map_err(|source| EstimateError::Profile { line: 0, source })?;
        let mixing = match profile.steps.mixing_e.len() {
            0 => None,
            n => Some(
                MixingState::new(n, MARLIN_VIRTUAL_TOOLS)
                    .map_err(|source| EstimateError::Mixing { line: 0, source })?,
            ),
        };
        let acc = Accounts {
            keys: Vec::new(),
            key_s: Vec::new(),
            mixes: vec![Vec::new()],
            steppers: Steppers::new(&profile.steps),
            t_s: 0.0,
            motion_s: 0.0,
            last_motion_end_s: 0.0,
            blocks: 0,
            speed: None,
        };
        let mut est = Self {
            block: Block::default(),
            state: State::new(StateOptions { firmware, ..StateOptions::default() }),
            planner,
            acc,
            key_index: HashMap::new(),
            last_tag: None,
            mix_index: HashMap::new(),
            mixing,
            mix: 0,
            tool: 0,
            klipper,
            started: false,
            motors_on: false,
            dwell_s: 0.0,
            overhead_s: 0.0,
            line: 0,
        };
        est.refresh_mix();
        Ok(est)
    }

    /// Execute one line (without its line ending). Mixing commands the firmware would refuse
    /// are skipped.
    pub fn line(&mut self, raw: &[u8]) -> Result<(), EstimateError> {
        let effect = self.parse(raw);
        match self.run(raw, &effect) {
            Err(EstimateError::Mixing { .. }) => Ok(()),
            other => other,
        }
    }

    /// First half of [`Estimator::line`]: parse the line and apply it to the modal state; say
    /// what it does. Nothing is planned yet.
    pub fn parse(&mut self, raw: &[u8]) -> Effect {
        self.line += 1;
        parse_into(raw, &mut self.block);
        *self.state.apply(raw, &self.block)
    }

    /// Second half of [`Estimator::line`]: carry out `effect` (normally what
    /// [`Estimator::parse`] returned for `raw`, possibly changed by the caller) and the line's
    /// motion-related commands.
    pub fn run(&mut self, raw: &[u8], effect: &Effect) -> Result<(), EstimateError> {
        match effect {
            Effect::Move(m) => return self.motion(m),
            Effect::Dwell { t_s } => {
                self.drain();
                self.dwell_s += t_s;
                self.acc.t_s += t_s;
                let tag = self.tag();
                self.acc.key_s[tag as usize] += t_s;
            }
            Effect::Home { .. } => self.drain(),
            Effect::FirmwareRetract { e_mm } => return self.firmware_retract(*e_mm),
            Effect::ToolChange { to, .. } => return self.select_tool(*to),
            _ => {}
        }
        match self.block.command {
            Command::Code { letter: b'M', number, sub: None } => self.m_code(raw, number),
            Command::Extended => self.extended(raw),
            _ => Ok(()),
        }
    }

    /// The line last parsed.
    pub fn block(&self) -> &Block {
        &self.block
    }

    /// The modal state after the line last parsed.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The modal state, to set what the machine found out itself (the position after homing).
    pub fn state_mut(&mut self) -> &mut State {
        &mut self.state
    }

    /// Lines parsed so far (the 1-based number of the last one).
    pub fn line_number(&self) -> u64 {
        self.line
    }

    /// The clock: the end of the last block executed plus dwells and waits, s. Queued moves
    /// are not counted until they leave the planner.
    pub fn now_s(&self) -> f64 {
        self.acc.t_s
    }

    /// Moves waiting in the lookahead queue.
    pub fn queued(&self) -> usize {
        self.planner.queued()
    }

    /// The motion profile in force (M201-M205 change it).
    pub fn profile(&self) -> &MotionProfile {
        self.planner.profile()
    }

    /// The motors.
    pub fn steppers(&self) -> &Steppers {
        &self.acc.steppers
    }

    /// The motors, to step what the planner does not plan (homing).
    pub fn steppers_mut(&mut self) -> &mut Steppers {
        &mut self.acc.steppers
    }

    /// Record the planned speed over time from now on ([`Estimator::speed_trace`]).
    pub fn record_speed(&mut self) {
        self.acc.speed.get_or_insert_with(Default::default);
    }

    /// The planned speed over time, if [`Estimator::record_speed`] was called.
    pub fn speed_trace(&self) -> Option<&SpeedTrace> {
        self.acc.speed.as_deref()
    }

    /// The mixing state, for a profile with mixing inputs.
    pub fn mixing(&self) -> Option<&MixingState> {
        self.mixing.as_ref()
    }

    /// Let `t_s` pass with the machine standing still, attributed to no layer (heating,
    /// homing). Plan the queue first with [`Estimator::drain`].
    pub fn idle(&mut self, t_s: f64) {
        if t_s > 0.0 {
            self.acc.t_s += t_s;
        }
    }

    /// Plan every queued move to a stop and execute it (what `M400` waits for).
    pub fn drain(&mut self) {
        self.planner.flush(&mut self.acc);
    }

    /// Plan the rest and return the estimate.
    pub fn finish(mut self) -> Estimate {
        self.end();
        self.summary()
    }

    /// The end of the file: plan the rest and, in Klipper mode, add its exit flush. Call once.
    pub fn end(&mut self) {
        self.drain();
        if self.klipper && self.acc.blocks > 0 {
            let exit_s = self.acc.last_motion_end_s + KLIPPER_EXIT_FLUSH_S;
            self.add_overhead((exit_s - self.acc.t_s).max(0.0));
        }
    }

    /// The times so far (moves still queued in the planner are not counted).
    pub fn summary(&self) -> Estimate {
        let mut est = Estimate {
            total_s: self.acc.t_s,
            motion_s: self.acc.motion_s,
            dwell_s: self.dwell_s,
            overhead_s: self.overhead_s,
            blocks: self.acc.blocks,
            steps: self.acc.steppers.totals().clone(),
            ..Estimate::default()
        };
        for (key, t) in self.acc.keys.iter().zip(&self.acc.key_s) {
            *est.feature_s.entry(key.feature).or_default() += t;
            match key.layer {
                None => est.unlayered_s += t,
                Some(l) => {
                    let l = l as usize;
                    if est.layer_s.len() <= l {
                        est.layer_s.resize(l + 1, 0.0);
                    }
                    est.layer_s[l] += t;
                }
            }
        }
        est
    }

    /// The tag for the current layer, feature and mix. The key changes only at a new layer,
    /// feature, mix or tool, so the last one is kept: hashing it for every move cost a tenth
    /// of the whole simulation.
    fn tag(&mut self) -> u64 {
        let s = &self.state.structure;
        let key = Key { layer: s.layer, feature: s.feature, mix: self.mix, tool: self.tool };
        if let Some((last, tag)) = self.last_tag {
            if last == key {
                return tag;
            }
        }
        let acc = &mut self.acc;
        let tag = *self.key_index.entry(key).or_insert_with(|| {
            acc.keys.push(key);
            acc.key_s.push(0.0);
            (acc.keys.len() - 1) as u64
        });
        self.last_tag = Some((key, tag));
        tag
    }

    fn motion(&mut self, m: &state::Move) -> Result<(), EstimateError> {
        let feed_mm_s = if m.feed_mm_min > 0.0 { m.feed_mm_min / 60.0 } else { DEFAULT_FEED_MM_S };
        let tag = self.tag();
        if !self.started {
            self.started = true;
            if self.klipper {
                self.add_overhead(KLIPPER_START_BUFFER_S);
            }
        }
        self.motors_on = true;
        let pos = |p: &state::Position, xy: [f64; 2], t: f64| Pos {
            x_mm: xy[0],
            y_mm: xy[1],
            z_mm: lerp(m.from[state::Z], p[state::Z], t),
            e_mm: lerp(m.from[state::E], p[state::E], t),
            a_deg: lerp(m.from[state::A], p[state::A], t),
        };
        let start = pos(&m.from, [m.from[state::X], m.from[state::Y]], 0.0);
        let chords = match &m.path {
            Path::Line => 1,
            Path::Arc(_) => (m.len_mm() / ARC_CHORD_MM).ceil().max(1.0) as usize,
        };
        let mut from = start;
        for k in 1..=chords {
            let t = k as f64 / chords as f64;
            let xy = match &m.path {
                Path::Arc(arc) if k < chords => arc.point(t),
                _ => [m.to[state::X], m.to[state::Y]],
            };
            let to = pos(&m.to, xy, t);
            let mv = Move { start: from, end: to, feed_mm_s, tag };
            self.planner
                .push(&mv, &mut self.acc)
                .map_err(|source| EstimateError::Move { line: self.line, source })?;
            from = to;
        }
        Ok(())
    }

    fn m_code(&mut self, raw: &[u8], number: u32) -> Result<(), EstimateError> {
        let b = &self.block;
        let axes =
            || AxisUpdate { x: b.get(b'X'), y: b.get(b'Y'), z: b.get(b'Z'), e: b.get(b'E'), a: b.get(b'A') };
        let mut profile = self.planner.profile().clone();
        let changed = match number {
            400 | 109 | 190 => {
                self.drain();
                return Ok(());
            }
            18 | 84 => {
                self.drain();
                if self.klipper && std::mem::take(&mut self.motors_on) {
                    self.add_overhead(KLIPPER_MOTOR_OFF_S);
                }
                return Ok(());
            }
            163..=165 | 567 => return self.mixing_command(raw),
            201 if !self.klipper => profile.set_max_accel(&axes()),
            203 if !self.klipper => profile.set_max_feed(&axes()),
            205 if !self.klipper => match b.get(b'J') {
                Some(j) => profile.set_junction_deviation(j),
                None => return Ok(()),
            },
            204 => {
                let m204 = M204 { s: b.get(b'S'), p: b.get(b'P'), r: b.get(b'R'), t: b.get(b'T') };
                match profile.set_accel(&m204) {
                    // Klipper answers an M204 without S, P and T with a message and goes on.
                    Err(ProfileError::M204NeedsPAndT) => return Ok(()),
                    other => other,
                }
            }
            _ => return Ok(()),
        };
        self.apply_profile(changed.map(|()| profile))
    }

    /// Klipper's extended commands that change motion: `SET_KINEMATIC_POSITION` and
    /// `SET_VELOCITY_LIMIT`.
    fn extended(&mut self, raw: &[u8]) -> Result<(), EstimateError> {
        let name = self.block.command_span.of(raw);
        let args = self.block.text_of(raw).unwrap_or_default();
        let arg = |key: &str| -> Option<f64> {
            std::str::from_utf8(args).ok()?.split_whitespace().find_map(|kv| {
                let (k, v) = kv.split_once('=')?;
                k.eq_ignore_ascii_case(key).then(|| v.parse().ok()).flatten()
            })
        };
        if name.eq_ignore_ascii_case(b"SET_KINEMATIC_POSITION") {
            self.drain();
            for (axis, key) in [(state::X, "X"), (state::Y, "Y"), (state::Z, "Z")] {
                if let Some(v) = arg(key) {
                    self.state.pos[axis] = v;
                }
            }
            Ok(())
        } else if name.eq_ignore_ascii_case(b"SET_VELOCITY_LIMIT") {
            let mut profile = self.planner.profile().clone();
            let result = match &mut profile.corners {
                CornerMode::Klipper(k) => k.set_velocity_limit(
                    arg("VELOCITY"),
                    arg("ACCEL"),
                    arg("SQUARE_CORNER_VELOCITY"),
                    arg("MINIMUM_CRUISE_RATIO"),
                ),
                CornerMode::Marlin { .. } => return Ok(()),
            };
            self.apply_profile(result.map(|()| profile))
        } else {
            Ok(())
        }
    }

    fn apply_profile(&mut self, profile: Result<MotionProfile, ProfileError>) -> Result<(), EstimateError> {
        profile
            .and_then(|p| self.planner.set_profile(p))
            .map_err(|source| EstimateError::Profile { line: self.line, source })
    }

    /// `M163`-`M165` and `M567` on a mixing hotend (ignored without one).
    fn mixing_command(&mut self, raw: &[u8]) -> Result<(), EstimateError> {
        let Some(mixing) = &mut self.mixing else {
            return Ok(());
        };
        let line = self.line;
        mixing.follow_line(raw, &self.block).map_err(|source| EstimateError::Mixing { line, source })?;
        self.refresh_mix();
        Ok(())
    }

    /// `T<n>`: on a mixing hotend, select virtual tool n (Marlin) or the tool's `M567` mix
    /// (RepRapFirmware).
    fn select_tool(&mut self, tool: u32) -> Result<(), EstimateError> {
        if let Some(mixing) = &mut self.mixing {
            if mixing.rrf_mix(tool).is_none() {
                let line = self.line;
                mixing.select_tool(tool as usize).map_err(|source| EstimateError::Mixing { line, source })?;
            }
        }
        self.tool = tool;
        self.refresh_mix();
        Ok(())
    }

    /// Make the mix in force the one that splits the E steps of the following moves.
    fn refresh_mix(&mut self) {
        let Some(mixing) = &self.mixing else {
            return;
        };
        let weights = match mixing.rrf_mix(self.state.tool) {
            Some(rrf) => rrf,
            None => mixing.active_mix().ratios(),
        };
        let bits: Vec<u64> = weights.iter().map(|w| w.to_bits()).collect();
        let mixes = &mut self.acc.mixes;
        self.mix = *self.mix_index.entry(bits).or_insert_with(|| {
            mixes.push(weights.to_vec());
            mixes.len() - 1
        });
    }

    /// `G10`/`G11`: an extrude-only move of the retraction length.
    fn firmware_retract(&mut self, e_mm: f64) -> Result<(), EstimateError> {
        let p = &self.state.pos;
        let start = Pos {
            x_mm: p[state::X],
            y_mm: p[state::Y],
            z_mm: p[state::Z],
            e_mm: p[state::E],
            a_deg: p[state::A],
        };
        let end = Pos { e_mm: start.e_mm + e_mm, ..start };
        let feed_mm_s = if e_mm < 0.0 { FW_RETRACT_FEED_MM_S } else { FW_RECOVER_FEED_MM_S };
        let mv = Move { start, end, feed_mm_s, tag: self.tag() };
        self.motors_on = true;
        self.planner
            .push(&mv, &mut self.acc)
            .map_err(|source| EstimateError::Move { line: self.line, source })
    }

    fn add_overhead(&mut self, t_s: f64) {
        self.overhead_s += t_s;
        self.acc.t_s += t_s;
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Estimate a whole file read from `input`.
pub fn estimate<R: Read>(input: R, profile: &MotionProfile) -> Result<Estimate, EstimateError> {
    let mut est = Estimator::new(profile)?;
    let mut reader = LineReader::new(input);
    while let Some(line) = reader.next_line()? {
        est.line(line.bytes)?;
    }
    Ok(est.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn marlin_layers_features_dwell_and_m204() {
        let text = ";FLAVOR:Marlin\n;LAYER:0\n;TYPE:WALL-OUTER\nG1 X10 E1 F600\n;LAYER:1\n;TYPE:FILL\n\
                    G1 X20 E2\nG4 P1000\nM204 T500\nG0 X30 F6000\n";
        let est = estimate(text.as_bytes(), &MotionProfile::default()).unwrap();
        // Two collinear 10 mm moves at 10 mm/s (a = 3000): 1/300 s and 1/60 mm at each end.
        let leg = 1.0 / 300.0 + (10.0 - 1.0 / 60.0) / 10.0;
        // The travel with M204 T500: 10 mm cannot reach 100 mm/s; peak v^2 = 500 * 10.
        let travel = 2.0 * 5000f64.sqrt() / 500.0;
        assert!(close(est.layer_s[0], leg), "{est:?}");
        assert!(close(est.layer_s[1], leg + 1.0 + travel), "{est:?}");
        assert!(close(est.feature_s[&Feature::OuterWall], leg));
        assert!(close(est.feature_s[&Feature::Infill], leg + 1.0 + travel));
        assert!(close(est.total_s, 2.0 * leg + 1.0 + travel));
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

    #[test]
    fn bad_input_is_an_error_with_its_line() {
        let err = estimate("G1 X1 F600\nM204 S-5\n".as_bytes(), &MotionProfile::default()).unwrap_err();
        assert!(matches!(err, EstimateError::Profile { line: 2, .. }), "{err}");
    }
}
