//! What every front end that writes a transform's G-code does around its pass (the CLI's
//! commands and the Python package alike): it refuses to run a transform a second time on its
//! own output, and it writes metadata that is true for the file as written.
//!
//! The transform writes into a scratch file (registered like every temporary file, so Ctrl-C
//! removes it). While it writes, one streaming read of that file, following it as it grows and
//! woken by each of its writes (`gweave::gcode::scratch`), measures it on another core
//! (`measure.rs`): the `stats` count (the filament) and its times. An input that states its
//! times (the slicer's footer, `M73`, Cura's `;TIME:`) keeps them, plus what the transform
//! changed: the measure reads the input beside the output (`diff.rs`) and gathers each change
//! with a few unchanged lines around it in a window (`delta.rs`), which a third thread plans as
//! the input had it and as the output has it (`planner_thread.rs`, `window.rs`). An input that states none has its output estimated in full (one planner thread
//! per mode), with the machine limits the slicer wrote into the file (normal and silent mode),
//! else the default machine's. A copy that looks only at the lines that can change writes it to the real target (a
//! temporary file renamed into place, `--in-place` with its `.bak`, or standard output) with
//! the run's header on top and the slicer's figures and `M73` progress rewritten
//! (`gweave::post::metadata`). Memory stays bounded: the passes stream, the comparison holds a
//! change's lines at most, and what is kept is one time per progress line. The estimator lives
//! here, which the engine cannot depend on, so this crate joins them.

use std::fs::File;
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};

use gweave::gcode::container;
use gweave::gcode::ends::{missing_footer, read_ends, Footer};
use gweave::gcode::scratch::ScratchFile;
use gweave::post::metadata::{earlier_runs, header_line, write_footer, Figures, MetadataPass};
use gweave::{Output, Strictness, Target};

use crate::motion::estimate::EstimateError;

mod delta;
mod diff;
mod measure;
mod planner_thread;
mod tally;
mod window;

use measure::measure_while_written;

/// A result of finishing an output.
pub(crate) type Result<T, E = FinishError> = std::result::Result<T, E>;

/// Why a transform's output could not be finished.
#[derive(Debug, thiserror::Error)]
pub enum FinishError {
    /// Reading the scratch file or writing the target failed.
    #[error(transparent)]
    Engine(#[from] gweave::Error),

    /// The written file could not be estimated for its metadata.
    #[error("estimating the print time of the written file: {0}")]
    Estimate(#[from] EstimateError),

    /// The input was written by an earlier run of the same transform (`run`: what ran, from the
    /// header at `line`).
    #[error(
        "{}:{line}: this file was written by `gweave {run}`: a second {command} would stack on the first; run it on the file before (--in-place keeps it as .bak)",
        path.display()
    )]
    #[allow(missing_docs)] // the input, the header's line, what ran and this command's name
    SecondRun { path: PathBuf, line: u64, run: String, command: String },

    /// The input looks cut short ([`missing_footer`]): its last line, `line`, ends at `column`
    /// without a line ending, and the slicer's last line is missing.
    #[error(
        "{}:{line}:{column}: {}; the transform would write its footer after a cut print, which would then look whole: slice or copy the file again (a lenient run writes it anyway)",
        path.display(),
        gweave::gcode::diag::Finding::NoFooter { footer: *footer }
    )]
    #[allow(missing_docs)] // the input, where its text stops, and the slicer it lacks the last line of
    Cut { path: PathBuf, line: u64, column: u64, footer: Footer },
}

