//! Rotary (lathe-type) printing: wrapping flat G-code, helical tubes and paths.

use crate::interrupt::interruptible;
use std::path::{Path, PathBuf};

use gweave::gcode::writer::Target;
use gweave::run::Run;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

use crate::args::{os_error, target_of};
use crate::{err, finish, strictness, to_json};
use gweave::malformed::{Malformed, Transformed};
use gweave::rotary::report::WrapReport;

// ---- rotary (lathe-type) printing: gweave::rotary ----

use std::sync::{Arc, Mutex};

use gweave::rotary::cylinder::{FeedConvention, RotaryConfig, RotaryUnit};
use gweave::rotary::helix::{
    self, Handedness, HelicalPath as RustHelicalPath, PrintSettings, Profile, Resolution,
};
use gweave::rotary::overrides::{MachineOverrides, TubeOverrides, WrapOverrides};
use gweave::rotary::report::merged_settings;
use gweave::rotary::wrap::WrapConfig;
use gweave::rotary::RotaryError;
use gweave::rotary_job::{tube_file, wrap_file};

fn rotary_err(e: RotaryError) -> PyErr {
    match e {
        RotaryError::Io(_) => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// The machine's keywords as `MachineOverrides` (`rotary_unit` `"deg"` or `"mm"`,
/// `feed_convention` `"nist"`, `"combined"` or `"inverse-time"`, as the CLI spells them).
fn machine(
    mandrel_diameter: Option<f64>,
    feed_convention: Option<&str>,
    rotary_unit: Option<&str>,
    axes: Option<(char, char, char)>,
) -> PyResult<MachineOverrides> {
    let feed_convention = match feed_convention {
        None => None,
        Some("nist") => Some(FeedConvention::Nist),
        Some("combined") => Some(FeedConvention::Combined),
        Some("inverse-time") => Some(FeedConvention::InverseTime),
        Some(other) => {
            let text = format!("feed_convention: 'nist', 'combined' or 'inverse-time', not {other:?}");
            return Err(PyValueError::new_err(text));
        }
    };
    let rotary_unit = match rotary_unit {
        None => None,
        Some("deg" | "degrees") => Some(RotaryUnit::Degrees),
        Some("mm") => Some(RotaryUnit::Mm),
        Some(other) => {
            return Err(PyValueError::new_err(format!("rotary_unit: 'deg' or 'mm', not {other:?}")))
        }
    };
    Ok(MachineOverrides {
        mandrel_diameter_mm: mandrel_diameter,
        feed_convention,
        rotary_unit,
        axes: axes.map(<[char; 3]>::from),
    })
}

/// Settings read by `read` from the TOML file `config` (its errors name the file) or, without
/// one, from the machine's keywords alone, as the CLI reads `-c`.
fn read_settings<T>(
    config: Option<&Path>,
    machine: &MachineOverrides,
    read: impl FnOnce(Option<&str>, &MachineOverrides) -> Result<T, RotaryError>,
) -> PyResult<T> {
    let Some(path) = config else {
        return read(None, machine).map_err(rotary_err);
    };
    let text = gweave::settings::read_text(path).map_err(|e| os_error(path, &e))?;
    read(Some(&text), machine)
        .map_err(|e| PyValueError::new_err(format!("{}: {}", path.display(), gweave::error::with_causes(&e))))
}

/// Wraps a flat G-code file onto the mandrel; the keywords override the TOML file `config` as
/// the CLI's flags do. Returns the report as JSON text (`rotary wrap --json`).
#[pyfunction]
#[pyo3(signature = (input, output=None, *, in_place=false, backup=true, force=false, mandrel_diameter=None,
    feed_convention=None, rotary_unit=None, axes=None, keep_arc_length=None, seam_rotation=None, helical=false,
    allow_overlap=false, chord_tol=None, config=None, preview=None, lenient=false, options=""))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn rotary_wrap_json(
    py: Python<'_>,
    input: PathBuf,
    output: Option<PathBuf>,
    in_place: bool,
    backup: bool,
    force: bool,
    mandrel_diameter: Option<f64>,
    feed_convention: Option<&str>,
    rotary_unit: Option<&str>,
    axes: Option<(char, char, char)>,
    keep_arc_length: Option<bool>,
    seam_rotation: Option<f64>,
    helical: bool,
    allow_overlap: bool,
    chord_tol: Option<f64>,
    config: Option<PathBuf>,
    preview: Option<PathBuf>,
    lenient: bool,
    options: &str,
) -> PyResult<String> {
    let machine = machine(mandrel_diameter, feed_convention, rotary_unit, axes)?;
    let mut wrap = read_settings(config.as_deref(), &machine, WrapConfig::read)?;
    wrap.apply(&WrapOverrides {
        machine,
        keep_arc_length,
        helical,
        allow_overlap,
        seam_rotation_deg: seam_rotation,
        chord_tolerance_mm: chord_tol,
    })
    .map_err(rotary_err)?;
    let strictness = strictness(lenient);
    let write = |t: &Target| {
        let run = Run::file(&input).strictness(strictness).to(t);
        wrap_file(&wrap, run, preview.as_deref()).map_err(rotary_err)
    };
    let target = target_of(output, in_place, backup, force)?;
    let own_time = |r: &(WrapReport, Malformed)| Some(r.0.time_s);
    let (report, malformed) = interruptible(py, || {
        finish::finished(Some(&input), &target, "rotary wrap", options, write, own_time)
    })??;
    to_json(&Transformed::new(&report, malformed, strictness))
}

