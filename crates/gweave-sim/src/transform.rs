//! A transform job run on a file, as `gweave purge-shift` and `gweave.purge_shift()` (and `mix`,
//! `rotary wrap`, `rotary tube`) both run it: the options read over the settings file they name,
//! the pass run, the output finished with the run's header and its metadata
//! ([`crate::with_metadata`]). Written once, so the front ends only read their options
//! ([`gweave::options`]) and show the result. The registry [`transforms`] lists the jobs
//! ([`Transform`]) the front ends derive their commands from: a row gives a job its CLI
//! subcommand and its Python function, with no code in either.

use std::io::Write;
use std::path::{Path, PathBuf};

use gweave::gcode::writer::Target;
use gweave::options::{JobFailure, JobOptions, OptionError, OptionSpec, Said, Spelling};
use gweave::post::mix::card::CardReport;
use gweave::post::mix::profile::MixProfile;
use gweave::post::mix::report::MixReport;
use gweave::post::mix::{MixOptions, MixPassError};
use gweave::post::purge_shift::{ConfigError, PurgeShiftConfig, PurgeShiftOptions, PurgeShiftReport};
use gweave::rotary::helix::TubeParams;
use gweave::rotary::options::MachineOptions;
use gweave::rotary::report::{TubeReport, WrapReport};
use gweave::rotary::wrap::WrapConfig;
use gweave::rotary::RotaryError;
use gweave::Malformed;
use gweave::Output;
use gweave::{tube_file, wrap_file};
use gweave::{Progress, Strictness};
use gweave::{Ran, Run};
use gweave::{TubeOptions, WrapOptions};

use crate::finish::{self, FinishError};

/// The file a job reads and where it writes.
pub struct Job<'a> {
    /// The G-code file read.
    pub input: &'a Path,
    /// Where the output goes.
    pub target: &'a Target,
    /// Stop at a malformed line, or copy it through and count it.
    pub strictness: Strictness,
    /// Told how far the read has come (a progress bar), if anything is.
    pub progress: Option<&'a mut dyn Progress>,
}

impl<'a> Job<'a> {
    /// `input` to `target`, strict, with no progress shown.
    pub fn new(input: &'a Path, target: &'a Target) -> Self {
        Job { input, target, strictness: Strictness::Strict, progress: None }
    }

    fn run(self, to: &Target) -> Run<'a> {
        let run = Run::file(self.input).to(to).strictness(self.strictness);
        match self.progress {
            Some(p) => run.progress(p),
            None => run,
        }
    }
}

/// A transform job as both front ends run it: `gweave <command> INPUT -o OUT [options]` and
/// `gweave.<command>(path, output, **options)`. Its row in [`transforms`] is all a front end
/// needs: the CLI derives the subcommand (its help [`Transform::HELP`], a flag per option, the
/// shared `-o`, `--lenient`, `--json` groups, the summary and warnings printed after the run)
/// and Python's `_gweave.transform_json(command, ...)` runs it by its command.
pub trait Transform: 'static {
    /// Its options, declared once (`gweave::job_options!`); their `COMMAND` names the job.
    type Options: JobOptions + Clone + std::fmt::Debug + Send + Sync + 'static;
    /// What it reports: the JSON document of `--json`, `--report` and Python.
    type Report: serde::Serialize + Send;
    /// The command's help as the CLI shows it, written as a doc comment is: its first
    /// paragraph for `-h` and the list of commands, the whole for `--help`.
    const HELP: &'static str;
    /// The command line has a subcommand of its own for the job (`mix`: `--wizard`,
    /// `--predict`, `--calibration-card`), which runs it as a derived one does; Python and the
    /// option lists still take the job from its row.
    const OWN_COMMAND: bool = false;
    /// Runs the job (the one function both front ends call).
    fn run(options: &Self::Options, job: Job<'_>) -> Outcome<Self::Report>;
    /// What a person reads after the run (the CLI's summary, on standard error when the G-code
    /// goes to standard output).
    fn summary(report: &Self::Report) -> String;
    /// The warnings the CLI prints after the run, one line each (after `gweave: `), even with
    /// `-q`.
    fn warnings(_report: &Self::Report) -> Vec<String> {
        Vec::new()
    }
}