/// Refuses, in a strict run, an input that looks cut short: no line ending at its end, and not
/// the line its slicer ends every file with ([`missing_footer`]). A transform appends its
/// footer (the slicer's figures rewritten for the file, its times): after a cut print, the
/// output would look whole to a host and print a part of the object. A lenient run, asked to
/// copy what is malformed through, writes it. The whole file is read only when the ends
/// already say it is cut, to name the line and column where its text stops.
pub(crate) fn refuse_cut_input(input: &Path, strictness: Strictness) -> Result<()> {
    if strictness == Strictness::Lenient {
        return Ok(());
    }
    // An input that cannot be read is the transform's to report, naming what failed.
    let Some(footer) = read_ends(input).ok().and_then(|ends| missing_footer(&ends)) else { return Ok(()) };
    let failed = |e| FinishError::from(gweave::Error::io(input, e));
    let mut text = container::open(input).map_err(failed)?;
    let (mut newlines, mut last_line_bytes, mut buf) = (0u64, 0u64, vec![0u8; 64 * 1024]);
    loop {
        let n = match text.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(failed(e)),
        };
        let chunk = &buf[..n];
        newlines += memchr::memchr_iter(b'\n', chunk).count() as u64;
        last_line_bytes = match memchr::memrchr(b'\n', chunk) {
            Some(i) => (n - i - 1) as u64,
            None => last_line_bytes + n as u64,
        };
    }
    Err(FinishError::Cut {
        path: input.to_path_buf(),
        line: newlines + 1,
        column: last_line_bytes + 1,
        footer,
    })
}

/// Refuses to run `command` (`mix`, `purge-shift`, `rotary wrap`) on a file an earlier run of
/// it wrote: a second run would stack on the first (shift the changes again, purge twice).
pub(crate) fn refuse_second_run(input: &Path, command: &str) -> Result<()> {
    // Read through its container: a `.gcode.gz` or `.bgcode` written by gweave holds the header
    // in its text. An input that cannot be opened or read (a damaged block) is the transform's
    // to report, with the file, block and line it names.
    let Ok(file) = container::open(input) else { return Ok(()) };
    let Ok(runs) = earlier_runs(BufReader::new(file)) else { return Ok(()) };
    match runs.into_iter().find(|r| r.is(command)) {
        Some(run) => Err(FinishError::SecondRun {
            path: input.to_path_buf(),
            line: run.line,
            run: run.text,
            command: command.to_owned(),
        }),
        None => Ok(()),
    }
}

/// Runs `write` into a scratch file, then writes that file to `target` (given `input`, the
/// G-code file the transform read, for `--in-place`) with the header of the run of
/// `command_line` (the command and the options that shape its output, in the CLI's words:
/// `mix --purge-mm 20`) and its metadata recomputed. Returns what `write` returned and the path
/// written (`None`: standard output).
pub fn with_metadata<R, E: From<FinishError>>(
    input: Option<&Path>,
    target: &Target,
    command_line: &str,
    write: impl FnOnce(&Target) -> Result<R, E>,
) -> Result<(R, Option<PathBuf>), E> {
    with_metadata_timed(input, target, command_line, write, |_| None)
}

/// [`with_metadata`] for a transform that times its own output better than the estimator's
/// machine can (`own_time_s`, s: a rotary axis, whose feed convention the default machine does
/// not read): the times are scaled to it, progress lines keeping their estimated proportions.
pub(crate) fn with_metadata_timed<R, E: From<FinishError>>(
    input: Option<&Path>,
    target: &Target,
    command_line: &str,
    write: impl FnOnce(&Target) -> Result<R, E>,
    own_time_s: impl FnOnce(&R) -> Option<f64>,
) -> Result<(R, Option<PathBuf>), E> {
    let output = beside(target, input);
    let dir = scratch_dir(output);
    // Beside the output, on its file system: a disk that fills up while the transform writes
    // is the output's, and errors name the output, which the user named.
    let scratch =
        ScratchFile::new_in(&dir, output).map_err(|e| FinishError::from(gweave::Error::io(&dir, e)))?;
    let (result, mut figures) = measure_while_written(&scratch, input, write)?;
    if let Some(t_s) = own_time_s(&result) {
        scale_times(&mut figures, t_s);
    }
    let written = finish(scratch.path(), figures, input, target, command_line)?;
    drop(scratch);
    Ok((result, written))
}

