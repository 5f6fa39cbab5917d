//! Measuring a written file for its metadata: its filament by the `stats` count, its settings,
//! its times (normal and silent mode) and the time at each progress line.
//!
//! A transform's output is measured while it is written ([`measure_while_written`]): the
//! measure follows the scratch file as it grows, woken by each write, on a thread of its own,
//! so the finishing step costs the slower of the two rather than their sum. How its times are
//! found depends on the input ([`Timing`]): an input that states its times has them kept, plus
//! what the transform changed ([`measure_changes`], `delta.rs`); one that states none has its
//! output estimated in full ([`measure_read`]); a Slic3r file, which shows no time, is not
//! planned at all.
//!
//! The full estimate is the costly part: Marlin's step-exact planner, about 1 100 instructions
//! a line and mode (docs/performance.md), twice for a file with silent-mode limits of its own.
//! So the file is read once, on one thread, which parses it once for both modes
//! ([`estimate_modes`]) and counts `stats` from the same parse; each mode's planner runs on a
//! thread of its own, fed the jobs in file order, so the figures are the same to the bit as a
//! serial pass's. The batches in flight are bounded, so the memory is a few batches whatever
//! the file's size, and one time per progress line.

use std::io::{self, Read};
use std::path::Path;

use gweave::gcode::container;
use gweave::gcode::ends::read_ends;
use gweave::gcode::flavour::flavour_in;
use gweave::gcode::line::PlainMove;
use gweave::gcode::reader::Part;
use gweave::gcode::scratch::ScratchFile;
use gweave::post::metadata::{is_progress_line, Figures};
use gweave::{Block, Ctx, Firmware, LineReader, State, StateOptions, Target};

use super::delta::{Stated, Times, Windows};
use super::diff::{DiffError, LineDiff, Op};
use super::tally::TallyPass;
use super::{FinishError, Result};
use crate::motion::estimate::{estimate_modes, EstimateError, ModeEstimate, Modes};
use crate::motion::limits::MotionProfile;
use crate::motion::slicer_limits::slicer_limits_both;
use crate::profile::MachineProfile;

/// Measures the written file at `path`.
///
/// The machine limits are the ones the slicer wrote into the file (normal and silent mode), else
/// the default machine's, read from the file's ends, as the flavour.
pub(super) fn measure(path: &Path) -> Result<Figures> {
    let modes = modes_of(&ends_of(path)?);
    let input = container::open(path).map_err(|e| gweave::Error::io(path, e))?;
    measure_read(input, path, &modes)
}

/// Runs `write`, which writes the target of `scratch` (a transform of `input`), and measures
/// that file while it is written: returns what `write` returned and the file's figures, the
/// same to the bit as [`measure`] of the finished file.
///
/// The measure needs the machine limits and the flavour before the file is written, and they
/// are read from its ends (PrusaSlicer's settings block is its last lines): the input's stand
/// for them, since a transform keeps the slicer's settings. The finished file's are then read
/// and compared; a transform that changed them (or an input whose ends cannot be read, or no
/// input at all: a generator) has its file measured again, after the write, with its own.
pub(super) fn measure_while_written<R, E: From<FinishError>>(
    scratch: &ScratchFile,
    input: Option<&Path>,
    write: impl FnOnce(&Target) -> Result<R, E>,
) -> Result<(R, Figures), E> {
    let path = scratch.path();
    let target = scratch.target();
    let read = |input: &Path| {
        let ends = read_ends(input).ok()?;
        let modes = modes_of(&ends);
        Some((Timing::of(&ends, &modes), modes))
    };
    let Some((input, (timing, guessed))) = input.and_then(|i| Some((i, read(i)?))) else {
        let result = write(&target)?;
        return Ok((result, measure(path)?));
    };
    let (result, early) = std::thread::scope(|scope| {
        let measuring = scope.spawn(|| measure_growing(scratch, input, timing, &guessed));
        // Ended before the measure is joined, also when `write` fails or unwinds: the measure
        // then stops rather than wait for the rest of the file.
        let writing = scratch.writing();
        let result = write(&target);
        writing.end(result.is_ok());
        (result, measuring.join())
    });
    // A failed write is the error, whatever the measure made of the unfinished file.
    let result = result?;
    let early = early.unwrap_or_else(|panic| std::panic::resume_unwind(panic));
    let figures = match (modes_of(&ends_of(path)?) == guessed, early?) {
        (true, Some(figures)) => figures,
        // Limits that changed, or changes that could not be timed: the file in full.
        _ => measure(path)?,
    };
    Ok((result, figures))
}

/// Measures the scratch file of a transform of `input` while it is written, as `timing` says.
/// When the changes cannot be timed by windows (a change longer than the comparison holds: a
/// `rotary wrap` rewrites every line; a progress line where none was expected), the output is
/// estimated in full from its first line, still while it is written: the estimate then costs
/// the slower of the transform and itself, not their sum. `None`: the caller measures the
/// finished file (its limits differ from the input's, or the write failed).
fn measure_growing(
    scratch: &ScratchFile,
    input: &Path,
    timing: Timing,
    modes: &FileModes,
) -> Result<Option<Figures>> {
    let path = scratch.path();
    let follow = || scratch.follow().map_err(|e| FinishError::from(gweave::Error::io(path, e)));
    let by_changes = match timing {
        Timing::Full => return measure_read(follow()?, path, modes).map(Some),
        Timing::Changes => {
            let text = container::open(input).map_err(|e| gweave::Error::io(input, e))?;
            measure_changes(follow()?, path, Some((text, input)), modes)?
        }
        Timing::Unused => measure_changes(follow()?, path, None::<(io::Empty, _)>, modes)?,
    };
    match by_changes {
        Some(figures) => Ok(Some(figures)),
        None => measure_read(follow()?, path, modes).map(Some),
    }
}

