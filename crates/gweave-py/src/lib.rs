//! Python bindings for gweave: one module, thin wrappers over the engine. Reports cross as JSON
//! text (the same documents `--json` prints) and become dicts in `gweave/__init__.py`.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

mod args;
mod interrupt;
mod options;
mod preview;
mod raster;
mod read;
mod rotary;
mod sim;
mod transform;

use args::os_error;

/// The engine's error as a Python exception: `OSError` for the file system's, `ValueError` else,
/// in the engine's words (which name no front end's flags).
fn err(e: gweave::Error) -> PyErr {
    match &e {
        gweave::Error::Io { path, source } => os_error(path, source),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// `lenient=` as `--lenient`.
fn strictness(lenient: bool) -> gweave::Strictness {
    if lenient {
        gweave::Strictness::Lenient
    } else {
        gweave::Strictness::Strict
    }
}

fn to_json<T: serde::Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| PyValueError::new_err(e.to_string()))
}

#[pymodule]
fn _gweave(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(read::stats_json, m)?)?;
    m.add_function(wrap_pyfunction!(read::check_json, m)?)?;
    m.add_function(wrap_pyfunction!(read::cat_json, m)?)?;
    m.add_function(wrap_pyfunction!(options::jobs, m)?)?;
    m.add_function(wrap_pyfunction!(options::job_options, m)?)?;
    // binder-jet raster
    m.add_function(wrap_pyfunction!(raster::raster_json, m)?)?;
    m.add_function(wrap_pyfunction!(raster::slice_raster_json, m)?)?;
    // the transforms of the registry (purge-shift, mix, ...)
    m.add_function(wrap_pyfunction!(transform::transform_json, m)?)?;
    m.add_function(wrap_pyfunction!(transform::transforms_list, m)?)?;
    // mix
    m.add_function(wrap_pyfunction!(transform::predict_colour_json, m)?)?;
    m.add_class::<read::Line>()?;
    m.add_class::<read::Reader>()?;
    // gweave-sim: the virtual printer
    m.add_function(wrap_pyfunction!(sim::sim_json, m)?)?;
    m.add_function(wrap_pyfunction!(sim::estimate_json, m)?)?;
    m.add_class::<sim::Machine>()?;
    // rotary (lathe-type) printing
    m.add_function(wrap_pyfunction!(rotary::rotary_wrap_json, m)?)?;
    m.add_function(wrap_pyfunction!(rotary::rotary_tube_json, m)?)?;
    m.add_function(wrap_pyfunction!(rotary::write_helical_paths_json, m)?)?;
    m.add_class::<rotary::HelicalPath>()?;

    m.add_function(wrap_pyfunction!(preview::preview_json, m)?)?;
    m.add_function(wrap_pyfunction!(preview::toolpath_columns, m)?)?;
    Ok(())
}
