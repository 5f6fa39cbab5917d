//! Python bindings for gweave: one module, thin wrappers over the engine. Reports cross as JSON
//! text (the same documents `--json` prints) and become dicts in `gweave/__init__.py`.

use std::path::PathBuf;

use gweave::check::{check_file, CheckOptions};
use gweave::gcode::container::{self, Input};
use gweave::gcode::diag::{Diagnostic, Finding};
use gweave::gcode::flavour::{read_firmware, read_flavour};
use gweave::gcode::lexer::{parse_into, parse_line};
use gweave::gcode::line::{Block, Command, Value};
use gweave::gcode::reader::{LineReader, Part};
use gweave::gcode::state::{Effect, State, StateOptions, E, X, Y, Z};
use gweave::gcode::writer::Target;
use gweave::pass::{Identity, Quiet, Run};
use gweave::stats::stats_file;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use gweave::colour::Srgb8;
use gweave::gcode::layers::ALL_FEATURES;
use gweave::render::{
    self, ColourBy, Format, PreviewOptions, Toolpath, ToolpathOptions, ViewKind, ViewOptions,
};
use pyo3::types::PyBytes;

mod args;
mod finish;

use args::{in_range, os_error, BedArg, LayersArg};
use gweave::render::layer_range;

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

/// Statistics of a G-code file as JSON text (see `gweave stats --json`).
#[pyfunction]
#[pyo3(signature = (path, *, filament_diameter=None, lenient=false))]
fn stats_json(
    py: Python<'_>,
    path: PathBuf,
    filament_diameter: Option<f64>,
    lenient: bool,
) -> PyResult<String> {
    let diameter = in_range("filament_diameter", filament_diameter, gweave::range::FILAMENT_DIAMETER_MM)?;
    let stats = py.allow_threads(|| stats_file(&path, diameter, strictness(lenient), &mut Quiet));
    to_json(&stats.map_err(err)?)
}

/// Lint report of a G-code file as JSON text (see `gweave check --json`). Without `bed`, the
/// bed the slicer's settings in the file give; `failed` is whether the file fails the check (an
/// error, or with `strict` a warning: `gweave check`'s exit code 1).
#[pyfunction]
#[pyo3(signature = (path, *, bed=None, max_feed=None, strict=false))]
fn check_json(
    py: Python<'_>,
    path: PathBuf,
    bed: Option<BedArg>,
    max_feed: Option<f64>,
    strict: bool,
) -> PyResult<String> {
    let mut options = CheckOptions { bed: bed.map(BedArg::bed).transpose()?, ..CheckOptions::default() };
    if let Some(f) = in_range("max_feed", max_feed, gweave::range::FEED_MM_MIN)? {
        options.max_feed_mm_min = f;
    }
    let report = py.allow_threads(|| check_file(&path, options, &mut Quiet)).map_err(err)?;
    let mut doc = serde_json::to_value(&report).map_err(|e| PyValueError::new_err(e.to_string()))?;
    doc["failed"] = report.failed(strict).into();
    to_json(&doc)
}

/// Parse a file and write it back unchanged (atomically); `output=None` with `in_place=True`
/// replaces the input, keeping `<path>.bak` unless `backup=False`. Returns what was copied as
/// JSON text (see `gweave cat --json`).
#[pyfunction]
#[pyo3(signature = (path, output=None, *, in_place=false, backup=true, force=false, lenient=false))]
#[allow(clippy::too_many_arguments)]
fn cat_json(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    in_place: bool,
    backup: bool,
    force: bool,
    lenient: bool,
) -> PyResult<String> {
    let target = match (output, in_place) {
        (_, true) => Target::InPlace { keep_backup: backup, force },
        (Some(p), false) => Target::File(p),
        (None, false) => return Err(PyValueError::new_err("give an output path or in_place=True")),
    };
    let report = py.allow_threads(|| {
        let mut copy = Identity::default();
        let mut quiet = Quiet;
        let mut run = Run::new(&path, &mut quiet);
        run.strictness = strictness(lenient);
        run.transform(&mut copy, &target).map(|_| copy.report)
    });
    to_json(&report.map_err(err)?)
}

