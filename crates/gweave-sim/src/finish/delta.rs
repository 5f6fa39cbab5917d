//! A transform's times as the slicer stated them for its input plus what the transform
//! changed, planned where it changed.
//!
//! The slicer states what the input costs: PrusaSlicer's footer (`; estimated printing time
//! (normal mode) = 5h 31m 58s`, silent mode, first layer) and its `M73 P.. R..` / `Q.. S..`
//! progress lines, Cura's `;TIME:` (or Griffin's `;PRINT.TIME:`) and `;TIME_ELAPSED:` per layer
//! ([`Stated`]). A transform changes a few lines at each tool change, so a full plan of its
//! output, twice for a file with silent-mode limits, is almost all spent on moves it copied.
//! Instead each change ([`super::diff`]) is planned in a window ([`Windows`]): the changed lines
//! with [`CONTEXT_LINES`] unchanged code lines on each side, once as the input had them and
//! once as the output has them, by the estimator with the file's limits (normal and silent
//! mode). Both sides start at rest from the same modal state (the output's before the window:
//! the files agree there) and end drained after the same lines, so what the context costs
//! cancels, and their difference is what the change costs. The times written are then the
//! slicer's plus the sum of those differences: at a progress line, those of the changes before
//! it; in the first layer, those within it.
//!
//! Marlin's lookahead is 16 blocks, and a change is a tool change: a retraction (an E-only
//! move brings the nozzle to a stop) before it, a prime after it. So a change's effect on the
//! plan reaches few moves either side, and the context needed is measured
//! (docs/performance.md): the total written stays within 0.1 s per change of the difference of
//! the two files' full estimates.

use std::collections::VecDeque;

use gweave::post::metadata::is_progress_line;
use gweave::post::purge_shift::held_text::{HeldText, TextRef};
use gweave::{Firmware, State};

use super::diff::Op;
use super::planner_thread::{Planner, WindowJob};
use super::window::{sides, Modal, Readers, WindowLines};
use crate::motion::estimate::EstimateError;
use crate::motion::limits::MotionProfile;

/// Unchanged code lines (not comments) planned on each side of a change: a change closer than
/// that to the previous one shares its window.
pub(super) const CONTEXT_LINES: u64 = 8;
/// Output lines a window holds at most (the changes and their context); past it, the output is
/// measured in full.
pub(super) const WINDOW_CAP_LINES: u64 = 8192;

/// What the slicer stated in the file (read from the output, which keeps those lines).
#[derive(Debug, Default)]
pub(super) struct Stated {
    /// The total, normal and silent mode, s.
    total_s: [Option<f64>; 2],
    /// The first layer's, s.
    first_layer_s: [Option<f64>; 2],
    /// Each progress line, in file order.
    progress: Vec<Progress>,
}

/// A progress line: what it says and the changes before it.
#[derive(Debug)]
struct Progress {
    /// Its output line (0-based).
    at: u64,
    said: Said,
    /// The sum of the changes' times before it, normal and silent mode, s.
    delta_s: [f64; 2],
}

/// What a progress line says of the time elapsed.
#[derive(Debug, Clone, Copy)]
enum Said {
    /// `M73 P.. R..` (mode 0) or `Q.. S..` (mode 1): percent done and minutes left, either or
    /// both.
    M73 { mode: usize, percent: Option<f64>, minutes_left: Option<f64> },
    /// Cura's `;TIME_ELAPSED:`, s.
    Elapsed(f64),
    /// Nothing readable: as the line before.
    Nothing,
}

/// Cura's placeholder for a time it does not know (CuraEngine writes `;TIME:6666` when it
/// writes the header before the print is planned, and the front end fills it in).
const CURA_PLACEHOLDER_S: f64 = 6666.0;

impl Stated {
    /// Whether the file has a progress line.
    pub(super) fn has_progress(&self) -> bool {
        !self.progress.is_empty()
    }

    /// Whether the file's ends (`ends`) state a total time in every mode the file is timed in
    /// (`silent`: it has silent-mode limits of its own).
    pub(super) fn in_ends(ends: &[u8], silent: bool) -> bool {
        let mut stated = Stated::default();
        // Only the lines with a total: the ends are half a megabyte.
        for key in [&b"; estimated printing time ("[..], b";TIME:", b";PRINT.TIME:"] {
            for at in memchr::memmem::find_iter(ends, key) {
                let line = ends[at..].split(|&b| b == b'\n').next().unwrap_or_default();
                stated.line(0, line.trim_ascii_end(), [0.0; 2]);
            }
        }
        stated.total_s[0].is_some() && (!silent || stated.total_s[1].is_some())
    }

