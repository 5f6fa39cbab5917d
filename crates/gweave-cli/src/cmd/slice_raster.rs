//! `gweave slice-raster`: a mesh to 1-bit layer images for `gweave raster`.

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use gweave::gen::slice_raster::{slice_to_dir, SliceConfig, SliceReport, MARGIN_PX};
use gweave::gen::stl::read_stl;
use gweave::range::{DPI, LAYER_HEIGHT_MM, PIXEL_MM};

use crate::common::{in_range, print_summary, ReportArgs};
use crate::files::{layer_png, Files};

/// Slice an STL mesh into layer images (PNG, 1-bit): each pixel is binder when its centre lies
/// inside the section at mid-layer height (even-odd rule). Image row 0 is the lowest Y, as
/// `gweave raster` expects. Example:
/// `gweave slice-raster part.stl --layer-height 0.1 --dpi 96 -o layers/`.
#[derive(Args, Debug)]
pub struct SliceRasterArgs {
    /// The mesh (binary or ASCII STL).
    pub model: PathBuf,
    /// Layer thickness, mm.
    #[arg(long, value_name = "MM", value_parser = in_range(LAYER_HEIGHT_MM))]
    pub layer_height: f64,
    /// Image resolution, dots per inch (96 = the HP C6602's nozzle pitch).
    #[arg(long, value_name = "D", default_value_t = 96.0, conflicts_with = "pixel_mm", value_parser = in_range(DPI))]
    pub dpi: f64,
    /// Pixel size in mm instead of --dpi [default: 25.4/--dpi].
    #[arg(long, value_name = "MM", value_parser = in_range(PIXEL_MM))]
    pub pixel_mm: Option<f64>,
    /// Empty pixels around the part on every side.
    #[arg(long, default_value_t = 0, value_name = "PX", value_parser = in_range(MARGIN_PX))]
    pub margin: usize,
    /// Folder for `layer_00000.png`, ...
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    #[command(flatten)]
    pub report: ReportArgs,
}

pub fn run(args: SliceRasterArgs) -> Result<ExitCode> {
    Files::new()
        .read("MODEL", Some(&args.model))
        .write_dir("-o", Some(&args.output), layer_png)
        .write("--report", args.report.report.as_deref())
        .check()?;
    let mesh = read_stl(&args.model).with_context(|| format!("reading {}", args.model.display()))?;
    let cfg = SliceConfig::with_resolution(args.layer_height, args.pixel_mm, args.dpi, args.margin)?;
    let rep = slice_to_dir(&mesh, &cfg, &args.output)
        .with_context(|| format!("slicing {}", args.model.display()))?;
    if args.report.emit(&rep)? {
        print_summary(|out| print_human(out, &args, &rep, mesh.triangles.len()))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn print_human(
    out: &mut dyn Write,
    args: &SliceRasterArgs,
    r: &SliceReport,
    triangles: usize,
) -> io::Result<()> {
    let g = &r.grid;
    writeln!(out, "{} -> {}", args.model.display(), args.output.display())?;
    writeln!(out, "  triangles       {triangles}")?;
    writeln!(out, "  layers          {} x {} mm from Z {:.3}", g.layers, g.layer_height_mm, g.z_min_mm)?;
    writeln!(
        out,
        "  images          {} x {} px of {:.6} mm, corner at ({:.3}, {:.3}) mm",
        g.width_px, g.height_px, g.pixel_mm, g.origin_x_mm, g.origin_y_mm
    )?;
    let total: u64 = r.pixels_per_layer.iter().sum();
    let max = r.pixels_per_layer.iter().max().copied().unwrap_or(0);
    writeln!(out, "  binder pixels   {total} (largest layer {max})")?;
    // PNGs carry their pixel size but no layer height: the next command gives both, or the
    // part would be printed at raster's default layer height.
    writeln!(
        out,
        "  next            gweave raster {} --pixel-mm {} --layer-height {} -o part.gcode",
        args.output.display(),
        g.pixel_mm,
        g.layer_height_mm
    )?;
    Ok(())
}
