//! A whole raster job as the CLI and the Python package run it: resolve the inputs (folders,
//! globs, image lists or one `.sl1`), raster them layer by layer into an atomically written file,
//! and estimate the print time with the virtual printer's planner while the G-code streams out.
//!
//! The G-code generator itself is `gweave::gen::raster`; this module only wires files, heads
//! and the estimate together, so `gweave raster` and `gweave.raster()` give identical results.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use gweave::firmware::Firmware;
use gweave::gcode::writer::{Output, Target};
use gweave::gen::bitmap::{load_image, Bitmap, Channel, ThresholdOptions};
use gweave::gen::image_files::list_images;
use gweave::gen::printhead::PrintheadProfile;
use gweave::gen::raster::{
    self, test_pattern, FireOrder, RasterConfig, RasterReport, RasterWriter, HEADS, THRESHOLD,
};
use gweave::gen::sl1::Sl1Reader;
use gweave::pass::Progress;
use gweave::range::{DPI, PIXEL_MM};
use gweave_sim::MotionProfile;
use gweave_sim::{Estimate, Estimator};
use serde::Serialize;

use crate::common::{load_or_default, read_text};

/// Where the layer images of a job come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// One image stack per head (stack `h` printed by head `h`), each with its channel.
    Stacks(Vec<raster::ImageStack>),
    /// A PrusaSlicer SLA archive, printed by head 0.
    Sl1 { path: PathBuf, threshold: ThresholdOptions },
}

/// How the inputs on the command line become a [`Source`].
#[derive(Debug, Clone, Default)]
pub struct InputSpec {
    /// Folders, globs (`*`, `?` in the file name), image files, or one `.sl1`.
    pub inputs: Vec<PathBuf>,
    /// Heads to use (None: as many as the profile has, but only head 0 unless inputs say more).
    pub heads: Option<usize>,
    /// One channel per head: every head prints the same images, head `h` their channel `h`.
    pub channels: Vec<Channel>,
    pub threshold: ThresholdOptions,
    /// The files' first row is the far edge (+Y up), as a picture is drawn.
    pub flip_y: bool,
}

impl Source {
    /// Every file the job will read its layers from.
    pub fn paths(&self) -> Vec<&Path> {
        match self {
            Source::Stacks(stacks) => {
                stacks.iter().flat_map(|s| s.paths.iter().map(PathBuf::as_path)).collect()
            }
            Source::Sl1 { path, .. } => vec![path],
        }
    }
}

fn is_sl1(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("sl1"))
}

fn is_glob(p: &Path) -> bool {
    p.file_name().is_some_and(|n| n.to_string_lossy().contains(['*', '?']))
}

/// Parses `r,b` / `red,luma` into channels.
pub fn parse_channels(text: &str) -> Result<Vec<Channel>> {
    text.split(',')
        .map(|c| {
            Ok(match c.trim().to_ascii_lowercase().as_str() {
                "r" | "red" => Channel::Red,
                "g" | "green" => Channel::Green,
                "b" | "blue" => Channel::Blue,
                "l" | "luma" | "grey" | "gray" => Channel::Luma,
                other => bail!("unknown channel {other:?} (use r, g, b or luma)"),
            })
        })
        .collect()
}

