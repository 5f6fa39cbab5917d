//! `gweave check`: lint a file before it reaches a printer; exit code 1 when errors are found.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::check::{CheckOptions, CheckPass, CheckReport};
use gweave::pass::{Run, Strictness};

use gweave::range::{BED_SIZE_MM, FEED_MM_MIN};

use crate::common::{in_range, numbers_in, print_summary, ReportArgs};
use crate::files::Files;
use crate::progress::Bar;

/// Lint G-code: checksums, malformed or unknown commands, cold extrusion, bed bounds, feed rates.
///
/// Exit code 0 when no errors were found (warnings allowed), 1 otherwise.
/// Example: `gweave check part.gcode --bed 220,220,250`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The G-code file to check.
    pub input: PathBuf,
    /// Printable volume X,Y,Z in mm; moves outside it are reported.
    #[arg(long, value_name = "X,Y,Z", value_parser = numbers_in::<3>(BED_SIZE_MM))]
    pub bed: Option<[f64; 3]>,
    /// Feed rates above this are absurd, mm/min.
    #[arg(long, value_name = "MM_MIN", default_value_t = CheckOptions::default().max_feed_mm_min,
          value_parser = in_range(FEED_MM_MIN))]
    pub max_feed: f64,
    /// Treat warnings as errors.
    #[arg(long)]
    pub strict: bool,
    #[command(flatten)]
    pub report: ReportArgs,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: CheckArgs) -> Result<ExitCode> {
    Files::new().read("INPUT", Some(&args.input)).write("--report", args.report.report.as_deref()).check()?;
    let options =
        CheckOptions { bed_mm: args.bed, max_feed_mm_min: args.max_feed, ..CheckOptions::default() };
    let mut pass = CheckPass::new(options);
    let mut bar = Bar::new(args.quiet);
    let mut run = Run::new(&args.input, &mut bar);
    run.strictness = Strictness::Lenient;
    run.scan(&mut pass)?;
    drop(bar);
    let report = pass.report;
    if args.report.emit(&report)? {
        print_summary(|out| print_human(out, &args.input, &report))?;
    }
    let failed = report.errors > 0 || (args.strict && report.warnings > 0);
    Ok(if failed { ExitCode::FAILURE } else { ExitCode::SUCCESS })
}

fn print_human(out: &mut dyn Write, input: &Path, report: &CheckReport) -> io::Result<()> {
    let name = input.display();
    for f in &report.findings {
        let level = match f.severity {
            gweave::gcode::diag::Severity::Error => "error",
            gweave::gcode::diag::Severity::Warning => "warning",
        };
        writeln!(out, "{name}:{}:{}: {level}: {}", f.line, f.diagnostic.column, f.diagnostic.finding)?;
    }
    let shown = report.findings.len() as u64;
    if shown < report.errors + report.warnings {
        writeln!(out, "... {} more findings not shown", report.errors + report.warnings - shown)?;
    }
    writeln!(out, "{name}: {} lines, {} errors, {} warnings", report.lines, report.errors, report.warnings)?;
    Ok(())
}
