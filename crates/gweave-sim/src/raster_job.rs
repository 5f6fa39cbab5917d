//! A raster job, as `gweave raster` and `gweave.raster()` both run it: the options
//! ([`RasterOptions`], declared once) read, the machine they name loaded, the layer images
//! resolved, then the G-code written and finished with the run's header, written from the
//! options, and its metadata ([`crate::with_metadata`]). The engine's generator
//! ([`gweave::gen::raster_job`]) cannot load a machine profile nor time the print on the
//! virtual printer's planner; this joins them, so the front ends only read their options and
//! show the result.
//!
//! A raster's own figures are the metadata when its output holds nothing the metadata is
//! measured from ([`Job::knows_its_figures`]): then it is written straight to the target with
//! no scratch file read back (a 2.8 GB raster costs its writing alone); otherwise (a user's
//! start G-code that extrudes) it is measured as every transform's output is.

use std::io::Write;
use std::path::{Path, PathBuf};

use gweave::gen::printhead::PrintheadProfile;
use gweave::gen::raster::RasterReport;
use gweave::gen::raster_job::{BoxError, Job, JobError, JobReport, LineTimer, Setup, Source};
use gweave::options::Spelling;
use gweave::post::metadata::Figures;
use gweave::RasterOptions;
use gweave::{JobFailure, JobOptions, OptionError, OptionSpec, Progress, Strictness, Target};
use serde::Serialize;

use crate::builtin::{load_machine, LoadError};
use crate::finish::{self, FinishError};
use crate::transform::command_line;
use crate::{Estimator, MachineProfile, MachineProfileError};

/// The raster job's command and options, part of [`crate::transform::jobs`].
pub const JOBS: &[(&str, &[OptionSpec])] = &[(RasterOptions::COMMAND, RasterOptions::SPEC)];

