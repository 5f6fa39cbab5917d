//! A job's keyword arguments read as its options type ([`gweave::options`]): each keyword by the
//! option's declared name, checked as the CLI checks its flag, a refusal naming the keyword.
//! `gweave/__init__.py` declares the typed keywords; `tests/test_options.py` holds them to
//! [`job_options`].

use gweave::options::{Kind, Spelling, Value};
use gweave::{JobFailure, JobOptions};
use pyo3::exceptions::{PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};

/// The options `T` from the keyword arguments of `function`: a keyword that is no option is a
/// `TypeError` as Python raises it, a value out of range or unreadable a `ValueError` naming it.
/// `None` leaves an option at its default.
pub fn read<T: JobOptions>(function: &str, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<T> {
    let mut options = T::default();
    for (key, value) in kwargs.map(|k| k.iter().collect::<Vec<_>>()).unwrap_or_default() {
        let name: String = key.extract()?;
        let Some(spec) = T::spec(&name) else {
            return Err(PyTypeError::new_err(format!(
                "{function}() got an unexpected keyword argument '{name}'"
            )));
        };
        if value.is_none() {
            continue;
        }
        let typed = |e: PyErr| PyTypeError::new_err(format!("{name}: {e}"));
        let value = match spec.kind {
            Kind::Flag => Value::Flag(value.extract().map_err(typed)?),
            Kind::Number => Value::Number(value.extract().map_err(typed)?),
            // An int, as Python types a count; a float (or a numeric string) is no layer.
            Kind::Whole => Value::Number(value.extract::<i64>().map_err(typed)? as f64),
            Kind::Text => Value::Text(value.extract().map_err(typed)?),
            Kind::Path => Value::Path(value.extract().map_err(typed)?),
            // A list as the CLI writes it (`"X,A,Z"`, `"XAZ"`, `"10,20"`) is read by the
            // engine's own parser, the flag's, so both front ends take the same spellings.
            Kind::Texts(_) | Kind::Numbers(_) if value.is_instance_of::<PyString>() => spec
                .parse(&value.extract::<String>()?)
                .map_err(|e| PyValueError::new_err(e.spelled(Spelling::Keyword)))?,
            Kind::Repeated | Kind::Texts(_) => Value::Texts(value.extract().map_err(typed)?),
            Kind::Numbers(_) => Value::Numbers(value.extract().map_err(typed)?),
        };
        options.set(spec, value).map_err(|e| PyValueError::new_err(e.spelled(Spelling::Keyword)))?;
    }
    options.check_conflicts().map_err(|e| PyValueError::new_err(e.spelled(Spelling::Keyword)))?;
    Ok(options)
}

/// A job's failure as Python raises it, for every job: a file the system refused as the
/// `OSError` for its errno (as [`crate::err`]), another refusal of the system (a write) an
/// `OSError`, the rest a `ValueError` with the options it names spelled as keywords; the text
/// is the message and the causes it does not say, `: `-separated.
pub fn failed<E: JobFailure>(e: E) -> PyErr {
    if let Some((path, source)) = e.refused_file() {
        return crate::args::os_error(path, source);
    }
    let text = e.said(Spelling::Keyword);
    if e.io_failed() {
        PyOSError::new_err(text)
    } else {
        PyValueError::new_err(text)
    }
}

/// The commands of every job (`purge-shift`, `mix`, `rotary wrap`, `rotary tube`, `sim`,
/// `estimate`, `preview`, `raster`: `gweave_sim::transform::jobs`), for the tests that hold the
/// typed wrappers to them.
#[pyfunction]
pub(crate) fn jobs() -> Vec<&'static str> {
    gweave_sim::transform::jobs().into_iter().map(|(command, _)| command).collect()
}

/// The options of the job `command` (one of [`jobs`]) as declared: a list of dicts `{"name",
/// "flag", "kind", "count", "default", "range", "help"}`, for the tests that hold the typed
/// wrappers to the declaration (and for documentation).
#[pyfunction]
pub(crate) fn job_options<'py>(py: Python<'py>, command: &str) -> PyResult<Bound<'py, PyList>> {
    let all = gweave_sim::transform::jobs();
    let Some((_, specs)) = all.iter().find(|(name, _)| *name == command) else {
        let known: Vec<&str> = all.iter().map(|(name, _)| *name).collect();
        return Err(PyValueError::new_err(format!("no job {command:?} ({})", known.join(", "))));
    };
    let list = PyList::empty(py);
    for spec in *specs {
        let d = PyDict::new(py);
        d.set_item("name", spec.name)?;
        d.set_item("flag", format!("--{}", spec.flag()))?;
        let kind = match spec.kind {
            Kind::Flag => "flag",
            Kind::Number => "number",
            Kind::Whole => "whole",
            Kind::Text => "text",
            Kind::Path => "path",
            Kind::Repeated => "repeated",
            Kind::Texts(_) => "texts",
            Kind::Numbers(_) => "numbers",
        };
        d.set_item("kind", kind)?;
        let count = match spec.kind {
            Kind::Texts(n) | Kind::Numbers(n) if n > 0 => Some(n),
            _ => None,
        };
        d.set_item("count", count)?;
        d.set_item("default", (spec.default)())?;
        d.set_item("range", spec.shape.range.map(|r| (r.min, r.max)))?;
        d.set_item("help", spec.help())?;
        list.append(d)?;
    }
    Ok(list)
}
