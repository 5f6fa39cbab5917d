//! A whole raster job as `gweave raster` and `gweave.raster()` run it: resolve the inputs
//! (folders, globs, image lists or one `.sl1`), raster them layer by layer into an atomically
//! written file, and time the print while the G-code streams out.
//!
//! The G-code generator itself is [`super::raster`]; this module wires files, heads and the
//! time estimate together, so that the command line and Python give identical results. The
//! planner that times the G-code is the virtual printer's, which sits above the engine: the
//! caller hands it in as a [`LineTimer`] (`gweave_sim::Estimator::line_timer`).

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::bitmap::{load_image, Bitmap, BitmapError, ThresholdOptions};
use super::printhead::{PrintheadError, PrintheadProfile};
use super::raster::{test_pattern, RasterConfig, RasterError, RasterReport, RasterWriter};
use super::sl1::{Sl1Error, Sl1Reader};
use crate::gcode::writer::{Output, Target};
use crate::options::{JobOptions, OptionError};
use crate::pass::Progress;

/// Any error, boxed: what a [`LineTimer`] (a planner outside the engine) fails with.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// Why a raster job failed. Its text is the message a user reads; a file that cannot be read
/// is named, with the operating system's error as the source.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// Inputs, heads or channels that do not fit together (the message says how).
    #[error("{0}")]
    Invalid(String),
    /// A layer image cannot be read.
    #[error("reading {}", path.display())]
    ReadImage {
        /// The image.
        path: PathBuf,
        /// Why.
        source: BitmapError,
    },
    /// A `.sl1` archive cannot be opened.
    #[error("reading {}", path.display())]
    ReadArchive {
        /// The archive.
        path: PathBuf,
        /// Why.
        source: Sl1Error,
    },
    /// A G-code block file (`--start`, `--end`, `--recoat`) or the profile cannot be read.
    #[error("reading {}", path.display())]
    ReadText {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: io::Error,
    },
    /// Images that cannot be listed, decoded or resampled.
    #[error(transparent)]
    Image(#[from] BitmapError),
    /// An archive's layer that cannot be read.
    #[error(transparent)]
    Archive(#[from] Sl1Error),
    /// The generator refused the settings or could not write.
    #[error(transparent)]
    Raster(#[from] RasterError),
    /// The printhead profile is invalid.
    #[error(transparent)]
    Printhead(#[from] PrintheadError),
    /// An option's value out of its declared range, or given with one it excludes.
    #[error(transparent)]
    Option(#[from] OptionError),
    /// The output (or a settings file) failed.
    #[error(transparent)]
    Engine(#[from] crate::Error),
    /// The planner could not be set up.
    #[error(transparent)]
    Planner(BoxError),
    /// The planner refused a line of the written G-code.
    #[error("estimating the print time")]
    Estimate(#[source] BoxError),
    /// The thread decoding the images stopped without an error of its own.
    #[error("the image decoder stopped")]
    DecoderStopped(#[source] std::sync::mpsc::RecvError),
}

/// A result whose error is a [`JobError`].
pub type Result<T, E = JobError> = std::result::Result<T, E>;

/// A planner that times G-code fed to it line by line, as the job writes it: the virtual
/// printer's (`gweave_sim::Estimator`), which the engine cannot name.
pub trait LineTimer {
    /// Takes one line, without its end.
    fn line(&mut self, line: &[u8]) -> std::result::Result<(), BoxError>;
    /// The motion (and dwell) time of every line taken, s.
    fn total_s(self: Box<Self>) -> f64;
}

/// `Err(JobError::Invalid(...))` with a formatted message.
macro_rules! invalid {
    ($($arg:tt)*) => {
        return Err(JobError::Invalid(format!($($arg)*)))
    };
}

mod inputs;
mod options;
pub use inputs::{parse_channels, InputSpec, Source};
pub use options::{FireDialect, RasterOptions};

/// The text of a file the job reads.
fn read_text(path: &Path) -> Result<String> {
    crate::settings::read_text(path).map_err(|source| JobError::ReadText { path: path.to_path_buf(), source })
}

/// Makes the profile have exactly `heads` heads: extra heads get zero offsets, which suits
/// cartridges whose offset the firmware already applies.
pub fn with_heads(profile: &PrintheadProfile, heads: usize) -> PrintheadProfile {
    let mut p = profile.clone();
    p.heads.resize(heads.max(1), Default::default());
    p
}

/// The print time of the job.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TimeEstimate {
    /// `planner`: gweave-sim's planner on the written G-code (the timer the caller hands in: the
    /// machine's motion, or Marlin's defaults, 3000 mm/s², junction deviation 0.013 mm; every
    /// `M400` a full stop); `feed`: the report's path at the
    /// feed rate without acceleration.
    pub method: &'static str,
    /// Motion (and dwell) time, s.
    pub motion_s: f64,
    /// Firing: every fire command counted at the head's minimum fire interval, s.
    pub fire_s: f64,
    /// Motion and firing, s.
    pub total_s: f64,
}

/// What a job did.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct JobReport {
    /// The file written, `-` for standard output: named by the caller that finishes the output
    /// (`gweave_sim::raster_job`, from the file it wrote), empty until then.
    pub output: String,
    /// Heads that printed.
    pub heads: usize,
    /// Layer images (or archive layers) read.
    pub images_read: usize,
    /// What the generator wrote.
    #[serde(flatten)]
    pub raster: RasterReport,
    /// The print time.
    pub time: TimeEstimate,
}

/// Feeds every complete line written through it to a planner.
struct EstimatingWriter<'t, W: Write> {
    inner: W,
    est: Option<Box<dyn LineTimer + 't>>,
    partial: Vec<u8>,
    error: Option<BoxError>,
}

impl<W: Write> EstimatingWriter<'_, W> {
    fn feed(&mut self, buf: &[u8]) {
        let Some(est) = self.est.as_mut() else {
            return;
        };
        let mut rest = buf;
        while let Some(n) = rest.iter().position(|&b| b == b'\n') {
            let res = if self.partial.is_empty() {
                est.line(&rest[..n])
            } else {
                self.partial.extend_from_slice(&rest[..n]);
                let r = est.line(&self.partial);
                self.partial.clear();
                r
            };
            if let Err(e) = res {
                self.error = Some(e);
                self.est = None;
                return;
            }
            rest = &rest[n + 1..];
        }
        self.partial.extend_from_slice(rest);
    }
}

impl<W: Write> Write for EstimatingWriter<'_, W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.feed(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// A raster job, ready to run.
#[derive(Debug, Clone)]
pub struct Job {
    /// Where the layers come from.
    pub source: Source,
    /// The printhead, with as many heads as the job drives.
    pub profile: PrintheadProfile,
    /// The validated raster settings.
    pub config: RasterConfig,
    /// Pixel size of image files in mm; they are resampled to the nozzle pitch when given.
    /// (`.sl1` archives carry their own.)
    pub pixel_mm: Option<f64>,
    /// Estimate with the planner (slower) rather than from the path length at the feed rate.
    pub planner_estimate: bool,
}

impl Job {
    /// Writes the G-code to `target` and returns the report. `progress` counts layers (its
    /// `set_len` gets the layer count, `advance` the layers done), not bytes. `planner` makes
    /// the timer of a [`Job::planner_estimate`] job (`gweave_sim::Estimator::line_timer`); a
    /// fast estimate never calls it.
    pub fn run<'t>(
        &self,
        target: &Target,
        progress: &mut dyn Progress,
        planner: impl FnOnce() -> std::result::Result<Box<dyn LineTimer + 't>, BoxError>,
    ) -> Result<JobReport> {
        let mut out = Output::create(target, None)?;
        let report = self.run_into(&mut out, progress, planner)?;
        out.commit()?;
        Ok(report)
    }

    /// [`Job::run`] into `out`, which the caller opened and commits.
    pub fn run_into<'t>(
        &self,
        out: &mut dyn Write,
        progress: &mut dyn Progress,
        planner: impl FnOnce() -> std::result::Result<Box<dyn LineTimer + 't>, BoxError>,
    ) -> Result<JobReport> {
        let est = if self.planner_estimate { Some(planner().map_err(JobError::Planner)?) } else { None };
        let mut tee = EstimatingWriter { inner: out, est, partial: Vec::new(), error: None };
        let (report, images_read) = self.write(&mut tee, progress)?;
        if let Some(e) = tee.error.take() {
            return Err(JobError::Estimate(e));
        }
        let motion_s: Option<f64> = tee.est.take().map(|mut e| {
            if !tee.partial.is_empty() {
                let _ = e.line(&tee.partial);
            }
            e.total_s()
        });
        let fire_s = self.profile.fire_time_s(report.fire_commands);
        let time = match motion_s {
            Some(motion_s) => {
                TimeEstimate { method: "planner", motion_s, fire_s, total_s: motion_s + fire_s }
            }
            None => TimeEstimate {
                method: "feed",
                motion_s: report.estimated_time_s - fire_s,
                fire_s,
                total_s: report.estimated_time_s,
            },
        };
        let heads = self.profile.heads.len();
        Ok(JobReport { output: String::new(), heads, images_read, raster: report, time })
    }

    /// Whether the job's output holds nothing its metadata is measured from, so that its own
    /// figures are the metadata ([`crate::post::metadata::write_footer`]): the generator's lines
    /// never extrude (the recoat has no E axis) and are no progress line nor slicer figure; the
    /// user's start, end and recoat G-code must not either, nor end lines with `\r\n` (the footer
    /// follows the first line's ending). A job that fails this is measured as before.
    pub fn knows_its_figures(&self) -> bool {
        let c = &self.config;
        [&c.start_gcode, &c.end_gcode, &c.recoat_gcode].into_iter().all(|block| {
            !block.contains('\r')
                && block.lines().all(|line| {
                    let code = line.split(';').next().unwrap_or_default();
                    !code.contains(['E', 'e']) && !crate::post::metadata::needs_figures(line.as_bytes())
                })
        })
    }

    fn write<W: Write>(&self, out: W, progress: &mut dyn Progress) -> Result<(RasterReport, usize)> {
        let pitch = self.profile.pitch_mm();
        match &self.source {
            Source::Sl1 { path, threshold } => {
                let mut reader = Sl1Reader::open(path)
                    .map_err(|source| JobError::ReadArchive { path: path.clone(), source })?;
                let (px_x, px_y) = reader.bed_pixel_mm();
                let layers = reader.layer_count();
                progress.set_len(layers as u64);
                let height = reader.info().layer_height_mm;
                let mut w = RasterWriter::new(out, &self.profile, &self.config, Some(height))?;
                let load = |k: usize| -> Result<Vec<Bitmap>> {
                    Ok(vec![reader.bed_layer(k, threshold)?.resample(px_x, px_y, pitch)?])
                };
                pipelined(&mut w, layers, load, progress)?;
                Ok((w.finish()?.1, layers))
            }
            Source::Stacks(stacks) => {
                if stacks.len() > self.profile.heads.len() {
                    invalid!(
                        "{} image sets but the printhead profile has {} heads",
                        stacks.len(),
                        self.profile.heads.len()
                    );
                }
                let mut w = RasterWriter::new(out, &self.profile, &self.config, None)?;
                let layers = stacks.iter().map(|s| s.paths.len()).max().unwrap_or(0);
                progress.set_len(layers as u64);
                let read = stacks.iter().map(|s| s.paths.len()).sum();
                // Each stack's first image, with its size: every later layer must match it, as
                // the layers of a .sl1 do.
                let mut first: Vec<Option<(PathBuf, usize, usize)>> = vec![None; stacks.len()];
                let load = |k: usize| -> Result<Vec<Bitmap>> {
                    let mut planes = Vec::with_capacity(stacks.len());
                    for (s, first) in stacks.iter().zip(&mut first) {
                        let Some(p) = s.paths.get(k) else {
                            planes.push(Bitmap::new(0, 0));
                            continue;
                        };
                        let b = load_image(p, &s.threshold, self.pixel_mm.unwrap_or(pitch))
                            .map_err(|source| JobError::ReadImage { path: p.clone(), source })?;
                        let (w, h) = (b.width(), b.height());
                        match first {
                            None => *first = Some((p.clone(), w, h)),
                            Some((p0, w0, h0)) if (*w0, *h0) != (w, h) => invalid!(
                                "{}: the layer image is {w} x {h} px, but {} is {w0} x {h0} px; every layer must have the same size",
                                p.display(),
                                p0.display()
                            ),
                            Some(_) => {}
                        }
                        let b = if s.flip_y { b.mirror_y() } else { b };
                        planes.push(match self.pixel_mm {
                            Some(px) => b.resample(px, px, pitch)?,
                            None => b,
                        });
                    }
                    Ok(planes)
                };
                pipelined(&mut w, layers, load, progress)?;
                Ok((w.finish()?.1, read))
            }
        }
    }
}

/// Rasters `layers` layers, decoding layer `k + 1` on a second thread while layer `k` is
/// written (decoding and G-code writing each take about half the time).
fn pipelined<W: Write>(
    w: &mut RasterWriter<W>,
    layers: usize,
    mut load: impl FnMut(usize) -> Result<Vec<Bitmap>> + Send,
    progress: &mut dyn Progress,
) -> Result<()> {
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Vec<Bitmap>>>(2);
        scope.spawn(move || {
            for k in 0..layers {
                let planes = load(k);
                let failed = planes.is_err();
                // A closed channel means the writer stopped on an error of its own.
                if tx.send(planes).is_err() || failed {
                    break;
                }
            }
        });
        for k in 0..layers {
            let planes = rx.recv().map_err(JobError::DecoderStopped)??;
            w.layer(&planes)?;
            progress.advance(k as u64 + 1);
        }
        Ok(())
    })
}

