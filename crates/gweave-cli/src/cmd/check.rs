//! `gweave check`: lint files before they reach a printer; exit code 1 when errors are found.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::range::FEED_MM_MIN;
use gweave::{check_file_with, Bed, CheckOptions, CheckReport, CheckTotal, Finding};

use crate::args::load_machine;
use crate::common::{in_range, print_summary, ReportArgs};
use crate::files::Files;

/// Lint G-code: checksums, malformed or unknown commands, cold extrusion, bed bounds, feed rates.
///
/// Malformed lines are findings, never a stop. Exit code 0 when no file has errors (warnings
/// allowed), 1 otherwise. Several files: one report each, then the total.
/// Example: `gweave check part.gcode --bed 0,-4,250,210,210`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The G-code files to check.
    #[arg(required = true, value_name = "INPUT")]
    pub inputs: Vec<PathBuf>,
    /// Printable volume, mm: X,Y,Z from the origin, or X0,Y0,X1,Y1 (or X0,Y0,X1,Y1,Z) from a
    /// corner (Z not checked without it); moves outside it are reported [default: the bed the
    /// slicer's settings in the file give (PrusaSlicer's bed_shape and max_print_height, Cura's
    /// machine_width, machine_depth, machine_height, machine_center_is_zero), else none].
    #[arg(long, value_name = "X,Y,Z|X0,Y0,X1,Y1[,Z]", value_parser = |s: &str| s.parse::<Bed>().map_err(|e| e.to_string()))]
    pub bed: Option<Bed>,
    /// The bed of this machine profile (a TOML file or a built-in name, `gweave machine list`):
    /// its `[bed]` travel, as `sim` holds moves to it, and its `[firmware] extrude_max_mm`.
    #[arg(long, value_name = "TOML|NAME", conflicts_with = "bed")]
    pub machine: Option<PathBuf>,
    /// Feed rates above this are absurd, mm/min.
    #[arg(long, value_name = "MM_MIN", default_value_t = CheckOptions::default().max_feed_mm_min,
          value_parser = in_range(FEED_MM_MIN))]
    pub max_feed: f64,
    /// A Klipper printer's `max_extrude_cross_section` (its printer.cfg's `[extruder]`), mm²: a
    /// printing move extruding a wider bead stops the print [default: Klipper's, 4 x the nozzle
    /// diameter², the nozzle the file's slicer settings state, else 0.4 mm]
    #[arg(long, value_name = "MM2", value_parser = in_range(gweave::range::CROSS_SECTION_MM2))]
    pub klipper_max_extrude_cross_section: Option<f64>,
    /// Treat warnings as errors.
    #[arg(long)]
    pub strict: bool,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: CheckArgs) -> Result<ExitCode> {
    Files::new()
        .read_all("INPUT", args.inputs.iter().map(PathBuf::as_path))
        .write("--report", args.report.report.as_deref())
        .check()?;
    let mut options =
        CheckOptions { bed: args.bed, max_feed_mm_min: args.max_feed, ..CheckOptions::default() };
    if let Some(mm2) = args.klipper_max_extrude_cross_section {
        options.klipper.max_extrude_cross_section_mm2 = mm2;
    }
    if let Some(m) = &args.machine {
        options = load_machine(m)?.check_options(options)?;
    }
    let mut reports = Vec::with_capacity(args.inputs.len());
    for input in &args.inputs {
        let mut bar = args.report.quiet.bar();
        // Number words are held to the virtual printer's ranges: the lines `sim` would refuse.
        let report = check_file_with(input, options.clone(), Some(&gweave_sim::REGISTRY_RANGES), &mut bar)?;
        drop(bar);
        // Findings print as each file is done (they are what `check` is for, -q or not); the
        // JSON waits for the total.
        if !args.report.json {
            print_summary(|out| print_file(out, input, &report, args.report.quiet.quiet))?;
        }
        reports.push(report);
    }
    let total = CheckTotal::of(&reports, args.strict);
    let human = args.report.emit_per_file(&args.inputs, &reports, || total.clone())?;
    if human && total.files > 1 {
        print_summary(|out| {
            writeln!(
                out,
                "total: {} files, {} lines, {} errors, {} warnings; {} failed",
                total.files, total.lines, total.errors, total.warnings, total.failed_files
            )
        })?;
    }
    Ok(if total.failed_files > 0 { ExitCode::FAILURE } else { ExitCode::SUCCESS })
}

/// A file's findings, one line per kind (with how many and where), then (without -q) the bed
/// used and its counts.
fn print_file(out: &mut dyn Write, input: &Path, report: &CheckReport, quiet: bool) -> io::Result<()> {
    let name = input.display();
    for g in &report.groups {
        let f = &g.first;
        let level = match f.severity {
            gweave::Severity::Error => "error",
            gweave::Severity::Warning => "warning",
        };
        write!(out, "{name}:{}:{}: {level}: ", f.line, f.diagnostic.column)?;
        match (&f.diagnostic.finding, g.range_mm) {
            (Finding::OutsideBed { axis, .. }, Some([lo, hi])) if g.count > 1 => {
                let what = g.feature.map(|f| format!("{} ", f.name().replace('_', " "))).unwrap_or_default();
                let range = match lo == hi {
                    true => format!("{axis}={lo:.3}"),
                    false => format!("{axis} {lo:.3} .. {hi:.3}"),
                };
                writeln!(
                    out,
                    "{what}moves outside the bed: {range} mm, {} moves, lines {} .. {}",
                    g.count, f.line, g.last_line
                )?;
            }
            (finding, _) if g.count > 1 => {
                writeln!(out, "{finding} ({} lines like it, the last at line {})", g.count, g.last_line)?
            }
            (finding, _) => writeln!(out, "{finding}")?,
        }
    }
    let shown: u64 = report.groups.iter().map(|g| g.count).sum();
    if shown < report.errors + report.warnings {
        writeln!(out, "... {} more findings not shown", report.errors + report.warnings - shown)?;
    }
    if quiet {
        return Ok(());
    }
    match (&report.bed, report.bed_from.as_deref()) {
        (Some(bed), Some("given")) => writeln!(out, "{name}: bed {bed}")?,
        (Some(bed), Some(from)) => writeln!(out, "{name}: bed {bed} (the file's {from})")?,
        _ => writeln!(out, "{name}: no bed given or found in the file: bounds not checked")?,
    }
    writeln!(out, "{name}: {} lines, {} errors, {} warnings", report.lines, report.errors, report.warnings)
}
