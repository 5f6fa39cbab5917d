//! What every command that writes G-code does around its pass: it refuses to run a transform a
//! second time on its own output, and it writes metadata that is true for the file as written.
//!
//! The transform writes into a scratch file (registered like every temporary file, so Ctrl-C
//! removes it). One streaming pass over that file measures it: the filament by the `stats` count
//! and the print time by the virtual printer's estimator, with the machine limits the slicer
//! wrote into the file (normal and silent mode), else the default machine's. A second pass
//! writes it to the real target (a temporary file renamed into place, `--in-place` with its
//! `.bak`, or standard output) with the run's header on top and the slicer's figures and `M73`
//! progress rewritten (`gweave::post::metadata`). Memory stays bounded: the passes stream, and
//! what is kept is one time per progress line. The estimator lives in gweave-sim, which the
//! engine cannot depend on, so this layer joins them.

use std::fs::File;
use std::io::{self, BufReader, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use gweave::gcode::container;
use gweave::gcode::flavour::read_flavour;
use gweave::gcode::state::{State, StateOptions};
use gweave::gcode::temp::TempFile;
use gweave::gcode::writer::{Output, Target};
use gweave::pass::{drive_reader, Ctx, Pass, Quiet, Run, Strictness};
use gweave::post::metadata::{
    earlier_runs, header_line, is_progress_line, read_setting, Figures, MetadataPass,
};
use gweave::stats::StatsPass;
use gweave_sim::estimate::{estimate_time, Estimate, Estimator};
use gweave_sim::limits::MotionProfile;
use gweave_sim::profile::MachineProfile;
use gweave_sim::slicer_limits::{slicer_limits, slicer_limits_silent};

use gweave::gcode::ends::read_ends;

/// Refuses to run `command` (`mix`, `purge-shift`, `rotary wrap`) on a file an earlier run of
/// it wrote: a second run would stack on the first (shift the changes again, purge twice).
pub fn refuse_second_run(input: &Path, command: &str) -> Result<()> {
    // Read through its container: a `.gcode.gz` or `.bgcode` written by gweave holds the header
    // in its text. An input that cannot be opened or read (a damaged block) is the transform's
    // to report, with the file, block and line it names.
    let Ok(file) = container::open(input) else { return Ok(()) };
    let Ok(runs) = earlier_runs(BufReader::new(file)) else { return Ok(()) };
    if let Some(run) = runs.iter().find(|r| r.is(command)) {
        bail!(
            "{}:{}: this file was written by `gweave {}`: a second {command} would stack on the first; run it on the file before (--in-place keeps it as .bak)",
            input.display(),
            run.line,
            run.text
        );
    }
    Ok(())
}

/// Runs `write` into a scratch file, then writes that file to `target` (given `input`, the
/// G-code file the command read, for `--in-place`) with the run's header and its metadata
/// recomputed. Returns what `write` returned and the path written (`None`: standard output).
pub fn with_metadata<R>(
    input: Option<&Path>,
    target: &Target,
    write: impl FnOnce(&Target) -> Result<R>,
) -> Result<(R, Option<PathBuf>)> {
    with_metadata_timed(input, target, write, |_| None)
}

/// [`with_metadata`] for a command that times its own output better than the estimator's
/// machine can (`own_time_s`, s: a rotary axis, whose feed convention the default machine does
/// not read): the times are scaled to it, progress lines keeping their estimated proportions.
pub fn with_metadata_timed<R>(
    input: Option<&Path>,
    target: &Target,
    write: impl FnOnce(&Target) -> Result<R>,
    own_time_s: impl FnOnce(&R) -> Option<f64>,
) -> Result<(R, Option<PathBuf>)> {
    let dir = scratch_dir(target, input);
    let scratch =
        TempFile::new_in(&dir).with_context(|| format!("creating a scratch file in {}", dir.display()))?;
    let path = scratch.path().to_path_buf();
    let result = write(&Target::File(path.clone()))?;
    let mut figures = measure(&path)?;
    if let Some(t_s) = own_time_s(&result) {
        scale_times(&mut figures, t_s);
    }
    let mut out = Output::create(target, input)?;
    let written = out.dest().map(Path::to_path_buf);
    let flavour = read_flavour(&path).with_context(|| format!("reading {}", path.display()))?;
    let options = StateOptions::default().for_flavour(flavour.as_deref());
    let file = File::open(&path).with_context(|| format!("reading {}", path.display()))?;
    let mut pass = MetadataPass::new(figures, header_line(&command_line(input)));
    drive_reader(file, &path, options, Strictness::Lenient, &mut Quiet, &mut pass, &mut out)?;
    out.commit()?;
    drop(scratch);
    Ok((result, written))
}

/// Where the scratch file goes: beside the output (the same file system, as its temporary
/// file), else the system's temporary directory (standard output, a device).
fn scratch_dir(target: &Target, input: Option<&Path>) -> PathBuf {
    let beside = match target {
        Target::File(p) if p.metadata().map_or(true, |m| m.is_file()) => Some(p.as_path()),
        Target::InPlace { .. } => input,
        _ => None,
    };
    match beside.and_then(Path::parent) {
        Some(dir) if dir.as_os_str().is_empty() => PathBuf::from("."),
        Some(dir) => dir.to_path_buf(),
        None => std::env::temp_dir(),
    }
}

/// Flags that say where the G-code comes from and goes, or how the run reports, not what it
/// does to the file; with a value, and alone.
const IO_FLAGS_WITH_VALUE: &[&str] = &["-o", "--output", "--report", "--preview", "--palette-png"];
const IO_FLAGS: &[&str] = &["--in-place", "--no-backup", "--force", "-q", "--quiet", "--json"];

/// The command and the options that shape its output, as typed, without the program, the
/// input and output files and the reporting flags: `mix -c mix.toml --purge-mm 20`. So the
/// same run from a file, a pipe or in place writes the same header.
fn command_line(input: Option<&Path>) -> String {
    transform_args(std::env::args().skip(1), input)
}

fn transform_args(args: impl Iterator<Item = String>, input: Option<&Path>) -> String {
    let quote =
        |a: String| if a.is_empty() || a.contains([' ', '\t', '\'', '"']) { format!("{a:?}") } else { a };
    let mut kept = Vec::new();
    let mut skip_value = false;
    for arg in args {
        let flag = arg.split_once('=').map_or(arg.as_str(), |(f, _)| f);
        if std::mem::take(&mut skip_value)
            || IO_FLAGS.contains(&arg.as_str())
            || input == Some(Path::new(&arg))
        {
            continue;
        }
        if IO_FLAGS_WITH_VALUE.contains(&flag) {
            skip_value = flag == arg;
            continue;
        }
        kept.push(quote(canonical(&kept, arg)));
    }
    kept.join(" ")
}

/// A flag as the command's help names it: an older name or a US spelling (`--purge`,
/// `--color-by`) is written as its canonical name, so the header of a run does not depend on
/// which alias was typed. `kept[0]` is the subcommand (with `rotary`, `kept[1]` too).
fn canonical(kept: &[String], arg: String) -> String {
    let Some(long) = arg.strip_prefix("--") else { return arg };
    let (name, value) = long.split_once('=').map_or((long, None), |(n, v)| (n, Some(v)));
    let mut cmd = crate::command();
    for sub in kept.iter().take(2) {
        match cmd.find_subcommand(sub) {
            Some(found) => cmd = found.clone(),
            None => break,
        }
    }
    let found = cmd
        .get_arguments()
        .find(|a| a.get_long() == Some(name) || a.get_all_aliases().is_some_and(|all| all.contains(&name)));
    match (found.and_then(|a| a.get_long()), value) {
        (Some(long), Some(v)) => format!("--{long}={v}"),
        (Some(long), None) => format!("--{long}"),
        (None, _) => arg,
    }
}

/// Measures the written file: its filament, its settings, its estimated times.
///
/// The time at each progress line needs the estimator fed line by line in the same pass; a
/// file without progress lines is estimated on three threads instead (`estimate_time`, several
/// times faster). Progress lines are looked for in the file's ends (PrusaSlicer's `M73 P0` in
/// its first lines, Cura's last `;TIME_ELAPSED:` in its last) and counted by the pass: a file
/// with them only in its middle is read once more.
fn measure(path: &Path) -> Result<Figures> {
    let ends = read_ends(path).with_context(|| format!("reading {}", path.display()))?;
    let base = MachineProfile::default().motion;
    let normal = slicer_limits(&ends, &base).map_or_else(|_| base.clone(), |l| l.profile);
    let silent = slicer_limits_silent(&ends, &base).map_or_else(|_| normal.clone(), |l| l.profile);
    // A second estimate only for a file that shows silent-mode figures (PrusaSlicer's footer is
    // in its last 256 KiB, `M73 Q0 S..` in its first lines) with limits of their own.
    let contains = |needle: &[u8]| ends.windows(needle.len()).any(|w| w == needle);
    let silent =
        (contains(b"(silent mode)") || contains(b"M73 Q")).then_some(silent).filter(|s| *s != normal);
    let per_line = contains(b"M73 ") || contains(b";TIME_ELAPSED:");
    let (scan, state) = scan(path, per_line.then(|| estimators(&normal, silent.as_ref())).transpose()?)?;
    let (scan, state) = match scan.estimators {
        None if scan.progress_lines > 0 => self::scan(path, Some(estimators(&normal, silent.as_ref())?))?,
        _ => (scan, state),
    };
    let stats = scan.stats.into_stats(&state);
    let (normal, silent) = match scan.estimators {
        Some((normal, silent)) => (normal.finish(), silent.map(Estimator::finish)),
        None => {
            let estimate = |p: &MotionProfile| -> Result<Estimate> {
                let file = File::open(path).with_context(|| format!("reading {}", path.display()))?;
                Ok(estimate_time(file, p)?)
            };
            (estimate(&normal)?, silent.as_ref().map(estimate).transpose()?)
        }
    };
    let silent = silent.as_ref().unwrap_or(&normal);
    let first_layer = |e: &Estimate| e.layer_s.first().copied().unwrap_or(0.0);
    Ok(Figures {
        filament_mm: stats.filament.iter().map(|f| f.extruded_mm).collect(),
        diameter_mm: stats.filament_diameter_mm,
        time_s: [normal.total_s, silent.total_s],
        first_layer_s: [first_layer(&normal), first_layer(silent)],
        ..scan.figures
    })
}

/// One measuring pass over the file, with `estimators` (normal and silent mode) fed line by
/// line if given.
fn scan(path: &Path, estimators: Option<(Estimator, Option<Estimator>)>) -> Result<(Scan, State)> {
    let figures = Figures::default();
    let mut scan = Scan { stats: StatsPass::new(None), estimators, figures, progress_lines: 0, error: None };
    let mut quiet = Quiet;
    let run = Run { strictness: Strictness::Lenient, ..Run::new(path, &mut quiet) };
    let state = run.scan(&mut scan)?;
    if let Some(e) = scan.error.take() {
        return Err(anyhow::Error::new(e).context("estimating the print time of the written file"));
    }
    Ok((scan, state))
}

/// Scales every time in `f` so that the normal mode's total is `t_s`.
fn scale_times(f: &mut Figures, t_s: f64) {
    let k = if f.time_s[0] > 0.0 { t_s / f.time_s[0] } else { 0.0 };
    let times = f.time_s.iter_mut().chain(&mut f.first_layer_s).chain(f.progress_s.iter_mut().flatten());
    times.for_each(|t| *t *= k);
    f.time_s[0] = t_s;
}

fn estimators(
    normal: &MotionProfile,
    silent: Option<&MotionProfile>,
) -> Result<(Estimator, Option<Estimator>)> {
    let estimator = |p: &MotionProfile| Estimator::timing_only(p);
    Ok((estimator(normal)?, silent.map(estimator).transpose()?))
}

/// The measuring pass: `stats`, the settings, the progress lines, and the estimators when the
/// time at each progress line is needed.
struct Scan {
    stats: StatsPass,
    /// Normal mode's, and silent mode's when its limits differ.
    estimators: Option<(Estimator, Option<Estimator>)>,
    figures: Figures,
    progress_lines: u64,
    /// The estimator's first error (the pass goes on to the end, then reports it).
    error: Option<gweave_sim::estimate::EstimateError>,
}

impl Pass for Scan {
    fn reads_words(&self) -> bool {
        false
    }

    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> io::Result<()> {
        self.stats.line(ctx, out)?;
        let raw = ctx.line.bytes;
        if let Some((normal, silent)) = &mut self.estimators {
            for est in std::iter::once(normal).chain(silent.as_mut()) {
                if let Err(e) = est.line(raw) {
                    self.error.get_or_insert(e);
                }
            }
        }
        if let Some(c) = ctx.block.comment_text(raw) {
            read_setting(c, &mut self.figures);
        }
        if is_progress_line(raw) {
            self.progress_lines += 1;
            if let Some((normal, silent)) = &self.estimators {
                let t = normal.now_s();
                self.figures.progress_s.push([t, silent.as_ref().map_or(t, Estimator::now_s)]);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_keeps_the_options_that_shape_the_output() {
        let args = |line: &str, input: Option<&str>| {
            transform_args(line.split(' ').map(str::to_owned), input.map(Path::new))
        };
        assert_eq!(
            args("purge-shift a.gcode --purge 2.5 -o b.gcode -q --report=r.json", Some("a.gcode")),
            "purge-shift --purge-mm 2.5"
        );
        assert_eq!(args("mix -c m.toml --in-place --no-backup a.gcode", Some("a.gcode")), "mix -c m.toml");
        assert_eq!(
            args("rotary tube --output=t.gcode --mandrel-diameter 20 --preview t.png --json", None),
            "rotary tube --mandrel-diameter 20"
        );
        let spaced =
            transform_args(["mix".into(), "--at-layer".into(), "0=Dark Red".into()].into_iter(), None);
        assert_eq!(spaced, r#"mix --at-layer "0=Dark Red""#);
    }

    #[test]
    fn a_header_names_the_canonical_flag_whatever_alias_was_typed() {
        let args = |line: &str| transform_args(line.split(' ').map(str::to_owned), None);
        assert_eq!(args("purge-shift --purge 2.5"), args("purge-shift --purge-mm 2.5"));
        assert_eq!(args("rotary wrap --feed=nist"), "rotary wrap --feed-convention=nist");
        assert_eq!(args("rotary tube --layers 4"), "rotary tube --layer-count 4");
    }
}
