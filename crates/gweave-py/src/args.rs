//! Python arguments read as the command line reads its flags, and errors raised as Python
//! expects them: `FileNotFoundError` (with `errno` and `filename`) for a missing file,
//! `ValueError` naming the parameter for a value out of its range.

use std::path::{Path, PathBuf};

use gweave::range::Quantity;
use gweave::{Bed, Range, Target};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

/// An I/O error on `path` as Python's `OSError(errno, strerror, filename)`, which Python turns
/// into its subclass for the errno (`FileNotFoundError`, `PermissionError`, `IsADirectoryError`).
pub fn os_error(path: &Path, e: &std::io::Error) -> PyErr {
    let filename = path.display().to_string();
    match e.raw_os_error() {
        Some(code) => {
            // The message without Rust's " (os error N)" suffix: Python prints the errno itself.
            let text = e.to_string();
            let strerror = text.split(" (os error").next().unwrap_or(&text).to_owned();
            PyOSError::new_err((code, strerror, filename))
        }
        None => PyOSError::new_err(format!("{filename}: {e}")),
    }
}

/// Where a transform writes, from the keywords every transform shares (`output`, `in_place`,
/// `backup`, `force`) as the CLI reads `-o`, `--in-place`, `--no-backup` and `--force`:
/// `in_place=True` replaces the input (keeping `<path>.bak` unless `backup=False`), else
/// `output` is the file written; neither, or both (as the CLI refuses `-o` with `--in-place`:
/// which one was meant?), is a `ValueError`.
pub fn target_of(output: Option<PathBuf>, in_place: bool, backup: bool, force: bool) -> PyResult<Target> {
    match (output, in_place) {
        (Some(p), true) => Err(PyValueError::new_err(format!(
            "output={} and in_place=True: give one of them (in_place=True replaces the input)",
            p.display()
        ))),
        (None, true) => Ok(Target::InPlace { keep_backup: backup, force }),
        (Some(p), false) => Ok(Target::File(p)),
        (None, false) => Err(PyValueError::new_err("give an output path or in_place=True")),
    }
}

/// `value` within `range`, or a `ValueError` naming the parameter and the range, as the CLI
/// refuses the flag.
pub fn in_range<T: Quantity>(name: &str, value: Option<T>, range: Range<T>) -> PyResult<Option<T>> {
    match value {
        Some(v) => range.check(name, v).map(Some).map_err(|e| PyValueError::new_err(e.to_string())),
        None => Ok(None),
    }
}

/// `bed=` as `gweave check --bed` reads it: the same text (`"200,200,200"`,
/// `"0,-4,250,210,210"`) or its numbers as a sequence.
#[derive(FromPyObject)]
pub enum BedArg {
    Text(String),
    Numbers(Vec<f64>),
}

impl BedArg {
    pub fn bed(self) -> PyResult<Bed> {
        let text = match self {
            BedArg::Text(t) => t,
            BedArg::Numbers(n) => n.iter().map(f64::to_string).collect::<Vec<_>>().join(","),
        };
        text.parse::<Bed>().map_err(|e| PyValueError::new_err(format!("bed: {e}")))
    }
}
