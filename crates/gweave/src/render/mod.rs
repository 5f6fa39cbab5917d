//! Pictures of what a file prints: `gweave preview`, and the drawing tools other commands use.
//!
//! - `toolpath`: the segments of a file (start, end, tool, feature, feed, layer, extruding),
//!   collected in one streaming pass, with decimation for huge files.
//! - [`colour_by`]: colour by tool, feature type, speed, layer or predicted mix colour.
//! - `mix_colour`: the predicted mix colour of each move (mixing model and chamber washout).
//! - [`view`]: top view of a layer or layer range, isometric view, before/after comparison;
//!   turns segments into pixel [`view::Stroke`]s.
//! - [`png_out`]: a drawing as pixels, painted front to back with [`crate::picture`]'s
//!   rasteriser (`tiny-skia`), skipping the strokes that the ones in front hide (`cull`) or
//!   that are past an ink budget.
//! - [`svg`]: the same drawing as SVG paths.
//! - [`job`]: `gweave preview` as both front ends run it, its options declared once.
//! - `html`: a self-contained interactive viewer page (the beads as lit 3D tubes, WebGL 2),
//!   of one file or two compared side by side.
//!
//! Binder-jet raster output (`gweave raster`) draws the drops of each layer
//! (`toolpath` decodes the fire commands with [`PreviewSettings::printhead`]).
//!
//! Rotary programs (`gweave rotary wrap`/`tube` output, whose header names the machine, or any
//! file with [`PreviewSettings::rotary`]) go through the same toolpath pass, each move's machine
//! words read back on the cylinder ([`crate::rotary::preview::RotaryReading`]), and are drawn in
//! 3D there, in the pictures and in the viewer, with the same colourings, travel and bounded
//! memory as flat files; so are the `--preview` pictures of `gweave rotary wrap` and `tube`
//! ([`crate::wrap_file`], [`crate::tube_file`]).
//!
//! ```no_run
//! use gweave::render::{preview, Format, PreviewSettings};
//! let png = preview("part.gcode".as_ref(), None, Format::Png, &PreviewSettings::default()).unwrap();
//! std::fs::write("part.png", png).unwrap();
//! ```

pub mod card;
pub mod colour_by;
mod cull;
pub(crate) mod html;
pub mod job;
pub(crate) mod legend;
pub(crate) mod mix_colour;
pub mod png_out;
pub mod svg;
pub(crate) mod toolpath;
pub mod view;

use std::io::{self, Write};
use std::path::Path;

use serde::Serialize;

use crate::gcode::state::State;
use crate::gen::printhead::PrintheadProfile;
use crate::malformed::Malformed;
use crate::pass::{Counting, Ctx, Pass, PassError, Progress, Quiet, Step, Strictness};
use crate::range::Range;
use crate::rotary::cylinder::RotaryConfig;
use crate::rotary::preview::RotaryReading;
use crate::run::Run;
use crate::stats::{Stats, StatsPass};

pub use colour_by::ColourBy;
pub use mix_colour::MixColours;
pub use toolpath::{Segment, Toolpath, ToolpathOptions};
pub use view::{ViewKind, ViewOptions};