/// Why a raster job failed.
#[derive(Debug, thiserror::Error)]
pub enum RasterJobError {
    /// An option's value refused; the front end names the option its own way
    /// ([`RasterJobError::spelled`]).
    #[error(transparent)]
    Option(#[from] OptionError),
    /// The machine profile `machine` names cannot be loaded.
    #[error(transparent)]
    Machine(#[from] LoadError),
    /// The machine has no inkjet printhead.
    #[error(transparent)]
    Printhead(#[from] MachineProfileError),
    /// The inputs, the printhead or the generator refused, or a file could not be read.
    #[error(transparent)]
    Job(#[from] JobError),
    /// Writing or finishing the output failed.
    #[error(transparent)]
    Finish(#[from] FinishError),
}

impl JobFailure for RasterJobError {
    /// The message, an option named as `spelling` names it (`--machine`, `machine`).
    fn spelled(&self, spelling: Spelling) -> String {
        match self {
            RasterJobError::Option(e) => e.spelled(spelling),
            e => e.to_string(),
        }
    }

    fn refused_file(&self) -> Option<(&Path, &std::io::Error)> {
        match self {
            RasterJobError::Machine(LoadError::Read { path, source }) => Some((path, source)),
            _ => None,
        }
    }
}

/// What a raster job wrote: the report of its layers, or of the nozzle test pattern.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum Written {
    /// Layers: the generator's report with the images read and the print time.
    Layers(JobReport),
    /// The nozzle test pattern (`test_pattern`).
    TestPattern(RasterReport),
}

/// A raster job done.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// What it wrote.
    pub written: Written,
    /// The printhead it wrote for, with as many heads as it drove.
    pub profile: PrintheadProfile,
    /// It read layer images (which carry no layer height nor pixel size), not a `.sl1`.
    pub from_images: bool,
}

/// A raster job ready to run: its options read, the machine they name loaded and its inputs
/// resolved (folders and globs listed, no image read), so that a front end can check the
/// files ([`Raster::images`]) before anything is written.
#[derive(Debug)]
pub struct Raster {
    setup: Setup,
    machine: Option<MachineProfile>,
    /// The layer source and the heads it needs; `None` for the test pattern.
    source: Option<(Source, usize)>,
}

impl Raster {
    /// The job of `options` on `inputs` (none for the test pattern).
    pub fn new(inputs: Vec<PathBuf>, options: RasterOptions) -> Result<Self, RasterJobError> {
        // The one check of the options, the declaration's (a front end has read them through
        // it already; a caller in code may have made them with a struct literal).
        options.check()?;
        let machine = options.machine.as_deref().map(|m| load_machine(Some(m))).transpose()?;
        let mut setup = Setup::new(inputs, options);
        if let Some(machine) = &machine {
            setup.head = Some(machine.raster_head()?);
        }
        let source = if setup.options.test_pattern { None } else { Some(setup.source()?) };
        Ok(Raster { setup, machine, source })
    }

    /// The options.
    pub fn options(&self) -> &RasterOptions {
        &self.setup.options
    }

    /// The machine the options name, if they do.
    pub fn machine(&self) -> Option<&MachineProfile> {
        self.machine.as_ref()
    }

    /// Every layer image (or the `.sl1`) the job will read.
    pub fn images(&self) -> Vec<&Path> {
        self.source.as_ref().map(|(source, _)| source.paths()).unwrap_or_default()
    }

    /// Writes the job to `target`, telling `progress` the layers done. The print is timed on
    /// the machine's motion, else on Marlin's defaults, unless `fast_estimate`.
    pub fn run(self, target: &Target, progress: &mut dyn Progress) -> Result<Outcome, RasterJobError> {
        let line = command_line(&self.setup.options, Strictness::Strict);
        let Some((source, heads)) = self.source else {
            let pattern = |t: &Target| Ok::<_, RasterJobError>(self.setup.test_pattern(t)?);
            let ((report, profile), _) = finish::with_metadata(None, target, &line, pattern)?;
            return Ok(Outcome { written: Written::TestPattern(report), profile, from_images: false });
        };
        let from_images = matches!(source, Source::Stacks(_));
        let job = self.setup.job_from(source, heads)?;
        let motion = self.machine.map(|m| m.motion).unwrap_or_default();
        let report = write(&job, target, &line, progress, || Estimator::line_timer_on(&motion))?;
        Ok(Outcome { written: Written::Layers(report), profile: job.profile, from_images })
    }
}

/// Writes `job` to `target` under the header `line`, its own figures the metadata when it knows
/// them, else measured from the file written; the report names the file written (the one
/// place a raster's output is named).
fn write<'t>(
    job: &Job,
    target: &Target,
    line: &str,
    progress: &mut dyn Progress,
    timer: impl FnOnce() -> Result<Box<dyn LineTimer + 't>, BoxError>,
) -> Result<JobReport, RasterJobError> {
    let (mut report, written) = if job.knows_its_figures() {
        let run = |out: &mut dyn Write| Ok::<_, RasterJobError>(job.run_into(out, progress, timer)?);
        let figures = |r: &JobReport| Figures { time_s: [r.time.total_s; 2], ..Figures::default() };
        finish::with_own_figures(target, line, run, figures)?
    } else {
        let run = |t: &Target| Ok::<_, RasterJobError>(job.run(t, progress, timer)?);
        // Its own time counts the printhead's firing, which the estimator does not know.
        finish::with_metadata_timed(None, target, line, run, |r: &JobReport| Some(r.time.total_s))?
    };
    report.output = written.map_or_else(|| "-".to_owned(), |path| path.display().to_string());
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gweave::Quiet;

    fn layers() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/raster/layers")
    }

    fn header(path: &Path) -> String {
        std::fs::read_to_string(path).unwrap().lines().next().unwrap().to_owned()
    }

    #[test]
    fn the_header_is_written_from_the_options_value() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("badge.gcode");
        let options = RasterOptions {
            flip_y: true,
            density: 2,
            threshold: 0.5,
            dialect: Some("reprap".parse().unwrap()),
            fast_estimate: true,
            ..RasterOptions::default()
        };
        let done = Raster::new(vec![layers()], options).unwrap().run(&Target::File(out.clone()), &mut Quiet);
        let Written::Layers(report) = done.unwrap().written else { panic!("layers written") };
        assert_eq!((report.raster.fire_commands, report.output), (2 * 844, out.display().to_string()));
        let version = env!("CARGO_PKG_VERSION");
        assert_eq!(
            header(&out),
            format!(
                "; gweave {version} raster --flip-y --density 2 --dialect reprapfirmware --fast-estimate (generated)"
            )
        );
    }

