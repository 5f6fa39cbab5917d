//! `gweave preview`: a picture (PNG, SVG) or an interactive page (HTML) of what a file prints.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::render::job;
use gweave::PreviewOptions;
use gweave::PreviewReport;

use crate::args::Lenient;
use crate::common::{print_malformed, print_summary, ReportArgs};
use crate::files::Files;
use crate::options::Options;

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
    #[command(flatten)]
    pub options: Options<PreviewOptions>,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: PreviewArgs) -> Result<ExitCode> {
    let o = &args.options;
    Files::new()
        .read("INPUT", Some(&args.input))
        .read("--compare", o.compare.as_deref())
        .read("--mix-profile", o.mix_profile.as_deref())
        .read("--head", o.head.as_deref())
        .write("-o", Some(&args.output))
        .write("--report", args.report.report.as_deref())
        .check()?;
    let to_stdout = args.output == Path::new("-");
    if to_stdout && o.format.is_none() {
        anyhow::bail!("-o - needs --format png, svg or html");
    }
    // The format is known before the file is read: a bad extension is refused first.
    job::format_of(o, Some(&args.output))?;
    args.report.refuse_json_with_stdout(to_stdout)?;
    let mut bar = args.report.quiet.bar();
    let preview = job::preview(o, &args.input, Some(&args.output), args.lenient.strictness(), &mut bar)
        .map_err(crate::options::failed)?;
    drop(bar);
    if to_stdout {
        print_summary(|out| out.write_all(&preview.bytes))?;
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
    match &args.options.compare {
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