/// For a generator that knows its output's figures as it writes it (a raster job: constant
/// feeds, straight lines, no extrusion): `write` writes straight to `target` (a temporary file
/// renamed into place, as every output), after the run's header, and the footer
/// ([`write_footer`]) follows with `figures` of what it returned. No scratch file, nothing read
/// back: the caller has made sure the output holds no line the metadata is measured from (no
/// progress line, no slicer figure, no extrusion), which [`with_metadata`] would rewrite.
/// Returns what `write` returned and the path written (`None`: standard output).
pub(crate) fn with_own_figures<R, E: From<FinishError>>(
    target: &Target,
    command_line: &str,
    write: impl FnOnce(&mut dyn Write) -> Result<R, E>,
    figures: impl FnOnce(&R) -> Figures,
) -> Result<(R, Option<PathBuf>), E> {
    let mut out = Output::create(target, None).map_err(FinishError::from)?;
    let written = out.dest().map(Path::to_path_buf);
    let shown = out.shown();
    let failed = |e| FinishError::from(gweave::Error::io(&shown, e));
    writeln!(out, "{}", header_line(command_line)).map_err(failed)?;
    let result = write(&mut out)?;
    write_footer(&figures(&result), b"\n", &mut out).map_err(failed)?;
    out.commit().map_err(FinishError::from)?;
    Ok((result, written))
}

/// Writes the scratch file `path` to `target` with the header and the metadata (`figures`).
fn finish(
    path: &Path,
    figures: Figures,
    input: Option<&Path>,
    target: &Target,
    command_line: &str,
) -> Result<Option<PathBuf>> {
    let mut out = Output::create(target, input)?;
    let written = out.dest().map(Path::to_path_buf);
    let file = File::open(path).map_err(|e| gweave::Error::io(path, e))?;
    let pass = MetadataPass::new(figures, header_line(command_line));
    // Write errors name the output the user named, not the scratch file read here.
    let shown = out.shown();
    pass.copy(file, path, &shown, &mut out)?;
    out.commit()?;
    Ok(written)
}

/// The output file the scratch file goes beside (the same file system, as its temporary file):
/// none for standard output or a device.
fn beside<'a>(target: &'a Target, input: Option<&'a Path>) -> Option<&'a Path> {
    match target {
        Target::File(p) if p.metadata().map_or(true, |m| m.is_file()) => Some(p.as_path()),
        Target::InPlace { .. } => input,
        _ => None,
    }
}

/// Where the scratch file goes: beside the output, else the system's temporary directory.
fn scratch_dir(beside: Option<&Path>) -> PathBuf {
    match beside.and_then(Path::parent) {
        Some(dir) if dir.as_os_str().is_empty() => PathBuf::from("."),
        Some(dir) => dir.to_path_buf(),
        None => std::env::temp_dir(),
    }
}

