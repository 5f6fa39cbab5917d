//! The estimate of a whole file as `gweave estimate` and Python's `gweave.estimate` give it.

use std::io::{self, Read};
use std::path::{Path, PathBuf};

use gweave::gcode::container;
use gweave::gcode::diag::Finding;
use gweave::gcode::ends::{missing_footer, read_ends};
use gweave::gcode::flavour::read_firmware;
use gweave::rotary::cylinder::RotaryConfig;
use gweave::{Firmware, Progress};
use serde::Serialize;

use super::{estimate_on, Estimate, EstimateError, Estimator};
use crate::motion::limits::CornerMode;
use crate::profile::MachineProfile;

/// The machine and planner an estimate was made with, then the estimate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateReport {
    /// The machine profile's name.
    pub machine: String,
    /// `klipper`, `marlin` or `constant`.
    pub planner: &'static str,
    /// Whether the steps were counted (otherwise all zero).
    pub steps_counted: bool,
    /// The estimate itself.
    #[serde(flatten)]
    pub estimate: Estimate,
    /// What the file does that is worth a look (a file cut short), as `gweave stats` says it;
    /// left out of the JSON when there is none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// Estimate the file read from `input` on `machine`, its lines read as `firmware` reads them (the
/// file's: [`gweave::gcode::flavour::read_firmware`]), counting steps if asked; on a machine
/// with a printhead, with the wait after each fire; a rotary program's F words as its header
/// declares them, as `gweave sim` reads them (without the header, as the firmware model does);
/// each tool change waiting for the queued moves as the machine's firmware makes it wait.
pub fn estimate_report<R: Read + Send>(
    input: R,
    machine: &MachineProfile,
    firmware: Firmware,
    count_steps: bool,
) -> Result<EstimateReport, EstimateError> {
    let mut estimator = Estimator::for_machine(machine, count_steps)?;
    estimator.read_as(firmware);
    let (rotary, input) = RotaryConfig::from_stream_head(input)?;
    if let Some(rotary) = rotary {
        estimator.declare_rotary(rotary);
    }
    let estimate = estimate_on(input, estimator)?;
    let planner = match machine.motion.corners {
        CornerMode::Klipper(_) => "klipper",
        CornerMode::Marlin { .. } => "marlin",
        CornerMode::Constant {} => "constant",
    };
    Ok(EstimateReport {
        machine: machine.name.clone(),
        planner,
        steps_counted: count_steps,
        estimate,
        warnings: Vec::new(),
    })
}

/// Why a file could not be estimated, naming the file and, when there is one, its line.
#[derive(Debug, thiserror::Error)]
pub enum EstimateFileError {
    /// The file could not be opened, or its flavour read.
    #[error("reading {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// A line the estimator refused, or a read error midway.
    #[error("{}: {}", place(path, error.line()), error.reason())]
    Estimate {
        /// The file.
        path: PathBuf,
        /// What the estimator said.
        error: EstimateError,
    },
}

/// `path:line` for a line of the file, `path` alone for the profile (line 0) or the file as a
/// whole.
fn place(path: &Path, line: Option<u64>) -> String {
    match line {
        Some(line) if line > 0 => format!("{}:{line}", path.display()),
        _ => path.display().to_string(),
    }
}

/// The estimate of the file at `path` on `machine`, as `gweave estimate` and `gweave.estimate()`
/// both make it: read as the firmware its flavour names, `progress` told of the bytes read.
pub fn estimate_file(
    path: &Path,
    machine: &MachineProfile,
    count_steps: bool,
    mut progress: impl Progress + Send,
) -> Result<EstimateReport, EstimateFileError> {
    let read_error = |source| EstimateFileError::Read { path: path.to_owned(), source };
    let firmware = read_firmware(path, None).map_err(read_error)?;
    let file = container::open(path).map_err(read_error)?;
    progress.set_len(file.text_len.unwrap_or(0));
    let mut last_byte = b'\n';
    let input = Counted { inner: file, progress, done: 0, last_byte: &mut last_byte };
    let mut report = estimate_report(input, machine, firmware, count_steps)
        .map_err(|error| EstimateFileError::Estimate { path: path.to_owned(), error })?;
    // A file cut short is timed to its cut, as a printer would run it: said, in `check`'s
    // words. Its ends are read (again) only when its text ends without a line ending.
    let unended = !matches!(last_byte, b'\n' | b'\r');
    if let Some(footer) = unended.then(|| read_ends(path).ok().and_then(|e| missing_footer(&e))).flatten() {
        report.warnings.push(Finding::NoFooter { footer }.to_string());
    }
    Ok(report)
}

/// The input file, telling `progress` how much of it is read, and keeping the last byte read.
struct Counted<'a, P> {
    inner: container::Input,
    progress: P,
    done: u64,
    last_byte: &'a mut u8,
}

impl<P: Progress> Read for Counted<'_, P> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.done += n as u64;
        self.progress.advance(self.done);
        if let Some(&b) = buf[..n].last() {
            *self.last_byte = b;
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gweave::Quiet;

    /// Regression: `check` and `sim` said a file cut short looks truncated; `estimate` timed it
    /// to the cut without a word (a shorter print, silently). It now says so, in `check`'s
    /// words, and times what is there; the whole file gets no such word, and no `warnings` key
    /// in its JSON.
    #[test]
    fn a_file_cut_short_is_said_truncated_by_estimate() {
        let dir = tempfile::tempdir().unwrap();
        let (fixture, path, _) = crate::test_support::cone_cut_short(dir.path());
        let machine = MachineProfile::default();
        let part = estimate_file(&path, &machine, false, Quiet).unwrap();
        assert_eq!(part.warnings.len(), 1, "{:?}", part.warnings);
        assert!(part.warnings[0].starts_with("the file looks truncated: its last line has no line ending"));
        let whole = estimate_file(&fixture, &machine, false, Quiet).unwrap();
        assert_eq!(whole.warnings, Vec::<String>::new());
        assert!(part.estimate.total_s < whole.estimate.total_s);
        assert!(!serde_json::to_string(&whole).unwrap().contains("\"warnings\""));
    }
}
