//! The plan side of the estimator: the lookahead planner, the steppers and the clock. It
//! carries out the [`Job`]s of the parse side ([`super::front::Front`]) in order and knows
//! nothing of G-code.

use super::{Estimate, EstimateError, Job, Key, KLIPPER_EXIT_FLUSH_S};
use crate::motion::limits::{CornerMode, MotionProfile, ProfileError};
use crate::motion::planner::{BlockSink, PlannedBlock, Planner};
use crate::motion::speed_trace::SpeedTrace;
use crate::motion::stepper::Steppers;

/// Times per key, steppers, the timeline: where planned blocks go.
#[derive(Debug, Clone)]
pub(super) struct Accounts {
    keys: Vec<Key>,
    key_s: Vec<f64>,
    /// Mixes by index; 0 is no mix.
    mixes: Vec<Vec<f64>>,
    pub(super) steppers: Steppers,
    /// Step the motors for each block (the virtual printer's counts), or only keep time.
    count_steps: bool,
    pub(super) t_s: f64,
    motion_s: f64,
    last_motion_end_s: f64,
    blocks: u64,
    /// The speed over time, when asked for.
    pub(super) speed: Option<Box<SpeedTrace>>,
}

impl BlockSink for Accounts {
    /// Inlined into the planner's flush: a block's time is a few additions; the speed trace and
    /// the steppers, when kept, are out of line (as one function with them, it saved and
    /// restored six registers a block).
    #[inline]
    fn block(&mut self, block: &PlannedBlock) {
        let d = block.duration_s();
        if self.count_steps || self.speed.is_some() {
            self.trace_and_step(block);
        }
        self.key_s[block.tag as usize] += d;
        self.motion_s += d;
        self.t_s += d;
        self.last_motion_end_s = self.t_s;
        self.blocks += 1;
    }

    /// The steppers read the positions; the time accounts and the speed trace (speeds and
    /// times only) do not. Fixed for the run, as a sink's answer must be.
    fn reads_positions(&self) -> bool {
        self.count_steps
    }
}

impl Accounts {
    /// The speed trace from the block's start (the clock before its time is added), and the
    /// motors' steps.
    #[inline(never)]
    fn trace_and_step(&mut self, block: &PlannedBlock) {
        if let Some(trace) = &mut self.speed {
            trace.add(self.t_s, block);
        }
        if self.count_steps {
            let key = self.keys[block.tag as usize];
            self.steppers.select_tool(key.tool as usize);
            self.steppers.step_block(block, &self.mixes[key.mix]);
        }
    }
}

/// Planner, steppers and clock.
#[derive(Debug, Clone)]
pub(super) struct Back {
    pub(super) planner: Planner,
    pub(super) acc: Accounts,
    klipper: bool,
    dwell_s: f64,
    overhead_s: f64,
    /// The mode whose limits this side plans with ([`Job::Profile`]).
    pub(super) mode: usize,
}

impl Back {
    pub(super) fn new(profile: &MotionProfile, count_steps: bool) -> Result<Self, ProfileError> {
        Ok(Self {
            planner: Planner::new(profile.clone())?,
            acc: Accounts {
                keys: Vec::new(),
                key_s: Vec::new(),
                mixes: vec![Vec::new()],
                steppers: Steppers::new(&profile.steps),
                count_steps,
                t_s: 0.0,
                motion_s: 0.0,
                last_motion_end_s: 0.0,
                blocks: 0,
                speed: None,
            },
            klipper: matches!(profile.corners, CornerMode::Klipper(_)),
            dwell_s: 0.0,
            overhead_s: 0.0,
            mode: 0,
        })
    }

    /// Carry out one job, read in place (a move is large): the plan sides of several modes
    /// read the same batch ([`super::modes`]), so what a job owns (a mix, a profile: rare) is
    /// copied.
    #[inline]
    pub(super) fn execute(&mut self, job: &Job) -> Result<(), EstimateError> {
        match job {
            Job::Move { mv, line } => self
                .planner
                .push(mv, &mut self.acc)
                .map_err(|source| EstimateError::Move { line: *line, source })?,
            Job::Arc { chords, line } => {
                for mv in chords.moves() {
                    self.planner
                        .push(&mv, &mut self.acc)
                        .map_err(|source| EstimateError::Move { line: *line, source })?;
                }
            }
            Job::Drain => self.drain(),
            Job::SetPosition { pos, by } => self.planner.set_position(*pos, *by),
            Job::Dwell { t_s, tag } => {
                self.dwell_s += *t_s;
                self.acc.t_s += *t_s;
                self.acc.key_s[*tag as usize] += *t_s;
            }
            Job::Overhead { t_s } => self.add_overhead(*t_s),
            Job::Key(key) => {
                self.acc.keys.push(*key);
                self.acc.key_s.push(0.0);
            }
            Job::Mix(weights) => self.acc.mixes.push(weights.clone()),
            Job::Tool(tool) => self.planner.select_tool(*tool as usize),
            Job::Profile { profile, line, mode } if *mode == self.mode => self
                .planner
                .set_profile((**profile).clone())
                .map_err(|source| EstimateError::Profile { line: *line, source })?,
            // Another mode's limits, or a mark read by the caller.
            Job::Profile { .. } | Job::Mark => {}
        }
        Ok(())
    }

    /// Plan every queued move to a stop and execute it.
    pub(super) fn drain(&mut self) {
        self.planner.flush(&mut self.acc);
    }

    /// The end of the file: plan the rest and, in Klipper mode, add its exit flush.
    pub(super) fn end(&mut self) {
        self.drain();
        if self.klipper && self.acc.blocks > 0 {
            let exit_s = self.acc.last_motion_end_s + KLIPPER_EXIT_FLUSH_S;
            self.add_overhead((exit_s - self.acc.t_s).max(0.0));
        }
    }

    fn add_overhead(&mut self, t_s: f64) {
        self.overhead_s += t_s;
        self.acc.t_s += t_s;
    }

    /// The times so far (moves still queued are not counted).
    pub(super) fn summary(&self) -> Estimate {
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
}