    /// Reads the output's line `at` (without its ending), after changes costing
    /// `delta_before_s` ([`Windows::delta_s`]).
    pub(super) fn line(&mut self, at: u64, line: &[u8], delta_before_s: [f64; 2]) {
        let t = line.trim_ascii_start();
        match t.first() {
            Some(b'M' | b'm' | b';') => {}
            _ => return,
        }
        if is_progress_line(t) {
            let said = match t.strip_prefix(b";TIME_ELAPSED:") {
                Some(v) => number(v).map_or(Said::Nothing, Said::Elapsed),
                None => m73(t),
            };
            self.progress.push(Progress { at, said, delta_s: delta_before_s });
            return;
        }
        let Some(c) = t.strip_prefix(b";") else { return };
        if let Some((key, value)) = c.iter().position(|&b| b == b'=').map(|i| (&c[..i], &c[i + 1..])) {
            let slot = match key.trim_ascii() {
                b"estimated printing time (normal mode)" => &mut self.total_s[0],
                b"estimated printing time (silent mode)" => &mut self.total_s[1],
                b"estimated first layer printing time (normal mode)" => &mut self.first_layer_s[0],
                b"estimated first layer printing time (silent mode)" => &mut self.first_layer_s[1],
                _ => return,
            };
            *slot = duration_s(value).or(*slot);
        } else if let Some(v) = c.strip_prefix(b"TIME:").or_else(|| c.strip_prefix(b"PRINT.TIME:")) {
            self.total_s[0] = number(v).filter(|&t| t != CURA_PLACEHOLDER_S).or(self.total_s[0]);
        }
    }

    /// Adds `delta_s` to the progress lines from output line `from` on that are read already
    /// (the later ones start from [`Windows::delta_s`]).
    fn add_from(&mut self, from: u64, delta_s: [f64; 2]) {
        for p in self.progress.iter_mut().rev().take_while(|p| p.at >= from) {
            p.delta_s[0] += delta_s[0];
            p.delta_s[1] += delta_s[1];
        }
    }

    /// The figures: the stated ones plus the changes' (`windows`), or `None` if the file does
    /// not state a total in normal mode (or in silent mode, `silent`).
    pub(super) fn figures(&self, windows: &Windows, silent: bool) -> Option<Times> {
        let normal = self.total_s[0]?;
        let total_in = [normal, if silent { self.total_s[1]? } else { self.total_s[1].unwrap_or(normal) }];
        let d = windows.delta_s;
        let total_s = [total_in[0] + d[0], total_in[1] + d[1]].map(|t| t.max(0.0));
        let first_layer_s = [0, 1].map(|m| {
            let stated = self.first_layer_s[m].or(self.first_layer_s[0]).unwrap_or(0.0);
            (stated + windows.first_layer_delta_s[m]).max(0.0)
        });
        let mut before = [0.0; 2];
        let progress_s = self
            .progress
            .iter()
            .map(|p| {
                // The elapsed time in the mode the line speaks of, the other in proportion.
                let share = |mode: usize, elapsed: f64| {
                    let ratio = if total_in[mode] > 0.0 { elapsed / total_in[mode] } else { 0.0 };
                    let mut both = [ratio * total_in[0], ratio * total_in[1]];
                    both[mode] = elapsed;
                    both
                };
                let elapsed = match p.said {
                    Said::M73 { mode, percent, minutes_left } => {
                        let total = total_in[mode];
                        // Minutes are rounded to 30 s, percent to 0.5 % of the total: the
                        // finer of the two (percent under 100 minutes).
                        let from_left = minutes_left.map(|m| total - 60.0 * m);
                        let from_percent = percent.map(|p| total * p / 100.0);
                        let finer = if total / 200.0 < 30.0 {
                            from_percent.or(from_left)
                        } else {
                            from_left.or(from_percent)
                        };
                        finer.map_or(before, |t| share(mode, t))
                    }
                    Said::Elapsed(t) => share(0, t),
                    Said::Nothing => before,
                };
                // Monotone and within the total, as a display shows it.
                let t = [0, 1].map(|m| (elapsed[m] + p.delta_s[m]).clamp(before[m], total_s[m]));
                before = t;
                t
            })
            .collect();
        Some(Times { total_s, first_layer_s, progress_s })
    }
}

