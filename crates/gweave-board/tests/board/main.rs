//! The gweave firmware on the emulated RAMPS board (`make firmware` builds it first): one test
//! binary, so the board's tests share one build and run in parallel.

mod common;
mod extruders;
mod faults;
mod heating;
mod inkjet;
mod mixing;
mod motion;
mod protocol;
mod rotary;
mod step_timing;