/// A raster job as given: the layer sources, the options, and the printhead the options name
/// (a `head` file, or the machine profile's printhead, which is read above the engine).
#[derive(Debug, Clone, Default)]
pub struct Setup {
    /// Folders, globs, image files in layer order, or one `.sl1` (`INPUTS`).
    pub inputs: Vec<PathBuf>,
    /// The options ([`RasterOptions`]).
    pub options: RasterOptions,
    /// The printhead (None: the HP C6602 defaults).
    pub head: Option<HeadSource>,
}

/// Where a job's printhead comes from.
#[derive(Debug, Clone)]
pub enum HeadSource {
    /// A printhead profile file (`--head`).
    File(PathBuf),
    /// A machine profile's inkjet table (`--machine`): its printhead, with the `[recoat]` the
    /// machine's powder bed needs, and the bed position of its canvas, which becomes the job's
    /// origin unless one is given, so that the virtual printer with the same machine finds every
    /// drop and every recoat where it expects them.
    Machine {
        /// The printhead as the machine profile describes it.
        printhead: Box<PrintheadProfile>,
        /// Bed position of the canvas' pixel (0, 0) corner, mm.
        origin_mm: (f64, f64),
    },
}

impl Setup {
    /// `inputs` with `options`, the printhead the options' `head` file (a machine's is set by
    /// the caller that reads the machine profile).
    pub fn new(inputs: Vec<PathBuf>, options: RasterOptions) -> Self {
        let head = options.head.clone().map(HeadSource::File);
        Setup { inputs, options, head }
    }

