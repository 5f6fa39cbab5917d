//! Previews (`gweave preview`) and the toolpath as columns for the notebook viewer.

use crate::interrupt::interruptible;
use std::path::PathBuf;

use gweave::{Quiet, Toolpath, ToolpathOptions};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::options::failed;
use crate::{err, strictness, to_json};
use gweave::gcode::layers::ALL_FEATURES;
use gweave::render::job;
use gweave::PreviewOptions;
use pyo3::types::PyBytes;

// ---- preview (render) ----

/// A picture or viewer page of a file as bytes and the report of what it shows as JSON; see
/// `gweave preview`. `output`, if given, is written (whole, or not at all) and its extension
/// picks the format unless `format` does; without either, PNG. The keyword arguments are the
/// options of `gweave.preview` (`layer`, `layers`, `size`, ...), by the names the engine
/// declares.
#[pyfunction]
#[pyo3(signature = (path, output=None, *, lenient=false, **options))]
pub(crate) fn preview_json(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    lenient: bool,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<(Py<PyBytes>, String)> {
    let options: PreviewOptions = crate::options::read("preview", options)?;
    let preview = interruptible(py, || {
        job::preview(&options, &path, output.as_deref(), strictness(lenient), &mut Quiet)
    })?
    .map_err(failed)?;
    Ok((PyBytes::new(py, &preview.bytes).unbind(), to_json(&preview.report)?))
}

/// A file's toolpath as little-endian column bytes: (segment count, {name: bytes}) with start
/// and end (f32 x 3 each), tool (u16), feature (u8, index into `feature_names`), feed_mm_s (f32),
/// layer (u32), extruding (u8 0/1). `gweave.toolpath` turns them into NumPy arrays. A rotary
/// program (its header names the machine, or `mandrel_diameter` is given) comes out in 3D on its
/// cylinder, mandrel along X, with `on_cylinder` true.
#[pyfunction]
#[pyo3(signature = (path, *, travel=true, min_len=0.0, mandrel_diameter=None))]
pub(crate) fn toolpath_columns(
    py: Python<'_>,
    path: PathBuf,
    travel: bool,
    min_len: f32,
    mandrel_diameter: Option<f64>,
) -> PyResult<(usize, Py<PyDict>)> {
    let machine = mandrel_diameter.map(gweave::rotary::cylinder::RotaryConfig::new);
    let rotary = gweave::rotary::preview::RotaryReading::for_file(&path, machine.as_ref())
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let options = ToolpathOptions { travel, min_len_mm: min_len, rotary, ..ToolpathOptions::default() };
    let tp = interruptible(py, || Toolpath::from_file(&path, options))?.map_err(err)?;
    let n = tp.segments.len();
    let mut cols: [(&str, Vec<u8>); 7] = [
        ("start", Vec::with_capacity(n * 12)),
        ("end", Vec::with_capacity(n * 12)),
        ("tool", Vec::with_capacity(n * 2)),
        ("feature", Vec::with_capacity(n)),
        ("feed_mm_s", Vec::with_capacity(n * 4)),
        ("layer", Vec::with_capacity(n * 4)),
        ("extruding", Vec::with_capacity(n)),
    ];
    for s in &tp.segments {
        cols[0].1.extend(s.start.iter().flat_map(|v| v.to_le_bytes()));
        cols[1].1.extend(s.end.iter().flat_map(|v| v.to_le_bytes()));
        cols[2].1.extend(s.tool.to_le_bytes());
        cols[3].1.push(s.feature as u8);
        cols[4].1.extend(s.feed_mm_s.to_le_bytes());
        cols[5].1.extend(s.layer.to_le_bytes());
        cols[6].1.push(u8::from(s.extruding));
    }
    let dict = PyDict::new(py);
    for (name, bytes) in cols {
        dict.set_item(name, PyBytes::new(py, &bytes))?;
    }
    let names: Vec<&str> = ALL_FEATURES.iter().map(|f| f.name()).collect();
    dict.set_item("feature_names", names)?;
    dict.set_item("layer_z", tp.layer_z_mm.clone())?;
    dict.set_item("on_cylinder", tp.on_cylinder)?;
    Ok((n, dict.unbind()))
}
