//! The same lines estimated in several modes: a file's normal and silent modes (PrusaSlicer's
//! `machine_max_*` pairs, `M73 Q.. S..`), which differ only in the machine's limits.
//!
//! Everything the parse side does (reading, lexing, the modal state, the time accounts, arcs
//! cut into chords) is the same in every mode: only the planner's limits differ. So the lines
//! are parsed once, into one stream of jobs, and each mode's plan side reads the same batches
//! on a thread of its own; a command that sets limits (`M201`-`M205`) changes every mode's
//! profile, each plan side taking its own ([`Job::Profile`]'s `mode`). Each plan side sees the
//! jobs an [`Estimator`](super::Estimator) of its mode would make, in the same order, so its
//! figures are that estimator's to the bit; the parse side's work (about 40 % of an estimate,
//! docs/performance.md) is done once instead of once per mode.

use std::io::Read;
use std::sync::{mpsc, Arc};

use gweave::gcode::reader::Part;
use gweave::Ctx;
use gweave::{Firmware, LineReader, State};

use super::back::Back;
use super::front::Front;
use super::{new_batch, skip_mixing_errors, Estimate, EstimateError, Job, BATCH, BATCHES_IN_FLIGHT};
use crate::motion::limits::{MotionProfile, ProfileError};
use crate::motion::planner::Planner;

/// What [`estimate_modes`] found: each mode's estimate and the modal state after the last line.
#[derive(Debug)]
pub(crate) struct Modes {
    /// The first profile's.
    pub first: ModeEstimate,
    /// The other profiles', in their order.
    pub others: Vec<ModeEstimate>,
    /// The modal state after the last line (what the lines given to `each_line` left).
    pub state: State,
}

/// One mode's estimate and its clock at each progress line.
#[derive(Debug)]
pub(crate) struct ModeEstimate {
    /// The estimate, the first layer apart and every later one accounted as one
    /// ([`Estimator::first_layer_only`](super::Estimator::first_layer_only)).
    pub estimate: Estimate,
    /// The clock after each line `each_line` picked, s: the time the queued moves before it
    /// leave the planner is not counted yet, as [`Estimator::now_s`](super::Estimator::now_s).
    pub progress_s: Vec<f64>,
}

/// The parse side, its set-up jobs in `jobs`, and a plan side per mode (`first`, then each of
/// `others`) for a timing-only estimate in several modes: the profiles must plan alike
/// ([`Planner::check_change`]), every layer after the first one account.
fn sides(
    first: &MotionProfile,
    others: &[MotionProfile],
    firmware: Firmware,
    jobs: &mut Vec<Job>,
) -> Result<(Front, Vec<Back>), EstimateError> {
    let profile_error = |source: ProfileError| EstimateError::Profile { line: 0, source };
    others.iter().try_for_each(|p| Planner::check_change(first, p)).map_err(profile_error)?;
    let mut front = Front::new(first, jobs)?;
    front.read_as(firmware);
    front.first_layer_only();
    front.other_modes = others.to_vec();
    let backs = std::iter::once(first)
        .chain(others)
        .enumerate()
        .map(|(mode, p)| {
            let mut back = Back::new(p, false).map_err(profile_error)?;
            back.mode = mode;
            Ok(back)
        })
        .collect::<Result<Vec<_>, EstimateError>>()?;
    Ok((front, backs))
}

