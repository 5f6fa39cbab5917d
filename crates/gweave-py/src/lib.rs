//! Python bindings for gweave: one module, thin wrappers over the engine. Reports cross as JSON
//! text (the same documents `--json` prints) and become dicts in `gweave/__init__.py`.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

mod args;
mod finish;
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
fn strictness(lenient: bool) -> gweave::pass::Strictness {
    if lenient {
        gweave::pass::Strictness::Lenient
    } else {
        gweave::pass::Strictness::Strict
    }
}

fn to_json<T: serde::Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Runs the `gweave` command line with these arguments (argv[0] included); returns the exit code.
/// A Ctrl-C stops the run (its scratch files removed, no output) and raises `SystemExit(130)`,
/// as a Python command-line tool ends on Ctrl-C, with the `KeyboardInterrupt` as its cause:
/// the interpreter unwinds, running `finally` blocks and `atexit` handlers.
#[pyfunction]
fn run_cli(py: Python<'_>, argv: Vec<String>) -> PyResult<i32> {
    let code = interrupt::interruptible(py, || gweave_cli::run(argv)).map_err(|raised| {
        if raised.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) {
            let exit = pyo3::exceptions::PySystemExit::new_err(130);
            exit.set_cause(py, Some(raised));
            exit
        } else {
            raised
        }
    })?;
    // ExitCode is opaque; the CLI only returns SUCCESS, FAILURE (1) or usage errors (2).
    Ok(if code == std::process::ExitCode::SUCCESS {
        0
    } else if code == std::process::ExitCode::from(2) {
        2
    } else {
        1
    })
}

#[pymodule]
fn _gweave(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(read::stats_json, m)?)?;
    m.add_function(wrap_pyfunction!(read::check_json, m)?)?;
    m.add_function(wrap_pyfunction!(read::cat_json, m)?)?;
    m.add_function(wrap_pyfunction!(run_cli, m)?)?;
    m.add_function(wrap_pyfunction!(options::job_options, m)?)?;
    // binder-jet raster
    m.add_function(wrap_pyfunction!(raster::raster_json, m)?)?;
    m.add_function(wrap_pyfunction!(raster::raster_test_pattern_json, m)?)?;
    m.add_function(wrap_pyfunction!(raster::slice_raster_json, m)?)?;
    // purge-shift
    m.add_function(wrap_pyfunction!(transform::purge_shift_json, m)?)?;
    // mix
    m.add_function(wrap_pyfunction!(transform::mix_json, m)?)?;
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