// purge-shift
/// Moves every colour change earlier by the purge (see `gweave purge-shift`); returns the report
/// as JSON text. `config` is TOML text; the keyword arguments override it.
#[pyfunction]
#[pyo3(signature = (path, output=None, *, in_place=false, backup=true, force=false, purge_mm=None, purge_mm3=None,
    config=None, filament_diameter=None, cross_layers=false, allow_features=None, markers=None,
    fallback=None, tower_at=None, options=""))]
#[allow(clippy::too_many_arguments)]
fn purge_shift_json(
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
    options: &str,
) -> PyResult<String> {
    use gweave::post::purge_shift::{purge_shift_file, Overrides, PurgeShiftConfig};
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
    let target = match (output, in_place) {
        (_, true) => Target::InPlace { keep_backup: backup, force },
        (Some(p), false) => Target::File(p),
        (None, false) => return Err(PyValueError::new_err("give an output path or in_place=True")),
    };
    let write = |t: &Target| purge_shift_file(rules, &path, t, &mut Quiet).map_err(err);
    let mut report =
        py.allow_threads(|| finish::finished(Some(&path), &target, "purge-shift", options, write, |_| None))?;
    // The run's header is one line above every change.
    report.changes.offset_output_lines(1);
    to_json(&report)
}

/// One line of a file, with what it says and the machine state after it.
#[pyclass(frozen, get_all, module = "gweave")]
struct Line {
    /// 1-based line number.
    number: u64,
    /// The line's bytes without its line ending.
    raw: Vec<u8>,
    /// `"G1"`, `"M104"`, `"T0"`, an extended command name, or None.
    command: Option<String>,
    /// Parameter words: letter -> number (float), None for a bare letter, or str for strings.
    words: Py<PyDict>,
    /// Text after `;`, or None.
    comment: Option<String>,
    /// The string argument of `M117` and the like, or an extended command's arguments.
    text: Option<String>,
    /// Diagnostics as (column, message) pairs.
    diagnostics: Vec<(u32, String)>,
    /// Position after the line: (x, y, z, e), mm.
    position: (f64, f64, f64, f64),
    /// Filament this line fed, mm (negative for a retraction).
    extruded: f64,
    /// True when the line moves the head.
    is_move: bool,
    tool: u32,
    /// 0-based layer index, or None before the first layer.
    layer: Option<u32>,
    /// Z of the current layer, mm.
    layer_z: f64,
    /// Feature type name (`outer_wall`, `infill`, ...).
    feature: &'static str,
    /// `start`, `print` or `end`.
    region: &'static str,
}

#[pymethods]
impl Line {
    fn __repr__(&self) -> String {
        format!("<gweave.Line {}: {:?}>", self.number, String::from_utf8_lossy(&self.raw))
    }
}

/// Iterates a file's lines with parsed words and machine state; memory stays bounded.
#[pyclass(module = "gweave")]
struct Reader {
    lines: LineReader<Input>,
    block: Block,
    state: State,
}

