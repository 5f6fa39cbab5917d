//! `gweave rotary`: lathe-type printers (a nozzle over a turning mandrel).
//!
//! `wrap` prints a part sliced flat onto the mandrel; `tube` generates a seam-free tube of
//! continuous helical layers. Both print a summary (or JSON) read back from the written file,
//! as the machine will execute it, and can draw that path in 3D (`--preview out.png`).

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::{Args, Subcommand};
use gweave::rotary::cylinder::{FeedConvention, RotaryUnit};
use gweave::rotary::report::{MachineReport, TubeReport, WrapReport};
use gweave::{TubeOptions, WrapOptions};
use gweave_sim::transform::{self, Job};

use super::transform::{settings_file, Shown};
use crate::args::Lenient;
use crate::common::hms;
use crate::common::{print_summary, OutputArgs, ReportArgs};
use crate::files::Files;
use crate::options::{failed, Options};

/// Rotary (lathe-type) printing: wrap flat G-code onto a mandrel, or generate helical tubes.
#[derive(Args, Debug)]
pub struct RotaryArgs {
    #[command(subcommand)]
    pub command: RotaryCommand,
}

#[derive(Subcommand, Debug)]
pub enum RotaryCommand {
    Wrap(WrapArgs),
    Tube(TubeArgs),
}

pub fn run(args: RotaryArgs) -> Result<ExitCode> {
    match args.command {
        RotaryCommand::Wrap(a) => run_wrap(a),
        RotaryCommand::Tube(a) => run_tube(a),
    }
}

/// Where both commands draw what they wrote.
#[derive(Args, Debug)]
pub struct PreviewArg {
    /// Draw the executed path in 3D to this PNG (isometric, one colour per layer).
    #[arg(long, value_name = "PNG")]
    pub preview: Option<PathBuf>,
}

fn print_machine(out: &mut dyn Write, m: &MachineReport) -> io::Result<()> {
    writeln!(
        out,
        "  mandrel         {:.3} mm (circumference {:.3} mm), axes {} (rotary in {}), feed {}",
        m.mandrel_diameter_mm,
        m.circumference_mm,
        m.axes,
        match m.rotary_unit {
            RotaryUnit::Degrees => "degrees",
            RotaryUnit::Mm => "mm",
        },
        match m.feed_convention {
            FeedConvention::Nist => "nist",
            FeedConvention::Combined => "combined",
            FeedConvention::InverseTime => "inverse-time (G93)",
        }
    )
}