/// Generates a helical tube; the keywords override the TOML file `config` as the CLI's flags
/// do. Returns the report as JSON text (`rotary tube --json`).
#[pyfunction]
#[pyo3(signature = (output, *, mandrel_diameter=None, length=None, layer_count=None, layer_height=None,
    bead_width=None, pitch=None, interweave=None, segments_per_turn=None, chord_tol=None, speed=None, temp=None,
    filament_diameter=None, feed_convention=None, rotary_unit=None, axes=None, config=None, preview=None, options=""))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn rotary_tube_json(
    py: Python<'_>,
    output: PathBuf,
    mandrel_diameter: Option<f64>,
    length: Option<f64>,
    layer_count: Option<u32>,
    layer_height: Option<f64>,
    bead_width: Option<f64>,
    pitch: Option<f64>,
    interweave: Option<bool>,
    segments_per_turn: Option<u32>,
    chord_tol: Option<f64>,
    speed: Option<f64>,
    temp: Option<f64>,
    filament_diameter: Option<f64>,
    feed_convention: Option<&str>,
    rotary_unit: Option<&str>,
    axes: Option<(char, char, char)>,
    config: Option<PathBuf>,
    preview: Option<PathBuf>,
    options: &str,
) -> PyResult<String> {
    let machine = machine(mandrel_diameter, feed_convention, rotary_unit, axes)?;
    let mut params = read_settings(config.as_deref(), &machine, helix::TubeParams::read)?;
    params
        .apply(&TubeOverrides {
            machine,
            length_mm: length,
            layers: layer_count,
            layer_height_mm: layer_height,
            bead_width_mm: bead_width,
            pitch_mm: pitch,
            interweave,
            segments_per_turn,
            chord_tolerance_mm: chord_tol,
            print_speed_mm_s: speed,
            nozzle_temp_c: temp,
            filament_diameter_mm: filament_diameter,
        })
        .map_err(rotary_err)?;
    let write = |t: &Target| tube_file(&params, t, preview.as_deref()).map_err(rotary_err);
    let target = Target::File(output);
    let own_time = |r: &gweave::rotary::report::TubeReport| Some(r.print_time_s);
    let report =
        interruptible(py, || finish::finished(None, &target, "rotary tube", options, write, own_time))??;
    to_json(&report)
}

/// The first exception a Python profile function raised, re-raised after the path fails.
type ErrorSlot = Arc<Mutex<Option<PyErr>>>;

/// A radius or pitch profile from Python: a number, a list of `(axial, value)` pairs, or a
/// callable `f(axial) -> value`.
fn profile(value: &Bound<'_, PyAny>, slot: &ErrorSlot) -> PyResult<Profile> {
    if value.is_callable() {
        let f = value.clone().unbind();
        let slot = slot.clone();
        return Ok(Profile::Custom(Arc::new(move |x: f64| {
            Python::with_gil(|py| match f.call1(py, (x,)).and_then(|v| v.extract::<f64>(py)) {
                Ok(v) => v,
                Err(e) => {
                    if let Ok(mut first) = slot.lock() {
                        first.get_or_insert(e);
                    }
                    f64::NAN
                }
            })
        })));
    }
    if let Ok(v) = value.extract::<f64>() {
        return Ok(Profile::Constant(v));
    }
    Ok(Profile::Table(value.extract::<Vec<(f64, f64)>>()?))
}