#[pymethods]
impl Reader {
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        let os_err = |e: std::io::Error| os_error(&path, &e);
        // The state reads the file's words as its flavour means them, as every command does.
        let flavour = read_flavour(&path).map_err(os_err)?;
        let file = container::open(&path).map_err(os_err)?;
        let state = State::new(StateOptions::default().for_flavour(flavour.as_deref()));
        Ok(Reader { lines: LineReader::new(file), block: Block::default(), state })
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<Option<Line>> {
        let os_err = |e: std::io::Error| PyOSError::new_err(e.to_string());
        let Some(line) = self.lines.next_line().map_err(os_err)? else {
            return Ok(None);
        };
        let (raw, number) = match line.part {
            Part::Whole => {
                parse_line(&line, &mut self.block);
                (line.bytes, line.number)
            }
            // A line longer than MAX_LINE comes in pieces: it is given once, empty, with its
            // finding, and leaves the state as it was.
            mut part => {
                let number = line.number;
                // The reader always ends a long line with its last piece.
                let len = loop {
                    match part {
                        Part::Last { len } => break len,
                        _ => {
                            part = self
                                .lines
                                .next_line()
                                .map_err(os_err)?
                                .map_or(Part::Last { len: 0 }, |l| l.part)
                        }
                    }
                };
                parse_into(b"", &mut self.block);
                self.block.diagnostics.push(Diagnostic::at(0, Finding::LineTooLong { len }));
                (&b""[..], number)
            }
        };
        let effect = *self.state.apply(raw, &self.block);
        let b = &self.block;
        let words = PyDict::new(py);
        for w in &b.words {
            let key = (w.letter as char).to_string();
            match w.value {
                Value::Number(v) => words.set_item(key, v)?,
                Value::Text(s) | Value::Expr(s) => words.set_item(key, String::from_utf8_lossy(s.of(raw)))?,
                Value::Empty | Value::Invalid => words.set_item(key, py.None())?,
            }
        }
        let lossy = |s: &[u8]| String::from_utf8_lossy(s).into_owned();
        let command = match b.command {
            Command::None => None,
            _ => Some(lossy(b.command_span.of(raw)).to_ascii_uppercase()),
        };
        let extruded = effect.filament_mm();
        let s = &self.state;
        Ok(Some(Line {
            number,
            raw: raw.to_vec(),
            command,
            words: words.unbind(),
            comment: b.comment_text(raw).map(lossy),
            text: b.text_of(raw).map(lossy),
            diagnostics: b.diagnostics.iter().map(|d| (d.column, d.finding.to_string())).collect(),
            position: (s.pos[X], s.pos[Y], s.pos[Z], s.pos[E]),
            extruded,
            is_move: matches!(effect, Effect::Move(_)),
            tool: s.tool,
            layer: s.structure.layer,
            layer_z: s.structure.layer_z_mm,
            feature: s.structure.feature.name(),
            region: match s.structure.region {
                gweave::gcode::layers::Region::Start => "start",
                gweave::gcode::layers::Region::Print => "print",
                gweave::gcode::layers::Region::End => "end",
            },
        }))
    }
}

// ---- preview (render) ----