/// Estimates `input` in the mode of `first` and of each of `others` (timing only, without step
/// counts), read as `firmware` reads it. The profiles must plan alike (the same corner mode,
/// [`Planner::check_change`]): only their limits differ. Each plan side sees the jobs an
/// [`Estimator`](super::Estimator) of its profile fed every line would make, so its figures are
/// that estimator's to the bit. Memory is a few batches of jobs in flight.
///
/// `each_line` reads every whole line beside the estimate, on the parse side's thread, with
/// the block, effect and modal state a [`gweave::Run`] gives a pass
/// for a pass that lists no words of plain moves (a transform's metadata: the `stats` count);
/// it returns whether the clock is to be read after that line (a progress line).
///
/// An error is the first line at fault: a parse side's (every mode's limits are checked) or a
/// plan side's, the first profile's before the others' on the same line.
pub(crate) fn estimate_modes(
    input: impl Read,
    first: &MotionProfile,
    others: &[MotionProfile],
    firmware: Firmware,
    each_line: impl FnMut(&Ctx<'_>) -> bool,
) -> Result<Modes, EstimateError> {
    // The first batch holds the jobs that set up the plan sides (the first mix).
    let mut batch = new_batch();
    let (mut front, backs) = sides(first, others, firmware, &mut batch)?;
    std::thread::scope(|scope| {
        let (senders, planning): (Vec<_>, Vec<_>) = backs
            .into_iter()
            .map(|back| {
                let (to_back, batches) = mpsc::sync_channel::<Arc<Vec<Job>>>(BATCHES_IN_FLIGHT);
                (to_back, scope.spawn(move || plan(back, batches)))
            })
            .collect();
        let parsed = parse(input, &mut front, &mut batch, &senders, each_line);
        // The lines before an error are planned too: one of them may hold an earlier error.
        send(&senders, batch);
        drop(senders);
        let join = |t: std::thread::ScopedJoinHandle<'_, _>| {
            t.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        };
        let planned: Vec<Result<(Back, Vec<f64>), EstimateError>> = planning.into_iter().map(join).collect();
        // The plan sides are behind the parse side: their errors are on earlier lines (or the
        // same line, for a move the parse side made before its error).
        let first_fault = planned
            .iter()
            .filter_map(|p| p.as_ref().err())
            .chain(parsed.as_ref().err())
            .min_by_key(|e| e.line().unwrap_or(u64::MAX))
            .map(|e| e.line());
        let mut estimates = Vec::with_capacity(planned.len());
        for p in planned {
            match p {
                Ok((mut back, progress_s)) => {
                    back.end();
                    let estimate = Estimate {
                        malformed: front.malformed,
                        huge_arcs: front.huge_arcs(),
                        refused: front.refused.clone(),
                        ..back.summary()
                    };
                    estimates.push(ModeEstimate { estimate, progress_s });
                }
                Err(e) if Some(e.line()) == first_fault => return Err(e),
                Err(_) => {}
            }
        }
        parsed?;
        let mut estimates = estimates.into_iter();
        // One plan side per profile, the first's first: none is missing without an error.
        match estimates.next() {
            Some(first) => Ok(Modes { first, others: estimates.collect(), state: front.state }),
            None => Err(EstimateError::Io(std::io::Error::other("no plan side"))),
        }
    })
}