/// What a front end does with each row of [`transforms`] (add its subcommand, find the one
/// called, run the one named).
pub trait EachTransform {
    /// Called once per transform job, in the registry's order.
    fn transform<T: Transform>(&mut self);
}

/// The registry of transform jobs, one row each, in the order the CLI lists them. A new
/// transform is its pass, its job ([`Transform`]) and one row here (docs/architecture.md,
/// "Adding a pass").
pub fn transforms(each: &mut impl EachTransform) {
    each.transform::<PurgeShift>();
    each.transform::<Mix>();
}

/// Every job's command and options, the one list of them, for a front end that lists them
/// (Python's `_gweave.jobs` and `_gweave.job_options`, which its tests hold the typed wrappers
/// to; the CLI's tests hold its subcommands to it): the registry's rows, then `rotary wrap` and
/// `rotary tube` (each its own command in both front ends: `wrap` draws a preview, `tube` reads
/// no file), the reading jobs ([`crate::reading::JOBS`]) and `raster`
/// ([`crate::raster_job::JOBS`]).
pub fn jobs() -> Vec<(&'static str, &'static [OptionSpec])> {
    struct List(Vec<(&'static str, &'static [OptionSpec])>);
    impl EachTransform for List {
        fn transform<T: Transform>(&mut self) {
            self.0.push((T::Options::COMMAND, T::Options::SPEC));
        }
    }
    let mut list = List(Vec::new());
    transforms(&mut list);
    list.0.extend([(WrapOptions::COMMAND, WrapOptions::SPEC), (TubeOptions::COMMAND, TubeOptions::SPEC)]);
    list.0.extend(crate::reading::JOBS.iter().chain(crate::raster_job::JOBS).copied());
    list.0
}

/// What a transform job returns: its report and the malformed lines a lenient run read past.
pub type Outcome<R> = Result<(R, Malformed), TransformError>;