/// A picture or viewer page of a file as bytes (`format`: png, svg or html) and the report of
/// what it shows as JSON; see `gweave preview`.
#[pyfunction]
#[pyo3(signature = (path, *, format, layer=None, layers=None, view=None, colour_by="tool", size=(1200, 900), compare=None, tool_colours=None, travel=false, mix_profile=None, mandrel_diameter=None, head=None, min_len=None, lenient=false))]
#[allow(clippy::too_many_arguments)]
fn preview_json(
    py: Python<'_>,
    path: PathBuf,
    format: &str,
    layer: Option<u32>,
    layers: Option<LayersArg>,
    view: Option<&str>,
    colour_by: &str,
    size: (u32, u32),
    compare: Option<PathBuf>,
    tool_colours: Option<Vec<String>>,
    travel: bool,
    mix_profile: Option<PathBuf>,
    mandrel_diameter: Option<f64>,
    head: Option<PathBuf>,
    min_len: Option<f32>,
    lenient: bool,
) -> PyResult<(Py<PyBytes>, String)> {
    let read = |p: &PathBuf| std::fs::read_to_string(p).map_err(|e| os_error(p, &e));
    let layer = in_range("layer", layer, gweave::range::LAYER_NUMBER)?;
    let mandrel_diameter =
        in_range("mandrel_diameter", mandrel_diameter, gweave::rotary::cylinder::MANDREL_DIAMETER_MM)?;
    let printhead = match head {
        Some(p) => Some(
            gweave::gen::printhead::PrintheadProfile::from_toml(&read(&p)?)
                .map_err(|e| PyValueError::new_err(e.to_string()))?,
        ),
        None => None,
    };
    let mix = match mix_profile {
        Some(p) => {
            let text = read(&p)?;
            let profile = gweave::post::mix::profile::MixProfile::from_toml_str(&text)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            Some(
                render::MixColours::from_profile(&profile)
                    .map_err(|e| PyValueError::new_err(e.to_string()))?,
            )
        }
        None => None,
    };
    let format = Format::from_path(std::path::Path::new(&format!("x.{format}")))
        .map_err(|e| PyValueError::new_err(format!("output: {e}")))?;
    let tool_colours = tool_colours
        .unwrap_or_default()
        .iter()
        .map(|c| c.parse::<Srgb8>().map_err(|e| PyValueError::new_err(e.to_string())))
        .collect::<PyResult<Vec<_>>>()?;
    let options = PreviewOptions {
        view: ViewOptions {
            kind: match view {
                Some(v) => v.parse::<ViewKind>().map_err(PyValueError::new_err)?,
                None => format.default_view(),
            },
            layers: match (layer, layers) {
                (Some(l), _) => Some(layer_range(l, l).map_err(PyValueError::new_err)?),
                (None, Some(range)) => Some(range.range()?),
                (None, None) => None,
            },
            width_px: size.0,
            height_px: size.1,
            colour_by: colour_by.parse::<ColourBy>().map_err(PyValueError::new_err)?,
            tool_colours,
            travel,
            ..ViewOptions::default()
        },
        mix,
        rotary: mandrel_diameter.map(gweave::rotary::cylinder::RotaryConfig::new),
        printhead,
        min_len_mm: min_len,
        strictness: strictness(lenient),
    };
    let preview = py
        .allow_threads(|| {
            render::preview_with_progress(&path, compare.as_deref(), format, &options, &mut Quiet)
        })
        .map_err(render_err)?;
    Ok((PyBytes::new(py, &preview.bytes).unbind(), to_json(&preview.report)?))
}

fn render_err(e: render::RenderError) -> PyErr {
    match e {
        render::RenderError::Gcode(e) => err(e),
        other => PyValueError::new_err(other.to_string()),
    }
}

/// A file's toolpath as little-endian column bytes: (segment count, {name: bytes}) with start
/// and end (f32 x 3 each), tool (u16), feature (u8, index into `feature_names`), feed_mm_s (f32),
/// layer (u32), extruding (u8 0/1). `gweave.toolpath` turns them into NumPy arrays. A rotary
/// program (its header names the machine, or `mandrel_diameter` is given) comes out in 3D on its
/// cylinder, mandrel along X, with `on_cylinder` true.
#[pyfunction]
#[pyo3(signature = (path, *, travel=true, min_len=0.0, mandrel_diameter=None))]
fn toolpath_columns(
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
    let tp = py.allow_threads(|| Toolpath::from_file(&path, options)).map_err(err)?;
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

/// Runs the `gweave` command line with these arguments (argv[0] included); returns the exit code.
#[pyfunction]
fn run_cli(py: Python<'_>, argv: Vec<String>) -> i32 {
    let code = py.allow_threads(|| gweave_cli::run(argv));
    // ExitCode is opaque; the CLI only returns SUCCESS, FAILURE (1) or usage errors (2).
    if code == std::process::ExitCode::SUCCESS {
        0
    } else if code == std::process::ExitCode::from(2) {
        2
    } else {
        1
    }
}

// ---- binder-jet raster (gweave raster, slice-raster) ----

/// An anyhow error from the CLI's job runner: OSError when a file could not be read or written.
fn job_err(e: anyhow::Error) -> PyErr {
    let io = e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some());
    let text = format!("{e:#}");
    if io {
        PyOSError::new_err(text)
    } else {
        PyValueError::new_err(text)
    }
}

/// Rasters layer images or a `.sl1` into inkjet G-code; the report as JSON text (see
/// `gweave raster --json`).
#[pyfunction]
#[pyo3(signature = (inputs, output, *, head=None, threshold=0.5, invert=false, flip_y=false, one_way=false,
    density=1, origin=(20.0, 20.0), layer_height=None, pixel_mm=None, dpi=None, heads=None, channels=None,
    recoat=None, start=None, end=None, dialect=None, feed=None, fast_estimate=false, options=""))]
