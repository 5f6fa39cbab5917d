//! The post-processing transforms: `purge-shift` and `mix` (and the colour a mix prints), and
//! how every transform job runs from Python.

use std::path::{Path, PathBuf};

use gweave::gcode::writer::Target;

use gweave::malformed::Transformed;
use gweave::post::mix::MixOptions;
use gweave::post::purge_shift::PurgeShiftOptions;
use gweave_sim::transform::{self, Job, Outcome};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::args::target_of;
use crate::interrupt::interruptible;
use crate::options::failed;
use crate::{strictness, to_json};

// purge-shift
/// Moves every colour change earlier by the purge (see `gweave purge-shift`); returns the report
/// as JSON text. The keyword arguments are the options of `gweave.options` (`purge_mm`,
/// `config`: a TOML file, ...), by the names the engine declares.
#[pyfunction]
#[pyo3(signature = (path, output=None, *, in_place=false, backup=true, force=false, lenient=false, **options))]
#[allow(clippy::too_many_arguments)] // the keywords every transform shares, as Python spells them
pub(crate) fn purge_shift_json(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    in_place: bool,
    backup: bool,
    force: bool,
    lenient: bool,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let options: PurgeShiftOptions = crate::options::read("purge_shift", options)?;
    let target = target_of(output, in_place, backup, force)?;
    run(py, &options, &path, &target, lenient, transform::purge_shift)
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

/// `gweave mix` on a file: returns the report as JSON text (see `gweave mix --json`). The
/// keyword arguments are the options of `gweave.mix` (`config`: a profile TOML file, `at_layer`,
/// `purge_mm`, ...), by the names the engine declares.
#[pyfunction]
#[pyo3(signature = (path, output=None, *, in_place=false, backup=true, force=false, lenient=false, **options))]
#[allow(clippy::too_many_arguments)] // the keywords every transform shares, as Python spells them
pub(crate) fn mix_json(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    in_place: bool,
    backup: bool,
    force: bool,
    lenient: bool,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let options: MixOptions = crate::options::read("mix", options)?;
    let target = target_of(output, in_place, backup, force)?;
    run(py, &options, &path, &target, lenient, transform::mix)
}