/// How a transform's output is timed, from its input's ends.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Timing {
    /// The input states its times: they plus what the transform changed ([`measure_changes`]).
    Changes,
    /// The output needs times the input does not state (a footer to add, a placeholder, a
    /// progress line): a full estimate of the output ([`measure_read`]).
    Full,
    /// No line of the output shows a time (Slic3r states filament only): not planned at all,
    /// unless a progress line turns up in the middle of the file.
    Unused,
}

impl Timing {
    fn of(ends: &[u8], modes: &FileModes) -> Self {
        let contains = |needle: &[u8]| memchr::memmem::find(ends, needle).is_some();
        if Stated::in_ends(ends, modes.silent.is_some()) {
            return Timing::Changes;
        }
        let times =
            [&b"estimated printing time"[..], b"\n;TIME:", b"\n;PRINT.TIME:", b"\nM73", b";TIME_ELAPSED:"];
        // Without a filament line of the slicer's, the output gets a footer with a time.
        let filament = [&b"; filament used ["[..], b"; filament used =", b";Filament used:"];
        match times.iter().any(|t| contains(t)) || !filament.iter().any(|f| contains(f)) {
            true => Timing::Full,
            false => Timing::Unused,
        }
    }
}

/// Measures the output `output` (at `path`) of a transform of `input` (its text, and its
/// path for errors) that states its times: the `stats` count of the output, and its times as
/// the input states them plus what the transform changed ([`delta`](super::delta)). Without an
/// input, the times are not measured (no line shows them: [`Timing::Unused`]). `None`: the
/// times cannot be found so (a change past the cap, a line the estimator refuses, no stated
/// total after all, a progress line where none was expected): the caller measures the output
/// in full.
fn measure_changes(
    output: impl Read,
    path: &Path,
    input: Option<(impl Read, &Path)>,
    modes: &FileModes,
) -> Result<Option<Figures>> {
    measure_changes_in(output, path, input, modes, |w| w)
}

/// [`measure_changes`] with the windows `windows` makes of its own.
fn measure_changes_in(
    output: impl Read,
    path: &Path,
    input: Option<(impl Read, &Path)>,
    modes: &FileModes,
    windows: impl FnOnce(Windows) -> Windows,
) -> Result<Option<Figures>> {
    let FileModes { firmware, normal, silent } = modes;
    let profiles: Vec<&MotionProfile> = std::iter::once(normal).chain(silent.as_ref()).collect();
    let (input_path, mut diff) = match input {
        Some((text, p)) => (p, Some(LineDiff::new(text, DIFF_CAP_LINES))),
        None => (path, None),
    };
    let Ok(mut windows) = Windows::new(&profiles, *firmware).map(windows) else { return Ok(None) };
    let mut tally = TallyPass::new();
    let mut stated = Stated::default();
    let mut state = State::new(StateOptions { firmware: *firmware, ..StateOptions::default() });
    let (mut block, mut plain, mut ops) = (Block::default(), PlainMove::default(), Vec::new());
    let mut reader = LineReader::new(output);
    let stop = gweave::Token::current();
    let read_failed = |e| FinishError::from(gweave::Error::io(path, e));
    // Output lines as the comparison counts them: the pieces of a line too long to hold are
    // lines of their own.
    let mut at = 0;
    // The output's bytes from the next line on, against the input's (while they agree).
    let compare_ahead = |diff: &mut Option<LineDiff<_>>, reader: &LineReader<_>| {
        if let Some(diff) = diff {
            diff.compare_ahead(reader.unread());
        }
    };
    compare_ahead(&mut diff, &reader);
    while let Some(line) = reader.next_line().map_err(read_failed)? {
        if diff.is_some() {
            windows.line(line.bytes, &state);
        }
        // A plain move states no time (`Stated` reads `M` and `;` lines).
        if line.part == Part::Whole && !tally.read(&line, &mut state, &mut block, &mut plain) {
            stated.line(at, line.bytes, windows.delta_s);
        }
        if let Some(diff) = &mut diff {
            let handed_over = match diff.same_in_stretch(&line) {
                true => windows.op(Op::Same, &mut stated).is_ok(),
                false => {
                    compared(diff.push(line.bytes, &mut ops), input_path)?
                        && hand_over(&mut ops, &mut windows, &mut stated)
                }
            };
            if !handed_over {
                return Ok(None);
            }
        }
        if at % STOP_CHECK_LINES == 0 {
            if let Some(stop) = &stop {
                stop.check().map_err(|e| gweave::Error::io(path, e))?;
            }
        }
        at += 1;
        compare_ahead(&mut diff, &reader);
    }
    if let Some(diff) = &mut diff {
        if !compared(diff.finish(&mut ops), input_path)? || !hand_over(&mut ops, &mut windows, &mut stated) {
            return Ok(None);
        }
        if windows.finish(&mut stated).is_err() {
            return Ok(None);
        }
    }
    if let Some(e) = tally.failed {
        return Err(gweave::Error::io(path, e).into());
    }
    let times = match diff {
        Some(_) => stated.figures(&windows, silent.is_some()),
        None if stated.has_progress() => None,
        None => Some(Times { total_s: [0.0; 2], first_layer_s: [0.0; 2], progress_s: Vec::new() }),
    };
    let Some(times) = times else { return Ok(None) };
    let stats = tally.stats.into_stats(&state);
    Ok(Some(Figures {
        filament_mm: stats.filament.iter().map(|f| f.extruded_mm).collect(),
        diameter_mm: stats.filament_diameter_mm,
        time_s: times.total_s,
        first_layer_s: times.first_layer_s,
        progress_s: times.progress_s,
        ..tally.figures
    }))
}

