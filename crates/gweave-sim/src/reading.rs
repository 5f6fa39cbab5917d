//! The reading jobs, `gweave sim` and `gweave estimate` as both front ends run them (`gweave
//! preview`'s is the engine's own, [`gweave::render::job`])
//! (`gweave.sim()`, `gweave.estimate()`): each takes one options type declared once
//! ([`gweave::options`]) and is one function here, so the command line and Python load the
//! machine, read the file and refuse an option alike. They had drifted: `estimate
//! --machine slicer` planned with the limits the slicer wrote into the file while
//! `gweave.estimate(machine="slicer")` looked for a profile called `slicer`; `sim --plot` drew
//! charts Python could not ask for.
//!
//! Neither writes G-code, so neither writes a run header; what they write besides their report
//! (the charts, the inkjet canvases) is named by options, checked before the run. The inkjet
//! canvases are written during the run, each layer once it is finished ([`SimSetup`]); the
//! charts after it.

use std::path::{Path, PathBuf};

use gweave::options::{Problem, Shape, Spelling};
use gweave::PreviewOptions;
use gweave::{JobFailure, JobOptions, OptionError, OptionSpec, Progress};

use crate::job::{simulate, SimJobError, SimSetup, Simulation};
use crate::motion::estimate::{estimate_file, EstimateFileError, EstimateReport};
use crate::motion::slicer_limits::{slicer_limits, SlicerLimitsError};
use crate::plot::{save_speed_chart, save_temperature_chart, ChartFormat, PlotError};
use crate::profile::build_options::FirmwareKind;
use crate::profile::builtin::{load_machine, LoadError};
use crate::profile::{FaultSpec, MachineProfile};

gweave::job_options! {
    /// What `gweave sim` is given besides its file: the machine, injected faults, and where
    /// to draw what the run did.
    pub struct SimOptions for "sim" {
        /// Machine profile: a TOML file (docs/machine.md) or a built-in profile's name
        /// (`gweave machine list`: prusa-mk3, klipper, ...); default: a RAMPS 1.4 printer on
        /// Marlin.
        machine: Option<PathBuf> = Shape::new("TOML|NAME"),
        /// Inject a heater fault, e.g. `hotend-cartridge-off@120s`, `bed-thermistor-open@30s`,
        /// `hotend1-thermistor-shorted@5s` (repeatable).
        fault: Vec<String> = Shape::new("SPEC"),
        /// Chart each heater's temperature and target over time into this PNG or SVG (by its
        /// extension).
        plot: Option<PathBuf> = Shape::new("PNG|SVG"),
        /// Chart the planned toolhead speed over time (mean and peak of each time slice), the
        /// time of each layer and, on a mixing machine, each input's filament into this PNG or
        /// SVG.
        plot_speed: Option<PathBuf> = Shape::new("PNG|SVG"),
        /// Write the inkjet canvases (one PNG per layer and head) into this directory.
        raster_out: Option<PathBuf> = Shape::new("DIR"),
    }
}

gweave::job_options! {
    /// What `gweave estimate` is given besides its file.
    pub struct EstimateOptions for "estimate" {
        /// Machine profile: a TOML file (docs/machine.md) or a built-in profile's name (`gweave
        /// machine list`); its motion limits are used, and a printhead's wait after each fire. Default: a RAMPS 1.4 printer on
        /// Marlin. `slicer`: the machine limits the slicer wrote into the file (PrusaSlicer,
        /// SuperSlicer, OrcaSlicer `machine_max_*`, Cura's `machine_max_*`); the settings used
        /// are listed on standard error.
        machine: Option<PathBuf> = Shape::new("TOML|NAME|slicer"),
        /// Also count the steps of every motor (Bresenham, as `gweave sim` does); up to a fifth
        /// slower.
        steps: bool = Shape::new(""),
    }
}

/// Every reading job's command and options (`preview`'s is the engine's,
/// [`gweave::render::job`]), part of [`crate::transform::jobs`].
pub const JOBS: &[(&str, &[OptionSpec])] = &[
    (SimOptions::COMMAND, SimOptions::SPEC),
    (EstimateOptions::COMMAND, EstimateOptions::SPEC),
    (PreviewOptions::COMMAND, PreviewOptions::SPEC),
];

