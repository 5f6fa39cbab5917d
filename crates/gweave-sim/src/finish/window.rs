//! One window of a transform's changes planned on both sides: as the input had its lines and
//! as the output has them, in every mode ([`super::delta`] gathers the windows).
//!
//! A window is read on the measure's thread ([`Readers`]: the estimators' parse side, which
//! also says whether the two sides agree at its end) and planned on the planner thread
//! ([`Plans`], `planner_thread.rs`) from the jobs the reading made ([`WindowJobs`]): its lines
//! are parsed once, not once to decide where it ends and again to plan it.
//!
//! ## Why the lines before the first change are planned once
//! Both sides start at rest from the same modal state and read the same lines up to the
//! window's first change: the limits replayed, the `G92` and modes that set the state, and the
//! context before the change ([`super::delta::CONTEXT_LINES`] code lines). The planner is
//! deterministic, so planning those twice gives twice the same queue, the same clock and the
//! same state. They are read and planned once, on the output's side, and each side is copied
//! (`copy_from`, into the allocations of the last window's copy) to go on with the input's
//! lines from there: a line planned costs about 2 000 instructions (planned in both modes), a
//! copy of the plan sides (each mode's planner queue and clock) about 8 000 a window, against
//! a shared part of a dozen lines or more (docs/performance.md). The output's side is the one
//! that lives from window to window; the input's is the copy, made afresh at each window, so
//! each window's input side starts exactly where its output side does.

use gweave::gcode::state::{Position, E, X, Y, Z};
use gweave::{Firmware, State};

use crate::motion::estimate::{modes_sides, EstimateError, Jobs, ModesParse, ModesPlan};
use crate::motion::limits::MotionProfile;

/// What a window's lines start from: the output's modal state before its first line.
#[derive(Debug, Clone, Copy)]
pub(super) struct Modal {
    pos: Position,
    absolute: bool,
    relative_e: bool,
    inches: bool,
    feed_mm_min: f64,
    tool: u32,
    /// In the first layer: the window's change counts in the first layer's time.
    pub(super) first_layer: bool,
}

impl Modal {
    pub(super) fn of(state: &State) -> Self {
        Modal {
            pos: state.pos,
            absolute: state.absolute(),
            relative_e: state.relative_e(),
            inches: state.inches,
            feed_mm_min: state.feed_mm_min,
            tool: state.tool,
            first_layer: state.structure.layer == Some(0),
        }
    }

    /// Puts `parse` (its plan drained, at rest) in this state: the position by a `G92` line
    /// (`g92`, this state's, written once for every window), the modes by their commands if
    /// they differ, the rest in its state; the lines' jobs go to `jobs`.
    fn set(&self, parse: &mut ModesParse, g92: &[u8], jobs: &mut Jobs) -> Result<(), EstimateError> {
        parse.state_mut().inches = false;
        parse.line(g92, jobs)?;
        if parse.state().absolute() != self.absolute {
            parse.line(if self.absolute { b"G90" } else { b"G91" }, jobs)?;
        }
        if parse.state().relative_e() != self.relative_e {
            parse.line(if self.relative_e { b"M83" } else { b"M82" }, jobs)?;
        }
        let state = parse.state_mut();
        state.inches = self.inches;
        state.feed_mm_min = self.feed_mm_min;
        state.tool = self.tool;
        Ok(())
    }

    /// The `G92` line that sets this position, in mm.
    pub(super) fn g92(&self) -> Vec<u8> {
        let p = &self.pos;
        format!("G92 X{} Y{} Z{} E{}", p[X], p[Y], p[Z], p[E]).into_bytes()
    }
}

/// A window's lines, each side's.
pub(super) struct WindowLines<'a> {
    /// The limits lines to replay first (none when the estimator has them already).
    pub limits: &'a [&'a [u8]],
    /// The state before the window, and its `G92` line ([`Modal::g92`]).
    pub modal: &'a Modal,
    pub g92: &'a [u8],
    /// The lines before the first change, the same on both sides.
    pub shared: &'a [&'a [u8]],
    /// From the first change on: the output's lines and the input's.
    pub output: &'a [&'a [u8]],
    pub input: &'a [&'a [u8]],
}

/// What a window's lines come to on both sides, for [`Plans::time`]: the jobs before the
/// clock starts (limits replayed, the state set), the shared lines', then each side's from the
/// first change on, each drained at its end.
#[derive(Debug, Default)]
pub(super) struct WindowJobs {
    setup: Jobs,
    shared: Jobs,
    output: Jobs,
    input: Jobs,
}

impl WindowJobs {
    /// Empties it, keeping its room.
    pub(super) fn clear(&mut self) {
        [&mut self.setup, &mut self.shared, &mut self.output, &mut self.input]
            .into_iter()
            .for_each(Jobs::clear);
    }
}