impl InputSpec {
    /// Resolves the inputs, and returns the source and the number of heads it needs.
    ///
    /// Rules: one `.sl1` alone -> head 0. With `channels`, all inputs form one image list and
    /// head `h` prints channel `h`. Without them and with `heads > 1`, each input is one head's
    /// folder or glob. Otherwise all inputs form one list for head 0, in the given order (a
    /// folder or glob contributes its files in natural order: `l2 < l10`).
    pub fn resolve(&self) -> Result<(Source, usize)> {
        if self.inputs.is_empty() {
            bail!("no input: give a folder, a glob, image files, or a .sl1 archive");
        }
        if self.inputs.iter().any(|p| is_sl1(p)) {
            if self.inputs.len() != 1 || !self.channels.is_empty() || self.heads.unwrap_or(1) > 1 {
                bail!("a .sl1 archive is printed alone by one head (no other inputs, heads or channels)");
            }
            return Ok((Source::Sl1 { path: self.inputs[0].clone(), threshold: self.threshold }, 1));
        }
        let expand = |p: &PathBuf| -> Result<Vec<PathBuf>> {
            if p.is_dir() || is_glob(p) {
                Ok(list_images(p)?)
            } else if p.is_file() {
                Ok(vec![p.clone()])
            } else {
                bail!("{}: no such file or folder", p.display())
            }
        };
        let stack = |paths: Vec<PathBuf>, channel: Channel| raster::ImageStack {
            paths,
            threshold: ThresholdOptions { channel, ..self.threshold },
            flip_y: self.flip_y,
        };
        let all = || -> Result<Vec<PathBuf>> {
            let mut v = Vec::new();
            for p in &self.inputs {
                v.extend(expand(p)?);
            }
            Ok(v)
        };
        if !self.channels.is_empty() {
            let heads = self.heads.unwrap_or(self.channels.len());
            if heads != self.channels.len() {
                bail!("{} channels given for {heads} heads: give one channel per head", self.channels.len());
            }
            let paths = all()?;
            let stacks = self.channels.iter().map(|&c| stack(paths.clone(), c)).collect();
            return Ok((Source::Stacks(stacks), heads));
        }
        match self.heads {
            Some(h) if h > 1 => {
                if self.inputs.len() != h {
                    bail!("{h} heads need {h} inputs (one folder or glob per head) or --channels");
                }
                let stacks = self
                    .inputs
                    .iter()
                    .map(|p| Ok(stack(expand(p)?, self.threshold.channel)))
                    .collect::<Result<_>>()?;
                Ok((Source::Stacks(stacks), h))
            }
            _ => Ok((Source::Stacks(vec![stack(all()?, self.threshold.channel)]), 1)),
        }
    }
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
    /// `planner`: gweave-sim's planner on the written G-code (Marlin defaults: 3000 mm/s²,
    /// junction deviation 0.013 mm, every `M400` a full stop); `feed`: the report's path at the
    /// feed rate without acceleration.
    pub method: &'static str,
    /// Motion (and dwell) time, s.
    pub motion_s: f64,
    /// Firing: every fire command counted at the head's minimum fire interval, s.
    pub fire_s: f64,
    pub total_s: f64,
}

/// What a job did.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct JobReport {
    pub output: String,
    pub heads: usize,
    /// Layer images (or archive layers) read.
    pub images_read: usize,
    #[serde(flatten)]
    pub raster: RasterReport,
    pub time: TimeEstimate,
}

/// Feeds every complete line written through it to an estimator.
struct EstimatingWriter<W: Write> {
    inner: W,
    est: Option<Estimator>,
    partial: Vec<u8>,
    error: Option<gweave_sim::EstimateError>,
}

impl<W: Write> EstimatingWriter<W> {
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

impl<W: Write> Write for EstimatingWriter<W> {
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
    pub source: Source,
    pub profile: PrintheadProfile,
    pub config: RasterConfig,
    /// Pixel size of image files in mm; they are resampled to the nozzle pitch when given.
    /// (`.sl1` archives carry their own.)
    pub pixel_mm: Option<f64>,
    /// Estimate with the planner (slower) rather than from the path length at the feed rate.
    pub planner_estimate: bool,
}

impl Job {
    /// Writes the G-code to `target` and returns the report. `progress` counts layers (its
    /// `set_len` gets the layer count, `advance` the layers done), not bytes.
    pub fn run(&self, target: &Target, progress: &mut dyn Progress) -> Result<JobReport> {
        let mut out = Output::create(target, None)?;
        let planner = self.planner_estimate;
        let est = if planner { Some(Estimator::new(&MotionProfile::default())?) } else { None };
        let mut tee = EstimatingWriter { inner: &mut out, est, partial: Vec::new(), error: None };
        let (report, images_read) = self.write(&mut tee, progress)?;
        if let Some(e) = tee.error.take() {
            return Err(anyhow::Error::new(e).context("estimating the print time"));
        }
        let estimate: Option<Estimate> = tee.est.take().map(|mut e| {
            if !tee.partial.is_empty() {
                let _ = e.line(&tee.partial);
            }
            e.finish()
        });
        out.commit()?;
        let fire_s = self.profile.fire_time_s(report.fire_commands);
        let time = match estimate {
            Some(e) => {
                TimeEstimate { method: "planner", motion_s: e.total_s, fire_s, total_s: e.total_s + fire_s }
            }
            None => TimeEstimate {
                method: "feed",
                motion_s: report.estimated_time_s - fire_s,
                fire_s,
                total_s: report.estimated_time_s,
            },
        };
        let output = match target {
            // Under `finish::with_metadata` this is its scratch file: name the output.
            Target::File(p) => gweave::gcode::temp::shown_name(p).display().to_string(),
            _ => "-".into(),
        };
        Ok(JobReport { output, heads: self.profile.heads.len(), images_read, raster: report, time })
    }

