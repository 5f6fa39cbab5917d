//! `gweave stats`: what a file will print, in one streaming pass.

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::WithMalformed;
use gweave::{stats_file, Stats, StatsTotal};

use gweave::range::FILAMENT_DIAMETER_MM;

use crate::args::Lenient;
use crate::common::{hms, in_range, print_malformed, print_summary, ReportArgs};
use crate::files::Files;

/// Statistics of a G-code file: slicer, layers, extents, filament per tool, distances, time.
///
/// Filament per tool counts extruding moves, as PrusaSlicer's `; filament used [mm]` does.
/// Several files: one report each, then the total of what adds up (lines, filament, distances,
/// times). Example: `gweave stats part.gcode --json`, `gweave stats *.gcode`.
#[derive(Args, Debug)]
pub struct StatsArgs {
    /// The G-code files to read.
    #[arg(required = true, value_name = "INPUT")]
    pub inputs: Vec<PathBuf>,
    /// Filament diameter in mm (default: the file's own setting, else 1.75).
    #[arg(long, value_name = "MM", value_parser = in_range(FILAMENT_DIAMETER_MM))]
    pub filament_diameter: Option<f64>,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: StatsArgs) -> Result<ExitCode> {
    Files::new()
        .read_all("INPUT", args.inputs.iter().map(PathBuf::as_path))
        .write("--report", args.report.report.as_deref())
        .check()?;
    let mut all = Vec::with_capacity(args.inputs.len());
    for input in &args.inputs {
        let mut bar = args.report.quiet.bar();
        all.push(stats_file(input, args.filament_diameter, args.lenient.strictness(), &mut bar)?);
    }
    let human = args.report.emit_per_file(&args.inputs, &all, || StatsTotal::of(&all))?;
    if human {
        print_summary(|out| {
            for (input, s) in args.inputs.iter().zip(&all) {
                print_human(out, input, s)?;
            }
            if all.len() > 1 {
                print_total(out, &StatsTotal::of(&all))?;
            }
            Ok(())
        })?;
    }
    Ok(ExitCode::SUCCESS)
}

fn print_total(out: &mut dyn Write, t: &StatsTotal) -> io::Result<()> {
    writeln!(out, "total of {} files", t.files)?;
    writeln!(out, "  lines           {} ({:.1} MB)", t.lines, t.bytes as f64 / 1e6)?;
    writeln!(out, "  tool changes    {}", t.tool_changes)?;
    for f in &t.filament {
        writeln!(out, "    T{:<3} {:>12.2} mm {:>10.1} mm3", f.tool, f.extruded_mm, f.extruded_mm3)?;
    }
    writeln!(out, "  print / travel  {:.1} m / {:.1} m", t.print_mm / 1000.0, t.travel_mm / 1000.0)?;
    writeln!(out, "  time (F only)   {}", hms(t.time_s))?;
    if t.malformed_lines > 0 {
        writeln!(out, "  malformed       {} lines skipped", t.malformed_lines)?;
    }
    Ok(())
}

fn print_human(out: &mut dyn Write, input: &std::path::Path, read: &WithMalformed<Stats>) -> io::Result<()> {
    let s = &read.report;
    writeln!(out, "{}", input.display())?;
    let flavour = s.slicer_figures.flavour.as_deref().map(|f| format!(" ({f})")).unwrap_or_default();
    writeln!(out, "  slicer          {}{flavour}", s.slicer.name())?;
    writeln!(out, "  lines           {} ({:.1} MB)", s.lines, s.bytes as f64 / 1e6)?;
    writeln!(out, "  layers          {}", s.layers)?;
    if let Some(r) = &s.rotary {
        // A rotary program: its words are not a flat box (the mandrel turns where Y moved).
        writeln!(out, "  mandrel         {} mm (lengths and times on its surface)", r.mandrel_diameter_mm)?;
        if let (Some([a0, a1]), Some([t0, t1]), Some([r0, r1])) = (r.axial_mm, r.angle_deg, r.radius_mm) {
            writeln!(
                out,
                "  extents         axial {a0:.2}..{a1:.2} mm  angle {t0:.1}..{t1:.1} deg  radius {r0:.3}..{r1:.3} mm"
            )?;
        }
    } else if let Some([lo, hi]) = s.z_range_mm {
        writeln!(out, "  z range         {lo:.3} .. {hi:.3} mm")?;
    }
    if let (Some(b), None) = (s.extrusion_bounds, &s.rotary) {
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
        // A wipe tower's priming and unloading/loading: PrusaSlicer's own way of counting.
        let as_prusaslicer = if (f.as_prusaslicer_mm - f.extruded_mm).abs() >= 0.005 {
            format!("   as PrusaSlicer counts {:.2} mm", f.as_prusaslicer_mm)
        } else {
            String::new()
        };
        writeln!(
            out,
            "    T{:<3} {:>12.2} mm {:>10.1} mm3{as_prusaslicer}{theirs}",
            f.tool, f.extruded_mm, f.extruded_mm3
        )?;
    }
    if let Some(matches) = s.filament_matches_slicer {
        writeln!(
            out,
            "  slicer figures  {}",
            if matches { "match" } else { "differ from the count above (see the warnings)" }
        )?;
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
    print_malformed(out, &read.malformed)?;
    Ok(())
}