/// The parse side: every line into jobs, sent in batches to every plan side, with a mark after
/// each line `each_line` picks. Stops early, with `Ok`, when a plan side has stopped (it reports
/// its error itself).
fn parse(
    input: impl Read,
    front: &mut Front,
    batch: &mut Vec<Job>,
    senders: &[mpsc::SyncSender<Arc<Vec<Job>>>],
    mut each_line: impl FnMut(&Ctx<'_>) -> bool,
) -> Result<(), EstimateError> {
    let stop = gweave::Token::current();
    let mut reader = LineReader::new(input);
    while let Some(line) = reader.next_line()? {
        skip_mixing_errors(front.step(&line, batch))?;
        // The front lexed the line into its block (a plain move's words unlisted, as for a
        // pass that reads none) and applied it to its state, as the pass driver does.
        if line.part == Part::Whole {
            let ctx = Ctx { line, block: &front.block, effect: &front.state.effect, state: &front.state };
            if each_line(&ctx) {
                batch.push(Job::Mark);
            }
        }
        // A stopped run (Python's Ctrl-C) stops here too, not only at the reader: counted in
        // lines, since a file of comments makes no jobs.
        if line.number % STOP_CHECK_LINES == 0 {
            if let Some(stop) = &stop {
                stop.check()?;
            }
        }
        if batch.len() >= BATCH && !send(senders, std::mem::replace(batch, new_batch())) {
            return Ok(());
        }
    }
    Ok(())
}

/// Lines between two looks at whether the run was stopped (an atomic load).
const STOP_CHECK_LINES: u64 = 4096;

/// Hands `batch` to every plan side; false when one has stopped (on an error).
fn send(senders: &[mpsc::SyncSender<Arc<Vec<Job>>>], batch: Vec<Job>) -> bool {
    let batch = Arc::new(batch);
    senders.iter().all(|s| s.send(Arc::clone(&batch)).is_ok())
}

/// A plan side: every batch in order, the clock read at each mark.
fn plan(mut back: Back, batches: mpsc::Receiver<Arc<Vec<Job>>>) -> Result<(Back, Vec<f64>), EstimateError> {
    let mut progress_s = Vec::new();
    for batch in batches {
        for job in batch.iter() {
            match job {
                Job::Mark => progress_s.push(back.acc.t_s),
                job => back.execute(job)?,
            }
        }
    }
    Ok((back, progress_s))
}

/// The same lines estimated in several modes on the caller's thread, for a few lines at a
/// time (a transform's changes, timed where they are: `finish/delta.rs`), where threads would
/// cost more than they share. The two sides of [`estimate_modes`] apart, so that they can run
/// at different places: [`ModesParse`] reads the lines once into [`Jobs`], and [`ModesPlan`]
/// plans those jobs in every mode, in order, as [`estimate_modes`]' plan sides do (the same
/// figures, to the bit). A transform's measure reads each window on its own thread and hands
/// the jobs to the thread that plans them (`finish/planner_thread.rs`), which then parses
/// nothing.
///
/// Both sides are [`Clone`]: a copy goes on as the original would, to the bit (the parse
/// side's state, each mode's planner queue and clock are copied whole). A transform's windows
/// read and plan the lines both files share once and copy each side for the lines where they
/// differ (`finish/window.rs`).
pub(crate) fn modes_sides(
    profiles: &[&MotionProfile],
    firmware: Firmware,
) -> Result<(ModesParse, ModesPlan), EstimateError> {
    let Some((first, others)) = profiles.split_first() else {
        return Err(EstimateError::Io(std::io::Error::other("no mode to estimate in")));
    };
    let others: Vec<MotionProfile> = others.iter().map(|p| (*p).clone()).collect();
    let mut jobs = Jobs::default();
    let (front, backs) = sides(first, &others, firmware, &mut jobs.0)?;
    let mut plan = ModesPlan { backs };
    plan.execute(&jobs)?;
    Ok((ModesParse { front }, plan))
}

/// Jobs a [`ModesParse`] made, in order, for a [`ModesPlan`].
#[derive(Debug, Default)]
pub(crate) struct Jobs(Vec<Job>);

impl Jobs {
    /// Empties it, keeping its room.
    pub(crate) fn clear(&mut self) {
        self.0.clear();
    }
}

/// The parse side of an estimate in several modes (the modes share it: only their limits
/// differ): lines in, [`Jobs`] out.
#[derive(Debug, Clone)]
pub(crate) struct ModesParse {
    front: Front,
}

impl ModesParse {
    /// Reads one line (without its line ending), adding its jobs to `jobs`, as
    /// [`Estimator::line`](super::Estimator::line) reads it.
    pub(crate) fn line(&mut self, raw: &[u8], jobs: &mut Jobs) -> Result<(), EstimateError> {
        self.front.lex(raw);
        if self.front.refuses(raw) {
            return Ok(());
        }
        let effect = *self.front.apply(raw);
        skip_mixing_errors(self.front.run(raw, &effect, &mut jobs.0))
    }

    /// The modal state after the line last read.
    pub(crate) fn state(&self) -> &State {
        &self.front.state
    }

    /// The modal state, to set what the caller knows (where a window of lines starts).
    pub(crate) fn state_mut(&mut self) -> &mut State {
        &mut self.front.state
    }

    /// Into the allocations `self` has already.
    pub(crate) fn copy_from(&mut self, source: &Self) {
        self.front.clone_from(&source.front);
    }
}

/// The plan sides of an estimate in several modes, one per mode, fed the jobs of one
/// [`ModesParse`].
#[derive(Debug, Clone)]
pub(crate) struct ModesPlan {
    backs: Vec<Back>,
}

impl ModesPlan {
    /// Plans `jobs` in every mode.
    pub(crate) fn execute(&mut self, jobs: &Jobs) -> Result<(), EstimateError> {
        self.backs.iter_mut().try_for_each(|back| jobs.0.iter().try_for_each(|job| back.execute(job)))
    }

    /// Each mode's clock, s ([`Estimator::now_s`](super::Estimator::now_s)).
    pub(crate) fn now_s(&self) -> impl Iterator<Item = f64> + '_ {
        self.backs.iter().map(|b| b.acc.t_s)
    }

    /// Into the allocations `self` has already.
    pub(crate) fn copy_from(&mut self, source: &Self) {
        self.backs.clone_from(&source.backs);
    }
}

#[cfg(test)]
pub(super) mod tests {
    use gweave::LineReader;

    use super::*;
    use crate::motion::estimate::Estimator;
    use crate::motion::limits::AxisLimits;