/// Why a preview could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The G-code cannot be read.
    #[error(transparent)]
    Gcode(#[from] crate::Error),
    /// A picture size outside [`PICTURE_SIDE_PX`].
    #[error("picture size {0}x{1} is out of range: {PICTURE_SIDE_PX} on each side")]
    Size(u32, u32),
    /// An option outside its range.
    #[error(transparent)]
    Range(#[from] crate::range::OutOfRange),
    /// An output format other than png, svg or html.
    #[error("unknown output format {0:?} (png, svg or html)")]
    Format(String),
    /// The image encoder failed.
    #[error("image encoding failed: {0}")]
    Encode(String),
    /// A rotary file cannot be read back.
    #[error(transparent)]
    Rotary(#[from] crate::rotary::RotaryError),
    /// `--layer`/`--layers` start past the file's last layer (a blank picture says nothing).
    #[error("{}", no_such_layer(*first, *last))]
    NoSuchLayer {
        /// The first layer asked for.
        first: u32,
        /// The file's last layer, from 0; `None` when it has none.
        last: Option<u32>,
    },
}

fn no_such_layer(first: u32, last: Option<u32>) -> String {
    match last {
        Some(last) => format!("layer {first} is past the file's last layer, {last} (layers count from 0)"),
        None => format!("layer {first}: the file has no layers to draw"),
    }
}

/// Refuses a layer range that starts past the last of `layers` layers.
fn check_layers(options: &PreviewSettings, layers: u32) -> Result<(), RenderError> {
    match &options.view.layers {
        Some(asked) if *asked.start() >= layers => {
            Err(RenderError::NoSuchLayer { first: *asked.start(), last: layers.checked_sub(1) })
        }
        _ => Ok(()),
    }
}

/// What the preview is written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// A PNG picture.
    Png,
    /// An SVG picture.
    Svg,
    /// An HTML page with an interactive 3D view.
    Html,
}

impl Format {
    /// From an output file's extension.
    pub fn from_path(path: &Path) -> Result<Format, RenderError> {
        path.extension().and_then(|e| e.to_str()).unwrap_or("").parse()
    }

    /// The view a preview opens on when none is asked for: a layer from the top for pictures,
    /// the whole part in 3D for the viewer page.
    pub fn default_view(self) -> ViewKind {
        match self {
            Format::Html => ViewKind::Iso,
            Format::Png | Format::Svg => ViewKind::Top,
        }
    }
}

impl std::str::FromStr for Format {
    type Err = RenderError;

    /// From a name (`png`, `svg`, `html`), as `--format` or an extension gives it.
    fn from_str(name: &str) -> Result<Format, RenderError> {
        let name = name.to_ascii_lowercase();
        match name.as_str() {
            "png" => Ok(Format::Png),
            "svg" => Ok(Format::Svg),
            "html" | "htm" => Ok(Format::Html),
            _ => Err(RenderError::Format(name)),
        }
    }
}

/// Width and height of a picture.
pub const PICTURE_SIDE_PX: Range<u32> = Range::new(16, 16_384, "px");
/// Merge length of chained moves (0: keep every move; 100 mm is a whole bed in a few strokes).
pub const MIN_LEN_MM: Range<f32> = Range::new(0.0, 100.0, "mm");

/// Everything `gweave preview` can be asked.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PreviewSettings {
    /// What to draw and how.
    pub view: ViewOptions,
    /// Merge chained moves shorter than this, mm; `None` picks by file size
    /// ([`ToolpathOptions::min_len_for_file_size`]).
    pub min_len_mm: Option<f32>,
    /// Mixing hardware for the `mix` colouring (default: [`MixColours::cmyw`]).
    pub mix: Option<MixColours>,
    /// Draw the file as a rotary program on this machine's cylinder (default: the machine its
    /// header names, [`RotaryConfig::from_header`], if any).
    pub rotary: Option<RotaryConfig>,
    /// The inkjet head of binder-jet raster output, whose fire commands are drawn as dots
    /// (default: the HP C6602, as `gweave raster` assumes).
    pub printhead: Option<PrintheadProfile>,
    /// Stop at the first malformed line (the default), or draw past them and count them
    /// ([`PreviewReport::malformed`]).
    pub strictness: Strictness,
}

impl PreviewSettings {
    fn check(&self) -> Result<(), RenderError> {
        let (w, h) = (self.view.width_px, self.view.height_px);
        if !(PICTURE_SIDE_PX.contains(w) && PICTURE_SIDE_PX.contains(h)) {
            return Err(RenderError::Size(w, h));
        }
        if let Some(m) = self.min_len_mm {
            MIN_LEN_MM.check("min_len_mm", m)?;
        }
        Ok(())
    }

    fn toolpath_options(&self, path: &Path, keep_all_layers: bool) -> Result<ToolpathOptions, RenderError> {
        let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        let rotary = RotaryReading::for_file(path, self.rotary.as_ref())?;
        Ok(ToolpathOptions {
            // The viewer shows every layer; pictures need only theirs.
            layers: if keep_all_layers { None } else { self.view.layers.clone() },
            travel: keep_all_layers || self.view.travel,
            min_len_mm: self.min_len_mm.unwrap_or_else(|| ToolpathOptions::min_len_for_file_size(bytes)),
            max_segments: Some(MAX_SEGMENTS),
            // The viewer page offers every colouring, mix included, whichever it opens on.
            mix: (keep_all_layers || self.view.colour_by == ColourBy::Mix)
                .then(|| self.mix.clone().unwrap_or_else(MixColours::cmyw)),
            printhead: self.printhead.clone().unwrap_or_default(),
            rotary,
            ..ToolpathOptions::default()
        })
    }
}

/// The most segments a picture or viewer keeps (80 MB, 140 MB with their strokes): twice the
/// pixels of a 1200 x 900 picture, so a file of any size is drawn in bounded memory and loses only
/// detail finer than a pixel or two (see [`ToolpathOptions::max_segments`]).
pub(crate) const MAX_SEGMENTS: usize = 1 << 21;

/// Feeds every line to two passes (a toolpath and the statistics, or a rotary program's figures,
/// in one read of the file).
pub(crate) struct Both<'a>(pub(crate) &'a mut dyn Pass, pub(crate) &'a mut dyn Pass);

impl Pass for Both<'_> {
    fn line(&mut self, ctx: &Ctx<'_>, out: &mut dyn Write) -> Step {
        self.0.line(ctx, &mut io::sink())?;
        self.1.line(ctx, out)
    }
    fn finish(&mut self, state: &State, out: &mut dyn Write) -> Result<(), PassError> {
        self.0.finish(state, &mut io::sink())?;
        self.1.finish(state, out)
    }
}

