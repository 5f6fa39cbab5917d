//! `gweave stats`: what a file will print, in one streaming pass.

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::pass::Run;
use gweave::stats::{Stats, StatsPass};

use gweave::range::FILAMENT_DIAMETER_MM;

use crate::common::{hms, in_range, print_summary, ReportArgs};
use crate::files::Files;
use crate::progress::Bar;

/// Statistics of a G-code file: slicer, layers, extents, filament per tool, distances, time.
///
/// Filament per tool counts extruding moves, as PrusaSlicer's `; filament used [mm]` does.
/// Example: `gweave stats part.gcode --json`.
#[derive(Args, Debug)]
pub struct StatsArgs {
    /// The G-code file to read.
    pub input: PathBuf,
    /// Filament diameter in mm (default: the file's own setting, else 1.75).
    #[arg(long, value_name = "MM", value_parser = in_range(FILAMENT_DIAMETER_MM))]
    pub filament_diameter: Option<f64>,
    #[command(flatten)]
    pub report: ReportArgs,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: StatsArgs) -> Result<ExitCode> {
    Files::new().read("INPUT", Some(&args.input)).write("--report", args.report.report.as_deref()).check()?;
    let mut pass = StatsPass::new(args.filament_diameter);
    let mut bar = Bar::new(args.quiet);
    let state = Run::new(&args.input, &mut bar).scan(&mut pass)?;
    drop(bar);
    let stats = pass.into_stats(&state);
    if args.report.emit(&stats)? {
        print_summary(|out| print_human(out, &args.input, &stats))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn print_human(out: &mut dyn Write, input: &std::path::Path, s: &Stats) -> io::Result<()> {
    writeln!(out, "{}", input.display())?;
    let flavour = s.slicer_figures.flavour.as_deref().map(|f| format!(" ({f})")).unwrap_or_default();
    writeln!(out, "  slicer          {}{flavour}", s.slicer.name())?;
    writeln!(out, "  lines           {} ({:.1} MB)", s.lines, s.bytes as f64 / 1e6)?;
    writeln!(out, "  layers          {}", s.layers)?;
    if let Some([lo, hi]) = s.z_range_mm {
        writeln!(out, "  z range         {lo:.3} .. {hi:.3} mm")?;
    }
    if let Some(b) = s.extrusion_bounds {
        writeln!(
            out,
            "  extents         X {:.2}..{:.2}  Y {:.2}..{:.2} mm",
            b.min[0], b.max[0], b.min[1], b.max[1]
        )?;
    }
    writeln!(out, "  tool changes    {}", s.tool_changes)?;
    writeln!(out, "  filament        (diameter {} mm)", s.filament_diameter_mm)?;
    for (i, f) in s.filament.iter().enumerate() {
        let theirs = s
            .slicer_figures
            .filament_used_mm
            .as_ref()
            .and_then(|l| l.get(i))
            .map(|v| format!("   slicer says {v:.2} mm"))
            .unwrap_or_default();
        writeln!(out, "    T{:<3} {:>12.2} mm {:>10.1} mm3{theirs}", f.tool, f.extruded_mm, f.extruded_mm3)?;
    }
    if let Some(matches) = s.filament_matches_slicer {
        writeln!(out, "  slicer figures  {}", if matches { "match" } else { "differ from the count above" })?;
    }
    writeln!(out, "  print / travel  {:.1} m / {:.1} m", s.print_mm / 1000.0, s.travel_mm / 1000.0)?;
    writeln!(out, "  time (F only)   {}", hms(s.time_s))?;
    for (feature, t) in &s.time_by_feature_s {
        writeln!(out, "    {feature:<18} {}", hms(*t))?;
    }
    if let Some(t) = s.slicer_figures.estimated_time_s {
        writeln!(out, "  slicer estimate {}", hms(t))?;
    }
    for w in &s.warnings {
        writeln!(out, "  warning: {w}")?;
    }
    Ok(())
}
