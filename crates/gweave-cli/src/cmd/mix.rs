//! `gweave mix`: rewrite slicer G-code for a mixing hotend (see `docs/mix.md`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Result};
use clap::Args;
use gweave::colour::named_mixes::{Palette, PaletteConfig};
use gweave::colour::swatch::{render_png, render_resolved_png, SwatchEntry, SwatchLayout};
use gweave::gcode::writer::Target;
use gweave::post::mix::profile::MixProfile;
use gweave::post::mix::schedule::Plan;
use gweave::post::mix::{wizard::run_wizard, MixOptions};
use gweave_sim::transform::{self, Job, Mix};

use super::transform::Shown;
use crate::args::Lenient;
use crate::common::{print_summary, write_bytes, OutputArgs, ReportArgs};
use crate::files::Files;
use crate::options::{failed, Options};

/// Colour a print on a mixing hotend: define mixes as virtual tools, change them by layer, by
/// height, along a gradient or per slicer tool, purge at each change, cap the Z feed rate.
///
/// Examples:
///   gweave mix part.gcode -c mix.toml -o part.mix.gcode
///   gweave mix part.gcode --at-layer 0=Orange --at-layer 10=Pink -o out.gcode
///   gweave mix dual.gcode --map T0=Orange --map T1=support --in-place
///   gweave mix --wizard -c mix.toml
/// As a PrusaSlicer post-processing script: `/path/to/gweave mix -c /path/mix.toml --in-place
/// --no-backup` (PrusaSlicer adds the G-code path last).
#[derive(Args, Debug)]
pub struct MixArgs {
    /// The G-code file (may come last, as PrusaSlicer passes it).
    pub input: Option<PathBuf>,
    #[command(flatten)]
    pub out: OutputArgs,
    #[command(flatten)]
    pub options: Options<MixOptions>,
    /// Draw the job's mixes (or the whole palette without a job) as a PNG swatch chart.
    #[arg(long, value_name = "PNG")]
    pub palette_png: Option<PathBuf>,
    /// Print the colour these ratios are predicted to print (`C:M:Y:W`, any scale), with the
    /// profile's filaments or the defaults; repeatable; with --json a list of
    /// `{"ratios", "srgb", "lab"}`.
    #[arg(long, value_name = "RATIOS")]
    pub predict: Vec<String>,
    /// Write a calibration card (G-code, to -o) for the profile's hotend and filaments: 30
    /// swatches for 4 inputs, purged between; --report lists each swatch's id and ratios.
    #[arg(long, conflicts_with_all = ["predict", "fit", "wizard"])]
    pub calibration_card: bool,
    /// With --calibration-card: draw the card from above in its predicted colours, each
    /// swatch with its number (as in --report and the CSV --fit reads), as a PNG.
    #[arg(long, value_name = "PNG", requires = "calibration_card")]
    pub card_png: Option<PathBuf>,
    /// Fit the filaments to a printed card's measured colours (CSV `id,srgb` or `id,L,a,b`)
    /// and write the fitted profile to -o.
    #[arg(long, value_name = "CSV", conflicts_with_all = ["predict", "wizard"])]
    pub fit: Option<PathBuf>,
    /// Ask the seed's questions on the terminal, show a summary, and after a yes write the
    /// profile to -c (or print it); with a G-code file and -o, then rewrite that file with it.
    #[arg(long)]
    pub wizard: bool,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: MixArgs) -> Result<ExitCode> {
    if args.wizard {
        return wizard(&args);
    }
    let target = match &args.input {
        Some(_) => Some(args.out.target()?),
        None => None,
    };
    args.report.refuse_json_with_stdout(target.as_ref().is_some_and(Target::is_stdout))?;
    let mut files =
        Files::new().read("INPUT", args.input.as_deref()).read("-c", args.options.config.as_deref());
    if let (Some(input), Some(target)) = (&args.input, &target) {
        files = files.target(target, input);
    }
    if args.calibration_card || args.fit.is_some() {
        let out = args.out.output.as_deref().filter(|_| args.input.is_none());
        files = files.read("--fit", args.fit.as_deref()).write("-o", out.filter(|p| *p != Path::new("-")));
    }
    files
        .write("--palette-png", args.palette_png.as_deref())
        .write("--card-png", args.card_png.as_deref())
        .write("--report", args.report.report.as_deref())
        .check()?;
    let profile = transform::mix_profile(&args.options).map_err(failed)?;
    if !args.predict.is_empty() {
        return super::mix_colour::predict_all(&profile, &args.predict, &args.report);
    }
    if args.calibration_card || args.fit.is_some() {
        let Some(out) = args.out.output.as_deref().filter(|_| args.input.is_none()) else {
            bail!("--calibration-card and --fit write to -o FILE and take no G-code input");
        };
        return match &args.fit {
            Some(csv) => {
                let text = match &args.options.config {
                    Some(path) => crate::common::read_text(path)?,
                    None => String::new(),
                };
                super::mix_colour::fit_profile(&profile, &text, csv, out, &args.report)
            }
            None => super::mix_colour::card(
                &profile,
                &args.options,
                out,
                &args.out.format.target(out)?,
                args.card_png.as_deref(),
                &args.report,
            ),
        };
    }
    let has_job = !(profile.schedule.is_empty() && profile.gradient.is_empty() && profile.map.is_empty());
    if let Some(png) = &args.palette_png {
        write_swatch(&profile, has_job, png)?;
        if args.input.is_none() {
            return Ok(ExitCode::SUCCESS);
        }
    }
    let (Some(input), Some(target)) = (&args.input, target) else { bail!("give the G-code file to rewrite") };
    run_job(&args, profile, input, target)
}