    /// The printhead profile: `head` file or the C6602 defaults, with `dialect` applied.
    pub fn profile(&self) -> Result<PrintheadProfile> {
        let mut p = match &self.head {
            Some(HeadSource::File(path)) => PrintheadProfile::from_toml(&read_text(path)?).map_err(|e| {
                crate::Error::Config { path: path.clone(), message: crate::error::with_causes(&e) }
            })?,
            Some(HeadSource::Machine { printhead, .. }) => (**printhead).clone(),
            None => PrintheadProfile::default(),
        };
        if let Some(FireDialect(d)) = self.options.dialect {
            p.dialect = d;
            // A firmware without a fire command is refused here, as in a profile.
            p.validate()?;
        }
        Ok(p)
    }

    /// The image corner on the bed: the given origin, else the machine's canvas, else the
    /// generator's default.
    fn origin_mm(&self) -> (f64, f64) {
        let default = RasterConfig::default();
        match (&self.options.origin, &self.head) {
            (Some([x, y]), _) => (*x, *y),
            (None, Some(HeadSource::Machine { origin_mm, .. })) => *origin_mm,
            (None, _) => (default.origin_x_mm, default.origin_y_mm),
        }
    }

    /// The validated raster settings.
    pub fn config(&self) -> Result<RasterConfig> {
        let (origin_x_mm, origin_y_mm) = self.origin_mm();
        let mut c = RasterConfig {
            origin_x_mm,
            origin_y_mm,
            layer_height_mm: self.options.layer_height,
            serpentine: !self.options.one_way,
            fire_order: self.options.fire_order,
            density: self.options.density,
            ..RasterConfig::default()
        };
        if let Some(f) = self.options.feed {
            c.feed_mm_min = f;
        }
        for (file, slot) in [
            (&self.options.start, &mut c.start_gcode),
            (&self.options.end, &mut c.end_gcode),
            (&self.options.recoat, &mut c.recoat_gcode),
        ] {
            if let Some(path) = file {
                *slot = read_text(path)?;
            }
        }
        c.validate()?;
        Ok(c)
    }

