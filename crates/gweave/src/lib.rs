//! gweave: a lossless, streaming G-code engine for unconventional 3D printers.
//!
//! Every command is a [`Pass`] over a stream of lines: the [`gcode::lexer`] records what
//! each line says (with spans), the [`gcode::state`] tracks what the machine would do, and lines a
//! pass does not change are written back byte for byte.
//!
//! The crate root re-exports what the front ends use (see "The public surface" in
//! `docs/architecture.md`): [`Run`] and [`Pass`] to run a pass, [`LineReader`], [`Block`] and
//! [`State`] to read a file, each job's entry point ([`stats_file`], [`check_file`],
//! [`purge_shift`], [`mix`], [`wrap_file`], [`tube_file`], [`preview`]) with its options and
//! report, and [`Error`]. The runner, the pass machinery and the jobs live in private modules;
//! the public modules below are the vocabularies a front end reads by path, by machine concept.
//!
//! ```
//! use gweave::gcode::{lexer::parse_into, line::Block, state::{State, X}};
//! let mut block = Block::default();
//! let mut state = State::default();
//! for line in ["G90", "G1 X10 Y5 E0.4 F1800", "G1X12.5"] {
//!     parse_into(line.as_bytes(), &mut block);
//!     state.apply(line.as_bytes(), &block);
//! }
//! assert_eq!(state.pos[X], 12.5);
//! ```

#![warn(missing_docs)]
#![warn(unreachable_pub)]

mod bed;
mod check;
pub mod colour;
pub(crate) mod eol;
mod error;
pub(crate) mod firmware;
pub mod gcode;
pub mod gen;
mod interrupt;
mod klipper_extruder;
mod malformed;
pub mod options;
mod pass;
pub mod picture;
// purge-shift and other post-processing passes
pub mod post;
pub mod range;
pub mod render;
pub mod rotary;
mod rotary_job;
mod run;
pub mod settings;
mod stats;
#[cfg(any(test, feature = "test-support"))]
pub mod test_support;
mod total;

// The public surface: what the front ends (the CLI, the Python package, the simulator, the board)
// start from, by what they do. The jobs, the runner and the pass machinery are private modules
// whose items are named here; the modules still public are vocabularies a front end reads by
// path (the G-code reader's, the generators', the options', the ranges'...). `unreachable_pub`
// keeps an item of a private module from claiming more than `pub(crate)` unless it is named
// here.

// Errors and ranges: every number a front end passes in has a range, every failure is an `Error`.
pub use error::{with_causes, Error, Result};
pub use range::{OutOfRange, Range};

// Reading a file: its container (plain, binary G-code), its lines, their words and the machine
// state they give.
pub use gcode::container::{Container, Input};
pub use gcode::diag::{Finding, Severity};
pub use gcode::line::{Block, Command, Value};
pub use gcode::reader::{LineReader, RawLine};
pub use gcode::state::{Effect, State, StateOptions};

// Running a pass: input to output, atomically (temp + rename), strict or lenient, stoppable.
pub use firmware::{Firmware, MixCommands, MixingCode, UnknownFirmware};
pub use gcode::temp::TempFile;
pub use gcode::writer::{Output, Target};
pub use interrupt::{is_stopped, run_under, Token};
pub use malformed::{Malformed, Transformed, WithMalformed};
pub use pass::{keep, CopyReport, Ctx, Flow, Identity, Pass, PassError, Progress, Quiet, Step, Strictness};
pub use run::{Dest, Ran, Run, Source};

// The jobs: each one's entry point, options and report, and the passes a front end composes.
pub use bed::{Bed, BedError, SlicerBed};
pub use check::{
    check_file, check_file_with, CheckOptions, CheckPass, CheckReport, FindingGroup, LineFinding,
    RefusedWord, WordRanges,
};
pub use gen::raster_job::RasterOptions;
pub use klipper_extruder::KlipperExtruder;
pub use options::{JobFailure, JobOptions, OptionError, OptionSpec};
pub use post::mix::{mix, MixOptions, MixPassError};
pub use post::purge_shift::{purge_shift, PurgeShiftConfig, PurgeShiftOptions, PurgeShiftReport};
pub use render::job::PreviewOptions;
pub use render::{preview, preview_with_progress, PreviewReport, PreviewSettings, Toolpath, ToolpathOptions};
pub use rotary::options::{TubeOptions, WrapOptions};
pub use rotary_job::{tube_file, wrap_file};
pub use stats::{stats_file, Bounds, SlicerFigures, Stats, StatsPass, ToolFilament};
pub use total::{CheckTotal, StatsTotal};
