//! The estimate of a whole file as `gweave estimate` and Python's `gweave.estimate` give it.

use std::io::Read;

use gweave::firmware::Firmware;
use serde::Serialize;

use super::{estimate_as, Estimate, EstimateError};
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
}

/// Estimate the file read from `input` on `machine`, its lines read as `firmware` reads them (the
/// file's: [`gweave::gcode::flavour::read_firmware`]), counting steps if asked.
pub fn estimate_report<R: Read + Send>(
    input: R,
    machine: &MachineProfile,
    firmware: Firmware,
    count_steps: bool,
) -> Result<EstimateReport, EstimateError> {
    let estimate = estimate_as(input, &machine.motion, firmware, count_steps)?;
    let planner = match machine.motion.corners {
        CornerMode::Klipper(_) => "klipper",
        CornerMode::Marlin { .. } => "marlin",
        CornerMode::Constant {} => "constant",
    };
    Ok(EstimateReport { machine: machine.name.clone(), planner, steps_counted: count_steps, estimate })
}
