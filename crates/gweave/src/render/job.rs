//! `gweave preview` as both front ends run it (`gweave.preview()`): its options declared once
//! ([`crate::options`]), the files they name read, the picture drawn and written, in one
//! function, so that the command line and Python read an option alike. They had drifted:
//! Python wrote its picture in place (a failed write left half a file) where the command line
//! writes a temporary file and renames it; Python checked `layer` against `layers` itself, with
//! its own message; `size` was checked twice with two messages.

use std::io::Write;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use super::{
    parse_layer_range, preview_with_progress, ColourBy, Format, MixColours, Preview, PreviewSettings,
    RenderError, ViewKind, ViewOptions, MIN_LEN_MM, PICTURE_SIDE_PX,
};
use crate::colour::Srgb8;
use crate::gen::printhead::PrintheadProfile;
use crate::options::{
    whole, JobFailure, JobOptions, Kind, OptionError, OptionField, Problem, Shape, Spelling, Value,
};
use crate::pass::{Progress, Strictness};
use crate::post::mix::profile::MixProfile;
use crate::range::{Range, LAYER_NUMBER};
use crate::rotary::cylinder::{RotaryConfig, MANDREL_DIAMETER_MM};

/// A layer number's range, as an option's (a number of the command line or of Python).
const LAYER: Range = Range::new(LAYER_NUMBER.min as f64, LAYER_NUMBER.max as f64, "");
/// A picture side's range, as an option's.
const SIDE_PX: Range = Range::new(PICTURE_SIDE_PX.min as f64, PICTURE_SIDE_PX.max as f64, "px");
/// The merge length's range, as an option's.
const MERGE_MM: Range = Range::new(MIN_LEN_MM.min as f64, MIN_LEN_MM.max as f64, "mm");

crate::text_option!(ViewKind);
crate::text_option!(ColourBy, default);
crate::text_option!(Format);

crate::job_options! {
    /// What `gweave preview` is given besides its file, where the picture goes, and whether
    /// to read past malformed lines.
    pub struct PreviewOptions for "preview" {
        /// png, svg or html (default: from the extension of -o; needed with `-o -`).
        format: Option<Format> = Shape::new("FORMAT"),
        /// Draw only this layer (0-based) [default: every layer].
        layer: Option<u32> = Shape::new("N").range(LAYER).conflicts(&["layers"]),
        /// Draw this layer range, inclusive, e.g. 10-20 [default: every layer].
        layers: Option<RangeInclusive<u32>> = Shape::new("A-B"),
        /// top (from above) or iso (isometric 3D); default: top for pictures, iso for the HTML
        /// page.
        view: Option<ViewKind> = Shape::new("VIEW"),
        /// tool, feature, speed, layer or mix (the colour each move is predicted to print, from
        /// the file's mixing commands, the filaments of --mix-profile and its chamber's washout).
        colour_by: ColourBy = Shape::new("COLOUR_BY").aliases(&["color-by"]),
        /// Picture size in pixels, WIDTHxHEIGHT.
        size: PictureSize = Shape::new("WIDTHxHEIGHT").range(SIDE_PX).separator('x'),
        /// Compare with this file (e.g. the output of a transform): changed moves are
        /// highlighted.
        compare: Option<PathBuf> = Shape::new("B"),
        /// Colours of tools 0, 1, ... as #rrggbb, comma separated, for --colour-by tool
        /// [default: eight colours told apart with any colour vision].
        tool_colours: Option<Vec<String>> = Shape::new("COLOURS").aliases(&["tool-colors"]),
        /// A `gweave mix` profile: the filament colours of its inputs and its mixing chamber
        /// (purge.chamber_mm3, dead_mm3) for --colour-by mix (default: cyan, magenta, yellow,
        /// white).
        mix_profile: Option<PathBuf> = Shape::new("PROFILE.toml"),
        /// Draw the file as a rotary program on a mandrel of this diameter, mm (axes X along, A
        /// around in degrees, Z away from it). Not needed for `gweave rotary` output: its header
        /// names the machine [default: the file's gweave header, else a flat print].
        mandrel_diameter: Option<f64> = Shape::new("MM").range(MANDREL_DIAMETER_MM),
        /// Printhead profile of binder-jet raster output (TOML, as for `gweave raster --head`;
        /// default: HP C6602, 12 nozzles at 96 dpi): its fire commands are drawn as drops.
        head: Option<PathBuf> = Shape::new("PROFILE.toml"),
        /// Draw travel moves too.
        travel: bool = Shape::new(""),
        /// Merge chained moves shorter than this, mm (default: 0, or 0.2 for files over 32 MB).
        min_len: Option<f64> = Shape::new("MM").range(MERGE_MM),
    }
}

