//! `gweave preview`: a picture (PNG, SVG) or an interactive page (HTML) of what a file prints.

use std::io::{self, Write};
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::colour::Srgb8;
use gweave::gen::printhead::PrintheadProfile;
use gweave::post::mix::profile::MixProfile;
use gweave::range::LAYER_NUMBER;
use gweave::render::{
    parse_layer_range, preview_with_progress, ColourBy, Format, MixColours, PreviewOptions, PreviewReport,
    ViewKind, ViewOptions, MIN_LEN_MM, PICTURE_SIDE_PX,
};
use gweave::rotary::cylinder::{RotaryConfig, MANDREL_DIAMETER_MM};

use crate::args::Lenient;
use crate::common::{in_range, load, print_malformed, print_summary, write_bytes, ReportArgs};
use crate::files::Files;

/// Draw a file: top view of a layer, isometric view of the print, or a before/after comparison.
///
/// The output format follows the extension of -o: `.png` and `.svg` are pictures, `.html` is one
/// self-contained page (no network): the beads as lit 3D tubes (WebGL), opening on an isometric
/// view of the whole part, with orbit, pan, zoom, top view, a layer range, legend and stats; with
/// --compare, the two files side by side, the moves each has that the other has not in colour.
/// `-o - --format png` writes the picture to standard output (and the summary to standard
/// error); `-` as INPUT reads standard input.
/// Layers are numbered from 0 as the core counts them (Cura's `;LAYER:n`).
/// Examples: `gweave preview part.gcode -o part.png --layer 12`,
/// `gweave preview part.gcode -o part.png --view iso --colour-by feature`,
/// `gweave preview before.gcode --compare after.gcode -o diff.png --layers 10-20`.
#[derive(Args, Debug)]
pub struct PreviewArgs {
    /// The G-code file to draw.
    pub input: PathBuf,
    /// Output file: .png, .svg or .html; `-` for standard output (with --format).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// png, svg or html (default: from the extension of -o; needed with `-o -`).
    #[arg(long, value_name = "FORMAT", value_parser = |s: &str| s.parse::<Format>())]
    pub format: Option<Format>,
    /// Draw only this layer (0-based) [default: every layer].
    #[arg(long, value_name = "N", conflicts_with = "layers", value_parser = in_range(LAYER_NUMBER))]
    pub layer: Option<u32>,
    /// Draw this layer range, inclusive, e.g. 10-20 [default: every layer].
    #[arg(long, value_name = "A-B", value_parser = parse_layer_range)]
    pub layers: Option<RangeInclusive<u32>>,
    /// top (from above) or iso (isometric 3D); default: top for pictures, iso for the HTML page.
    #[arg(long, value_parser = |s: &str| s.parse::<ViewKind>())]
    pub view: Option<ViewKind>,
    /// tool, feature, speed, layer or mix (the colour each move is predicted to print, from the
    /// file's mixing commands, the filaments of --mix-profile and its chamber's washout).
    #[arg(long, alias = "color-by", default_value = "tool", value_parser = |s: &str| s.parse::<ColourBy>())]
    pub colour_by: ColourBy,
    /// Picture size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "1200x900", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Compare with this file (e.g. the output of a transform): changed moves are highlighted.
    #[arg(long, value_name = "B")]
    pub compare: Option<PathBuf>,
    /// Colours of tools 0, 1, ... as #rrggbb, comma separated, for --colour-by tool.
    #[arg(long, alias = "tool-colors", value_name = "COLOURS", value_delimiter = ',')]
    pub tool_colours: Vec<Srgb8>,
    /// A `gweave mix` profile: the filament colours of its inputs and its mixing chamber
    /// (purge.chamber_mm3, dead_mm3) for --colour-by mix (default: cyan, magenta, yellow, white).
    #[arg(long, value_name = "PROFILE.toml")]
    pub mix_profile: Option<PathBuf>,
    /// Draw the file as a rotary program on a mandrel of this diameter, mm (axes X along, A
    /// around in degrees, Z away from it). Not needed for `gweave rotary` output: its header
    /// names the machine [default: the file's gweave header, else a flat print].
    #[arg(long, value_name = "MM", value_parser = in_range(MANDREL_DIAMETER_MM))]
    pub mandrel_diameter: Option<f64>,
    /// Printhead profile of binder-jet raster output (TOML, as for `gweave raster --head`;
    /// default: HP C6602, 12 nozzles at 96 dpi): its fire commands are drawn as drops.
    #[arg(long, value_name = "PROFILE.toml")]
    pub head: Option<PathBuf>,
    /// Draw travel moves too.
    #[arg(long)]
    pub travel: bool,
    /// Merge chained moves shorter than this, mm (default: 0, or 0.2 for files over 32 MB).
    #[arg(long, value_name = "MM", value_parser = in_range(MIN_LEN_MM))]
    pub min_len: Option<f32>,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let side = |n: &str| in_range(PICTURE_SIDE_PX)(n).map_err(|e| format!("{}: {e}", n.trim()));
    Ok((side(w)?, side(h)?))
}

