//! What a run of the virtual printer reports: times, filament, steps, heaters, warnings.

use std::collections::BTreeMap;

use gweave::gcode::layers::Feature;
use gweave::gcode::retraction::Retraction;
use serde::Serialize;

use super::{heat, Machine};
use crate::inkjet::InkjetWarning;
use crate::motion::estimate::{HugeArcs, Malformed};
use crate::motion::stepper::StepTotals;
use crate::thermal::heater::HeaterId;
use crate::thermal::protection::ThermalFault;

/// Where the simulated time went, s. `total_s` is the sum of the others.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SimTimes {
    /// Everything.
    pub total_s: f64,
    /// Planned moves (what `gweave estimate` computes as motion).
    pub motion_s: f64,
    /// `G4` dwells.
    pub dwell_s: f64,
    /// `M109`/`M190` waits and `M303` autotunes.
    pub heating_s: f64,
    /// `G28`, `G29` probing, `M600` parking and filament moves.
    pub homing_s: f64,
    /// Firmware bookkeeping of Klipper mode (start buffer, motor-off stalls, exit flush).
    pub overhead_s: f64,
    /// Waiting for the host: time `gweave serve` let pass while the line was silent (0 in a run
    /// of a file).
    pub idle_s: f64,
}

/// One heater at the end of the run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeaterStats {
    /// Which heater.
    pub heater: HeaterId,
    /// Reading at the end, C.
    pub temp_c: f64,
    /// Target at the end, C.
    pub target_c: f64,
    /// Highest recorded reading, C.
    pub max_c: f64,
    /// Mean duty over the run, 0..=1.
    pub mean_duty: f64,
    /// Electrical energy, Wh (mean duty x power x time).
    pub energy_wh: f64,
}

/// The inkjet canvases.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InkjetSummary {
    /// Layers with at least one fire.
    pub layers: usize,
    /// Drops fired per head.
    pub drops_per_head: Vec<u64>,
}

/// Something the file asked for that a real printer would refuse or do wrongly.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum WarningKind {
    /// A move ends outside the build volume on this axis.
    OutOfBounds {
        /// `X`, `Y` or `Z`.
        axis: char,
        /// Where it ends (machine coordinates), mm.
        value_mm: f64,
        /// The axis range, mm.
        min_mm: f64,
        /// See `min_mm`.
        max_mm: f64,
    },
    /// A move ends below the bed surface.
    BelowBed {
        /// Where it ends (machine coordinates), mm.
        z_mm: f64,
    },
    /// An extrusion refused because the hotend was too cold.
    ColdExtrusion {
        /// Which hotend.
        hotend: u8,
        /// Its reading, C.
        temp_c: f64,
        /// The minimum, C.
        min_c: f64,
    },
    /// A move that would feed more filament than `EXTRUDE_MAXLENGTH` ran without its E part
    /// (`PREVENT_LENGTHY_EXTRUDE`, the `[firmware]` table's `extrude_max_mm`).
    LongExtrusion {
        /// What the move asked to feed, mm (the flow factor applied).
        fed_mm: f64,
        /// The limit, mm.
        max_mm: f64,
    },
    /// A `G2`/`G3` the firmware refuses (`Error:G2/G3 bad parameters`): the machine did not
    /// move ([`gweave::gcode::arc`]).
    ArcRefused {
        /// Why.
        refusal: gweave::gcode::arc::ArcRefusal,
    },
    /// A command the machine does not know.
    UnknownCommand {
        /// The command as written (without comment).
        command: String,
    },
    /// `T<n>` or `M104 T<n>` for a tool or hotend that does not exist.
    InvalidExtruder {
        /// The tool number.
        tool: u32,
    },
    /// A command refused with a reason (a bad mixing or limit value, a heater command while
    /// halted).
    Refused {
        /// The reason.
        message: String,
    },
    /// A thermal protection fault.
    Thermal {
        /// Marlin's `Error:` line.
        message: String,
    },
    /// A heating wait that never ended.
    WaitTimeout {
        /// Which heater.
        heater: HeaterId,
    },
    /// A questionable inkjet fire.
    Inkjet {
        /// What was wrong.
        detail: InkjetWarning,
    },
    /// The clock passed the run's limit ([`Machine::limit_clock`]): the machine stopped there.
    ClockLimit {
        /// The limit, s.
        limit_s: f64,
    },
    /// A fault asked for (`--fault`, the profile's `faults`) at a time the run never reached.
    FaultNotInjected {
        /// The fault as it was asked for (`hotend-cartridge-off@4000s`).
        fault: String,
        /// When the run ended, s.
        end_s: f64,
    },
    /// The file looks cut short: its last line has no line ending and the line its slicer ends
    /// every file with is missing (`gweave check`'s warning, on the last line): a printer runs
    /// it to that line and stops with part of the object printed.
    Truncated {
        /// The slicer whose last line is missing.
        footer: gweave::gcode::ends::Footer,
    },
}

impl WarningKind {
    /// The snake-case name used in reports.
    pub fn name(&self) -> &'static str {
        match self {
            WarningKind::OutOfBounds { .. } => "out_of_bounds",
            WarningKind::BelowBed { .. } => "below_bed",
            WarningKind::ColdExtrusion { .. } => "cold_extrusion",
            WarningKind::LongExtrusion { .. } => "long_extrusion",
            WarningKind::ArcRefused { .. } => "arc_refused",
            WarningKind::UnknownCommand { .. } => "unknown_command",
            WarningKind::InvalidExtruder { .. } => "invalid_extruder",
            WarningKind::Refused { .. } => "refused",
            WarningKind::Thermal { .. } => "thermal",
            WarningKind::WaitTimeout { .. } => "wait_timeout",
            WarningKind::Inkjet { .. } => "inkjet",
            WarningKind::ClockLimit { .. } => "time_limit",
            WarningKind::FaultNotInjected { .. } => "fault_not_injected",
            WarningKind::Truncated { .. } => "truncated",
        }
    }
}

