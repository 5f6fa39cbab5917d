//! `gweave sim`: run a file through the virtual printer and report what the machine did.

use std::collections::BTreeMap;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::gcode::layers::Feature;
use gweave_sim::reading::{self, SimOptions};
use gweave_sim::CoreReport;
use gweave_sim::HeaterId;
use gweave_sim::Simulation;
use gweave_sim::{HugeArcs, Malformed, SimReport, MAX_ARC_CHORDS};

use crate::common::{hms, print_summary, ReportArgs};
use crate::files::{layer_png, Files};
use crate::options::Options;

/// Simulate a print on a virtual Marlin-like printer: time per layer and feature (planner),
/// filament per tool and mixing input, exact step counts per motor (Bresenham), heaters
/// (thermal plant, PID, protection), warnings (out of bounds, cold extrusion, unknown
/// commands). Exits with 1 when the machine halted (a thermal fault or M112).
///
/// Example: `gweave sim part.gcode --machine examples/machines/marlin-ramps.toml --plot t.png
/// --plot-speed speed.png`.
#[derive(Args, Debug)]
pub struct SimArgs {
    /// The G-code file to run.
    pub input: PathBuf,
    #[command(flatten)]
    pub options: Options<SimOptions>,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: SimArgs) -> Result<ExitCode> {
    let o = &args.options;
    Files::new()
        .read("INPUT", Some(&args.input))
        .read("--machine", o.machine.as_deref())
        .write("--plot", o.plot.as_deref())
        .write("--plot-speed", o.plot_speed.as_deref())
        .write_dir("--raster-out", o.raster_out.as_deref(), layer_png)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let mut bar = args.report.quiet.bar();
    let simulation = reading::sim(o, &args.input, &mut bar).map_err(crate::options::failed)?;
    drop(bar);
    match &simulation {
        Simulation::Marlin { report, errors, .. } => {
            if args.report.emit(report)? {
                print_summary(|out| print_human(out, &args.input, report, errors))?;
                return Ok(exit_code(&simulation));
            }
        }
        Simulation::Core(report) => {
            if args.report.emit(report)? {
                print_summary(|out| print_core(out, &args.input, report))?;
                return Ok(exit_code(&simulation));
            }
        }
    }
    // Without the summary (-q, --json) the printer's errors still reach standard error: -q never
    // hides why a run failed.
    for e in simulation.errors() {
        eprintln!("gweave: the printer said: {e}");
    }
    Ok(exit_code(&simulation))
}