/// Why a transform job failed.
#[derive(Debug, thiserror::Error)]
pub enum TransformError {
    /// An option's value refused; the front end names the option its own way
    /// ([`TransformError::spelled`]).
    #[error(transparent)]
    Option(#[from] OptionError),
    /// The settings file the options name cannot be read as settings.
    #[error("{}: {message}", path.display())]
    Settings {
        /// The file.
        path: PathBuf,
        /// What is wrong with it, its causes joined.
        message: String,
    },
    /// purge-shift's settings are inconsistent.
    #[error(transparent)]
    PurgeShift(#[from] ConfigError),
    /// The mix profile or the mix pass refused.
    #[error(transparent)]
    Mix(#[from] MixPassError),
    /// The rotary settings are inconsistent, or wrapping or writing the tube failed.
    #[error(transparent)]
    Rotary(#[from] RotaryError),
    /// Reading, writing, or finishing the output failed.
    #[error(transparent)]
    Finish(#[from] FinishError),
}

impl From<gweave::Error> for TransformError {
    fn from(e: gweave::Error) -> Self {
        TransformError::Finish(FinishError::Engine(e))
    }
}

impl JobFailure for TransformError {
    /// The message, an option named as `spelling` names it (`--purge-mm`, `purge_mm`).
    fn spelled(&self, spelling: Spelling) -> String {
        match self {
            TransformError::Option(e) => e.spelled(spelling),
            TransformError::PurgeShift(e) => e.said().map_or_else(|| e.to_string(), |s| s.spelled(spelling)),
            TransformError::Mix(MixPassError::Needs(said)) => said.spelled(spelling),
            // A refusal in the middle of the file: the driver's place, then the sentence.
            e => match e.engine().and_then(|inner| Some((inner, pass_needs(inner)?))) {
                Some((inner, said)) => {
                    let whole = inner.to_string();
                    let place = whole.strip_suffix(&said.to_string()).unwrap_or("");
                    format!("{place}{}", said.spelled(spelling))
                }
                None => e.to_string(),
            },
        }
    }

    fn refused_file(&self) -> Option<(&Path, &std::io::Error)> {
        self.engine().and_then(JobFailure::refused_file)
    }
}

impl TransformError {
    /// The engine's own error inside, if that is what failed (a file unreadable, a malformed
    /// line): a front end raises it as it raises the engine's errors.
    pub fn engine(&self) -> Option<&gweave::Error> {
        match self {
            TransformError::Finish(FinishError::Engine(e))
            | TransformError::Mix(MixPassError::Engine(e))
            | TransformError::Rotary(RotaryError::Engine(e)) => Some(e),
            _ => None,
        }
    }
}

/// The sentence naming options of a mix refusal in the middle of the file, if it is one.
fn pass_needs(e: &gweave::Error) -> Option<&Said> {
    match e {
        gweave::Error::Pass { source, .. } => match source.downcast_ref::<MixPassError>() {
            Some(MixPassError::Needs(said)) => Some(said),
            _ => None,
        },
        _ => None,
    }
}

/// The run's header, in the CLI's words: `purge-shift --purge-mm 2.5 --lenient`.
///
/// ```
/// use gweave::Strictness;
/// use gweave::post::mix::MixOptions;
/// use gweave_sim::transform::command_line;
/// let options = MixOptions { at_layer: vec!["0=Dark  Red".into()], ..MixOptions::default() };
/// assert_eq!(command_line(&options, Strictness::Lenient), r#"mix --at-layer "0=Dark  Red" --lenient"#);
/// assert_eq!(command_line(&MixOptions::default(), Strictness::Lenient), "mix --lenient");
/// assert_eq!(command_line(&MixOptions::default(), Strictness::Strict), "mix");
/// ```
pub fn command_line<O: JobOptions>(options: &O, strictness: Strictness) -> String {
    header_of(O::COMMAND, options, strictness)
}

/// The header of `command` (`mix --calibration-card`) run with `options`.
fn header_of<O: JobOptions>(command: &str, options: &O, strictness: Strictness) -> String {
    let lenient = if strictness == Strictness::Lenient { "--lenient" } else { "" };
    let header = options.header();
    [command, header.as_str(), lenient].into_iter().filter(|w| !w.is_empty()).collect::<Vec<_>>().join(" ")
}

/// Runs a transform's pass on the job's file (`pass`: the engine's function that runs it on
/// a [`Run`]), refusing a file an earlier run of the same command wrote, and finishes the
/// output with the run's header ([`command_line`] of `options`) and the slicer's figures
/// rewritten for the file as written ([`finish::with_metadata`]).
pub fn finished<O: JobOptions, R, E>(
    options: &O,
    job: Job<'_>,
    pass: impl FnOnce(Run<'_>) -> Result<(R, Ran), E>,
) -> Outcome<R>
where
    TransformError: From<E>,
{
    let pass = |run: Run<'_>| pass(run).map(|(report, ran)| (report, ran.malformed));
    let (done, _) = finished_timed(options, job, pass, |_| None)?;
    Ok(done)
}

/// [`finished`] for a pass that times its output better than the estimator's machine can
/// (`own_time_s`, s: a rotary axis, whose feed convention the default machine does not read;
/// [`finish::with_metadata_timed`]), also returning the path written (`None`: standard
/// output).
fn finished_timed<O: JobOptions, R, E>(
    options: &O,
    job: Job<'_>,
    pass: impl FnOnce(Run<'_>) -> Result<(R, Malformed), E>,
    own_time_s: impl FnOnce(&R) -> Option<f64>,
) -> Result<((R, Malformed), Option<PathBuf>), TransformError>
where
    TransformError: From<E>,
{
    finish::refuse_second_run(job.input, O::COMMAND)?;
    finish::refuse_cut_input(job.input, job.strictness)?;
    let line = command_line(options, job.strictness);
    let (input, target) = (job.input, job.target);
    let write = |t: &Target| Ok::<_, TransformError>(pass(job.run(t))?);
    let own_time_s = |done: &(R, Malformed)| own_time_s(&done.0);
    finish::with_metadata_timed(Some(input), target, &line, write, own_time_s)
}

/// A settings file named by an option, read with `parse`; the default without one.
fn settings<T: Default, E: std::error::Error + 'static>(
    path: Option<&Path>,
    parse: impl FnOnce(&str) -> Result<T, E>,
) -> Result<T, TransformError> {
    let Some(path) = path else { return Ok(T::default()) };
    let text = gweave::settings::read_text(path).map_err(|e| gweave::Error::io(path, e))?;
    parse(&text)
        .map_err(|e| TransformError::Settings { path: path.to_path_buf(), message: gweave::with_causes(&e) })
}

/// `purge-shift`'s row in [`transforms`].
pub struct PurgeShift;

impl Transform for PurgeShift {
    type Options = PurgeShiftOptions;
    type Report = PurgeShiftReport;
    const HELP: &'static str = "
        Move each tool/mix change earlier by the purge, so the old colour is purged inside the part.

        For every `T<n>` (and `M163`/`M164`, `M165`, `M567` mix change) the old colour's extruding
        moves are walked back until the purge amount of filament is found; that move is split at the
        exact point and the change goes there. Works with absolute and relative E, `G92 E` resets,
        retractions and firmware retraction; never crosses a layer change (unless --cross-layers),
        the outer wall (unless allowed) or the previous change. With too little room the rest of
        the purge is accepted as missing, or purged in a block or on a small tower (--fallback).

        As a PrusaSlicer post-processing script: `/path/to/gweave purge-shift --purge-mm 2.5 --in-place
        --no-backup` (PrusaSlicer appends the file name). Chains after `gweave mix`.
        Example: `gweave purge-shift part.gcode -o part.shifted.gcode --purge-mm 2.5`.";

    fn run(options: &PurgeShiftOptions, job: Job<'_>) -> Outcome<PurgeShiftReport> {
        purge_shift(options, job)
    }

    fn summary(report: &PurgeShiftReport) -> String {
        report.summary()
    }

    /// One line per kind of warning (docs/pipeline.md), and how many more were only counted.
    fn warnings(report: &PurgeShiftReport) -> Vec<String> {
        let mut lines: Vec<String> = gweave::post::warning::grouped(&report.warnings)
            .iter()
            .map(|w| format!("warning: {w}"))
            .collect();
        let kept = report.warnings.len() as u64;
        if report.warnings_total > kept {
            lines.push(format!("... {} more warnings, counted only", report.warnings_total - kept));
        }
        lines
    }
}

/// Moves every colour change earlier by the purge (docs/purge-shift.md): returns the report
/// (its changes' output lines counting the header) and the malformed lines read past.
pub fn purge_shift(options: &PurgeShiftOptions, job: Job<'_>) -> Outcome<PurgeShiftReport> {
    options.check_conflicts()?;
    let mut config = settings(options.config.as_deref(), PurgeShiftConfig::parse_toml)?;
    config.apply(options);
    let rules = config.validate()?;
    let (mut report, malformed) =
        finished(options, job, |run| gweave::post::purge_shift::purge_shift(rules, run))?;
    // The run's header is one line above every change.
    report.changes.offset_output_lines(1);
    Ok((report, malformed))
}

/// `mix`'s row in [`transforms`]; the CLI's `gweave mix` is its own command (the wizard, the
/// predicted colours, the calibration card) around the same run.
pub struct Mix;

impl Transform for Mix {
    type Options = MixOptions;
    type Report = MixReport;
    const HELP: &'static str =
        "Colour a print on a mixing hotend: define mixes as virtual tools, change them by layer, by
        height, along a gradient or per slicer tool, purge at each change, cap the Z feed rate.";
    const OWN_COMMAND: bool = true;

    fn run(options: &MixOptions, job: Job<'_>) -> Outcome<MixReport> {
        mix(options, job)
    }

    fn summary(report: &MixReport) -> String {
        report.summary()
    }

    fn warnings(report: &MixReport) -> Vec<String> {
        report.warnings.iter().map(|w| format!("warning: {w}")).collect()
    }
}

/// The mix profile the options name, with the options applied over it.
pub fn mix_profile(options: &MixOptions) -> Result<MixProfile, TransformError> {
    options.check_conflicts()?;
    let mut profile = settings(options.config.as_deref(), MixProfile::from_toml_str)?;
    profile.apply(options)?;
    Ok(profile)
}

/// Rewrites a file for a mixing hotend (docs/mix.md) with the profile and options given.
pub fn mix(options: &MixOptions, job: Job<'_>) -> Outcome<MixReport> {
    mix_with(mix_profile(options)?, options, job)
}

/// [`mix`] with a profile made otherwise (`gweave mix --wizard`'s); `options` name the run.
pub fn mix_with(profile: MixProfile, options: &MixOptions, job: Job<'_>) -> Outcome<MixReport> {
    finished(options, job, |run| gweave::post::mix::mix(profile, run))
}

/// Writes a calibration card (docs/mix.md: a swatch per mix of `card_mixes`, purged between)
/// for the hotend and filaments of `profile` (made of `options`, [`mix_profile`]) to `target`,
/// finished as every job's output: the header written from the options (`mix
/// --calibration-card -c mix.toml`, whatever order or alias was typed) and the metadata.
///
/// ```
/// use gweave::post::mix::MixOptions;
/// use gweave::Target;
/// use gweave_sim::transform::{calibration_card, mix_profile};
/// let dir = tempfile::tempdir().unwrap();
/// let out = dir.path().join("card.gcode");
/// let options = MixOptions { purge_mm: Some(20.0), ..MixOptions::default() };
/// let card = calibration_card(&mix_profile(&options).unwrap(), &options, &Target::File(out.clone())).unwrap();
/// assert_eq!(card.swatches.len(), 30);
/// let text = std::fs::read_to_string(&out).unwrap();
/// let version = env!("CARGO_PKG_VERSION");
/// assert!(text.starts_with(&format!("; gweave {version} mix --calibration-card --purge-mm 20 (generated)\n")), "{text:.80}");
/// ```
pub fn calibration_card(
    profile: &MixProfile,
    options: &MixOptions,
    target: &Target,
) -> Result<CardReport, TransformError> {
    let (gcode, card) = gweave::post::mix::card::calibration_card(profile)?;
    let line = header_of(CALIBRATION_CARD, options, Strictness::Strict);
    finish::with_metadata(None, target, &line, |t| {
        let mut out = Output::create(t, None)?;
        out.write_all(&gcode).map_err(|e| gweave::Error::io(out.shown(), e))?;
        Ok::<_, TransformError>(out.commit()?)
    })?;
    Ok(card)
}

/// The command a calibration card's header names.
const CALIBRATION_CARD: &str = "mix --calibration-card";

/// The rotary settings `read` makes of the settings file the machine options name (its errors
/// name the file) or, without one, of the options alone (`WrapConfig::read`, `TubeParams::read`).
fn rotary_settings<T>(
    machine: &MachineOptions,
    read: impl Fn(Option<&str>, &MachineOptions) -> Result<T, RotaryError>,
) -> Result<T, TransformError> {
    let from_file = settings(machine.config.as_deref(), |text| read(Some(text), machine).map(Some))?;
    match from_file {
        Some(settings) => Ok(settings),
        None => Ok(read(None, machine)?),
    }
}

/// Wraps a part sliced flat onto the mandrel (docs/rotary.md), drawing the path as the machine
/// runs it to the PNG `preview` if given: returns the report and the malformed lines read past.
pub fn rotary_wrap(options: &WrapOptions, job: Job<'_>, preview: Option<&Path>) -> Outcome<WrapReport> {
    options.check_conflicts()?;
    let mut config = rotary_settings(&options.machine, WrapConfig::read)?;
    config.apply(options)?;
    let wrap = |run: Run<'_>| wrap_file(&config, run, preview);
    // Its own time: the estimator's default machine does not read the rotary feed.
    let ((mut report, malformed), written) =
        finished_timed(options, job, wrap, |r: &WrapReport| Some(r.time_s))?;
    report.output = written;
    Ok((report, malformed))
}

/// Writes a seam-free tube of continuous helical layers (docs/rotary.md) to `target`, drawing
/// it to the PNG `preview` if given.
pub fn rotary_tube(
    options: &TubeOptions,
    target: &Target,
    preview: Option<&Path>,
) -> Result<TubeReport, TransformError> {
    options.check_conflicts()?;
    let mut params = rotary_settings(&options.machine, TubeParams::read)?;
    params.apply(options)?;
    let line = command_line(options, Strictness::Strict);
    let tube = |t: &Target| Ok::<_, TransformError>(tube_file(&params, t, preview)?);
    let own_time_s = |r: &TubeReport| Some(r.print_time_s);
    let (mut report, written) = finish::with_metadata_timed(None, target, &line, tube, own_time_s)?;
    report.output = written;
    Ok(report)
}