pub fn run(args: PreviewArgs) -> Result<ExitCode> {
    Files::new()
        .read("INPUT", Some(&args.input))
        .read("--compare", args.compare.as_deref())
        .read("--mix-profile", args.mix_profile.as_deref())
        .read("--head", args.head.as_deref())
        .write("-o", Some(&args.output))
        .write("--report", args.report.report.as_deref())
        .check()?;
    let to_stdout = args.output == Path::new("-");
    let format = match args.format {
        Some(format) => format,
        None if to_stdout => anyhow::bail!("-o - needs --format png, svg or html"),
        None => Format::from_path(&args.output)?,
    };
    args.report.refuse_json_with_stdout(to_stdout)?;
    let mix = match &args.mix_profile {
        Some(path) => Some(MixColours::from_profile(&load(path, MixProfile::from_toml_str)?)?),
        None => None,
    };
    let printhead = args.head.as_ref().map(|path| load(path, PrintheadProfile::from_toml)).transpose()?;
    let options = PreviewOptions {
        view: ViewOptions {
            kind: args.view.unwrap_or(format.default_view()),
            layers: args.layer.map(|l| l..=l).or(args.layers.clone()),
            width_px: args.size.0,
            height_px: args.size.1,
            colour_by: args.colour_by,
            tool_colours: args.tool_colours.clone(),
            travel: args.travel,
            ..ViewOptions::default()
        },
        min_len_mm: args.min_len,
        mix,
        rotary: args.mandrel_diameter.map(RotaryConfig::new),
        printhead,
        strictness: args.lenient.strictness(),
    };
    let mut bar = args.report.quiet.bar();
    let preview = preview_with_progress(&args.input, args.compare.as_deref(), format, &options, &mut bar)?;
    drop(bar);
    if to_stdout {
        print_summary(|out| out.write_all(&preview.bytes))?;
    } else {
        write_bytes(&args.output, &preview.bytes)?;
    }
    if args.report.emit(&preview.report)? {
        // Standard output holds the picture: the summary goes to standard error.
        match to_stdout {
            true => print_human(&mut io::stderr().lock(), &args, &preview.report)?,
            false => print_summary(|out| print_human(out, &args, &preview.report))?,
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn print_human(out: &mut dyn Write, args: &PreviewArgs, r: &PreviewReport) -> io::Result<()> {
    let format = r.format.to_uppercase();
    match &args.compare {
        Some(b) => writeln!(out, "{} vs {} -> {}", args.input.display(), b.display(), args.output.display())?,
        None => writeln!(out, "{} -> {}", args.input.display(), args.output.display())?,
    }
    let size = format!("{:.1} KB", r.bytes as f64 / 1e3);
    writeln!(
        out,
        "  {:<15} {format} {}x{} px, {size}, {} view, colour by {}",
        "picture", r.width_px, r.height_px, r.view, r.colour_by
    )?;
    match &r.layers_drawn {
        Some([a, b]) if a == b => writeln!(out, "  layer           {a}")?,
        Some([a, b]) => writeln!(out, "  layers          {a}-{b}")?,
        None => writeln!(out, "  layers          none in range: the picture is empty")?,
    }
    if let Some(n) = r.strokes {
        writeln!(out, "  drawn           {n} lines")?;
    }
    if let Some(n) = r.moves {
        writeln!(out, "  moves           {n} (a slider steps through the layers)")?;
    }
    if let Some([before, after]) = r.changed_moves {
        writeln!(out, "  changed         {before} moves of the first file, {after} of the second")?;
    }
    const SHOWN: usize = 8;
    if !r.legend.is_empty() {
        let mut entries: Vec<String> =
            r.legend.iter().take(SHOWN).map(|e| format!("{} {}", e.label, e.colour)).collect();
        if r.legend.len() > SHOWN {
            entries.push(format!("... {} more", r.legend.len() - SHOWN));
        }
        writeln!(out, "  legend          {}", entries.join(", "))?;
    }
    print_malformed(out, &r.malformed)?;
    Ok(())
}