/// A picture's width and height in pixels, each within [`PICTURE_SIDE_PX`]; 1200 x 900 unless
/// asked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PictureSize {
    /// Width, px.
    pub width_px: u32,
    /// Height, px.
    pub height_px: u32,
}

impl Default for PictureSize {
    fn default() -> Self {
        PictureSize { width_px: 1200, height_px: 900 }
    }
}

impl OptionField for PictureSize {
    const KIND: Kind = Kind::Numbers(2);
    fn from_value(value: Value) -> Result<Self, Problem> {
        match value {
            Value::Numbers(v) => match v[..] {
                [w, h] => Ok(PictureSize { width_px: whole(w)?, height_px: whole(h)? }),
                _ => Err(Problem::Count { expected: 2, got: v.len(), value_name: "WIDTHxHEIGHT" }),
            },
            other => Err(Problem::Invalid(format!("{other:?}"))),
        }
    }
    fn to_value(&self) -> Option<Value> {
        Some(Value::Numbers(vec![f64::from(self.width_px), f64::from(self.height_px)]))
    }
}

/// A layer range `A-B` (inclusive, each a layer number), as `--layers` and `layers=` give it.
impl OptionField for Option<RangeInclusive<u32>> {
    const KIND: Kind = Kind::Text;
    fn from_value(value: Value) -> Result<Self, Problem> {
        match value {
            Value::Text(t) => parse_layer_range(&t).map(Some).map_err(Problem::Invalid),
            other => Err(Problem::Invalid(format!("{other:?}"))),
        }
    }
    fn to_value(&self) -> Option<Value> {
        self.as_ref().map(|r| Value::Text(format!("{}-{}", r.start(), r.end())))
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Format::Png => "png",
            Format::Svg => "svg",
            Format::Html => "html",
        })
    }
}

/// Why a preview job failed.
#[derive(Debug, thiserror::Error)]
pub enum PreviewJobError {
    /// An option's value refused.
    #[error(transparent)]
    Option(#[from] OptionError),
    /// A settings file an option names (the mix profile, the printhead) cannot be read.
    #[error(transparent)]
    Read(crate::Error),
    /// A settings file an option names cannot be read as such settings.
    #[error("{}: {message}", path.display())]
    Settings {
        /// The file.
        path: PathBuf,
        /// What is wrong with it, its causes joined.
        message: String,
    },
    /// The output's extension names no format (and none was asked).
    #[error("output: {0}")]
    Output(RenderError),
    /// The file cannot be drawn (or read).
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The picture cannot be written.
    #[error(transparent)]
    Write(crate::Error),
}

impl JobFailure for PreviewJobError {
    /// The message, an option named as `spelling` names it (`--layer`, `layer`).
    fn spelled(&self, spelling: Spelling) -> String {
        match self {
            PreviewJobError::Option(e) => e.spelled(spelling),
            e => e.to_string(),
        }
    }

    fn refused_file(&self) -> Option<(&Path, &std::io::Error)> {
        match self {
            PreviewJobError::Read(e)
            | PreviewJobError::Write(e)
            | PreviewJobError::Render(RenderError::Gcode(e)) => e.refused_file(),
            _ => None,
        }
    }
}

/// A settings file named by an option, read with `parse`.
fn settings<T, E: std::error::Error + 'static>(
    path: &Path,
    parse: impl FnOnce(&str) -> Result<T, E>,
) -> Result<T, PreviewJobError> {
    let text =
        crate::settings::read_text(path).map_err(|e| PreviewJobError::Read(crate::Error::io(path, e)))?;
    parse(&text).map_err(|e| PreviewJobError::Settings {
        path: path.to_path_buf(),
        message: crate::error::with_causes(&e),
    })
}

/// The picture's format: as asked, else the output's extension, else PNG (Python's bytes, with
/// no file named).
pub fn format_of(options: &PreviewOptions, output: Option<&Path>) -> Result<Format, RenderError> {
    match (options.format, output) {
        (Some(format), _) => Ok(format),
        (None, Some(path)) => Format::from_path(path),
        (None, None) => Ok(Format::Png),
    }
}