#[allow(clippy::too_many_arguments)]
fn raster_json(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    output: PathBuf,
    head: Option<PathBuf>,
    threshold: f64,
    invert: bool,
    flip_y: bool,
    one_way: bool,
    density: u32,
    origin: (f64, f64),
    layer_height: Option<f64>,
    pixel_mm: Option<f64>,
    dpi: Option<f64>,
    heads: Option<usize>,
    channels: Option<String>,
    recoat: Option<PathBuf>,
    start: Option<PathBuf>,
    end: Option<PathBuf>,
    dialect: Option<&str>,
    feed: Option<f64>,
    fast_estimate: bool,
    options: &str,
) -> PyResult<String> {
    let job_options = gweave_cli::raster_job::JobOptions {
        inputs,
        head,
        threshold,
        invert,
        flip_y,
        one_way,
        fire_order: Default::default(),
        density,
        origin_mm: origin,
        layer_height_mm: layer_height,
        pixel_mm,
        dpi,
        heads,
        channels,
        recoat,
        start,
        end,
        dialect: args::firmware("dialect", dialect)?,
        feed_mm_min: feed,
        fast_estimate,
    };
    let job = job_options.job().map_err(job_err)?;
    let write = |t: &Target| job.run(t, &mut Quiet).map_err(job_err);
    // Its own time counts the printhead's firing, which the estimator does not know.
    let own_time = |r: &gweave_cli::raster_job::JobReport| Some(r.time.total_s);
    let target = Target::File(output);
    let report = py.allow_threads(|| finish::finished(None, &target, "raster", options, write, own_time))?;
    to_json(&report)
}

/// Writes a nozzle test pattern; the raster report as JSON text.
#[pyfunction]
#[pyo3(signature = (output, *, head=None, heads=None, dialect=None, columns=4, origin=(20.0, 20.0)))]
fn raster_test_pattern_json(
    py: Python<'_>,
    output: PathBuf,
    head: Option<PathBuf>,
    heads: Option<usize>,
    dialect: Option<&str>,
    columns: usize,
    origin: (f64, f64),
) -> PyResult<String> {
    let options = gweave_cli::raster_job::JobOptions {
        head,
        heads,
        dialect: args::firmware("dialect", dialect)?,
        origin_mm: origin,
        ..Default::default()
    };
    let (report, _) =
        py.allow_threads(|| options.test_pattern(&Target::File(output), columns)).map_err(job_err)?;
    to_json(&report)
}

/// Slices an STL into 1-bit layer PNGs in `out_dir`; the report as JSON text (see
/// `gweave slice-raster --json`).
#[pyfunction]
#[pyo3(signature = (stl, out_dir, *, layer_height, dpi=96.0, pixel_mm=None, margin=0))]
fn slice_raster_json(
    py: Python<'_>,
    stl: PathBuf,
    out_dir: PathBuf,
    layer_height: f64,
    dpi: f64,
    pixel_mm: Option<f64>,
    margin: usize,
) -> PyResult<String> {
    use gweave::gen::slice_raster::{slice_to_dir, SliceConfig};
    let cfg = SliceConfig {
        layer_height_mm: layer_height,
        pixel_mm: pixel_mm.unwrap_or(25.4 / dpi),
        margin_px: margin,
    };
    let report = py.allow_threads(|| {
        let mesh = gweave::gen::stl::read_stl(&stl).map_err(|e| match e {
            gweave::gen::stl::StlError::Io { .. } => PyOSError::new_err(e.to_string()),
            _ => PyValueError::new_err(format!("{}: {e}", stl.display())),
        })?;
        slice_to_dir(&mesh, &cfg, &out_dir).map_err(|e| PyValueError::new_err(e.to_string()))
    })?;
    to_json(&report)
}

// --- gweave-sim: the virtual printer ---