/// Lines of a change the comparison holds at most (of each file); past it, the output is
/// measured in full.
const DIFF_CAP_LINES: usize = 4096;
/// Lines between two looks at whether the run was stopped.
const STOP_CHECK_LINES: u64 = 4096;

/// Gives the comparison's ops to the windows, in order: `false` if the changes cannot be timed
/// so.
fn hand_over(ops: &mut Vec<Op>, windows: &mut Windows, stated: &mut Stated) -> bool {
    ops.drain(..).all(|op| windows.op(op, stated).is_ok())
}

/// Whether the comparison goes on: an input that cannot be read is the error, naming it; a
/// change past the cap ends it.
fn compared(result: std::result::Result<(), DiffError>, input: &Path) -> Result<bool> {
    match result {
        Ok(()) => Ok(true),
        Err(DiffError::Io(e)) => Err(gweave::Error::io(input, e).into()),
        Err(DiffError::PastCap(_)) => Ok(false),
    }
}

fn ends_of(path: &Path) -> Result<Vec<u8>> {
    read_ends(path).map_err(|e| gweave::Error::io(path, e).into())
}

/// Measures the text `input` of the file at `path` (errors name it), read as `modes` says.
fn measure_read(input: impl Read, path: &Path, modes: &FileModes) -> Result<Figures> {
    let FileModes { firmware, normal, silent } = modes;
    let silent: Vec<_> = silent.iter().cloned().collect();
    // The `stats` count and the settings from the estimate's own parse: every whole line, with
    // the state `stats` would see (the same firmware's reading).
    let mut tally = TallyPass::new();
    let each_line = |ctx: &Ctx<'_>| {
        tally.line(ctx);
        is_progress_line(ctx.line.bytes)
    };
    let Modes { first: normal, others: silent, state } =
        estimate_modes(input, normal, &silent, *firmware, each_line).map_err(|e| match e {
            // A read error names the file; a fault on a line is the estimate's.
            EstimateError::Io(e) => gweave::Error::io(path, e).into(),
            e => super::FinishError::from(e),
        })?;
    if let Some(e) = tally.failed {
        return Err(gweave::Error::io(path, e).into());
    }
    let stats = tally.stats.into_stats(&state);
    // Without a silent mode of its own, the normal mode's figures stand for it.
    let silent = silent.first().unwrap_or(&normal);
    let normal = &normal;
    let first_layer = |t: &ModeEstimate| t.estimate.layer_s.first().copied().unwrap_or(0.0);
    let figures = Figures {
        filament_mm: stats.filament.iter().map(|f| f.extruded_mm).collect(),
        diameter_mm: stats.filament_diameter_mm,
        time_s: [normal.estimate.total_s, silent.estimate.total_s],
        first_layer_s: [first_layer(normal), first_layer(silent)],
        progress_s: normal.progress_s.iter().zip(&silent.progress_s).map(|(&n, &s)| [n, s]).collect(),
        ..tally.figures
    };
    Ok(figures)
}

/// How a file is read and timed, from its ends (`ends`: its first and last 256 KiB).
#[derive(Debug, PartialEq)]
struct FileModes {
    /// The firmware that reads it, as `stats` resolves it from the flavour (the metadata's
    /// filament comes from that count).
    firmware: Firmware,
    /// The normal mode's limits: the slicer's, else the default machine's.
    normal: MotionProfile,
    /// The silent mode's, for a file that shows silent-mode figures (PrusaSlicer's footer,
    /// `M73 Q0 S..` in its first lines) with limits of their own.
    silent: Option<MotionProfile>,
}

fn modes_of(ends: &[u8]) -> FileModes {
    let firmware = Firmware::resolve(None, flavour_in(ends).as_deref());
    let base = MachineProfile::default().motion;
    let [normal, silent] = slicer_limits_both(ends, &base);
    let normal = normal.map_or_else(|_| base.clone(), |l| l.profile);
    let silent = silent.map_or_else(|_| normal.clone(), |l| l.profile);
    let contains = |needle: &[u8]| memchr::memmem::find(ends, needle).is_some();
    let silent =
        (contains(b"(silent mode)") || contains(b"M73 Q")).then_some(silent).filter(|s| *s != normal);
    FileModes { firmware, normal, silent }
}

#[cfg(test)]
mod tests {
    use gweave::gcode::reader::Part;
    use gweave::LineReader;