/// Draws `input` as the options ask and, when `output` names a file (not `-`), writes it there
/// (a temporary file renamed into place once whole); returns the bytes and the report.
pub fn preview(
    options: &PreviewOptions,
    input: &Path,
    output: Option<&Path>,
    strictness: Strictness,
    progress: &mut dyn Progress,
) -> Result<Preview, PreviewJobError> {
    options.check_conflicts()?;
    let format = format_of(options, output).map_err(PreviewJobError::Output)?;
    let tool_colours = options
        .tool_colours
        .iter()
        .flatten()
        .map(|c| {
            c.trim().parse::<Srgb8>().map_err(|e| OptionError {
                option: "tool_colours",
                problem: Problem::Invalid(format!("{}: {e}", c.trim())),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mix = match &options.mix_profile {
        Some(path) => {
            let profile = settings(path, MixProfile::from_toml_str)?;
            let colours = MixColours::from_profile(&profile).map_err(|e| PreviewJobError::Settings {
                path: path.clone(),
                message: crate::error::with_causes(&e),
            })?;
            Some(colours)
        }
        None => None,
    };
    let printhead =
        options.head.as_deref().map(|path| settings(path, PrintheadProfile::from_toml)).transpose()?;
    let settings = PreviewSettings {
        view: ViewOptions {
            kind: options.view.unwrap_or(format.default_view()),
            layers: options.layer.map(|l| l..=l).or(options.layers.clone()),
            width_px: options.size.width_px,
            height_px: options.size.height_px,
            colour_by: options.colour_by,
            tool_colours,
            travel: options.travel,
            ..ViewOptions::default()
        },
        min_len_mm: options.min_len.map(|mm| mm as f32),
        mix,
        rotary: options.mandrel_diameter.map(RotaryConfig::new),
        printhead,
        strictness,
    };
    let preview = preview_with_progress(input, options.compare.as_deref(), format, &settings, progress)?;
    if let Some(path) = output.filter(|p| *p != Path::new("-")) {
        crate::gcode::writer::write_file(path, |out| {
            out.write_all(&preview.bytes).map_err(|e| crate::Error::io(path, e))
        })
        .map_err(PreviewJobError::Write)?;
    }
    Ok(preview)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_size_is_two_whole_numbers_within_the_picture_range() {
        let size = PreviewOptions::spec("size").unwrap();
        assert_eq!((size.default)().as_deref(), Some("1200x900"));
        let mut o = PreviewOptions::default();
        o.set(size, size.parse("640x480").unwrap()).unwrap();
        assert_eq!(o.size, PictureSize { width_px: 640, height_px: 480 });
        assert_eq!(o.header(), "--size 640x480");
        let err = o.set(size, Value::Numbers(vec![-1.0, 5.0])).unwrap_err();
        assert_eq!(err.spelled(Spelling::Keyword), "size = -1 is out of range: 16 to 16384 px");
        let err = o.set(size, Value::Numbers(vec![100.5, 50.0])).unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), "--size: 100.5 is not a whole number");
    }

    #[test]
    fn layer_and_layers_exclude_each_other_and_a_range_reads_as_the_cli_reads_it() {
        let mut o = PreviewOptions::default();
        let layers = PreviewOptions::spec("layers").unwrap();
        o.set(layers, Value::Text("3-4".into())).unwrap();
        assert_eq!(o.layers, Some(3..=4));
        let err = o.set(layers, Value::Text("9-3".into())).unwrap_err();
        assert_eq!(err.spelled(Spelling::Keyword), "layers: empty layer range 9-3");
        o.layer = Some(2);
        let err = o.check_conflicts().unwrap_err();
        assert_eq!(err.spelled(Spelling::Flag), "--layer and --layers: give one of them");
    }

    #[test]
    fn the_format_is_asked_or_the_outputs_or_png() {
        let mut o = PreviewOptions::default();
        assert_eq!(format_of(&o, None).unwrap(), Format::Png);
        assert_eq!(format_of(&o, Some(Path::new("a.SVG"))).unwrap(), Format::Svg);
        assert!(format_of(&o, Some(Path::new("a.jpg"))).is_err());
        o.format = Some(Format::Html);
        assert_eq!(format_of(&o, Some(Path::new("-"))).unwrap(), Format::Html);
    }
}