/// The times written: total, first layer and at each progress line, normal and silent mode, s.
#[derive(Debug)]
pub(super) struct Times {
    pub total_s: [f64; 2],
    pub first_layer_s: [f64; 2],
    pub progress_s: Vec<[f64; 2]>,
}

/// What an `M73` line says, in the first mode it speaks of.
fn m73(line: &[u8]) -> Said {
    let code = line.split(|&b| b == b';').next().unwrap_or_default();
    let (mut percent, mut left) = ([None; 2], [None; 2]);
    for word in code.split(|b| b.is_ascii_whitespace()).skip(1) {
        let Some((&letter, v)) = word.split_first() else { continue };
        match letter.to_ascii_uppercase() {
            b'P' => percent[0] = number(v),
            b'R' => left[0] = number(v),
            b'Q' => percent[1] = number(v),
            b'S' => left[1] = number(v),
            _ => {}
        }
    }
    match (0..2).find(|&m| percent[m].is_some() || left[m].is_some()) {
        Some(mode) => Said::M73 { mode, percent: percent[mode], minutes_left: left[mode] },
        None => Said::Nothing,
    }
}

fn number(v: &[u8]) -> Option<f64> {
    std::str::from_utf8(v).ok()?.trim().parse().ok().filter(|x: &f64| x.is_finite() && *x >= 0.0)
}

/// PrusaSlicer's `1d 2h 3m 4s` (any of its parts), s.
fn duration_s(v: &[u8]) -> Option<f64> {
    let text = std::str::from_utf8(v).ok()?;
    let mut total = None;
    for part in text.split_whitespace() {
        let (n, unit) = part.split_at(part.len().checked_sub(1)?);
        let scale = match unit {
            "d" => 86400.0,
            "h" => 3600.0,
            "m" => 60.0,
            "s" => 1.0,
            _ => return None,
        };
        total = Some(total.unwrap_or(0.0) + n.parse::<f64>().ok()? * scale);
    }
    total
}

/// An output line held for the windows: its text in [`Windows`]' one buffer (a `Vec` per line
/// cost an allocation's bookkeeping and a copy each way for every line of the output).
#[derive(Debug)]
struct Held {
    text: TextRef,
    /// Code lines before it.
    codes: u64,
    /// The state before it.
    modal: Modal,
}

/// The changes of a window being gathered.
#[derive(Debug)]
struct Window {
    /// Its first output line, and the state before it.
    start: u64,
    modal: Modal,
    /// Its first change's output line.
    first_change: u64,
    /// Each change: its output line, the output lines it adds and the input lines it removes.
    changes: Vec<(u64, u64, Vec<Vec<u8>>)>,
    /// Unchanged code lines since its last change.
    equal_codes: u64,
}

/// Why the changes could not be timed: the output is measured in full.
#[derive(Debug)]
pub(super) enum Unmeasured {
    /// A window longer than [`WINDOW_CAP_LINES`].
    PastCap,
    /// The estimator refused a line (the full measure names it).
    Estimate,
    /// The planner thread could not be started.
    NoPlanner,
}

/// The windows of a transform's changes, gathered from the output's lines and the
/// comparison's [`Op`]s, and timed as they close, on the planner thread
/// ([`super::planner_thread`]).
pub(super) struct Windows {
    /// The output's side and the input's, each read by the estimators' parse side alone: they
    /// say where a window ends, and read its lines into the jobs the planner plans.
    follower: Readers,
    /// The thread that plans the windows, on the sides proper.
    planner: Planner,
    /// Modes: 2 for a file with silent-mode limits of its own, else 1.
    modes: usize,
    /// The output's lines from where the next window would start on.
    held: VecDeque<Held>,
    held_from: u64,
    text: HeldText,
    /// Output lines given, and given an op.
    lines: u64,
    decided: u64,
    codes: u64,
    /// The lines that set limits (`M201`-`M205`), with their output line: the last few of
    /// each, replayed before a window.
    limits: Vec<(u64, Vec<u8>)>,
    /// The last limits line replayed, and whether a window's own lines set limits since.
    replayed: Option<u64>,
    window_set_limits: bool,
    open: Option<Window>,
    /// Unchanged code lines planned on each side of a change ([`CONTEXT_LINES`]).
    context: u64,
    /// The changes' times so far (the windows planned and taken back), normal and silent
    /// mode, s; and those in the first layer.
    pub delta_s: [f64; 2],
    pub first_layer_delta_s: [f64; 2],
    /// Windows timed.
    pub timed: u64,
}

