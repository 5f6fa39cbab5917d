//! Reading G-code: statistics, the lint report, the lossless copy, and the line-by-line
//! reader (`gweave.Reader`, `gweave.Line`).

use crate::interrupt::interruptible;
use std::path::PathBuf;

use gweave::gcode::container::{self};
use gweave::gcode::diag::Diagnostic;
use gweave::gcode::flavour::read_flavour;
use gweave::gcode::lexer::{parse_into, parse_line};
use gweave::gcode::reader::Part;
use gweave::gcode::state::{E, X, Y, Z};
use gweave::{
    check_file_with, stats_file, Block, CheckOptions, Command, Effect, Finding, Identity, Input, LineReader,
    Quiet, Run, State, StateOptions, Value,
};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::args::target_of;
use crate::args::{in_range, os_error, BedArg};
use crate::{err, strictness, to_json};

/// Statistics of a G-code file as JSON text (see `gweave stats --json`).
#[pyfunction]
#[pyo3(signature = (path, *, filament_diameter=None, lenient=false))]
pub(crate) fn stats_json(
    py: Python<'_>,
    path: PathBuf,
    filament_diameter: Option<f64>,
    lenient: bool,
) -> PyResult<String> {
    let diameter = in_range("filament_diameter", filament_diameter, gweave::range::FILAMENT_DIAMETER_MM)?;
    let stats = interruptible(py, || stats_file(&path, diameter, strictness(lenient), &mut Quiet))?;
    to_json(&stats.map_err(err)?)
}

/// Lint report of a G-code file as JSON text (see `gweave check --json`). Without `bed`, the
/// bed the slicer's settings in the file give; `failed` is whether the file fails the check (an
/// error, or with `strict` a warning: `gweave check`'s exit code 1).
#[pyfunction]
#[pyo3(signature = (path, *, bed=None, machine=None, max_feed=None, klipper_max_extrude_cross_section=None, strict=false))]
pub(crate) fn check_json(
    py: Python<'_>,
    path: PathBuf,
    bed: Option<BedArg>,
    machine: Option<PathBuf>,
    max_feed: Option<f64>,
    klipper_max_extrude_cross_section: Option<f64>,
    strict: bool,
) -> PyResult<String> {
    let mut options = match (bed, machine) {
        (Some(_), Some(_)) => return Err(PyValueError::new_err("give bed or machine, not both")),
        (None, Some(m)) => crate::sim::machine_profile(Some(m))?
            .check_options(CheckOptions::default())
            .map_err(|e| PyValueError::new_err(format!("machine: {e}")))?,
        (bed, None) => CheckOptions { bed: bed.map(BedArg::bed).transpose()?, ..CheckOptions::default() },
    };
    if let Some(f) = in_range("max_feed", max_feed, gweave::range::FEED_MM_MIN)? {
        options.max_feed_mm_min = f;
    }
    let cross_section = gweave::range::CROSS_SECTION_MM2;
    if let Some(mm2) =
        in_range("klipper_max_extrude_cross_section", klipper_max_extrude_cross_section, cross_section)?
    {
        options.klipper.max_extrude_cross_section_mm2 = mm2;
    }
    let report = interruptible(py, || {
        check_file_with(&path, options, Some(&gweave_sim::REGISTRY_RANGES), &mut Quiet)
    })?
    .map_err(err)?;
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
pub(crate) fn cat_json(
    py: Python<'_>,
    path: PathBuf,
    output: Option<PathBuf>,
    in_place: bool,
    backup: bool,
    force: bool,
    lenient: bool,
) -> PyResult<String> {
    let target = target_of(output, in_place, backup, force)?;
    let report = interruptible(py, || {
        let mut copy = Identity::default();
        let run = Run::file(&path).strictness(strictness(lenient)).to(&target);
        run.run(&mut copy).map(|_| copy.report)
    })?;
    to_json(&report.map_err(err)?)
}

/// One line of a file, with what it says and the machine state after it.
#[pyclass(frozen, get_all, module = "gweave")]
pub(crate) struct Line {
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
pub(crate) struct Reader {
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
        let state = State::new(StateOptions::default().resolved(None, flavour.as_deref()));
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
