//! `gweave estimate`: the print time from the virtual printer's planner alone, fast.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave_sim::reading::{self, EstimateOptions};
use gweave_sim::EstimateReport;

use super::sim::{print_layers_and_features, print_malformed};
use crate::common::{hms, print_summary, ReportArgs};
use crate::files::Files;
use crate::options::Options;

/// Estimate the print time with the virtual printer's lookahead planner (Klipper or Marlin
/// mode, from the machine profile), per layer and per feature, without heaters or the serial
/// face: what `gweave sim` reports as motion, dwell and overhead, with reading, parsing and
/// planning on two threads. Heating waits and homing are not timed (`gweave sim` simulates
/// them).
///
/// Example: `gweave estimate part.gcode --machine examples/machines/klipper.toml`.
#[derive(Args, Debug)]
pub struct EstimateArgs {
    /// The G-code file to estimate.
    pub input: PathBuf,
    #[command(flatten)]
    pub options: Options<EstimateOptions>,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: EstimateArgs) -> Result<ExitCode> {
    // `--machine slicer`: the limits the slicer wrote into the file itself, no file to check.
    let machine = args.options.machine.as_deref().filter(|m| m.as_os_str() != "slicer");
    Files::new()
        .read("INPUT", Some(&args.input))
        .read("--machine", machine)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let estimated = reading::estimate(&args.options, &args.input, args.report.quiet.bar())
        .map_err(crate::options::failed)?;
    let report = estimated.report;
    if let Some(used) = estimated.slicer_settings {
        eprintln!("{}: {}", report.machine, used.join(", "));
        eprintln!("  (steps per mm and anything not listed: the default machine's)");
    }
    if args.report.emit(&report)? {
        print_summary(|out| print_human(out, &args.input, &report))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn print_human(out: &mut dyn Write, input: &Path, r: &EstimateReport) -> io::Result<()> {
    let e = &r.estimate;
    writeln!(out, "{} on {} ({} planner)", input.display(), r.machine, r.planner)?;
    writeln!(out, "  time            {}  ({:.1} s, {} planned blocks)", hms(e.total_s), e.total_s, e.blocks)?;
    writeln!(
        out,
        "    motion {}  dwell {}  overhead {}",
        hms(e.motion_s),
        hms(e.dwell_s),
        hms(e.overhead_s)
    )?;
    print_layers_and_features(out, &e.layer_s, e.unlayered_s, &e.feature_s)?;
    print_malformed(out, &e.malformed, &e.huge_arcs)?;
    if let (Some(first), Some(why)) = (e.refused.first_refused_line, &e.refused.first_refusal) {
        let n = e.refused.refused_lines;
        writeln!(
            out,
            "  refused         {n} lines, skipped as the printer refuses them (first: line {first}, {why}; see gweave check)"
        )?;
    }
    if r.steps_counted {
        let s = &e.steps.axes;
        writeln!(out, "  steps           X {}  Y {}  Z {}  E {}  A {}", s[0], s[1], s[2], s[3], s[4])?;
    }
    for w in &r.warnings {
        writeln!(out, "  warning: {w}")?;
    }
    Ok(())
}
