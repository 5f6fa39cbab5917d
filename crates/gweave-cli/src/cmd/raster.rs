//! `gweave raster`: layer images (or a PrusaSlicer `.sl1`) to binder-jet inkjet G-code.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::{Args, ValueEnum};
use gweave::firmware::Firmware;
use gweave::gcode::writer::Target;
use gweave::gen::printhead::PrintheadProfile;
use gweave::gen::raster::{FireOrder, DENSITY, HEADS, PATTERN_COLUMNS, THRESHOLD};
use gweave::gen::raster_job::{HeadSource, JobOptions, JobReport, Source};
use gweave::post::metadata::Figures;
use gweave::range::{DPI, FEED_MM_MIN, LAYER_HEIGHT_MM, PIXEL_MM, POSITION_MM};
use gweave_sim::{Estimator, MachineProfile};

use crate::args::load_machine;
use crate::common::{hms, in_range, numbers_in, print_summary, ReportArgs};
use crate::files::Files;
use crate::finish;
use crate::firmware_arg::inkjet_firmware;

/// Layer images to inkjet G-code for binder jetting: bands as tall as the nozzle row, per
/// inked column `G1 X`, `M400`, `M700 P<head> S<bits>` (Marlin hpc6602) or `M578` (RepRapFirmware).
///
/// Serpentine passes by default; empty columns and bands are skipped; Z and a powder recoat
/// block between layers. Pixels lit at or above the threshold are binder (`--invert` for black on
/// white). Example: `gweave raster layers/ -o part.gcode --head examples/raster/c6602.toml`.
#[derive(Args, Debug)]
pub struct RasterArgs {
    /// Folders, globs (`'slices/*.png'`), image files (BMP, PNG) in layer order, or one `.sl1`.
    #[arg(required_unless_present = "test_pattern")]
    pub inputs: Vec<PathBuf>,
    /// Output G-code file (`-` for standard output).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    #[command(flatten)]
    pub format: crate::format::FormatArgs,
    /// Printhead profile (TOML; default: HP C6602, 12 nozzles at 96 dpi, one head).
    #[arg(long, value_name = "PROFILE.toml")]
    pub head: Option<PathBuf>,
    /// Write for this inkjet machine (a profile file or a built-in name: binder-jet,
    /// inkjet-c6602): its printhead, its powder recoat and its canvas origin, as `gweave sim
    /// --machine` checks them. Instead of --head.
    #[arg(long, value_name = "TOML|NAME", conflicts_with = "head")]
    pub machine: Option<PathBuf>,
    /// Fraction of full scale at or above which a pixel gets binder.
    #[arg(long, default_value_t = 0.5, value_name = "0..1", value_parser = in_range(THRESHOLD))]
    pub threshold: f64,
    /// Dark pixels get binder (black-on-white drawings, as in the binder-jet seed's BMPs).
    #[arg(long)]
    pub invert: bool,
    /// The images' first row is the far edge (+Y up, as pictures are drawn); default: the first
    /// row is printed at the lowest Y, as `gweave slice-raster` writes them.
    #[arg(long)]
    pub flip_y: bool,
    /// Print every pass left to right (default: serpentine).
    #[arg(long)]
    pub one_way: bool,
    /// Fire `after` the move onto each column (`G1`, `M400`, `M700`), or `before` the move to
    /// the next one as the binder-jet seed writes it (`M700`, `M400`, `G1`).
    #[arg(long, value_enum, default_value = "after")]
    pub fire_order: FireOrderArg,
    /// Fires per pixel (binder saturation).
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = in_range(DENSITY))]
    pub density: u32,
    /// Bed position of the image corner, mm [default: the machine's canvas origin, else 20,20].
    #[arg(long, value_name = "X,Y", value_parser = numbers_in::<2>(POSITION_MM))]
    pub origin: Option<[f64; 2]>,
    /// Layer thickness, mm (default: the .sl1's own, else 0.1).
    #[arg(long, value_name = "MM", value_parser = in_range(LAYER_HEIGHT_MM))]
    pub layer_height: Option<f64>,
    /// Pixel size of the images, mm; they are resampled to the nozzle pitch [default: 25.4/--dpi,
    /// else one pixel per nozzle pitch, or the .sl1's own].
    #[arg(long, value_name = "MM", conflicts_with = "dpi", value_parser = in_range(PIXEL_MM))]
    pub pixel_mm: Option<f64>,
    /// Resolution of the images, dots per inch (pixel = 25.4 / D mm) [default: the nozzle pitch's].
    #[arg(long, value_name = "D", value_parser = in_range(DPI))]
    pub dpi: Option<f64>,
    /// Heads to use (the profile's offsets; missing heads get zero offsets) [default: one per
    /// --channels entry, else 1].
    #[arg(long, value_name = "N", value_parser = in_range(HEADS))]
    pub heads: Option<usize>,
    /// One image channel per head, e.g. `r,b` (r, g, b, luma) [default: luma, one head].
    #[arg(long, value_name = "LIST")]
    pub channels: Option<String>,
    /// G-code between layers (powder recoat); `{layer}` and `{z}` are replaced.
    #[arg(long, value_name = "FILE")]
    pub recoat: Option<PathBuf>,
    /// G-code before the first layer.
    #[arg(long, value_name = "FILE")]
    pub start: Option<PathBuf>,
    /// G-code after the last layer.
    #[arg(long, value_name = "FILE")]
    pub end: Option<PathBuf>,
    /// Fire command dialect (default: the profile's).
    #[arg(long, value_parser = inkjet_firmware())]
    pub dialect: Option<Firmware>,
    /// Carriage feed rate, mm/min [default: 3000].
    #[arg(long, value_name = "MM_MIN", value_parser = in_range(FEED_MM_MIN))]
    pub feed: Option<f64>,
    /// Estimate time from the path at the feed rate instead of running the planner (faster).
    #[arg(long)]
    pub fast_estimate: bool,
    /// Write a nozzle test pattern instead (each nozzle address fired alone, in order).
    #[arg(long)]
    pub test_pattern: bool,
    /// Columns per nozzle in the test pattern.
    #[arg(long, default_value_t = 4, value_name = "N", value_parser = in_range(PATTERN_COLUMNS))]
    pub pattern_columns: usize,
    #[command(flatten)]
    pub report: ReportArgs,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum FireOrderArg {
    /// Move, `M400`, fire: the head stands at the column when it fires.
    After,
    /// Fire, `M400`, move: the seed's order (fires while moving on Marlin).
    Before,
}

