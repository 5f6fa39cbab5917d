//! The gweave virtual printer: a Marlin-like (or Klipper-like) board on a simulated clock, laid
//! out as firmware is, one folder per subsystem.
//!
//! - [`Machine`] (`interp/`) executes one command at a time, dispatched through the command
//!   registry ([`COMMANDS`]), and keeps the [`SimReport`] of a run;
//! - `motion/`: kinematics, limits ([`MotionProfile`]), the lookahead [`Planner`] (Marlin's
//!   `planner.cpp` or Klipper's `toolhead.py`), the [`Steppers`] and the print-time estimator
//!   ([`estimate`], [`Estimator`]);
//! - `thermal/`: heater plants, thermistors, control, protection and autotune behind
//!   [`Thermal`] (Marlin's `temperature.cpp`);
//! - `link/`: the host protocol ([`Protocol`]) and the endpoints [`serve`] runs it on
//!   ([`PtyEndpoint`], [`TcpEndpoint`]);
//! - `inkjet/`: the drops of a printhead ([`InkjetCanvas`]) and the recoats of a binder-jet bed;
//! - `profile/`: the [`MachineProfile`] TOML and its `[firmware]` build options;
//! - `core_board.rs`: `[firmware] kind = "gweave"`, the board running gweave's own controller
//!   core (the firmware of the real board) instead of the Marlin model ([`run_on_core`],
//!   [`CoreDevice`], [`CoreReport`]);
//! - [`simulate`] (`job.rs`): a whole file through the one or the other, for every front end;
//! - [`reading`]: the jobs `gweave sim` and `gweave estimate`, each with its options declared
//!   once, as both front ends run them ([`transform`]: the transform jobs);
//! - `finish/`: what a front end does around a transform's output ([`with_metadata`]); `plot.rs`:
//!   the charts ([`speed_chart`]).
//!
//! ```
//! use gweave_sim::{Machine, MachineProfile, Outcome};
//!
//! let mut m = Machine::new(MachineProfile::default()).unwrap();
//! let mut replies = Vec::new();
//! assert_eq!(m.execute(b"M114", &mut |_t, l| replies.push(l.to_owned())), Outcome::Ok);
//! assert_eq!(replies, ["X:0.00 Y:0.00 Z:0.00 E:0.00 Count X:0 Y:0 Z:0"]);
//! ```
#![warn(missing_docs)]
#![warn(unreachable_pub)]

mod chart_canvas;
mod core_board;
mod finish;
mod inkjet;
mod interp;
mod job;
mod link;
mod motion;
mod plot;
mod profile;
pub mod raster_job;
pub mod reading;
#[cfg(any(test, feature = "test-support"))]
pub mod test_support;
mod thermal;
pub mod transform;

pub use core_board::{run_on_core, CoreBoardError, CoreDevice, CoreReport, Unsupported};
pub use finish::{with_metadata, FinishError};
pub use inkjet::{
    CanvasGeometry, InkjetCanvas, InkjetError, InkjetLayer, InkjetWarning, LayerSink, CANVAS_BUDGET_BYTES,
};
pub use interp::commands::{RegistryRanges, REGISTRY_RANGES};
pub use interp::{
    help_lines, CommandSpec, HeaterStats, InkjetSummary, Machine, Outcome, Param, Queue, SimError, SimReport,
    SimTimes, SimWarning, WarningKind, COMMANDS, STOPPED_LINE, UNKNOWN_KINDS, UNKNOWN_OTHERS,
};
pub use job::{simulate, SimJobError, SimSetup, Simulation, MAX_FILE_RUN_S};
pub use link::early::EarlyLines;
pub use link::pty::PtyEndpoint;
pub use link::serial::{frame_line, Device, Protocol, ProtocolConfig, DEFAULT_KEEPALIVE_S};
pub use link::tcp::TcpEndpoint;
pub use link::transport::{serve, Endpoint, Event as EndpointEvent, ServeOptions, ServeSummary};
pub use motion::estimate::{
    estimate, estimate_file, estimate_report, estimate_time, Estimate, EstimateError, EstimateFileError,
    EstimateReport, Estimator, HugeArcs, Malformed, Refused, ToolChange, MAX_ARC_CHORDS,
};
pub use motion::kinematics::{Move, Pos};
pub use motion::limits::{
    AxisLimits, CornerMode, Jerk, KlipperLimits, MotionProfile, MoveAccel, StepsPerUnit,
};
pub use motion::marlin_limits::{ExtruderLimits, MarlinCorners};
pub use motion::planner::{PlannedBlock, Planner, PositionSet};
pub use motion::slicer_limits::slicer_limits;
pub use motion::stepper::{BresenhamWalk, Steppers};
pub use plot::{speed_chart, temperature_chart, ChartFormat, PlotError, SpeedAxes};
pub use profile::build_options::{BuildOptions, BuildOptionsError, Feature, FirmwareKind, ProgramStop};
pub use profile::builtin;
pub use profile::m503::from_m503;
pub use profile::{FaultSpec, Inkjet, MachineProfile, MachineProfileError};
pub use thermal::autotune::{run_on_heater, AutotuneConfig, AutotuneRun, Cycle};
pub use thermal::control::PidGains;
pub use thermal::heater::{Heater, HeaterConfig, HeaterFault, HeaterId};
pub use thermal::protection::{FaultKind, ThermalFault, KILL_LINE};
pub use thermal::thermistor::{BetaThermistor, SensorFault};
pub use thermal::{Thermal, ThermalConfig, ThermalError, WaitMode, WaitStatus, COLD_EXTRUSION_LINE};