/// Lines that set limits kept per command.
const LIMITS_KEPT: usize = 8;

impl Windows {
    /// Windows timed with the limits of each of `profiles` (normal mode, then silent), the
    /// lines read as `firmware` reads them.
    pub(super) fn new(profiles: &[&MotionProfile], firmware: Firmware) -> Result<Self, EstimateError> {
        let (readers, plans) = sides(profiles, firmware)?;
        Ok(Windows {
            follower: readers,
            planner: Planner::new(plans),
            modes: profiles.len(),
            held: VecDeque::new(),
            held_from: 0,
            text: HeldText::default(),
            lines: 0,
            decided: 0,
            codes: 0,
            limits: Vec::new(),
            replayed: None,
            window_set_limits: false,
            open: None,
            context: CONTEXT_LINES,
            delta_s: [0.0; 2],
            first_layer_delta_s: [0.0; 2],
            timed: 0,
        })
    }

    /// The same with `context` unchanged code lines on each side of a change.
    #[cfg(test)]
    pub(super) fn with_context(self, context: u64) -> Self {
        Windows { context, ..self }
    }

    /// The same planned on the caller's thread ([`Planner::here`]).
    #[cfg(test)]
    pub(super) fn planned_here(mut self) -> Self {
        self.planner.plan_here();
        self
    }

    /// The output's next line, `state` being the state before it.
    pub(super) fn line(&mut self, bytes: &[u8], state: &State) {
        let text = self.text.push(bytes, b"");
        self.held.push_back(Held { text, codes: self.codes, modal: Modal::of(state) });
        let t = bytes.trim_ascii_start();
        if !matches!(t.first(), None | Some(b';')) {
            self.codes += 1;
            if sets_limits(t) {
                let code = &t[..4];
                let same: Vec<usize> = (0..self.limits.len())
                    .filter(|&i| self.limits[i].1[..4].eq_ignore_ascii_case(code))
                    .collect();
                if same.len() >= LIMITS_KEPT {
                    self.limits.remove(same[0]);
                }
                self.limits.push((self.lines, t.to_vec()));
            }
        }
        self.lines += 1;
    }

    /// What the comparison found for the next undecided output lines.
    pub(super) fn op(&mut self, op: Op, stated: &mut Stated) -> Result<(), Unmeasured> {
        match op {
            Op::Same => {
                let code = self.codes_before(self.decided + 1) > self.codes_before(self.decided);
                self.decided += 1;
                let context = self.context;
                match &mut self.open {
                    Some(w) => {
                        w.equal_codes += u64::from(code);
                        // Comments cost no time: a long run of them ends a window too.
                        if w.equal_codes >= context || self.decided - w.start > WINDOW_CAP_LINES {
                            self.close(stated, false)?;
                        }
                    }
                    None => self.forget(),
                }
            }
            Op::Changed { removed, added } => {
                let at = self.decided;
                if self.open.is_none() {
                    // The context before the change is what is held.
                    self.forget();
                    let Some(first) = self.held.front() else { return Err(Unmeasured::PastCap) };
                    let (start, modal) = (self.held_from, first.modal);
                    self.open =
                        Some(Window { start, modal, first_change: at, changes: Vec::new(), equal_codes: 0 });
                }
                if let Some(w) = &mut self.open {
                    w.changes.push((at, added as u64, removed));
                    w.equal_codes = 0;
                    if at + added as u64 - w.start > WINDOW_CAP_LINES {
                        return Err(Unmeasured::PastCap);
                    }
                }
                self.decided += added as u64;
            }
        }
        Ok(())
    }

    /// The output has ended: the last window is timed, and every window's times are added.
    pub(super) fn finish(&mut self, stated: &mut Stated) -> Result<(), Unmeasured> {
        if self.open.is_some() {
            self.close(stated, true)?;
        }
        while let Some(job) = self.planner.wait() {
            self.add(job, stated)?;
        }
        Ok(())
    }

    /// Code lines before output line `at` (given already, or the next).
    fn codes_before(&self, at: u64) -> u64 {
        match self.held.get((at - self.held_from) as usize) {
            Some(h) => h.codes,
            None => self.codes,
        }
    }