impl RasterArgs {
    /// The job's options; `machine` is the loaded `--machine`.
    fn options(&self, machine: Option<&MachineProfile>) -> Result<JobOptions> {
        Ok(JobOptions {
            inputs: self.inputs.clone(),
            head: match (machine, &self.head) {
                (Some(machine), _) => Some(machine.raster_head()?),
                (None, head) => head.clone().map(HeadSource::File),
            },
            threshold: self.threshold,
            invert: self.invert,
            flip_y: self.flip_y,
            one_way: self.one_way,
            fire_order: match self.fire_order {
                FireOrderArg::After => FireOrder::After,
                FireOrderArg::Before => FireOrder::Before,
            },
            density: self.density,
            origin_mm: self.origin.map(|[x, y]| (x, y)),
            layer_height_mm: self.layer_height,
            pixel_mm: self.pixel_mm,
            dpi: self.dpi,
            heads: self.heads,
            channels: self.channels.clone(),
            recoat: self.recoat.clone(),
            start: self.start.clone(),
            end: self.end.clone(),
            dialect: self.dialect,
            feed_mm_min: self.feed,
            fast_estimate: self.fast_estimate,
        })
    }
}

pub fn run(args: RasterArgs) -> Result<ExitCode> {
    let machine = args.machine.as_deref().map(load_machine).transpose()?;
    let options = args.options(machine.as_ref())?;
    // The planner times the job on the machine it is written for, else on Marlin's defaults.
    let motion = machine.as_ref().map(|m| m.motion.clone()).unwrap_or_default();
    let timer = || Estimator::line_timer_on(&motion);
    let planner = machine.as_ref().map_or("Marlin defaults", |m| m.name.as_str());
    let to_stdout = args.output == Path::new("-");
    args.report.refuse_json_with_stdout(to_stdout)?;
    let target = args.format.target(&args.output)?;
    let source = if args.test_pattern { None } else { Some(options.source()?) };
    let images = source.as_ref().map(|(s, _)| s.paths()).unwrap_or_default();
    Files::new()
        .read_all("INPUTS", images)
        .read("--head", args.head.as_deref())
        .read("--machine", args.machine.as_deref())
        .read("--recoat", args.recoat.as_deref())
        .read("--start", args.start.as_deref())
        .read("--end", args.end.as_deref())
        .write("-o", Some(&args.output))
        .write("--report", args.report.report.as_deref())
        .check()?;
    let Some((source, heads)) = source else {
        let pattern = |t: &Target| Ok(options.test_pattern(t, args.pattern_columns)?);
        let ((rep, profile), _) = finish::with_metadata(None, &target, pattern)?;
        if args.report.emit(&rep)? && !to_stdout {
            print_summary(|out| {
                writeln!(out, "{}: nozzle test pattern", args.output.display())?;
                writeln!(
                    out,
                    "  {} head(s) x {} nozzles, {} columns per address, {} fire commands",
                    profile.heads.len(),
                    profile.nozzle_count,
                    args.pattern_columns,
                    rep.fire_commands
                )?;
                writeln!(out, "  column group a fires address a alone: the row it prints is nozzle_rows[a]")
            })?;
        }
        return Ok(ExitCode::SUCCESS);
    };
    let from_images = matches!(source, Source::Stacks(_));
    let job = options.job_from(source, heads)?;
    let mut bar = LayerBar::new(args.report.quiet.quiet);
    // Its own time counts the printhead's firing, which the estimator does not know.
    let (mut report, _) = if job.knows_its_figures() {
        // Its time and filament (none) are known as it writes: nothing is read back.
        let run = |out: &mut dyn Write| Ok(job.run_into(out, &mut bar, timer)?);
        let figures = |r: &JobReport| Figures { time_s: [r.time.total_s; 2], ..Figures::default() };
        finish::with_own_figures(&target, run, figures)?
    } else {
        let run = |t: &Target| Ok(job.run(t, &mut bar, timer)?);
        finish::with_metadata_timed(None, &target, run, |r: &JobReport| Some(r.time.total_s))?
    };
    report.output = if to_stdout { "-".into() } else { args.output.display().to_string() };
    drop(bar);
    if args.report.emit(&report)? && !to_stdout {
        print_summary(|out| print_human(out, &report, &job.profile, planner))?;
    }
    if from_images && args.layer_height.is_none() {
        eprintln!("gweave: note: {}", layer_height_hint(args.pixel_mm.or(args.dpi.map(|d| 25.4 / d))));
    }
    if from_images && args.pixel_mm.is_none() && args.dpi.is_none() {
        eprintln!("gweave: note: {}", pixel_size_hint(&job.profile));
    }
    Ok(ExitCode::SUCCESS)
}