/// A warning with the line that caused it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimWarning {
    /// 1-based number of the line executed.
    pub line: u64,
    /// Simulated time, s.
    pub t_s: f64,
    /// What happened.
    #[serde(flatten)]
    pub kind: WarningKind,
}

/// Everything a run reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimReport {
    /// The machine profile's name.
    pub machine: String,
    /// Lines executed.
    pub lines: u64,
    /// Where the time went.
    pub time: SimTimes,
    /// Planned blocks.
    pub blocks: u64,
    /// Motion and dwell before the first layer, s.
    pub unlayered_s: f64,
    /// Motion and dwell per layer (0-based), s.
    pub layer_s: Vec<f64>,
    /// Motion and dwell per feature, s.
    pub feature_s: BTreeMap<Feature, f64>,
    /// Filament fed per tool (net, after flow and refused cold extrusions), mm.
    pub filament_mm: Vec<f64>,
    /// Filament per tool still retracted at the end (pulled back and not pushed out again:
    /// Cura's end retraction, a tool parked retracted after its last change), mm. Added to
    /// `filament_mm` it is what left the nozzle, `gweave stats`'s figure and the slicer's.
    pub retracted_at_end_mm: Vec<f64>,
    /// Filament fed per mixing input (net, from its motor), mm.
    pub mixing_input_mm: Vec<f64>,
    /// Steps per motor (both directions count).
    pub steps: StepTotals,
    /// Logical position X Y Z E A at the end (`M114`), mm / degrees.
    pub position: [f64; 5],
    /// Motor positions X Y Z E A at the end (`M114 Count`), steps.
    pub count: [i64; 5],
    /// The heaters.
    pub heaters: Vec<HeaterStats>,
    /// Thermal faults, in order.
    pub thermal_faults: Vec<ThermalFault>,
    /// The machine ended halted (a fault or `M112`).
    pub halted: bool,
    /// Unknown commands and how often each came.
    pub unknown_commands: BTreeMap<String, u64>,
    /// Warnings by kind, all of them counted.
    pub warning_counts: BTreeMap<String, u64>,
    /// The first warnings in detail (at most 1000).
    pub warnings: Vec<SimWarning>,
    /// The inkjet canvases, on a machine with a printhead.
    pub inkjet: Option<InkjetSummary>,
    /// Lines skipped because they could not be read.
    #[serde(flatten)]
    pub malformed: Malformed,
    /// Arcs too long to cut into chords of 1 mm.
    #[serde(flatten)]
    pub huge_arcs: HugeArcs,
}

impl SimReport {
    /// The inkjet warnings among the first warnings kept ([`SimReport::warnings`]), in order.
    pub fn inkjet_warnings(&self) -> impl Iterator<Item = &InkjetWarning> {
        self.warnings.iter().filter_map(|w| match &w.kind {
            WarningKind::Inkjet { detail } => Some(detail),
            _ => None,
        })
    }
}

impl Machine {
    /// What the run so far did. Moves still queued in the planner are not counted yet; call
    /// [`Machine::finish`] at the end of a job first.
    pub fn report(&self) -> SimReport {
        let est = self.core.summary();
        let steps = &self.profile.motion.steps;
        let mixing_input_mm = self
            .core
            .steppers()
            .mix_position_steps()
            .zip(&steps.mixing_e)
            .map(|(n, spu)| n as f64 / spu)
            .collect();
        let ids: Vec<HeaterId> = (0..self.thermal.hotend_count())
            .map(HeaterId::Hotend)
            .chain(self.profile.thermal.bed.map(|_| HeaterId::Bed))
            .collect();
        SimReport {
            machine: self.profile.name.clone(),
            lines: self.core.line_number(),
            time: SimTimes {
                total_s: est.total_s,
                motion_s: est.motion_s,
                dwell_s: est.dwell_s,
                heating_s: self.heating_s,
                homing_s: self.homing_s,
                overhead_s: est.overhead_s,
                idle_s: self.idle_s,
            },
            blocks: est.blocks,
            unlayered_s: est.unlayered_s,
            layer_s: est.layer_s,
            feature_s: est.feature_s,
            filament_mm: self.filament_mm.clone(),
            retracted_at_end_mm: self.retraction.iter().map(Retraction::in_force_mm).collect(),
            mixing_input_mm,
            steps: est.steps,
            position: self.position(),
            count: self.core.steppers().position_steps(),
            heaters: heat::heater_stats(&self.thermal, &ids),
            thermal_faults: self.thermal_faults.clone(),
            halted: self.halt.is_some(),
            unknown_commands: self.unknown.clone(),
            warning_counts: self.warning_counts.iter().map(|(k, v)| ((*k).to_owned(), *v)).collect(),
            warnings: self.warnings.clone(),
            inkjet: self.inkjet.as_ref().map(|c| InkjetSummary {
                layers: c.layer_count(),
                drops_per_head: c.drops_per_head().to_vec(),
            }),
            malformed: est.malformed,
            huge_arcs: est.huge_arcs,
        }
    }
}