    use super::*;
    use crate::motion::estimate::{Estimate, Estimator};
    use gweave::test_support::read_lenient;
    use gweave::{StateOptions, StatsPass};

    /// The serial pass the threads replaced: one estimator per mode fed every whole line, the
    /// clock read after each progress line.
    fn serial(text: &[u8], profile: &MotionProfile) -> ([f64; 2], Vec<f64>) {
        let mut est = Estimator::timing_only(profile).unwrap();
        est.read_as(Firmware::Marlin);
        let (mut reader, mut progress_s) = (LineReader::new(text), Vec::new());
        while let Some(line) = reader.next_line().unwrap() {
            if line.part == Part::Whole {
                est.line(line.bytes).unwrap();
                if is_progress_line(line.bytes) {
                    progress_s.push(est.now_s());
                }
            }
        }
        let est = est.finish();
        ([est.total_s, est.layer_s[0]], progress_s)
    }

    /// Regression: the metadata was measured by a serial pass after the transform (purge-shift
    /// 17x `cat`); the threads must give its figures to the bit, both modes, and the `stats`
    /// count read from the estimate's parse its filament.
    #[test]
    fn the_threaded_measure_gives_the_serial_figures_to_the_bit() {
        let fixture =
            format!("{}/../../tests/data/prusaslicer/pr_bunny_3tool_rel.gcode", env!("CARGO_MANIFEST_DIR"));
        let whole = std::fs::read_to_string(fixture).unwrap();
        let lines: Vec<&str> = whole.lines().collect();
        // Its first 6000 lines with progress lines in both modes every 500, and its settings
        // block (the silent mode's own limits).
        let mut text = String::new();
        for (i, line) in lines[..6000].iter().chain(&lines[lines.len() - 350..]).enumerate() {
            if i % 500 == 0 {
                text.push_str("M73 P0 R0\nM73 Q0 S0\n");
            }
            text.push_str(line);
            text.push('\n');
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m73.gcode");
        std::fs::write(&path, &text).unwrap();
        let figures = measure(&path).unwrap();
        let ends = read_ends(&path).unwrap();
        let base = MachineProfile::default().motion;
        let normal = slicer_limits_both(&ends, &base)[0].as_ref().unwrap().profile.clone();
        let silent = slicer_limits_both(&ends, &base)[1].as_ref().unwrap().profile.clone();
        assert_ne!(normal, silent);
        let (normal_s, normal_progress) = serial(text.as_bytes(), &normal);
        let (silent_s, silent_progress) = serial(text.as_bytes(), &silent);
        assert_eq!(figures.time_s.map(f64::to_bits), [normal_s[0].to_bits(), silent_s[0].to_bits()]);
        assert_eq!(figures.first_layer_s.map(f64::to_bits), [normal_s[1].to_bits(), silent_s[1].to_bits()]);
        let expected: Vec<[f64; 2]> =
            normal_progress.into_iter().zip(silent_progress).map(|(n, s)| [n, s]).collect();
        assert_eq!(figures.progress_s.len(), 2 * 13);
        assert_eq!(figures.progress_s, expected);
        assert!(figures.filament_mm.iter().sum::<f64>() > 100.0, "{figures:?}");
        // The filament is the `stats` count's to the bit, as a pass of its own counts it.
        let mut pass = StatsPass::new(None);
        let firmware = Firmware::resolve(None, flavour_in(&ends).as_deref());
        let options = StateOptions { firmware, ..StateOptions::default() };
        let state = read_lenient(text.as_bytes(), options, &mut pass, &mut io::sink()).unwrap();
        let counted: Vec<f64> = pass.into_stats(&state).filament.iter().map(|f| f.extruded_mm).collect();
        assert_eq!(figures.filament_mm, counted);
    }

    /// A file with progress lines in both modes every 500 lines: the 3-tool bunny's first
    /// `lines` lines and its settings block (the silent mode's own limits).
    fn bunny_with_progress(lines: usize) -> String {
        bunny(lines, |i| (i % 500 == 0).then(|| "M73 P0 R0\nM73 Q0 S0\n".to_owned()))
    }

    /// The 3-tool bunny's first `lines` lines and its last 350 (the settings block and
    /// footer), with `progress(i)` before the `i`-th of them.
    fn bunny(lines: usize, progress: impl Fn(usize) -> Option<String>) -> String {
        let fixture =
            format!("{}/../../tests/data/prusaslicer/pr_bunny_3tool_rel.gcode", env!("CARGO_MANIFEST_DIR"));
        let whole = std::fs::read_to_string(fixture).unwrap();
        let all: Vec<&str> = whole.lines().collect();
        let mut text = String::new();
        for (i, line) in all[..lines].iter().chain(&all[all.len() - 350..]).enumerate() {
            text.extend(progress(i));
            text.push_str(line);
            text.push('\n');
        }
        text
    }

    /// Writes `text` to `target` as a transform does (through an output): in pieces that
    /// split lines, each flushed, with pauses, so that the measure catches up with the writer
    /// and sleeps at the file's end until the next piece wakes it.
    fn write_slowly(target: &Target, text: &str) -> Result<()> {
        use gweave::gcode::writer::Output;
        use std::io::Write;
        let mut out = Output::create(target, None)?;
        let name = out.shown();
        for piece in text.as_bytes().chunks(100_003) {
            out.write_all(piece).and_then(|()| out.flush()).map_err(|e| gweave::Error::io(&name, e))?;
            std::thread::sleep(std::time::Duration::from_millis(3));
        }
        Ok(out.commit()?)
    }

    /// Regression (issue 35): the measure waited for the transform to finish (their times
    /// added up). Measured while it is written, the file's figures are its measure after, to the
    /// bit, both with the input's ends standing for the output's and when they do not (the
    /// input has no settings block: the file is measured again with its own).
    #[test]
    fn a_file_measured_while_written_has_the_figures_of_the_finished_file() {
        let dir = tempfile::tempdir().unwrap();
        // Without the slicer's totals: the output is estimated in full.
        let text: String = bunny_with_progress(4000)
            .lines()
            .filter(|l| !l.contains("estimated printing time"))
            .map(|l| format!("{l}\n"))
            .collect();
        let input = dir.path().join("in.gcode");
        std::fs::write(&input, &text).unwrap();
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let ((), early) = measure_while_written(&scratch, Some(&input), |t| write_slowly(t, &text)).unwrap();
        let after = measure(scratch.path()).unwrap();
        assert_eq!(early, after);
        assert_eq!(early.progress_s.len(), 2 * 9);
        assert_ne!(early.time_s[0].to_bits(), early.time_s[1].to_bits(), "two modes");
        // An input whose ends do not give the output's limits.
        let settings_at = text.rfind("; prusaslicer_config = begin").unwrap();
        std::fs::write(&input, &text[..settings_at]).unwrap();
        assert_ne!(modes_of(&read_ends(&input).unwrap()), modes_of(&read_ends(scratch.path()).unwrap()));
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let ((), again) = measure_while_written(&scratch, Some(&input), |t| write_slowly(t, &text)).unwrap();
        assert_eq!(again, after);
    }

    /// A write that fails is the error, and the measure following it stops (it does not wait
    /// for the rest of a file that will not come).
    #[test]
    fn a_failed_write_is_the_error_and_ends_the_measure() {
        let dir = tempfile::tempdir().unwrap();
        let text = bunny_with_progress(2000);
        let input = dir.path().join("in.gcode");
        std::fs::write(&input, &text).unwrap();
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let failing = |t: &Target| -> Result<()> {
            write_slowly(t, &text[..text.len() / 2])?;
            Err(gweave::Error::io(&input, io::Error::other("the transform failed")).into())
        };
        let e = measure_while_written(&scratch, Some(&input), failing).unwrap_err();
        assert!(e.to_string().contains("the transform failed"), "{e}");
    }

    /// The old measure, line by line: one estimator per mode fed every line as the passes split
    /// them, the clock read after each progress line, and a `stats` pass of its own.
    fn measured_serially(path: &Path) -> Figures {
        let text = std::fs::read(path).unwrap();
        let FileModes { firmware, normal, silent } = modes_of(&read_ends(path).unwrap());
        let timed = |profile: &MotionProfile| {
            let mut est = Estimator::timing_only(profile).unwrap();
            est.read_as(firmware);
            est.first_layer_only();
            let (mut reader, mut progress_s) = (LineReader::new(&text[..]), Vec::new());
            while let Some(line) = reader.next_line().unwrap() {
                est.read_line(&line).unwrap();
                if line.part == Part::Whole && is_progress_line(line.bytes) {
                    progress_s.push(est.now_s());
                }
            }
            (est.finish(), progress_s)
        };
        let (normal, silent) = (timed(&normal), silent.as_ref().map(timed));
        let silent = silent.as_ref().unwrap_or(&normal);
        let mut pass = StatsPass::new(None);
        let options = StateOptions { firmware, ..StateOptions::default() };
        let state = read_lenient(&text[..], options, &mut pass, &mut io::sink()).unwrap();
        let stats = pass.into_stats(&state);
        let first = |e: &Estimate| e.layer_s.first().copied().unwrap_or(0.0);
        Figures {
            filament_mm: stats.filament.iter().map(|f| f.extruded_mm).collect(),
            diameter_mm: stats.filament_diameter_mm,
            time_s: [normal.0.total_s, silent.0.total_s],
            first_layer_s: [first(&normal.0), first(&silent.0)],
            progress_s: normal.1.iter().zip(&silent.1).map(|(&n, &s)| [n, s]).collect(),
            ..Figures::default()
        }
    }

    /// Regression (issue 35): the measure now parses once for both modes and `stats`; on every
    /// fixture, as it is and with progress lines in both modes, its figures are the old line by
    /// line measure's to the bit: the times, the first layer's, the clock at each progress line
    /// and the filament per tool.
    #[test]
    fn every_fixture_measures_as_the_line_by_line_measure() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
        let dir = tempfile::tempdir().unwrap();
        let (mut measured, mut two_modes) = (0, 0);
        for kind in std::fs::read_dir(&data).unwrap() {
            let kind = kind.unwrap().path();
            if !kind.is_dir() {
                continue;
            }
            for file in std::fs::read_dir(kind).unwrap() {
                let path = file.unwrap().path();
                if path.extension().is_none_or(|e| e != "gcode") {
                    continue;
                }
                let text = std::fs::read_to_string(&path).unwrap();
                let lines: Vec<&str> = text.lines().collect();
                // The first 3000 lines and the last 400 (the settings, the footer): a debug
                // build's planner is slow.
                let cut = if lines.len() > 3400 {
                    [&lines[..3000], &lines[lines.len() - 400..]].concat()
                } else {
                    lines
                };
                for m73 in [false, true] {
                    let mut copy = String::new();
                    for (i, line) in cut.iter().enumerate() {
                        if m73 && i % 300 == 0 {
                            copy.push_str("M73 P0 R0\nM73 Q0 S0\n");
                        }
                        copy.push_str(line);
                        copy.push('\n');
                    }
                    let name = path.file_name().unwrap().to_string_lossy();
                    let copy_path = dir.path().join(format!("{m73}-{name}"));
                    std::fs::write(&copy_path, copy).unwrap();
                    let (ours, old) = (measure(&copy_path).unwrap(), measured_serially(&copy_path));
                    let bits = |f: &Figures| (f.time_s.map(f64::to_bits), f.first_layer_s.map(f64::to_bits));
                    assert_eq!(bits(&ours), bits(&old), "{name}, M73 {m73}");
                    assert_eq!(ours.progress_s, old.progress_s, "{name}, M73 {m73}");
                    assert_eq!(ours.filament_mm, old.filament_mm, "{name}, M73 {m73}");
                    assert_eq!(ours.diameter_mm, old.diameter_mm, "{name}, M73 {m73}");
                    measured += 1;
                    two_modes += usize::from(ours.time_s[0] != ours.time_s[1]);
                    // Cura's files carry `;TIME_ELAPSED:` progress lines of their own.
                    assert!(!m73 || ours.progress_s.len() >= 10, "{name}");
                }
            }
        }
        assert!(measured >= 20, "{measured} files");
        // Some with silent-mode limits of their own: both planners ran apart.
        assert!(two_modes >= 2, "{two_modes} files timed in two modes");
    }