/// Images carry no layer height, so a stack gets the default; a stack sliced from a model at
/// its pixel size (a voxel stack, as medical and CT scans are) printed at 0.1 mm comes out
/// squashed or stretched by the ratio. Say so, with the flag that fixes it.
fn layer_height_hint(pixel_mm: Option<f64>) -> String {
    let default = gweave::gen::raster::DEFAULT_LAYER_HEIGHT_MM;
    let fix = match pixel_mm {
        Some(px) => format!("--layer-height {px:.4} (the pixel size given)"),
        None => "--layer-height H".to_owned(),
    };
    format!(
        "images carry no layer height: the layers are {default} mm apart (the default); if the \
         stack was sliced at its pixel size (voxels), give {fix} so the part keeps its proportions"
    )
}

/// Images carry no pixel size either: each pixel is printed one nozzle pitch wide, so a stack
/// drawn at another resolution comes out larger or smaller (a PrusaSlicer `.sl1` exported to
/// BMPs at 0.05 mm a pixel prints five times too large). Say so, with the size it took.
fn pixel_size_hint(profile: &PrintheadProfile) -> String {
    format!(
        "images carry no pixel size: each pixel is one nozzle pitch ({:.4} mm, {} dpi); if they \
         were drawn at another resolution give --pixel-mm P or --dpi D so the part keeps its size",
        profile.pitch_mm(),
        profile.dpi
    )
}