    /// What the shared parse side replaces: an estimator of `profile` fed every line, the clock
    /// read after each progress line.
    fn alone(text: &[u8], profile: &MotionProfile) -> (Estimate, Vec<f64>) {
        let mut est = Estimator::timing_only(profile).unwrap();
        est.read_as(Firmware::Marlin);
        est.first_layer_only();
        let (mut reader, mut progress_s) = (LineReader::new(text), Vec::new());
        while let Some(line) = reader.next_line().unwrap() {
            est.read_line(&line).unwrap();
            if line.part == Part::Whole && is_progress(line.bytes) {
                progress_s.push(est.now_s());
            }
        }
        (est.finish(), progress_s)
    }

    fn is_progress(line: &[u8]) -> bool {
        line.starts_with(b"M73")
    }

    /// A second mode: the same machine with lower accelerations and feeds (a silent mode).
    pub(crate) fn silent() -> MotionProfile {
        let p = MotionProfile::default();
        MotionProfile {
            max_accel_mm_s2: AxisLimits { x: 1000.0, y: 1000.0, ..p.max_accel_mm_s2 },
            max_feed_mm_s: AxisLimits { x: 100.0, y: 100.0, ..p.max_feed_mm_s },
            ..p
        }
    }

    /// Regression (issue 35: a transform's metadata estimated every line twice, once per
    /// mode): with one parse side, each mode's figures are its own estimator's to the bit, limits
    /// changed by the file in the middle (each mode's own limits changed), arcs, dwells and
    /// progress lines included.
    #[test]
    fn one_parse_side_gives_each_modes_own_estimate_to_the_bit() {
        let mut text = String::from(";LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F600\nM73 P0 R10\n");
        for i in 0..400 {
            let (x, y) = (f64::from(i % 20) * 7.3, f64::from(i / 20) * 3.1);
            text.push_str(&format!(
                "G1 X{x:.3} Y{y:.3} E{:.4} F{}\n",
                0.1 + f64::from(i % 7) * 0.05,
                1200 + 300 * (i % 11)
            ));
            match i {
                50 => text.push_str("M201 X700 Y800\nM204 P900 T1500\n"),
                120 => text.push_str("G2 X10 Y10 I5 J5 E1\nG4 P250\n;LAYER_CHANGE\n;Z:0.4\nG1 Z0.4\n"),
                200 => text.push_str("M203 X80 Y90\nM204 S600\nM73 P50 R5\n"),
                300 => text.push_str("G1 E-2 F2400\nG1 E2\nM400\n"),
                _ => {}
            }
        }
        text.push_str("M73 P100 R0\n");
        let (normal, silent) = (MotionProfile::default(), silent());
        let progress = |ctx: &Ctx<'_>| is_progress(ctx.line.bytes);
        let Modes { first: a, others, .. } = estimate_modes(
            text.as_bytes(),
            &normal,
            std::slice::from_ref(&silent),
            Firmware::Marlin,
            progress,
        )
        .unwrap();
        let [b] = others.as_slice() else { panic!("{others:?}") };
        for (got, profile) in [(&a, &normal), (b, &silent)] {
            let (est, progress_s) = alone(text.as_bytes(), profile);
            assert_eq!(got.estimate.total_s.to_bits(), est.total_s.to_bits());
            assert_eq!(got.estimate.layer_s, est.layer_s);
            assert_eq!(got.estimate.blocks, est.blocks);
            assert_eq!(got.progress_s, progress_s);
            assert_eq!(got.progress_s.len(), 3);
        }
        // The modes did plan apart: the silent one is slower until the file's `M201` and `M203`
        // set the same limits in both.
        assert!(b.estimate.layer_s[0] > a.estimate.layer_s[0] + 0.1, "{a:?} {b:?}");
    }

    /// A limit one mode refuses stops the estimate at its line, as that mode's estimator does
    /// (Klipper's `SET_VELOCITY_LIMIT`: a value out of a declared range, `M204 S-5`, is a line
    /// refused and skipped before any mode sees it).
    #[test]
    fn a_limit_refused_names_its_line() {
        let text = "G1 X10 F600\nG1 X20\nSET_VELOCITY_LIMIT ACCEL=-5\nG1 X30\n";
        let klipper = MotionProfile::klipper(crate::motion::limits::KlipperLimits::default());
        let e = estimate_modes(
            text.as_bytes(),
            &klipper,
            &[MotionProfile { max_feed_mm_s: silent().max_feed_mm_s, ..klipper.clone() }],
            Firmware::Marlin,
            |_: &Ctx<'_>| false,
        )
        .unwrap_err();
        assert_eq!(e.line(), Some(3), "{e}");
    }
}
