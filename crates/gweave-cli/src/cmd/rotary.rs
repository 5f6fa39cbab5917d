//! `gweave rotary`: lathe-type printers (a nozzle over a turning mandrel).
//!
//! `wrap` prints a part sliced flat onto the mandrel; `tube` generates a seam-free tube of
//! continuous helical layers. Both print a summary (or JSON) read back from the written file,
//! as the machine will execute it, and can draw that path in 3D (`--preview out.png`).

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::{Args, Subcommand, ValueEnum};
use gweave::gcode::writer::Target;
use gweave::range::{ANGLE_DEG, FILAMENT_DIAMETER_MM, LAYER_HEIGHT_MM, SPEED_MM_S, TEMPERATURE_C};
use gweave::rotary::cylinder::{FeedConvention, RotaryUnit, MANDREL_DIAMETER_MM};
use gweave::rotary::helix::{
    TubeParams, BEAD_WIDTH_MM, CHORD_TOLERANCE_MM, PITCH_MM, SEGMENTS_PER_TURN, TUBE_LAYERS, TUBE_LENGTH_MM,
};
use gweave::rotary::overrides::{MachineOverrides, TubeOverrides, WrapOverrides};
use gweave::rotary::report::{MachineReport, TubeReport, WrapReport};
use gweave::rotary::wrap::WrapConfig;
use gweave::rotary::RotaryError;
use gweave::rotary_job;

use crate::args::Lenient;
use crate::common::hms;
use crate::common::{in_range, load, print_malformed, print_summary, OutputArgs, ReportArgs};
use crate::files::Files;
use crate::finish;
use gweave::malformed::Transformed;
use gweave::run::Run;

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

/// How the firmware reads F on rotary moves.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum FeedArg {
    /// F is the linear (X, Z) speed; rotary-only moves in deg/min (LinuxCNC, Marlin default).
    Nist,
    /// F = sqrt(dX^2 + dZ^2 + dA^2)/T (Marlin ARTICULATED_ROBOT_ARM, RRF `M584 S0`).
    Combined,
    /// G93: F = 1/T, T in minutes.
    InverseTime,
}

/// The unit of the rotary word.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum UnitArg {
    /// Degrees (a true rotary axis such as A).
    Deg,
    /// Millimetres of circumference at the mandrel surface (a rotary axis set up as Y).
    Mm,
}

/// The machine, shared by both commands; flags override the TOML file.
#[derive(Args, Debug)]
pub struct MachineArgs {
    /// Mandrel diameter, mm [default: the config file's `[machine] mandrel_diameter_mm`; one of
    /// them is required].
    #[arg(long, value_name = "MM", value_parser = in_range(MANDREL_DIAMETER_MM))]
    pub mandrel_diameter: Option<f64>,
    /// How the firmware reads F on rotary moves (`--feed` is an older name) [default: nist].
    #[arg(long, alias = "feed", value_enum)]
    pub feed_convention: Option<FeedArg>,
    /// Unit of the rotary word [default: deg].
    #[arg(long, value_enum)]
    pub rotary_unit: Option<UnitArg>,
    /// Axis letters: axial, rotary, radial [default: X,A,Z].
    #[arg(long, value_name = "X,A,Z", value_parser = parse_axes)]
    pub axes: Option<[char; 3]>,
    /// Configuration file (TOML; see examples/rotary/).
    #[arg(short = 'c', long, value_name = "TOML")]
    pub config: Option<PathBuf>,
    /// Draw the executed path in 3D to this PNG (isometric, one colour per layer).
    #[arg(long, value_name = "PNG")]
    pub preview: Option<PathBuf>,
}

fn parse_axes(text: &str) -> Result<[char; 3], String> {
    let letters: Vec<char> = text.split(',').map(str::trim).flat_map(str::chars).collect();
    match letters[..] {
        [a, r, z] => Ok([a, r, z].map(|c| c.to_ascii_uppercase())),
        _ => Err(format!("three axis letters are needed (axial,rotary,radial), got `{text}`")),
    }
}