    fn write<W: Write>(&self, out: W, progress: &mut dyn Progress) -> Result<(RasterReport, usize)> {
        let pitch = self.profile.pitch_mm();
        match &self.source {
            Source::Sl1 { path, threshold } => {
                let mut reader =
                    Sl1Reader::open(path).with_context(|| format!("reading {}", path.display()))?;
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
                    bail!(
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
                        let b = load_image(p, &s.threshold)
                            .with_context(|| format!("reading {}", p.display()))?;
                        let (w, h) = (b.width(), b.height());
                        match first {
                            None => *first = Some((p.clone(), w, h)),
                            Some((p0, w0, h0)) if (*w0, *h0) != (w, h) => bail!(
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
            let planes = rx.recv().context("the image decoder stopped")??;
            w.layer(&planes)?;
            progress.advance(k as u64 + 1);
        }
        Ok(())
    })
}

/// Every setting of a job as the user gives it (CLI flags, Python keywords), turned into the
/// library's validated types by [`JobOptions::job`].
#[derive(Debug, Clone)]
pub struct JobOptions {
    pub inputs: Vec<PathBuf>,
    /// Printhead profile TOML (None: the HP C6602 defaults).
    pub head: Option<PathBuf>,
    pub threshold: f64,
    pub invert: bool,
    pub flip_y: bool,
    pub one_way: bool,
    /// Fire after the move onto a column (default) or, as the binder-jet seed, before the next.
    pub fire_order: FireOrder,
    pub density: u32,
    pub origin_mm: (f64, f64),
    pub layer_height_mm: Option<f64>,
    pub pixel_mm: Option<f64>,
    pub dpi: Option<f64>,
    pub heads: Option<usize>,
    pub channels: Option<String>,
    /// Files with G-code blocks.
    pub recoat: Option<PathBuf>,
    pub start: Option<PathBuf>,
    pub end: Option<PathBuf>,
    pub dialect: Option<Firmware>,
    pub feed_mm_min: Option<f64>,
    pub fast_estimate: bool,
}

impl Default for JobOptions {
    fn default() -> Self {
        let c = RasterConfig::default();
        JobOptions {
            inputs: Vec::new(),
            head: None,
            threshold: ThresholdOptions::default().threshold,
            invert: false,
            flip_y: false,
            one_way: false,
            fire_order: FireOrder::After,
            density: c.density,
            origin_mm: (c.origin_x_mm, c.origin_y_mm),
            layer_height_mm: None,
            pixel_mm: None,
            dpi: None,
            heads: None,
            channels: None,
            recoat: None,
            start: None,
            end: None,
            dialect: None,
            feed_mm_min: None,
            fast_estimate: false,
        }
    }
}

impl JobOptions {
    /// The printhead profile: `head` file or the C6602 defaults, with `dialect` applied.
    pub fn profile(&self) -> Result<PrintheadProfile> {
        let mut p = load_or_default(self.head.as_ref(), PrintheadProfile::from_toml)?;
        if let Some(d) = self.dialect {
            p.dialect = d;
            // A firmware without a fire command is refused here, as in a profile.
            p.validate()?;
        }
        Ok(p)
    }

    /// The validated raster settings.
    pub fn config(&self) -> Result<RasterConfig> {
        let mut c = RasterConfig {
            origin_x_mm: self.origin_mm.0,
            origin_y_mm: self.origin_mm.1,
            layer_height_mm: self.layer_height_mm,
            serpentine: !self.one_way,
            fire_order: self.fire_order,
            density: self.density,
            ..RasterConfig::default()
        };
        if let Some(f) = self.feed_mm_min {
            c.feed_mm_min = f;
        }
        for (file, slot) in [
            (&self.start, &mut c.start_gcode),
            (&self.end, &mut c.end_gcode),
            (&self.recoat, &mut c.recoat_gcode),
        ] {
            if let Some(path) = file {
                *slot = read_text(path)?;
            }
        }
        c.validate()?;
        Ok(c)
    }

    /// Resolves the inputs and builds the job.
    pub fn job(&self) -> Result<Job> {
        let (source, heads) = self.source()?;
        self.job_from(source, heads)
    }

    /// Resolves the inputs (lists folders and globs, reads no image) into the layer source and
    /// the heads it needs, so that a caller can check the files before any is read. The
    /// numbers are checked first: the CLI's parser checked them already, Python keywords
    /// arrive here unchecked.
    pub fn source(&self) -> Result<(Source, usize)> {
        if self.pixel_mm.is_some() && self.dpi.is_some() {
            bail!("give the image resolution once: pixel size or dpi");
        }
        if let Some(px) = self.pixel_mm {
            PIXEL_MM.check("pixel_mm", px)?;
        }
        if let Some(dpi) = self.dpi {
            DPI.check("dpi", dpi)?;
        }
        if let Some(heads) = self.heads {
            HEADS.check("heads", heads)?;
        }
        THRESHOLD.check("threshold", self.threshold)?;
        let spec = InputSpec {
            inputs: self.inputs.clone(),
            heads: self.heads,
            channels: match &self.channels {
                Some(c) => parse_channels(c)?,
                None => Vec::new(),
            },
            threshold: ThresholdOptions {
                threshold: self.threshold,
                invert: self.invert,
                ..ThresholdOptions::default()
            },
            flip_y: self.flip_y,
        };
        spec.resolve()
    }

    /// Builds the job from a resolved [`JobOptions::source`]: reads the profile and snippets.
    pub fn job_from(&self, source: Source, heads: usize) -> Result<Job> {
        if matches!(source, Source::Sl1 { .. }) && (self.pixel_mm.is_some() || self.dpi.is_some()) {
            bail!("a .sl1 archive carries its own pixel size: drop the pixel size / dpi");
        }
        let profile = self.profile()?;
        if profile.recoat.is_some() && self.recoat.is_some() {
            bail!("the printhead profile's [recoat] table and --recoat both describe the recoat: give one");
        }
        Ok(Job {
            source,
            profile: with_heads(&profile, self.heads.unwrap_or(heads)),
            config: self.config()?,
            pixel_mm: self.pixel_mm.or(self.dpi.map(|d| 25.4 / d)),
            planner_estimate: !self.fast_estimate,
        })
    }

    /// Writes a nozzle test pattern (`columns` columns per nozzle address) to `target`; the
    /// profile keeps its heads unless `heads` is set.
    pub fn test_pattern(&self, target: &Target, columns: usize) -> Result<(RasterReport, PrintheadProfile)> {
        let profile = match self.heads {
            Some(h) => with_heads(&self.profile()?, h),
            None => self.profile()?,
        };
        let mut out = Output::create(target, None)?;
        let rep = test_pattern(&mut out, &profile, &self.config()?, columns)?;
        out.commit()?;
        Ok((rep, profile))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gweave::pass::Quiet;

    fn examples() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/raster")
    }

    #[test]
    fn inputs_resolve_to_heads_and_channels() {
        let layers = examples().join("layers");
        let spec = |inputs: Vec<PathBuf>, heads, channels: &str| InputSpec {
            inputs,
            heads,
            channels: if channels.is_empty() { Vec::new() } else { parse_channels(channels).unwrap() },
            ..InputSpec::default()
        };
        let (src, heads) = spec(vec![layers.clone()], None, "").resolve().unwrap();
        let Source::Stacks(s) = src else { panic!("stacks") };
        assert_eq!((heads, s.len(), s[0].paths.len()), (1, 1, 8));
        assert!(s[0].paths[7].ends_with("badge_7.bmp"));
        let (src, heads) = spec(vec![layers.join("badge_?.bmp")], None, "r,b").resolve().unwrap();
        let Source::Stacks(s) = src else { panic!("stacks") };
        assert_eq!(heads, 2);
        assert_eq!((s[0].threshold.channel, s[1].threshold.channel), (Channel::Red, Channel::Blue));
        assert_eq!(s[1].paths.len(), 8);
        let (_, heads) = spec(vec![layers.clone(), layers.clone()], Some(2), "").resolve().unwrap();
        assert_eq!(heads, 2);
        // Errors: heads without enough inputs, channel count mismatch, a .sl1 with other inputs.
        assert!(spec(vec![layers.clone()], Some(2), "").resolve().is_err());
        assert!(spec(vec![layers.clone()], Some(3), "r,b").resolve().is_err());
        assert!(spec(vec![PathBuf::from("a.sl1"), layers], None, "").resolve().is_err());
        assert!(parse_channels("r,x").is_err());
        let sl1 = Path::new(env!("CARGO_MANIFEST_DIR")).join("../gweave/tests/data/raster/sphere.sl1");
        let with_dpi = JobOptions { inputs: vec![sl1.clone()], dpi: Some(300.0), ..JobOptions::default() };
        assert!(with_dpi.job().is_err());
        let job = JobOptions { inputs: vec![sl1], ..JobOptions::default() }.job().unwrap();
        assert!(matches!(job.source, Source::Sl1 { .. }));
        assert_eq!(job.profile.heads.len(), 1);
    }

    #[test]
    fn streamed_estimate_equals_estimating_the_written_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("badge.gcode");
        let options = JobOptions {
            inputs: vec![examples().join("layers")],
            flip_y: true,
            density: 2,
            ..JobOptions::default()
        };
        let rep = options.job().unwrap().run(&Target::File(out.clone()), &mut Quiet).unwrap();
        let whole =
            gweave_sim::estimate(std::fs::File::open(&out).unwrap(), &MotionProfile::default()).unwrap();
        assert_eq!(rep.time.method, "planner");
        assert_eq!(rep.time.motion_s, whole.total_s);
        // 844 inked columns, each fired twice at >= 800 us.
        assert_eq!(rep.raster.fire_commands, 2 * 844);
        assert!((rep.time.fire_s - 2.0 * 844.0 * 800e-6).abs() < 1e-12);
        assert_eq!(rep.images_read, 8);
        // The planner's time exceeds the feed-rate bound: every column starts and stops.
        let fast = JobOptions { fast_estimate: true, ..options }.job().unwrap();
        let rep_fast = fast.run(&Target::File(out), &mut Quiet).unwrap();
        assert_eq!(rep_fast.time.method, "feed");
        assert!(rep.time.total_s > rep_fast.time.total_s, "{:?} {:?}", rep.time, rep_fast.time);
    }

    #[test]
    fn writer_splits_lines_across_chunks() {
        let text = b"G1 X10 F600\nM400\nG1 X20\nG1 Y5\nM400\n";
        let mut w = EstimatingWriter {
            inner: Vec::new(),
            est: Some(Estimator::new(&MotionProfile::default()).unwrap()),
            partial: Vec::new(),
            error: None,
        };
        for chunk in text.chunks(3) {
            w.write_all(chunk).unwrap();
        }
        assert_eq!(w.inner, text);
        assert!(w.partial.is_empty());
        let chunked = w.est.take().unwrap().finish();
        let whole = gweave_sim::estimate(&text[..], &MotionProfile::default()).unwrap();
        assert_eq!(chunked, whole);
        assert!(whole.total_s > 2.0, "{whole:?}");
    }
}