    /// The 3-tool bunny's first `lines` lines with the slicer's progress lines every 500 (the
    /// times it states: 19 918 s in all, 20 544 s in silent mode, in proportion to the lines),
    /// and its settings block and footer.
    fn bunny_as_sliced(lines: usize) -> String {
        bunny(lines, |i| {
            let done = i as f64 / lines as f64;
            let left = |total: f64| (total * (1.0 - done) / 60.0).round();
            (i % 500 == 0 && i < lines).then(|| {
                format!(
                    "M73 P{:.0} R{}\nM73 Q{:.0} S{}\n",
                    100.0 * done,
                    left(19918.0),
                    100.0 * done,
                    left(20544.0)
                )
            })
        })
    }

    /// The figures of `output` as a transform of `input`, by its changes.
    fn by_changes(dir: &Path, input: &str, output: &str) -> Option<Figures> {
        let (in_path, out_path) = (dir.join("in.gcode"), dir.join("out.gcode"));
        std::fs::write(&in_path, input).unwrap();
        std::fs::write(&out_path, output).unwrap();
        let modes = modes_of(&read_ends(&in_path).unwrap());
        assert_eq!(Timing::of(&read_ends(&in_path).unwrap(), &modes), Timing::Changes);
        measure_changes(output.as_bytes(), &out_path, Some((input.as_bytes(), in_path.as_path())), &modes)
            .unwrap()
    }