/// The two sides' parse sides: they read a window's lines and end in the modal state the
/// lines leave, so they say whether the sides agree ([`Readers::agree`]).
pub(super) struct Readers {
    output: ModesParse,
    /// A copy of `output` at the window's first change.
    input: ModesParse,
}

/// The two sides' plan sides, one per mode each.
#[derive(Clone)]
pub(super) struct Plans {
    output: ModesPlan,
    /// A copy of `output` at the window's first change.
    input: ModesPlan,
}

/// The two sides, read with the limits of each of `profiles` (normal mode, then silent) and
/// planned in each, the lines read as `firmware` reads them.
pub(super) fn sides(
    profiles: &[&MotionProfile],
    firmware: Firmware,
) -> Result<(Readers, Plans), EstimateError> {
    let (parse, plan) = modes_sides(profiles, firmware)?;
    Ok((Readers { input: parse.clone(), output: parse }, Plans { input: plan.clone(), output: plan }))
}

impl Readers {
    /// Reads `lines` on the output's side and on the input's into `jobs` (emptied first).
    pub(super) fn read(
        &mut self,
        lines: &WindowLines<'_>,
        jobs: &mut WindowJobs,
    ) -> Result<(), EstimateError> {
        jobs.clear();
        let out = &mut self.output;
        lines.limits.iter().try_for_each(|l| out.line(l, &mut jobs.setup))?;
        lines.modal.set(out, lines.g92, &mut jobs.setup)?;
        lines.shared.iter().try_for_each(|l| out.line(l, &mut jobs.shared))?;
        self.input.copy_from(out);
        read_drained(&mut self.output, lines.output, &mut jobs.output)?;
        read_drained(&mut self.input, lines.input, &mut jobs.input)
    }

    /// Whether the two sides left the machine in the same modal state ([`same_modes`]).
    pub(super) fn agree(&self) -> bool {
        same_modes(self.output.state(), self.input.state())
    }
}

/// Reads `lines`, then drains: the next window starts at rest.
fn read_drained(parse: &mut ModesParse, lines: &[&[u8]], jobs: &mut Jobs) -> Result<(), EstimateError> {
    lines.iter().try_for_each(|l| parse.line(l, jobs))?;
    parse.line(b"M400", jobs)
}

impl Plans {
    /// The time a window's lines (read into `jobs`) take on the output's side and on the
    /// input's, in each mode, from rest to rest, s.
    pub(super) fn time(&mut self, jobs: &WindowJobs) -> Result<[[f64; 2]; 2], EstimateError> {
        let out = &mut self.output;
        out.execute(&jobs.setup)?;
        let t0 = clock(out);
        out.execute(&jobs.shared)?;
        self.input.copy_from(out);
        Ok([rest(&mut self.output, &jobs.output, t0)?, rest(&mut self.input, &jobs.input, t0)?])
    }
}

/// The time from `t0` to the end of `jobs` planned on `plan`, s.
fn rest(plan: &mut ModesPlan, jobs: &Jobs, t0: [f64; 2]) -> Result<[f64; 2], EstimateError> {
    plan.execute(jobs)?;
    let t = clock(plan);
    Ok([t[0] - t0[0], t[1] - t0[1]])
}

/// Each mode's clock (the second the normal mode's without a silent mode), s.
fn clock(plan: &ModesPlan) -> [f64; 2] {
    let mut t = [0.0; 2];
    t.iter_mut().zip(plan.now_s()).for_each(|(t, now)| *t = now);
    t
}

/// Whether two sides left the machine in the same modal state: what the lines after a window
/// read (the feed rate, the modes, the position; E only where it is absolute). Not the tool:
/// `mix` renumbers them for good, and with the file's limits (no extruder's own) a tool plans
/// as any other.
fn same_modes(a: &State, b: &State) -> bool {
    a.feed_mm_min == b.feed_mm_min
        && a.absolute() == b.absolute()
        && a.relative_e() == b.relative_e()
        && a.inches == b.inches
        && [X, Y, Z].iter().all(|&i| a.pos[i] == b.pos[i])
        && (a.relative_e() || a.pos[E] == b.pos[E])
}

#[cfg(test)]
mod tests {
    use gweave::gcode::state::AXES;
    use proptest::prelude::*;

    use super::*;
    use crate::motion::estimate::silent;

