//! `gweave raster`: layer images (or a PrusaSlicer `.sl1`) to binder-jet inkjet G-code.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use gweave::gen::printhead::PrintheadProfile;
use gweave::gen::raster_job::JobReport;
use gweave::RasterOptions;
use gweave_sim::raster_job::{Raster, Written};

use crate::common::{hms, print_summary, ReportArgs};
use crate::files::Files;
use crate::options::{failed, Options};

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
    #[command(flatten)]
    pub options: Options<RasterOptions>,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: RasterArgs) -> Result<ExitCode> {
    let options = &args.options;
    let raster = Raster::new(args.inputs.clone(), options.0.clone()).map_err(failed)?;
    let planner = raster.machine().map_or("Marlin defaults", |m| m.name.as_str()).to_owned();
    let to_stdout = args.output == Path::new("-");
    args.report.refuse_json_with_stdout(to_stdout)?;
    let target = args.format.target(&args.output)?;
    Files::new()
        .read_all("INPUTS", raster.images())
        .read("--head", options.head.as_deref())
        .read("--machine", options.machine.as_deref())
        .read("--recoat", options.recoat.as_deref())
        .read("--start", options.start.as_deref())
        .read("--end", options.end.as_deref())
        .write("-o", Some(&args.output))
        .write("--report", args.report.report.as_deref())
        .check()?;
    let mut bar = LayerBar::new(args.report.quiet.quiet);
    let done = raster.run(&target, &mut bar).map_err(failed)?;
    drop(bar);
    let profile = &done.profile;
    let report = match done.written {
        Written::TestPattern(rep) => {
            if args.report.emit(&rep)? && !to_stdout {
                print_summary(|out| {
                    writeln!(out, "{}: nozzle test pattern", args.output.display())?;
                    writeln!(
                        out,
                        "  {} head(s) x {} nozzles, {} columns per address, {} fire commands",
                        profile.heads.len(),
                        profile.nozzle_count,
                        options.pattern_columns,
                        rep.fire_commands
                    )?;
                    writeln!(
                        out,
                        "  column group a fires address a alone: the row it prints is nozzle_rows[a]"
                    )
                })?;
            }
            return Ok(ExitCode::SUCCESS);
        }
        Written::Layers(report) => report,
    };
    if args.report.emit(&report)? && !to_stdout {
        print_summary(|out| print_human(out, &report, profile, &planner))?;
    }
    if done.from_images && options.layer_height.is_none() {
        eprintln!("gweave: note: {}", layer_height_hint(options.pixel_mm.or(options.dpi.map(|d| 25.4 / d))));
    }
    if done.from_images && options.pixel_mm.is_none() && options.dpi.is_none() {
        eprintln!("gweave: note: {}", pixel_size_hint(profile));
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

impl gweave::Progress for LayerBar {
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