    /// The figures of `input` and of `output` each measured in full (the whole file
    /// estimated), written into `dir`.
    fn full_estimates(dir: &Path, input: &str, output: &str) -> (Figures, Figures) {
        let full = |text: &str, name: &str| {
            let path = dir.join(name);
            std::fs::write(&path, text).unwrap();
            measure(&path).unwrap()
        };
        (full(input, "full_in.gcode"), full(output, "full_out.gcode"))
    }

    /// Issue 35: an output the same as its input states the slicer's figures to the bit (no
    /// window is planned: nothing changed), its filament is the `stats` count, and its progress
    /// lines the times they state.
    #[test]
    fn an_unchanged_file_states_the_slicers_figures() {
        let dir = tempfile::tempdir().unwrap();
        let text = bunny_as_sliced(3000);
        let f = by_changes(dir.path(), &text, &text).unwrap();
        assert_eq!(f.time_s, [19918.0, 20544.0]);
        assert_eq!(f.progress_s.len(), 2 * 6);
        // `M73 P0 R332` then `M73 Q0 S342`, each in its own mode (332 minutes is a little
        // over 19 918 s: none elapsed).
        assert_eq!(f.progress_s[0][0], 0.0);
        assert_eq!(f.progress_s[1][1], 20544.0 - 342.0 * 60.0);
        assert_eq!(f.filament_mm, measure(&dir.path().join("out.gcode")).unwrap().filament_mm);
    }

