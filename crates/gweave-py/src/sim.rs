//! The virtual printer (`gweave sim`, `gweave estimate`, `gweave.Machine`).

use crate::interrupt::interruptible;
use std::path::PathBuf;

use gweave_sim::reading::{self, EstimateOptions, SimOptions};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::args::os_error;
use crate::options::failed;
use crate::to_json;

// --- gweave-sim: the virtual printer ---

/// `machine=`: a profile file or a built-in profile's name (`gweave machine list`), loaded as
/// `--machine` is (`gweave_sim::builtin::load_machine`); an unreadable file is the `OSError` for
/// its errno.
pub(crate) fn machine_profile(machine: Option<PathBuf>) -> PyResult<gweave_sim::MachineProfile> {
    use gweave_sim::builtin::{load_machine, LoadError};
    load_machine(machine.as_deref()).map_err(|e| match &e {
        LoadError::Read { path, source } => os_error(path, source),
        LoadError::Profile { .. } | LoadError::SlicerLimits => PyValueError::new_err(e.to_string()),
    })
}

fn sim_err(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Runs a file through the virtual printer; the report as JSON text (see `gweave sim --json`).
/// The keyword arguments are the options of `gweave.sim` (`machine`, `fault`, `plot`, ...), by
/// the names the engine declares.
#[pyfunction]
#[pyo3(signature = (path, **options))]
pub(crate) fn sim_json(
    py: Python<'_>,
    path: PathBuf,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let options: SimOptions = crate::options::read("sim", options)?;
    interruptible(py, || {
        let simulation = reading::sim(&options, &path, &mut gweave::Quiet).map_err(failed)?;
        // The report `gweave sim --json` prints: the Marlin model's, or the controller core's.
        match simulation {
            gweave_sim::Simulation::Marlin { report, .. } => to_json(&report),
            gweave_sim::Simulation::Core(report) => to_json(&report),
        }
    })?
}

/// Estimates a file's print time with the virtual printer's planner alone, on two threads; the
/// report as JSON text (see `gweave estimate --json`). The keyword arguments are the options of
/// `gweave.estimate` (`machine`, `steps`).
#[pyfunction]
#[pyo3(signature = (path, **options))]
pub(crate) fn estimate_json(
    py: Python<'_>,
    path: PathBuf,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let options: EstimateOptions = crate::options::read("estimate", options)?;
    let estimated = interruptible(py, || reading::estimate(&options, &path, gweave::Quiet).map_err(failed))??;
    to_json(&estimated.report)
}

/// A virtual printer to drive one command at a time, as a host would over a serial line.
/// (Unsendable: it stays on the thread that made it; the controllers are not `Sync`.)
#[pyclass(module = "gweave", unsendable)]
pub(crate) struct Machine {
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
