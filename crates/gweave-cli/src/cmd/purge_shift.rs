//! `gweave purge-shift`: move every colour change earlier by the purge amount, splitting the
//! move, so the purge prints inside the part instead of a wipe tower (docs/purge-shift.md).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::malformed::Transformed;
use gweave::post::purge_shift::PurgeShiftOptions;
use gweave_sim::transform::{self, Job};

use crate::args::Lenient;
use crate::common::{print_malformed, print_summary, OutputArgs, ReportArgs};
use crate::files::Files;
use crate::options::Options;

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
    #[command(flatten)]
    pub options: Options<PurgeShiftOptions>,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: PurgeShiftArgs) -> Result<ExitCode> {
    let target = args.out.target()?;
    args.report.refuse_json_with_stdout(target.is_stdout())?;
    Files::new()
        .read("INPUT", Some(&args.input))
        .read("-c", args.options.config.as_deref())
        .target(&target, &args.input)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let mut bar = args.report.quiet.bar();
    let strictness = args.lenient.strictness();
    let job = Job { strictness, progress: Some(&mut bar), ..Job::new(&args.input, &target) };
    let (report, malformed) = transform::purge_shift(&args.options, job).map_err(crate::options::failed)?;
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