    /// Checks the options as declared ([`JobOptions::check`]: each number within its range,
    /// `pixel_mm` and `dpi` not both), resolves the inputs and builds the job.
    pub fn job(&self) -> Result<Job> {
        self.options.check()?;
        let (source, heads) = self.source()?;
        self.job_from(source, heads)
    }

    /// Resolves the inputs (lists folders and globs, reads no image) into the layer source and
    /// the heads it needs, so that a caller can check the files before any is read. The options
    /// are the caller's to check first ([`JobOptions::check`]), as [`Setup::job`] does.
    pub fn source(&self) -> Result<(Source, usize)> {
        let o = &self.options;
        let spec = InputSpec {
            inputs: self.inputs.clone(),
            heads: self.heads(),
            channels: match &o.channels {
                Some(c) => parse_channels(c)?,
                None => Vec::new(),
            },
            threshold: ThresholdOptions {
                threshold: o.threshold,
                invert: o.invert,
                ..ThresholdOptions::default()
            },
            flip_y: o.flip_y,
        };
        spec.resolve()
    }

    /// The heads the options ask for, if they do.
    fn heads(&self) -> Option<usize> {
        self.options.heads.map(|h| h as usize)
    }

    /// Builds the job from a resolved [`Setup::source`]: reads the profile and snippets.
    pub fn job_from(&self, source: Source, heads: usize) -> Result<Job> {
        let o = &self.options;
        if matches!(source, Source::Sl1 { .. }) && (o.pixel_mm.is_some() || o.dpi.is_some()) {
            invalid!("a .sl1 archive carries its own pixel size: drop the pixel size / dpi");
        }
        let profile = self.profile()?;
        if profile.recoat.is_some() && o.recoat.is_some() {
            invalid!(
                "the printhead profile's [recoat] table and --recoat both describe the recoat: give one"
            );
        }
        Ok(Job {
            source,
            profile: with_heads(&profile, self.heads().unwrap_or(heads)),
            config: self.config()?,
            pixel_mm: o.pixel_mm.or(o.dpi.map(|d| 25.4 / d)),
            planner_estimate: !o.fast_estimate,
        })
    }