fn machine_profile(machine: Option<PathBuf>) -> PyResult<gweave_sim::MachineProfile> {
    match machine {
        None => Ok(gweave_sim::MachineProfile::default()),
        Some(path) => {
            let text = std::fs::read_to_string(&path).map_err(|e| os_error(&path, &e))?;
            gweave_sim::MachineProfile::from_toml_str(&text)
                .map_err(|e| PyValueError::new_err(format!("{}: {e}", path.display())))
        }
    }
}

fn sim_err(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Runs a file through the virtual printer; the report as JSON text (see `gweave sim --json`).
#[pyfunction]
#[pyo3(signature = (path, *, machine=None, fault=Vec::new()))]
fn sim_json(py: Python<'_>, path: PathBuf, machine: Option<PathBuf>, fault: Vec<String>) -> PyResult<String> {
    let mut profile = machine_profile(machine)?;
    for spec in &fault {
        let spec = spec.parse::<gweave_sim::FaultSpec>();
        profile.faults.push(spec.map_err(|e| PyValueError::new_err(format!("fault: {e}")))?);
    }
    let report = py.allow_threads(|| {
        let mut m = gweave_sim::Machine::new(profile).map_err(sim_err)?;
        m.read_as(read_firmware(&path).map_err(|e| os_error(&path, &e))?);
        let file = container::open(&path).map_err(|e| os_error(&path, &e))?;
        let mut reader = LineReader::new(file);
        let mut out = |_t: f64, _l: &str| {};
        while let Some(line) = reader.next_line().map_err(|e| PyOSError::new_err(e.to_string()))? {
            match line.part {
                Part::Whole => {
                    if m.execute(line.bytes, &mut out) == gweave_sim::Outcome::Halted {
                        break;
                    }
                }
                Part::Piece => {}
                Part::Last { .. } => m.skip_long_line(),
            }
        }
        m.finish(&mut out);
        Ok::<_, PyErr>(m.report())
    })?;
    to_json(&report)
}

/// Estimates a file's print time with the virtual printer's planner alone, on three threads; the
/// report as JSON text (see `gweave estimate --json`).
#[pyfunction]
#[pyo3(signature = (path, *, machine=None, steps=false))]
fn estimate_json(py: Python<'_>, path: PathBuf, machine: Option<PathBuf>, steps: bool) -> PyResult<String> {
    let profile = machine_profile(machine)?;
    let report = py.allow_threads(|| {
        let firmware = read_firmware(&path).map_err(|e| os_error(&path, &e))?;
        let file = container::open(&path).map_err(|e| os_error(&path, &e))?;
        gweave_sim::estimate_report(file, &profile, firmware, steps)
            .map_err(|e| PyValueError::new_err(format!("{}: {e}", path.display())))
    })?;
    to_json(&report)
}

/// A virtual printer to drive one command at a time, as a host would over a serial line.
/// (Unsendable: it stays on the thread that made it; the controllers are not `Sync`.)
#[pyclass(module = "gweave", unsendable)]
struct Machine {
    inner: gweave_sim::Machine,
}

#[pymethods]
impl Machine {
    /// A machine at power-on; `machine` is a profile TOML path (default: RAMPS 1.4 Marlin).
    #[new]
    #[pyo3(signature = (*, machine=None))]
    fn new(machine: Option<PathBuf>) -> PyResult<Self> {
        let inner = gweave_sim::Machine::new(machine_profile(machine)?).map_err(sim_err)?;
        Ok(Self { inner })
    }

    /// The lines printed at power-on (`start`, ...).
    fn boot_lines(&self) -> Vec<String> {
        self.inner.boot_lines()
    }

    /// Executes one command; returns its replies as a serial port would show them, ending
    /// with `ok` unless the machine is halted (`M105` answers `ok T:...` in one line).
    fn execute(&mut self, line: &str) -> Vec<String> {
        let mut replies = Vec::new();
        let outcome = self.inner.execute(line.as_bytes(), &mut |_t, l| replies.push(l.to_owned()));
        if outcome == gweave_sim::Outcome::Ok && !self.inner.acknowledged() {
            replies.push("ok".to_owned());
        }
        replies
    }

    /// Simulated time, s.
    #[getter]
    fn now_s(&self) -> f64 {
        self.inner.now_s()
    }

    /// Executes everything still queued in the planner (the end of a job).
    fn finish(&mut self) {
        self.inner.finish(&mut |_, _| {});
    }

    /// The report so far as a dict (the same fields as `gweave sim --json`).
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = to_json(&self.inner.report())?;
        py.import("json")?.call_method1("loads", (text,))
    }
}