    /// Issue 35: what a change adds is what the full estimates of the two files differ by,
    /// within 0.05 s for four changes (0.015 s measured), in both modes: a dwell and a purge added, a retraction
    /// removed, a tool change moved earlier; the progress lines after each change move by it,
    /// those before do not, and so does the first layer's.
    #[test]
    fn the_changes_time_is_what_the_full_estimates_differ_by() {
        let dir = tempfile::tempdir().unwrap();
        let input = bunny_as_sliced(4000);
        let mut lines: Vec<&str> = input.lines().collect();
        let t = lines.iter().rposition(|l| *l == "T1").unwrap();
        let block: Vec<&str> = lines.drain(t - 1..t + 2).collect();
        lines.splice(t - 40..t - 40, block);
        let retraction = lines.iter().position(|l| l.starts_with("G1 E-")).unwrap();
        lines.remove(retraction);
        let middle = lines.len() / 2;
        lines.splice(middle..middle, ["G4 P1500", "G1 E25 F200", "G1 E-0.8 F2100"]);
        let output: String = lines.iter().map(|l| format!("{l}\n")).collect();
        let f = by_changes(dir.path(), &input, &output).unwrap();
        let (full_in, full_out) = full_estimates(dir.path(), &input, &output);
        let stated = by_changes(dir.path(), &input, &input).unwrap();
        for m in 0..2 {
            let (changes, estimated) =
                (f.time_s[m] - stated.time_s[m], full_out.time_s[m] - full_in.time_s[m]);
            assert!(
                changes > 1.5 + 25.0 / (200.0 / 60.0) && (changes - estimated).abs() < 0.05,
                "mode {m}: {changes} s, estimates {estimated} s"
            );
            // The progress lines before the first change are the slicer's, the last is moved by
            // all of them.
            assert_eq!(f.progress_s[..2], stated.progress_s[..2]);
            let last = f.progress_s.len() - 1;
            assert!((f.progress_s[last][m] - stated.progress_s[last][m] - changes).abs() < 1e-9);
        }
    }

    /// Regression (issue 35): a change whose modal state lasts to the output's end (a move
    /// added after the print's last, which leaves the head elsewhere) has a window whose sides
    /// never agree; it was left open at the end and its time never counted. At the end it
    /// closes: what it adds is what the full estimates differ by, in both modes.
    #[test]
    fn a_change_that_lasts_to_the_end_is_counted() {
        let dir = tempfile::tempdir().unwrap();
        let input = bunny_as_sliced(3000);
        let last_move = input.rfind("\nG1 X").unwrap() + 1;
        let after = last_move + input[last_move..].find('\n').unwrap() + 1;
        let output = format!("{}G1 X5 Y5 F600\n{}", &input[..after], &input[after..]);
        let f = by_changes(dir.path(), &input, &output).unwrap();
        let stated = by_changes(dir.path(), &input, &input).unwrap();
        let (full_in, full_out) = full_estimates(dir.path(), &input, &output);
        for m in 0..2 {
            let (changes, estimated) =
                (f.time_s[m] - stated.time_s[m], full_out.time_s[m] - full_in.time_s[m]);
            assert!(estimated > 1.0, "mode {m}: the full estimates differ by {estimated} s");
            assert!((changes - estimated).abs() < 0.05, "mode {m}: {changes} s, estimates {estimated} s");
        }
    }

    /// A change longer than the comparison holds is not timed by windows: the output is
    /// measured in full (and so it is, by `measure_while_written`).
    #[test]
    fn a_change_past_the_cap_is_measured_in_full() {
        let dir = tempfile::tempdir().unwrap();
        let input = bunny_as_sliced(2000);
        let at = input.find("\nG1 ").unwrap() + 1;
        let added: String = (0..DIFF_CAP_LINES + 10).map(|i| format!("G1 X{} Y10 F3000\n", i % 50)).collect();
        let output = format!("{}{added}{}", &input[..at], &input[at..]);
        assert_eq!(by_changes(dir.path(), &input, &output), None);
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let in_path = dir.path().join("in.gcode");
        let ((), figures) =
            measure_while_written(&scratch, Some(&in_path), |t| write_slowly(t, &output)).unwrap();
        assert_eq!(figures, measure(scratch.path()).unwrap());
    }

    /// Issue 35: the windows planned on a thread of their own give the figures of the
    /// windows planned on the measure's thread, to the bit (the total, the first layer's and
    /// every progress line's, in both modes), for changes all over the file: dwells added,
    /// retractions removed, and feed rates changed for good (windows that grow until the sides
    /// agree, their first attempts planned all the same).
    #[test]
    fn windows_planned_on_their_thread_give_the_figures_planned_here() {
        let dir = tempfile::tempdir().unwrap();
        let input = bunny_as_sliced(6000);
        let mut output = String::new();
        for (i, line) in input.lines().enumerate() {
            match i % 97 {
                0 => output.push_str("G4 P200\n"),
                30..=40 if line.starts_with("G1 E-") => continue,
                60..=70 if line.starts_with("G1 X") && !line.contains(['F', ';']) => {
                    output.push_str(line);
                    output.push_str(" F1234\n");
                    continue;
                }
                _ => {}
            }
            output.push_str(line);
            output.push('\n');
        }
        assert!(output.matches(" F1234").count() > 20);
        let (in_path, out_path) = (dir.path().join("in.gcode"), dir.path().join("out.gcode"));
        std::fs::write(&in_path, &input).unwrap();
        std::fs::write(&out_path, &output).unwrap();
        let modes = modes_of(&read_ends(&in_path).unwrap());
        let open = |p: &Path| std::fs::File::open(p).unwrap();
        let measured = |here: bool| {
            let input = Some((open(&in_path), in_path.as_path()));
            measure_changes_in(open(&out_path), &out_path, input, &modes, |w| match here {
                true => w.planned_here(),
                false => w,
            })
            .unwrap()
            .unwrap()
        };
        let (thread, here) = (measured(false), measured(true));
        let bits = |f: &Figures| {
            let progress: Vec<_> = f.progress_s.iter().map(|p| p.map(f64::to_bits)).collect();
            (f.time_s.map(f64::to_bits), f.first_layer_s.map(f64::to_bits), progress)
        };
        assert_eq!(bits(&thread), bits(&here));
        assert_eq!(thread.filament_mm, here.filament_mm);
        // The changes were timed: over 60 dwells of 0.2 s.
        assert!(thread.time_s[0] > 19918.0 + 60.0 * 0.2, "{:?}", thread.time_s);
        assert!(thread.first_layer_s[0] > 0.0);
    }