/// Why a reading job failed.
#[derive(Debug, thiserror::Error)]
pub enum ReadingError {
    /// An option's value refused (a fault that is no fault, a chart that is no PNG or SVG).
    #[error(transparent)]
    Option(#[from] OptionError),
    /// The machine profile cannot be loaded.
    #[error(transparent)]
    Machine(#[from] LoadError),
    /// `machine` = `slicer`, and the file's own limits cannot be read or used.
    #[error("{}: machine slicer: {source}", path.display())]
    SlicerLimits {
        /// The G-code file.
        path: PathBuf,
        /// Why its limits cannot be used.
        source: SlicerLimitsError,
    },
    /// The file's ends cannot be read (for `machine` = `slicer`).
    #[error("reading {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The simulation could not run.
    #[error(transparent)]
    Sim(#[from] SimJobError),
    /// The estimate could not be made.
    #[error(transparent)]
    Estimate(#[from] EstimateFileError),
    /// A chart could not be drawn or written.
    #[error(transparent)]
    Chart(#[from] PlotError),
}

impl JobFailure for ReadingError {
    /// The message, an option named as `spelling` names it (`--plot`, `plot`).
    fn spelled(&self, spelling: Spelling) -> String {
        match self {
            ReadingError::Option(e) => e.spelled(spelling),
            ReadingError::SlicerLimits { path, source } => {
                format!("{}: {} slicer: {source}", path.display(), spelling.name("machine"))
            }
            ReadingError::Sim(e) => e.spelled(spelling),
            e => e.to_string(),
        }
    }

    fn refused_file(&self) -> Option<(&Path, &std::io::Error)> {
        match self {
            ReadingError::Machine(LoadError::Read { path, source })
            | ReadingError::Read { path, source }
            | ReadingError::Sim(SimJobError::Read { path, source })
            | ReadingError::Estimate(EstimateFileError::Read { path, source }) => Some((path, source)),
            _ => None,
        }
    }
}

/// What `machine` names: a profile file or a built-in profile's name, as both front ends read it.
fn machine(value: Option<&Path>) -> Result<MachineProfile, ReadingError> {
    Ok(load_machine(value)?)
}

/// Runs `input` through the virtual printer the options name, to its end, a halt or the
/// program's end, and draws the charts and canvases asked for; `progress` follows the bytes
/// read. A chart's format (its extension) and each fault are checked before the run, not
/// after it; on a profile that runs the controller core, the options only the Marlin model
/// answers (its heaters' faults, its speed trace, its charts and canvases) are refused.
pub fn sim(
    options: &SimOptions,
    input: &Path,
    progress: &mut dyn Progress,
) -> Result<Simulation, ReadingError> {
    let refuse = |option, problem| ReadingError::Option(OptionError { option, problem });
    let faults = options
        .fault
        .iter()
        .map(|spec| spec.parse::<FaultSpec>().map_err(|e| refuse("fault", Problem::Invalid(e.to_string()))))
        .collect::<Result<Vec<_>, _>>()?;
    for (option, path) in [("plot", &options.plot), ("plot_speed", &options.plot_speed)] {
        if let Some(path) = path {
            ChartFormat::from_path(path).map_err(|e| refuse(option, Problem::Invalid(e.to_string())))?;
        }
    }
    let profile = machine(options.machine.as_deref())?;
    if profile.firmware.kind == FirmwareKind::Gweave {
        let marlin_only = [
            ("fault", !faults.is_empty()),
            ("plot", options.plot.is_some()),
            ("plot_speed", options.plot_speed.is_some()),
            ("raster_out", options.raster_out.is_some()),
        ];
        if let Some((option, _)) = marlin_only.iter().find(|(_, given)| *given) {
            return Err(SimJobError::MarlinModelOnly { option }.into());
        }
    }
    let setup = SimSetup {
        faults,
        record_speed: options.plot_speed.is_some(),
        raster_out: options.raster_out.clone(),
    };
    let simulation = simulate(input, profile, &setup, progress)?;
    if let Simulation::Marlin { machine, report, .. } = &simulation {
        if let Some(path) = &options.plot {
            save_temperature_chart(machine.thermal().series(), path)?;
        }
        if let (Some(path), Some(trace)) = (&options.plot_speed, machine.speed_trace()) {
            save_speed_chart(trace, &report.layer_s, &report.mixing_input_mm, path)?;
        }
    }
    Ok(simulation)
}

/// An estimate and the machine it was made on.
#[derive(Debug, Clone)]
pub struct Estimated {
    /// The estimate.
    pub report: EstimateReport,
    /// With `machine` = `slicer`: the settings taken from the file (`key = value` as written),
    /// which a front end shows; the rest is the default machine's.
    pub slicer_settings: Option<Vec<String>>,
}

/// Estimates `input`'s print time on the machine the options name (`slicer`: the limits the
/// slicer wrote into the file, over the default machine), `progress` told of the bytes read.
pub fn estimate(
    options: &EstimateOptions,
    input: &Path,
    progress: impl Progress + Send,
) -> Result<Estimated, ReadingError> {
    let (profile, slicer_settings) = match options.machine.as_deref() {
        Some(word) if word.as_os_str() == "slicer" => {
            let (profile, used) = slicer_profile(input)?;
            (profile, Some(used))
        }
        // A file or a built-in profile's name, as `sim` reads it.
        other => (machine(other)?, None),
    };
    let report = estimate_file(input, &profile, options.steps, progress)?;
    Ok(Estimated { report, slicer_settings })
}

/// The default machine with the limits the slicer wrote into `input`, and the settings used.
fn slicer_profile(input: &Path) -> Result<(MachineProfile, Vec<String>), ReadingError> {
    let ends = gweave::gcode::ends::read_ends(input)
        .map_err(|source| ReadingError::Read { path: input.to_owned(), source })?;
    let base = MachineProfile::default();
    let limits = slicer_limits(&ends, &base.motion)
        .map_err(|source| ReadingError::SlicerLimits { path: input.to_owned(), source })?;
    let flavour = limits.flavour.as_deref().map(|f| format!(", flavour {f}")).unwrap_or_default();
    let name = format!("{}'s machine limits in the file{flavour}", limits.slicer);
    Ok((MachineProfile { name, motion: limits.profile, ..base }, limits.used))
}

#[cfg(test)]
mod tests {
    use super::*;
    use gweave::Quiet;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(name)
    }

    #[test]
    fn a_fault_that_is_no_fault_is_refused_before_the_run_naming_the_option() {
        let options = SimOptions { fault: vec!["hotend-melted@5s".into()], ..SimOptions::default() };
        let e = sim(&options, Path::new("/nowhere/job.gcode"), &mut Quiet).err().unwrap();
        assert!(e.spelled(Spelling::Flag).starts_with("--fault: "), "{e}");
        assert!(e.spelled(Spelling::Keyword).starts_with("fault: "), "{e}");
    }

    #[test]
    fn a_chart_that_is_no_png_or_svg_is_refused_before_the_run() {
        let options = SimOptions { plot_speed: Some("speed.jpg".into()), ..SimOptions::default() };
        let e = sim(&options, Path::new("/nowhere/job.gcode"), &mut Quiet).err().unwrap();
        assert_eq!(
            e.spelled(Spelling::Flag),
            r#"--plot-speed: a plot is written as PNG or SVG (by its extension), not "jpg""#
        );
    }

    #[test]
    fn machine_slicer_plans_with_the_files_own_limits() {
        let file = fixture("prusaslicer/pr_torus_pva.gcode");
        let options = EstimateOptions { machine: Some("slicer".into()), steps: false };
        let estimated = estimate(&options, &file, Quiet).unwrap();
        assert_eq!(estimated.report.machine, "PrusaSlicer's machine limits in the file, flavour marlin2");
        let used = estimated.slicer_settings.unwrap();
        assert!(used.iter().any(|s| s == "machine_max_acceleration_x = 9000"), "{used:?}");
        let cura = fixture("cura/cura_torus.gcode");
        let e = estimate(&options, &cura, Quiet).err().unwrap();
        assert!(
            e.spelled(Spelling::Flag).contains(": --machine slicer: the file holds no machine limits"),
            "{e}"
        );
        assert!(
            e.spelled(Spelling::Keyword).contains(": machine slicer: the file holds no machine limits"),
            "{e}"
        );
    }
}