// ---- rotary (lathe-type) printing: gweave::rotary ----

use std::sync::{Arc, Mutex};

use gweave::rotary::cylinder::RotaryConfig;
use gweave::rotary::helix::{
    self, Handedness, HelicalPath as RustHelicalPath, PrintSettings, Profile, Resolution,
};
use gweave::rotary::report::{merged_settings, tube_file, wrap_file};
use gweave::rotary::wrap::WrapConfig;
use gweave::rotary::RotaryError;

fn rotary_err(e: RotaryError) -> PyErr {
    match e {
        RotaryError::Io(_) => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Wraps a flat G-code file onto the mandrel; `settings` is a JSON object of `WrapConfig` keys
/// merged over the TOML file `config`. Returns the report as JSON text (`rotary wrap --json`).
#[pyfunction]
#[pyo3(signature = (input, output, *, settings, config=None, preview=None, options=""))]
fn rotary_wrap_json(
    py: Python<'_>,
    input: PathBuf,
    output: PathBuf,
    settings: String,
    config: Option<PathBuf>,
    preview: Option<PathBuf>,
    options: &str,
) -> PyResult<String> {
    let wrap: WrapConfig = merged_settings(config.as_deref(), &settings).map_err(rotary_err)?;
    let write = |t: &Target| wrap_file(&wrap, &input, t, preview.as_deref(), &mut Quiet).map_err(rotary_err);
    let target = Target::File(output);
    let own_time = |r: &gweave::rotary::report::WrapReport| Some(r.time_s);
    let report = py
        .allow_threads(|| finish::finished(Some(&input), &target, "rotary wrap", options, write, own_time))?;
    to_json(&report)
}

/// Generates a helical tube; `settings` is a JSON object of `TubeParams` keys merged over the
/// TOML file `config`. Returns the report as JSON text (`rotary tube --json`).
#[pyfunction]
#[pyo3(signature = (output, *, settings, config=None, preview=None, options=""))]
fn rotary_tube_json(
    py: Python<'_>,
    output: PathBuf,
    settings: String,
    config: Option<PathBuf>,
    preview: Option<PathBuf>,
    options: &str,
) -> PyResult<String> {
    let params: helix::TubeParams = merged_settings(config.as_deref(), &settings).map_err(rotary_err)?;
    let write = |t: &Target| tube_file(&params, t, preview.as_deref()).map_err(rotary_err);
    let target = Target::File(output);
    let own_time = |r: &gweave::rotary::report::TubeReport| Some(r.print_time_s);
    let report =
        py.allow_threads(|| finish::finished(None, &target, "rotary tube", options, write, own_time))?;
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
struct HelicalPath {
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
fn write_helical_paths_json(
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

// mix
/// The colour `ratios` (one per input, any scale) is predicted to print, as JSON text
/// `{"ratios", "srgb", "lab"}` (see `gweave mix --predict`); `config` is a profile's TOML text
/// (empty: the default cyan, magenta, yellow, white filaments).
#[pyfunction]
#[pyo3(signature = (ratios, *, config=""))]
fn predict_colour_json(ratios: Vec<f64>, config: &str) -> PyResult<String> {
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
#[pyo3(signature = (path, output=None, *, config="", at_layer=Vec::new(), at_z=Vec::new(), map=Vec::new(), gradient=Vec::new(), gradient_space="mix", dialect=None, purge_mm=None, initial_purge=None, in_place=false, backup=true, force=false, options=""))]
#[allow(clippy::too_many_arguments)]
fn mix_json(
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
    options: &str,
) -> PyResult<String> {
    use gweave::post::mix::profile::{GradientSpace, GradientSpec, MixProfile, ScheduleEntry};
    let bad = |e: gweave::post::mix::MixPassError| PyValueError::new_err(e.to_string());
    let target = match (output, in_place) {
        (_, true) => Target::InPlace { keep_backup: backup, force },
        (Some(p), false) => Target::File(p),
        (None, false) => return Err(PyValueError::new_err("give an output path or in_place=True")),
    };
    let mut profile = MixProfile::from_toml_str(config).map_err(bad)?;
    let space = match gradient_space {
        "mix" => GradientSpace::Mix,
        "perceived" => GradientSpace::Perceived,
        other => {
            let text = format!("gradient_space: 'mix' or 'perceived', not {other:?}");
            return Err(PyValueError::new_err(text));
        }
    };
    if let Some(mm) = in_range("purge_mm", purge_mm, gweave::range::PURGE_MM)? {
        profile.purge.set_length_mm(mm);
    }
    if let Some(mm) = in_range("initial_purge", initial_purge, gweave::range::PURGE_MM)? {
        profile.purge.initial_mm = mm;
    }
    for s in &at_layer {
        profile.schedule.push(ScheduleEntry::parse_layer(s).map_err(bad)?);
    }
    for s in &at_z {
        profile.schedule.push(ScheduleEntry::parse_z(s).map_err(bad)?);
    }
    for s in &gradient {
        profile.gradient.push(GradientSpec::parse(s, space).map_err(bad)?);
    }
    for s in &map {
        profile.add_map(s).map_err(bad)?;
    }
    if let Some(d) = dialect {
        profile.hardware.dialect = Some(d.parse::<gweave::firmware::MixCommands>().map_err(bad)?);
    }
    let write = |t: &Target| match gweave::post::mix::mix_file(profile, &path, t, &mut Quiet) {
        Ok(r) => Ok(r),
        Err(gweave::post::mix::MixPassError::Engine(e)) => Err(err(e)),
        Err(e) => Err(bad(e)),
    };
    let report =
        py.allow_threads(|| finish::finished(Some(&path), &target, "mix", options, write, |_| None))?;
    to_json(&report)
}

#[pymodule]
fn _gweave(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(stats_json, m)?)?;
    m.add_function(wrap_pyfunction!(check_json, m)?)?;
    m.add_function(wrap_pyfunction!(cat_json, m)?)?;
    m.add_function(wrap_pyfunction!(run_cli, m)?)?;
    // binder-jet raster
    m.add_function(wrap_pyfunction!(raster_json, m)?)?;
    m.add_function(wrap_pyfunction!(raster_test_pattern_json, m)?)?;
    m.add_function(wrap_pyfunction!(slice_raster_json, m)?)?;
    // purge-shift
    m.add_function(wrap_pyfunction!(purge_shift_json, m)?)?;
    // mix
    m.add_function(wrap_pyfunction!(mix_json, m)?)?;
    m.add_function(wrap_pyfunction!(predict_colour_json, m)?)?;
    m.add_class::<Line>()?;
    m.add_class::<Reader>()?;
    // gweave-sim: the virtual printer
    m.add_function(wrap_pyfunction!(sim_json, m)?)?;
    m.add_function(wrap_pyfunction!(estimate_json, m)?)?;
    m.add_class::<Machine>()?;
    // rotary (lathe-type) printing
    m.add_function(wrap_pyfunction!(rotary_wrap_json, m)?)?;
    m.add_function(wrap_pyfunction!(rotary_tube_json, m)?)?;
    m.add_function(wrap_pyfunction!(write_helical_paths_json, m)?)?;
    m.add_class::<HelicalPath>()?;

    m.add_function(wrap_pyfunction!(preview_json, m)?)?;
    m.add_function(wrap_pyfunction!(toolpath_columns, m)?)?;
    Ok(())
}
