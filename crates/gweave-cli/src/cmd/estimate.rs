//! `gweave estimate`: the print time from the virtual printer's planner alone, fast.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use gweave_sim::slicer_limits;
use gweave_sim::MachineProfile;
use gweave_sim::{estimate_file, EstimateReport};

use super::sim::{print_layers_and_features, print_malformed};
use crate::args::MachineArg;
use crate::common::{hms, print_summary, ReportArgs};
use crate::files::Files;

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
    /// Machine profile: a TOML file (docs/machine.md) or a built-in profile's name (`gweave
    /// machine list`); only its motion limits are used. Default: a RAMPS 1.4 printer on Marlin. `slicer`: the machine limits the slicer wrote into the file
    /// (PrusaSlicer, SuperSlicer, OrcaSlicer `machine_max_*`, Cura's `machine_max_*`); the
    /// settings used are listed on standard error.
    #[arg(long, value_name = "TOML|NAME|slicer")]
    pub machine: Option<PathBuf>,
    /// Also count the steps of every motor (Bresenham, as `gweave sim` does); up to a fifth slower.
    #[arg(long)]
    pub steps: bool,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: EstimateArgs) -> Result<ExitCode> {
    // `--machine slicer`: the limits the slicer wrote into the file itself.
    let from_slicer = args.machine.as_deref().is_some_and(|m| m.as_os_str() == "slicer");
    Files::new()
        .read("INPUT", Some(&args.input))
        .read("--machine", args.machine.as_deref().filter(|_| !from_slicer))
        .write("--report", args.report.report.as_deref())
        .check()?;
    let profile = match &args.machine {
        Some(_) if from_slicer => slicer_profile(&args.input)?,
        // A file or a built-in profile's name, as `sim` reads it.
        other => MachineArg { path: other.clone() }.load()?,
    };
    let report = estimate_file(&args.input, &profile, args.steps, args.report.quiet.bar())?;
    if args.report.emit(&report)? {
        print_summary(|out| print_human(out, &args.input, &report))?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The default machine with the limits the slicer wrote into `input`, saying which.
fn slicer_profile(input: &Path) -> Result<MachineProfile> {
    let ends =
        gweave::gcode::ends::read_ends(input).with_context(|| format!("reading {}", input.display()))?;
    let base = MachineProfile::default();
    let limits = slicer_limits(&ends, &base.motion)
        .with_context(|| format!("{}: --machine slicer", input.display()))?;
    let flavour = limits.flavour.as_deref().map(|f| format!(", flavour {f}")).unwrap_or_default();
    let name = format!("{}'s machine limits in the file{flavour}", limits.slicer);
    eprintln!("{name}: {}", limits.used.join(", "));
    eprintln!("  (steps per mm and anything not listed: the default machine's)");
    Ok(MachineProfile { name, motion: limits.profile, ..base })
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
    if r.steps_counted {
        let s = &e.steps.axes;
        writeln!(out, "  steps           X {}  Y {}  Z {}  E {}  A {}", s[0], s[1], s[2], s[3], s[4])?;
    }
    Ok(())
}