/// A layer range as `--layers` and Python's `layers=` take it: `A-B`, inclusive, 0-based, each
/// within [`LAYER_NUMBER`](crate::range::LAYER_NUMBER).
pub fn parse_layer_range(text: &str) -> Result<std::ops::RangeInclusive<u32>, String> {
    let (a, b) = text.split_once('-').ok_or_else(|| format!("expected A-B, got {text:?}"))?;
    let layer = |n: &str| -> Result<u32, String> {
        let v: u32 = n.trim().parse().map_err(|e| format!("layer {}: {e}", n.trim()))?;
        crate::range::LAYER_NUMBER.check("layer", v).map_err(|e| e.to_string())
    };
    layer_range(layer(a)?, layer(b)?)
}

/// `first..=last`, refused when empty.
pub fn layer_range(first: u32, last: u32) -> Result<std::ops::RangeInclusive<u32>, String> {
    if first > last {
        return Err(format!("empty layer range {first}-{last}"));
    }
    Ok(first..=last)
}

/// Collects a file's toolpath and statistics in one pass.
pub fn toolpath_with_stats(
    path: &Path,
    options: ToolpathOptions,
    strictness: Strictness,
    progress: &mut dyn Progress,
) -> crate::Result<(Toolpath, Stats, Malformed)> {
    let mut tp = toolpath::ToolpathPass::new(options);
    let mut st = StatsPass::new(None);
    let mut both = Counting::new(Both(&mut tp, &mut st));
    let state = Run::file(path).progress(progress).strictness(strictness).scan(&mut both)?;
    let malformed = both.malformed;
    Ok((tp.finish_toolpath(), st.into_stats(&state), malformed))
}

/// The preview of `path` (compared with `compare` when given) in `format`, as file bytes.
pub fn preview(
    path: &Path,
    compare: Option<&Path>,
    format: Format,
    options: &PreviewSettings,
) -> Result<Vec<u8>, RenderError> {
    preview_with_progress(path, compare, format, options, &mut Quiet).map(|p| p.bytes)
}

/// A preview's file bytes and what they show.
pub struct Preview {
    /// The file's contents.
    pub bytes: Vec<u8>,
    /// What it shows.
    pub report: PreviewReport,
}

/// What a preview shows, for `gweave preview`'s summary and `--json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PreviewReport {
    /// `png`, `svg` or `html`.
    pub format: &'static str,
    /// Size of the file, bytes.
    pub bytes: usize,
    /// `top` or `iso`.
    pub view: String,
    /// The colouring's name.
    pub colour_by: &'static str,
    /// Picture size (for HTML, the initial canvas), pixels.
    pub width_px: u32,
    /// Picture height, pixels.
    pub height_px: u32,
    /// Layers drawn, first and last, as the file numbers them (HTML: all, with a slider).
    pub layers_drawn: Option<[u32; 2]>,
    /// Lines drawn in the picture (PNG, SVG), after merging short chained moves; binder-jet
    /// drops count one each.
    pub strokes: Option<usize>,
    /// Moves the page holds (HTML).
    pub moves: Option<usize>,
    /// With `--compare`: the moves of the first file the second does not have, and the reverse.
    pub changed_moves: Option<[usize; 2]>,
    /// What each colour stands for.
    pub legend: Vec<colour_by::LegendEntry>,
    /// Lines a lenient read went past (in both files, with `--compare`; the first is the
    /// first file's, else the second's).
    #[serde(flatten)]
    pub malformed: Malformed,
}

impl PreviewReport {
    fn new(format: Format, bytes: usize, options: &PreviewSettings) -> Self {
        PreviewReport {
            format: match format {
                Format::Png => "png",
                Format::Svg => "svg",
                Format::Html => "html",
            },
            bytes,
            view: options.view.kind.to_string(),
            colour_by: options.view.colour_by.name(),
            width_px: options.view.width_px,
            height_px: options.view.height_px,
            layers_drawn: None,
            strokes: None,
            moves: None,
            changed_moves: None,
            legend: Vec::new(),
            malformed: Malformed::default(),
        }
    }
}

