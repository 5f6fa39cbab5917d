//! The transform jobs of the registry, run by their command (`transform_json`), the colour a
//! mix prints, and how every transform job runs from Python.

use std::path::{Path, PathBuf};

use gweave::gcode::writer::Target;

use gweave::options::JobOptions;
use gweave::Transformed;
use gweave_sim::transform::{transforms, EachTransform, Job, Outcome, Transform};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::args::target_of;
use crate::interrupt::interruptible;
use crate::options::failed;
use crate::{strictness, to_json};

/// Runs the transform `command` of the registry (`purge-shift`, `mix`:
/// `gweave_sim::transform::transforms`) on `path`, as `gweave <command>` runs it; returns the
/// report as JSON text. The keyword arguments are the job's options by the names the engine
/// declares (`purge_mm`, `config`: a TOML file, ...); the typed wrappers of `gweave/__init__.py`
/// call it.
#[pyfunction]
#[pyo3(signature = (command, path, output=None, *, in_place=false, backup=true, force=false, lenient=false, **options))]
#[allow(clippy::too_many_arguments)] // the keywords every transform shares, as Python spells them
pub(crate) fn transform_json(
    py: Python<'_>,
    command: &str,
    path: PathBuf,
    output: Option<PathBuf>,
    in_place: bool,
    backup: bool,
    force: bool,
    lenient: bool,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    /// The row called `command`, run when the registry reaches it.
    struct Called<'a, 'py> {
        py: Python<'py>,
        command: &'a str,
        options: Option<&'a Bound<'py, PyDict>>,
        path: &'a Path,
        target: &'a dyn Fn() -> PyResult<Target>,
        lenient: bool,
        result: Option<PyResult<String>>,
    }
    impl EachTransform for Called<'_, '_> {
        fn transform<T: Transform>(&mut self) {
            if T::Options::COMMAND != self.command {
                return;
            }
            let run = || -> PyResult<String> {
                // Python's name of the function, for a keyword it does not take.
                let function = self.command.replace('-', "_");
                let options: T::Options = crate::options::read(&function, self.options)?;
                run(self.py, &options, self.path, &(self.target)()?, self.lenient, T::run)
            };
            self.result = Some(run());
        }
    }
    let target = || target_of(output.clone(), in_place, backup, force);
    let mut called = Called { py, command, options, path: &path, target: &target, lenient, result: None };
    transforms(&mut called);
    called.result.unwrap_or_else(|| {
        Err(PyValueError::new_err(format!("no transform {command:?} ({})", commands().join(", "))))
    })
}

/// The commands of the transform registry, in its order: each one `transform_json` runs, a
/// `gweave` subcommand and a typed function of `gweave` (held to that by the tests).
#[pyfunction(name = "transforms")]
pub(crate) fn transforms_list() -> Vec<&'static str> {
    commands()
}

fn commands() -> Vec<&'static str> {
    struct Names(Vec<&'static str>);
    impl EachTransform for Names {
        fn transform<T: Transform>(&mut self) {
            self.0.push(T::Options::COMMAND);
        }
    }
    let mut names = Names(Vec::new());
    transforms(&mut names);
    names.0
}

/// Runs the transform `job` with `options` on `path` into `target`, Ctrl-C stopping it; the
/// report as JSON text (with the lines a lenient run read past).
pub(crate) fn run<O: Sync, R: serde::Serialize + Send>(
    py: Python<'_>,
    options: &O,
    path: &Path,
    target: &Target,
    lenient: bool,
    job: impl FnOnce(&O, Job<'_>) -> Outcome<R> + Send,
) -> PyResult<String> {
    let strictness = strictness(lenient);
    let work = || job(options, Job { strictness, ..Job::new(path, target) });
    let (report, malformed) = interruptible(py, work)?.map_err(failed)?;
    to_json(&Transformed::new(&report, malformed, strictness))
}

// mix
/// The colour `ratios` (one per input, any scale) is predicted to print, as JSON text
/// `{"ratios", "srgb", "lab"}` (see `gweave mix --predict`); `config` is a profile's TOML text
/// (empty: the default cyan, magenta, yellow, white filaments).
#[pyfunction]
#[pyo3(signature = (ratios, *, config=""))]
pub(crate) fn predict_colour_json(ratios: Vec<f64>, config: &str) -> PyResult<String> {
    let bad = |e: &dyn std::fmt::Display| PyValueError::new_err(e.to_string());
    let profile = gweave::post::mix::profile::MixProfile::from_toml_str(config).map_err(|e| bad(&e))?;
    let model = profile.hardware.mixing_model().map_err(|e| bad(&e))?;
    let mix = gweave::colour::Mix::new(&ratios).map_err(|e| bad(&e))?;
    to_json(&gweave::colour::predict::predict(&model, &mix).map_err(|e| bad(&e))?)
}