    /// Issue 35: a write that fails while windows are being planned on their thread is the
    /// error, and ends the measure and the planner thread (joined when the measure drops it:
    /// a thread left waiting would hang the test).
    #[test]
    fn a_failed_write_ends_the_windows_planner() {
        let dir = tempfile::tempdir().unwrap();
        let input = bunny_as_sliced(4000);
        let output: String = input
            .lines()
            .enumerate()
            .map(|(i, l)| match i % 50 {
                0 => format!("G4 P100\n{l}\n"),
                _ => format!("{l}\n"),
            })
            .collect();
        let in_path = dir.path().join("in.gcode");
        std::fs::write(&in_path, &input).unwrap();
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let failing = |t: &Target| -> Result<()> {
            write_slowly(t, &output[..output.len() * 3 / 4])?;
            Err(gweave::Error::io(&in_path, io::Error::other("the transform failed")).into())
        };
        let e = measure_while_written(&scratch, Some(&in_path), failing).unwrap_err();
        assert!(e.to_string().contains("the transform failed"), "{e}");
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let ((), figures) =
            measure_while_written(&scratch, Some(&in_path), |t| write_slowly(t, &output)).unwrap();
        // Some 80 dwells of 0.1 s timed by the windows.
        assert!(figures.time_s[0] > 19918.0 + 7.0, "{:?}", figures.time_s);
    }

    /// Regression (issue 35): a change too long to compare (a `rotary wrap` rewrites every
    /// line) gave up on the measure while the file was written, and the whole output was
    /// estimated after the write, serially: the measure now switches to the full estimate from
    /// the output's first line, on its own thread, with the same figures.
    #[test]
    fn a_change_past_the_cap_is_estimated_in_full_while_written() {
        let dir = tempfile::tempdir().unwrap();
        let input = bunny_as_sliced(2000);
        let output: String = input.lines().map(|l| format!("{l} ;wrapped\n")).collect();
        let in_path = dir.path().join("in.gcode");
        std::fs::write(&in_path, &input).unwrap();
        let modes = modes_of(&read_ends(&in_path).unwrap());
        let scratch = ScratchFile::new_in(dir.path(), None).unwrap();
        let writing = scratch.writing();
        write_slowly(&scratch.target(), &output).unwrap();
        writing.end(true);
        let while_written = measure_growing(&scratch, &in_path, Timing::Changes, &modes).unwrap();
        // The input's limits, as the measure takes them while the file is written (the
        // comment after each line hides the output's own silent-mode limits).
        let after =
            measure_read(std::fs::File::open(scratch.path()).unwrap(), scratch.path(), &modes).unwrap();
        assert_ne!(after.time_s[0], after.time_s[1], "both modes timed");
        assert_eq!(while_written, Some(after));
    }

    /// The context a change's window needs (docs/performance.md): the total written against
    /// the difference of the two files' full estimates, for context from 1 to 32 code lines.
    /// `DELTA_IN`, `DELTA_OUT`: a transform's input and output.
    #[test]
    #[ignore]
    fn context_sweep() {
        let (input, output) = (std::env::var("DELTA_IN").unwrap(), std::env::var("DELTA_OUT").unwrap());
        let (input, output) = (Path::new(&input), Path::new(&output));
        let modes = modes_of(&read_ends(output).unwrap());
        let (full_in, full_out) = (measure(input).unwrap(), measure(output).unwrap());
        let stated = measure_changes(
            std::fs::File::open(input).unwrap(),
            input,
            Some((std::fs::File::open(input).unwrap(), input)),
            &modes,
        )
        .unwrap()
        .unwrap();
        let expected = [0, 1].map(|m| full_out.time_s[m] - full_in.time_s[m]);
        println!("full estimates differ by {expected:?} s; stated {:?}", stated.time_s);
        for k in [1, 2, 3, 4, 6, 8, 12, 16, 24, 32] {
            let open = |p: &Path| std::fs::File::open(p).unwrap();
            let Some(f) = measure_changes_in(open(output), output, Some((open(input), input)), &modes, |w| {
                w.with_context(k)
            })
            .unwrap() else {
                println!("K {k:2}: measured in full");
                continue;
            };
            let got = [0, 1].map(|m| f.time_s[m] - stated.time_s[m]);
            println!("K {k:2}: changes {got:?} s, error {:?} s", [0, 1].map(|m| got[m] - expected[m]));
        }
    }
}