/// Scales every time in `f` so that the normal mode's total is `t_s`.
fn scale_times(f: &mut Figures, t_s: f64) {
    let k = if f.time_s[0] > 0.0 { t_s / f.time_s[0] } else { 0.0 };
    let times = f.time_s.iter_mut().chain(&mut f.first_layer_s).chain(f.progress_s.iter_mut().flatten());
    times.for_each(|t| *t *= k);
    f.time_s[0] = t_s;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_run_of_the_same_transform_is_refused_naming_the_first() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gcode");
        std::fs::write(&input, "; gweave 0.1.0 mix --purge-mm 20 (generated)\nG1 X1\n").unwrap();
        let e = refuse_second_run(&input, "purge-shift").and_then(|()| refuse_second_run(&input, "mix"));
        let Err(FinishError::SecondRun { line, run, command, .. }) = e else { panic!("{e:?}") };
        assert_eq!((line, run.as_str(), command.as_str()), (1, "0.1.0 mix --purge-mm 20", "mix"));
    }

    #[test]
    fn a_run_writes_its_header_and_true_filament() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.gcode");
        let write =
            |t: &Target| write_text(t, "G92 E0\nG1 X10 E5 F600\n; filament used [mm] = 1.00\n", false);
        let ((), written) =
            with_metadata(None, &Target::File(out.clone()), "rotary tube --length 10", write).unwrap();
        assert_eq!(written.as_deref(), Some(out.as_path()));
        let text = std::fs::read_to_string(&out).unwrap();
        let header = header_line("rotary tube --length 10");
        assert!(text.starts_with(&format!("{header}\n")), "{text}");
        assert!(text.contains("; filament used [mm] = 5.00\n"), "{text}");
    }

    /// Regression (issue 35): the transform's output is written straight into the scratch file
    /// and measured as it grows; the finished file is the one measured after the write (no
    /// input to stand for it), and a transform that fails leaves no file behind, scratch
    /// included.
    #[test]
    fn a_transform_measured_while_it_writes_finishes_the_same_file_and_fails_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let text = "; generated\nG92 E0\nM73 P0 R0\nG1 X10 E5 F600\nG1 X20 E9\nM73 P50 R1\n\
                    G1 X0 Y20 F3000\n; filament used [mm] = 1.00\n";
        let input = dir.path().join("in.gcode");
        std::fs::write(&input, text).unwrap();
        let transform = |fail: bool| move |t: &Target| write_text(t, text, fail);
        let (overlapped, after) = (dir.path().join("overlapped.gcode"), dir.path().join("after.gcode"));
        with_metadata(Some(&input), &Target::File(overlapped.clone()), "mix", transform(false)).unwrap();
        with_metadata(None, &Target::File(after.clone()), "mix", transform(false)).unwrap();
        let written = std::fs::read_to_string(&overlapped).unwrap();
        assert_eq!(written, std::fs::read_to_string(&after).unwrap());
        assert!(written.contains("\n; filament used [mm] = 9.00\n"), "{written}");
        let failed = Target::File(dir.path().join("failed.gcode"));
        let e = with_metadata(Some(&input), &failed, "mix", transform(true));
        assert!(e.is_err_and(|e| e.to_string().contains("stopped")));
        let mut left: Vec<_> =
            std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        left.sort();
        assert_eq!(left, ["after.gcode", "in.gcode", "overlapped.gcode"]);
    }

    /// Regression: a raster's 2.8 GB output was written to a scratch file and read back by the
    /// estimator (129x Python zlib's time) though the generator knows its time; written
    /// directly, the file is the same to the byte.
    #[test]
    fn a_raster_written_directly_is_the_measured_file_to_the_byte() {
        use gweave::gen::raster_job::{JobReport, Setup};
        use gweave::Quiet;
        use gweave::RasterOptions;
        let dir = tempfile::tempdir().unwrap();
        let layers = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/raster/layers");
        let job = Setup::new(vec![layers], RasterOptions::default()).job().unwrap();
        assert!(job.knows_its_figures());
        // The planner times it as it streams out (the default: no `--fast-estimate`).
        let timer = crate::Estimator::line_timer;
        let (measured, direct) = (dir.path().join("measured.gcode"), dir.path().join("direct.gcode"));
        let run = |t: &Target| job.run(t, &mut Quiet, timer).map_err(Failed::Job);
        let time = |r: &JobReport| Some(r.time.total_s);
        let (a, _) =
            with_metadata_timed(None, &Target::File(measured.clone()), "raster l", run, time).unwrap();
        let run = |out: &mut dyn Write| job.run_into(out, &mut Quiet, timer).map_err(Failed::Job);
        let figures = |r: &JobReport| Figures { time_s: [r.time.total_s; 2], ..Figures::default() };
        let (b, written) = with_own_figures(&Target::File(direct.clone()), "raster l", run, figures).unwrap();
        assert_eq!(written.as_deref(), Some(direct.as_path()));
        assert_eq!(a.time, b.time);
        let (a, b) = (std::fs::read_to_string(measured).unwrap(), std::fs::read_to_string(direct).unwrap());
        assert!(b.contains("\n; filament used [mm] = 0.00\n"), "{b}");
        assert_eq!(a, b);
    }

    /// A raster job's error or the finishing's.
    #[derive(Debug)]
    enum Failed {
        Job(#[allow(dead_code)] gweave::gen::raster_job::JobError),
        Finish(#[allow(dead_code)] FinishError),
    }

    impl From<FinishError> for Failed {
        fn from(e: FinishError) -> Self {
            Failed::Finish(e)
        }
    }

    /// A transform that writes `text` to its target, then fails (`fail`) or commits.
    fn write_text(t: &Target, text: &str, fail: bool) -> Result<()> {
        let mut out = Output::create(t, None)?;
        let name = out.shown();
        out.write_all(text.as_bytes()).map_err(|e| gweave::Error::io(&name, e))?;
        match fail {
            true => Err(gweave::Error::io(&name, std::io::Error::other("stopped")).into()),
            false => Ok(out.commit()?),
        }
    }
}