impl MachineArgs {
    /// The machine's flags, in the library's words.
    fn overrides(&self) -> MachineOverrides {
        MachineOverrides {
            mandrel_diameter_mm: self.mandrel_diameter,
            feed_convention: self.feed_convention.map(|feed| match feed {
                FeedArg::Nist => FeedConvention::Nist,
                FeedArg::Combined => FeedConvention::Combined,
                FeedArg::InverseTime => FeedConvention::InverseTime,
            }),
            rotary_unit: self.rotary_unit.map(|unit| match unit {
                UnitArg::Deg => RotaryUnit::Degrees,
                UnitArg::Mm => RotaryUnit::Mm,
            }),
            axes: self.axes,
        }
    }

    /// The settings `read` makes of the config file (its errors name the file) or, without
    /// one, of the flags alone (`WrapConfig::read`, `TubeParams::read`).
    fn read<T>(
        &self,
        read: impl FnOnce(Option<&str>, &MachineOverrides) -> Result<T, RotaryError>,
    ) -> Result<T> {
        let machine = self.overrides();
        match &self.config {
            Some(path) => load(path, |text| read(Some(text), &machine)),
            None => Ok(read(None, &machine)?),
        }
    }
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
    pub machine: MachineArgs,
    /// Keep flat arc lengths (the Diabase wizard: A = Y*180/(pi*(R + z - z1)), E unchanged).
    #[arg(long)]
    pub keep_arc_length: bool,
    /// Wind each layer as one turn of a helix rising one layer height per turn, joined to the
    /// next layer without a step: no weld line (the rotary seed's helical unwrapping).
    #[arg(long, conflicts_with_all = ["keep_arc_length", "seam_rotation"])]
    pub helical: bool,
    /// Wrap a part wider than the circumference over itself instead of refusing it.
    #[arg(long)]
    pub allow_overlap: bool,
    /// Turn every layer this much further than the one below, degrees, so seams do not stack
    /// [default: 0].
    #[arg(long, value_name = "DEG", value_parser = in_range(ANGLE_DEG))]
    pub seam_rotation: Option<f64>,
    /// Largest chord sagitta on the cylinder, mm (0: one move per flat move) [default: 0.01].
    #[arg(long, value_name = "MM", value_parser = in_range(CHORD_TOLERANCE_MM.or_zero()))]
    pub chord_tol: Option<f64>,
    #[command(flatten)]
    pub lenient: Lenient,
    #[command(flatten)]
    pub report: ReportArgs,
}