/// Wrap a part sliced flat onto the mandrel of a lathe-type printer.
///
/// The flat X runs along the mandrel, Y around it (model the part unwrapped with its Y length
/// equal to the circumference pi*D) and Z away from it: theta = 360*y/(pi*D), radius D/2 + z.
/// Extrusion grows with the surface at each radius; F keeps the slicer's surface speed in the
/// machine's feed convention; arcs are linearised and long moves cut into chords.
///
/// Example: `gweave rotary wrap plate.gcode -o sleeve.gcode --mandrel-diameter 30
/// --seam-rotation 7.5 --preview sleeve.png`. Before: `G1 X10 Y15 E1.0 F1200`; after, on a
/// 60 mm circumference at Z0.2: `G1 X10.000 A90.000 E1.01455 F656.097`.
#[derive(Args, Debug)]
pub struct WrapArgs {
    /// The flat G-code file.
    pub input: PathBuf,
    #[command(flatten)]
    pub out: OutputArgs,
    #[command(flatten)]
    pub options: Options<WrapOptions>,
    #[command(flatten)]
    pub preview: PreviewArg,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

fn run_wrap(args: WrapArgs) -> Result<ExitCode> {
    let target = args.out.target()?;
    args.report.refuse_json_with_stdout(target.is_stdout())?;
    let preview = args.preview.preview.as_deref();
    let (settings_flag, settings) = settings_file(&*args.options);
    Files::new()
        .read("INPUT", Some(&args.input))
        .read(&settings_flag, settings.as_deref())
        .target(&target, &args.input)
        .write("--preview", preview)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let job = |job: Job<'_>| transform::rotary_wrap(&args.options, job, preview);
    let shown = Shown { warnings: |_| Vec::new(), summary: |r, out| print_wrap(out, r) };
    super::transform::run_job(&args.report, args.lenient.strictness(), &args.input, &target, job, shown)
}

/// Layers a summary lists in full: a part of a few hundred layers printed a line each (a
/// new user's 535-layer wrap, 540 lines); past this, the first and last halves and a count.
const LAYERS_SHOWN: usize = 20;

/// One line a layer, [`LAYERS_SHOWN`] at most, the rest counted (every layer is in `--json`).
fn print_layers<T>(out: &mut dyn Write, layers: &[T], line: impl Fn(&T) -> String) -> io::Result<()> {
    let half = LAYERS_SHOWN / 2;
    for (i, l) in layers.iter().enumerate() {
        if layers.len() <= LAYERS_SHOWN || i < half || i >= layers.len() - half {
            writeln!(out, "{}", line(l))?;
        } else if i == half {
            writeln!(out, "    ... {} more layers (see --json)", layers.len() - LAYERS_SHOWN)?;
        }
    }
    Ok(())
}

fn print_wrap(out: &mut dyn Write, r: &WrapReport) -> io::Result<()> {
    if let Some(dest) = &r.output {
        writeln!(out, "{} -> {}", r.input.display(), dest.display())?;
    }
    print_machine(out, &r.machine)?;
    let mapping = match (r.keep_arc_length, r.helical) {
        (true, _) => "arc length kept (Diabase)",
        (false, true) => "helical: theta = 360*(y-y0)/C, radius rising one layer per turn, E scaled",
        (false, false) => "theta = 360*y/C, E scaled",
    };
    writeln!(out, "  mapping         {mapping}")?;
    writeln!(out, "  layers          {}", r.layers.len())?;
    print_layers(out, &r.layers, |l| {
        format!(
            "    layer {:<4} r {:>8.3} mm  theta {:>9.3} .. {:>9.3} deg (span {:>7.3})  seam {:>7.3} deg  {:>9.2} mm",
            l.layer.index,
            l.layer.radius_mm,
            l.layer.theta_range_deg[0],
            l.layer.theta_range_deg[1],
            l.span_deg,
            l.seam_deg,
            l.layer.filament_mm
        )
    })?;
    if r.helical {
        // Each layer is one turn of a helix that ends where the next begins (docs/rotary.md).
        writeln!(
            out,
            "  seam            none: each layer is one turn of a helix, ending where the next starts"
        )?;
    } else {
        writeln!(
            out,
            "  seam            at flat y = 0: {:.3} deg, turning {:.3} deg per layer",
            r.seam_offset_deg, r.seam_rotation_per_layer_deg
        )?;
    }
    writeln!(out, "  filament        {:.2} mm", r.filament_mm)?;
    writeln!(out, "  time (F only)   {}", hms(r.time_s))
}

/// Generate a seam-free tube of continuous helical layers on the mandrel.
///
/// Layer k lies on radius D/2 + (k + 1/2)*h and advances one pitch per turn (the bead width
/// closes the wall, more leaves an open lattice); the helix reverses its handedness every
/// layer (interweaving) unless --no-interweave; the spindle speed is recomputed per layer to
/// keep the surface speed; E = w*h*L/A_filament; layers join without travel.
///
/// Example: `gweave rotary tube -o tube.gcode --mandrel-diameter 20 --length 40 --layer-count 4
/// --pitch 3 --preview tube.png` (an open, interwoven lattice).
#[derive(Args, Debug)]
pub struct TubeArgs {
    /// Output file (`-` for standard output).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    #[command(flatten)]
    pub format: crate::format::FormatArgs,
    #[command(flatten)]
    pub options: Options<TubeOptions>,
    #[command(flatten)]
    pub preview: PreviewArg,
    #[command(flatten)]
    pub report: ReportArgs,
}

fn run_tube(args: TubeArgs) -> Result<ExitCode> {
    let target = args.format.target(&args.output)?;
    args.report.refuse_json_with_stdout(target.is_stdout())?;
    let preview = args.preview.preview.as_deref();
    let (settings_flag, settings) = settings_file(&*args.options);
    Files::new()
        .read(&settings_flag, settings.as_deref())
        .write("-o", Some(&args.output))
        .write("--preview", preview)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let report = transform::rotary_tube(&args.options, &target, preview).map_err(failed)?;
    if args.report.emit(&report)? && !target.is_stdout() {
        print_summary(|out| print_tube(out, &report))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn print_tube(out: &mut dyn Write, r: &TubeReport) -> io::Result<()> {
    if let Some(dest) = &r.output {
        writeln!(out, "{}", dest.display())?;
    }
    print_machine(out, &r.machine)?;
    writeln!(
        out,
        "  tube            length {:.3} mm, bead {:.3} x {:.3} mm, pitch {:.3} mm, {}",
        r.length_mm,
        r.bead_width_mm,
        r.layer_height_mm,
        r.pitch_mm,
        if r.interweave { "interwoven" } else { "one handedness" }
    )?;
    writeln!(out, "  layers          {}", r.layers.len())?;
    print_layers(out, &r.layers, |l| {
        format!(
            "    layer {:<3} r {:>8.3} mm  {:<5} {:>8.2} turns  {:>8.3} deg/s  X {:.3} -> {:.3}  A {:.1} -> {:.1}",
            l.index,
            l.radius_mm,
            format!("{:?}", l.handedness).to_lowercase(),
            l.turns,
            l.angular_speed_deg_s,
            l.axial_mm[0],
            l.axial_mm[1],
            l.theta_deg[0],
            l.theta_deg[1]
        )
    })?;
    writeln!(out, "  seam            none: each layer starts where the one below ended, no travel")?;
    let share = 100.0 * r.extruded_mm3 / r.wall_volume_mm3;
    let versus = if r.pitch_mm == r.bead_width_mm {
        format!("tube wall {:.1} mm3, {:+.2} %", r.wall_volume_mm3, share - 100.0)
    } else {
        format!("lattice: {share:.1} % of the closed wall's {:.1} mm3", r.wall_volume_mm3)
    };
    writeln!(out, "  filament        {:.2} mm = {:.1} mm3 ({versus})", r.filament_mm, r.extruded_mm3)?;
    writeln!(out, "  time (F only)   {}", hms(r.print_time_s))?;
    if let Some(n) = r.executed_beads {
        writeln!(out, "  read back       {n} extruding moves")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A new user's trial: a 535-layer wrap printed 540 lines. Past LAYERS_SHOWN the first and
    /// last ten are listed and the rest counted; up to it, every layer.
    #[test]
    fn a_long_summary_lists_the_ends_of_its_layers() {
        let lines = |n: usize| {
            let mut out = Vec::new();
            print_layers(&mut out, &(0..n).collect::<Vec<_>>(), |l| format!("layer {l}")).unwrap();
            String::from_utf8(out).unwrap().lines().map(str::to_owned).collect::<Vec<_>>()
        };
        assert_eq!(lines(20).len(), 20);
        let long = lines(535);
        assert_eq!(long.len(), 21);
        assert_eq!((long[9].as_str(), long[11].as_str()), ("layer 9", "layer 525"));
        assert_eq!(long[10], "    ... 515 more layers (see --json)");
    }
}
