//! `gweave purge-shift`: move every colour change earlier by the purge amount, splitting the
//! move, so the purge prints inside the part instead of a wipe tower (docs/purge-shift.md).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::malformed::Transformed;
use gweave::post::purge_shift::{purge_shift, Overrides, PurgeShiftConfig};
use gweave::range::{FILAMENT_DIAMETER_MM, POSITION_MM, PURGE_MM, PURGE_MM3};
use gweave::run::Run;

use crate::args::Lenient;
use crate::common::{
    in_range, load_or_default, numbers_in, print_malformed, print_summary, OutputArgs, ReportArgs,
};
use crate::files::Files;
use crate::finish;

/// Move each tool/mix change earlier by the purge, so the old colour is purged inside the part.
///
/// For every `T<n>` (and `M163`/`M164`, `M165`, `M567` mix change) the old colour's extruding
/// moves are walked back until the purge amount of filament is found; that move is split at the
/// exact point and the change goes there. Works with absolute and relative E, `G92 E` resets,
/// retractions and firmware retraction; never crosses a layer change (unless --cross-layers),
/// the outer wall (unless allowed) or the previous change. With too little room the rest of
/// the purge is accepted as missing, or purged in a block or on a small tower (--fallback).
///
/// As a PrusaSlicer post-processing script: `/path/to/gweave purge-shift --purge-mm 2.5 --in-place
/// --no-backup` (PrusaSlicer appends the file name). Chains after `gweave mix`.
/// Example: `gweave purge-shift part.gcode -o part.shifted.gcode --purge-mm 2.5`.
#[derive(Args, Debug)]
pub struct PurgeShiftArgs {
    /// The G-code file to read.
    pub input: PathBuf,
    #[command(flatten)]
    pub out: OutputArgs,
    /// Purge per change, mm of filament (`--purge` is an older name); one of --purge-mm,
    /// --purge-mm3 or the config's amounts is needed [default: the config's].
    #[arg(long, alias = "purge", value_name = "MM", value_parser = in_range(PURGE_MM))]
    pub purge_mm: Option<f64>,
    /// Purge per change as a volume, mm^3 (converted with --filament-diameter) [default: the
    /// config's].
    #[arg(long, value_name = "MM3", conflicts_with = "purge_mm", value_parser = in_range(PURGE_MM3))]
    pub purge_mm3: Option<f64>,
    /// TOML settings: per-pair table, colours, washout model, rules (flags override it).
    #[arg(short, long, value_name = "TOML")]
    pub config: Option<PathBuf>,
    /// Filament diameter, mm (default 1.75).
    #[arg(long, value_name = "MM", value_parser = in_range(FILAMENT_DIAMETER_MM))]
    pub filament_diameter: Option<f64>,
    /// Allow a change to move back into the previous layer.
    #[arg(long)]
    pub cross_layers: bool,
    /// Features the change may move through, comma separated (default: all but outer_wall).
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    pub allow_features: Option<Vec<String>>,
    /// Explicit print-proper markers: the comment texts `begin,end`.
    #[arg(long, value_name = "BEGIN,END", value_delimiter = ',', num_args = 1)]
    pub markers: Option<Vec<String>>,
    /// Too little room: `partial` (accept the shortfall), `block` (purge the rest in a purge
    /// block, as `gweave mix` does) or `tower` (purge the rest on a small tower beside the part)
    /// [default: the config's, else partial].
    #[arg(long, value_name = "NAME")]
    pub fallback: Option<String>,
    /// The tower's corner `X,Y`, mm (default: beside the print's extent so far).
    #[arg(long, value_name = "X,Y", value_parser = numbers_in::<2>(POSITION_MM))]
    pub tower_at: Option<[f64; 2]>,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

/// Builds the library settings: the TOML file first, then the flags on top.
fn config(args: &PurgeShiftArgs) -> Result<PurgeShiftConfig> {
    let mut c = load_or_default(args.config.as_ref(), PurgeShiftConfig::parse_toml)?;
    let markers = match args.markers.as_deref() {
        None => None,
        Some([begin, end]) => Some([begin.clone(), end.clone()]),
        Some(_) => anyhow::bail!("--markers takes two comment texts: BEGIN,END"),
    };
    c.apply(&Overrides {
        purge_mm: args.purge_mm,
        purge_mm3: args.purge_mm3,
        filament_diameter_mm: args.filament_diameter,
        cross_layers: args.cross_layers,
        allow_features: args.allow_features.clone(),
        markers,
        fallback: args.fallback.clone(),
        tower_xy_mm: args.tower_at,
    });
    Ok(c)
}

pub fn run(args: PurgeShiftArgs) -> Result<ExitCode> {
    let target = args.out.target()?;
    args.report.refuse_json_with_stdout(target.is_stdout())?;
    Files::new()
        .read("INPUT", Some(&args.input))
        .read("-c", args.config.as_deref())
        .target(&target, &args.input)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let rules = config(&args)?.validate()?;
    finish::refuse_second_run(&args.input, "purge-shift")?;
    let mut bar = args.report.quiet.bar();
    let strictness = args.lenient.strictness();
    let ((mut report, malformed), _) = finish::with_metadata(Some(&args.input), &target, |t| {
        let run = Run::file(&args.input).to(t).progress(&mut bar).strictness(strictness);
        let (report, ran) = purge_shift(rules, run)?;
        Ok((report, ran.malformed))
    })?;
    // The run's header is one line above every change.
    report.changes.offset_output_lines(1);
    drop(bar);
    // Warnings print with -q too (docs/pipeline.md), one line per kind.
    for w in gweave::post::warning::grouped(&report.warnings) {
        eprintln!("gweave: warning: {w}");
    }
    let kept = report.warnings.len() as u64;
    if report.warnings_total > kept {
        eprintln!("gweave: ... {} more warnings, counted only", report.warnings_total - kept);
    }
    if args.report.emit(&Transformed::new(&report, malformed, strictness))? {
        let summary = |out: &mut dyn std::io::Write| {
            write!(out, "{}", report.summary())?;
            print_malformed(out, &malformed)
        };
        // Keep standard output clean when the G-code goes there.
        if target.is_stdout() {
            summary(&mut std::io::stderr())?;
        } else {
            print_summary(summary)?;
        }
    }
    Ok(ExitCode::SUCCESS)
}
