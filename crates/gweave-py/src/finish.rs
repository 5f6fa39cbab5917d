//! Python's side of finishing a transform's output (`gweave_sim::finish`), as the CLI does: the
//! run's header, the slicer's figures rewritten for the file as written, and a second run of
//! the same transform on its own output refused (`ValueError` naming the earlier run).

use std::io::Write;
use std::path::Path;

use gweave::gcode::writer::Target;
use gweave::post::metadata::Figures;
use gweave_sim::finish::{self, FinishError};
use pyo3::exceptions::PyValueError;
use pyo3::PyErr;

/// A transform's failure or the finishing step's, as the Python exception it raises.
pub struct Failed(pub PyErr);

impl From<PyErr> for Failed {
    fn from(e: PyErr) -> Self {
        Failed(e)
    }
}

impl From<FinishError> for Failed {
    fn from(e: FinishError) -> Self {
        Failed(match e {
            FinishError::Engine(e) => crate::err(e),
            e => PyValueError::new_err(e.to_string()),
        })
    }
}

/// Runs the transform `command` (`mix`, `rotary tube`) with `options` (its flags in the CLI's
/// words, built by the Python package from the keyword arguments: `--purge-mm 20`) through
/// `write`, reading `input` if it has one, into `target`. A transform that reads a file refuses
/// one an earlier run of it wrote; `own_time_s` is the time a transform computed for its own
/// output (see `gweave_sim::finish::with_metadata_timed`).
pub fn finished<R>(
    input: Option<&Path>,
    target: &Target,
    command: &str,
    options: &str,
    write: impl FnOnce(&Target) -> Result<R, PyErr>,
    own_time_s: impl FnOnce(&R) -> Option<f64>,
) -> Result<R, PyErr> {
    let run = || -> Result<R, Failed> {
        if let Some(input) = input {
            finish::refuse_second_run(input, command)?;
        }
        let line = format!("{command} {options}");
        let write = |t: &Target| write(t).map_err(Failed);
        let (result, _) = finish::with_metadata_timed(input, target, line.trim_end(), write, own_time_s)?;
        Ok(result)
    };
    run().map_err(|Failed(e)| e)
}

/// [`finished`] for a generator that knows its output's figures as it writes it (a raster job
/// whose G-code holds nothing the metadata is measured from): `write` writes straight to
/// `target`, between the run's header and the footer of `figures`
/// (`gweave_sim::finish::with_own_figures`).
pub fn finished_directly<R>(
    target: &Target,
    command: &str,
    options: &str,
    write: impl FnOnce(&mut dyn Write) -> Result<R, PyErr>,
    figures: impl FnOnce(&R) -> Figures,
) -> Result<R, PyErr> {
    let line = format!("{command} {options}");
    let write = |out: &mut dyn Write| write(out).map_err(Failed);
    match finish::with_own_figures(target, line.trim_end(), write, figures) {
        Ok((result, _)) => Ok(result),
        Err(Failed(e)) => Err(e),
    }
}
