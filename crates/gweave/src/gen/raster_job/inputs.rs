//! The inputs of a raster job: folders, globs, image files or one `.sl1`, resolved into the
//! layer images each head prints.

use std::path::{Path, PathBuf};

use super::{JobError, Result};
use crate::gen::bitmap::{Channel, ThresholdOptions};
use crate::gen::image_files::list_images;
use crate::gen::raster;

/// Where the layer images of a job come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// One image stack per head (stack `h` printed by head `h`), each with its channel.
    Stacks(Vec<raster::ImageStack>),
    /// A PrusaSlicer SLA archive, printed by head 0.
    Sl1 {
        /// The archive.
        path: PathBuf,
        /// How its layer images become binder pixels.
        threshold: ThresholdOptions,
    },
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
    /// How a pixel becomes binder (the channel is each stack's own).
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
                other => invalid!("unknown channel {other:?} (use r, g, b or luma)"),
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
            invalid!("no input: give a folder, a glob, image files, or a .sl1 archive");
        }
        if self.inputs.iter().any(|p| is_sl1(p)) {
            if self.inputs.len() != 1 || !self.channels.is_empty() || self.heads.unwrap_or(1) > 1 {
                invalid!("a .sl1 archive is printed alone by one head (no other inputs, heads or channels)");
            }
            return Ok((Source::Sl1 { path: self.inputs[0].clone(), threshold: self.threshold }, 1));
        }
        let expand = |p: &PathBuf| -> Result<Vec<PathBuf>> {
            if p.is_dir() || is_glob(p) {
                Ok(list_images(p)?)
            } else if p.is_file() {
                Ok(vec![p.clone()])
            } else {
                invalid!("{}: no such file or folder", p.display())
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
                invalid!(
                    "{} channels given for {heads} heads: give one channel per head",
                    self.channels.len()
                );
            }
            let paths = all()?;
            let stacks = self.channels.iter().map(|&c| stack(paths.clone(), c)).collect();
            return Ok((Source::Stacks(stacks), heads));
        }
        match self.heads {
            Some(h) if h > 1 => {
                if self.inputs.len() != h {
                    invalid!("{h} heads need {h} inputs (one folder or glob per head) or --channels");
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gen::raster_job::{RasterOptions, Setup};

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
        let sl1 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/raster/sphere.sl1");
        let with_dpi =
            Setup::new(vec![sl1.clone()], RasterOptions { dpi: Some(300.0), ..RasterOptions::default() });
        assert!(with_dpi.job().is_err());
        let job = Setup::new(vec![sl1], RasterOptions::default()).job().unwrap();
        assert!(matches!(job.source, Source::Sl1 { .. }));
        assert_eq!(job.profile.heads.len(), 1);
    }
}