    /// Drops the lines no window can start from any more: a change comes at the earliest at
    /// the next undecided line, and its window starts the context's code lines before it.
    fn forget(&mut self) {
        let codes = self.codes_before(self.decided);
        while self.held.len() > 1
            && self.held[1].codes + self.context <= codes
            && self.held_from < self.decided
        {
            self.held.pop_front();
            self.held_from += 1;
        }
        self.text.written_up_to(self.held.front().map(|h| h.text));
    }

    /// Hands the open window to the planner, to be timed on both sides in every mode, and adds
    /// the differences of those planned already. At the output's end (`at_end`) the window
    /// closes whether or not its sides agree: no line follows that their states would plan
    /// differently.
    fn close(&mut self, stated: &mut Stated, at_end: bool) -> Result<(), Unmeasured> {
        let Some(w) = self.open.take() else { return Ok(()) };
        let end = self.decided;
        let mut job = self.planner.job(w.modal.first_layer, w.first_change);
        // The limits in force at the window's start, if they changed since the last replay.
        let in_force = self.limits.iter().filter(|(at, _)| *at < w.start);
        let latest = in_force.clone().map(|(at, _)| *at).next_back();
        let mut limits = Vec::new();
        if latest != self.replayed || self.window_set_limits {
            limits.extend(in_force.map(|(_, line)| line.as_slice()));
            self.replayed = latest;
        }
        self.window_set_limits = self.limits.iter().any(|(at, _)| (w.start..end).contains(at));
        let held = |i: u64| self.text.bytes(self.held[(i - self.held_from) as usize].text);
        // The lines before the first change are the same on both sides: read and planned once.
        let shared: Vec<&[u8]> = (w.start..w.first_change).map(held).collect();
        let output: Vec<&[u8]> = (w.first_change..end).map(held).collect();
        let mut input = Vec::with_capacity(output.len());
        let mut next = w.first_change;
        for (at, added, removed) in &w.changes {
            input.extend((next..*at).map(held));
            input.extend(removed.iter().map(Vec::as_slice));
            next = at + added;
        }
        input.extend((next..end).map(held));
        let g92 = w.modal.g92();
        let lines = WindowLines {
            limits: &limits,
            modal: &w.modal,
            g92: &g92,
            shared: &shared,
            output: &output,
            input: &input,
        };
        self.follower.read(&lines, &mut job.jobs).map_err(|_| Unmeasured::Estimate)?;
        // A change whose modal state outlasts the window (a feed rate, a position, a mode not
        // put back) goes on changing the moves after it: the window grows until the two sides
        // agree again, and is timed again then. The attempt is planned all the same: it moves
        // the estimators' clocks on, as it did when the windows were planned here.
        job.closes = at_end || self.follower.agree();
        let closes = job.closes;
        self.planner.send(job)?;
        while let Some(job) = self.planner.planned() {
            self.add(job, stated)?;
        }
        match closes {
            true => self.forget(),
            false => self.open = Some(Window { equal_codes: 0, ..w }),
        }
        Ok(())
    }

    /// Adds the difference a planned window makes, if it closed. The windows come back in the
    /// order they closed, so each sum is made in the same order as when they were planned
    /// here: the figures are the same to the bit. A progress line read since the window
    /// closed is after its first change, and gets its difference from `add_from`.
    fn add(&mut self, job: WindowJob, stated: &mut Stated) -> Result<(), Unmeasured> {
        let [t_out, t_in] = job.times_s.ok_or(Unmeasured::Estimate)?;
        if job.closes {
            // Without a silent mode of its own, the normal mode's difference stands for it.
            let delta_s = [0, 1].map(|m| {
                let m = m.min(self.modes - 1);
                t_out[m] - t_in[m]
            });
            stated.add_from(job.first_change, delta_s);
            for (m, d) in delta_s.into_iter().enumerate() {
                self.delta_s[m] += d;
                if job.first_layer {
                    self.first_layer_delta_s[m] += d;
                }
            }
            self.timed += 1;
        }
        self.planner.recycle(job);
        Ok(())
    }
}

/// Whether the code line `t` sets the planner's limits (`M201`, `M203`, `M204`, `M205`).
fn sets_limits(t: &[u8]) -> bool {
    t.len() >= 4
        && t[0].eq_ignore_ascii_case(&b'M')
        && matches!(&t[1..4], b"201" | b"203" | b"204" | b"205")
        && !t.get(4).is_some_and(u8::is_ascii_digit)
}