/// [`preview`], reporting the progress of reading and then drawing, with what the preview shows.
pub fn preview_with_progress(
    path: &Path,
    compare: Option<&Path>,
    format: Format,
    options: &PreviewSettings,
    progress: &mut dyn Progress,
) -> Result<Preview, RenderError> {
    options.check()?;
    if format == Format::Html {
        return html_page(path, compare, options, progress);
    }
    let (d, malformed) = drawing_counted(path, compare, options, progress)?;
    let bytes = match format {
        Format::Svg => svg::write_svg(&d).into_bytes(),
        _ => crate::picture::encode(&png_out::rasterise_with_progress(&d, progress))
            .map_err(|e| RenderError::Encode(e.to_string()))?,
    };
    let changed: Vec<usize> = d.panels.iter().filter_map(|p| p.changed_moves).collect();
    let report = PreviewReport {
        layers_drawn: d.layers_drawn.as_ref().map(|r| [*r.start(), *r.end()]),
        strokes: Some(d.strokes.len()),
        changed_moves: <[usize; 2]>::try_from(changed).ok(),
        legend: d.legend,
        malformed,
        ..PreviewReport::new(format, bytes.len(), options)
    };
    Ok(Preview { bytes, report })
}

/// The picture of one file, or of two compared.
pub fn drawing(
    path: &Path,
    compare: Option<&Path>,
    options: &PreviewSettings,
    progress: &mut dyn Progress,
) -> Result<view::Drawing, RenderError> {
    drawing_counted(path, compare, options, progress).map(|(d, _)| d)
}

/// [`drawing`] and the malformed lines a lenient read went past, over both files.
fn drawing_counted(
    path: &Path,
    compare: Option<&Path>,
    options: &PreviewSettings,
    progress: &mut dyn Progress,
) -> Result<(view::Drawing, Malformed), RenderError> {
    let mut malformed = Malformed::default();
    let mut read = |p: &Path| -> Result<Toolpath, RenderError> {
        let mut pass = Counting::new(toolpath::ToolpathPass::new(options.toolpath_options(p, false)?));
        Run::file(p).progress(&mut *progress).strictness(options.strictness).scan(&mut pass)?;
        malformed.merge(pass.malformed);
        Ok(pass.pass.finish_toolpath())
    };
    let before = read(path)?;
    let drawn = match compare {
        Some(other) => {
            let after = read(other)?;
            check_layers(options, before.layer_count().max(after.layer_count()))?;
            view::draw_compare(&before, &after, &options.view)
        }
        None => {
            check_layers(options, before.layer_count())?;
            view::draw(&before, &options.view)
        }
    };
    Ok((drawn, malformed))
}

fn html_page(
    path: &Path,
    compare: Option<&Path>,
    options: &PreviewSettings,
    progress: &mut dyn Progress,
) -> Result<Preview, RenderError> {
    let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut malformed = Malformed::default();
    let mut read = |p: &Path| -> Result<(Toolpath, Stats), RenderError> {
        let (tp, stats, m) =
            toolpath_with_stats(p, options.toolpath_options(p, true)?, options.strictness, &mut *progress)?;
        malformed.merge(m);
        Ok((tp, stats))
    };
    let mut read_files = vec![(path, read(path)?)];
    if let Some(other) = compare {
        read_files.push((other, read(other)?));
    }
    let changed = match &read_files[..] {
        [(_, (a, _)), (_, (b, _))] => vec![Some(view::changed_moves(a, b)), Some(view::changed_moves(b, a))],
        _ => vec![None],
    };
    let changed_moves = <[usize; 2]>::try_from(
        changed.iter().flatten().map(|c| c.iter().filter(|&&c| c).count()).collect::<Vec<_>>(),
    )
    .ok();
    let files: Vec<html::HtmlFile<'_>> = read_files
        .iter()
        .zip(changed)
        .map(|((p, (tp, stats)), changed)| html::HtmlFile {
            name: name(p),
            toolpath: tp,
            stats: Some(stats),
            changed,
        })
        .collect();
    let title = files.iter().map(|f| f.name.as_str()).collect::<Vec<_>>().join(" vs ");
    let layers = files.iter().map(|f| f.toolpath.layer_count()).max().unwrap_or(0);
    check_layers(options, layers)?;
    // The range the page opens on, as the pictures clip it; the reader can widen it.
    let layers_drawn = view::layers_drawn(&options.view, layers).map(|r| [*r.start(), *r.end()]);
    let html_options = html::HtmlOptions {
        title,
        colour_by: options.view.colour_by,
        view: options.view.kind,
        layers: layers_drawn.filter(|_| options.view.layers.is_some()),
        tool_colours: options.view.tool_colours.clone(),
    };
    let bytes = html::write_html(&files, &html_options).into_bytes();
    let toolpaths: Vec<&Toolpath> = files.iter().map(|f| f.toolpath).collect();
    let colouring =
        colour_by::Colouring::new(options.view.colour_by, options.view.tool_colours.clone(), &toolpaths);
    let report = PreviewReport {
        layers_drawn,
        moves: Some(toolpaths.iter().map(|tp| tp.segments.len()).sum()),
        changed_moves,
        legend: colouring.legend(&toolpaths),
        malformed,
        ..PreviewReport::new(Format::Html, bytes.len(), options)
    };
    Ok(Preview { bytes, report })
}
