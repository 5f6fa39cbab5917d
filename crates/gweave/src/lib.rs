//! gweave: a lossless, streaming G-code engine for unconventional 3D printers.
//!
//! Every command is a [`pass::Pass`] over a stream of lines: the [`gcode::lexer`] records what
//! each line says (with spans), the [`gcode::state`] tracks what the machine would do, and lines a
//! pass does not change are written back byte for byte.
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

pub mod bed;
pub mod check;
pub mod colour;
pub mod eol;
pub mod error;
pub mod firmware;
pub mod gcode;
pub mod gen;
pub mod interrupt;
pub mod malformed;
pub mod options;
pub mod pass;
pub mod picture;
// purge-shift and other post-processing passes
pub mod post;
pub mod range;
pub mod render;
pub mod rotary;
pub mod rotary_job;
pub mod run;
pub mod settings;
pub mod stats;
#[cfg(any(test, feature = "test-support"))]
pub mod test_support;
pub mod total;

pub use error::{Error, Result};
// The types most callers start from, as shortcuts; their modules keep the full paths.
pub use gcode::line::Block;
pub use gcode::state::State;
pub use pass::{Pass, Progress, Quiet, Strictness};
pub use range::Range;