    /// Writes a nozzle test pattern (the options' `pattern_columns` columns per nozzle address)
    /// to `target`; the profile keeps its heads unless the options set them.
    pub fn test_pattern(&self, target: &Target) -> Result<(RasterReport, PrintheadProfile)> {
        let profile = match self.heads() {
            Some(h) => with_heads(&self.profile()?, h),
            None => self.profile()?,
        };
        let mut out = Output::create(target, None)?;
        let rep = test_pattern(&mut out, &profile, &self.config()?, self.options.pattern_columns)?;
        out.commit()?;
        Ok((rep, profile))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pass::Quiet;

    fn examples() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/raster")
    }

    /// A timer that keeps the lines it is fed and counts each as one second.
    #[derive(Default)]
    struct Lines(std::rc::Rc<std::cell::RefCell<Vec<Vec<u8>>>>);

    impl LineTimer for Lines {
        fn line(&mut self, line: &[u8]) -> std::result::Result<(), BoxError> {
            self.0.borrow_mut().push(line.to_vec());
            Ok(())
        }
        fn total_s(self: Box<Self>) -> f64 {
            self.0.borrow().len() as f64
        }
    }

    #[test]
    fn writer_splits_lines_across_chunks() {
        let text = b"G1 X10 F600\nM400\nG1 X20\nG1 Y5\nM400\n";
        let seen = Lines::default();
        let mut w = EstimatingWriter {
            inner: Vec::new(),
            est: Some(Box::new(Lines(seen.0.clone()))),
            partial: Vec::new(),
            error: None,
        };
        for chunk in text.chunks(3) {
            w.write_all(chunk).unwrap();
        }
        assert_eq!(w.inner, text);
        assert!(w.partial.is_empty());
        let lines: Vec<&[u8]> = text.split(|&b| b == b'\n').filter(|l| !l.is_empty()).collect();
        assert_eq!(*seen.0.borrow(), lines);
    }