/// Mixes `input` into `target` and reports: the job of a plain run and of the wizard's.
fn run_job(args: &MixArgs, profile: MixProfile, input: &Path, target: Target) -> Result<ExitCode> {
    let job = |job: Job<'_>| transform::mix_with(profile, &args.options, job);
    let shown = Shown::of::<Mix>();
    super::transform::run_job(&args.report, args.lenient.strictness(), input, &target, job, shown)
}

fn write_swatch(profile: &MixProfile, has_job: bool, png: &Path) -> Result<()> {
    let layout = SwatchLayout::default();
    let bytes = if has_job {
        let plan = Plan::new(profile)?;
        let entries: Vec<SwatchEntry> = plan
            .mixes
            .iter()
            .map(|m| SwatchEntry { name: m.label.clone(), predicted: m.predicted, target: m.target })
            .collect();
        render_png(&entries, &layout)?
    } else {
        let model = profile.hardware.mixing_model()?;
        let palette = Palette::seed().with_config(PaletteConfig { mix: profile.mix.clone() });
        render_resolved_png(&palette.resolve_all(&model)?, &layout)?
    };
    write_bytes(png, &bytes)
}

fn wizard(args: &MixArgs) -> Result<ExitCode> {
    // With a G-code file and -o (or --in-place) the job runs right after: check those first.
    let target = match (&args.input, args.out.output.is_some() || args.out.in_place) {
        (Some(_), true) => Some(args.out.target()?),
        _ => None,
    };
    let mut files =
        Files::new().read("INPUT", args.input.as_deref()).write("-c", args.options.config.as_deref());
    if let (Some(input), Some(target)) = (&args.input, &target) {
        files = files.target(target, input);
    }
    files.check()?;
    let stdin = std::io::stdin();
    let mut input = stdin.lock();
    // The questions go to standard error when the job's G-code goes to standard output.
    let mut prompts: Box<dyn Write> = if target.as_ref().is_some_and(Target::is_stdout) {
        Box::new(std::io::stderr())
    } else {
        Box::new(std::io::stdout())
    };
    let Some(text) = run_wizard(&mut input, &mut prompts)? else {
        eprintln!("gweave: nothing written");
        return Ok(ExitCode::FAILURE);
    };
    drop(prompts);
    match &args.options.config {
        Some(path) => {
            write_bytes(path, text.as_bytes())?;
            eprintln!("Wrote {}.", path.display());
        }
        None if target.is_none() => print_summary(|out| write!(out, "\n{text}"))?,
        None => {}
    }
    let (Some(file), Some(target)) = (&args.input, target) else {
        if let Some(file) = &args.input {
            eprintln!(
                "gweave: the wizard only wrote the profile; {} was not processed: give -o OUT to process it too",
                file.display()
            );
        } else if let Some(path) = &args.options.config {
            eprintln!("Next: gweave mix part.gcode -c {} -o part.mix.gcode", path.display());
        }
        return Ok(ExitCode::SUCCESS);
    };
    run_job(args, MixProfile::from_toml_str(&text)?, file, target)
}