/// One helical bead on the mandrel from `start` to `end` (axial, mm), its centreline at
/// `radius` and advancing `pitch` per turn; each is a number, a list of `(axial, value)` pairs
/// (linear in between) or a callable of the axial position.
#[pyclass(module = "gweave", name = "HelicalPath")]
pub(crate) struct HelicalPath {
    path: RustHelicalPath,
    errors: ErrorSlot,
}

impl HelicalPath {
    /// Turns a failed path into the Python exception a profile raised, if any.
    fn fail(&self, e: RotaryError) -> PyErr {
        match self.errors.lock().ok().and_then(|mut slot| slot.take()) {
            Some(raised) => raised,
            None => rotary_err(e),
        }
    }
}

#[pymethods]
impl HelicalPath {
    #[new]
    #[pyo3(signature = (start, end, *, radius, pitch, handedness="right", start_theta=0.0, lead_in=0.0, lead_out=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        start: f64,
        end: f64,
        radius: &Bound<'_, PyAny>,
        pitch: &Bound<'_, PyAny>,
        handedness: &str,
        start_theta: f64,
        lead_in: f64,
        lead_out: f64,
    ) -> PyResult<Self> {
        let handedness = match handedness {
            "right" => Handedness::Right,
            "left" => Handedness::Left,
            other => {
                return Err(PyValueError::new_err(format!("handedness is 'right' or 'left', not {other:?}")))
            }
        };
        let errors = ErrorSlot::default();
        let mut path = RustHelicalPath::new(start, end, profile(radius, &errors)?, profile(pitch, &errors)?);
        path.handedness = handedness;
        path.start_theta_deg = start_theta;
        path.lead_in_deg = lead_in;
        path.lead_out_deg = lead_out;
        Ok(Self { path, errors })
    }

    /// The points `(axial_mm, theta_deg, radius_mm)`, chords within `chord_tol` mm of the helix.
    #[pyo3(signature = (*, chord_tol=0.01, segments_per_turn=None))]
    fn points(&self, chord_tol: f64, segments_per_turn: Option<u32>) -> PyResult<Vec<(f64, f64, f64)>> {
        let resolution = Resolution { chord_tolerance_mm: chord_tol, segments_per_turn };
        let points = self.path.points(resolution).map_err(|e| self.fail(e))?;
        Ok(points.into_iter().map(|p| (p.axial_mm, p.theta_deg, p.radius_mm)).collect())
    }

    fn __repr__(&self) -> String {
        format!(
            "<gweave.HelicalPath {} -> {} mm, {:?}>",
            self.path.start_axial_mm, self.path.end_axial_mm, self.path.handedness
        )
    }
}

/// `{"machine": RotaryConfig, "print": PrintSettings}` for custom paths.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PathsSettings {
    machine: RotaryConfig,
    #[serde(default)]
    print: PrintSettings,
}

/// Writes a program printing `paths` in order; `settings` as for the tube's `machine` and
/// `print` tables. Returns `{"filament_mm", "print_time_s"}` as JSON text.
#[pyfunction]
#[pyo3(signature = (paths, output, *, settings, config=None))]
pub(crate) fn write_helical_paths_json(
    paths: Vec<PyRef<'_, HelicalPath>>,
    output: PathBuf,
    settings: String,
    config: Option<PathBuf>,
) -> PyResult<String> {
    let s: PathsSettings = merged_settings(config.as_deref(), &settings).map_err(rotary_err)?;
    let rust: Vec<RustHelicalPath> = paths.iter().map(|p| p.path.clone()).collect();
    let mut out = gweave::gcode::writer::Output::create(&Target::File(output), None).map_err(err)?;
    let summary = helix::write_paths(&s.machine, &s.print, &rust, std::io::BufWriter::new(&mut out));
    let summary = summary.map_err(|e| match paths.iter().find_map(|p| p.errors.lock().ok()?.take()) {
        Some(raised) => raised,
        None => rotary_err(e),
    })?;
    out.commit().map_err(err)?;
    to_json(&serde_json::json!({ "filament_mm": summary.filament_mm, "print_time_s": summary.print_time_s }))
}
