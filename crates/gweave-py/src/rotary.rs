//! Rotary (lathe-type) printing: wrapping flat G-code, helical tubes and paths. The two jobs
//! are `gweave_sim::transform`'s, their keywords read as the options the engine declares
//! (`gweave::rotary::options`).

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use gweave::rotary::cylinder::RotaryConfig;
use gweave::rotary::helix::{
    self, Handedness, HelicalPath as RustHelicalPath, PrintSettings, Profile, Resolution,
};
use gweave::rotary::options::MachineOptions;
use gweave::rotary::report::merged_settings;
use gweave::rotary::RotaryError;
use gweave::Target;
use gweave::{TubeOptions, WrapOptions};
use gweave_sim::transform::{self, Job};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::args::target_of;
use crate::interrupt::interruptible;
use crate::options::failed;
use crate::{err, to_json};

fn rotary_err(e: RotaryError) -> PyErr {
    match e {
        RotaryError::Io(_) => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Wraps a flat G-code file onto the mandrel (see `gweave rotary wrap`), drawing the executed
/// path to the PNG `preview` if given; returns the report as JSON text. The keyword arguments
/// are the options of `gweave.rotary_wrap` (`mandrel_diameter`, `config`: a TOML file, ...), by
/// the names the engine declares.
#[pyfunction]
#[pyo3(signature = (input, output=None, *, in_place=false, backup=true, force=false, lenient=false, preview=None,
    **options))]
#[allow(clippy::too_many_arguments)] // the keywords every transform shares, as Python spells them
pub(crate) fn rotary_wrap_json(
    py: Python<'_>,
    input: PathBuf,
    output: Option<PathBuf>,
    in_place: bool,
    backup: bool,
    force: bool,
    lenient: bool,
    preview: Option<PathBuf>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let options: WrapOptions = crate::options::read("rotary_wrap", options)?;
    let target = target_of(output, in_place, backup, force)?;
    let wrap = |o: &WrapOptions, job: Job<'_>| transform::rotary_wrap(o, job, preview.as_deref());
    crate::transform::run(py, &options, &input, &target, lenient, wrap)
}

/// Generates a helical tube (see `gweave rotary tube`), drawing it to the PNG `preview` if
/// given; returns the report as JSON text. The keyword arguments are the options of
/// `gweave.rotary_tube`, by the names the engine declares.
#[pyfunction]
#[pyo3(signature = (output, *, preview=None, **options))]
pub(crate) fn rotary_tube_json(
    py: Python<'_>,
    output: PathBuf,
    preview: Option<PathBuf>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let options: TubeOptions = crate::options::read("rotary_tube", options)?;
    let target = Target::File(output);
    let report = interruptible(py, || transform::rotary_tube(&options, &target, preview.as_deref()))?;
    to_json(&report.map_err(failed)?)
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

/// Writes a program printing `paths` in order; `settings` the tube's `print` table as JSON
/// text, `machine` the machine's keywords (`mandrel_diameter`, `axes`, ... read as the options
/// the engine declares, `gweave::rotary::options::MachineOptions`), each over the TOML
/// `config`'s. Returns `{"filament_mm", "print_time_s"}` as JSON text.
#[pyfunction]
#[pyo3(signature = (paths, output, *, settings, config=None, **machine))]
pub(crate) fn write_helical_paths_json(
    paths: Vec<PyRef<'_, HelicalPath>>,
    output: PathBuf,
    settings: String,
    config: Option<PathBuf>,
    machine: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let machine: MachineOptions = crate::options::read("write_helical_paths", machine)?;
    let mut overrides: serde_json::Value =
        serde_json::from_str(&settings).map_err(|e| PyValueError::new_err(e.to_string()))?;
    // The `[machine]` table requires the diameter: a keyword completes a file without one.
    if let Some(d) = machine.mandrel_diameter {
        overrides["machine"]["mandrel_diameter_mm"] = d.into();
    }
    let mut s: PathsSettings =
        merged_settings(config.as_deref(), &overrides.to_string()).map_err(rotary_err)?;
    machine.apply(&mut s.machine);
    let rust: Vec<RustHelicalPath> = paths.iter().map(|p| p.path.clone()).collect();
    let mut out = gweave::Output::create(&Target::File(output), None).map_err(err)?;
    let summary = helix::write_paths(&s.machine, &s.print, &rust, std::io::BufWriter::new(&mut out));
    let summary = summary.map_err(|e| match paths.iter().find_map(|p| p.errors.lock().ok()?.take()) {
        Some(raised) => raised,
        None => rotary_err(e),
    })?;
    out.commit().map_err(err)?;
    to_json(&serde_json::json!({ "filament_mm": summary.filament_mm, "print_time_s": summary.print_time_s }))
}
