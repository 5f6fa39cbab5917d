//! Binder-jet raster: layer images or a `.sl1` into inkjet G-code, the nozzle test pattern,
//! and STL slicing into layer images.

use crate::interrupt::interruptible;
use std::io::Write;
use std::path::PathBuf;

use gweave::gcode::writer::Target;
use gweave::gen::raster_job::{HeadSource, JobError, JobOptions, JobReport};
use gweave::pass::Quiet;
use gweave::post::metadata::Figures;
use gweave_sim::{Estimator, MachineProfile};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

use crate::{finish, to_json};

// ---- binder-jet raster (gweave raster, slice-raster) ----

/// A raster job's error as Python raises it: `OSError` when a file could not be read or written
/// (an I/O error among its causes), else `ValueError`; the text is the message and its causes,
/// `: `-separated.
fn job_err(e: JobError) -> PyErr {
    let mut text = e.to_string();
    let mut io = false;
    let mut cause = std::error::Error::source(&e);
    while let Some(c) = cause {
        io |= c.downcast_ref::<std::io::Error>().is_some();
        text = format!("{text}: {c}");
        cause = c.source();
    }
    if io {
        PyOSError::new_err(text)
    } else {
        PyValueError::new_err(text)
    }
}

/// `head=` (a printhead profile file) or `machine=` (an inkjet machine profile, a file or a
/// built-in name), as `--head` and `--machine`: the printhead, and the machine when one is given.
fn head_source(
    head: Option<PathBuf>,
    machine: Option<PathBuf>,
) -> PyResult<(Option<HeadSource>, Option<MachineProfile>)> {
    match (head, machine) {
        (Some(_), Some(_)) => Err(PyValueError::new_err("give head or machine, not both")),
        (None, Some(m)) => {
            let profile = crate::sim::machine_profile(Some(m))?;
            let head = profile.raster_head().map_err(|e| PyValueError::new_err(e.to_string()))?;
            Ok((Some(head), Some(profile)))
        }
        (head, None) => Ok((head.map(HeadSource::File), None)),
    }
}

/// Rasters layer images or a `.sl1` into inkjet G-code; the report as JSON text (see
/// `gweave raster --json`).
#[pyfunction]
#[pyo3(signature = (inputs, output, *, head=None, machine=None, threshold=0.5, invert=false, flip_y=false, one_way=false,
    fire_order="after", density=1, origin=None, layer_height=None, pixel_mm=None, dpi=None, heads=None, channels=None,
    recoat=None, start=None, end=None, dialect=None, feed=None, fast_estimate=false, options=""))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn raster_json(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    output: PathBuf,
    head: Option<PathBuf>,
    machine: Option<PathBuf>,
    threshold: f64,
    invert: bool,
    flip_y: bool,
    one_way: bool,
    fire_order: &str,
    density: u32,
    origin: Option<(f64, f64)>,
    layer_height: Option<f64>,
    pixel_mm: Option<f64>,
    dpi: Option<f64>,
    heads: Option<usize>,
    channels: Option<String>,
    recoat: Option<PathBuf>,
    start: Option<PathBuf>,
    end: Option<PathBuf>,
    dialect: Option<&str>,
    feed: Option<f64>,
    fast_estimate: bool,
    options: &str,
) -> PyResult<String> {
    let (head, machine) = head_source(head, machine)?;
    // The planner times the job on the machine it is written for, else on Marlin's defaults.
    let motion = machine.map(|m| m.motion).unwrap_or_default();
    let timer = || Estimator::line_timer_on(&motion);
    let job_options = JobOptions {
        inputs,
        head,
        threshold,
        invert,
        flip_y,
        one_way,
        fire_order: match fire_order {
            "after" => gweave::gen::raster::FireOrder::After,
            "before" => gweave::gen::raster::FireOrder::Before,
            other => {
                let text = format!("fire_order must be 'after' or 'before', got {other:?}");
                return Err(PyValueError::new_err(text));
            }
        },
        density,
        origin_mm: origin,
        layer_height_mm: layer_height,
        pixel_mm,
        dpi,
        heads,
        channels,
        recoat,
        start,
        end,
        dialect: crate::args::firmware("dialect", dialect)?,
        feed_mm_min: feed,
        fast_estimate,
    };
    let job = job_options.job().map_err(job_err)?;
    let target = Target::File(output.clone());
    let report = if job.knows_its_figures() {
        // Its time and filament (none) are known as it writes: nothing is read back.
        let write = |out: &mut dyn Write| job.run_into(out, &mut Quiet, timer).map_err(job_err);
        let figures = |r: &JobReport| Figures { time_s: [r.time.total_s; 2], ..Figures::default() };
        let mut report =
            interruptible(py, || finish::finished_directly(&target, "raster", options, write, figures))??;
        report.output = output.display().to_string();
        report
    } else {
        let write = |t: &Target| job.run(t, &mut Quiet, timer).map_err(job_err);
        // Its own time counts the printhead's firing, which the estimator does not know.
        let own_time = |r: &JobReport| Some(r.time.total_s);
        interruptible(py, || finish::finished(None, &target, "raster", options, write, own_time))??
    };
    to_json(&report)
}

/// Writes a nozzle test pattern; the raster report as JSON text.
#[pyfunction]
#[pyo3(signature = (output, *, head=None, machine=None, heads=None, dialect=None, columns=4, origin=None, options=""))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn raster_test_pattern_json(
    py: Python<'_>,
    output: PathBuf,
    head: Option<PathBuf>,
    machine: Option<PathBuf>,
    heads: Option<usize>,
    dialect: Option<&str>,
    columns: usize,
    origin: Option<(f64, f64)>,
    options: &str,
) -> PyResult<String> {
    let job_options = JobOptions {
        head: head_source(head, machine)?.0,
        heads,
        dialect: crate::args::firmware("dialect", dialect)?,
        origin_mm: origin,
        ..Default::default()
    };
    let write = |t: &Target| job_options.test_pattern(t, columns).map_err(job_err);
    let target = Target::File(output);
    let (report, _) =
        interruptible(py, || finish::finished(None, &target, "raster", options, write, |_| None))??;
    to_json(&report)
}

/// Slices an STL into 1-bit layer PNGs in `out_dir`; the report as JSON text (see
/// `gweave slice-raster --json`).
#[pyfunction]
#[pyo3(signature = (stl, out_dir, *, layer_height, dpi=96.0, pixel_mm=None, margin=0))]
pub(crate) fn slice_raster_json(
    py: Python<'_>,
    stl: PathBuf,
    out_dir: PathBuf,
    layer_height: f64,
    dpi: f64,
    pixel_mm: Option<f64>,
    margin: usize,
) -> PyResult<String> {
    use gweave::gen::slice_raster::{slice_to_dir, SliceConfig};
    let report = interruptible(py, || {
        let mesh = gweave::gen::stl::read_stl(&stl).map_err(|e| match e {
            gweave::gen::stl::StlError::Io { .. } => PyOSError::new_err(e.to_string()),
            _ => PyValueError::new_err(format!("{}: {e}", stl.display())),
        })?;
        let sliced = SliceConfig::with_resolution(layer_height, pixel_mm, dpi, margin)
            .and_then(|cfg| slice_to_dir(&mesh, &cfg, &out_dir));
        sliced.map_err(|e| PyValueError::new_err(e.to_string()))
    })??;
    to_json(&report)
}
