//! Python bindings for gweave: one module, thin wrappers over the engine. Reports cross as JSON
//! text (the same documents `--json` prints) and become dicts in `gweave/__init__.py`.

use std::fs::File;
use std::path::PathBuf;

use gweave::check::{CheckOptions, CheckPass};
use gweave::gcode::lexer::parse_into;
use gweave::gcode::line::{Block, Command, Value};
use gweave::gcode::reader::LineReader;
use gweave::gcode::state::{Effect, State, E, X, Y, Z};
use gweave::gcode::writer::Target;
use gweave::pass::{Identity, Quiet, Run};
use gweave::stats::StatsPass;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use gweave::colour::Srgb8;
use gweave::gcode::layers::ALL_FEATURES;
use gweave::render::{
    self, ColourBy, Format, PreviewOptions, Toolpath, ToolpathOptions, ViewKind, ViewOptions,
};
use pyo3::types::PyBytes;

fn err(e: gweave::Error) -> PyErr {
    match e {
        gweave::Error::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

fn to_json<T: serde::Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Statistics of a G-code file as JSON text (see `gweave stats --json`).
#[pyfunction]
#[pyo3(signature = (path, *, filament_diameter=None))]
fn stats_json(py: Python<'_>, path: PathBuf, filament_diameter: Option<f64>) -> PyResult<String> {
    let stats = py.allow_threads(|| {
        let mut pass = StatsPass::new(filament_diameter);
        let state = Run::new(&path, &mut Quiet).scan(&mut pass)?;
        Ok::<_, gweave::Error>(pass.into_stats(&state))
    });
    to_json(&stats.map_err(err)?)
}

/// Lint report of a G-code file as JSON text (see `gweave check --json`).
#[pyfunction]
#[pyo3(signature = (path, *, bed=None, max_feed=None))]
fn check_json(
    py: Python<'_>,
    path: PathBuf,
    bed: Option<[f64; 3]>,
    max_feed: Option<f64>,
) -> PyResult<String> {
    let mut options = CheckOptions { bed_mm: bed, ..CheckOptions::default() };
    if let Some(f) = max_feed {
        options.max_feed_mm_min = f;
    }
    let report = py.allow_threads(|| {
        let mut pass = CheckPass::new(options);
        let mut quiet = Quiet;
        let mut run = Run::new(&path, &mut quiet);
        run.strictness = gweave::pass::Strictness::Lenient;
        run.scan(&mut pass)?;
        Ok::<_, gweave::Error>(pass.report)
    });
    to_json(&report.map_err(err)?)
}

/// Parse a file and write it back unchanged (atomically); `output=None` with `in_place=True`
/// replaces the input, keeping `<path>.bak` unless `backup=False`.
#[pyfunction]
#[pyo3(signature = (path, output=None, *, in_place=false, backup=true))]
fn cat(py: Python<'_>, path: PathBuf, output: Option<PathBuf>, in_place: bool, backup: bool) -> PyResult<()> {
    let target = match (output, in_place) {
        (_, true) => Target::InPlace { keep_backup: backup },
        (Some(p), false) => Target::File(p),
        (None, false) => return Err(PyValueError::new_err("give an output path or in_place=True")),
    };
    py.allow_threads(|| Run::new(&path, &mut Quiet).transform(&mut Identity, &target).map(|_| ()))
        .map_err(err)
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
    lines: LineReader<File>,
    block: Block,
    state: State,
}

#[pymethods]
impl Reader {
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        let file = File::open(&path).map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))?;
        Ok(Reader { lines: LineReader::new(file), block: Block::default(), state: State::default() })
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<Option<Line>> {
        let Some(line) = self.lines.next_line().map_err(|e| PyOSError::new_err(e.to_string()))? else {
            return Ok(None);
        };
        let raw = line.bytes;
        parse_into(raw, &mut self.block);
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
        let extruded = match effect {
            Effect::Move(m) => m.e_mm(),
            Effect::FirmwareRetract { e_mm } => e_mm,
            _ => 0.0,
        };
        let s = &self.state;
        Ok(Some(Line {
            number: line.number,
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

/// A picture or viewer page of a file as bytes (`format`: png, svg or html); see `gweave preview`.
#[pyfunction]
#[pyo3(signature = (path, *, format, layers=None, view="top", colour_by="tool", size=(1200, 900), compare=None, tool_colours=None, travel=false))]
#[allow(clippy::too_many_arguments)]
fn preview_bytes(
    py: Python<'_>,
    path: PathBuf,
    format: &str,
    layers: Option<(u32, u32)>,
    view: &str,
    colour_by: &str,
    size: (u32, u32),
    compare: Option<PathBuf>,
    tool_colours: Option<Vec<String>>,
    travel: bool,
) -> PyResult<Py<PyBytes>> {
    let format = Format::from_path(std::path::Path::new(&format!("x.{format}"))).map_err(render_err)?;
    let tool_colours = tool_colours
        .unwrap_or_default()
        .iter()
        .map(|c| c.parse::<Srgb8>().map_err(|e| PyValueError::new_err(e.to_string())))
        .collect::<PyResult<Vec<_>>>()?;
    let options = PreviewOptions {
        view: ViewOptions {
            kind: view.parse::<ViewKind>().map_err(PyValueError::new_err)?,
            layers: layers.map(|(a, b)| a..=b),
            width_px: size.0,
            height_px: size.1,
            colour_by: colour_by.parse::<ColourBy>().map_err(PyValueError::new_err)?,
            tool_colours,
            travel,
            ..ViewOptions::default()
        },
        min_len_mm: None,
    };
    let bytes = py
        .allow_threads(|| render::preview(&path, compare.as_deref(), format, &options))
        .map_err(render_err)?;
    Ok(PyBytes::new(py, &bytes).unbind())
}

fn render_err(e: render::RenderError) -> PyErr {
    match e {
        render::RenderError::Gcode(e) => err(e),
        other => PyValueError::new_err(other.to_string()),
    }
}

/// A file's toolpath as little-endian column bytes: (segment count, {name: bytes}) with start
/// and end (f32 x 3 each), tool (u16), feature (u8, index into `feature_names`), feed_mm_s (f32),
/// layer (u32), extruding (u8 0/1). `gweave.toolpath` turns them into NumPy arrays.
#[pyfunction]
#[pyo3(signature = (path, *, travel=true, min_len=0.0))]
fn toolpath_columns(
    py: Python<'_>,
    path: PathBuf,
    travel: bool,
    min_len: f32,
) -> PyResult<(usize, Py<PyDict>)> {
    let options = ToolpathOptions { travel, min_len_mm: min_len, ..ToolpathOptions::default() };
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

#[pymodule]
fn _gweave(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(stats_json, m)?)?;
    m.add_function(wrap_pyfunction!(check_json, m)?)?;
    m.add_function(wrap_pyfunction!(cat, m)?)?;
    m.add_function(wrap_pyfunction!(run_cli, m)?)?;
    m.add_class::<Line>()?;
    m.add_class::<Reader>()?;

    m.add_function(wrap_pyfunction!(preview_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(toolpath_columns, m)?)?;
    Ok(())
}