    #[test]
    fn the_planner_times_the_written_file_and_a_fast_estimate_never_asks_for_it() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("badge.gcode");
        let options = RasterOptions { flip_y: true, density: 2, ..RasterOptions::default() };
        let setup = |options| Setup::new(vec![examples().join("layers")], options);
        let seen = Lines::default();
        let timer = || Ok(Box::new(Lines(seen.0.clone())) as Box<dyn LineTimer>);
        let rep =
            setup(options.clone()).job().unwrap().run(&Target::File(out.clone()), &mut Quiet, timer).unwrap();
        let written = std::fs::read(&out).unwrap();
        let lines = written.split(|&b| b == b'\n').filter(|l| !l.is_empty()).count();
        assert_eq!(seen.0.borrow().len(), lines);
        assert_eq!((rep.time.method, rep.time.motion_s), ("planner", lines as f64));
        // 844 inked columns, each fired twice at >= 800 us.
        assert_eq!(rep.raster.fire_commands, 2 * 844);
        assert!((rep.time.fire_s - 2.0 * 844.0 * 800e-6).abs() < 1e-12);
        assert_eq!(rep.time.total_s, rep.time.motion_s + rep.time.fire_s);
        assert_eq!(rep.images_read, 8);
        let fast = setup(RasterOptions { fast_estimate: true, ..options }).job().unwrap();
        let never = || -> std::result::Result<Box<dyn LineTimer>, BoxError> {
            panic!("a fast estimate ran the planner")
        };
        let rep_fast = fast.run(&Target::File(out), &mut Quiet, never).unwrap();
        assert_eq!(rep_fast.time.method, "feed");
        assert_eq!(rep_fast.time.total_s, rep_fast.raster.estimated_time_s);
    }

    /// The direct write of a raster's metadata (no read-back) holds only while its output has
    /// no line that metadata is measured from: the generator's own lines never are, and a
    /// user's G-code that is sends the job the measured way.
    #[test]
    fn a_raster_knows_its_figures_unless_the_user_gcode_extrudes_or_shows_progress() {
        let dir = tempfile::tempdir().unwrap();
        let options = RasterOptions { fast_estimate: true, ..RasterOptions::default() };
        let setup = |options| Setup::new(vec![examples().join("layers")], options);
        let job = setup(options.clone()).job().unwrap();
        assert!(job.knows_its_figures());
        let mut out = Vec::new();
        job.run_into(&mut out, &mut Quiet, || unreachable!("a fast estimate")).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.lines().count() > 100, "{text}");
        for line in text.lines() {
            let code = line.split(';').next().unwrap();
            assert!(
                !code.contains(['E', 'e']) && !crate::post::metadata::needs_figures(line.as_bytes()),
                "{line}"
            );
        }
        let with_start = |gcode: &str| {
            let start = dir.path().join("start.gcode");
            std::fs::write(&start, gcode).unwrap();
            setup(RasterOptions { start: Some(start), ..options.clone() }).job().unwrap().knows_its_figures()
        };
        assert!(with_start("G28 ; home\nM400\n"));
        assert!(!with_start("G28\nM73 P0 R10\n"));
        assert!(!with_start("G1 X5 E2 F600\n"));
        assert!(!with_start("; estimated printing time (normal mode) = 1m 0s\n"));
        assert!(!with_start("G28\r\n"));
    }

    #[test]
    fn a_timer_that_refuses_a_line_fails_the_job_and_leaves_no_output() {
        struct Refuses;
        impl LineTimer for Refuses {
            fn line(&mut self, _: &[u8]) -> std::result::Result<(), BoxError> {
                Err("line 1: no".into())
            }
            fn total_s(self: Box<Self>) -> f64 {
                0.0
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("badge.gcode");
        let job = Setup::new(vec![examples().join("layers")], RasterOptions::default()).job().unwrap();
        let e = job.run(&Target::File(out.clone()), &mut Quiet, || Ok(Box::new(Refuses))).unwrap_err();
        assert_eq!(e.to_string(), "estimating the print time");
        assert_eq!(std::error::Error::source(&e).unwrap().to_string(), "line 1: no");
        assert!(!out.exists());
    }
}
