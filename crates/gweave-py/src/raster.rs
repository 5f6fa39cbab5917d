//! Binder-jet raster: layer images or a `.sl1` into inkjet G-code, the nozzle test pattern,
//! and STL slicing into layer images.

use crate::interrupt::interruptible;
use std::path::PathBuf;

use gweave::RasterOptions;
use gweave::{Quiet, Target};
use gweave_sim::raster_job::Raster;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::options::failed;
use crate::to_json;

// ---- binder-jet raster (gweave raster, slice-raster) ----

/// Rasters layer images or a `.sl1` into inkjet G-code, or writes the nozzle test pattern
/// (`test_pattern=True`, no inputs); the report as JSON text (see `gweave raster --json`). The
/// keyword arguments are the options of `gweave.raster` (`machine`, `density`, ...), by the
/// names the engine declares.
#[pyfunction]
#[pyo3(signature = (inputs, output, **options))]
pub(crate) fn raster_json(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    output: PathBuf,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let options: RasterOptions = crate::options::read("raster", options)?;
    let target = Target::File(output);
    let done = interruptible(py, || Raster::new(inputs, options)?.run(&target, &mut Quiet))?;
    to_json(&done.map_err(failed)?.written)
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