fn run_wrap(args: WrapArgs) -> Result<ExitCode> {
    let target = args.out.target()?;
    args.report.refuse_json_with_stdout(target.is_stdout())?;
    Files::new()
        .read("INPUT", Some(&args.input))
        .read("-c", args.machine.config.as_deref())
        .target(&target, &args.input)
        .write("--preview", args.machine.preview.as_deref())
        .write("--report", args.report.report.as_deref())
        .check()?;
    let mut config = args.machine.read(WrapConfig::read)?;
    config.apply(&WrapOverrides {
        machine: args.machine.overrides(),
        keep_arc_length: args.keep_arc_length.then_some(true),
        helical: args.helical,
        allow_overlap: args.allow_overlap,
        seam_rotation_deg: args.seam_rotation,
        chord_tolerance_mm: args.chord_tol,
    })?;
    finish::refuse_second_run(&args.input, "rotary wrap")?;
    let mut bar = args.report.quiet.bar();
    let preview = args.machine.preview.as_deref();
    let strictness = args.lenient.strictness();
    let wrap = |t: &Target| {
        let run = Run::file(&args.input).to(t).progress(&mut bar).strictness(strictness);
        Ok(rotary_job::wrap_file(&config, run, preview)?)
    };
    // Its own time: the default machine of the estimator does not read the rotary feed.
    let ((mut report, malformed), written) =
        finish::with_metadata_timed(Some(&args.input), &target, wrap, |r| Some(r.0.time_s))?;
    report.output = written;
    drop(bar);
    if args.report.emit(&Transformed::new(&report, malformed, strictness))? && !target.is_stdout() {
        print_summary(|out| {
            print_wrap(out, &report)?;
            print_malformed(out, &malformed)
        })?;
    }
    Ok(ExitCode::SUCCESS)
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
    for l in &r.layers {
        writeln!(
            out,
            "    layer {:<4} r {:>8.3} mm  theta {:>9.3} .. {:>9.3} deg (span {:>7.3})  seam {:>7.3} deg  {:>9.2} mm",
            l.layer.index,
            l.layer.radius_mm,
            l.layer.theta_range_deg[0],
            l.layer.theta_range_deg[1],
            l.span_deg,
            l.seam_deg,
            l.layer.filament_mm
        )?;
    }
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
    pub machine: MachineArgs,
    /// Tube length along the mandrel, mm [default: 50].
    #[arg(long, value_name = "MM", value_parser = in_range(TUBE_LENGTH_MM))]
    pub length: Option<f64>,
    /// Number of layers (`--layers` is an older name) [default: 4].
    #[arg(long, alias = "layers", value_name = "N", value_parser = in_range(TUBE_LAYERS))]
    pub layer_count: Option<u32>,
    /// Layer height (radial step), mm [default: 0.2].
    #[arg(long, value_name = "MM", value_parser = in_range(LAYER_HEIGHT_MM))]
    pub layer_height: Option<f64>,
    /// Bead width, mm [default: 0.4].
    #[arg(long, value_name = "MM", value_parser = in_range(BEAD_WIDTH_MM))]
    pub bead_width: Option<f64>,
    /// Axial advance per turn, mm [default: the bead width, a closed wall].
    #[arg(long, value_name = "MM", value_parser = in_range(PITCH_MM))]
    pub pitch: Option<f64>,
    /// Keep one handedness for every layer (the spindle reverses instead).
    #[arg(long)]
    pub no_interweave: bool,
    /// At least this many chords per turn [default: as many as --chord-tol needs].
    #[arg(long, value_name = "N", value_parser = in_range(SEGMENTS_PER_TURN))]
    pub segments_per_turn: Option<u32>,
    /// Largest chord sagitta, mm [default: 0.01].
    #[arg(long, value_name = "MM", value_parser = in_range(CHORD_TOLERANCE_MM))]
    pub chord_tol: Option<f64>,
    /// Surface speed while printing, mm/s [default: 20].
    #[arg(long, value_name = "MM_S", value_parser = in_range(SPEED_MM_S))]
    pub speed: Option<f64>,
    /// Nozzle temperature, degrees C [default: 190].
    #[arg(long, value_name = "C", value_parser = in_range(TEMPERATURE_C))]
    pub temp: Option<f64>,
    /// Filament diameter, mm [default: 1.75].
    #[arg(long, value_name = "MM", value_parser = in_range(FILAMENT_DIAMETER_MM))]
    pub filament_diameter: Option<f64>,
    #[command(flatten)]
    pub report: ReportArgs,
}

fn tube_params(args: &TubeArgs) -> Result<TubeParams> {
    let mut t = args.machine.read(TubeParams::read)?;
    t.apply(&TubeOverrides {
        machine: args.machine.overrides(),
        length_mm: args.length,
        layers: args.layer_count,
        layer_height_mm: args.layer_height,
        bead_width_mm: args.bead_width,
        pitch_mm: args.pitch,
        interweave: args.no_interweave.then_some(false),
        segments_per_turn: args.segments_per_turn,
        chord_tolerance_mm: args.chord_tol,
        print_speed_mm_s: args.speed,
        nozzle_temp_c: args.temp,
        filament_diameter_mm: args.filament_diameter,
    })?;
    Ok(t)
}

fn run_tube(args: TubeArgs) -> Result<ExitCode> {
    args.report.refuse_json_with_stdout(args.output == Path::new("-"))?;
    Files::new()
        .read("-c", args.machine.config.as_deref())
        .write("-o", Some(&args.output))
        .write("--preview", args.machine.preview.as_deref())
        .write("--report", args.report.report.as_deref())
        .check()?;
    let params = tube_params(&args)?;
    let target = args.format.target(&args.output)?;
    let preview = args.machine.preview.as_deref();
    let tube = |t: &Target| Ok(rotary_job::tube_file(&params, t, preview)?);
    let (mut report, written) =
        finish::with_metadata_timed(None, &target, tube, |r: &TubeReport| Some(r.print_time_s))?;
    report.output = written;
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
    for l in &r.layers {
        writeln!(
            out,
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
        )?;
    }
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