/// 1 when the machine halted (a thermal fault or M112).
fn exit_code(simulation: &Simulation) -> ExitCode {
    if simulation.halted() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

fn print_core(out: &mut dyn Write, input: &Path, r: &CoreReport) -> io::Result<()> {
    writeln!(out, "{} on {} (gweave controller core)", input.display(), r.machine)?;
    writeln!(out, "  lines           {}", r.lines)?;
    writeln!(out, "  time            {}", hms(r.time_s))?;
    let [x, y, z, e] = r.end_steps;
    writeln!(out, "  end position    Count X {x} Y {y} Z {z} E {e}")?;
    let [x, y, z, e] = r.axis_steps;
    write!(out, "  step pulses     X {x} Y {y} Z {z} E {e}")?;
    if let Some(a) = r.rotary_steps {
        write!(out, " A {a}")?;
    }
    writeln!(out)?;
    if !r.mixing_steps.is_empty() {
        write!(out, "  mixing steps   ")?;
        for (k, steps) in r.mixing_steps.iter().enumerate() {
            write!(out, " E{k} {steps}")?;
        }
        writeln!(out)?;
    }
    if !r.extruder_steps.is_empty() {
        write!(out, "  extruder steps ")?;
        for (k, steps) in r.extruder_steps.iter().enumerate() {
            write!(out, " E{k} {steps}")?;
        }
        writeln!(out)?;
    }
    for error in &r.errors {
        writeln!(out, "  the printer said: {error}")?;
    }
    if r.halted {
        writeln!(out, "  halted")?;
    }
    Ok(())
}

fn print_human(out: &mut dyn Write, input: &Path, r: &SimReport, errors: &[String]) -> io::Result<()> {
    let t = &r.time;
    writeln!(out, "{} on {}", input.display(), r.machine)?;
    writeln!(out, "  lines           {}  ({} planned blocks)", r.lines, r.blocks)?;
    writeln!(out, "  time            {}", hms(t.total_s))?;
    writeln!(
        out,
        "    motion {}  dwell {}  heating {}  homing {}  overhead {}",
        hms(t.motion_s),
        hms(t.dwell_s),
        hms(t.heating_s),
        hms(t.homing_s),
        hms(t.overhead_s)
    )?;
    print_layers_and_features(out, &r.layer_s, r.unlayered_s, &r.feature_s)?;
    for (tool, mm) in r.filament_mm.iter().enumerate() {
        let steps = r.steps.tools.get(tool).copied().unwrap_or(0);
        write!(out, "  filament T{tool:<3}  {mm:.2} mm  ({steps} E steps)")?;
        // The motor's net feed; what left the nozzle (stats', the slicer's) adds what is still
        // retracted at the end.
        match r.retracted_at_end_mm.get(tool).copied().filter(|r| *r >= 0.005) {
            Some(back) => {
                writeln!(out, "; {:.2} mm left the nozzle, {back:.2} mm stayed retracted", mm + back)?
            }
            None => writeln!(out)?,
        }
    }
    for (input, mm) in r.mixing_input_mm.iter().enumerate() {
        let steps = r.steps.mixing.get(input).copied().unwrap_or(0);
        writeln!(out, "  mixing input {input}  {mm:.2} mm  ({steps} steps)")?;
    }
    let s = &r.steps.axes;
    writeln!(out, "  steps           X {}  Y {}  Z {}  E {}  A {}", s[0], s[1], s[2], s[3], s[4])?;
    let [x, y, z, e, _] = r.position;
    writeln!(
        out,
        "  end position    X {x:.2} Y {y:.2} Z {z:.2} E {e:.2}  (Count X {} Y {} Z {})",
        r.count[0], r.count[1], r.count[2]
    )?;
    for h in &r.heaters {
        writeln!(
            out,
            "  heater {:<8} max {:.1} C, end {:.1} / {:.1} C, duty {:.0} %, {:.1} Wh",
            match h.heater {
                HeaterId::Hotend(n) => format!("T{n}"),
                HeaterId::Bed => "bed".to_owned(),
            },
            h.max_c,
            h.temp_c,
            h.target_c,
            h.mean_duty * 100.0,
            h.energy_wh
        )?;
    }
    if let Some(ink) = &r.inkjet {
        writeln!(out, "  inkjet          {} layers, drops per head {:?}", ink.layers, ink.drops_per_head)?;
    }
    if !r.unknown_commands.is_empty() {
        // The most frequent first; names escaped, since they come from whatever the file holds.
        let mut by_count: Vec<(&String, &u64)> = r.unknown_commands.iter().collect();
        by_count.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
        const SHOWN: usize = 10;
        let mut list: Vec<String> =
            by_count.iter().take(SHOWN).map(|(c, n)| format!("{} x{n}", c.escape_debug())).collect();
        if by_count.len() > SHOWN {
            list.push(format!("... {} more (see --json)", by_count.len() - SHOWN));
        }
        writeln!(out, "  unknown         {}", list.join(", "))?;
    }
    print_malformed(out, &r.malformed, &r.huge_arcs)?;
    for e in errors {
        writeln!(out, "  {e}")?;
    }
    if r.halted {
        writeln!(out, "  HALTED")?;
    }
    let total: u64 = r.warning_counts.values().sum();
    if total > 0 {
        let kinds: Vec<String> = r.warning_counts.iter().map(|(k, n)| format!("{k} {n}")).collect();
        writeln!(out, "  warnings        {total} ({})", kinds.join(", "))?;
        for w in r.warnings.iter().filter(|w| w.kind.name() != "unknown_command").take(10) {
            writeln!(out, "    line {}: {}", w.line, w.kind)?;
        }
    }
    Ok(())
}

/// Lines that could not be read, as `check` reports them, and arcs too long to plan finely:
/// handled, but never silently.
pub(super) fn print_malformed(out: &mut dyn Write, m: &Malformed, arcs: &HugeArcs) -> io::Result<()> {
    crate::common::print_malformed(out, m)?;
    if let Some(first) = arcs.first_huge_arc_line {
        writeln!(
            out,
            "  huge arcs       {} of more than {MAX_ARC_CHORDS} chords, planned with longer ones (first: line {first})",
            arcs.huge_arcs
        )?;
    }
    Ok(())
}

/// The planner's time per layer (shortest, mean, longest) and per feature.
pub(super) fn print_layers_and_features(
    out: &mut dyn Write,
    layer_s: &[f64],
    unlayered_s: f64,
    feature_s: &BTreeMap<Feature, f64>,
) -> io::Result<()> {
    if let Some((slowest, max)) = layer_s.iter().copied().enumerate().max_by(|a, b| a.1.total_cmp(&b.1)) {
        let min = layer_s.iter().copied().fold(f64::INFINITY, f64::min);
        let mean = layer_s.iter().sum::<f64>() / layer_s.len() as f64;
        writeln!(
            out,
            "  layers          {}: min {min:.1} s, mean {mean:.1} s, max {max:.1} s (layer {slowest}); before the first {unlayered_s:.1} s",
            layer_s.len(),
        )?;
    }
    for (feature, t) in feature_s {
        writeln!(out, "    {:<18} {}", feature.name(), hms(*t))?;
    }
    Ok(())
}
