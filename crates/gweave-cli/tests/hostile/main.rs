//! The hostile-input suite: every command run on generated hostile input (long lines, NUL runs,
//! CR-only files, huge numbers and arcs, output paths that name inputs, signals, a full disk)
//! under a time and memory limit. Each case asserts what a user must be able to rely on: no
//! panic, no hang, bounded memory, no input changed, no temporary file left, and the values
//! the command should give. Inputs are generated here, never checked in.
//!
//! One module per finding area; `harness` runs the binary and measures it.

mod bgcode_bombs;
mod bombs;
mod harness;
#[path = "../../../gweave/tests/one_nozzle/mod.rs"]
mod one_nozzle;

mod bytes;
mod canvases;
mod config;
mod containers;
mod counts;
mod hosts;
mod image_bombs;
mod messages;
mod odd_inputs;
mod outputs;
mod sd_links;
mod serve;
mod signals;
mod sizes;
mod spools;
mod sweep;
mod values;