/// The human summary; `planner` names the motion the time was planned on.
fn print_human(
    out: &mut dyn Write,
    r: &JobReport,
    profile: &PrintheadProfile,
    planner: &str,
) -> io::Result<()> {
    let rr = &r.raster;
    writeln!(out, "{}", r.output)?;
    writeln!(
        out,
        "  head            {} nozzles at {} dpi ({:.6} mm), {} head(s), M{}",
        profile.nozzle_count,
        profile.dpi,
        profile.pitch_mm(),
        r.heads,
        profile.fire_code()
    )?;
    writeln!(out, "  layers          {} ({} images read)", rr.layers, r.images_read)?;
    writeln!(out, "  bands           {} printed, {} empty skipped", rr.bands_printed, rr.bands_skipped)?;
    writeln!(out, "  columns         {} fired, {} empty skipped", rr.columns_fired, rr.columns_skipped)?;
    writeln!(out, "  fire commands   {}", rr.fire_commands)?;
    for (h, d) in rr.drops_per_head.iter().enumerate() {
        writeln!(out, "    P{h} drops      {d}")?;
    }
    match rr.binder_volume_ul {
        Some(v) => writeln!(out, "  binder          {v:.3} uL ({:.4} mL)", v / 1000.0)?,
        None => writeln!(out, "  binder          (set drop_volume_pl in the profile)")?,
    }
    writeln!(
        out,
        "  path            {:.1} m, {} XY moves, {} Z moves",
        rr.xy_path_mm / 1000.0,
        rr.xy_moves,
        rr.z_moves
    )?;
    let method = match r.time.method {
        "planner" => format!("planner, {planner}"),
        _ => "path at feed rate, no acceleration".to_owned(),
    };
    writeln!(
        out,
        "  time            {} ({method}: motion {}, firing {})",
        hms(r.time.total_s),
        hms(r.time.motion_s),
        hms(r.time.fire_s)
    )?;
    Ok(())
}

/// A layer-count progress bar on stderr, only when stderr is a terminal and the job has enough
/// layers to take a while. (`crate::progress::Bar` counts input bytes, which says little here:
/// 1-bit PNG layers are tiny files that take long to raster.)
struct LayerBar(Option<indicatif::ProgressBar>);

/// Fewer layers than this finish too fast for a bar to help.
const MIN_LAYERS: u64 = 50;

impl LayerBar {
    fn new(quiet: bool) -> Self {
        use std::io::IsTerminal;
        LayerBar((!quiet && std::io::stderr().is_terminal()).then(indicatif::ProgressBar::hidden))
    }
}

impl gweave::pass::Progress for LayerBar {
    fn set_len(&mut self, layers: u64) {
        if let Some(bar) = &self.0 {
            if layers < MIN_LAYERS {
                self.0 = None;
                return;
            }
            bar.set_length(layers);
            bar.set_style(
                indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} layers {per_sec} {eta}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
    }

    fn advance(&mut self, layers_done: u64) {
        if let Some(bar) = &self.0 {
            bar.set_position(layers_done);
        }
    }
}

impl Drop for LayerBar {
    fn drop(&mut self) {
        if let Some(bar) = &self.0 {
            bar.finish_and_clear();
        }
    }
}