    /// A line of a print: extrusions, travels with a feed, retractions, a Z lift, a dwell,
    /// a limit, a mode, a comment.
    fn line() -> impl Strategy<Value = String> {
        (0u8..12, 0.0..200.0f64, 0.0..200.0f64, 0.0..2.0f64, 300u32..12_000).prop_map(|(kind, x, y, e, f)| {
            match kind {
                0..=4 => format!("G1 X{x:.3} Y{y:.3} E{e:.5}"),
                5 => format!("G1 X{x:.3} Y{y:.3} F{f}"),
                6 => format!("G1 E-{e:.3} F2400"),
                7 => format!("G1 Z{:.2} F{f}", x / 50.0),
                8 => format!("M204 S{}", 500 + f / 10),
                9 => format!("G4 P{}", f / 100),
                10 => (if e < 1.0 { "M83" } else { "G91" }).into(),
                _ => ";TYPE:Perimeter".into(),
            }
        })
    }

    fn lines(most: usize) -> impl Strategy<Value = Vec<String>> {
        proptest::collection::vec(line(), 0..most)
    }

    /// Reads and plans one line on one side, as an estimator fed line by line does.
    fn step(parse: &mut ModesParse, plan: &mut ModesPlan, line: &[u8]) -> Result<(), EstimateError> {
        let mut jobs = Jobs::default();
        parse.line(line, &mut jobs)?;
        plan.execute(&jobs)
    }

    fn bytes(lines: &[String]) -> Vec<&[u8]> {
        lines.iter().map(String::as_bytes).collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]

        /// The lines before a window's first change planned once and the estimator copied
        /// give each side's time, in both modes, and its state to the bit, as two plans of
        /// the whole window from the same estimator.
        #[test]
        fn the_shared_prefix_plans_as_two_separate_plans(
            before in lines(40),
            shared in lines(16),
            output in lines(24),
            input in lines(24),
            replay in any::<bool>(),
            start in (0.0..200.0f64, 0.0..200.0f64, 0.0..5.0f64, 300.0..9000.0f64, any::<bool>()),
        ) {
            let profiles = [&MotionProfile::default(), &silent()];
            let (mut readers, mut plans) = sides(&profiles, Firmware::Marlin).unwrap();
            // Where earlier windows left both sides: read, planned, drained, the clock on.
            for l in bytes(&before).into_iter().chain([&b"M400"[..]]) {
                let _ = step(&mut readers.output, &mut plans.output, l);
            }
            let (x, y, z, feed_mm_min, relative_e) = start;
            let mut pos: Position = [0.0; AXES];
            (pos[X], pos[Y], pos[Z]) = (x, y, z);
            let modal = Modal {
                pos,
                absolute: true,
                relative_e,
                inches: false,
                feed_mm_min,
                tool: 0,
                first_layer: false,
            };
            let g92 = modal.g92();
            let limits: Vec<&[u8]> = if replay { vec![b"M201 X900 Y900", b"M204 P800 T1200"] } else { Vec::new() };
            let (shared, output, input) = (bytes(&shared), bytes(&output), bytes(&input));
            let window = WindowLines { limits: &limits, modal: &modal, g92: &g92, shared: &shared, output: &output, input: &input };
            // Each side read and planned whole, line by line, from a copy of both as they were.
            let alone = |side: &[&[u8]]| {
                let (mut parse, mut plan) = (readers.output.clone(), plans.output.clone());
                limits.iter().try_for_each(|l| step(&mut parse, &mut plan, l))?;
                let mut jobs = Jobs::default();
                modal.set(&mut parse, &g92, &mut jobs)?;
                plan.execute(&jobs)?;
                let t0 = clock(&plan);
                shared.iter().chain(side).try_for_each(|l| step(&mut parse, &mut plan, l))?;
                step(&mut parse, &mut plan, b"M400")?;
                let t = clock(&plan);
                Ok::<_, EstimateError>(([t[0] - t0[0], t[1] - t0[1]], parse.state().clone()))
            };
            let expected = (alone(&output), alone(&input));
            let mut window_jobs = WindowJobs::default();
            let got = readers.read(&window, &mut window_jobs).and_then(|()| plans.time(&window_jobs));
            match (got, expected) {
                (Ok([t_out, t_in]), (Ok((e_out, out_state)), Ok((e_in, in_state)))) => {
                    prop_assert_eq!(t_out.map(f64::to_bits), e_out.map(f64::to_bits));
                    prop_assert_eq!(t_in.map(f64::to_bits), e_in.map(f64::to_bits));
                    prop_assert_eq!(readers.output.state().pos, out_state.pos);
                    prop_assert_eq!(readers.input.state().pos, in_state.pos);
                    prop_assert_eq!(readers.agree(), same_modes(&out_state, &in_state));
                }
                (Err(_), (e_out, e_in)) => prop_assert!(e_out.is_err() || e_in.is_err()),
                (Ok(_), (e_out, e_in)) => prop_assert!(false, "{e_out:?} {e_in:?}"),
            }
        }
    }
}