    #[test]
    fn the_test_pattern_reads_no_input_and_names_itself_in_the_header() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("pattern.gcode");
        let options = RasterOptions { test_pattern: true, pattern_columns: 2, ..RasterOptions::default() };
        let raster = Raster::new(Vec::new(), options).unwrap();
        assert!(raster.images().is_empty());
        let done = raster.run(&Target::File(out.clone()), &mut Quiet).unwrap();
        let Written::TestPattern(report) = done.written else { panic!("a test pattern written") };
        assert_eq!((report.fire_commands, done.profile.nozzle_count), (24, 12));
        let version = env!("CARGO_PKG_VERSION");
        assert_eq!(
            header(&out),
            format!("; gweave {version} raster --test-pattern --pattern-columns 2 (generated)")
        );
    }

    /// The report names the file written whichever way the output is finished (its own
    /// figures, or measured when the user's start G-code extrudes): named once, from the file
    /// the finishing step wrote (issue 40: it was worked out three times).
    #[test]
    fn the_report_names_the_file_written_either_way() {
        let dir = tempfile::tempdir().unwrap();
        let start = dir.path().join("start.gcode");
        std::fs::write(&start, "G1 E1 F300\n").unwrap();
        for (name, start) in [("own.gcode", None), ("measured.gcode", Some(start))] {
            let out = dir.path().join(name);
            let options = RasterOptions { start, fast_estimate: true, ..RasterOptions::default() };
            let raster = Raster::new(vec![layers()], options).unwrap();
            let done = raster.run(&Target::File(out.clone()), &mut Quiet).unwrap();
            let Written::Layers(report) = done.written else { panic!("layers written") };
            assert_eq!(report.output, out.display().to_string(), "{name}");
        }
    }

    /// Regression (issue 40): options made in code were checked a second time by hand in the
    /// engine (`Setup::source`), with messages of their own ("threshold 1.5 ..." naming neither
    /// front end's spelling); the declaration's check is the one check now.
    #[test]
    fn options_made_in_code_are_checked_by_the_declaration_alone() {
        let refused = |options: RasterOptions| Raster::new(vec![layers()], options).unwrap_err();
        let err = refused(RasterOptions { threshold: 1.5, ..RasterOptions::default() });
        assert_eq!(err.spelled(Spelling::Flag), "--threshold 1.5 is out of range: 0 to 1");
        assert_eq!(err.spelled(Spelling::Keyword), "threshold = 1.5 is out of range: 0 to 1");
        let err =
            refused(RasterOptions { pixel_mm: Some(0.05), dpi: Some(300.0), ..RasterOptions::default() });
        assert_eq!(err.spelled(Spelling::Flag), "--pixel-mm and --dpi: give one of them");
        let err = refused(RasterOptions { heads: Some(0), ..RasterOptions::default() });
        assert!(err.spelled(Spelling::Flag).starts_with("--heads 0 is out of range: "), "{err}");
        // The test pattern reads no layer, and is checked all the same.
        let err = Raster::new(
            Vec::new(),
            RasterOptions { test_pattern: true, density: 0, ..RasterOptions::default() },
        );
        assert!(err.unwrap_err().spelled(Spelling::Keyword).starts_with("density = 0 is out of range: "));
    }

    #[test]
    fn head_and_machine_exclude_each_other_and_a_machine_needs_a_printhead() {
        let options = RasterOptions {
            head: Some("h.toml".into()),
            machine: Some("binder-jet".into()),
            ..RasterOptions::default()
        };
        let err = Raster::new(vec![layers()], options).unwrap_err();
        assert_eq!(err.spelled(Spelling::Keyword), "machine and head: give one of them");
        assert_eq!(err.spelled(Spelling::Flag), "--machine and --head: give one of them");
        let options = RasterOptions { machine: Some("prusa-mk3".into()), ..RasterOptions::default() };
        let err = Raster::new(vec![layers()], options).unwrap_err();
        assert!(err.to_string().contains("has no inkjet printhead"), "{err}");
    }
}
