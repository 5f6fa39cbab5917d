//! The post-processing transforms: `purge-shift` and `mix` (and the colour a mix prints).

use crate::interrupt::interruptible;
use std::path::PathBuf;

use gweave::gcode::writer::Target;
use gweave::run::Run;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::args::{in_range, target_of};
use crate::{err, finish, strictness, to_json};
use gweave::malformed::Transformed;
use gweave::post::mix::mix;

// purge-shift
/// Moves every colour change earlier by the purge (see `gweave purge-shift`); returns the report
/// as JSON text. `config` is TOML text; the keyword arguments override it.
#[pyfunction]
#[pyo3(signature = (path, output=None, *, in_place=false, backup=true, force=false, purge_mm=None, purge_mm3=None,
    config=None, filament_diameter=None, cross_layers=false, allow_features=None, markers=None,
    fallback=None, tower_at=None, lenient=false, options=""))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn purge_shift_json(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    in_place: bool,
    backup: bool,
    force: bool,
    purge_mm: Option<f64>,
    purge_mm3: Option<f64>,
    config: Option<String>,
    filament_diameter: Option<f64>,
    cross_layers: bool,
    allow_features: Option<Vec<String>>,
    markers: Option<(String, String)>,
    fallback: Option<String>,
    tower_at: Option<(f64, f64)>,
    lenient: bool,
    options: &str,
) -> PyResult<String> {
    use gweave::post::purge_shift::{purge_shift, Overrides, PurgeShiftConfig};
    let value_err = |e: gweave::post::purge_shift::ConfigError| PyValueError::new_err(e.to_string());
    let mut c = match &config {
        Some(text) => PurgeShiftConfig::parse_toml(text).map_err(value_err)?,
        None => PurgeShiftConfig::default(),
    };
    c.apply(&Overrides {
        purge_mm,
        purge_mm3,
        filament_diameter_mm: filament_diameter,
        cross_layers,
        allow_features,
        markers: markers.map(|(b, e)| [b, e]),
        fallback,
        tower_xy_mm: tower_at.map(|(x, y)| [x, y]),
    });
    let rules = c.validate().map_err(value_err)?;
    let target = target_of(output, in_place, backup, force)?;
    let strictness = strictness(lenient);
    let write = |t: &Target| {
        let (report, ran) = purge_shift(rules, Run::file(&path).strictness(strictness).to(t)).map_err(err)?;
        Ok((report, ran.malformed))
    };
    let (mut report, malformed) = interruptible(py, || {
        finish::finished(Some(&path), &target, "purge-shift", options, write, |_| None)
    })??;
    // The run's header is one line above every change.
    report.changes.offset_output_lines(1);
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
/// profile is TOML text (empty: the defaults); the lists add schedule entries, gradients and
/// tool maps as the command line flags do.
#[pyfunction]
#[pyo3(signature = (path, output=None, *, config="", at_layer=Vec::new(), at_z=Vec::new(), map=Vec::new(), gradient=Vec::new(), gradient_space="mix", dialect=None, purge_mm=None, initial_purge=None, in_place=false, backup=true, force=false, lenient=false, options=""))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn mix_json(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    config: &str,
    at_layer: Vec<String>,
    at_z: Vec<String>,
    map: Vec<String>,
    gradient: Vec<String>,
    gradient_space: &str,
    dialect: Option<&str>,
    purge_mm: Option<f64>,
    initial_purge: Option<f64>,
    in_place: bool,
    backup: bool,
    force: bool,
    lenient: bool,
    options: &str,
) -> PyResult<String> {
    use gweave::firmware::MixCommands;
    use gweave::post::mix::overrides::{gradient_space as space_named, Overrides};
    use gweave::post::mix::profile::MixProfile;
    let bad = |e: gweave::post::mix::MixPassError| PyValueError::new_err(e.to_string());
    let target = target_of(output, in_place, backup, force)?;
    let mut profile = MixProfile::from_toml_str(config).map_err(bad)?;
    profile
        .apply(&Overrides {
            at_layer,
            at_z,
            map,
            gradient,
            gradient_space: space_named(gradient_space).map_err(bad)?,
            dialect: dialect.map(str::parse::<MixCommands>).transpose().map_err(bad)?,
            purge_mm: in_range("purge_mm", purge_mm, gweave::range::PURGE_MM)?,
            initial_purge_mm: in_range("initial_purge", initial_purge, gweave::range::PURGE_MM)?,
        })
        .map_err(bad)?;
    let strictness = strictness(lenient);
    let write = |t: &Target| match mix(profile, Run::file(&path).strictness(strictness).to(t)) {
        Ok((report, ran)) => Ok((report, ran.malformed)),
        Err(gweave::post::mix::MixPassError::Engine(e)) => Err(err(e)),
        Err(e) => Err(bad(e)),
    };
    let (report, malformed) =
        interruptible(py, || finish::finished(Some(&path), &target, "mix", options, write, |_| None))??;
    to_json(&Transformed::new(&report, malformed, strictness))
}
